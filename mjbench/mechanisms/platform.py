"""Rotary platforms driven through an elastic transmission by a servomotor (seeds 001 and 003).

Both are machines with one driven coordinate, the motor angle φ (input coordinate q), and one
internal coordinate, the transmission deflection ψ (platform side, rad).  With the drive torque
τ on the motor shaft (the drive's inertia J_d and viscous c_d are added on q by the backends):

    (J_d + J_in)·φ̈ = τ − c_d·φ̇ + ρ·(k·ψ + c·ψ̇)          motor side
    ψ̈ + 2ξω_n·ψ̇ + ω_n²·ψ = −ρ·φ̈                         (seed 001 Eq 4, seed 003 Eq 6)

J [kg·m²], k [N·m/rad], c [N·m·s/rad] on the platform side (ω_n² = k/J, 2ξω_n = c/J), ρ =
platform rad per motor rad of the rigid transmission, J_in the mechanism's own inertia on the
motor shaft (``J_motor``: pulley/reducer input; the rotor is the drive's J_m).  When the motor
follows its motion law exactly (the papers' ideal-servo hypothesis) only the second equation
remains (:class:`Oscillator`, :mod:`mjbench.vibration`).

* :class:`BeltPlatform` (seed 001, Fig. 1, Table III): motor → gear reducer z → pulley r → two belt
  branches (stiffness k [N/m], damping c [N·s/m] each) → pulley R on the platform (inertia J).
  ρ = λ = z·r/R, k_t = 2kR², c_t = 2cR² (Eqs 2-3), ψ = α = ϑ − λ·φ.
* :class:`ElasticPlatform` (seed 003, Fig. 1, Table II): motor → reducer z (α = z·φ) → torsional
  joint (k [N·m/rad], c [N·m·s/rad]) → gearbox 1:1 + platform, J_eq = J1 + J2 + J3 (Eqs 2-4).
  ρ = z, ψ = β − z·φ.

MJCF (``build_spec``): two hinges about the vertical z axis, gravity off (it does no work on
vertical-axis hinges): ``motor`` (the input joint φ, carrying the drive's reflected inertia as
armature) and ``platform`` (ϑ).  The elastic transmission is made of *fixed tendons* of length
linear in the joint angles, with MuJoCo's tendon stiffness/damping (passive forces, integrated by
MuJoCo inside every step):

* belt: two branches, length ±(R·ϑ − r·z·φ) = ±R·ψ, stiffness k, damping c, rest length 0 (a
  linear, always taut belt; a constant pretension gives no net torque on a pulley);
* elastic joint: one tendon ``elastic_joint`` of length ϑ − z·φ = ψ, stiffness k, damping c.
"""
from __future__ import annotations

import math
import os
from collections import namedtuple
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field

from .. import compiled as C
from ..compiled import law
from ..errors import ParameterError
from ..fields import Q, Strict
from . import register
from .base import Mechanism, new_spec
from ..trajectory import atomic_write
from .mjcf_export import standalone_xml
from .base import RenderView

J_MIN = 1e-9  #: [kg·m²] smallest body inertia given to MuJoCo for the motor-side body


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

    def energy(self, psi, psid, motor_speed=0.0):
        """E = ½J[(ψ̇ + ρφ̇)² + ω_n²ψ²] [J] (seed 001 Eq 25)."""
        return 0.5 * self.J * ((psid + self.ratio * motor_speed) ** 2 + self.omega_n ** 2 * psi ** 2)

    def envelope(self, psi, psid) -> float:
        """Envelope [rad, platform] at T of the free vibration ψ(t) = e^{−ξω_n t'}(A cos ω_d t' + B sin ω_d t')
        that starts from (ψ, ψ̇) when the motor stops: √(ψ² + ((ψ̇ + ξω_nψ)/ω_d)²).  An envelope, not a
        peak actually reached: the damped motion stays below it."""
        return float(math.hypot(psi, (psid + self.xi * self.omega_n * psi) / self.omega_d))

    def residual_metrics(self, tr, T, t_after) -> dict:
        """Residual-vibration figures of a machine run (columns deflection_rad, deflection_rate_rad_s):
        E(T) = ½J[(ψ̇ + ρφ̇)² + ω_n²ψ²] at the end of the move (Incerti belt Eq 25, with the actual
        motor speed), the free-vibration envelope at T (``residual_envelope_at_T_rad``), the actual peak
        |ψ| over [T, T + t_after] (``residual_peak_after_T_rad``, window in ``residual_peak_window_s``;
        cut at the end of the run), the energy at the end of the run."""
        import numpy as np

        t = tr.t
        iT = int(np.argmin(np.abs(t - T)))
        psi, psid, om = tr["deflection_rad"], tr["deflection_rate_rad_s"], tr.qd
        after = (t >= T - 1e-12) & (t <= T + t_after + 1e-12)
        return {"E_T_J": float(self.energy(psi[iT], psid[iT], om[iT])),
                "E_end_J": float(self.energy(psi[-1], psid[-1], om[-1])),
                "residual_envelope_at_T_rad": self.envelope(float(psi[iT]), float(psid[iT])),
                "residual_peak_after_T_rad": float(np.max(np.abs(psi[after]))),
                "residual_peak_window_s": float(min(t_after, t[-1] - T)),
                "peak_current_A": float(np.max(np.abs(tr.current))),
                "peak_voltage_V": float(np.max(np.abs(tr.voltage)))}

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


