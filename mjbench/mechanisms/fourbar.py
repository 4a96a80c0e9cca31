"""Four-bar linkage in the seed-000 notation (Incerti 2012, Fig. 1 and Appendices A-C).

Frame: origin at the crank pivot A, x horizontal, y vertical (up); gravity −y.  Links:
crank a (link 1, angle α), coupler b (link 2, angle β), rocker c (link 3, angle γ, pivot D at
(h_x, h_y)).  Mass centre of link i at polar offset (f_i, ϑ_i) from its proximal joint, measured
from the link line (A for link 1, B for link 2, D for link 3); m_i, J_Gi about G_i.
Assembly mode k = ±1 (Appendix A).

In MuJoCo the plane (x, y) maps to (x, z) with hinges about −y, so that a hinge angle is the
paper's angle measured counter-clockwise and MuJoCo's default gravity is the paper's −y.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass, field

import numpy as np

from typing import Literal

from pydantic import Field, field_validator

from .. import compiled as C
from ..compiled import array_twin, law
from ..errors import GeometryError, ParameterError
from ..fields import Q, Strict
from . import register
from .base import HINGE_AXIS, INPUT_JOINT, Mechanism, closure_solref, new_spec
from .linkage_kin import _angle_ranges
from .linkage_kin import ArcP, PeriodicTable, arc_length_law
from .linkage import Linkage, LinkageParams, table_from_fourbar

G = 9.81  #: gravitational acceleration [m/s²] (seed 000 Eq 3)
AXIS = HINGE_AXIS  #: hinge axis in MuJoCo (the plane convention of mechanisms/base.py)



def _xp(x):
    """math for Python floats (fast scalar path), numpy otherwise: one code path for both."""
    return math if isinstance(x, float) else np


@dataclass
class CouplerPoint:
    """A point P of the coupler at polar offset (f, theta) from B, theta from the line BC."""

    f: float = 0.0
    theta: float = 0.0


@dataclass
class FourBar(Mechanism):
    """Planar four-bar (seed 000).  Lengths [m], angles [rad], masses [kg], inertias [kg·m²]."""

    a: float
    b: float
    c: float
    h_x: float
    h_y: float = 0.0
    f: tuple = (0.0, 0.0, 0.0)
    theta: tuple = (0.0, 0.0, 0.0)
    m: tuple = (0.0, 0.0, 0.0)
    J_G: tuple = (0.0, 0.0, 0.0)
    k: int = 1
    g: float = G
    coupler_point: CouplerPoint = field(default_factory=CouplerPoint)
    #: extra point masses at joints [kg]: {"A":..,"B":..,"C":..,"D":..} (bearings, seed 002)
    joint_masses: dict = field(default_factory=dict)
    #: viscous friction in the passive hinges B and D [N·m·s/rad] (seed 002 bearings)
    joint_damping: float = 0.0
    #: viscous friction in the crank pivot A (crank vs ground) [N·m·s/rad], on top of the drive's λ
    damping_A: float = 0.0
    #: viscous friction in the loop-closing hinge C (coupler vs rocker) [N·m·s/rad]
    damping_C: float = 0.0
    name: str = "fourbar"
    type_name = "fourbar"

    @classmethod
    def params_for(cls, raw):
        """Params model of a raw ``[mechanism]`` table: the seed-002 notation if it says so."""
        seed002 = isinstance(raw, dict) and (raw.get("notation") == "seed002" or ("r1" in raw and "a" not in raw))
        return FourBarSeed002Params if seed002 else FourBarParams

    @classmethod
    def from_params(cls, p):
        return seed002_to_fourbar(p) if isinstance(p, FourBarSeed002Params) else _fourbar_from_seed000(p)

    def __post_init__(self):
        self.f = tuple(float(v) for v in self.f)
        self.theta = tuple(float(v) for v in self.theta)
        self.m = tuple(float(v) for v in self.m)
        self.J_G = tuple(float(v) for v in self.J_G)
        if isinstance(self.coupler_point, dict):
            self.coupler_point = CouplerPoint(**self.coupler_point)
        self.check()

    # ================================================================ validation
    def check(self, n: int = 7200):
        """Raise ParameterError / GeometryError if the linkage is non-physical, cannot be
        assembled, or its crank cannot make the full turn (A²+B²−C² < 0 for some α)."""
        for name in ("a", "b", "c"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ParameterError(f"fourbar.{name} = {v!r}: link length must be a finite number > 0 [m]")
        for name in ("h_x", "h_y", "g"):
            v = getattr(self, name)
            if not np.isfinite(v):
                raise ParameterError(f"fourbar.{name} = {v!r}: must be finite")
        if self.k not in (1, -1):
            raise ParameterError(f"fourbar.k = {self.k!r}: assembly mode must be +1 or -1")
        for name in ("f", "theta", "m", "J_G"):
            v = getattr(self, name)
            if len(v) != 3 or not all(np.isfinite(v)):
                raise ParameterError(f"fourbar.{name} = {v!r}: need 3 finite values (links 1..3)")
        for i in range(3):
            if self.m[i] < 0:
                raise ParameterError(f"fourbar.m{i+1} = {self.m[i]!r}: mass must be >= 0 [kg]")
            if self.J_G[i] < 0:
                raise ParameterError(f"fourbar.J_G{i+1} = {self.J_G[i]!r}: inertia must be >= 0 [kg m^2]")
            if self.f[i] < 0:
                raise ParameterError(f"fourbar.f{i+1} = {self.f[i]!r}: mass-centre distance must be >= 0 [m]")
        for name in ("joint_damping", "damping_A", "damping_C"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ParameterError(f"fourbar.{name} = {v!r}: viscous friction must be finite and >= 0 [N·m·s/rad]")
        for j, v in self.joint_masses.items():
            if j not in ("A", "B", "C", "D") or not (np.isfinite(v) and v >= 0):
                raise ParameterError(f"fourbar.joint_mass_{j} = {v!r}: joint must be A..D and mass finite >= 0 [kg]")
        geo = (float(self.a), float(self.b), float(self.c), float(self.h_x), float(self.h_y), int(n))
        if geo in _TURNS_FULL:  # this geometry's crank was found to make the full turn (in this process)
            return
        alpha = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        _, _, _, D2 = self._abcd2(alpha)
        scale = (2 * self.c * (self.a + math.hypot(self.h_x, self.h_y))) ** 2
        bad = D2 <= 1e-10 * scale
        if not bad.any():
            if len(_TURNS_FULL) > 4096:
                _TURNS_FULL.clear()
            _TURNS_FULL.add(geo)
            return
        if bad.all():
            raise GeometryError(
                f"four-bar cannot be assembled at any crank angle: a={self.a}, b={self.b}, c={self.c}, "
                f"h_x={self.h_x}, h_y={self.h_y} (A²+B²−C² < 0 everywhere; check the loop "
                f"|a − d| ≤ b + c with d = |AD| = {math.hypot(self.h_x, self.h_y):.6g} m)")
        if bad.any():
            ranges = _angle_ranges(alpha, bad)
            txt = ", ".join(f"{math.degrees(lo):.1f}°..{math.degrees(hi):.1f}°" for lo, hi in ranges)
            raise GeometryError(
                f"four-bar crank cannot make the full turn: a={self.a}, b={self.b}, c={self.c}, "
                f"h_x={self.h_x}, h_y={self.h_y}; A²+B²−C² ≤ 0 (no assembly, or a dead point) for α in {txt}. "
                f"A crank-rocker needs the crank to be the shortest link (Grashof).")

    # ================================================================ position analysis (App. A)
    # one formula: the laws fourbar_abcd2 / fourbar_solve / fourbar_velocity, evaluated
    # elementwise (array_twin) for arrays and as they are for floats
    def _geometry(self) -> "FourBarKinP":
        """The link lengths, frame and assembly mode as the kinematic laws' parameters."""
        return FourBarKinP(float(self.a), float(self.b), float(self.c), float(self.h_x), float(self.h_y),
                           float(self.k), 0.0, 0.0)

    def _abcd2(self, alpha):
        P = self._geometry()
        return (_ABCD2 if _is_array(alpha) else fourbar_abcd2)(alpha, P)

    def angles(self, alpha):
        """(β, γ) [rad] of coupler and rocker for crank angle α (Appendix A: laws
        :func:`fourbar_abcd2`, :func:`fourbar_solve`)."""
        P = self.kinematic_params()
        if not _is_array(alpha):
            beta, gamma = fourbar_angles(alpha, P)
            if math.isnan(beta) and math.isfinite(alpha):
                D2 = fourbar_abcd2(alpha, P)[3]
                raise GeometryError(f"four-bar cannot be assembled at α = {alpha:.6g} rad (A²+B²−C² = {D2:.3g} < 0)")
            return beta, gamma
        alpha = np.asarray(alpha, dtype=float)
        A, B, Cc, D2 = _ABCD2(alpha, P)
        if np.any(D2 < 0):
            raise GeometryError("four-bar cannot be assembled at some of the requested crank angles")
        return _SOLVE(alpha, A, B, Cc, np.sqrt(D2), P)

    # ================================================================ velocity analysis (App. B)
    def ratios(self, alpha):
        """(β, γ, Q, R): link angles and velocity ratios Q = β̇/α̇, R = γ̇/α̇ (Appendix B)."""
        return self.ratio_derivatives(alpha)[:4]

    def ratio_derivatives(self, alpha):
        """(β, γ, Q, R, dQ/dα, dR/dα), analytic (law :func:`fourbar_velocity`)."""
        beta, gamma = self.angles(alpha)
        P = self._geometry()
        return (beta, gamma, *(_VELOCITY if _is_array(alpha) else fourbar_velocity)(alpha, beta, gamma, P))

    def transmission_angle(self, alpha):
        """Transmission angle μ = |γ − β| folded to [0, π/2] [rad]."""
        beta, gamma = self.angles(alpha)
        mu = np.abs(np.mod(np.asarray(gamma - beta) + np.pi, 2 * np.pi) - np.pi)
        return np.minimum(mu, np.pi - mu)

    # ================================================================ points
    def joints(self, alpha):
        """Joint positions A, B, C, D as (x, y) [m]."""
        xp = _xp(alpha)
        beta, gamma = self.angles(alpha)
        Bx, By = self.a * xp.cos(alpha), self.a * xp.sin(alpha)
        Cx, Cy = self.h_x + self.c * xp.cos(gamma), self.h_y + self.c * xp.sin(gamma)
        zero = 0.0 * alpha
        return {"A": (zero, zero), "B": (Bx, By), "C": (Cx, Cy), "D": (zero + self.h_x, zero + self.h_y)}

    def points(self, q):
        p = self.joints(q)
        p["P"] = self.coupler_point_position(q)
        return p

    def trace_point(self, q):
        return self.coupler_point_position(q)

    def coupler_point_position(self, alpha, point: CouplerPoint | None = None):
        """(x_P, y_P) [m] of a coupler point at polar (f, ϑ) from B (default: ``coupler_point``)."""
        pt = point or self.coupler_point
        xp = _xp(alpha)
        beta, _ = self.angles(alpha)
        return (self.a * xp.cos(alpha) + pt.f * xp.cos(beta + pt.theta),
                self.a * xp.sin(alpha) + pt.f * xp.sin(beta + pt.theta))

    def coupler_point_velocity(self, alpha, alpha_dot, point: CouplerPoint | None = None):
        """(ẋ_P, ẏ_P) [m/s] of a coupler point (Appendix B, G₂ → P)."""
        pt = point or self.coupler_point
        xp = _xp(alpha)
        beta, _, Q, _ = self.ratios(alpha)
        bd = Q * alpha_dot
        return (-self.a * alpha_dot * xp.sin(alpha) - pt.f * bd * xp.sin(beta + pt.theta),
                self.a * alpha_dot * xp.cos(alpha) + pt.f * bd * xp.cos(beta + pt.theta))

    # ================================================================ coupler curve (seed 002 §2)
    def kinematic_params(self, point: CouplerPoint | None = None) -> "FourBarKinP":
        """The geometry and one coupler point (default ``coupler_point``) as the parameters of the
        kinematic laws (:func:`coupler_speed_ratio_law`, :func:`fourbar_angles`)."""
        pt = point or self.coupler_point
        return FourBarKinP(float(self.a), float(self.b), float(self.c), float(self.h_x), float(self.h_y),
                           float(self.k), float(pt.f), float(pt.theta))

    def coupler_speed_ratio(self, alpha, point: CouplerPoint | None = None):
        """|dP/dα| [m/rad]: coupler-point speed per unit crank speed, the square root of the
        denominator of seed 002 Eq 17, √(r₂² + r_C²g₁² + 2·r₂·r_C·g₁·cos(q − φ₁ − β_C)) — the law
        :func:`coupler_speed_ratio_law` (the coupler-speed reference's), elementwise."""
        P = self.kinematic_params(point)
        return _assembled(_each(lambda a: coupler_speed_ratio_law(a, P), alpha, 2)[0], alpha)

    def coupler_speed_ratio_derivative(self, alpha, point: CouplerPoint | None = None):
        """(S, dS/dα) with S = |dP/dα| [m/rad] and its analytic derivative [m/rad²]
        (:func:`coupler_speed_ratio_law`, elementwise)."""
        P = self.kinematic_params(point)
        S, dS = _each(lambda a: coupler_speed_ratio_law(a, P), alpha, 2)
        return _assembled(S, alpha), dS

    def coupler_curve(self, n: int = 721, point: CouplerPoint | None = None):
        """(α, x_P, y_P) over one crank turn α ∈ [0, 2π] (n samples, both ends included) [rad, m]."""
        alpha = np.linspace(0.0, 2 * np.pi, int(n))
        x, y = self.coupler_point_position(alpha, point)
        return alpha, np.asarray(x), np.asarray(y)

    def _arc_key(self, point):
        pt = point or self.coupler_point
        return (self.a, self.b, self.c, self.h_x, self.h_y, self.k, pt.f, pt.theta)

    def arc_params(self, point: CouplerPoint | None = None) -> "ArcP":
        """The tabulated arc length s(α) of a coupler point as the parameters of
        :func:`arc_length_law` (cached by geometry)."""
        return _arc_table(self, self._arc_key(point), point)

    def speed_ratio_table(self, point: CouplerPoint | None = None):
        """Periodic spline table of (S, dS/dα) of a coupler point over one crank turn (channels 0, 1;
        :class:`~mjbench.mechanisms.linkage_kin.PeriodicTable`, cached by geometry) for the
        coupler-speed reference's law: nodes doubled from 1024 until the error at the cells'
        mid-points against :func:`coupler_speed_ratio_law` is ≤ ``SPEED_RATIO_TOL`` of each channel's
        peak (attribute ``max_rel_error``)."""
        return _speed_ratio_table(self, self._arc_key(point), point)

    def path_length(self, point: CouplerPoint | None = None) -> float:
        """Length of the closed coupler curve traced in one crank turn [m]."""
        return float(self.arc_params(point).L)

    def arc_length(self, alpha, point: CouplerPoint | None = None):
        """Path length s(α) = ∫₀^α |dP/dα'| dα' travelled by the coupler point since α = 0 [m],
        cumulative over turns (s(α + 2π) = s(α) + path_length): the law :func:`arc_length_law`
        (Gauss-Legendre table + cubic Hermite interpolation, error < 1e-10 m), elementwise."""
        P = self.arc_params(point)
        out = _each(lambda a: (arc_length_law(a, P),), alpha, 1)[0]
        return float(out) if np.ndim(out) == 0 and isinstance(alpha, (float, int)) else out

    def mass_centres(self, alpha):
        """(x, y) of G1, G2, G3 [m] (Eq 4 and Appendix A)."""
        xp = _xp(alpha)
        beta, gamma = self.angles(alpha)
        f, th = self.f, self.theta
        return ((f[0] * xp.cos(alpha + th[0]), f[0] * xp.sin(alpha + th[0])),
                (self.a * xp.cos(alpha) + f[1] * xp.cos(beta + th[1]),
                 self.a * xp.sin(alpha) + f[1] * xp.sin(beta + th[1])),
                (self.h_x + f[2] * xp.cos(gamma + th[2]), self.h_y + f[2] * xp.sin(gamma + th[2])))

    # ================================================================ reduced dynamics (App. C)
    def _lumped(self):
        """Link inertias J_A, J_B, J_D and masses incl. joint point masses (see joint_masses)."""
        jm = self.joint_masses
        mB, mC = jm.get("B", 0.0), jm.get("C", 0.0)
        m1, m2, m3 = self.m
        f1, f2, f3 = self.f
        # a point mass at B rides on the crank tip; at C on the rocker tip (both are also on the coupler:
        # assigning it to either link gives the same kinetic and potential energy)
        J_A = self.J_G[0] + m1 * f1 * f1 + mB * self.a ** 2
        J_B = self.J_G[1] + m2 * f2 * f2
        J_D = self.J_G[2] + m3 * f3 * f3 + mC * self.c ** 2
        return J_A, J_B, J_D

    def reduced(self, q):
        """J(α), dJ/dα, dE_p/dα (Appendix C; Eqs 3-5).  Analytic derivatives."""
        xp = _xp(q)
        alpha = q
        beta, gamma, Q, R, dQ, dR = self.ratio_derivatives(alpha)
        J_A, J_B, J_D = self._lumped()
        m1, m2, m3 = self.m
        f1, f2, f3 = self.f
        th1, th2, th3 = self.theta
        a = self.a
        jm = self.joint_masses
        mB, mC = jm.get("B", 0.0), jm.get("C", 0.0)
        psi = beta + th2 - alpha
        cpsi, spsi = xp.cos(psi), xp.sin(psi)
        J = J_A + J_D * R * R + m2 * a * a + J_B * Q * Q + 2 * a * f2 * m2 * Q * cpsi
        dJ = (2 * J_D * R * dR + 2 * J_B * Q * dQ
              + 2 * a * f2 * m2 * (dQ * cpsi - Q * spsi * (Q - 1.0)))
        dEp = self.g * (m1 * f1 * xp.cos(alpha + th1)
                        + m2 * (a * xp.cos(alpha) + f2 * xp.cos(beta + th2) * Q)
                        + m3 * f3 * xp.cos(gamma + th3) * R
                        + mB * a * xp.cos(alpha)
                        + mC * self.c * xp.cos(gamma) * R)
        return J, dJ, dEp

    def potential_energy(self, q):
        """E_p(α) = g Σ m_i y_Gi [J] (Eq 3), plus joint point masses; zero level y = 0."""
        xp = _xp(q)
        (_, y1), (_, y2), (_, y3) = self.mass_centres(q)
        _, gamma = self.angles(q)
        jm = self.joint_masses
        extra = jm.get("B", 0.0) * self.a * xp.sin(q) + jm.get("C", 0.0) * (self.h_y + self.c * xp.sin(gamma))
        extra = extra + jm.get("D", 0.0) * self.h_y
        return self.g * (self.m[0] * y1 + self.m[1] * y2 + self.m[2] * y3 + extra)

    def hinge_damping_factor(self, q):
        """Σ_j c_j·(ω_j,rel/α̇)² [N·m·s/rad]: viscous friction of the hinges reduced to the crank.

        Relative hinge speeds per unit crank speed: A (crank/ground) 1, B (coupler/crank) Q−1,
        C (coupler/rocker) R−Q, D (rocker/ground) R.  ``joint_damping`` acts in B and D,
        ``damping_A`` in A and ``damping_C`` in C (seed 002: the same coefficient in every bearing).
        """
        _, _, Q, R = self.ratios(q)
        return (self.damping_A + self.joint_damping * ((Q - 1.0) ** 2 + R * R)
                + self.damping_C * (R - Q) ** 2)

    def has_external_torque(self) -> bool:
        return not (self.joint_damping == 0.0 and self.damping_A == 0.0 and self.damping_C == 0.0)

    def reduced_viscous(self, q):
        """Hinge friction is viscous: external_torque = −hinge_damping_factor(α)·α̇."""
        return self.hinge_damping_factor(q) if self.has_external_torque() else None

    def external_torque(self, q, qd, t):
        """Viscous friction of the hinges reduced to the crank, −hinge_damping_factor(α)·α̇ [N·m]
        (the MJCF model has the same: joint damping in A, B, D; an explicit torque in C, see
        ``multibody_load``)."""
        if self.joint_damping == 0.0 and self.damping_A == 0.0 and self.damping_C == 0.0:
            return 0.0 * qd
        return -self.hinge_damping_factor(q) * qd

    def has_multibody_load(self) -> bool:
        """Only a damped hinge C loads the MuJoCo model (the other hinges are joint ``damping``)."""
        return self.damping_C != 0.0

    def multibody_load(self, model, data, t: float) -> None:
        """Viscous friction of the loop-closing hinge C (coupler/rocker: a ``connect`` equality in
        MJCF, so no joint to carry ``damping``) as generalised forces, from the velocities at the
        start of the step (hinges A, B, D are joint ``damping``, integrated by MuJoCo).
        ``qfrc_applied[crank]`` already holds the drive torque: it is added to, not replaced."""
        f = self.load_form(model, data)
        if f is not None:
            hinge_c_load(float(t), C.python_view(f.P))

    def load_form(self, model, data):
        """The hinge-C friction as a law (:func:`hinge_c_load`), None without it."""
        if self.damping_C == 0.0:
            return None
        va, vb, vr = _dof_cache(model)
        return C.Form(hinge_c_load, HingeCP(data.qvel, data.qfrc_applied, va, vb, vr, float(self.damping_C)))

    def linkage_view(self):
        """The same linkage as a generic :class:`~mjbench.mechanisms.linkage.Linkage` (link lines:
        transmission angles, toggles, velocity ratios for ``mjbench analyze``)."""

        return Linkage(LinkageParams.model_validate(table_from_fourbar(self)))

    # ================================================================ MJCF builder
    def build_spec(self, armature: float = 0.0, options=None):
        """MjSpec of the linkage: crank, coupler, rocker; loop closed by a site ``connect``.

        ``options``: dict with optional ``timestep`` [s], ``integrator`` (Euler|RK4|implicit|
        implicitfast), ``solref`` (2 values), ``solimp`` (5 values).  The constraint Jacobian is
        MuJoCo's default (:func:`~mjbench.mechanisms.base.new_spec`).
        """
        import mujoco

        o = dict(options or {})
        h = float(o.get("timestep", 1e-4))
        spec = new_spec(self.name, o, gravity=(0.0, 0.0, -self.g))

        rad = 0.012 * max(self.a, self.b, self.c, math.hypot(self.h_x, self.h_y))
        colors = {"ground": [0.45, 0.45, 0.5, 1], "crank": [0.85, 0.25, 0.2, 1],
                  "coupler": [0.2, 0.55, 0.85, 1], "rocker": [0.3, 0.7, 0.3, 1]}
        jm = self.joint_masses
        world = spec.worldbody
        world.add_light(pos=[0, -3, 3], dir=[0, 1, -1], diffuse=[0.8, 0.8, 0.8])
        # ground pivots
        for nm, (x, y) in (("A", (0.0, 0.0)), ("D", (self.h_x, self.h_y))):
            world.add_geom(name=f"pivot_{nm}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                           size=[1.8 * rad, 1.5 * rad, 0], pos=[x, 0.0, y],
                           quat=[0.7071068, 0.7071068, 0, 0], rgba=colors["ground"],
                           contype=0, conaffinity=0)

        def link(parent, name, pos, length, mass, f, th, JG, color, jname, ref_mass=0.0):
            body = parent.add_body(name=name, pos=pos)
            body.add_joint(name=jname, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(AXIS))
            mtot = mass + ref_mass
            if mtot > 0:
                # point mass ref_mass at the body origin (bearing) combined with the link
                cx, cz = f * math.cos(th), f * math.sin(th)
                body.mass = mtot
                body.ipos = [mass * cx / mtot, 0.0, mass * cz / mtot]
                # parallel-axis shift of both parts to the combined centre
                dlink2 = (cx - body.ipos[0]) ** 2 + (cz - body.ipos[2]) ** 2
                dref2 = body.ipos[0] ** 2 + body.ipos[2] ** 2
                Iy = JG + mass * dlink2 + ref_mass * dref2
            else:
                body.mass = 1e-9
                body.ipos = [0.0, 0.0, 0.0]
                Iy = JG
            Iy = max(Iy, 1e-12)
            body.inertia = [0.6 * Iy, Iy, 0.6 * Iy]  # only I_yy (hinge axis) matters; 0.6 keeps A+B ≥ C
            body.explicitinertial = True
            body.add_geom(name=f"{name}_geom", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                          fromto=[0, 0, 0, length, 0, 0], size=[rad, 0, 0], rgba=color,
                          contype=0, conaffinity=0, mass=0)
            return body

        crank = link(world, "crank", [0, 0, 0], self.a, self.m[0], self.f[0], self.theta[0],
                     self.J_G[0], colors["crank"], INPUT_JOINT, ref_mass=jm.get("A", 0.0))
        crank.joints[0].armature = float(armature)
        crank.joints[0].damping = [float(self.damping_A), 0.0, 0.0]  # bearing A; the drive adds z²λ
        # bearing at B rides on the coupler origin, at C on the rocker tip (added below as a site mass)
        coupler = link(crank, "coupler", [self.a, 0, 0], self.b, self.m[1], self.f[1], self.theta[1],
                       self.J_G[1], colors["coupler"], "coupler_joint", ref_mass=jm.get("B", 0.0))
        rocker = world.add_body(name="rocker_frame", pos=[self.h_x, 0, self.h_y])
        rocker_b = link(rocker, "rocker", [0, 0, 0], self.c, self.m[2], self.f[2], self.theta[2],
                        self.J_G[2], colors["rocker"], "rocker_joint", ref_mass=jm.get("D", 0.0))
        if jm.get("C", 0.0) > 0:
            tip = rocker_b.add_body(name="bearing_C", pos=[self.c, 0, 0])
            tip.mass = jm["C"]
            tip.ipos = [0.0, 0.0, 0.0]  # explicit: MjSpec otherwise puts the inertial frame at pos (2c from D)
            tip.inertia = [1e-9, 1e-9, 1e-9]
            tip.explicitinertial = True
        for j in (coupler.joints[0], rocker_b.joints[0]):
            j.damping = [float(self.joint_damping), 0.0, 0.0]
        coupler.add_site(name="B_end", pos=[self.b, 0, 0], size=[1.3 * rad, 0, 0])
        rocker_b.add_site(name="C_end", pos=[self.c, 0, 0], size=[1.3 * rad, 0, 0])
        pt = self.coupler_point
        coupler.add_site(name="coupler_point", pos=[pt.f * math.cos(pt.theta), 0, pt.f * math.sin(pt.theta)],
                         size=[1.6 * rad, 0, 0], rgba=[1, 0.8, 0.1, 1])
        solref, solimp = closure_solref(o, h)  # loop closure at C (base.py: 3·h, impedance 0.9999)
        spec.add_equality(name="loop_closure", type=mujoco.mjtEq.mjEQ_CONNECT,
                          objtype=mujoco.mjtObj.mjOBJ_SITE, name1="B_end", name2="C_end",
                          solref=solref, solimp=solimp)
        return spec

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        beta, gamma = self.angles(float(q0))
        qpos = np.array(model.qpos0, dtype=float)
        qpos[model.joint(INPUT_JOINT).qposadr[0]] = q0
        qpos[model.joint("coupler_joint").qposadr[0]] = beta - q0
        qpos[model.joint("rocker_joint").qposadr[0]] = gamma
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        _, _, Q, R = self.ratios(float(q0))
        qvel = np.zeros(model.nv)
        qvel[model.joint(INPUT_JOINT).dofadr[0]] = qd0
        qvel[model.joint("coupler_joint").dofadr[0]] = (Q - 1.0) * qd0
        qvel[model.joint("rocker_joint").dofadr[0]] = R * qd0
        return qvel

    def describe(self) -> dict:
        return {"type": "fourbar", "a": self.a, "b": self.b, "c": self.c, "h_x": self.h_x, "h_y": self.h_y,
                "f": list(self.f), "theta": list(self.theta), "m": list(self.m), "J_G": list(self.J_G),
                "k": self.k, "g": self.g, "coupler_point": {"f": self.coupler_point.f, "theta": self.coupler_point.theta},
                "joint_masses": dict(self.joint_masses), "joint_damping": self.joint_damping,
                "damping_A": self.damping_A, "damping_C": self.damping_C}


