"""The linear analysis of a machine with several motors (docs/linear.md §8): the MIMO plant and
loop as python-control ``StateSpace`` objects with named signals, loop-at-a-time margins and the
MIMO sensitivity peak.

**Operating point** (:func:`path_operating_point`): the path's point at a time t — the inputs q,
q̇, q̈ of the inverse kinematics the axes' references tabulate (:mod:`mjbench.taskpath`) — with
the drive torques that move the machine along it, τ = (M̄ + J_eq)·q̈ + c̄ + ḡ + D̄·q̇ + z²λ·q̇ (the
reduced model's table, as the simulation reads it), each DC motor's current I* = τ/(z·k_m) +
T_0·sgn(z·q̇)/k_m and voltage V* = R·I* + k_m·z·q̇.  Default t: where the inputs move fastest
along one cycle.  A machine without a path: its initial pose at rest, gravity held.

**Plant.**  The n-axis reduced model ẋ = f(x, τ), x = (q, q̇) (2n), f = (q̇, (M̄ + J_eq)⁻¹(τ − c̄ −
ḡ − D̄q̇ − z²λq̇)), linearised by central differences of the functions the reduced backend
integrates (the tabulated M̄, c̄'s coefficients, ḡ, D̄: :meth:`MultiLinkage.reduced_table`),
∂f/∂τ = (M̄ + J_eq)⁻¹ exactly.  The *full* Jacobian: along a prescribed motion the small deviations
from the reference trajectory obey δẋ = A(t)·δx + B(t)·δτ, the frozen-time Jacobian at the point
(the one-axis "frozen angle" picture of docs/linear.md §5 is not used).  The drives per axis
(:func:`plant_n`): a DC motor adds its current, L·İ = V − R·I − k_m·z·q̇, τ = z·k_m·I (input
``V_A``); an ideal torque source's input is the torque (``tau_A``).  Outputs ``q_A``, ``qd_A``,
``I_A`` … (the axes' labels).  ``h=``: the kernel's co-step (the mechanics under the held torque
exactly, ZOH; the torque from the mean current over the step; I⁺ from the exponential update with
the mean of the speeds at both ends — as :func:`mjbench.linear.plant` for one axis);
:func:`sample_n` lifts it to the controller period and adds ``qd_prev_A`` (the speed one co-step
before the sample).  Checked against MuJoCo: :func:`multibody_mechanics_n` is the MJCF model
linearised by ``mjd_transitionFD`` (every input joint actuated) and expressed in the input
coordinates (A_r = S·A·E, E the embedding of (q, q̇) in MuJoCo's qpos, qvel).

**Controllers** (:func:`controller_n`): a controller per axis is that axis's one-axis counterpart
(its ``linear`` capability, e.g. the PID's Eq 16; by default its law linearised numerically,
:mod:`mjbench.linearise`) with the axis's signals renamed (``q_ref_A``, ``q_A`` … → ``V_A``); one
controller for all axes (computed torque) is linearised numerically from its law
(:func:`multi_law_counterpart`: central differences of the law the kernel runs, every axis's
signals at the point; its state must be a work space, rewritten at every sample).  References are
exogenous inputs (a path is a function of time).

**Loop** (:func:`loop_n`): broken at the plant inputs, L = −C·P (n×n), S = (I + L)⁻¹, T = I − S;
the feedback loop alone (its poles are the closed-loop poles).  **Loop at a time**: axis k's loop
broken at its plant input with every other loop closed, L_k = −(u_k/V_k), its gain and phase
margins and peak |S_k| (:func:`mjbench.linear.loop_margins`).  **MIMO sensitivity peak**: the
largest singular value of S(e^{jωT}) over ω up to Nyquist (a dense grid, refined), ‖S‖∞ — a
disturbance at the plant inputs is amplified at most that much in any direction; 1/‖S‖∞ is the
smallest simultaneous perturbation of all loops that destabilises them (the disk margin's
relative).  Also ‖T‖∞.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from .. import compiled as C
from .. import scenario as S
from ..errors import ParameterError
from ..kernel import control_every
from ..mechanisms.linkage.multi_mechanism import cbar, unpack
from ..signals import call_law
from .loop import _db, _observable, _reachable, loop_margins
from .mechanics import _acceleration_jacobians, _linearisation_model
from .plant import _expm_zoh, s_poles
from .point import OperatingPoint
from .signals import FD_Q, LAW_INPUTS, _ct
from .study import matrices, plain

#: the per-axis signals of a controller counterpart (suffixed with the axis label)
MEAS_N = ("q", "qd", "qd_prev", "I")
REF_N = ("q_ref", "qd_ref", "qdd_ref")


def _name(sig: str, lab: str) -> str:
    return f"{sig}_{lab}"


# ============================================================================ operating point
@dataclass
class MultiPoint:
    """Where a machine with several motors is linearised (SI, input side, one entry per axis):
    time t, inputs q, speeds qd, accelerations qdd, the drive torques tau (J_eq·q̈ and z²λ·q̇
    included), currents I and voltages V (V = R·I + k_m·z·q̇, L·dI/dt left out)."""

    labels: tuple
    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    I: np.ndarray
    V: np.ndarray
    source: str = ""

    def axis(self, k: int) -> OperatingPoint:
        """Axis k's point as a one-axis :class:`OperatingPoint` (for its controller's counterpart)."""
        return OperatingPoint(float(self.q[k]), float(self.qd[k]), float(self.I[k]), float(self.V[k]),
                              float(self.tau[k]), float(self.qdd[k]), float(self.t))

    def as_dict(self) -> dict:
        return {"t_s": self.t, "source": self.source, "axes": {
            lab: {"q_rad": float(self.q[k]), "qd_rad_s": float(self.qd[k]), "qdd_rad_s2": float(self.qdd[k]),
                  "tau_Nm": float(self.tau[k]), "I_A": float(self.I[k]), "V_V": float(self.V[k])}
            for k, lab in enumerate(self.labels)}}


def path_references(machine):
    """The joint trajectories the machine's controllers track (a
    :class:`~mjbench.taskpath.PathReferences`), or None."""
    refs = getattr(machine.controllers[0][0], "references", None)
    if refs is not None and hasattr(refs, "Q"):
        return refs
    for c, _ in machine.controllers:
        src = getattr(getattr(c, "reference", None), "source", None)
        if src is not None and hasattr(src, "Q"):
            return src
    return None


def _drive_electric(d) -> bool:
    return str(getattr(d, "type_name", "dcmotor") or "dcmotor") == "dcmotor"


def _check_drives(machine):
    for lab, d in zip(machine.axis_labels, machine.drives):
        kind = str(getattr(d, "type_name", "dcmotor") or "dcmotor")
        if kind not in ("dcmotor", "torque"):
            raise ParameterError(f"linearize: axis {lab} has a {kind!r} drive; the linear model of a machine with "
                                 f"several motors takes DC motors and ideal torque sources")
        if getattr(d, "train", None) is not None:
            raise ParameterError(f"linearize: axis {lab}'s drive train has no linear model")


def _model(mech, drives, q, qd):
    """(M̄ + J_eq (n, n), the bias c̄ + ḡ + D̄q̇ + z²λq̇ (n,)) as the simulation evaluates them (the table, or
    the loops solved)."""
    M, G, g, D = unpack(mech.c.model_channels(np.atleast_2d(q)), mech.n_inputs)
    Ja = np.array([float(d.J_eq) for d in drives])
    c = np.array([float(d.crank_damping) for d in drives])
    qd2 = np.atleast_2d(qd)
    bias = cbar(G, qd2)[0] + g[0] + D[0] @ qd2[0] + c * qd2[0]
    return M[0] + np.diag(Ja), bias


def path_operating_point(machine, t: float | None = None) -> MultiPoint:
    """The operating point at time ``t`` of the path the machine tracks (module docstring)."""
    mech, drives, labels = machine.mechanism, machine.drives, machine.axis_labels
    _check_drives(machine)
    refs = path_references(machine)
    n = machine.naxes
    if refs is None:
        if t is not None and float(t) != 0.0:
            raise ParameterError(f"linearize: t = {t:g} s: the machine follows no [path]; it is linearised at its "
                                 f"initial pose at rest")
        q, qd, qdd, t, src = np.asarray(machine.q0, float), np.zeros(n), np.zeros(n), 0.0, "initial pose, at rest"
    else:
        tt = refs.t
        if t is None:
            k = int(np.argmax(np.linalg.norm(refs.Qd, axis=1)))
            t, src = float(tt[k]), "the path's point where the inputs move fastest"
        else:
            t, src = float(t), "the path's point at t"
            if not (math.isfinite(t) and t >= 0.0):
                raise ParameterError(f"linearize: t = {t!r} must be a finite time >= 0 s")
        tc = t % refs.period if refs.period > 0 else min(t, float(tt[-1]))
        q, qd, qdd = (np.array([np.interp(tc, tt, A[:, k]) for k in range(n)]) for A in (refs.Q, refs.Qd, refs.Qdd))
    Mt, bias = _model(mech, drives, q, qd)
    tau = Mt @ qdd + bias
    I, V = np.zeros(n), np.zeros(n)
    for k, d in enumerate(drives):
        if _drive_electric(d):
            z, km = float(d.z), float(d.k_m)
            w = z * qd[k]
            I[k] = tau[k] / (z * km) + float(d.T_0) * (1.0 if w > 0 else -1.0 if w < 0 else 0.0) / km
            V[k] = float(d.R) * I[k] + km * w
        else:
            I[k], V[k] = math.nan, math.nan
    return MultiPoint(tuple(labels), float(t), q, qd, qdd, tau, I, V, src)


# ============================================================================ mechanics
def reduced_mechanics_n(machine, op: MultiPoint):
    """(A (2n, 2n), B (2n, n)) of ẋ = f(x, τ), x = (q, q̇): central differences of the tabulated
    model (module docstring); B = (0; (M̄ + J_eq)⁻¹) exactly."""
    mech, drives = machine.mechanism, machine.drives
    n = machine.naxes
    x0 = np.concatenate([op.q, op.qd])

    def acc(x):
        Mt, bias = _model(mech, drives, x[:n], x[n:])
        return np.linalg.solve(Mt, op.tau - bias)

    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    for j in range(2 * n):
        e = FD_Q * max(1.0, abs(x0[j]))
        xp, xm = x0.copy(), x0.copy()
        xp[j] += e
        xm[j] -= e
        A[n:, j] = (acc(xp) - acc(xm)) / (2 * e)
    B = np.zeros((2 * n, n))
    B[n:] = np.linalg.inv(_model(mech, drives, op.q, op.qd)[0])
    return A, B


def multibody_mechanics_n(machine, op: MultiPoint, options=None):
    """(A, B) of the machine's MJCF linearised by ``mjd_transitionFD`` and expressed in the input
    coordinates (q, q̇) (module docstring)."""
    import mujoco

    mech = machine.mechanism
    n = machine.naxes
    m, act_dof = _linearisation_model(machine, options)
    nv = m.nv
    dofs = [int(m.joint(j).dofadr[0]) for j in mech.input_joints]
    qadr = [int(m.joint(j).qposadr[0]) for j in mech.input_joints]
    d = mujoco.MjData(m)
    d.time = op.t
    d.qpos[:] = mech.initial_qpos(m, op.q)
    d.qvel[:] = mech.initial_qvel(m, op.q, op.qd)
    d.ctrl[:] = 0.0
    for k, va in enumerate(dofs):
        d.ctrl[act_dof.index(va)] = op.tau[k]
    mujoco.mj_forward(m, d)
    Jq, Jv, Jf = _acceleration_jacobians(m, d, act_dof, None)
    A = np.zeros((2 * nv, 2 * nv))
    A[:nv, nv:] = np.eye(nv)
    A[nv:, :nv], A[nv:, nv:] = Jq, Jv
    B = np.zeros((2 * nv, n))
    for k, va in enumerate(dofs):
        B[nv:, k] = Jf[:, va]
    # the embedding of (q, q̇) in (qpos, qvel), and the rows of the inputs' own coordinates
    base = np.concatenate([op.q, op.qd])

    def emb(v):
        return np.concatenate([mech.initial_qpos(m, v[:n]), mech.initial_qvel(m, v[:n], v[n:])])

    E = np.zeros((2 * nv, 2 * n))
    for j in range(2 * n):
        dp = np.zeros(2 * n)
        dp[j] = FD_Q
        E[:, j] = (emb(base + dp) - emb(base - dp)) / (2 * FD_Q)
    S = np.zeros((2 * n, 2 * nv))
    for k in range(n):
        S[k, qadr[k]] = 1.0
        S[n + k, nv + dofs[k]] = 1.0
    return S @ A @ E, S @ B


# ============================================================================ plant
def _inputs(drives, labels):
    return [_name("V" if _drive_electric(d) else "tau", lab) for d, lab in zip(drives, labels)]


def plant_n(A, B, drives, labels, h=None, name="plant"):
    """Mechanics (A, B: x = (q, q̇), input the drive torques) + each axis's drive → a
    ``control.StateSpace`` with inputs ``V_A`` (DC motor) or ``tau_A`` (torque source) and outputs
    ``q_A``, ``qd_A``, ``I_A`` (DC motors); continuous (``h=None``) or the kernel's co-step at h."""
    ct = _ct()
    n = len(drives)
    el = [k for k, d in enumerate(drives) if _drive_electric(d)]
    ne = len(el)
    Cqd = np.zeros((n, 2 * n))
    Cqd[:, n:] = np.eye(n)
    states = [_name("q", lab) for lab in labels] + [_name("qd", lab) for lab in labels] + \
        [_name("I", labels[k]) for k in el]
    outs = [_name("q", lab) for lab in labels] + [_name("qd", lab) for lab in labels] + \
        [_name("I", labels[k]) for k in el]
    ns = 2 * n + ne
    Cm = np.eye(ns)
    Dm = np.zeros((ns, n))
    R = {k: float(drives[k].R) for k in el}
    L = {k: float(drives[k].L) for k in el}
    K = {k: float(drives[k].k_m) * float(drives[k].z) for k in el}  # z·k_m: torque per ampere, back-EMF per rad/s
    if h is None:
        Ac = np.zeros((ns, ns))
        Bc = np.zeros((ns, n))
        Ac[:2 * n, :2 * n] = A
        keep = []
        for k in range(n):
            if k not in el:
                Bc[:2 * n, k] = B[:, k]
        for i, k in enumerate(el):
            r = 2 * n + i
            if L[k] > 0:
                Ac[:2 * n, r] = B[:, k] * K[k]
                Ac[r, n + k] = -K[k] / L[k]
                Ac[r, r] = -R[k] / L[k]
                Bc[r, k] = 1.0 / L[k]
                keep.append(r)
            else:  # algebraic current: τ = K·(V − K·q̇)/R
                Ac[:2 * n, n + k] += -B[:, k] * K[k] ** 2 / R[k]
                Bc[:2 * n, k] = B[:, k] * K[k] / R[k]
                Cm[r] = 0.0
                Cm[r, n + k] = -K[k] / R[k]
                Dm[r, k] = 1.0 / R[k]
        drop = [2 * n + i for i, k in enumerate(el) if L[k] <= 0]
        if drop:  # no current state: the output stays (algebraic)
            keep_s = [i for i in range(ns) if i not in drop]
            Ac, Bc = Ac[np.ix_(keep_s, keep_s)], Bc[keep_s]
            Cm = Cm[:, keep_s]
            states = [states[i] for i in keep_s]
        return ct.ss(Ac, Bc, Cm, Dm, 0, inputs=_inputs(drives, labels), outputs=outs, states=states, name=name)
    h = float(h)
    Ad, Bd = _expm_zoh(A, B, h)
    # the held torque of each axis: τ_k = t_I·I_k + t_qd·q̇_k + t_V·V_k (DC motor), u_k (torque source)
    tI, tqd, tV, decay, g = (np.zeros(n) for _ in range(5))
    for k in range(n):
        if k in el:
            if L[k] > 0:
                x = h * R[k] / L[k]
                decay[k] = math.exp(-x)
                w = -math.expm1(-x) / x
            else:
                decay[k] = w = 0.0
            tI[k], tqd[k], tV[k] = K[k] * w, -K[k] ** 2 * (1 - w) / R[k], K[k] * (1 - w) / R[k]
            g[k] = (1.0 - decay[k]) / R[k]
        else:
            tV[k] = 1.0
    E = np.zeros((n, ne))  # the electric axes' currents among the axes
    for i, k in enumerate(el):
        E[k, i] = 1.0
    Amm = Ad + Bd @ np.diag(tqd) @ Cqd
    AmI = Bd @ np.diag(tI) @ E
    BmV = Bd @ np.diag(tV)
    Ge = np.diag([0.5 * g[k] * K[k] for k in el]) if ne else np.zeros((0, 0))
    Ce = E.T @ Cqd  # (ne, 2n): the electric axes' speeds
    AIm = -Ge @ (Ce + Ce @ Amm)
    AII = np.diag([decay[k] for k in el]) - Ge @ Ce @ AmI if ne else np.zeros((0, 0))
    BI = E.T @ np.diag(g) - Ge @ Ce @ BmV
    Ad_ = np.block([[Amm, AmI], [AIm, AII]])
    Bd_ = np.vstack([BmV, BI])
    return ct.ss(Ad_, Bd_, np.eye(ns), np.zeros((ns, n)), h, inputs=_inputs(drives, labels), outputs=outs,
                 states=states, name=name)


