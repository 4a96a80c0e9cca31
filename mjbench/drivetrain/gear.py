"""Gearbox (backlash, mesh stiffness, efficiency) and dry friction, in both backends.

**Compliant gear** (``backlash > 0`` or a ``stiffness``): the motor is its own coordinate θ_m
(expressed at the output, θ_m = φ/z, so the drive's reflected inertia and torque keep their
units), coupled to the crank α through the mesh deflection δ = θ_m − α:

    T_g = k·(δ − sgn δ·β/2) + c·δ̇   for |δ| > β/2 (contact),   T_g = 0 inside the play

on the crank (+T_g) and the motor (−T_g).  β: total play at the output; k: mesh stiffness at the
output (default: the motor inertia against the lighter output side resonates at
``mesh_frequency``, 1 kHz); c: contact damping (default from ``damping_ratio`` 0.1 of that
mode).  Multibody: a hinge ``drive_motor`` carrying the motor inertia (J_m + J_a)·z² and z²λ, and
a MuJoCo fixed tendon L = θ_m − α with a **dead-band spring** (``springlength = [−β/2, β/2]``,
``stiffness = k``); the contact damping is the tendon's ``damping``, switched on while in contact
(state at the start of the step; always on if β = 0).  These per-step model edits are part of
the load law :func:`driven_load`, writing through live NumPy views of the model's
``tendon_damping`` and ``dof_frictionloss``; in a batch every simulation has its own model
(``describe()`` makes the models distinct).  Reduced model: the same mesh law
(:func:`mesh_torque_law`) in the acceleration law :func:`compliant_accel` (the internal coordinate
``gear_deflection``, last), contact evaluated at every RK4 stage.  The crank keeps J_b.

**Efficiency** (rigid or compliant gear): the motor's net torque T_m (electromagnetic minus the
held Coulomb T_0) is scaled by η (T_m·φ̇ ≥ 0: the motor drives the load) or 1/η_back (the load
drives the motor) before it reaches the gear — exact for the mesh power at constant speed; the
rotor's own inertial torque is not charged with the loss (docs/drivetrain.md).

**Dry friction** (motor shaft, any joint): F(v) = F_C + (F_S − F_C)·exp(−(v/v_S)²) opposing the
motion, up to F_S while sticking.  Multibody: MuJoCo ``frictionloss`` on the joint (a soft
constraint: true stick, ``solref_friction = (2h, 1)``), its level updated at every step to
F(v at the start of the step) when F_S > F_C (Stribeck); the motor's friction sits on the
crank joint (×z, rigid gear) or on ``drive_motor`` (compliant).  Reduced model: the same law,
regularised as −F(|v|)·tanh(v/v_ε) with v_ε = 2·h·n·F_S·g²/J_min (g: the joint's speed ratio,
n: number of friction terms on the coordinate) so that the stick slope stays within RK4's
stability for any h; friction on a joint other than the crank is reduced to the crank through
the joint's speed ratio r_j(q) (tabulated once from the MuJoCo kinematics, rigid crank
mechanisms).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .. import compiled as C
from ..errors import ParameterError
from ..mechanisms.base import Mechanism, accel_call

MOTOR_JOINT = "drive_motor"       #: the motor's hinge in a compliant-gear multibody model
MESH_TENDON = "gear_mesh"         #: the fixed tendon θ_m − α carrying the mesh spring
DEFLECTION = "gear_deflection"    #: the internal coordinate δ = θ_m − α


#: the largest ω·h of a compliant gear's mesh mode a run accepts (RK4's stability limit on an undamped
#: mode is 2√2 ≈ 2.83; the margin covers the estimate of the lighter output side)
MESH_OMEGA_H = 2.5


def check_mesh(where: str, k: float, J_motor: float, J_out: float, h: float) -> None:
    """ParameterError naming ``where`` when a mesh of stiffness k between the motor (J_motor) and the
    lighter output side (J_out) resonates too fast for RK4 at step h: ω = √(k·(1/J_motor + 1/J_out))
    beyond ω·h = :data:`MESH_OMEGA_H` (both backends integrate by RK4 at h; such a run diverges)."""
    if not (J_motor > 0 and J_out > 0):  # (no inertia on a side: nothing RK4 could follow or miss)
        return
    w = math.sqrt(k * (1.0 / J_motor + 1.0 / J_out))
    if w * h > MESH_OMEGA_H:
        raise ParameterError(f"{where}: the gear's mesh (stiffness {k:.4g} N·m/rad) resonates at {w / (2 * math.pi):.4g} "
                             f"Hz against the motor; RK4 at dt = {h:g} s follows it up to "
                             f"{MESH_OMEGA_H / h / (2 * math.pi):.4g} Hz: lower the stiffness (or mesh_frequency) or "
                             f"make simulation.dt <= {MESH_OMEGA_H / w:.2g} s")


class Gear:
    """Backlash β [rad], stiffness k [N·m/rad] (None: from ``mesh_frequency`` [Hz]), contact
    damping c [N·m·s/rad] (None: from ``damping_ratio``), efficiencies η, η_back."""

    def __init__(self, backlash=0.0, stiffness=None, mesh_frequency=1000.0, damping=None,
                 damping_ratio=0.1, efficiency=1.0, efficiency_back=None):
        self.backlash, self.stiffness, self.mesh_frequency = backlash, stiffness, mesh_frequency
        self.damping, self.damping_ratio = damping, damping_ratio
        self.efficiency = efficiency
        self.efficiency_back = efficiency if efficiency_back is None else efficiency_back
        for name in ("efficiency", "efficiency_back"):
            v = np.asarray(getattr(self, name), dtype=float)
            if not np.all((v > 0) & (v <= 1)):
                raise ParameterError(f"drive.gear.{name} = {getattr(self, name)!r}: must be in (0, 1]")
        if np.any(np.asarray(backlash) < 0):
            raise ParameterError(f"drive.gear.backlash = {backlash!r}: must be >= 0")

    @property
    def compliant(self) -> bool:
        return bool(np.any(np.asarray(self.backlash) > 0)) or self.stiffness is not None

    @property
    def lossy(self) -> bool:
        return bool(np.any(np.asarray(self.efficiency) < 1) or np.any(np.asarray(self.efficiency_back) < 1))

    def describe(self) -> dict:
        return {"backlash_rad": _plain(self.backlash), "stiffness_Nm_rad": _plain(self.stiffness),
                "mesh_frequency_Hz": _plain(self.mesh_frequency), "damping_Nms_rad": _plain(self.damping),
                "damping_ratio": _plain(self.damping_ratio), "efficiency": _plain(self.efficiency),
                "efficiency_back": _plain(self.efficiency_back)}

    # ------------------------------------------------------------------ efficiency (law: gear_efficiency)
    def efficiency_params(self) -> "EfficiencyP":
        return EfficiencyP(float(self.efficiency), 1.0 / float(self.efficiency_back))

    def efficiency_form(self):
        """The kernel's EFF form (:func:`gear_efficiency`), None if the gear is lossless."""
        return C.Form(gear_efficiency, self.efficiency_params()) if self.lossy else None

    def transmitted_torque(self, Tm, w):
        """The torque the gear passes on for motor torque T_m at motor speed φ̇ (scalars or arrays)."""
        P = self.efficiency_params()
        return C.vectorize(lambda t, v: gear_efficiency(t, v, P), Tm, w)


