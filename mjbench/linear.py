"""Linear analysis of a machine with python-control: plant, controller, loop, margins, modes.

A machine (mechanism + drive + controller) is linearised at an *operating point* — input angle
q*, input speed q̇* (crank side, rad/s), current I*, time t* (for K_p·t and time-dependent loads);
by default I* is the current that holds q̈ = 0 at (q*, q̇*), so that the point is stationary at
that instant (:func:`operating_point`).  Everything returned is a python-control object
(``control.StateSpace``) with named signals, or a small dataclass of plain numbers.

Plant (input ``V`` [V]; outputs ``q`` [rad], ``qd`` [rad/s], ``I`` [A], the internal coordinates):

* :func:`reduced_plant` — the reduced (Eksergian) model, seed 000 Eqs 5-9, with its *analytic*
  Jacobian (chain rule on J, J', E_p' of the mechanism; the second derivatives J'', E_p'' and the
  derivatives of Q_ext by central differences of the mechanism's analytic J' and E_p'; mechanisms
  with internal coordinates — the elastic platforms, linear — by central differences of
  ``reduced_accel``) and the motor equation L·İ = V − R·I − k_m·z·q̇.
* :func:`multibody_plant` — the MJCF model linearised by MuJoCo's ``mjd_transitionFD``.  It does
  not support the RK4 integrator our models use, so the model is copied with the semi-implicit
  Euler integrator and implicit damping off (``eulerdamp`` disabled): then qvel⁺ = qvel + h·q̈
  exactly, and the qvel rows of the transition matrix give the *continuous-time* acceleration
  Jacobian ∂q̈/∂(qpos, qvel, τ) to finite-difference precision, for any h.  Loads the mechanism
  applies from Python (``multibody_load``, e.g. seed 002's hinge-C friction) are differentiated
  separately and added through ∂q̈/∂qfrc.  State: qpos/qvel of every joint, I.  With
  ``coordinates="input"`` the model is expressed in the reduced coordinates (q, x, q̇, ẋ) through
  the embedding of the assembled configuration (A_r = S·A·E): this is the form that can be
  compared with the reduced model at a *running* point — frozen-time Jacobians of a moving
  linkage depend on the coordinates (a term Φ̇Φ⁻¹ of order q̇*), docs/linear.md §2.
* ``h=`` gives, instead of the continuous model, the kernel's **co-step** at h: the mechanics
  with the drive torque held over the step (exact ZOH), composed with the drive's discrete
  current update exactly as :mod:`mjbench.kernel` does it (torque from the mean current over the
  step, :meth:`DCMotorDrive.current_mean`; I⁺ with the mean of the speeds at both ends,
  :meth:`DCMotorDrive.current_step`).  :func:`sample` lifts it to the controller period N·h and
  adds the output ``qd_prev`` (the speed one co-step before the sample, which the kernel's
  backward-difference acceleration uses).

Controllers (:func:`controller_counterpart`), **discrete-time at the controller's period**: the
kernel samples the controller every ``period`` (0: every co-step) and holds V (ZOH), the PID
derivative and the SMC surface use the backward difference of the speed over one co-step, and
the K_p·t ramp of seed 000 loses stability through sampling — none of which a continuous model
shows.  Inputs ``q_set``, ``qd_set`` (exogenous set-points, input side) and the measurements
``q``, ``qd``, ``qd_prev``, ``I``; output ``V``.  The reference is part of the counterpart: seed
002's coupler-speed reference q̇_trj(q) depends on the *measured* angle, which closes one more
loop.  Saturation (v_limit, anti-windup) is assumed inactive.  Each counterpart is a capability of
the controller's class (``Controller.linear``, ``Controller.linear_reference``, the reference's
``linear``): a new controller brings its own, and one without it gets a ParameterError saying so.

Loop (:func:`loop`): broken at the plant input V — L = −C·P, S = 1/(1 + L), T = L/(1 + L) built
with ``control.feedback``, the closed loop (set-points and an input disturbance ``d`` → q, q̇, I,
V) with ``control.interconnect``; :func:`margins`: gain/phase margins and peak |S| from the
exact response of L on a dense grid with every crossing refined (:func:`loop_margins`; equal to
``control.stability_margins(method="poly")`` where that is reliable, see the tests), the −3 dB
bandwidth of the set-point response q̇/q̇_set, closed-loop poles.

Angle dependence (:func:`frozen_angle_family`): the loop at frozen angles q over one turn at the
running speed, worst-case margins and where they occur, and the frozen-angle validity number
(the inertia variation rate max|J'·q̇/J_tot| over the loop bandwidth).
"""
from __future__ import annotations

import cmath
import dataclasses
import math
from collections import namedtuple
from dataclasses import dataclass, field

import numpy as np

from controllers.reference import Reference as _Reference

from .compiled import law
from .errors import ParameterError

FD_Q = 1e-6  #: [rad] central-difference step for second derivatives in q
FD_MB = 1e-6  #: finite-difference epsilon handed to mjd_transitionFD
LOCK_FACTOR = 1e12  #: locked-input limit: the input inertia multiplied by this
MEAS = ("q", "qd", "qd_prev", "I")  #: measurement signals a controller counterpart may use
SETPOINTS = ("q_set", "qd_set")


def _ct():
    import control
    return control


# ============================================================================ operating point
@dataclass
class OperatingPoint:
    """Where the machine is linearised (SI, input side): angle q [rad], speed qd [rad/s],
    current I [A], voltage V [V] (R·I + k_m·z·q̇, dI/dt = 0), drive torque tau [N·m] (without
    the viscous part), acceleration qdd [rad/s²] at that state, time t [s], internal coordinates
    x and rates xd."""

    q: float
    qd: float
    I: float
    V: float
    tau: float
    qdd: float = 0.0
    t: float = 0.0
    x: tuple = ()
    xd: tuple = ()

    def as_dict(self) -> dict:
        return {"q_rad": self.q, "qd_rad_s": self.qd, "I_A": self.I, "V_V": self.V, "tau_Nm": self.tau,
                "qdd_rad_s2": self.qdd, "t_s": self.t, "x": list(self.x), "xd": list(self.xd)}


def _sgn(v):
    return 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)


def _accel(machine, q, qd, x, xd, tau, t):
    """(q̈, ẍ) of the reduced model (drive inertia and viscous friction included)."""
    d = machine.drive
    return machine.mechanism.reduced_accel(t, q, qd, tuple(x), tuple(xd), tau, float(d.J_eq), float(d.crank_damping))


def _holding_torque(machine, q, qd, x, xd, t):
    """Drive torque τ that gives q̈ = 0 at the state (q̈ is affine in τ)."""
    a0 = _accel(machine, q, qd, x, xd, 0.0, t)[0]
    a1 = _accel(machine, q, qd, x, xd, 1.0, t)[0]
    return -a0 / (a1 - a0)


def operating_point(machine, q=0.0, qd=0.0, I=None, t=0.0, x=None, xd=None, n_mean: int = 72) -> OperatingPoint:
    """The operating point at (q, q̇) [rad, rad/s].  ``I=None``: at rest (q̇ = 0) the current that
    holds q̈ = 0 there (gravity balanced); running (q̇ ≠ 0) the current that sustains the speed
    on average over a turn (the mean of the holding currents at q̇ over ``n_mean`` angles): a
    linkage running at constant speed is not at a stationary point — its q̈* ≠ 0 follows.  The
    frozen-angle model (:func:`freeze_angle`) does not depend on I*."""
    mech, d = machine.mechanism, machine.drive
    nx = len(mech.internal)
    x = tuple(float(v) for v in (x or (0.0,) * nx))
    xd = tuple(float(v) for v in (xd or (0.0,) * nx))
    for name, v in (("q", q), ("omega", qd), ("t", t)):
        if not math.isfinite(float(v)):
            raise ParameterError(f"operating point {name} = {v!r}: must be finite")
    q, qd, t = float(q), float(qd), float(t)
    z, km = float(d.z), float(d.k_m)
    fric = float(d.T_0) * _sgn(z * qd)
    if I is None:
        if qd == 0.0:
            tau = _holding_torque(machine, q, qd, x, xd, t)
        else:
            qs = np.linspace(0.0, 2 * np.pi, int(n_mean), endpoint=False)
            tau = float(np.mean([_holding_torque(machine, qq, qd, x, xd, t) for qq in qs]))
        I = (tau / z + fric) / km
    I = float(I)
    if not math.isfinite(I):
        raise ParameterError(f"operating point current I = {I!r}: must be finite")
    tau = z * (km * I - fric)
    V = float(d.R) * I + km * z * qd
    qdd = float(_accel(machine, q, qd, x, xd, tau, t)[0])
    return OperatingPoint(q, qd, I, V, tau, qdd, t, x, xd)


# ============================================================================ mechanics
@dataclass
class Mechanics:
    """Continuous-time linearised mechanics under the held drive torque τ: ẋ = A·x + B·τ.
    ``states``: names; ``rows``: output name → row vector (``q``, ``qd`` and the internal
    coordinates); ``coords``: "input" (q, x, q̇, ẋ) or "model" (MuJoCo qpos, qvel);
    ``embedding``: for model coordinates, ∂(qpos, qvel)/∂(q, x, q̇, ẋ) at the point."""

    A: np.ndarray
    B: np.ndarray
    states: list
    rows: dict
    coords: str = "input"
    embedding: np.ndarray | None = None