def sample_n(plant_h, N: int, labels, name=None):
    """Lift a co-step plant to the controller period N·h (inputs held) and add the states/outputs
    ``qd_prev_A``: every axis's speed one co-step before the sample."""
    ct = _ct()
    A, B, Cm, D = (np.asarray(M) for M in (plant_h.A, plant_h.B, plant_h.C, plant_h.D))
    ns, nu = A.shape[0], B.shape[1]
    h = float(plant_h.dt)
    cqd = np.vstack([Cm[plant_h.output_labels.index(_name("qd", lab))] for lab in labels])
    Ak, Bk = np.eye(ns), np.zeros((ns, nu))
    for _ in range(int(N) - 1):
        Ak, Bk = A @ Ak, A @ Bk + B
    Phi, Gam = A @ Ak, A @ Bk + B
    n = len(labels)
    An = np.zeros((ns + n, ns + n))
    An[:ns, :ns] = Phi
    An[ns:, :ns] = cqd @ Ak
    Bn = np.vstack([Gam, cqd @ Bk])
    Cn = np.block([[Cm, np.zeros((Cm.shape[0], n))], [np.zeros((n, ns)), np.eye(n)]])
    Dn = np.vstack([D, np.zeros((n, nu))])
    prev = [_name("qd_prev", lab) for lab in labels]
    return ct.ss(An, Bn, Cn, Dn, int(N) * h, inputs=list(plant_h.input_labels),
                 outputs=list(plant_h.output_labels) + prev, states=list(plant_h.state_labels) + prev,
                 name=name or f"{plant_h.name}_T")