#: the efficiency law's parameters: η (the motor drives the load) and 1/η_back (the load drives)
EfficiencyP = namedtuple("EfficiencyP", "eta inv_eta_back")


@C.law
def gear_efficiency(Tm, w, P):
    """The kernel's EFF slot: η·T_m when the motor drives the load (T_m·φ̇ ≥ 0), T_m/η_back when
    the load drives the motor."""
    return Tm * P.eta if Tm * w >= 0.0 else Tm * P.inv_eta_back


class Friction:
    """Dry friction: on the motor shaft (``coulomb``, ``breakaway``, ``stribeck_speed``, motor
    side) and per joint (``joints``: {name: {coulomb, breakaway, stribeck_speed, viscous}})."""

    def __init__(self, coulomb=0.0, breakaway=None, stribeck_speed=None, joints=None):
        self.coulomb = coulomb
        self.breakaway = coulomb if breakaway is None else breakaway
        self.stribeck_speed = stribeck_speed
        self.joints = {k: dict(v) for k, v in (joints or {}).items()}
        for name, law in [("motor", {"coulomb": self.coulomb, "breakaway": self.breakaway,
                                     "stribeck_speed": stribeck_speed})] + list(self.joints.items()):
            fc, fs = float(law.get("coulomb", 0.0)), law.get("breakaway")
            fs = fc if fs is None else float(fs)
            if fc < 0 or fs < fc:
                raise ParameterError(f"drive.friction {name}: need 0 <= coulomb <= breakaway, got {fc:g}, {fs:g}")
            if fs > fc and not law.get("stribeck_speed"):
                raise ParameterError(f"drive.friction {name}: breakaway > coulomb needs a stribeck_speed")

    def describe(self) -> dict:
        return {"coulomb_Nm": _plain(self.coulomb), "breakaway_Nm": _plain(self.breakaway),
                "stribeck_speed_rad_s": _plain(self.stribeck_speed), "joints": self.joints}


def _law(d):
    """(F_C, F_S, v_S) of a law dict (v_S = inf when there is no Stribeck drop)."""
    fc = float(d.get("coulomb", 0.0) or 0.0)
    fs = d.get("breakaway")
    fs = fc if fs is None else float(fs)
    vs = d.get("stribeck_speed")
    return fc, fs, (float(vs) if vs else math.inf)