def rigid_mechanics(J: float, c: float) -> Mechanics:
    """A constant inertia J [kg·m²] (drive included) with viscous friction c [N·m·s/rad] on the
    input: J·q̈ = τ − c·q̇ — the textbook DC-motor load, e.g. a linkage at its lap-mean inertia."""
    if not (J > 0 and math.isfinite(J)) or not (c >= 0 and math.isfinite(c)):
        raise ParameterError(f"rigid_mechanics: J = {J!r} must be > 0, c = {c!r} >= 0")
    A = np.array([[0.0, 1.0], [0.0, -c / J]])
    B = np.array([[0.0], [1.0 / J]])
    return Mechanics(A, B, ["q", "qd"], {"q": np.array([1.0, 0.0]), "qd": np.array([0.0, 1.0])}, "input")


def _input_names(mech):
    xs = list(mech.internal)
    return ["q", *xs, "qd", *[f"{n}_rate" for n in xs]]


def reduced_mechanics(machine, op: OperatingPoint) -> Mechanics:
    """Jacobian of the reduced model at ``op`` (states q, x, q̇, ẋ; input τ)."""
    from .mechanisms.base import Mechanism

    mech, d = machine.mechanism, machine.drive
    nx = len(mech.internal)
    n = 2 + 2 * nx
    A = np.zeros((n, n))
    B = np.zeros((n, 1))
    A[: 1 + nx, 1 + nx:] = np.eye(1 + nx)  # d(q, x)/dt = (q̇, ẋ)
    q, qd, t = op.q, op.qd, op.t
    if nx == 0 and type(mech).reduced_accel is Mechanism.reduced_accel:
        # rigid Eksergian model (seed 000 Eq 5 + Eq 9): analytic chain rule
        J, dJ, dEp = (float(v) for v in mech.reduced(q))
        Jt = float(d.J_eq) + J
        c = float(d.crank_damping)
        e = FD_Q
        _, dJp, dEpp = mech.reduced(q + e)
        _, dJm, dEpm = mech.reduced(q - e)
        ddJ = (float(dJp) - float(dJm)) / (2 * e)
        ddEp = (float(dEpp) - float(dEpm)) / (2 * e)
        Qq = (float(mech.external_torque(q + e, qd, t)) - float(mech.external_torque(q - e, qd, t))) / (2 * e)
        Qv = (float(mech.external_torque(q, qd + e, t)) - float(mech.external_torque(q, qd - e, t))) / (2 * e)
        qdd = op.qdd
        A[1, 0] = (Qq - ddEp - 0.5 * ddJ * qd * qd - dJ * qdd) / Jt
        A[1, 1] = (-c + Qv - dJ * qd) / Jt
        B[1, 0] = 1.0 / Jt
    else:
        # internal coordinates (elastic platforms: linear): central differences of reduced_accel
        x0 = np.array([q, *op.x, qd, *op.xd], dtype=float)

        def f(xv, tau):
            a, b = _accel(machine, xv[0], xv[1 + nx], xv[1:1 + nx], xv[2 + nx:], tau, t)
            return np.array([a, *b], dtype=float)

        for j in range(n):
            step = FD_Q * max(1.0, abs(x0[j]))
            xp, xm = x0.copy(), x0.copy()
            xp[j] += step
            xm[j] -= step
            A[1 + nx:, j] = (f(xp, op.tau) - f(xm, op.tau)) / (2 * step)
        st = FD_Q * max(1.0, abs(op.tau))
        B[1 + nx:, 0] = (f(x0, op.tau + st) - f(x0, op.tau - st)) / (2 * st)
    names = _input_names(mech)
    rows = {nm: np.eye(n)[i] for i, nm in enumerate(names) if not nm.endswith("_rate")}
    return Mechanics(A, B, names, rows, "input")


def _require_hinges(m):
    if m.nq != m.nv:
        raise ParameterError("multibody linearisation: the model has ball/free joints (nq != nv); only hinge "
                             "and slide joints are supported")


def multibody_mechanics(machine, op: OperatingPoint, options=None) -> Mechanics:
    """Continuous-time Jacobian of the MJCF model at ``op`` from ``mujoco.mjd_transitionFD``
    (states: qpos and qvel of every joint; input τ on the input joint); see the module doc."""
    import mujoco

    from .backends.multibody import DEFAULT_OPTIONS, build_model

    o = {**DEFAULT_OPTIONS, **(options or {})}
    o["integrator"] = "Euler"
    mech = machine.mechanism
    spec, m0 = build_model(machine, o)
    _require_hinges(m0)
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    joints = [m0.joint(j).name for j in range(m0.njnt)]
    for jn in joints:  # one unit-gain force actuator per joint: ∂q̈/∂qfrc, column by column
        spec.add_actuator(name=f"_lin_{jn}", trntype=mujoco.mjtTrn.mjTRN_JOINT, target=jn,
                          gear=[1.0, 0, 0, 0, 0, 0])
    m = spec.compile()
    nv = m.nv
    va = int(m.joint(mech.input_joint).dofadr[0])
    act_dof = [int(m.jnt_dofadr[m.actuator_trnid[i, 0]]) for i in range(m.nu)]
    d = mujoco.MjData(m)
    d.time = op.t
    d.qpos[:] = mech.initial_qpos(m, op.q, op.x or None)
    d.qvel[:] = mech.initial_qvel(m, op.q, op.qd, op.x or None, op.xd or None)

    load = mech.has_multibody_load()

    def qfrc(qpos, qvel):
        if not load:
            return np.zeros(nv)
        dd = mujoco.MjData(m)
        dd.time = op.t
        dd.qpos[:], dd.qvel[:] = qpos, qvel
        mech.multibody_load(m, dd, op.t)
        return dd.qfrc_applied.copy()

    d.qfrc_applied[:] = qfrc(d.qpos, d.qvel)
    d.ctrl[:] = 0.0
    d.ctrl[act_dof.index(va)] = op.tau
    mujoco.mj_forward(m, d)
    h = float(m.opt.timestep)
    T = np.zeros((2 * nv, 2 * nv))
    Bu = np.zeros((2 * nv, m.nu))
    mujoco.mjd_transitionFD(m, d, FD_MB, True, T, Bu, None, None)
    Jq = T[nv:, :nv] / h
    Jv = (T[nv:, nv:] - np.eye(nv)) / h
    Jf = np.zeros((nv, nv))
    for col, dof in enumerate(act_dof):
        Jf[:, dof] = Bu[nv:, col] / h
    if load:  # Python loads: q̈ += ∂q̈/∂qfrc · ∂qfrc/∂(qpos, qvel)
        K = np.zeros((nv, 2 * nv))
        p0, v0 = d.qpos.copy(), d.qvel.copy()
        for j in range(2 * nv):
            dp, dm = np.zeros(2 * nv), np.zeros(2 * nv)
            dp[j], dm[j] = FD_Q, -FD_Q
            K[:, j] = (qfrc(p0 + dp[:nv], v0 + dp[nv:]) - qfrc(p0 + dm[:nv], v0 + dm[nv:])) / (2 * FD_Q)
        Jq = Jq + Jf @ K[:, :nv]
        Jv = Jv + Jf @ K[:, nv:]
    A = np.zeros((2 * nv, 2 * nv))
    A[:nv, nv:] = np.eye(nv)
    A[nv:, :nv], A[nv:, nv:] = Jq, Jv
    B = np.zeros((2 * nv, 1))
    B[nv:, 0] = Jf[:, va]
    qa = int(m.joint(mech.input_joint).qposadr[0])
    rows = {"q": np.eye(2 * nv)[qa], "qd": np.eye(2 * nv)[nv + va]}
    # internal coordinates: linear map from (qpos, qvel) (central differences of internal_state)
    if mech.internal:
        p0, v0 = d.qpos.copy(), d.qvel.copy()
        for k, nm in enumerate(mech.internal):
            r = np.zeros(2 * nv)
            for j in range(2 * nv):
                dp = np.zeros(2 * nv)
                dp[j] = FD_Q
                xp, _ = mech.internal_state(m, p0 + dp[:nv], v0 + dp[nv:])
                xm, _ = mech.internal_state(m, p0 - dp[:nv], v0 - dp[nv:])
                r[j] = (float(xp[k]) - float(xm[k])) / (2 * FD_Q)
            rows[nm] = r
    names = [f"qpos[{m.joint(j).name}]" for j in range(m.njnt)] + [f"qvel[{m.joint(j).name}]" for j in range(m.njnt)]
    E = _embedding(machine, m, op)
    return Mechanics(A, B, names, rows, "model", E)


def _embedding(machine, m, op):
    """∂(qpos, qvel)/∂(q, x, q̇, ẋ) of the assembled configuration (central differences)."""
    mech = machine.mechanism
    nx = len(mech.internal)
    base = np.array([op.q, *op.x, op.qd, *op.xd], dtype=float)

    def emb(v):
        q, x, qd, xd = v[0], tuple(v[1:1 + nx]), v[1 + nx], tuple(v[2 + nx:])
        return np.concatenate([mech.initial_qpos(m, q, x or None), mech.initial_qvel(m, q, qd, x or None, xd or None)])

    E = np.zeros((2 * m.nv, len(base)))
    for j in range(len(base)):
        dp = np.zeros(len(base))
        dp[j] = FD_Q
        E[:, j] = (emb(base + dp) - emb(base - dp)) / (2 * FD_Q)
    return E