#: the hinge-C friction load's parameters: live qvel and qfrc_applied, the crank, coupler and rocker
#: dofs, the damping c_C [N·m·s/rad]
HingeCP = namedtuple("HingeCP", "qvel qfrc va vb vr dC")


@law
def hinge_c_load(t, P):
    """Viscous friction of the loop-closing hinge C (coupler/rocker) as generalised forces, from the
    velocities at the step's start: τ_C = −c_C·(ω_crank + ω_coupler,rel − ω_rocker) on the coupler
    (added to the drive torque on the crank dof), −τ_C on the rocker."""
    tau_c = -P.dC * (P.qvel[P.va] + P.qvel[P.vb] - P.qvel[P.vr])
    P.qfrc[P.va] += tau_c
    P.qfrc[P.vb] = tau_c
    P.qfrc[P.vr] = -tau_c


_DOF_CACHE: dict = {}
_ARC_CACHE: dict = {}


def _arc_table(fb, key, point, n: int = 2048) -> "ArcP":
    """The parameters of :func:`arc_length_law` for the coupler point, cached by geometry: n
    intervals over one turn, s at the nodes by 3-point Gauss-Legendre per interval, the exact
    S = ds/dα at the nodes as slopes (both from :func:`coupler_speed_ratio_law`)."""
    hit = _ARC_CACHE.get(key)
    if hit is not None:
        return hit
    nodes = np.arange(n + 1) * (2 * np.pi / n)
    h = 2 * np.pi / n
    xg, wg = np.polynomial.legendre.leggauss(3)
    mid = 0.5 * (nodes[:-1] + nodes[1:])
    pts = mid[:, None] + 0.5 * h * xg[None, :]
    S = fb.coupler_speed_ratio(pts.ravel(), point).reshape(pts.shape)
    seg = 0.5 * h * (S * wg[None, :]).sum(axis=1)
    s_nodes = np.concatenate(([0.0], np.cumsum(seg)))
    slopes = np.asarray(fb.coupler_speed_ratio(nodes, point), dtype=float)
    if len(_ARC_CACHE) > 64:
        _ARC_CACHE.clear()
    _ARC_CACHE[key] = ArcP(int(n), float(h), float(s_nodes[-1]), np.ascontiguousarray(s_nodes),
                           np.ascontiguousarray(slopes))
    return _ARC_CACHE[key]