def level(v, fc, fs, vs):
    """Friction level F(|v|) = F_C + (F_S − F_C)·exp(−(v/v_S)²) (:func:`friction_level`)."""
    return C.vectorize(lambda u: friction_level(u, float(fc), float(fs), float(vs)), v)


# ============================================================================ laws
@C.law
def friction_level(u, fc, fs, vs):
    """Friction level F(u) = F_C + (F_S − F_C)·exp(−(u/v_S)²) at a speed u ≥ 0 (F_C without a
    Stribeck drop, F_S = F_C)."""
    if fs == fc:
        return fc
    r = u / vs
    return fc + (fs - fc) * math.exp(-(r * r))


# Parameters are few arrays with one row per term (each array read in a law costs a reference
# count update in compiled code: a table of rows, not a tuple of columns).
#: columns of a friction-terms table (one row per term on one coordinate): F_C, F_S, v_S, gain on
#: the force g_F and on the speed g_v (the motor's friction seen through the gear: both z),
#: regularisation speed v_ε, viscous coefficient
TERM_COLUMNS = ("fc", "fs", "vs", "gF", "gv", "veps", "visc")
#: the crank's friction: its own terms (table, TERM_COLUMNS), the terms of joints away from the
#: crank (rows F_C, F_S, v_S, v_ε, viscous) with their speed ratios r_j(q) tabulated on N + 1
#: uniform nodes over one crank turn (R: (terms, N + 1), k = N/2π); whether there is any term
CrankFrictionP = namedtuple("CrankFrictionP", "terms oterms R k N any")


@C.law
def friction_terms(v, T):
    """Σ −g_F·F(|g_v·v|)·tanh(g_v·v/v_ε) − visc·v over a coordinate's friction terms (regularised
    dry friction, module docstring; T: one row per term, TERM_COLUMNS)."""
    out = 0.0
    for i in range(len(T)):
        out = friction_term(out, v, T, i)
    return out


@C.law
def friction_term(out, v, T, i):
    """``out`` with the friction of term (row) i of T at the speed v subtracted: out − g_F·F(|g_v·v|)·
    tanh(g_v·v/v_ε) − visc·v (:func:`friction_terms`' step; a machine with several motors: one row
    per axis, :mod:`mjbench.drivetrain.axes`)."""
    u = T[i, 4] * v
    return out - T[i, 3] * friction_level(abs(u), T[i, 0], T[i, 1], T[i, 2]) * math.tanh(u / T[i, 5]) - T[i, 6] * v


@C.law
def speed_ratio(q, R, i, k, n):
    """Joint i's speed ratio r_i(q): linear interpolation of its table R[i] (n + 1 nodes over one
    crank turn, periodic); NaN at a non-finite angle (a diverged run)."""
    u = q * k
    if not abs(u) < 1e15:
        return math.nan
    fl = math.floor(u)
    f = u - fl
    j = fl % n
    return R[i, j] + f * (R[i, j + 1] - R[i, j])


@C.law
def crank_friction(q, qd, P):
    """The friction torque on the crank [N·m]: its own terms (:func:`friction_terms`) and those of
    the other joints, −r_j·(F(|r_j·q̇|)·tanh(r_j·q̇/v_ε) + visc·r_j·q̇) with r_j = :func:`speed_ratio`."""
    tq = friction_terms(qd, P.terms)
    W = P.oterms
    if len(W) > 0:
        R = P.R
        for i in range(len(W)):
            rq = speed_ratio(q, R, i, P.k, P.N)
            u = rq * qd
            tq = tq - rq * (friction_level(abs(u), W[i, 0], W[i, 1], W[i, 2]) * math.tanh(u / W[i, 3]) + W[i, 4] * u)
    return tq


@C.law
def mesh_torque_law(d, dd, k, c, hb):
    """Mesh torque on the crank [N·m] at deflection δ and rate δ̇: k·(δ ∓ β/2) + c·δ̇ in contact
    (|δ| > β/2, hb = β/2), 0 inside the play; k·δ + c·δ̇ without play."""
    if hb == 0.0:
        return k * d + c * dd
    if d > hb:
        return k * (d - hb) + c * dd
    if d < -hb:
        return k * (d + hb) + c * dd
    return 0.0


#: the compliant gear's acceleration parameters: n internal coordinates (the deflection last), mesh
#: k, c, β/2, the crank-side drive inertia J_b, the crank's friction (``crank_any``: whether there is
#: any), the motor's friction terms (TERM_COLUMNS; ``motor_any``: whether there are any), the inner
#: mechanism's acceleration parameters
CompliantP = namedtuple("CompliantP", "n k c hb J_b crank crank_any motor motor_any inner")
#: a rigid gear with friction: the crank's friction and the inner mechanism's parameters
RigidFrictionP = namedtuple("RigidFrictionP", "crank inner")