def _inertial(body, Izz, mass=1.0):
    body.mass = mass
    body.inertia = [0.6 * Izz, 0.6 * Izz, Izz]  # Izz about the hinge; Ixx + Iyy >= Izz
    body.ipos = [0.0, 0.0, 0.0]  # default is unset (NaN) and compiles to the body offset
    body.iquat = [1.0, 0.0, 0.0, 0.0]
    body.explicitinertial = True


# ============================================================================ parameters
class BeltParams(Strict):
    """``[mechanism] type = "platform"``, ``variant = "belt"`` (seed 001, Table III)."""

    type: Literal["platform"] = "platform"
    variant: Literal["belt"] = "belt"
    J: Q("inertia", gt=0.0, what="a platform inertia") = Field(description="platform inertia")
    k: Q("lin_stiffness", gt=0.0) = Field(description="stiffness of each belt branch")
    c: Q("lin_damping", ge=0.0) = Field(description="damping of each belt branch")
    r: Q("length", gt=0.0, what="a pulley radius") = Field(description="radius of pulley 1 (motor side)")
    R: Q("length", gt=0.0, what="a pulley radius") = Field(description="radius of pulley 2 (platform)")
    z: float = Field(gt=0.0, description="reducer: pulley-1 rad per motor rad (Table III '1:10' = 0.1)")
    d: Q("length", gt=0.0) = Field(0.5, description="centre distance O1-O2 (drawing only)")
    J_motor: Q("inertia", ge=0.0) = Field(0.0, description="transmission inertia on the motor shaft besides the rotor (drive J_m)")


class ElasticParams(Strict):
    """``[mechanism] type = "platform"``, ``variant = "elastic"`` (seed 003, Table II)."""

    type: Literal["platform"] = "platform"
    variant: Literal["elastic"]
    J1: Q("inertia", ge=0.0) = Field(description="Eq 2: inertias rotating with the platform")
    J2: Q("inertia", ge=0.0)
    J3: Q("inertia", gt=0.0, what="a platform inertia")
    k: Q("rot_stiffness", gt=0.0) = Field(description="joint torsional stiffness")
    c: Q("rot_damping", ge=0.0) = Field(description="joint damping")
    z: float = Field(gt=0.0, description="reducer α/φ (Table II: 1/20)")
    J_motor: Q("inertia", ge=0.0) = Field(0.0, description="transmission inertia on the motor shaft besides the rotor (drive J_m)")