#: largest relative error of the tabulated S, dS/dα (:meth:`FourBar.speed_ratio_table`)
SPEED_RATIO_TOL = 1e-9
_RATIO_CACHE: dict = {}


def _speed_ratio_table(fb, key, point):
    hit = _RATIO_CACHE.get(key)
    if hit is not None:
        return hit

    for n in (1024, 2048, 4096, 8192, 16384):
        u = np.arange(n) * (2 * np.pi / n)
        tab = PeriodicTable(0.0, np.stack(fb.coupler_speed_ratio_derivative(u, point), axis=1))
        um = u + np.pi / n
        exact = np.stack(fb.coupler_speed_ratio_derivative(um, point), axis=1)
        err = np.max(np.abs(tab(um) - exact), axis=0) / np.max(np.abs(exact), axis=0)
        if np.all(err <= SPEED_RATIO_TOL):
            break
    else:
        raise ParameterError(f"fourbar: the coupler point's speed ratio cannot be tabulated to {SPEED_RATIO_TOL:g} "
                             f"(error {np.max(err):.3g} with {n} nodes: a near-singular linkage?)")
    tab.max_rel_error = float(np.max(err))
    if len(_RATIO_CACHE) > 64:
        _RATIO_CACHE.clear()
    _RATIO_CACHE[key] = tab
    return tab