# ============================================================================ controllers
def _period(machine, h) -> int:
    Ns = {control_every(c, h) for c, _ in machine.controllers}
    if len(Ns) != 1:
        raise ParameterError(f"linearize: the axes' controllers sample at different periods ({sorted(Ns)} co-steps); "
                             f"the MIMO loop needs one period")
    return Ns.pop()


def axis_view(machine, k: int):
    """Axis k of a machine as its one-axis controller sees it: that axis's drive and controller
    (``drives`` stays every axis's: a controller reads its own through its ``axis``)."""
    c = machine.controller[k] if machine.naxes > 1 and isinstance(machine.controller, list) else machine.controller
    return SimpleNamespace(mechanism=machine.mechanism, drive=machine.drives[k], drives=machine.drives,
                           controller=c, controllers=[(c, k)], naxes=1, axis_labels=(machine.axis_labels[k],),
                           q0=float(machine.q0[k]), qd0=float(machine.qd0[k]))


def _renamed(sys, labels_in, labels_out, lab, name):
    ct = _ct()
    return ct.ss(sys.A, sys.B, sys.C, sys.D, sys.dt, inputs=[_name(s, lab) for s in labels_in],
                 outputs=[_name(s, lab) for s in labels_out],
                 states=[_name(s, lab) for s in sys.state_labels], name=name)


