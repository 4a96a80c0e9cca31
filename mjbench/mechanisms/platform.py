"""Rotary platforms driven through an elastic transmission by a servomotor (seeds 001 and 003).

Both reduce to one linear oscillator in the transmission deflection ψ driven by the motor
acceleration φ̈ (the motor follows its motion law exactly — the papers' ideal-servo hypothesis):

    ψ̈ + 2ξω_n·ψ̇ + ω_n²·ψ = −ρ·φ̈(t)                     (seed 001 Eq 4, seed 003 Eq 6)

* :class:`BeltPlatform` (seed 001, Fig. 1, Table III): motor → gear reducer z → pulley r → two belt
  branches (stiffness k [N/m], damping c [N·s/m] each) → pulley R on the platform (inertia J).
  ρ = λ = z·r/R, k_t = 2kR², c_t = 2cR² (Eqs 2-3), ψ = α = ϑ − λ·φ_m.
* :class:`ElasticPlatform` (seed 003, Fig. 1, Table II): motor → reducer z (α = z·φ) → torsional
  joint (k [N·m/rad], c [N·m·s/rad]) → gearbox 1:1 + platform, J_eq = J1 + J2 + J3 (Eqs 2-4).
  ρ = z, ψ = β − z·φ.

MJCF (``build_spec``): every joint is a hinge about the vertical z axis, gravity off (it does no
work on vertical-axis hinges).  The driven joint (``driven_joint`` of each class, ``driven_ratio`` rad per motor rad) is kinematically driven by
``mjbench.vibration.simulate_multibody`` (the generalised force that makes its acceleration
equal the law's is computed at every integrator stage), so the motor follows the law exactly.

* belt: joint ``motor`` (the motor shaft φ_m; the reducer and pulley r are folded into the belt
  tendons' coefficients), joint ``platform`` (ϑ).  Each branch is a *fixed tendon* of length
  ±(R·ϑ − r·z·φ_m) with stiffness k, damping c and rest length 0 (a linear, always taut belt with
  its pretension omitted: a constant pretension gives no net torque on a pulley).
* elastic: joint ``reducer`` (α = z·φ, driven) carrying the body ``platform`` through the hinge
  ``elastic_joint`` (ψ = β − α) with stiffness k, damping c (the spring of the joint).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .base import new_spec


@dataclass
class Oscillator:
    """ψ̈ + 2ξω_n ψ̇ + ω_n² ψ = −ρ φ̈: J [kg·m²], k [N·m/rad], c [N·m·s/rad] on the platform side,
    ratio ρ = platform rad per motor rad of the rigid transmission."""

    J: float
    k: float
    c: float
    ratio: float

    @property
    def omega_n(self):
        return math.sqrt(self.k / self.J)

    @property
    def xi(self):
        return self.c / (2.0 * self.J * self.omega_n)

    @property
    def omega_d(self):
        return self.omega_n * math.sqrt(1.0 - self.xi ** 2)

    @property
    def s(self):
        """Pole −ξω_n + iω_d [1/s]."""
        return complex(-self.xi * self.omega_n, self.omega_d)

    def scaled(self, omega_factor: float, keep: str = "xi"):
        """The same oscillator with ω_n × ``omega_factor`` (k × f²); ``keep="xi"`` scales c by f so
        ξ is unchanged, ``keep="c"`` keeps c (ξ / f)."""
        f = float(omega_factor)
        return Oscillator(self.J, self.k * f * f, self.c * (f if keep == "xi" else 1.0), self.ratio)

    def describe(self):
        return {"J": self.J, "k": self.k, "c": self.c, "ratio": self.ratio, "omega_n": self.omega_n,
                "xi": self.xi, "omega_d": self.omega_d}


def _check_positive(obj, names, allow_zero=()):
    for name in names:
        v = getattr(obj, name)
        ok = np.isfinite(v) and (v >= 0 if name in allow_zero else v > 0)
        if not ok:
            raise ParameterError(f"platform.{name} = {v!r}: must be finite and "
                                 f"{'>= 0' if name in allow_zero else '> 0'}")


def _spec_common(name, options):
    return new_spec(name, options, gravity=(0.0, 0.0, 0.0), offscreen=(1280, 720))


def _inertial(body, Izz, mass=1.0):
    body.mass = mass
    body.inertia = [0.6 * Izz, 0.6 * Izz, Izz]  # Izz about the hinge; Ixx + Iyy >= Izz
    body.ipos = [0.0, 0.0, 0.0]  # default is unset (NaN) and compiles to the body offset
    body.iquat = [1.0, 0.0, 0.0, 0.0]
    body.explicitinertial = True


@dataclass
class BeltPlatform:
    """Seed 001: platform inertia J [kg·m²], belt branch stiffness k [N/m] and damping c [N·s/m],
    pulley radii r, R [m], reducer ratio z (pulley-1 rad per motor rad; Table III "1:10" = 0.1),
    centre distance d [m] (drawing only), rotor inertia J_motor [kg·m²] on the motor shaft
    (not in the paper; only for the torque estimate and the DC-servo option)."""

    J: float = 6.0
    k: float = 9e4
    c: float = 150.0
    r: float = 0.06
    R: float = 0.18
    z: float = 0.1
    d: float = 0.5
    J_motor: float = 0.0
    variant = "belt"
    driven_joint = "motor"
    driven_ratio = 1.0  # driven-joint rad per motor rad

    def __post_init__(self):
        _check_positive(self, ("J", "k", "r", "R", "z", "d"))
        _check_positive(self, ("c", "J_motor"), allow_zero=("c", "J_motor"))

    @property
    def ratio(self):
        """λ = z·r/R (seed 001 Eq 2)."""
        return self.z * self.r / self.R

    @property
    def k_t(self):
        return 2.0 * self.k * self.R ** 2  # Eq 3

    @property
    def c_t(self):
        return 2.0 * self.c * self.R ** 2

    def oscillator(self) -> Oscillator:
        return Oscillator(self.J, self.k_t, self.c_t, self.ratio)

    # multibody --------------------------------------------------------------------------
    def build_spec(self, options=None):
        import mujoco

        spec = _spec_common("belt_platform", options)
        w = spec.worldbody
        motor = w.add_body(name="motor_pulley", pos=[0, 0, 0])
        _inertial(motor, max(self.J_motor, 1e-4), mass=1.0)
        motor.add_joint(name="motor", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        motor.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[self.r, 0.02, 0], rgba=[0.8, 0.3, 0.2, 1],
                       contype=0, conaffinity=0)
        motor.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.9 * self.r, 0.005, 0.021], rgba=[0.2, 0.2, 0.2, 1],
                       contype=0, conaffinity=0)
        plat = w.add_body(name="platform", pos=[self.d, 0, 0])
        _inertial(plat, self.J, mass=10.0)
        plat.add_joint(name="platform", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        plat.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[self.R, 0.02, 0], rgba=[0.2, 0.5, 0.85, 1],
                      contype=0, conaffinity=0)
        plat.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.9 * self.R, 0.01, 0.021], pos=[0, 0, 0],
                      rgba=[0.9, 0.9, 0.2, 1], contype=0, conaffinity=0)
        for name, sign in (("belt_upper", 1.0), ("belt_lower", -1.0)):
            t = spec.add_tendon(name=name)
            t.wrap_joint("platform", sign * self.R)
            t.wrap_joint("motor", -sign * self.r * self.z)
            t.stiffness = [float(self.k), 0.0, 0.0]
            t.damping = [float(self.c), 0.0, 0.0]
            t.springlength = [0.0, 0.0]
            t.rgba = [0.1, 0.1, 0.1, 1]
        return spec

    def platform_state(self, model, qpos, qvel, qacc=None):
        """(ϑ, ϑ̇, ϑ̈) of the platform [rad, rad/s, rad/s²] from a multibody state."""
        a = int(model.joint("platform").qposadr[0])
        v = int(model.joint("platform").dofadr[0])
        return qpos[..., a], qvel[..., v], (None if qacc is None else qacc[..., v])

    def describe(self):
        return {"type": "platform", "variant": "belt", "J": self.J, "k": self.k, "c": self.c, "r": self.r,
                "R": self.R, "z": self.z, "d": self.d, "J_motor": self.J_motor, **_osc_summary(self)}


@dataclass
class ElasticPlatform:
    """Seed 003: inertias J1, J2, J3 [kg·m²] (all rotate with the platform, Eq 2), joint stiffness
    k [N·m/rad] and damping c [N·m·s/rad], reducer ratio z = α/φ (Table II: 1/20), rotor inertia
    J_motor [kg·m²] (not in the paper)."""

    J1: float = 5e-3
    J2: float = 5e-3
    J3: float = 2.8
    k: float = 8000.0
    c: float = 35.0
    z: float = 1.0 / 20.0
    J_motor: float = 0.0
    variant = "elastic"
    driven_joint = "reducer"
    driven_ratio = None  # = z, set in __post_init__

    def __post_init__(self):
        _check_positive(self, ("J1", "J2", "J3", "k", "z"))
        _check_positive(self, ("c", "J_motor"), allow_zero=("c", "J_motor"))
        self.driven_ratio = self.z

    @property
    def J_eq(self):
        return self.J1 + self.J2 + self.J3  # Eq 4

    @property
    def ratio(self):
        return self.z

    def oscillator(self) -> Oscillator:
        return Oscillator(self.J_eq, self.k, self.c, self.z)

    def build_spec(self, options=None):
        import mujoco

        spec = _spec_common("elastic_platform", options)
        w = spec.worldbody
        red = w.add_body(name="reducer_out", pos=[0, 0, 0])
        _inertial(red, 1e-3, mass=1.0)
        red.add_joint(name="reducer", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        red.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.02, 0.05, 0], pos=[0, 0, -0.15],
                     rgba=[0.8, 0.3, 0.2, 1], contype=0, conaffinity=0)
        plat = red.add_body(name="platform", pos=[0, 0, 0])
        _inertial(plat, self.J_eq, mass=10.0)
        j = plat.add_joint(name="elastic_joint", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        j.stiffness = [float(self.k), 0.0, 0.0]
        j.damping = [float(self.c), 0.0, 0.0]
        j.springref = 0.0
        plat.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.4, 0.02, 0], rgba=[0.2, 0.5, 0.85, 1],
                      contype=0, conaffinity=0)
        plat.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.38, 0.02, 0.021], rgba=[0.9, 0.9, 0.2, 1],
                      contype=0, conaffinity=0)
        return spec

    def platform_state(self, model, qpos, qvel, qacc=None):
        """(β, β̇, β̈) = reducer + elastic joint."""
        ra, ea = int(model.joint("reducer").qposadr[0]), int(model.joint("elastic_joint").qposadr[0])
        rv, ev = int(model.joint("reducer").dofadr[0]), int(model.joint("elastic_joint").dofadr[0])
        acc = None if qacc is None else qacc[..., rv] + qacc[..., ev]
        return qpos[..., ra] + qpos[..., ea], qvel[..., rv] + qvel[..., ev], acc

    def describe(self):
        return {"type": "platform", "variant": "elastic", "J1": self.J1, "J2": self.J2, "J3": self.J3,
                "k": self.k, "c": self.c, "z": self.z, "J_motor": self.J_motor, **_osc_summary(self)}


def _osc_summary(p):
    o = p.oscillator()
    return {"omega_n": o.omega_n, "xi": o.xi, "ratio": o.ratio}


def from_params(p: dict):
    """Scenario ``[mechanism]`` table (type = "platform") → BeltPlatform | ElasticPlatform.
    Key ``variant`` = "belt" (seed 001: J, k, c, r, R, z, d, J_motor) or "elastic" (seed 003:
    J1, J2, J3, k, c, z, J_motor)."""
    p = {k: v for k, v in p.items() if not k.startswith("_")}
    variant = p.pop("variant", "belt")
    cls = {"belt": BeltPlatform, "elastic": ElasticPlatform}.get(variant)
    if cls is None:
        raise ParameterError(f"mechanism.variant = {variant!r}: choose 'belt' (seed 001) or 'elastic' (seed 003)")
    try:
        return cls(**{k: float(v) for k, v in p.items()})
    except TypeError as e:
        raise ParameterError(f"[mechanism] ({variant} platform): {e}") from None


def export_default_mjcf(folder="assets/mjcf"):
    """Write the default models to ``folder``/belt_platform.xml and elastic_platform.xml."""
    import os

    from ..trajectory import atomic_write

    out = []
    for obj, fname in ((BeltPlatform(), "belt_platform.xml"), (ElasticPlatform(), "elastic_platform.xml")):
        spec = obj.build_spec()
        spec.compile()
        xml = _xml_with_inertials(spec)
        path = os.path.join(folder, fname)
        atomic_write(path, lambda f, x=xml: f.write(x))
        out.append(path)
    return out


def _xml_with_inertials(spec) -> str:
    """``spec.to_xml()`` with any explicit ``<inertial>`` element it left out restored (MuJoCo
    4.0.0's ``to_xml`` drops one whose ``ipos`` is unset; the XML would then not compile)."""
    import re

    xml = spec.to_xml()
    for b in spec.bodies[1:]:
        if not b.explicitinertial or re.search(rf'<body name="{re.escape(b.name)}"[^>]*>\s*<inertial', xml):
            continue
        tag = (f'<inertial pos="0 0 0" mass="{b.mass:.17g}" '
               f'diaginertia="{b.inertia[0]:.17g} {b.inertia[1]:.17g} {b.inertia[2]:.17g}"/>')
        xml = re.sub(rf'(\n(\s*)<body name="{re.escape(b.name)}"[^>]*>)', lambda m: f"{m.group(1)}\n{m.group(2)}  {tag}",
                     xml, count=1)
    return xml