# ================================================================ kinematic laws (one formula)
#: the four-bar's geometry for the kinematic laws, with one coupler point (f, ϑ from B)
FourBarKinP = namedtuple("FourBarKinP", "a b c hx hy k f theta")


@law
def fourbar_abcd2(alpha, P):
    """A, B, C of the loop-closure equation A·sin γ + B·cos γ = C (Appendix A) and its
    discriminant A² + B² − C² (< 0: the linkage cannot be assembled at α)."""
    a = P.a
    c = P.c
    sa = math.sin(alpha)
    ca = math.cos(alpha)
    A = 2 * c * (P.hy - a * sa)
    B = 2 * c * (P.hx - a * ca)
    Cc = a * a - P.b * P.b + c * c + P.hx * P.hx + P.hy * P.hy - 2 * a * (P.hx * ca + P.hy * sa)
    return A, B, Cc, A * A + B * B - Cc * Cc


@law
def fourbar_solve(alpha, A, B, Cc, D, P):
    """(β, γ) [rad] from the closure coefficients and D = √(A² + B² − C²), assembly mode k."""
    AB = A * A + B * B
    sg = -(A * Cc + P.k * B * D) / AB
    cg = -(B * Cc - P.k * A * D) / AB
    sb = (P.hy + P.c * sg - P.a * math.sin(alpha)) / P.b
    cb = (P.hx + P.c * cg - P.a * math.cos(alpha)) / P.b
    return math.atan2(sb, cb), math.atan2(sg, cg)