def controller_n(machine, op: MultiPoint, h: float):
    """The controllers as one discrete-time ``control.StateSpace`` at their period (module
    docstring): inputs ``q_ref_A``, ``qd_ref_A``, ``qdd_ref_A``, ``q_A``, ``qd_A``, ``qd_prev_A``,
    ``I_A`` … of every axis, outputs the plant's inputs (``V_A`` …)."""
    ct = _ct()
    labels, drives = machine.axis_labels, machine.drives
    N = _period(machine, h)
    T = N * h
    plant_in = _inputs(drives, labels)
    if len(machine.controllers) == 1 and machine.naxes > 1:  # one controller for all axes
        ctrl = machine.controllers[0][0]
        fn = getattr(ctrl, "linear_n", None)
        sysc = fn(machine, op, T, h) if fn is not None else multi_law_counterpart(ctrl, machine, op, T, h)
        return sysc
    parts = []
    for k, (c, _) in enumerate(machine.controllers):
        lab = labels[k]
        view = axis_view(machine, k)
        fn = getattr(c, "linear", None)
        if fn is None:
            raise ParameterError(f"controller {getattr(c, 'type_name', type(c).__name__)!r} of axis {lab} has no "
                                 f"linear counterpart")
        law_k = fn(view, op.axis(k), T, h, angle="state")
        if law_k is None:
            raise ParameterError(f"axis {lab}: an open-loop controller: there is no feedback loop to analyse")
        sys_k = _renamed(law_k, list(law_k.input_labels), ["V"], lab, f"controller_{lab}")
        parts.append(ct.ss(sys_k.A, sys_k.B, sys_k.C, sys_k.D, sys_k.dt, inputs=list(sys_k.input_labels),
                           outputs=[plant_in[k]], states=list(sys_k.state_labels), name=f"controller_{lab}"))
    ins = [_name(s, lab) for lab in labels for s in LAW_INPUTS]
    return ct.interconnect(parts, inplist=ins, outlist=plant_in, inputs=ins, outputs=plant_in, name="controller",
                           check_unused=False)