# ============================================================================ mechanisms
class Platform(Mechanism):
    """Common part of the two platforms (input: motor angle φ; internal: deflection ψ)."""

    type_name = "platform"
    Params = BeltParams
    input_joint = "motor"
    internal = ("deflection",)
    view = "top"
    variant = ""

    @classmethod
    def params_for(cls, raw):
        v = raw.get("variant", "belt") if isinstance(raw, dict) else "belt"
        return ElasticParams if v == "elastic" else BeltParams

    @classmethod
    def from_params(cls, p):
        if isinstance(p, ElasticParams):
            return ElasticPlatform(J1=p.J1, J2=p.J2, J3=p.J3, k=p.k, c=p.c, z=p.z, J_motor=p.J_motor)
        return BeltPlatform(J=p.J, k=p.k, c=p.c, r=p.r, R=p.R, z=p.z, d=p.d, J_motor=p.J_motor)

    # --- subclasses: oscillator(), geometry for the MJCF ----------------------------------
    def oscillator(self) -> Oscillator:  # pragma: no cover - overridden
        raise NotImplementedError

    @property
    def ratio(self):
        return self.oscillator().ratio

    @property
    def J_input(self):
        """Mechanism inertia on the motor shaft [kg·m²] as the MJCF body carries it."""
        return max(float(self.J_motor), J_MIN)

    # --- reduced model -------------------------------------------------------------------
    def reduced(self, q):
        """Rigid transmission: J = J_in + ρ²J (constant), no potential energy."""
        o = self.oscillator()
        J = self.J_input + o.ratio ** 2 * o.J
        return J + 0.0 * q, 0.0 * q, 0.0 * q

    def potential_energy(self, q):
        return 0.0 * q

    def accel_params(self) -> "PlatformP":
        """The parameters of :func:`platform_xdd`."""
        o = self.oscillator()
        return PlatformP(float(self.J_input), float(o.k), float(o.c), float(o.J), float(o.ratio))

    def accel_form(self):
        """The motor and deflection accelerations as a law (:func:`platform_accel`)."""
        return C.Form(platform_accel, self.accel_params())

    def reduced_accel(self, t, q, qd, x, xd, tau, J_add, c_add):
        qdd, psidd = platform_xdd(float(qd), float(x[0]), float(xd[0]), float(tau), float(J_add), float(c_add),
                                  self.accel_params())
        return qdd, (psidd,)

    def internal_index(self, model):
        """ψ = ϑ − ρ·φ: one row (qpos platform, qpos motor, dof platform, dof motor, ρ)."""
        jp, jm = model.joint("platform"), model.joint(self.input_joint)
        return np.array([[int(jp.qposadr[0]), int(jm.qposadr[0]), int(jp.dofadr[0]), int(jm.dofadr[0]),
                          float(self.ratio)]])

    def render_view(self):
        """Top view: the platform hinge turns ρ·φ + ψ, the deflection column needle (render.py)."""

        return RenderView("top", output_joint="platform", output_body="platform", ratio=float(self.ratio),
                          deflection="deflection", label=f"{self.variant} platform")

    def energy(self, qd, psi, psid, J_add=0.0):
        """Total mechanical energy [J]: motor side + platform + spring (passive checks)."""
        o = self.oscillator()
        thd = psid + o.ratio * qd
        return 0.5 * (J_add + self.J_input) * qd * qd + 0.5 * o.J * thd * thd + 0.5 * o.k * psi * psi

    # --- multibody -----------------------------------------------------------------------
    def _spec_base(self, armature, options, name):
        import mujoco

        spec = new_spec(name, options, gravity=(0.0, 0.0, 0.0), offscreen=(1280, 720))
        w = spec.worldbody
        motor = w.add_body(name="motor_pulley", pos=[0, 0, 0])
        _inertial(motor, self.J_input, mass=1.0)
        j = motor.add_joint(name="motor", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        j.armature = float(armature)
        return spec, w, motor

    def initial_qpos(self, model, q0, x0=None):
        qpos = np.array(model.qpos0, dtype=float)
        psi = 0.0 if not x0 else float(x0[0])
        qpos[model.joint("motor").qposadr[0]] = q0
        qpos[model.joint("platform").qposadr[0]] = self.ratio * q0 + psi
        return qpos

    def initial_qvel(self, model, q0, qd0, x0=None, xd0=None):
        qvel = np.zeros(model.nv)
        psid = 0.0 if not xd0 else float(xd0[0])
        qvel[model.joint("motor").dofadr[0]] = qd0
        qvel[model.joint("platform").dofadr[0]] = self.ratio * qd0 + psid
        return qvel

    def internal_state(self, model, qpos, qvel):
        th, thd, _ = self.platform_state(model, qpos, qvel)
        a, v = int(model.joint("motor").qposadr[0]), int(model.joint("motor").dofadr[0])
        rho = self.ratio
        return (th - rho * qpos[..., a],), (thd - rho * qvel[..., v],)

    def platform_state(self, model, qpos, qvel, qacc=None):
        """(ϑ, ϑ̇, ϑ̈) of the platform [rad, rad/s, rad/s²] from a multibody state."""
        a = int(model.joint("platform").qposadr[0])
        v = int(model.joint("platform").dofadr[0])
        return qpos[..., a], qvel[..., v], (None if qacc is None else qacc[..., v])

    def points(self, q):
        """Top view: motor axis O1 at the origin, platform axis O2 (drawing only)."""
        z = 0.0 * q
        return {"O1": (z, z), "O2": (z + self._centre(), z)}

    def _centre(self):
        return 0.0


@dataclass
class BeltPlatform(Platform):
    """Seed 001: platform inertia J [kg·m²], belt branch stiffness k [N/m] and damping c [N·s/m],
    pulley radii r, R [m], reducer ratio z (pulley-1 rad per motor rad; Table III "1:10" = 0.1),
    centre distance d [m] (drawing only), transmission inertia J_motor [kg·m²] on the motor shaft."""

    J: float = 6.0
    k: float = 9e4
    c: float = 150.0
    r: float = 0.06
    R: float = 0.18
    z: float = 0.1
    d: float = 0.5
    J_motor: float = 0.0
    variant = "belt"

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

    def _centre(self):
        return self.d

    def build_spec(self, armature: float = 0.0, options=None):
        import mujoco

        spec, w, motor = self._spec_base(armature, options, "belt_platform")
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

    def describe(self):
        o = self.oscillator()
        return {"type": "platform", "variant": "belt", "J": self.J, "k": self.k, "c": self.c, "r": self.r,
                "R": self.R, "z": self.z, "d": self.d, "J_motor": self.J_motor,
                "omega_n": o.omega_n, "xi": o.xi, "ratio": o.ratio}


@dataclass
class ElasticPlatform(Platform):
    """Seed 003: inertias J1, J2, J3 [kg·m²] (all rotate with the platform, Eq 2), joint stiffness
    k [N·m/rad] and damping c [N·m·s/rad], reducer ratio z = α/φ (Table II: 1/20), transmission
    inertia J_motor [kg·m²] on the motor shaft."""

    J1: float = 5e-3
    J2: float = 5e-3
    J3: float = 2.8
    k: float = 8000.0
    c: float = 35.0
    z: float = 1.0 / 20.0
    J_motor: float = 0.0
    variant = "elastic"

    def __post_init__(self):
        _check_positive(self, ("J3", "k", "z"))
        _check_positive(self, ("J1", "J2", "c", "J_motor"), allow_zero=("J1", "J2", "c", "J_motor"))

    @property
    def J_eq(self):
        return self.J1 + self.J2 + self.J3  # Eq 4

    @property
    def ratio(self):
        return self.z

    def oscillator(self) -> Oscillator:
        return Oscillator(self.J_eq, self.k, self.c, self.z)

    def build_spec(self, armature: float = 0.0, options=None):
        import mujoco

        spec, w, motor = self._spec_base(armature, options, "elastic_platform")
        motor.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.02, 0.05, 0], pos=[0, 0, -0.15],
                       rgba=[0.8, 0.3, 0.2, 1], contype=0, conaffinity=0)
        plat = w.add_body(name="platform", pos=[0, 0, 0])
        _inertial(plat, self.J_eq, mass=10.0)
        plat.add_joint(name="platform", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        plat.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.4, 0.02, 0], rgba=[0.2, 0.5, 0.85, 1],
                      contype=0, conaffinity=0)
        plat.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.38, 0.02, 0.021], rgba=[0.9, 0.9, 0.2, 1],
                      contype=0, conaffinity=0)
        t = spec.add_tendon(name="elastic_joint")  # length ψ = ϑ − z·φ
        t.wrap_joint("platform", 1.0)
        t.wrap_joint("motor", -float(self.z))
        t.stiffness = [float(self.k), 0.0, 0.0]
        t.damping = [float(self.c), 0.0, 0.0]
        t.springlength = [0.0, 0.0]
        return spec

    def describe(self):
        o = self.oscillator()
        return {"type": "platform", "variant": "elastic", "J1": self.J1, "J2": self.J2, "J3": self.J3,
                "k": self.k, "c": self.c, "z": self.z, "J_motor": self.J_motor,
                "omega_n": o.omega_n, "xi": o.xi, "ratio": o.ratio}