def to_input_coordinates(mb: Mechanics, mech) -> Mechanics:
    """A multibody linearisation expressed in the reduced coordinates (q, x, q̇, ẋ):
    A_r = S·A·E, B_r = S·B with S the rows of q, x, q̇, ẋ and E the embedding."""
    nx = len(mech.internal)
    rates = []
    for nm in mech.internal:  # rate rows: velocity part of the position map (linear coordinates)
        r = mb.rows[nm]
        n = len(r) // 2
        rates.append(np.concatenate([np.zeros(n), r[:n]]))
    S = np.vstack([mb.rows["q"], *[mb.rows[nm] for nm in mech.internal], mb.rows["qd"], *rates])
    A = S @ mb.A @ mb.embedding
    B = S @ mb.B
    names = _input_names(mech)
    n = 2 + 2 * nx
    rows = {nm: np.eye(n)[i] for i, nm in enumerate(names) if not nm.endswith("_rate")}
    return Mechanics(A, B, names, rows, "input")


def freeze_angle(mech: Mechanics, nx: int = 0) -> Mechanics:
    """The frozen-angle model (q a parameter, not a state of the dynamics): the accelerations'
    dependence on the input angle is removed (the angle still integrates the speed, for a
    controller that feeds it back).  At a running point (q̇* ≠ 0) the full Jacobian's q column
    holds ½J''q̇² and J'q̈ — the inertia variation along the turn, a time-varying effect that a
    frozen linear model cannot represent (docs/linear.md §3); input coordinates only."""
    if mech.coords != "input":
        raise ParameterError("freeze_angle: needs a model in input coordinates (q, x, q̇, ẋ)")
    A = mech.A.copy()
    A[1 + nx:, 0] = 0.0
    return dataclasses.replace(mech, A=A)


# ============================================================================ plants
def _expm_zoh(A, B, h):
    from scipy.linalg import expm

    n, m = A.shape[0], B.shape[1]
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = expm(M * h)
    return E[:n, :n], E[:n, n:]


def _outputs(mech: Mechanics, internal, n_states, I_row, I_D=0.0):
    names = ["q", "qd", "I", *internal]
    C = np.zeros((len(names), n_states))
    D = np.zeros((len(names), 1))
    nm = mech.A.shape[0]
    C[0, :nm], C[1, :nm] = mech.rows["q"], mech.rows["qd"]
    C[2] = I_row
    D[2, 0] = I_D
    for i, s in enumerate(internal):
        C[3 + i, :nm] = mech.rows[s]
    return names, C, D


def plant(mech: Mechanics, drive, internal=(), h=None, name="plant"):
    """Mechanics + DC-motor drive → ``control.StateSpace`` with input ``V``.

    ``h=None``: continuous time (L·İ = V − R·I − k_m·z·q̇; L = 0: algebraic current).
    ``h`` [s]: the kernel's co-step at h (discrete time, module doc)."""
    ct = _ct()
    R, L, km, z = float(drive.R), float(drive.L), float(drive.k_m), float(drive.z)
    Am, Bm = mech.A, mech.B
    nm = Am.shape[0]
    cqd = mech.rows["qd"][None, :]
    if h is None:
        if L > 0:
            A = np.block([[Am, Bm * z * km], [-(km * z / L) * cqd, np.array([[-R / L]])]])
            B = np.vstack([np.zeros((nm, 1)), [[1.0 / L]]])
            states = list(mech.states) + ["I"]
            I_row = np.zeros(nm + 1)
            I_row[-1] = 1.0
            names, C, D = _outputs(mech, internal, nm + 1, I_row)
        else:
            A = Am - Bm @ cqd * (z * km) ** 2 / R
            B = Bm * z * km / R
            states = list(mech.states)
            names, C, D = _outputs(mech, internal, nm, -(km * z / R) * cqd[0], 1.0 / R)
        return ct.ss(A, B, C, D, 0, inputs=["V"], outputs=names, states=states, name=name)
    h = float(h)
    if L > 0:
        x = h * R / L
        decay = math.exp(-x)
        w = -math.expm1(-x) / x  # mean of exp(-s/τ_e) over the step
    else:
        decay = w = 0.0
    Ad, Bd = _expm_zoh(Am, Bm, h)
    # τ = z·k_m·(w·I + (1 − w)·(V − k_m·z·q̇)/R)
    t_I, t_qd, t_V = z * km * w, -(z * km) ** 2 * (1 - w) / R, z * km * (1 - w) / R
    Amm = Ad + Bd @ cqd * t_qd
    AmI = Bd * t_I
    BmV = Bd * t_V
    # I⁺ = decay·I + g·(V − ½·k_m·z·(q̇ + q̇⁺)),  g = (1 − decay)/R
    g = (1.0 - decay) / R
    cq = cqd[0]
    AIm = -0.5 * g * km * z * (cq + cq @ Amm)
    AII = decay - 0.5 * g * km * z * float(cq @ AmI[:, 0])
    BI = g - 0.5 * g * km * z * float(cq @ BmV[:, 0])
    A = np.block([[Amm, AmI], [AIm[None, :], np.array([[AII]])]])
    B = np.vstack([BmV, [[BI]]])
    I_row = np.zeros(nm + 1)
    I_row[-1] = 1.0
    names, C, D = _outputs(mech, internal, nm + 1, I_row)
    return ct.ss(A, B, C, D, h, inputs=["V"], outputs=names, states=list(mech.states) + ["I"], name=name)


def sample(plant_h, N: int = 1, name=None):
    """Lift a co-step plant (dt = h) to the controller period N·h (V held over the period) and
    add the state/output ``qd_prev``: q̇ one co-step before the sample (the kernel's
    backward-difference acceleration is (q̇ − qd_prev)/h)."""
    ct = _ct()
    N = int(N)
    if N < 1:
        raise ParameterError(f"sample: N = {N} must be >= 1")
    A, B, C, D = (np.asarray(M) for M in (plant_h.A, plant_h.B, plant_h.C, plant_h.D))
    n = A.shape[0]
    h = float(plant_h.dt)
    cqd = C[plant_h.output_labels.index("qd")]
    Ak, Bk = np.eye(n), np.zeros((n, 1))  # state after k co-steps: Ak·x + Bk·u
    for _ in range(N - 1):
        Ak, Bk = A @ Ak, A @ Bk + B
    Phi, Gam = A @ Ak, A @ Bk + B
    An = np.zeros((n + 1, n + 1))
    An[:n, :n] = Phi
    An[n, :n] = cqd @ Ak
    Bn = np.vstack([Gam, (cqd @ Bk)[None, :]])
    Cn = np.hstack([C, np.zeros((C.shape[0], 1))])
    row = np.zeros((1, n + 1))
    row[0, n] = 1.0
    Cn = np.vstack([Cn, row])
    Dn = np.vstack([D, [[0.0]]])
    return ct.ss(An, Bn, Cn, Dn, N * h, inputs=["V"], outputs=list(plant_h.output_labels) + ["qd_prev"],
                 states=list(plant_h.state_labels) + ["qd_prev"], name=name or f"{plant_h.name}_T")


def _angle_mode(angle, op):
    if angle is None:
        return "frozen" if op.qd != 0.0 else "state"
    if angle not in ("state", "frozen"):
        raise ParameterError(f"angle = {angle!r}: choose 'state' (full Jacobian) or 'frozen' (q a parameter)")
    return angle


def reduced_plant(machine, op: OperatingPoint, h=None, angle="state"):
    """The reduced model linearised at ``op``: continuous (``h=None``) or the co-step at h;
    ``angle`` "state" (full Jacobian) or "frozen" (:func:`freeze_angle`; None: frozen when q̇* ≠ 0)."""
    mech = reduced_mechanics(machine, op)
    if _angle_mode(angle, op) == "frozen":
        mech = freeze_angle(mech, len(machine.mechanism.internal))
    return plant(mech, machine.drive, machine.mechanism.internal, h, name="reduced")


def multibody_plant(machine, op: OperatingPoint, options=None, h=None, coordinates="model", angle="state"):
    """The MJCF model linearised at ``op`` by ``mjd_transitionFD`` (module doc): continuous or
    the co-step at h; ``coordinates`` "model" (qpos/qvel of every joint) or "input" (q, x, q̇, ẋ);
    ``angle`` as in :func:`reduced_plant` (input coordinates only)."""
    if coordinates not in ("model", "input"):
        raise ParameterError(f"coordinates = {coordinates!r}: choose 'model' or 'input'")
    mb = multibody_mechanics(machine, op, options)
    if coordinates == "input":
        mb = to_input_coordinates(mb, machine.mechanism)
        if _angle_mode(angle, op) == "frozen":
            mb = freeze_angle(mb, len(machine.mechanism.internal))
    return plant(mb, machine.drive, machine.mechanism.internal, h, name=f"multibody_{coordinates}")


# ============================================================================ comparisons, modes
def frequency_grid(h=None, lo=0.1, n=400, hi=None):
    """Log grid [rad/s] from ``lo`` to ``hi`` (default: 0.9 × the Nyquist frequency π/h, or 1e4)."""
    if hi is None:
        hi = 0.9 * math.pi / h if h else 1e4
    return np.logspace(math.log10(lo), math.log10(hi), int(n))


def response(sys, omega, output=None, input=None):
    """Complex frequency response of one channel (default: the only one) at ``omega`` [rad/s]
    (z = e^{jωT} for a discrete system): C·(sI − A)⁻¹·B + D, solved for every frequency at once."""
    if output is not None or input is not None:
        sys = sys[output if output is not None else 0, input if input is not None else 0]
    A, B, C, D = (np.asarray(M, dtype=float) for M in (sys.A, sys.B, sys.C, sys.D))
    w = np.asarray(omega, dtype=float).reshape(-1)
    s = np.exp(1j * w * float(sys.dt)) if sys.dt else 1j * w
    n = A.shape[0]
    if n == 0:
        return np.full(len(w), complex(D[0, 0]))
    M = s[:, None, None] * np.eye(n)[None] - A[None]
    X = np.linalg.solve(M, np.broadcast_to(B[:, :1], (len(w), n, 1)))
    return (C[:1] @ X)[:, 0, 0] + D[0, 0]