def multi_law_counterpart(ctrl, machine, op: MultiPoint, T: float, h: float):
    """A law for every axis (computed torque) linearised numerically at ``op``: central
    differences of its outputs in every axis's inputs (:data:`LAW_INPUTS`), the references at the
    point.  Its state must be a work space (rewritten at every sample): a law whose output
    depends on its previous state is refused (no counterpart yet)."""
    ct = _ct()
    form = ctrl.form(T, machine)
    fn = form.bound()
    P = C.python_view(form.P)
    S0 = form.state()
    labels, drives = machine.axis_labels, machine.drives
    n = machine.naxes
    z = [float(d.z) for d in drives]
    nin = len(LAW_INPUTS)

    def signals(v):
        s = {"t": op.t}
        for k in range(n):
            qr, qdr, qddr, q, qd, qdp, I = v[nin * k:nin * (k + 1)]
            vals = {"q": q, "qd": qd, "qdd": (qd - qdp) / h, "I": I, "phi_ref": z[k] * qr, "om_ref": z[k] * qdr,
                    "acc_ref": z[k] * qddr, "z": z[k]}
            s.update({f"{nm}_{k}": x for nm, x in vals.items()})
            if k == int(getattr(ctrl, "axis", 0) or 0):
                s.update(vals)
        return s

    def out(v, S):
        u = call_law(fn, signals(v), P, memoryview(S))
        return np.atleast_1d(np.asarray(u, float))

    v0 = np.concatenate([[op.q[k], op.qd[k], op.qdd[k], op.q[k], op.qd[k], op.qd[k] - h * op.qdd[k],
                          op.I[k] if math.isfinite(op.I[k]) else 0.0] for k in range(n)])
    S1 = S0.copy()
    u0 = out(v0, S1)
    u1 = out(v0, S1.copy())
    u2 = out(v0, np.full_like(S0, 0.37))
    name = getattr(ctrl, "type_name", "") or type(ctrl).__name__
    if len(u0) != n:
        raise ParameterError(f"controller {name!r}: its law writes {len(u0)} outputs for {n} axes")
    if not (np.allclose(u0, u1, rtol=1e-12, atol=1e-12) and np.allclose(u0, u2, rtol=1e-12, atol=1e-12)):
        raise ParameterError(f"controller {name!r}: its law's output depends on its state; a linear counterpart of "
                             f"such a law for several axes is not available yet (write linear_n)")
    Dm = np.zeros((n, n * nin))
    for j in range(n * nin):
        e = 1e-6 * max(1.0, abs(v0[j]))
        vp, vm = v0.copy(), v0.copy()
        vp[j] += e
        vm[j] -= e
        Dm[:, j] = (out(vp, S0.copy()) - out(vm, S0.copy())) / (2 * e)
    ins = [_name(s, lab) for lab in labels for s in LAW_INPUTS]
    return ct.ss(np.zeros((0, 0)), np.zeros((0, n * nin)), np.zeros((n, 0)), Dm, T, inputs=ins,
                 outputs=_inputs(drives, labels), name=name)