@law
def fourbar_angles(alpha, P):
    """(β, γ) [rad] of coupler and rocker at crank angle α (Appendix A); NaN where the linkage
    cannot be assembled (A² + B² − C² < 0)."""
    A, B, Cc, D2 = fourbar_abcd2(alpha, P)
    if not D2 >= 0.0:
        return math.nan, math.nan
    return fourbar_solve(alpha, A, B, Cc, math.sqrt(D2), P)


@law
def fourbar_velocity(alpha, beta, gamma, P):
    """(Q, R, dQ/dα, dR/dα): velocity ratios Q = β̇/α̇, R = γ̇/α̇ (Appendix B) and their analytic
    derivatives, at the link angles β, γ of crank angle α."""
    a = P.a
    s_gb = math.sin(gamma - beta)
    c_gb = math.cos(gamma - beta)
    s_ab = math.sin(alpha - beta)
    c_ab = math.cos(alpha - beta)
    s_ag = math.sin(alpha - gamma)
    c_ag = math.cos(alpha - gamma)
    R = a * s_ab / (P.c * s_gb)
    Q = a * s_ag / (P.b * s_gb)
    d_gb = R - Q  # d(γ−β)/dα
    dR = a / P.c * (c_ab * (1 - Q) * s_gb - s_ab * c_gb * d_gb) / (s_gb * s_gb)
    dQ = a / P.b * (c_ag * (1 - R) * s_gb - s_ag * c_gb * d_gb) / (s_gb * s_gb)
    return Q, R, dQ, dR