register(Platform)


# ============================================================================ laws
#: the platform's acceleration parameters: motor-side inertia J_in, transmission stiffness k and
#: damping c (platform side), platform inertia J, ratio ρ
PlatformP = namedtuple("PlatformP", "J_in k c J ratio")


@law
def platform_xdd(qd, psi, psid, tau, Ja, c_add, P):
    """(φ̈, ψ̈) of the platform (module docstring): transmission torque T = k·ψ + c·ψ̇ (platform
    side), (J_a + J_in)·φ̈ = τ − c_a·φ̇ + ρ·T, ψ̈ = −T/J − ρ·φ̈."""
    tr = P.k * psi + P.c * psid
    qdd = (tau - c_add * qd + P.ratio * tr) / (Ja + P.J_in)
    return qdd, -tr / P.J - P.ratio * qdd


@law
def platform_accel(t, S, iy, ia, tau, Ja, c_add, P):
    """:func:`platform_xdd` as an acceleration law (state (φ, φ̇, ψ, ψ̇) at S[iy:], (φ̈, ψ̈) to S[ia:])."""
    qdd, psidd = platform_xdd(S[iy + 1], S[iy + 2], S[iy + 3], tau, Ja, c_add, P)
    S[ia] = qdd
    S[ia + 1] = psidd
    return qdd


def export_default_mjcf(folder="assets/mjcf"):
    """Write the default models to ``folder``/belt_platform.xml and elastic_platform.xml (stand-alone:
    mjbench/mjcf_export.py)."""
    out = []
    for obj, fname in ((BeltPlatform(), "belt_platform.xml"), (ElasticPlatform(), "elastic_platform.xml")):
        spec = obj.build_spec()
        model = spec.compile()  # at rest, undeflected: qpos0 and the keyframe ``initial``
        xml = standalone_xml(spec, model, obj.initial_qpos(model, 0.0), obj.initial_qvel(model, 0.0, 0.0),
                             obj.input_joint)
        path = os.path.join(folder, fname)
        atomic_write(path, lambda f, x=xml: f.write(x))
        out.append(path)
    return out