# ============================================================================ loop
@dataclass
class MultiLoop:
    """The closed MIMO loop, discrete time at the controller period: ``plant`` (V_A … → q_A, qd_A,
    I_A, qd_prev_A …), ``controller``, ``L`` (n×n, at the plant inputs), ``S`` = (I + L)⁻¹,
    ``T`` = I − S, ``feedback`` (the loop alone: its poles are the closed-loop poles), ``closed``
    (the references and a disturbance at each plant input d_A … → the outputs and the plant inputs),
    ``at_a_time`` {axis: L_k, that axis's loop broken with the others closed (SISO)}."""

    plant: object
    controller: object
    L: object
    S: object
    T: object
    feedback: object
    closed: object
    at_a_time: dict = field(default_factory=dict)
    labels: tuple = ()


def loop_n(P_T, Cn, labels) -> MultiLoop:
    """Close the controllers ``Cn`` around the sampled plant ``P_T`` (module docstring)."""
    ct = _ct()
    plant_in = list(P_T.input_labels)
    meas = [_name(s, lab) for lab in labels for s in MEAS_N if _name(s, lab) in P_T.output_labels]
    Cfb = _reachable(Cn[plant_in, meas])
    used = [j for j, nm in enumerate(meas) if np.any(np.asarray(Cfb.D)[:, j] != 0)
            or (Cfb.nstates and np.any(np.asarray(Cfb.B)[:, j] != 0))]
    meas = [meas[j] for j in used]
    if not meas:
        raise ParameterError("linearize: the controllers read no measurement: there is no feedback loop")
    Cfb = _reachable(Cn[plant_in, meas])
    Pfb = _observable(P_T[meas, plant_in])
    L = -(Cfb * Pfb)
    n = len(plant_in)
    eye = ct.ss([], [], [], np.eye(n), dt=P_T.dt)
    S = ct.feedback(eye, L)
    T = ct.feedback(L, eye)
    fb = ct.feedback(Pfb, Cfb, sign=1)
    # the loop at a time: axis k broken at its plant input, the others closed
    Cnamed = ct.ss(Cfb.A, Cfb.B, Cfb.C, Cfb.D, Cfb.dt, inputs=meas, outputs=plant_in,
                   states=list(Cfb.state_labels), name="ctrl")
    Pnamed = ct.ss(Pfb.A, Pfb.B, Pfb.C, Pfb.D, Pfb.dt, inputs=plant_in, outputs=meas,
                   states=list(Pfb.state_labels), name="plant")
    at = {}
    for k, lab in enumerate(labels):
        outs = [f"u_{lab}" if j == k else plant_in[j] for j in range(n)]
        Ck = ct.ss(Cnamed.A, Cnamed.B, Cnamed.C, Cnamed.D, Cnamed.dt, inputs=meas, outputs=outs,
                   states=list(Cnamed.state_labels), name="ctrl_k")
        Gk = ct.interconnect([Pnamed, Ck], inplist=[plant_in[k]], outlist=[f"u_{lab}"], inputs=[plant_in[k]],
                             outputs=[f"u_{lab}"], check_unused=False)
        Lk = -Gk
        Lk.name = f"L_{lab}"
        at[lab] = Lk
    # the closed loop: references and input disturbances in, outputs and plant inputs out
    refs = [nm for nm in Cn.input_labels if nm.startswith(("q_ref_", "qd_ref_", "qdd_ref_"))]
    Cu = ct.ss(Cn.A, Cn.B, Cn.C, Cn.D, Cn.dt, inputs=list(Cn.input_labels), outputs=[f"u_{x}" for x in plant_in],
               states=list(Cn.state_labels), name="ctrl_u")
    sums = [ct.summing_junction(inputs=[f"u_{x}", f"d_{x}"], output=x, name=f"sum_{x}", dt=P_T.dt) for x in plant_in]
    outs = [o for o in P_T.output_labels if not o.startswith("qd_prev_")]
    ins = refs + [f"d_{x}" for x in plant_in]
    closed = ct.interconnect([P_T, Cu, *sums], inplist=ins, outlist=outs + plant_in, inputs=ins,
                             outputs=outs + plant_in, name="closed_loop", check_unused=False)
    return MultiLoop(P_T, Cn, L, S, T, fb, closed, at, tuple(labels))