@law
def fourbar_ratio_derivatives(alpha, P):
    """(β, γ, Q, R, dQ/dα, dR/dα) at crank angle α (Appendices A and B)."""
    beta, gamma = fourbar_angles(alpha, P)
    Q, R, dQ, dR = fourbar_velocity(alpha, beta, gamma, P)
    return beta, gamma, Q, R, dQ, dR


#: the branch-free kinematic laws evaluated over arrays (the same code, NumPy's functions)
_ABCD2 = array_twin(fourbar_abcd2)
_SOLVE = array_twin(fourbar_solve)
_VELOCITY = array_twin(fourbar_velocity)


def _is_array(x) -> bool:
    return isinstance(x, (np.ndarray, list, tuple)) and np.ndim(x) > 0


@law
def coupler_speed_ratio_law(alpha, P):
    """(S, dS/dα): S = |dP/dα| [m/rad] of the coupler point (P.f, P.theta), the square root of
    the denominator of seed 002 Eq 17, S² = a² + f²Q² + 2afQ·cos(α − β − ϑ), and its analytic
    derivative [m/rad²]."""
    beta, gamma, Q, R, dQ, dR = fourbar_ratio_derivatives(alpha, P)
    a = P.a
    f = P.f
    psi = alpha - beta - P.theta
    c = math.cos(psi)
    s = math.sin(psi)
    S2 = a * a + f * f * Q * Q + 2 * a * f * Q * c
    S = math.sqrt(0.0 if S2 < 0.0 else S2)
    dS2 = 2 * f * f * Q * dQ + 2 * a * f * (dQ * c - Q * s * (1.0 - Q))
    return S, dS2 / (2 * S)