def frequency_difference(a, b, omega=None, output="qd", input="V") -> dict:
    """max |G_a − G_b| / |G_a| over ``omega`` for one channel, and where it occurs."""
    if omega is None:
        omega = frequency_grid(float(a.dt) if a.dt else None)
    Ga, Gb = response(a, omega, output, input), response(b, omega, output, input)
    rel = np.abs(Ga - Gb) / np.abs(Ga)
    i = int(np.argmax(rel))
    return {"max_rel": float(rel[i]), "at_rad_s": float(omega[i]), "rms_rel": float(np.sqrt(np.mean(rel ** 2))),
            "omega_lo_rad_s": float(omega[0]), "omega_hi_rad_s": float(omega[-1])}


@dataclass
class Mode:
    """One pole: s-plane location (discrete poles mapped by s = ln z / T), natural frequency
    |s| [rad/s] and damping ratio −Re s/|s|."""

    pole: complex
    omega_n_rad_s: float
    zeta: float

    def as_dict(self):
        return {"pole": [self.pole.real, self.pole.imag], "omega_n_rad_s": self.omega_n_rad_s, "zeta": self.zeta}


def s_poles(sys) -> np.ndarray:
    """Poles in the s-plane (discrete: ln z / T; poles at z = 0 are dropped)."""
    p = np.asarray(sys.poles(), dtype=complex)
    if sys.dt:
        p = np.array([cmath.log(z) / float(sys.dt) for z in p if abs(z) > 1e-300], dtype=complex)
    return p


def modes(sys, oscillatory_only=False) -> list:
    """Every pole as a :class:`Mode` (one per complex pair, upper half), sorted by ω_n."""
    out = []
    for s in s_poles(sys):
        if s.imag < -1e-9 * max(1.0, abs(s)):
            continue
        if oscillatory_only and abs(s.imag) <= 1e-9 * max(1.0, abs(s)):
            continue
        wn = abs(s)
        out.append(Mode(complex(s), float(wn), float(-s.real / wn) if wn > 0 else float("nan")))
    return sorted(out, key=lambda m: m.omega_n_rad_s)


def locked_input_machine(machine):
    """The machine with its input coordinate locked (input inertia × LOCK_FACTOR): the
    internal (transmission) modes with the motor held still."""
    d = machine.drive
    J_lock = LOCK_FACTOR * max(float(d.J_eq) + float(np.mean(machine.mechanism.reduced(0.0)[0])), 1e-6)
    drive = dataclasses.replace(d, J_b=float(d.J_b) + J_lock)
    return dataclasses.replace(machine, drive=drive)


def transmission_modes(machine, op: OperatingPoint) -> dict:
    """Oscillatory modes of the reduced model in three limits: ``locked`` input (the motor
    held still), ``free`` input (mechanics alone, drive torque held: motor open-circuited) and
    ``driven`` (voltage-driven motor: back-EMF damping, continuous plant)."""
    ct = _ct()
    lk = locked_input_machine(machine)
    m_lock = reduced_mechanics(lk, operating_point(lk, op.q, op.qd, 0.0, op.t, op.x, op.xd))
    m_free = reduced_mechanics(machine, op)
    out = {"locked": modes(ct.ss(m_lock.A, m_lock.B, np.eye(len(m_lock.A)), 0), True),
           "free": modes(ct.ss(m_free.A, m_free.B, np.eye(len(m_free.A)), 0), True),
           "driven": modes(reduced_plant(machine, op), True)}
    return out


# ============================================================================ references, controllers
def running_speed(machine, q=0.0) -> float:
    """The input speed [rad/s] the controller asks for at angle q (its class's capability
    ``running_speed(machine, q)``: PID ``omega0``/z, the coupler-speed reference q̇_trj(q) (seed 002
    Eq 17), SMC ``omega_d``, a motion law's mean speed; open loop: the constant-inertia steady speed
    at its voltage); 0 for a controller that cannot say."""
    fn = getattr(machine.controller, "running_speed", None)
    return float(fn(machine, float(q))) if fn is not None else 0.0


def reference_gain(ctrl, q) -> float:
    """∂q̇_ref/∂q [1/s] of a reference computed from the measured angle (seed 002 Eq 17:
    q̇_trj = V_C/S(q)); 0 for a time-based reference."""
    ref = getattr(ctrl, "reference", None)
    if ref is None or not hasattr(ref, "crank_speed"):
        return 0.0
    e = FD_Q
    return (float(ref.crank_speed(q + e)) - float(ref.crank_speed(q - e))) / (2 * e)


#: inputs of a control law's counterpart (the reference's outputs, then the measurements)
LAW_INPUTS = ("q_ref", "qd_ref", "qdd_ref", "q", "qd", "qd_prev", "I")
#: inputs and outputs of a reference's counterpart
REF_INPUTS = ("q_set", "qd_set", "q", "qd")
REF_OUTPUTS = ("q_ref", "qd_ref", "qdd_ref")


def setpoint_reference(T):
    """A time-based reference as a DT system at period T (constant speed, motion law): q_ref =
    q_set + Σ T·qd_set (exactly ω0·t for a step), q̇_ref = qd_set, q̈_ref = 0 (a set-point step is
    not differentiated).  Inputs q_set, qd_set, q, qd → q_ref, qd_ref, qdd_ref."""
    ct = _ct()
    A = np.array([[1.0]])
    B = np.array([[0.0, T, 0.0, 0.0]])
    C = np.array([[1.0], [0.0], [0.0]])
    D = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    return ct.ss(A, B, C, D, T, inputs=list(REF_INPUTS), outputs=list(REF_OUTPUTS), states=["qref_int"],
                 name="reference")


def passthrough_reference(T):
    """The set-points themselves (a controller with its own set-point, e.g. SMC's ω_d): q_ref =
    q_set, q̇_ref = qd_set, q̈_ref = 0."""
    ct = _ct()
    return ct.ss(np.zeros((0, 0)), np.zeros((0, 4)), np.zeros((3, 0)),
                 [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 0, 0]], T, inputs=list(REF_INPUTS),
                 outputs=list(REF_OUTPUTS), name="reference")


def pid_law(kp, ki, kd, z, T, h):
    """Eq 16 as a DT system at period T: V = K_p·z·(q̇_ref − q̇) + K_i·z·(q_ref − q) +
    K_d·z·(q̈_ref − (q̇ − qd_prev)/h) (gains on motor-shaft errors; crank-side gains: z = 1)."""
    ct = _ct()
    D = float(z) * np.array([[ki, kp, kd, -ki, -kp - kd / h, kd / h, 0.0]], dtype=float)
    return ct.ss(np.zeros((0, 0)), np.zeros((0, 7)), np.zeros((1, 0)), D, T,
                 inputs=list(LAW_INPUTS), outputs=["V"], name="pid")


def pid_controller(kp, ki, kd, z, T, h):
    """The PID of :func:`pid_law` with a constant-speed reference: a full controller counterpart
    (inputs q_set, qd_set, q, qd, qd_prev, I)."""
    ct = _ct()
    return ct.interconnect([setpoint_reference(T), pid_law(kp, ki, kd, z, T, h)],
                           inplist=["q_set", "qd_set", "q", "qd", "qd_prev", "I"], outlist=["V"],
                           inputs=["q_set", "qd_set", "q", "qd", "qd_prev", "I"], outputs=["V"],
                           name="controller", check_unused=False)


def controller_counterpart(machine, op: OperatingPoint, h: float, reference_feedback: bool = True,
                           angle: str = "state"):
    """The machine's controller as a discrete-time ``control.StateSpace`` at its period T
    (inputs q_set, qd_set, q, qd, qd_prev, I; output V), or None for an open-loop controller.

    Built from the controller class's capabilities: ``ctrl.linear(machine, op, T, h, angle)`` (the
    law: inputs q_ref, qd_ref, qdd_ref, q, qd, qd_prev, I → V; :class:`controllers.base.Controller`)
    and ``ctrl.linear_reference(machine, op, T, h, feedback)`` (its reference: q_set, qd_set, q, qd
    → q_ref, qd_ref, qdd_ref).  A controller without them raises a ParameterError naming the
    missing capability.  ``reference_feedback=False`` treats an angle-dependent reference (seed
    002) as an exogenous speed profile (its dependence on the measured angle left out): the *speed
    loop*.  ``angle="frozen"``: the frozen-angle picture for the controller too — the angle is a
    parameter of the reference and of a model-based law (SMC's ℑ(q), C(q), Q0(q)), as it is of
    the plant (:func:`freeze_angle`); the measured angle still enters where it is a state (the
    PID's integral, the servo's position loop)."""
    from .kernel import control_every

    ct = _ct()
    ctrl = machine.controller
    if angle not in ("state", "frozen"):
        raise ParameterError(f"angle = {angle!r}: choose 'state' or 'frozen'")
    if angle == "frozen":
        reference_feedback = False
    name = getattr(ctrl, "type_name", "") or type(ctrl).__name__
    fn = getattr(ctrl, "linear", None)
    if fn is None:
        raise ParameterError(f"controller {name!r} has no linear counterpart (capability linear(machine, op, T, h) "
                             f"not defined; see controllers.base.Controller)")
    T = control_every(ctrl, h) * h
    law = fn(machine, op, T, h, angle=angle)
    if law is None:  # open loop
        return None
    rfn = getattr(ctrl, "linear_reference", None)
    if rfn is None:
        raise ParameterError(f"controller {name!r} has no linear_reference capability "
                             f"(see controllers.base.Controller)")
    ref = rfn(machine, op, T, h, reference_feedback)
    return ct.interconnect([ref, law], inplist=["q_set", "qd_set", "q", "qd", "qd_prev", "I"], outlist=["V"],
                           inputs=["q_set", "qd_set", "q", "qd", "qd_prev", "I"], outputs=["V"],
                           name="controller", check_unused=False)