def _freq_response(sys, w):
    """C(zI − A)⁻¹B + D at z = e^{jωT} (or s = jω) for every ω: (len(w), p, m)."""
    A, B, Cm, D = (np.asarray(M, float) for M in (sys.A, sys.B, sys.C, sys.D))
    s = np.exp(1j * np.asarray(w) * float(sys.dt)) if sys.dt else 1j * np.asarray(w)
    n = A.shape[0]
    if n == 0:
        return np.broadcast_to(D, (len(w),) + D.shape).astype(complex)
    X = np.linalg.solve(s[:, None, None] * np.eye(n)[None] - A[None], np.broadcast_to(B, (len(w),) + B.shape))
    return Cm[None] @ X + D[None]


def sigma_peak(sys, n: int = 2000) -> tuple[float, float]:
    """(max over ω of the largest singular value of ``sys``(e^{jωT}), ω of it [rad/s]) on a log grid
    up to 0.999 × Nyquist, refined around the largest by a bounded search."""
    from scipy.optimize import minimize_scalar

    dt = float(sys.dt) if sys.dt else None
    hi = 0.999 * math.pi / dt if dt else 1e5
    w = np.logspace(-2, math.log10(hi), int(n))
    sv = np.linalg.svd(_freq_response(sys, w), compute_uv=False)[:, 0]
    k = int(np.argmax(sv))
    lo_w, hi_w = w[max(k - 1, 0)], w[min(k + 1, len(w) - 1)]

    def neg(x):
        return -float(np.linalg.svd(_freq_response(sys, [x]), compute_uv=False)[0, 0])

    r = minimize_scalar(neg, bounds=(lo_w, hi_w), method="bounded", options={"xatol": 1e-9 * hi_w})
    return (float(-r.fun), float(r.x)) if -r.fun > sv[k] else (float(sv[k]), float(w[k]))


def sigma_curves(sys, w):
    """Singular values (len(w), min(p, m)) of ``sys`` over ω."""
    return np.linalg.svd(_freq_response(sys, w), compute_uv=False)


def margins_n(lp: MultiLoop) -> dict:
    """Loop-at-a-time margins per axis, ‖S‖∞ and ‖T‖∞, the closed-loop poles and stability."""
    poles_z = np.asarray(lp.feedback.poles(), dtype=complex)
    rho = float(np.max(np.abs(poles_z))) if len(poles_z) else 0.0
    axes = {}
    for lab, Lk in lp.at_a_time.items():
        mm = loop_margins(Lk)
        axes[lab] = {"gain_margin_dB": _db(mm["gm"]), "w_phase_crossover_rad_s": mm["wpc"],
                     "lower_gain_margin_dB": _db(mm["gm_lower"]), "phase_margin_deg": mm["pm"],
                     "w_gain_crossover_rad_s": mm["wgc"],
                     "peak_sensitivity": 1.0 / mm["sm"] if mm["sm"] > 0 else math.inf,
                     "w_peak_sensitivity_rad_s": mm["wms"]}
    sp, wsp = sigma_peak(lp.S)
    tp, wtp = sigma_peak(lp.T)
    return {"loop_at_a_time": axes,
            "mimo_sensitivity_peak": sp, "w_mimo_sensitivity_peak_rad_s": wsp,
            "mimo_complementary_peak": tp, "w_mimo_complementary_peak_rad_s": wtp,
            "stable": bool(rho < 1.0), "spectral_radius": rho,
            "closed_loop_poles_s": [[float(p.real), float(p.imag)] for p in s_poles(lp.feedback)]}


