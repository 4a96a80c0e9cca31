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
from dataclasses import dataclass, field

import numpy as np

from ..errors import GeometryError, ParameterError
from .base import INPUT_JOINT, Mechanism

G = 9.81  #: gravitational acceleration [m/s²] (seed 000 Eq 3)
AXIS = (0.0, -1.0, 0.0)  #: hinge axis in MuJoCo: paper angles are counter-clockwise in (x, z)

# Loop-closure equality: solref (timeconst, dampratio) and solimp.  timeconst = 2·h (the
# smallest MuJoCo accepts) with impedance 0.9999 makes the closure nearly hard: the constraint
# acceleration is the reference a* = −b·ṙ − k·r with (1−d)/d ≈ 1e-4 regularisation.  Measured
# closure residual < 1e-6 m (tests/test_fourbar_multibody.py).
DEFAULT_SOLREF = (-1.0, 0.0)  # < 0: replaced by (2·timestep, 1) when the model is built
DEFAULT_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)


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
    #: viscous friction in the passive joints B, C, D [N·m·s/rad] (seed 002 bearings)
    joint_damping: float = 0.0
    name: str = "fourbar"

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
        if self.joint_damping < 0:
            raise ParameterError(f"fourbar.joint_damping = {self.joint_damping!r}: must be >= 0")
        alpha = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        _, _, _, D2 = self._abcd2(alpha)
        scale = (2 * self.c * (self.a + math.hypot(self.h_x, self.h_y))) ** 2
        bad = D2 <= 1e-10 * scale
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
    def _abcd2(self, alpha):
        xp = _xp(alpha)
        a, b, c, hx, hy = self.a, self.b, self.c, self.h_x, self.h_y
        sa, ca = xp.sin(alpha), xp.cos(alpha)
        A = 2 * c * (hy - a * sa)
        B = 2 * c * (hx - a * ca)
        C = a * a - b * b + c * c + hx * hx + hy * hy - 2 * a * (hx * ca + hy * sa)
        return A, B, C, A * A + B * B - C * C

    def angles(self, alpha):
        """(β, γ) [rad] of coupler and rocker for crank angle α (Appendix A)."""
        xp = _xp(alpha)
        A, B, C, D2 = self._abcd2(alpha)
        if xp is math:
            if D2 < 0:
                raise GeometryError(f"four-bar cannot be assembled at α = {alpha:.6g} rad (A²+B²−C² = {D2:.3g} < 0)")
            D = math.sqrt(D2)
        else:
            if np.any(D2 < 0):
                raise GeometryError("four-bar cannot be assembled at some of the requested crank angles")
            D = np.sqrt(D2)
        k = self.k
        AB = A * A + B * B
        sg = -(A * C + k * B * D) / AB
        cg = -(B * C - k * A * D) / AB
        gamma = xp.arctan2(sg, cg) if xp is np else math.atan2(sg, cg)
        sb = (self.h_y + self.c * sg - self.a * xp.sin(alpha)) / self.b
        cb = (self.h_x + self.c * cg - self.a * xp.cos(alpha)) / self.b
        beta = xp.arctan2(sb, cb) if xp is np else math.atan2(sb, cb)
        return beta, gamma

    # ================================================================ velocity analysis (App. B)
    def ratios(self, alpha):
        """(β, γ, Q, R): link angles and velocity ratios Q = β̇/α̇, R = γ̇/α̇ (Appendix B)."""
        xp = _xp(alpha)
        beta, gamma = self.angles(alpha)
        s_gb = xp.sin(gamma - beta)
        R = self.a * xp.sin(alpha - beta) / (self.c * s_gb)
        Q = self.a * xp.sin(alpha - gamma) / (self.b * s_gb)
        return beta, gamma, Q, R

    def ratio_derivatives(self, alpha):
        """(β, γ, Q, R, dQ/dα, dR/dα), analytic."""
        xp = _xp(alpha)
        beta, gamma, Q, R = self.ratios(alpha)
        s_gb, c_gb = xp.sin(gamma - beta), xp.cos(gamma - beta)
        d_gb = R - Q  # d(γ−β)/dα
        s_ab, c_ab = xp.sin(alpha - beta), xp.cos(alpha - beta)
        s_ag, c_ag = xp.sin(alpha - gamma), xp.cos(alpha - gamma)
        dR = self.a / self.c * (c_ab * (1 - Q) * s_gb - s_ab * c_gb * d_gb) / (s_gb * s_gb)
        dQ = self.a / self.b * (c_ag * (1 - R) * s_gb - s_ag * c_gb * d_gb) / (s_gb * s_gb)
        return beta, gamma, Q, R, dQ, dR

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

    def external_torque(self, q, qd, t):
        """Viscous friction of the passive hinges B (coupler-crank) and D (rocker) reduced to the
        crank: −c·[(Q−1)² + R²]·α̇ [N·m] (the loop-closing joint C is frictionless, as in the MJCF)."""
        if self.joint_damping == 0.0:
            return 0.0 * qd
        _, _, Q, R = self.ratios(q)
        return -self.joint_damping * ((Q - 1.0) ** 2 + R * R) * qd

    # ================================================================ MJCF builder
    def build_spec(self, armature: float = 0.0, options=None):
        """MjSpec of the linkage: crank, coupler, rocker; loop closed by a site ``connect``.

        ``options``: dict with optional ``timestep`` [s], ``integrator`` (Euler|RK4|implicit|
        implicitfast), ``solref`` (2 values), ``solimp`` (5 values).  The Jacobian is forced
        dense (MuJoCo 4.0.0 sparse-Cholesky bug on closed chains, upstream issue 3767).
        """
        import mujoco

        o = dict(options or {})
        h = float(o.get("timestep", 1e-4))
        spec = mujoco.MjSpec()
        spec.modelname = self.name
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
        spec.compiler.autolimits = True
        opt = spec.option
        opt.timestep = h
        opt.integrator = _integrator(o.get("integrator", "Euler"))
        opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
        opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
        opt.iterations = int(o.get("iterations", 100))
        opt.tolerance = float(o.get("tolerance", 1e-12))
        opt.gravity = [0.0, 0.0, -self.g]
        opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
        spec.visual.global_.offwidth = 1920
        spec.visual.global_.offheight = 1080

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
        # bearing at B rides on the coupler origin, at C on the rocker tip (added below as a site mass)
        coupler = link(crank, "coupler", [self.a, 0, 0], self.b, self.m[1], self.f[1], self.theta[1],
                       self.J_G[1], colors["coupler"], "coupler_joint", ref_mass=jm.get("B", 0.0))
        rocker = world.add_body(name="rocker_frame", pos=[self.h_x, 0, self.h_y])
        rocker_b = link(rocker, "rocker", [0, 0, 0], self.c, self.m[2], self.f[2], self.theta[2],
                        self.J_G[2], colors["rocker"], "rocker_joint", ref_mass=jm.get("D", 0.0))
        if jm.get("C", 0.0) > 0:
            tip = rocker_b.add_body(name="bearing_C", pos=[self.c, 0, 0])
            tip.mass = jm["C"]
            tip.inertia = [1e-9, 1e-9, 1e-9]
            tip.explicitinertial = True
        for j in (coupler.joints[0], rocker_b.joints[0]):
            j.damping = [float(self.joint_damping), 0.0, 0.0]
        coupler.add_site(name="B_end", pos=[self.b, 0, 0], size=[1.3 * rad, 0, 0])
        rocker_b.add_site(name="C_end", pos=[self.c, 0, 0], size=[1.3 * rad, 0, 0])
        pt = self.coupler_point
        coupler.add_site(name="coupler_point", pos=[pt.f * math.cos(pt.theta), 0, pt.f * math.sin(pt.theta)],
                         size=[1.6 * rad, 0, 0], rgba=[1, 0.8, 0.1, 1])
        solref = list(o.get("solref", DEFAULT_SOLREF))
        if solref[0] < 0:
            solref = [2.0 * h, 1.0]
        solimp = list(o.get("solimp", DEFAULT_SOLIMP))
        spec.add_equality(name="loop_closure", type=mujoco.mjtEq.mjEQ_CONNECT,
                          objtype=mujoco.mjtObj.mjOBJ_SITE, name1="B_end", name2="C_end",
                          solref=solref, solimp=solimp)
        return spec

    def initial_qpos(self, model, q0: float) -> np.ndarray:
        beta, gamma = self.angles(float(q0))
        qpos = np.array(model.qpos0, dtype=float)
        qpos[model.joint(INPUT_JOINT).qposadr[0]] = q0
        qpos[model.joint("coupler_joint").qposadr[0]] = beta - q0
        qpos[model.joint("rocker_joint").qposadr[0]] = gamma
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float) -> np.ndarray:
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
                "joint_masses": dict(self.joint_masses), "joint_damping": self.joint_damping}


