"""The linearised mechanics: the reduced (Eksergian) model with its analytic Jacobian, the MJCF
model through MuJoCo's ``mjd_transitionFD``, its reduced coordinates and the frozen angle."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .point import OperatingPoint, _accel
from .signals import FD_MB, FD_Q
from ..mechanisms.base import Mechanism
from ..backends.multibody import DEFAULT_OPTIONS, build_model


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
    mech = machine.mechanism
    m, act_dof = _linearisation_model(machine, options)
    nv = m.nv
    va = int(m.joint(mech.input_joint).dofadr[0])
    qfrc = _python_loads(m, mech, op.t)
    d = _state_at(m, mech, op, act_dof, va, qfrc)
    Jq, Jv, Jf = _acceleration_jacobians(m, d, act_dof, qfrc)
    A = np.zeros((2 * nv, 2 * nv))
    A[:nv, nv:] = np.eye(nv)
    A[nv:, :nv], A[nv:, nv:] = Jq, Jv
    B = np.zeros((2 * nv, 1))
    B[nv:, 0] = Jf[:, va]
    qa = int(m.joint(mech.input_joint).qposadr[0])
    rows = {"q": np.eye(2 * nv)[qa], "qd": np.eye(2 * nv)[nv + va]}
    rows.update(_internal_rows(mech, m, d))
    names = [f"qpos[{m.joint(j).name}]" for j in range(m.njnt)] + [f"qvel[{m.joint(j).name}]" for j in range(m.njnt)]
    E = _embedding(machine, m, op)
    return Mechanics(A, B, names, rows, "model", E)


def _linearisation_model(machine, options):
    """The machine's MJCF for ``mjd_transitionFD``: semi-implicit Euler without implicit damping
    (qvel⁺ = qvel + h·q̈ exactly), one unit-gain force actuator per joint → (model, actuated dofs)."""
    import mujoco


    o = {**DEFAULT_OPTIONS, **(options or {})}
    o["integrator"] = "Euler"
    spec, m0 = build_model(machine, o)
    _require_hinges(m0)
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP
    joints = [m0.joint(j).name for j in range(m0.njnt)]
    for jn in joints:  # one unit-gain force actuator per joint: ∂q̈/∂qfrc, column by column
        spec.add_actuator(name=f"_lin_{jn}", trntype=mujoco.mjtTrn.mjTRN_JOINT, target=jn,
                          gear=[1.0, 0, 0, 0, 0, 0])
    m = spec.compile()
    return m, [int(m.jnt_dofadr[m.actuator_trnid[i, 0]]) for i in range(m.nu)]


def _python_loads(m, mech, t):
    """qfrc(qpos, qvel): the loads the mechanism applies from Python (``multibody_load``) at time t,
    or None when it has none."""
    import mujoco

    if not mech.has_multibody_load():
        return None

    def qfrc(qpos, qvel):
        dd = mujoco.MjData(m)
        dd.time = t
        dd.qpos[:], dd.qvel[:] = qpos, qvel
        mech.multibody_load(m, dd, t)
        return dd.qfrc_applied.copy()
    return qfrc


def _state_at(m, mech, op, act_dof, va, qfrc):
    """MjData at the operating point: assembled pose and velocity, the loads, the drive torque on
    the input's actuator, forward dynamics done."""
    import mujoco

    d = mujoco.MjData(m)
    d.time = op.t
    d.qpos[:] = mech.initial_qpos(m, op.q, op.x or None)
    d.qvel[:] = mech.initial_qvel(m, op.q, op.qd, op.x or None, op.xd or None)
    d.qfrc_applied[:] = qfrc(d.qpos, d.qvel) if qfrc is not None else np.zeros(m.nv)
    d.ctrl[:] = 0.0
    d.ctrl[act_dof.index(va)] = op.tau
    mujoco.mj_forward(m, d)
    return d


def _acceleration_jacobians(m, d, act_dof, qfrc):
    """∂q̈/∂qpos, ∂q̈/∂qvel, ∂q̈/∂qfrc from one ``mjd_transitionFD`` (the qvel rows / h), plus the
    Python loads' own derivatives (central differences) through ∂q̈/∂qfrc."""
    import mujoco

    nv = m.nv
    h = float(m.opt.timestep)
    T = np.zeros((2 * nv, 2 * nv))
    Bu = np.zeros((2 * nv, m.nu))
    mujoco.mjd_transitionFD(m, d, FD_MB, True, T, Bu, None, None)
    Jq = T[nv:, :nv] / h
    Jv = (T[nv:, nv:] - np.eye(nv)) / h
    Jf = np.zeros((nv, nv))
    for col, dof in enumerate(act_dof):
        Jf[:, dof] = Bu[nv:, col] / h
    if qfrc is not None:  # Python loads: q̈ += ∂q̈/∂qfrc · ∂qfrc/∂(qpos, qvel)
        K = np.zeros((nv, 2 * nv))
        p0, v0 = d.qpos.copy(), d.qvel.copy()
        for j in range(2 * nv):
            dp, dm = np.zeros(2 * nv), np.zeros(2 * nv)
            dp[j], dm[j] = FD_Q, -FD_Q
            K[:, j] = (qfrc(p0 + dp[:nv], v0 + dp[nv:]) - qfrc(p0 + dm[:nv], v0 + dm[nv:])) / (2 * FD_Q)
        Jq = Jq + Jf @ K[:, :nv]
        Jv = Jv + Jf @ K[:, nv:]
    return Jq, Jv, Jf


def _internal_rows(mech, m, d) -> dict:
    """Internal coordinates as linear maps of (qpos, qvel) (central differences of ``internal_state``)."""
    rows = {}
    nv = m.nv
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
    return rows


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