# ============================================================================ the study
def study_n(scn, mode=None, t=None, multibody=True) -> dict:
    """What ``mjbench linearize`` computes for a machine with several motors: the operating point,
    the MIMO plant (reduced; and MuJoCo's in the input coordinates, compared), the controllers'
    counterpart, the loop, loop-at-a-time margins, ‖S‖∞.  {"json": plain data, "objects": ...}."""
    mode = scn.mode(mode)
    mach = S.make_machine(scn, mode)
    h = float(scn.simulation.dt)
    op = path_operating_point(mach, t)
    labels, drives = mach.axis_labels, mach.drives
    A, B = reduced_mechanics_n(mach, op)
    red = plant_n(A, B, drives, labels, name="reduced")
    objs = {"machine": mach, "op": op, "h": h, "plant_reduced": red}
    ctrls = sorted({str(getattr(c, "type_name", "") or type(c).__name__) for c, _ in mach.controllers})
    js = {"scenario": scn.name, "mode": mode, "multi_axis": True, "axes": list(labels), "controller": " / ".join(ctrls),
          "co_step_s": h, "operating_point": op.as_dict(), "angle_model": "state (full Jacobian along the path)",
          "plant": {"reduced": matrices(red)}, "warnings": _limit_warnings(mach, op)}
    if multibody:
        Am, Bm = multibody_mechanics_n(mach, op, scn.multibody_options())
        mb = plant_n(Am, Bm, drives, labels, name="multibody_input")
        objs["plant_multibody_input"] = mb
        js["plant"]["multibody_input_coordinates"] = matrices(mb)
        js["agreement"] = {"reduced_vs_multibody_input_coordinates": mimo_difference(red, mb)}
    try:
        N = _period(mach, h)
        P_T = sample_n(plant_n(A, B, drives, labels, h=h, name="reduced_h"), N, labels)
        Cn = controller_n(mach, op, h)
    except ParameterError as e:
        js["loop_note"] = str(e)
        return {"json": plain(js), "objects": objs}
    lp = loop_n(P_T, Cn, labels)
    mg = margins_n(lp)
    objs["loop"], objs["margins"] = lp, mg
    js["control_period_s"] = float(P_T.dt)
    js["loop"] = {**mg, "plant_sampled": matrices(lp.plant), "controller": matrices(lp.controller)}
    return {"json": plain(js), "objects": objs}


def _limit_warnings(mach, op) -> list:
    out = []
    for k, (lab, d) in enumerate(zip(mach.axis_labels, mach.drives)):
        vm = float(getattr(d, "v_max", math.inf))
        if math.isfinite(op.V[k]) and math.isfinite(vm) and abs(op.V[k]) > vm:
            out.append(f"axis {lab}: the operating point needs V = {op.V[k]:.4g} V > v_max = {vm:.4g} V: the limiter "
                       f"saturates there, the linear model does not apply")
    return out


def mimo_difference(a, b, omega=None) -> dict:
    """max over ω and channels of |G_a − G_b| / max|G_a| (per channel's input column) for the speed
    outputs ``qd_*`` of two plants with the same signals."""
    if omega is None:
        omega = np.logspace(-1, 4, 300)
    qd = [o for o in a.output_labels if o.startswith("qd_")]
    ia = [a.output_labels.index(o) for o in qd]
    ib = [b.output_labels.index(o) for o in qd]
    Ga = _freq_response(a, omega)[:, ia, :]
    Gb = _freq_response(b, omega)[:, ib, :]
    scale = np.max(np.abs(Ga), axis=1, keepdims=True)  # per frequency and input: the largest response
    rel = np.abs(Ga - Gb) / np.where(scale > 0, scale, 1.0)
    k = np.unravel_index(int(np.argmax(rel)), rel.shape)
    return {"max_rel": float(rel[k]), "at_rad_s": float(omega[k[0]]), "output": qd[k[1]],
            "input": a.input_labels[k[2]], "omega_lo_rad_s": float(omega[0]), "omega_hi_rad_s": float(omega[-1]),
            "what": "max over ω of |G_reduced − G_multibody| of q̇_k/V_j, relative to the largest |q̇/V_j| at that ω"}


__all__ = ["MultiPoint", "path_operating_point", "path_references", "reduced_mechanics_n", "multibody_mechanics_n",
           "plant_n", "sample_n", "controller_n", "multi_law_counterpart", "axis_view", "MultiLoop", "loop_n",
           "margins_n", "sigma_peak", "sigma_curves", "study_n", "mimo_difference"]