# ============================================================================ loop
@dataclass
class Loop:
    """A closed loop, discrete time at the controller period: ``plant`` (V → q, qd, I, ...,
    qd_prev), ``controller``, ``L`` (loop at the plant input, SISO), ``S`` = 1/(1+L),
    ``T`` = L/(1+L), ``closed`` (q_set, qd_set, d → q, qd, I, V, u; d = voltage disturbance added
    at the plant input), ``feedback`` (the feedback loop alone, without pure reference dynamics:
    its poles are the closed-loop poles)."""

    plant: object
    controller: object
    L: object
    S: object
    T: object
    closed: object
    op: OperatingPoint | None = None
    feedback: object = None
    speed: "Loop | None" = None  #: the speed loop (angle-dependent reference as exogenous), or self


def loop(plant_T, controller) -> Loop:
    """Close ``controller`` around ``plant_T`` (both discrete at the same period)."""
    ct = _ct()
    if controller is None:
        raise ParameterError("open-loop controller: there is no feedback loop to analyse")
    if abs(float(plant_T.dt) - float(controller.dt)) > 1e-12 * float(plant_T.dt):
        raise ParameterError(f"plant period {plant_T.dt} s != controller period {controller.dt} s")
    Cfb = _reachable(controller[["V"], list(MEAS)])
    # measurements the controller does not use are left out, then plant states no used output
    # sees (e.g. the angle of a frozen plant under a pure speed law: a free integrator, z = 1)
    used = [k for k, nm in enumerate(MEAS) if np.any(np.asarray(Cfb.D)[:, k] != 0)
            or (Cfb.nstates and np.any(np.asarray(Cfb.B)[:, k] != 0))]
    meas = [MEAS[k] for k in used] or ["qd"]
    Cfb = _reachable(controller[["V"], meas])
    Pfb = _observable(plant_T[meas, ["V"]])
    L = -(Cfb * Pfb)
    L.name = "L"
    S = ct.feedback(ct.ss([], [], [], [[1.0]], dt=plant_T.dt), L)
    T = ct.feedback(L, 1)
    fb = ct.feedback(Pfb, Cfb, sign=1)  # the feedback loop alone: its poles are the loop's
    # closed loop: the controller's output u plus a voltage disturbance d drives the plant
    ctrl_u = ct.ss(controller.A, controller.B, controller.C, controller.D, controller.dt,
                   inputs=list(controller.input_labels), outputs=["u"], states=list(controller.state_labels),
                   name="ctrl")
    sj = ct.summing_junction(inputs=["u", "d"], output="V", name="sum", dt=plant_T.dt)
    outs = [o for o in plant_T.output_labels if o != "qd_prev"]
    closed = ct.interconnect([plant_T, ctrl_u, sj], inplist=["q_set", "qd_set", "d"], outlist=outs + ["V", "u"],
                             inputs=["q_set", "qd_set", "d"], outputs=outs + ["V", "u"], name="closed_loop",
                             check_unused=False)
    return Loop(plant_T, controller, L, S, T, closed, feedback=fb)


def _reachable(sys):
    """``sys`` without the states no input reaches (structurally: zero B rows, not coupled through
    A) — e.g. a reference integrator driven only by the set-point, whose pole at z = 1 is not a
    pole of the feedback loop."""
    ct = _ct()
    A, B = np.asarray(sys.A), np.asarray(sys.B)
    n = A.shape[0]
    if n == 0:
        return sys
    reach = np.any(B != 0, axis=1)
    while True:
        new = reach | np.any((A != 0) & reach[None, :], axis=1)
        if (new == reach).all():
            break
        reach = new
    if reach.all():
        return sys
    k = np.flatnonzero(reach)
    return ct.ss(A[np.ix_(k, k)], B[k], np.asarray(sys.C)[:, k], sys.D, sys.dt, inputs=list(sys.input_labels),
                 outputs=list(sys.output_labels), states=[sys.state_labels[i] for i in k], name=sys.name)


def _observable(sys):
    """``sys`` without the states no output sees (structurally: zero C columns, not coupled into
    observed states through A)."""
    ct = _ct()
    A, C = np.asarray(sys.A), np.asarray(sys.C)
    n = A.shape[0]
    if n == 0:
        return sys
    obs = np.any(C != 0, axis=0)
    while True:
        new = obs | np.any((A != 0) & obs[:, None], axis=0)
        if (new == obs).all():
            break
        obs = new
    if obs.all():
        return sys
    k = np.flatnonzero(obs)
    return ct.ss(A[np.ix_(k, k)], np.asarray(sys.B)[k], C[:, k], sys.D, sys.dt, inputs=list(sys.input_labels),
                 outputs=list(sys.output_labels), states=[sys.state_labels[i] for i in k], name=sys.name)


@dataclass
class Margins:
    """Robustness and speed of a loop (SI; dB, degrees).  Margins at the plant input: gain
    margin (inf: none), phase margin, the frequencies where they are read; ``Ms`` = peak |S|
    (= 1/stability margin); ``bandwidth_rad_s``: −3 dB of the set-point response q̇/q̇_set;
    ``stable``: every closed-loop pole inside the unit circle; ``poles``: closed-loop poles
    (s-plane, ln z / T)."""

    gain_margin_dB: float
    phase_margin_deg: float
    w_phase_crossover_rad_s: float
    w_gain_crossover_rad_s: float
    Ms: float
    w_Ms_rad_s: float
    bandwidth_rad_s: float
    stable: bool
    spectral_radius: float
    poles: list = field(default_factory=list)
    lower_gain_margin_dB: float = float("nan")

    def as_dict(self) -> dict:
        return {"gain_margin_dB": self.gain_margin_dB, "phase_margin_deg": self.phase_margin_deg,
                "w_phase_crossover_rad_s": self.w_phase_crossover_rad_s,
                "w_gain_crossover_rad_s": self.w_gain_crossover_rad_s,
                "lower_gain_margin_dB": self.lower_gain_margin_dB, "peak_sensitivity": self.Ms,
                "w_peak_sensitivity_rad_s": self.w_Ms_rad_s, "bandwidth_rad_s": self.bandwidth_rad_s,
                "stable": self.stable, "spectral_radius": self.spectral_radius,
                "closed_loop_poles_s": [[p.real, p.imag] for p in self.poles]}


def _db(x):
    return 20.0 * math.log10(x) if x > 0 and math.isfinite(x) else (math.inf if x == math.inf else float("nan"))


def bandwidth(sys, output="qd", input="qd_set", dbdrop=-3.0) -> float:
    """First frequency [rad/s] where |G| drops ``dbdrop`` dB below its DC gain (nan: infinite or
    zero DC gain; inf: it never drops below 0.9 × the Nyquist frequency)."""
    from scipy.optimize import brentq

    G = sys[output, input]
    omega = frequency_grid(float(G.dt) if G.dt else None, lo=1e-3, n=300)
    g0 = abs(complex(response(G, [1e-6])[0]))
    if not (math.isfinite(g0) and g0 > 0):
        return float("nan")
    lim = g0 * 10 ** (dbdrop / 20.0)
    mag = np.abs(response(G, omega))
    below = np.flatnonzero(mag < lim)
    if len(below) == 0:
        return math.inf
    i = int(below[0])
    if i == 0:
        return float(omega[0])
    f = lambda w: abs(complex(response(G, [w])[0])) - lim  # noqa: E731
    return float(brentq(f, omega[i - 1], omega[i], xtol=1e-9, rtol=1e-9))


def loop_margins(L, n: int = 3000) -> dict:
    """Gain margins (upper and lower), phase margin and peak sensitivity of a SISO loop L from its
    frequency response on a dense log grid up to 0.999 × Nyquist, every crossing refined by
    Brent's method.  (python-control's ``stability_margins`` falls back, for loops sampled this
    finely, to a spline search whose minimum |1 + L| is unreliable — spurious values measured on
    the platform servo — so the crossings are found here on the python-control object's exact
    response.)"""
    from scipy.optimize import brentq, minimize_scalar

    dt = float(L.dt) if L.dt else None
    hi = 0.999 * math.pi / dt if dt else 1e5
    w = np.logspace(-3, math.log10(hi), int(n))
    G = response(L, w)
    f = lambda x: complex(response(L, [x])[0])  # noqa: E731
    gms_up, gms_lo = [], []
    im = G.imag
    for k in np.flatnonzero(np.sign(im[:-1]) != np.sign(im[1:])):
        wc = brentq(lambda x: f(x).imag, w[k], w[k + 1], xtol=1e-12, rtol=1e-10)
        g = f(wc)
        if g.real < 0:
            gm = 1.0 / abs(g)
            (gms_up if gm > 1 else gms_lo).append((gm, wc))
    pms = []
    mag = np.abs(G) - 1.0
    for k in np.flatnonzero(np.sign(mag[:-1]) != np.sign(mag[1:])):
        wc = brentq(lambda x: abs(f(x)) - 1.0, w[k], w[k + 1], xtol=1e-12, rtol=1e-10)
        pm = math.degrees(cmath.phase(f(wc))) + 180.0
        pm = (pm + 180.0) % 360.0 - 180.0
        pms.append((pm, wc))
    d = np.abs(1.0 + G)
    k = int(np.argmin(d))
    lo_w, hi_w = w[max(k - 1, 0)], w[min(k + 1, len(w) - 1)]
    r = minimize_scalar(lambda x: abs(1.0 + f(x)), bounds=(lo_w, hi_w), method="bounded",
                        options={"xatol": 1e-9 * hi_w})
    sm, wms = (float(r.fun), float(r.x)) if r.fun < d[k] else (float(d[k]), float(w[k]))
    gm, wpc = min(gms_up) if gms_up else (math.inf, float("nan"))
    gml = max(gms_lo)[0] if gms_lo else float("nan")
    pm, wgc = min(pms, key=lambda p: abs(p[0])) if pms else (math.inf, float("nan"))
    return {"gm": gm, "wpc": wpc, "gm_lower": gml, "pm": pm, "wgc": wgc, "sm": sm, "wms": wms}