@C.law
def compliant_accel(INNER, t, S, iy, ia, tau, Ja, c_add, P):
    """Accelerations of a mechanism behind a compliant gear (module docstring): the mesh torque
    T_g (:func:`mesh_torque_law`) plus the crank's friction drives the inner mechanism (its law
    INNER with the crank-side inertia J_b); the motor θ_m = α + δ (last coordinate) gets
    τ − c·θ̇_m − T_g + its friction over J_eq − J_b.  Writes (α̈, ẍ…, δ̈); → α̈."""
    n = P.n
    q = S[iy]
    qd = S[iy + 1]
    d = S[iy + 2 * n]
    dd = S[iy + 2 * n + 1]
    Tg = mesh_torque_law(d, dd, P.k, P.c, P.hb)
    Tc = Tg
    if P.crank_any:
        Tc = Tg + crank_friction(q, qd, P.crank)
    qdd = INNER(t, S, iy, ia, Tc, P.J_b, 0.0, P.inner)
    wm = qd + dd
    Tm = tau - c_add * wm - Tg
    if P.motor_any:
        Tm = Tm + friction_terms(wm, P.motor)
    S[ia + n] = Tm / (Ja - P.J_b) - qdd
    return qdd


@C.law
def friction_accel(INNER, t, S, iy, ia, tau, Ja, c_add, P):
    """Accelerations of a mechanism with internal coordinates behind a rigid gear with friction:
    the inner law under τ + the crank's friction."""
    return INNER(t, S, iy, ia, tau + crank_friction(S[iy], S[iy + 1], P.crank), Ja, c_add, P.inner)


@C.law
def friction_model(MODEL, q, qd, t, P):
    """The reduced model of a rigid mechanism behind a rigid gear with friction: the inner model
    law with the crank's friction added to Q_ext."""
    J, H, E, Q = MODEL(q, qd, t, P.inner)
    return J, H, E, Q + crank_friction(q, qd, P.crank)


#: the MuJoCo loads of a driven mechanism: qpos, qvel, qfrc_applied (live), the crank dof (its
#: applied force zeroed under a compliant gear), flags, the motor and crank qpos, the mesh tendon,
#: its contact damping c and β/2, tendon_damping (live, MjModel); Stribeck dofs (sdof, terms
#: sptr[k]..sptr[k+1] of each, rows F_C, F_S, v_S, g_F, g_v), dof_frictionloss (live, MjModel); the
#: inner loads' P
DrivenLoadP = namedtuple("DrivenLoadP", "qpos qvel qfrc vc compliant toggle qm qc tendon c hb tdamp sdof sptr sterms "
                                        "floss inner")


@C.law
def driven_load(INNER, t, P):
    """The MuJoCo loads of a driven mechanism, before each step: the crank's applied force zeroed
    under a compliant gear (the drive torque acts on the motor hinge), the inner mechanism's loads
    (INNER), then the per-step model edits from the state at the step's start — the mesh's
    contact damping on while in contact, the Stribeck friction level F(|v|) of each dof."""
    if P.compliant:
        P.qfrc[P.vc] = 0.0
    INNER(t, P.inner)
    if P.toggle:
        d = P.qpos[P.qm] - P.qpos[P.qc]
        P.tdamp[P.tendon] = P.c if abs(d) > P.hb else 0.0
    sdof = P.sdof
    if len(sdof) > 0:
        sptr = P.sptr
        W = P.sterms
        qvel = P.qvel
        floss = P.floss
        for k in range(len(sdof)):
            dof = sdof[k]
            v = qvel[dof]
            F = 0.0
            for i in range(sptr[k], sptr[k + 1]):
                F += W[i, 3] * friction_level(abs(W[i, 4] * v), W[i, 0], W[i, 1], W[i, 2])
            floss[dof] = F


@C.law
def no_load(t, P):
    """No MuJoCo load (a driven mechanism whose inner mechanism has none)."""
    return None


def _terms_params(terms) -> np.ndarray:
    """The friction-terms table (one row per term, TERM_COLUMNS)."""
    return np.array(terms, dtype=float).reshape(-1, len(TERM_COLUMNS))