def _each(fn, x, nout):
    """A law ``fn(float) → tuple of nout floats`` applied to every element of x: a tuple of nout
    arrays of x's shape (floats for a scalar x; post-processing, never on the hot path)."""
    xa = np.asarray(x, dtype=float)
    if xa.ndim == 0:
        return tuple(fn(float(xa)))
    rows = np.array([fn(v) for v in xa.ravel().tolist()], dtype=float).reshape(-1, nout)
    return tuple(rows[:, k].reshape(xa.shape) for k in range(nout))


def _assembled(S, alpha):
    """S, or GeometryError where a finite angle gave NaN (the linkage cannot be assembled there)."""
    bad = np.isnan(S) & np.isfinite(np.asarray(alpha, dtype=float))
    if np.any(bad):
        raise GeometryError("four-bar cannot be assembled at some of the requested crank angles")
    return S


def _dof_cache(model):
    """(crank, coupler, rocker) dof addresses of a compiled model, cached per model object."""
    hit = _DOF_CACHE.get(id(model))
    if hit is not None and hit[0] is model:
        return hit[1]
    adr = tuple(int(model.joint(n).dofadr[0]) for n in (INPUT_JOINT, "coupler_joint", "rocker_joint"))
    if len(_DOF_CACHE) > 32:
        _DOF_CACHE.clear()
    _DOF_CACHE[id(model)] = (model, adr)
    return adr


#: geometries (a, b, c, h_x, h_y, n) whose crank makes the full turn, found by :meth:`FourBar.check`
#: (its scan of n crank angles costs ≈ 0.15 ms: done once per geometry and process)
_TURNS_FULL: set = set()


class FourBarParams(Strict):
    """``[mechanism] type = "fourbar"`` in the seed-000 notation (Incerti 2012, Fig. 1, Table I).
    Lengths [m], angles [rad], masses [kg], inertias about the mass centres [kg·m²]."""

    type: Literal["fourbar"] = "fourbar"
    notation: Literal["seed000"] = "seed000"
    a: Q("length", gt=0.0, what="a link length") = Field(description="crank length AB")
    b: Q("length", gt=0.0, what="a link length") = Field(description="coupler length BC")
    c: Q("length", gt=0.0, what="a link length") = Field(description="rocker length DC")
    h_x: Q("length", what="a pivot coordinate") = Field(description="rocker pivot D, x")
    h_y: Q("length", what="a pivot coordinate") = Field(description="rocker pivot D, y")
    f1: Q("length", ge=0.0, what="a mass-centre distance") = Field(description="crank mass centre from A")
    f2: Q("length", ge=0.0, what="a mass-centre distance") = Field(description="coupler mass centre from B")
    f3: Q("length", ge=0.0, what="a mass-centre distance") = Field(description="rocker mass centre from D")
    theta1: Q("angle") = Field(0.0, description="mass-centre angle from the link line (default: on the line)")
    theta2: Q("angle") = 0.0
    theta3: Q("angle") = 0.0
    m1: Q("mass", ge=0.0, what="a link mass") = Field(description="crank mass")
    m2: Q("mass", ge=0.0, what="a link mass") = Field(description="coupler mass")
    m3: Q("mass", ge=0.0, what="a link mass") = Field(description="rocker mass")
    J_G1: Q("inertia", ge=0.0, what="a link inertia") = Field(description="crank inertia about its mass centre")
    J_G2: Q("inertia", ge=0.0, what="a link inertia") = Field(description="coupler inertia about its mass centre")
    J_G3: Q("inertia", ge=0.0, what="a link inertia") = Field(description="rocker inertia about its mass centre")
    k: Literal[1, -1] = Field(1, description="assembly mode (Appendix A)")
    g: Q("acceleration", what="gravity") = Field(G, description="gravity, −y in the mechanism plane (0: plane horizontal)")
    coupler_f: Q("length", ge=0.0) = Field(0.0, description="traced coupler point: distance from B (display, seed-002 reference)")
    coupler_theta: Q("angle") = Field(0.0, description="traced coupler point: angle from BC")
    joint_mass_A: Q("mass", ge=0.0) = Field(0.0, description="point mass in joint A (bearing; default none)")
    joint_mass_B: Q("mass", ge=0.0) = 0.0
    joint_mass_C: Q("mass", ge=0.0) = 0.0
    joint_mass_D: Q("mass", ge=0.0) = 0.0
    joint_damping: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous friction in hinges B and D (default none)")
    damping_A: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous friction in the crank pivot A, besides the drive's")
    damping_C: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous friction in the loop-closing hinge C")


class FourBarSeed002Params(Strict):
    """``[mechanism] type = "fourbar"``, ``notation = "seed002"`` (Hülako & Çakar 2025, Eqs 2-17,
    Table 1): r1 ground A₀B₀, r2 crank A₀A, r3 coupler AB, r4 rocker B₀B; link i of seed 002 is
    link i−1 of seed 000 (see :func:`seed002_to_fourbar`)."""

    type: Literal["fourbar"] = "fourbar"
    notation: Literal["seed002"] = "seed002"
    r1: Q("length", gt=0.0, what="a link length") = Field(description="ground link A0B0")
    r2: Q("length", gt=0.0, what="a link length") = Field(description="crank A0A")
    r3: Q("length", gt=0.0, what="a link length") = Field(description="coupler AB")
    r4: Q("length", gt=0.0, what="a link length") = Field(description="rocker B0B")
    beta1: Q("angle") = Field(0.0, description="angle of the ground line A0→B0 (Table 1: 0)")
    c2: Q("length", ge=0.0) = Field(description="crank mass centre from A0")
    c3: Q("length", ge=0.0) = Field(description="coupler mass centre from A")
    c4: Q("length", ge=0.0) = Field(description="rocker mass centre from B0")
    beta2: Q("angle") = 0.0
    beta3: Q("angle") = 0.0
    beta4: Q("angle") = 0.0
    m2: Q("mass", ge=0.0, what="a link mass")
    m3: Q("mass", ge=0.0, what="a link mass")
    m4: Q("mass", ge=0.0, what="a link mass")
    J2: Q("inertia", ge=0.0, what="a link inertia") = Field(description="about the mass centre")
    J3: Q("inertia", ge=0.0, what="a link inertia")
    J4: Q("inertia", ge=0.0, what="a link inertia")
    rC: Q("length", ge=0.0) = Field(0.0, description="coupler point C: distance from A")
    betaC: Q("angle") = Field(0.0, description="coupler point C: angle from AB")
    g: Q("acceleration", what="gravity") = G
    branch: Literal["open", "crossed", 1, -1] = Field("open", description="assembly branch")
    bearing_mass: Q("mass", ge=0.0) = Field(0.0, description="point mass in each bearing of bearing_joints")
    bearing_joints: str | list[Literal["A0", "A", "B", "B0"]] = "all"
    bearing_damping: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous friction in each hinge of damping_joints")
    damping_joints: str | list[Literal["A0", "A", "B", "B0"]] = "all"

    @field_validator("bearing_joints", "damping_joints")
    @classmethod
    def _joints(cls, v):
        _joint_list(v, "joints")
        return v