def margins(lp: Loop, with_bandwidth: bool = True) -> Margins:
    """Margins (:func:`loop_margins`), peak |S|, bandwidth and closed-loop poles of a
    :class:`Loop`.  The gain margin is the factor by which the loop gain may grow; when the loop
    is only conditionally stable (an open-loop-unstable frozen plant), ``lower_gain_margin_dB``
    (negative) is how far it may drop."""
    mm = loop_margins(lp.L)
    poles_z = np.asarray(lp.feedback.poles(), dtype=complex)
    rho = float(np.max(np.abs(poles_z))) if len(poles_z) else 0.0
    stable = rho < 1.0
    sp = lp.speed if lp.speed is not None else lp
    sp_stable = stable if sp is lp else float(np.max(np.abs(sp.feedback.poles()))) < 1.0
    bw = bandwidth(sp.closed) if (sp_stable and with_bandwidth) else float("nan")
    Ms = 1.0 / mm["sm"] if mm["sm"] > 0 else math.inf
    return Margins(_db(mm["gm"]), mm["pm"], mm["wpc"], mm["wgc"], Ms, mm["wms"], bw, stable, rho,
                   list(s_poles(lp.feedback)), _db(mm["gm_lower"]))


def analyse(machine, op: OperatingPoint, h: float, plant_kind="reduced", options=None, angle=None):
    """Plant at the controller period + controller counterpart + loop + margins at ``op``.
    ``plant_kind`` "reduced" or "multibody" (input coordinates); ``angle`` None: frozen when
    q̇* ≠ 0, the full Jacobian at a stationary point.  Returns (Loop, Margins)."""
    from .kernel import control_every

    N = control_every(machine.controller, h)
    if plant_kind == "reduced":
        p_h = reduced_plant(machine, op, h, angle=_angle_mode(angle, op))
    elif plant_kind == "multibody":
        p_h = multibody_plant(machine, op, options, h, coordinates="input", angle=_angle_mode(angle, op))
    else:
        raise ParameterError(f"plant = {plant_kind!r}: choose 'reduced' or 'multibody'")
    P = sample(p_h, N)
    ang = _angle_mode(angle, op)
    C = controller_counterpart(machine, op, h, angle=ang)
    lp = loop(P, C)
    lp.op = op
    if ang == "state" and reference_gain(machine.controller, op.q) != 0.0:
        lp.speed = loop(P, controller_counterpart(machine, op, h, reference_feedback=False))
        lp.speed.op = op
    return lp, margins(lp)


# ============================================================================ angle dependence
@dataclass
class Family:
    """Frozen-angle loops over one turn.  ``angles`` [rad], ``speeds`` [rad/s], ``margins`` (one
    :class:`Margins` per angle), ``loops``; ``worst``: worst-case figures and the angle where each
    occurs; ``validity``: the frozen-angle validity number and verdict."""

    angles: np.ndarray
    speeds: np.ndarray
    margins: list
    loops: list
    worst: dict
    validity: dict


VALID_BELOW = 0.1  #: validity ratio below which the frozen-angle picture holds
FAILS_ABOVE = 1.0  #: ... and above which it fails


def frozen_angle_family(machine, h: float, n_angles: int = 36, speed=None, t: float = 0.0,
                        plant_kind="reduced", options=None, keep_loops=True, angle=None) -> Family:
    """The loop at ``n_angles`` frozen input angles over [0, 2π) at the running speed (or
    ``speed``: a number or a function of q) at time ``t`` (K_p·t); ``angle`` as in
    :func:`analyse` (None: frozen when running)."""
    qs = np.linspace(0.0, 2 * np.pi, int(n_angles), endpoint=False)
    if speed is None:
        speeds = np.array([running_speed(machine, q) for q in qs])
    elif callable(speed):
        speeds = np.array([float(speed(q)) for q in qs])
    else:
        speeds = np.full(len(qs), float(speed))
    ms, lps = [], []
    for q, w in zip(qs, speeds):
        op = operating_point(machine, q, w, t=t)
        lp, m = analyse(machine, op, h, plant_kind, options, angle)
        ms.append(m)
        lps.append(lp if keep_loops else None)
    worst = worst_case(qs, ms)
    validity = frozen_validity(machine, qs, speeds, ms)
    return Family(qs, speeds, ms, lps, worst, validity)


def worst_case(qs, ms) -> dict:
    """Worst figures over a family and the angle [rad] where each occurs."""
    def pick(key, fn):
        vals = np.array([getattr(m, key) for m in ms], dtype=float)
        ok = np.isfinite(vals)
        if not ok.any():
            return {"value": float(vals[0]) if len(vals) else float("nan"), "at_q_rad": None}
        i = int(np.flatnonzero(ok)[fn(vals[ok])])
        return {"value": float(vals[i]), "at_q_rad": float(qs[i])}

    return {"gain_margin_dB": pick("gain_margin_dB", np.argmin), "phase_margin_deg": pick("phase_margin_deg", np.argmin),
            "peak_sensitivity": pick("Ms", np.argmax), "bandwidth_rad_s": pick("bandwidth_rad_s", np.argmin),
            "spectral_radius": pick("spectral_radius", np.argmax),
            "all_stable": bool(all(m.stable for m in ms))}


def frozen_validity(machine, qs, speeds, ms) -> dict:
    """Frozen-angle validity number ν = max_q max(|J'(q)·q̇*|/(J_eq + J(q)), |∂q̇_ref/∂q|) /
    min_q ω_bw: how fast the loop's plant (inertia) and reference change along the turn, over
    the slowest closed-loop (speed-loop) bandwidth.  ν < 0.1: the frozen-angle loops describe
    the machine; 0.1-1: marginal; > 1: they fail (the machine changes faster than its loop
    responds; the speed fluctuation is then set by the angle-periodic dynamics)."""
    J, dJ, _ = machine.mechanism.reduced(qs)
    Jt = float(machine.drive.J_eq) + np.asarray(J, dtype=float) + 0.0 * qs
    rate_J = np.abs(np.asarray(dJ, dtype=float) * speeds) / Jt
    rate_r = np.abs(np.array([reference_gain(machine.controller, q) for q in qs]))
    rate = np.maximum(rate_J, rate_r)
    bws = np.array([m.bandwidth_rad_s for m in ms], dtype=float)
    ok = np.isfinite(bws) & (bws > 0)
    bw = float(np.min(bws[ok])) if ok.any() else float("nan")
    i = int(np.argmax(rate))
    nu = float(rate[i] / bw) if math.isfinite(bw) else float("nan")
    if not math.isfinite(nu):
        verdict = "undefined (no finite closed-loop bandwidth)"
    else:
        verdict = "valid" if nu < VALID_BELOW else ("marginal" if nu <= FAILS_ABOVE else "fails")
    return {"inertia_rate_max_1_s": float(rate_J.max()), "reference_rate_max_1_s": float(rate_r.max()),
            "at_q_rad": float(qs[i]), "bandwidth_min_rad_s": bw, "ratio": nu, "verdict": verdict,
            "rotation_to_bandwidth": float(np.max(np.abs(speeds)) / bw) if math.isfinite(bw) else float("nan")}


# ============================================================================ margins for design
MARGIN_KEYS = {"pm": ("phase_margin_deg", ">=", "phase margin [deg]"),
               "gm": ("gain_margin_dB", ">=", "gain margin [dB]"),
               "ms": ("peak_sensitivity", "<=", "peak |S|"),
               "bw": ("bandwidth_rad_s", ">=", "closed-loop bandwidth [rad/s]")}


def parse_margin(text: str) -> tuple:
    """``"pm>=45"`` → ("pm", ">=", 45.0); keys pm [deg], gm [dB], ms (peak |S|), bw [rad/s]."""
    import re

    m = re.fullmatch(r"\s*(pm|gm|ms|bw)\s*(>=|<=)\s*([-+0-9.eE]+)\s*", str(text))
    if not m:
        raise ParameterError(f"--margin {text!r}: expected pm>=DEG, gm>=DB, ms<=VALUE or bw>=RAD_S "
                             f"(e.g. --margin pm>=45 --margin ms<=2)")
    key, op, val = m.group(1), m.group(2), float(m.group(3))
    if op != MARGIN_KEYS[key][1]:
        raise ParameterError(f"--margin {text!r}: {key} is a {'lower' if MARGIN_KEYS[key][1] == '>=' else 'upper'} "
                             f"bound, write {key}{MARGIN_KEYS[key][1]}{val:g}")
    if not math.isfinite(val) or (key in ("ms", "bw", "pm") and val <= 0):
        raise ParameterError(f"--margin {text!r}: the bound must be finite and > 0")
    return key, op, val