def _integrator(name):
    import mujoco

    table = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4,
             "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
             "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}
    try:
        return table[str(name).lower()]
    except KeyError:
        raise ParameterError(f"multibody.integrator = {name!r}: choose one of {sorted(table)}") from None


def _angle_ranges(alpha, mask):
    """Contiguous [lo, hi] ranges of alpha where mask is True (wrapping at 2π)."""
    n = len(alpha)
    step = alpha[1] - alpha[0]
    idx = np.flatnonzero(mask)
    ranges, start, prev = [], idx[0], idx[0]
    for i in idx[1:]:
        if i != prev + 1:
            ranges.append((start, prev))
            start = i
        prev = i
    ranges.append((start, prev))
    if len(ranges) > 1 and ranges[0][0] == 0 and ranges[-1][1] == n - 1:
        first = ranges.pop(0)
        last = ranges.pop()
        ranges.append((last[0], first[1] + n))
    return [(alpha[s % n], alpha[s % n] + (e - s) * step) for s, e in ranges]


def from_params(p: dict) -> FourBar:
    """Scenario ``[mechanism]`` table (seed-000 notation, flat keys) → FourBar.

    Keys: a, b, c, h_x, h_y [m]; f1..f3 [m]; theta1..theta3 [rad]; m1..m3 [kg];
    J_G1..J_G3 [kg·m²]; k (±1); g [m/s²]; coupler_f [m], coupler_theta [rad];
    joint_mass_A..D [kg]; joint_damping [N·m·s/rad].
    """
    p = dict(p)
    if "r1" in p or "notation" in p:  # seed-002 notation, see from_seed002
        return from_seed002(p)
    try:
        fb = FourBar(
            a=float(p.pop("a")), b=float(p.pop("b")), c=float(p.pop("c")),
            h_x=float(p.pop("h_x")), h_y=float(p.pop("h_y", 0.0)),
            f=tuple(float(p.pop(f"f{i}", 0.0)) for i in (1, 2, 3)),
            theta=tuple(float(p.pop(f"theta{i}", 0.0)) for i in (1, 2, 3)),
            m=tuple(float(p.pop(f"m{i}", 0.0)) for i in (1, 2, 3)),
            J_G=tuple(float(p.pop(f"J_G{i}", 0.0)) for i in (1, 2, 3)),
            k=int(p.pop("k", 1)), g=float(p.pop("g", G)),
            coupler_point=CouplerPoint(float(p.pop("coupler_f", 0.0)), float(p.pop("coupler_theta", 0.0))),
            joint_masses={j: float(p.pop(f"joint_mass_{j}")) for j in "ABCD" if f"joint_mass_{j}" in p},
            joint_damping=float(p.pop("joint_damping", 0.0)),
        )
    except KeyError as e:
        raise ParameterError(f"mechanism.{e.args[0]} is required for a four-bar") from None
    if p:
        raise ParameterError(f"unknown four-bar parameters: {sorted(p)}")
    return fb


def from_seed002(p: dict) -> FourBar:  # pragma: no cover - provided by the seed-002 issue
    raise ParameterError("seed-002 notation (r1..r4) is not implemented yet")