def _fourbar_from_seed000(p: FourBarParams) -> FourBar:
    return FourBar(a=p.a, b=p.b, c=p.c, h_x=p.h_x, h_y=p.h_y, f=(p.f1, p.f2, p.f3),
                   theta=(p.theta1, p.theta2, p.theta3), m=(p.m1, p.m2, p.m3), J_G=(p.J_G1, p.J_G2, p.J_G3),
                   k=int(p.k), g=p.g, coupler_point=CouplerPoint(p.coupler_f, p.coupler_theta),
                   joint_masses={j: getattr(p, f"joint_mass_{j}") for j in "ABCD" if getattr(p, f"joint_mass_{j}") > 0},
                   joint_damping=p.joint_damping, damping_A=p.damping_A, damping_C=p.damping_C)


#: seed-002 joint names → seed-000 joint names (A₀ crank pivot, A crank/coupler,
#: B coupler/rocker, B₀ rocker pivot  →  A, B, C, D)
SEED002_JOINTS = {"A0": "A", "A": "B", "B": "C", "B0": "D"}


def seed002_to_fourbar(p: FourBarSeed002Params) -> FourBar:
    """The seed-002 description → the same :class:`FourBar` (seed-000 notation).

    Mapping: a = r2, b = r3, c = r4, (h_x, h_y) = r1·(cos β₁, sin β₁); q = α, φ₁ = β, φ₂ = γ,
    g₁ = Q, g₂ = R.  ``branch = "open"`` is the circuit in which B lies left of A₀→B₀ (above the
    ground line for β₁ = 0) at q = β₁ + 90°; bearings: a point mass in each joint of
    ``bearing_joints``, viscous friction in each hinge of ``damping_joints`` ("A" and "B0" share
    FourBar.joint_damping, so both or neither)."""
    bjoints = _joint_list(p.bearing_joints, "bearing_joints")
    djoints = _joint_list(p.damping_joints, "damping_joints")
    if ("A" in djoints) != ("B0" in djoints):
        raise ParameterError(f"mechanism.damping_joints = {sorted(djoints)}: hinges 'A' and 'B0' share one "
                             f"coefficient (FourBar.joint_damping); list both or neither")
    hx, hy = p.r1 * math.cos(p.beta1), p.r1 * math.sin(p.beta1)
    bmass, bdamp = p.bearing_mass, p.bearing_damping
    kw = dict(a=p.r2, b=p.r3, c=p.r4, h_x=hx, h_y=hy, f=(p.c2, p.c3, p.c4), theta=(p.beta2, p.beta3, p.beta4),
              m=(p.m2, p.m3, p.m4), J_G=(p.J2, p.J3, p.J4), g=p.g, coupler_point=CouplerPoint(p.rC, p.betaC),
              joint_masses={SEED002_JOINTS[j]: bmass for j in bjoints} if bmass > 0 else {},
              joint_damping=bdamp if "A" in djoints else 0.0,
              damping_A=bdamp if "A0" in djoints else 0.0,
              damping_C=bdamp if "B" in djoints else 0.0)
    branch = p.branch
    if isinstance(branch, str):
        fb = FourBar(**kw, k=1)
        q = p.beta1 + 0.5 * math.pi
        Cx, Cy = (float(v) for v in fb.joints(q)["C"])
        left = (hx * Cy - hy * Cx) > 0
        k = 1 if left == (branch == "open") else -1
        return fb if k == 1 else FourBar(**kw, k=-1)
    return FourBar(**kw, k=int(branch))


def _joint_list(v, name):
    if isinstance(v, str):
        key = v.strip().lower()
        if key == "all":
            return set(SEED002_JOINTS)
        if key == "none":
            return set()
        v = [x.strip() for x in v.split(",")]
    out = set(v)
    bad = out - set(SEED002_JOINTS)
    if bad:
        raise ParameterError(f"mechanism.{name} = {v!r}: joints are {sorted(SEED002_JOINTS)}, 'all' or 'none'")
    return out


def to_seed002(fb: FourBar) -> dict:
    """The seed-002 ``[mechanism]`` table of a FourBar (inverse of :func:`seed002_to_fourbar`,
    bearings excluded)."""
    return {"type": "fourbar", "notation": "seed002", "r1": math.hypot(fb.h_x, fb.h_y), "r2": fb.a, "r3": fb.b, "r4": fb.c,
            "beta1": math.atan2(fb.h_y, fb.h_x),
            **{f"c{i + 2}": fb.f[i] for i in range(3)}, **{f"beta{i + 2}": fb.theta[i] for i in range(3)},
            **{f"m{i + 2}": fb.m[i] for i in range(3)}, **{f"J{i + 2}": fb.J_G[i] for i in range(3)},
            "rC": fb.coupler_point.f, "betaC": fb.coupler_point.theta, "g": fb.g, "branch": fb.k}


# ----------------------------------------------------------------- registration
FourBar.Params = FourBarParams

register(FourBar)