def plant_family(machine, h: float, n_angles: int = 12, t: float = 0.0, speed=None) -> list:
    """(angle, operating point, plant at the controller period) at ``n_angles`` frozen angles:
    the part of the loop analysis that does not depend on the controller gains."""
    from .kernel import control_every

    N = control_every(machine.controller, h)
    out = []
    for q in np.linspace(0.0, 2 * np.pi, int(n_angles), endpoint=False):
        w = running_speed(machine, q) if speed is None else float(speed)
        op = operating_point(machine, q, w, t=t)
        out.append((float(q), op, sample(reduced_plant(machine, op, h, angle=_angle_mode(None, op)), N)))
    return out


def family_margins(machine, plants, h: float, with_bandwidth: bool = False) -> dict:
    """Worst-case margins of ``machine``'s controller over a :func:`plant_family` (frozen loops):
    {"phase_margin_deg", "gain_margin_dB", "peak_sensitivity", "bandwidth_rad_s", "all_stable"}."""
    ms = []
    for q, op, P in plants:
        ang = _angle_mode(None, op)
        lp = loop(P, controller_counterpart(machine, op, h, angle=ang))
        if ang == "state" and reference_gain(machine.controller, op.q) != 0.0:
            lp.speed = loop(P, controller_counterpart(machine, op, h, reference_feedback=False))
        ms.append(margins(lp, with_bandwidth))
    w = worst_case(np.array([p[0] for p in plants]), ms)
    return {"phase_margin_deg": w["phase_margin_deg"]["value"], "gain_margin_dB": w["gain_margin_dB"]["value"],
            "peak_sensitivity": w["peak_sensitivity"]["value"], "bandwidth_rad_s": w["bandwidth_rad_s"]["value"],
            "all_stable": w["all_stable"]}


def margin_violation(worst: dict, constraints) -> float:
    """Sum over ``constraints`` [(key, op, value)] of the relative violation by the worst-case
    margins, each capped at 1 (0: all met); an unstable frozen loop, or a margin that cannot be
    computed, violates every constraint fully."""
    total = 0.0
    for key, _, val in constraints:
        v = worst.get(MARGIN_KEYS[key][0])
        if not worst.get("all_stable", True) or v is None or (isinstance(v, float) and math.isnan(v)):
            total += 1.0
        elif key == "ms":
            total += min(1.0, max(0.0, v / val - 1.0))
        elif v != math.inf:
            total += min(1.0, max(0.0, (val - v) / abs(val)))
    return float(total)


# ============================================================================ responses
def step_response(lp: Loop, t, q_set=0.0, qd_set=0.0, t_step=0.0, d=0.0) -> dict:
    """Linear prediction of the closed loop's response to steps of the set-points (and of a
    voltage disturbance d) applied at ``t_step``: deviations from the operating point at the
    sample times ``t`` [s] (0, T, 2T ...), dict of arrays by output name."""
    ct = _ct()
    t = np.asarray(t, dtype=float)
    on = (t >= t_step - 1e-12).astype(float)
    U = np.vstack([q_set * on, qd_set * on, d * on])
    r = ct.forced_response(lp.closed, T=t, U=U)
    return {"t": t, **{nm: np.asarray(r.outputs[i]) for i, nm in enumerate(lp.closed.output_labels)}}


def rise_time(t, y, fraction=0.9) -> float:
    """First time y reaches ``fraction`` of its final value (from y(0) = 0) [s]."""
    y = np.asarray(y)
    yf = y[-1]
    idx = np.flatnonzero(y >= fraction * yf) if yf > 0 else np.flatnonzero(y <= fraction * yf)
    return float(t[idx[0]]) if len(idx) else float("nan")


# ============================================================================ JSON
def matrices(sys) -> dict:
    """The state-space matrices and signal names of a python-control system (plain lists)."""
    return {"A": np.asarray(sys.A).tolist(), "B": np.asarray(sys.B).tolist(), "C": np.asarray(sys.C).tolist(),
            "D": np.asarray(sys.D).tolist(), "dt": float(sys.dt) if sys.dt else 0.0,
            "states": list(sys.state_labels), "inputs": list(sys.input_labels), "outputs": list(sys.output_labels)}