class DrivenMechanism(Mechanism):
    """A mechanism with the drive train's mechanical elements (compliant gear, friction) added to
    both of its models.  Everything else is the wrapped mechanism's (``inner``)."""

    Params = None

    def __init__(self, inner, drive, gear=None, friction=None):
        self.inner = inner
        self.type_name = inner.type_name
        self.input_joint = inner.input_joint
        self.view = inner.view
        self.gear, self.friction = gear, friction
        self.compliant = gear is not None and gear.compliant
        self.drive_joint = MOTOR_JOINT if self.compliant else inner.input_joint
        self.internal = tuple(inner.internal) + ((DEFLECTION,) if self.compliant else ())
        # the tabulated reduced model (mjbench.backends.table) tabulates the inner mechanism's J, J', E_p'
        # (periodic in q); the friction is a law added at every stage (model_form)
        self.reduced_period = getattr(inner, "reduced_period", None)
        self.z = float(drive.z)
        self.J_b = float(drive.J_b)
        self.J_mo = float(drive.J_eq) - self.J_b  # motor + pinion inertia at the output
        self._Jmin_mech = _min_inertia(inner)
        if self.compliant:
            if self.J_mo <= 0:
                raise ParameterError("drive.gear: a compliant gear (backlash or stiffness) needs a motor inertia "
                                     "drive.J_m + drive.J_a > 0 (the motor becomes its own coordinate)")
            self.beta = float(gear.backlash)
            Jc = self.J_b + self._Jmin_mech
            Jr = self.J_mo * Jc / (self.J_mo + Jc)
            w = 2.0 * math.pi * float(gear.mesh_frequency)
            self.k = float(gear.stiffness) if gear.stiffness is not None else Jr * w * w
            self.c = float(gear.damping) if gear.damping is not None else \
                2.0 * float(gear.damping_ratio) * math.sqrt(self.k * Jr)
        else:
            self.beta = self.k = self.c = 0.0
        # friction laws: motor (at the motor shaft) and joints
        self._motor_law = None
        self._joint_laws = {}
        if friction is not None:
            m = _law({"coulomb": friction.coulomb, "breakaway": friction.breakaway,
                      "stribeck_speed": friction.stribeck_speed})
            if m[1] > 0:
                self._motor_law = m
            for name, d in friction.joints.items():
                law = _law(d)
                visc = float(d.get("viscous", 0.0) or 0.0)
                if law[1] > 0 or visc > 0:
                    self._joint_laws[name] = (*law, visc)
        self._h = None
        self._mj = {}

    # ------------------------------------------------------------------ delegation
    def __getattr__(self, name):
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    @classmethod
    def from_params(cls, params):  # pragma: no cover - built by the drive train, not from a table
        raise TypeError("DrivenMechanism wraps a mechanism; build it with DriveTrain.wrap")

    def reduced(self, q):
        return self.inner.reduced(q)

    def potential_energy(self, q):
        return self.inner.potential_energy(q)

    def kinetic_energy(self, q, qd):
        return self.inner.kinetic_energy(q, qd)

    def points(self, q):
        return self.inner.points(q)

    def trace_point(self, q):
        return self.inner.trace_point(q)

    def closure_error(self, model, data):
        return self.inner.closure_error(model, data)

    def closure_form(self, model, data):
        return self.inner.closure_form(model, data)

    def render_view(self):
        return self.inner.render_view()

    def linkage_view(self):
        return self.inner.linkage_view()

    def kinematics(self, q):
        return self.inner.kinematics(q)

    def input_positions(self, n: int):
        return self.inner.input_positions(n)

    def describe(self) -> dict:
        d = dict(self.inner.describe())
        dt = {}
        if self.gear is not None:
            dt["gear"] = {**self.gear.describe(), "stiffness_used_Nm_rad": self.k, "damping_used_Nms_rad": self.c}
        if self.friction is not None:
            dt["friction"] = self.friction.describe()
        if self.needs_model_edits:
            dt["instance"] = id(self)  # per-step model edits: one compiled model per simulation in a batch
        d["drivetrain"] = dt
        return d

    @property
    def has_stribeck(self) -> bool:
        laws = ([self._motor_law] if self._motor_law else []) + list(self._joint_laws.values())
        return any(law[1] > law[0] for law in laws)

    @property
    def toggles_damping(self) -> bool:
        return self.compliant and self.beta > 0 and self.c > 0

    @property
    def needs_model_edits(self) -> bool:
        return self.has_stribeck or self.toggles_damping

    # ------------------------------------------------------------------ step-size dependent set-up
    def set_step(self, h):
        """Prepare the reduced model's friction regularisation for co-simulation step h [s]: the
        parameters of the friction laws (v_ε = 2·h·n·F_S·g²/J_min, module docstring)."""
        if self._h == h:
            return
        if self.compliant:
            check_mesh("drive.gear", self.k, self.J_mo, self.J_b + self._Jmin_mech, float(h))
        self._h = float(h)
        crank_terms, motor_terms, others = [], [], []
        z = self.z
        if self._motor_law is not None:
            (motor_terms if self.compliant else crank_terms).append((self._motor_law, z, z))
        for name, (fc, fs, vs, visc) in self._joint_laws.items():
            if name == self.input_joint:
                crank_terms.append(((fc, fs, vs), 1.0, 1.0, visc))
            elif name == MOTOR_JOINT:
                raise ParameterError("drive.friction.joints.drive_motor: use [drive.friction] (the motor shaft)")
            else:
                others.append((name, (fc, fs, vs), visc))
        J_crank = (self.J_b if self.compliant else self.J_b + self.J_mo) + self._Jmin_mech
        table = self._speed_ratios([n for n, _, _ in others]) if others else {}
        n_c = len(crank_terms) + len(others)
        self._crank_terms = []
        for term in crank_terms:
            (fc, fs, vs), gF, gv = term[:3]
            visc = term[3] if len(term) > 3 else 0.0
            veps = 2.0 * h * max(n_c, 1) * fs * gF * gv / J_crank if fs > 0 else 1.0
            self._crank_terms.append((fc, fs, vs, gF, gv, max(veps, 1e-12), visc))
        self._other_terms = []
        for name, (fc, fs, vs), visc in others:
            qg, r = table[name]
            rmax = float(np.max(np.abs(r))) or 1.0
            veps = 2.0 * h * max(n_c, 1) * fs * rmax * rmax / J_crank if fs > 0 else 1.0
            self._other_terms.append((fc, fs, vs, qg, r, max(veps / rmax, 1e-12), visc))
        self._motor_terms = []
        for (fc, fs, vs), gF, gv in motor_terms:
            veps = 2.0 * h * fs * gF * gv / self.J_mo if fs > 0 else 1.0
            self._motor_terms.append((fc, fs, vs, gF, gv, max(veps, 1e-12), 0.0))
        self._has_crank_friction = bool(self._crank_terms or self._other_terms)
        # the laws' parameters
        nodes = SPEED_RATIO_NODES
        O = self._other_terms
        R = np.array([r for _, _, _, _, r, _, _ in O], dtype=float).reshape(-1, nodes + 1)
        W = np.array([(t[0], t[1], t[2], t[5], t[6]) for t in O], dtype=float).reshape(-1, 5)
        self._crank_P = CrankFrictionP(_terms_params(self._crank_terms), W, np.ascontiguousarray(R),
                                       nodes / (2.0 * math.pi), nodes, bool(self._has_crank_friction))
        self._motor_P = _terms_params(self._motor_terms)

    def _ensure_step(self):
        if self._h is None:
            self.set_step(1e-4)

    def _speed_ratios(self, names):
        """{joint: (q grid, dθ_j/dq on it)} over one crank turn (SPEED_RATIO_NODES + 1 uniform
        nodes, both ends), from the MuJoCo kinematics."""
        if self.inner.internal:
            raise ParameterError(f"drive.friction.joints: friction on {', '.join(names)} needs a rigid mechanism in "
                                 f"the reduced model ({self.inner.type_name} has internal coordinates); use the "
                                 f"multibody backend or friction on the input joint")
        spec = self.inner.build_spec(0.0, {"timestep": self._h})
        m = spec.compile()
        qg = np.linspace(0.0, 2.0 * math.pi, SPEED_RATIO_NODES + 1)
        out = {}
        for n in names:
            try:
                dof = int(m.joint(n).dofadr[0])
            except KeyError:
                raise ParameterError(f"drive.friction.joints.{n}: no joint {n!r} in the mechanism's model") from None
            out[n] = (qg, np.array([self.inner.initial_qvel(m, float(q), 1.0)[dof] for q in qg]))
        return out

    # ------------------------------------------------------------------ reduced model (laws)
    def _terms_torque(self, terms, v):
        """Σ −g_F·F(|g_v·v|)·tanh(g_v·v/v_ε) − visc·v over one coordinate's friction terms
        (:func:`friction_terms`)."""
        P = _terms_params(terms)
        return C.vectorize(lambda x: friction_terms(x, P), v)

    def _crank_friction(self, q, qd):
        """The crank's friction torque (:func:`crank_friction`) at (q, q̇), scalars or arrays."""
        self._ensure_step()
        P = C.python_view(self._crank_P)
        return C.vectorize(lambda a, b: crank_friction(a, b, P), q, qd)

    def external_torque(self, q, qd, t):
        ext = self.inner.external_torque(q, qd, t)
        if not self.compliant and (self._motor_law is not None or self._joint_laws):
            self._ensure_step()
            if self._has_crank_friction:
                ext = ext + self._crank_friction(q, qd)
        return ext

    def has_external_torque(self) -> bool:
        return self.inner.has_external_torque() or (not self.compliant and bool(self._motor_law or self._joint_laws))

    def reduced_viscous(self, q):
        return None

    def mesh_torque(self, d, dd):
        """Mesh torque on the crank [N·m] for deflection δ [rad] and rate δ̇ [rad/s] (output side;
        :func:`mesh_torque_law`)."""
        k, c, hb = self.k, self.c, 0.5 * self.beta
        return C.vectorize(lambda a, b: mesh_torque_law(a, b, k, c, hb), d, dd)

    def model_form(self):
        """The crank's reduced model: the inner mechanism's model law plus the crank's friction
        (:func:`friction_model`; the inner model alone without friction)."""
        self._ensure_step()
        inner = self.inner.model_form()
        if not self._has_crank_friction:
            return inner
        return C.Form(friction_model, RigidFrictionP(self._crank_P, inner.P), fn_args=(inner,),
                      flags=dict(inner.flags))

    def accel_form(self):
        """The accelerations: :func:`compliant_accel` (compliant gear) or :func:`friction_accel`
        (rigid gear, an inner mechanism with internal coordinates) around the inner mechanism's law."""
        self._ensure_step()
        if not self.compliant:
            if not self.internal:
                return super().accel_form()
            inner = self.inner.accel_form()
            if not self._has_crank_friction:
                return inner
            return C.Form(friction_accel, RigidFrictionP(self._crank_P, inner.P), fn_args=(inner,),
                          flags=dict(inner.flags))
        inner = self.inner.accel_form()
        P = CompliantP(len(self.internal), float(self.k), float(self.c), 0.5 * float(self.beta), float(self.J_b),
                       self._crank_P, bool(self._has_crank_friction), self._motor_P, bool(len(self._motor_P)),
                       inner.P)
        return C.Form(compliant_accel, P, fn_args=(inner,), flags=dict(inner.flags))

    def reduced_accel(self, t, q, qd, x, xd, tau, J_add, c_add):
        if not self.internal:
            self._ensure_step()
            if self._has_crank_friction:
                tau = tau + self._crank_friction(q, qd)
            return self.inner.reduced_accel(t, q, qd, x, xd, tau, J_add, c_add)
        return accel_call(self.accel_form(), t, q, qd, x, xd, tau, J_add, c_add)

    # ------------------------------------------------------------------ multibody model
    def build_spec(self, armature: float = 0.0, options=None):
        import mujoco

        o = dict(options or {})
        h = float(o.get("timestep", 1e-4))
        inner = self.inner
        if self.compliant:
            check_mesh("drive.gear", self.k, self.J_mo, self.J_b + self._Jmin_mech, h)
            spec = inner.build_spec(armature=self.J_b, options=options)
            axis = [float(a) for a in spec.joint(self.input_joint).axis]
            rotor = spec.worldbody.add_body(name="drive_motor_rotor", pos=[0.0, 0.0, 0.0])
            rotor.mass = 1e-9
            rotor.ipos = [0.0, 0.0, 0.0]
            rotor.inertia = [1e-12, 1e-12, 1e-12]
            rotor.explicitinertial = True
            j = rotor.add_joint(name=MOTOR_JOINT, type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis)
            j.armature = float(armature) - self.J_b
            t = spec.add_tendon(name=MESH_TENDON)
            t.wrap_joint(MOTOR_JOINT, 1.0)
            t.wrap_joint(self.input_joint, -1.0)
            t.stiffness = [self.k, 0.0, 0.0]
            t.springlength = [-0.5 * self.beta, 0.5 * self.beta]
            t.damping = [self.c if self.beta == 0.0 else 0.0, 0.0, 0.0]
        else:
            spec = inner.build_spec(armature=armature, options=options)
        levels = {}
        if self._motor_law is not None:
            levels[self.drive_joint] = levels.get(self.drive_joint, 0.0) + self.z * self._motor_law[1]
        for name, (fc, fs, vs, visc) in self._joint_laws.items():
            try:
                j = spec.joint(name)
            except Exception:  # noqa: BLE001
                j = None
            if j is None:
                raise ParameterError(f"drive.friction.joints.{name}: no joint {name!r} in the mechanism's model")
            if fs > 0:
                levels[name] = levels.get(name, 0.0) + fs
            if visc > 0:
                j.damping = [float(j.damping[0]) + visc, 0.0, 0.0]
        for name, F in levels.items():
            j = spec.joint(name)
            j.frictionloss = float(F)
            j.solref_friction = [2.0 * h, 1.0]
        return spec

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        xi = tuple(x0[:-1]) if (x0 and self.compliant) else x0
        qpos = self.inner.initial_qpos(model, q0, xi or None)
        if self.compliant:
            qpos[model.joint(MOTOR_JOINT).qposadr[0]] = q0 + (float(x0[-1]) if x0 else 0.0)
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        xi = tuple(x0[:-1]) if (x0 and self.compliant) else x0
        xdi = tuple(xd0[:-1]) if (xd0 and self.compliant) else xd0
        qvel = self.inner.initial_qvel(model, q0, qd0, xi or None, xdi or None)
        if self.compliant:
            qvel[model.joint(MOTOR_JOINT).dofadr[0]] = qd0 + (float(xd0[-1]) if xd0 else 0.0)
        return qvel

    def internal_state(self, model, qpos, qvel):
        x, xd = self.inner.internal_state(model, qpos, qvel)
        if not self.compliant:
            return x, xd
        ids = self._ids(model)
        return ((*x, qpos[..., ids["qm"]] - qpos[..., ids["qc"]]),
                (*xd, qvel[..., ids["vm"]] - qvel[..., ids["vc"]]))

    def internal_index(self, model):
        """The inner mechanism's rows, then the deflection δ = θ_m − α (compliant gear)."""
        rows = self.inner.internal_index(model) if self.inner.internal else np.zeros((0, 5))
        if rows is None:
            return None
        if not self.compliant:
            return rows
        ids = self._ids(model)
        return np.vstack([rows, [[ids["qm"], ids["qc"], ids["vm"], ids["vc"], 1.0]]])

    def motor_index(self, model):
        """The motor hinge ``drive_motor`` (qpos, dof) under a compliant gear."""
        if not self.compliant:
            return self.inner.motor_index(model)
        ids = self._ids(model)
        return ids["qm"], ids["vm"]

    def _ids(self, model):
        key = id(model)
        ids = self._mj.get(key)
        if ids is not None and ids["model"] is model:
            return ids
        jc = model.joint(self.input_joint)
        ids = {"model": model, "qc": int(jc.qposadr[0]), "vc": int(jc.dofadr[0])}
        if self.compliant:
            jm = model.joint(MOTOR_JOINT)
            ids.update(qm=int(jm.qposadr[0]), vm=int(jm.dofadr[0]), tendon=int(model.tendon(MESH_TENDON).id))
        # Stribeck: per dof, the laws whose level is updated every step (gain on force, gain on speed)
        strib = {}
        if self._motor_law is not None and self._motor_law[1] > self._motor_law[0]:
            strib.setdefault(int(model.joint(self.drive_joint).dofadr[0]), []).append((self._motor_law, self.z, self.z))
        for name, (fc, fs, vs, visc) in self._joint_laws.items():
            dof = int(model.joint(name).dofadr[0])
            strib.setdefault(dof, []).append(((fc, fs, vs), 1.0, 1.0))
        # a dof is updated if one of its laws has a Stribeck drop (the others' levels are constant)
        ids["stribeck"] = [(dof, laws) for dof, laws in strib.items() if any(lw[0][1] > lw[0][0] for lw in laws)]
        self._mj[key] = ids
        return ids

    def has_multibody_load(self) -> bool:
        return self.compliant or self.inner.has_multibody_load() or self.needs_model_edits

    def load_form(self, model, data):
        """The MuJoCo loads as a law (:func:`driven_load` around the inner mechanism's loads), the
        model edits through live views of ``model.tendon_damping`` and ``model.dof_frictionloss``."""
        if not self.has_multibody_load():
            return None
        ids = self._ids(model)
        inner = self.inner.load_form(model, data) if self.inner.has_multibody_load() else None
        if inner is None:
            inner = C.Form(no_load)
        sdof, sptr, terms = [], [0], []
        for dof, laws in ids["stribeck"]:
            sdof.append(dof)
            for (fc, fs, vs), gF, gv in laws:
                terms.append((fc, fs, vs, gF, gv))
            sptr.append(len(terms))
        P = DrivenLoadP(data.qpos, data.qvel, data.qfrc_applied, ids["vc"], bool(self.compliant),
                        bool(self.toggles_damping), ids.get("qm", 0), ids["qc"], ids.get("tendon", 0),
                        float(self.c), 0.5 * float(self.beta), model.tendon_damping,
                        np.array(sdof, dtype=np.int64), np.array(sptr, dtype=np.int64),
                        np.array(terms, dtype=float).reshape(-1, 5), model.dof_frictionloss, inner.P)
        return C.Form(driven_load, P, fn_args=(inner,))

    def multibody_load(self, model, data, t: float) -> None:
        f = self.load_form(model, data)
        if f is not None:
            f.bound()(float(t), C.python_view(f.P))


#: nodes of the tabulated speed ratios of joints with friction (one crank turn)
SPEED_RATIO_NODES = 1024


def _min_inertia(mech) -> float:
    """Smallest rigid inertia J(q) of the mechanism over one input turn [kg·m²]."""
    q = np.linspace(0.0, 2.0 * math.pi, 721)
    try:
        J = np.asarray(mech.reduced(q)[0], dtype=float)
        if J.shape != q.shape:
            J = np.broadcast_to(J, q.shape)
    except Exception:  # noqa: BLE001 - a mechanism whose reduced() only takes floats
        J = np.array([float(mech.reduced(float(v))[0]) for v in q])
    return float(np.min(J))


def _plain(v):
    if v is None:
        return None
    return v.tolist() if isinstance(v, np.ndarray) else float(v)