def plain(o):
    """Plain Python data: complex → [re, im], NumPy → Python numbers and lists (non-finite floats
    kept: :func:`mjbench.outputs.write_json` writes them as null and lists them in ``_nonfinite``)."""
    if isinstance(o, dict):
        return {str(k): plain(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [plain(v) for v in o]
    if isinstance(o, np.ndarray):
        return plain(o.tolist())
    if isinstance(o, (complex, np.complexfloating)):
        return [float(o.real), float(o.imag)]
    if isinstance(o, (bool, np.bool_)):
        return bool(o)
    if isinstance(o, (int, np.integer)):
        return int(o)
    if isinstance(o, (float, np.floating)):
        return float(o)
    return o


# ============================================================================ nonlinear check
#: :func:`step_reference_law`'s parameters (input side; eps: half a co-step, the step's tolerance)
StepRefP = namedtuple("StepRefP", "z q0 qd0 t_step dq dqd eps")


@law
def step_reference_law(t, q, qd, qdd, I, P, S):
    """Motor-side φ_ref, φ̇_ref, φ̈_ref of a constant speed q̇0 from angle q0 with steps of the angle
    (dq) and of the speed (dqd) at t_step (input side × z)."""
    on = t >= P.t_step - P.eps
    qq = P.q0 + P.qd0 * t + ((P.dq + P.dqd * (t - P.t_step)) if on else 0.0)
    qdd_ = P.qd0 + (P.dqd if on else 0.0)
    return P.z * qq, P.z * qdd_, 0.0


class StepReference(_Reference):
    """Reference (a law, :mod:`controllers.reference`): motor-side φ_ref, φ̇_ref, φ̈_ref of a
    constant speed q̇0 from angle q0 [input side, rad, rad/s], with steps of the angle (dq) and of
    the speed (dqd) at ``t_step`` — the same signals as :func:`step_response`'s set-points."""

    STATE = ()
    law = step_reference_law

    def __init__(self, z, q0, qd0, t_step, dq=0.0, dqd=0.0, h=1e-4):
        self.z, self.q0, self.qd0, self.t_step, self.dq, self.dqd = (float(v) for v in (z, q0, qd0, t_step, dq, dqd))
        self._eps = 0.5 * float(h)
        self.reset()

    def parameters(self, T, z):
        return StepRefP(self.z, self.q0, self.qd0, self.t_step, self.dq, self.dqd, self._eps)

    def crank_speed_at(self, machine, q):
        return self.qd0


def step_check(machine, op: OperatingPoint, h: float, dq=0.0, dqd=0.0, t_step=0.05, t_end=0.3,
               backend="multibody", options=None, plant_kind=None) -> dict:
    """The nonlinear co-simulation started at ``op`` (held there by the controller) with
    set-point steps dq [rad] / dqd [rad/s] at ``t_step``, against the linear closed loop's
    prediction.  PID and servo controllers (their reference replaced by a :class:`StepReference`
    whose offset holds the operating point).  Returns the deviations from the operating point
    (simulated and predicted) and max |difference| / max |predicted| for q and q̇."""
    import copy

    from .backends import simulate
    from .kernel import control_every

    ctrl = machine.controller
    z = float(machine.drive.z)
    N = control_every(ctrl, h)
    T = N * h
    # reference offset that makes the controller output V* at the point (steady start): the
    # class's capability hold_offset(machine, op) (PID, servo)
    fn = getattr(ctrl, "hold_offset", None)
    if fn is None:
        raise ParameterError(f"step_check: controller {type(ctrl).__name__} not supported (capability "
                             f"hold_offset(machine, op) not defined)")
    q_off = float(fn(machine, op))
    lp, _ = analyse(machine, op, h, plant_kind or ("multibody" if backend == "multibody" else "reduced"), options)
    c2 = copy.copy(ctrl)
    c2.reference = StepReference(z, op.q + q_off, op.qd, t_step, dq, dqd, h)
    mach = dataclasses.replace(machine, controller=c2, q0=op.q, qd0=op.qd, I0=op.I,
                               x0=op.x or None, xd0=op.xd or None)
    o = dict(options or {})
    kw = {"record_dt": T}
    if backend == "multibody":
        kw["options"] = {**o, "timestep": h}
    else:
        kw["dt"] = h
    tr = simulate(mach, backend, t_end, **kw)
    t = tr.t
    pred = step_response(lp, t, q_set=dq, qd_set=dqd, t_step=t_step)
    dq_sim = tr.q - (op.q + op.qd * t)
    dqd_sim = tr.qd - op.qd
    out = {"t": t, "q_sim": dq_sim, "qd_sim": dqd_sim, "q_lin": pred["q"], "qd_lin": pred["qd"]}
    for k in ("q", "qd"):
        lin, sim = pred[k], out[f"{k}_sim"]
        # deviations measured from the pre-step state (the start settles the soft constraints)
        i0 = max(0, int(np.searchsorted(t, t_step - 1e-12)) - 1)
        sim = sim - sim[i0]
        out[f"{k}_sim"] = sim
        scale = float(np.max(np.abs(lin)))
        out[f"{k}_rel_error"] = float(np.max(np.abs(sim - lin)) / scale) if scale > 0 else float("nan")
    return out


# ============================================================================ K_p·t
def kp_ramp_limit(machine, h: float, n_angles: int = 24, t_max: float = 1e4, speed=None) -> dict:
    """Seed 000 Eq 15, K_p·t PID sampled at its period: ``t_s`` — the time at which the growing
    gain makes the frozen loop unstable at the worst angle (``at_q_rad``; bisection on the
    closed-loop spectral radius), ``kp_eff`` = K_p·t there [V·s/rad]; ``t_stable_from_s`` — before
    it the gain is too small to stabilise every frozen angle (where J'·q̇ < 0 the frozen plant has
    negative damping).  ``None``: no such time below ``t_max``."""
    ctrl = machine.controller
    if not getattr(ctrl, "kp_ramp", False):
        raise ParameterError("kp_ramp_limit: the controller has no K_p·t ramp (kp_ramp = false)")
    ct = _ct()
    cases = [(q, op, P[list(MEAS), ["V"]]) for q, op, P in plant_family(machine, h, n_angles, 0.0, speed)]

    def rho(t):
        worst, at = 0.0, None
        for q, op, Pfb in cases:
            C = _reachable(controller_counterpart(machine, dataclasses.replace(op, t=t), h,
                                                  angle=_angle_mode(None, op))[["V"], list(MEAS)])
            r = float(np.max(np.abs(ct.feedback(Pfb, C, sign=1).poles())))
            if r > worst:
                worst, at = r, q
        return worst, at

    def bisect(lo, hi):  # rho(lo) and rho(hi) on opposite sides of 1
        s_lo = rho(lo)[0] < 1.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if (rho(mid)[0] < 1.0) == s_lo:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-4 * hi:
                break
        return lo, hi

    out = {"n_angles": int(n_angles), "t_stable_from_s": None, "t_s": None, "kp_eff": None, "at_q_rad": None}
    # a stable instant: the first of 1, 2, 4 ... s where every frozen angle is stable
    t_ok = 1.0
    while rho(t_ok)[0] >= 1.0:
        t_ok *= 2.0
        if t_ok > t_max:
            return out
    if rho(1e-6)[0] >= 1.0:  # unstable at the start of the ramp (small K_p·t): where it becomes stable
        out["t_stable_from_s"] = bisect(1e-6, t_ok)[1]
    else:
        out["t_stable_from_s"] = 0.0
    hi = 2.0 * t_ok
    while rho(hi)[0] < 1.0:
        t_ok, hi = hi, 2.0 * hi
        if hi > t_max:
            return out
    lo, hi = bisect(t_ok, hi)
    r, at = rho(hi)
    kp = float(np.asarray(ctrl.gain_p(hi)))
    out.update({"t_s": hi, "kp_eff": kp, "at_q_rad": at})
    return out


# ============================================================================ one scenario
def agree_above(a, b, omega, tol=0.01, output="qd", input="V"):
    """Lowest frequency [rad/s] above which |G_a − G_b|/|G_a| stays below ``tol`` (None: never)."""
    Ga, Gb = response(a, omega, output, input), response(b, omega, output, input)
    bad = np.flatnonzero(np.abs(Ga - Gb) / np.abs(Ga) >= tol)
    if len(bad) == 0:
        return float(omega[0])
    return float(omega[bad[-1] + 1]) if bad[-1] + 1 < len(omega) else None


def study(scn, mode=None, q=None, qd=None, I=None, t=None, n_angles=36, multibody=True) -> dict:
    """What ``mjbench linearize`` computes for a scenario: the plant (reduced and multibody) at
    the operating point and their agreement, modes, the loop and its margins, the frozen-angle
    family, the K_p·t stability limit.  Returns {"json": plain data for ``outputs.write_json``,
    "objects": the python-control objects, for the figures}.
    Defaults: q = the scenario's initial angle, q̇ = the running speed there, I = the current
    holding q̈ = 0, t = simulation.t_end for a K_p·t PID (the largest gain of the run), else 0."""
    from . import scenario as S
    from .kernel import control_every

    ct = _ct()
    mode = scn.mode(mode)
    mach = S.make_machine(scn, mode)
    h = float(scn.simulation.dt)
    opts = scn.multibody_options()
    ctrl = mach.controller
    ramp = bool(getattr(ctrl, "kp_ramp", False))
    if t is None:
        t = float(scn.simulation.t_end) if ramp else 0.0
    if q is None:
        q = float(scn.initial.q0)
    if qd is None:
        qd = running_speed(mach, q)
    op = operating_point(mach, q, qd, I, t)
    angle = _angle_mode(None, op)
    d = mach.drive
    warn = []
    if math.isfinite(float(d.v_max)) and abs(op.V) > float(d.v_max):
        warn.append(f"the operating point needs V = {op.V:.4g} V > drive.v_max = {float(d.v_max):.4g} V: the limiter "
                    f"saturates there, the linear model does not apply")
    if math.isfinite(float(d.i_max)) and abs(op.I) > float(d.i_max):
        warn.append(f"the operating point needs I = {op.I:.4g} A > drive.i_max: current limited there")
    objs = {"machine": mach, "op": op, "h": h}
    red = reduced_plant(mach, op, angle=angle)
    red_full = reduced_plant(mach, op, angle="state")
    objs["plant_reduced"], objs["plant_reduced_full"] = red, red_full
    js = {"scenario": scn.name, "mode": mode, "controller": getattr(ctrl, "type_name", type(ctrl).__name__),
          "co_step_s": h, "control_period_s": control_every(ctrl, h) * h if getattr(ctrl, "type_name", "") != "open"
          else None, "operating_point": op.as_dict(), "angle_model": angle, "warnings": warn,
          "plant": {"reduced": {**matrices(red), "modes": [m.as_dict() for m in modes(red)]}}}
    if angle == "frozen":
        js["plant"]["reduced_full_jacobian"] = {**matrices(red_full), "modes": [m.as_dict() for m in modes(red_full)]}
    om = frequency_grid(None, 0.1, 400, min(1e4, 0.9 * math.pi / h))
    costep = reduced_plant(mach, op, h, angle=angle)
    js["agreement"] = {"costep_vs_exact_zoh": frequency_difference(ct.c2d(red, h, "zoh"), costep, frequency_grid(h))}
    if multibody:
        mb = multibody_plant(mach, op, opts)
        mbi = multibody_plant(mach, op, opts, coordinates="input")
        objs["plant_multibody"], objs["plant_multibody_input"] = mb, mbi
        objs["plant_multibody_loop"] = mbi if angle == "state" else multibody_plant(
            mach, op, opts, coordinates="input", angle=angle)
        js["plant"]["multibody"] = {**matrices(mb), "modes": [m.as_dict() for m in modes(mb)]}
        js["plant"]["multibody_input_coordinates"] = {**matrices(mbi), "modes": [m.as_dict() for m in modes(mbi)]}
        js["agreement"]["reduced_vs_multibody_input_coordinates"] = frequency_difference(red_full, mbi, om)
        js["agreement"]["reduced_vs_multibody_model_coordinates"] = {
            **frequency_difference(red_full, mb, om), "agree_within_1pct_above_rad_s": agree_above(red_full, mb, om)}
    if mach.mechanism.internal:
        tm = transmission_modes(mach, op)
        js["transmission_modes"] = {k: [m.as_dict() for m in v] for k, v in tm.items()}
    try:
        C = controller_counterpart(mach, op, h, angle=angle)
    except ParameterError as e:  # e.g. SMC without a boundary layer: plant only
        C = None
        js["loop_note"] = str(e)
    if C is not None:
        lp, mg = analyse(mach, op, h, angle=angle)
        objs["loop"], objs["margins"] = lp, mg
        js["loop"] = {**mg.as_dict(), "closed_loop_modes": [m.as_dict() for m in modes(lp.feedback)],
                      "reference_gain_1_s": reference_gain(ctrl, op.q),
                      "plant_sampled": matrices(lp.plant), "controller": matrices(lp.controller)}
        if lp.speed is not lp and lp.speed is not None:
            js["loop"]["speed_loop_modes"] = [m.as_dict() for m in modes(lp.speed.feedback)]
        tt = np.arange(0.0, 10.0 / mg.bandwidth_rad_s if math.isfinite(mg.bandwidth_rad_s) else 0.0,
                       control_every(ctrl, h) * h)
        sp = lp.speed or lp
        if len(tt) > 1 and float(np.max(np.abs(sp.feedback.poles()))) < 1.0:
            r = step_response(sp, tt, qd_set=1.0)
            js["loop"]["rise_time_90_s"] = rise_time(tt, r["qd"])
        if ramp:
            js["kp_ramp"] = {"t_s": t, "kp_eff": float(np.asarray(ctrl.gain_p(t))),
                             "limit": kp_ramp_limit(mach, h, min(24, int(n_angles)))}
    if n_angles and n_angles > 0 and (C is not None):
        fam = frozen_angle_family(mach, h, n_angles, t=t)
        objs["family"] = fam
        js["frozen_angle"] = {"angles_rad": fam.angles, "speeds_rad_s": fam.speeds,
                              **{k: [getattr(m, a) for m in fam.margins] for k, a in
                                 (("gain_margin_dB", "gain_margin_dB"), ("phase_margin_deg", "phase_margin_deg"),
                                  ("peak_sensitivity", "Ms"), ("bandwidth_rad_s", "bandwidth_rad_s"),
                                  ("stable", "stable"))},
                              "worst": fam.worst, "validity": fam.validity}
    elif n_angles and n_angles > 0:
        qs = np.linspace(0.0, 2 * np.pi, int(n_angles), endpoint=False)
        objs["plant_family"] = (qs, [reduced_plant(mach, operating_point(mach, qq, running_speed(mach, qq), t=t),
                                                   angle=angle) for qq in qs])
    return {"json": plain(js), "objects": objs}
