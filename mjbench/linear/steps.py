"""Time-domain checks of the linear model: step responses, and the nonlinear machine's step
against them (:func:`step_check`)."""
from __future__ import annotations

import dataclasses
from collections import namedtuple

from ..control import Reference as _Reference
import numpy as np

from ..compiled import law
from ..errors import ParameterError
from .loop import Loop, analyse
from .plant import response
from .point import OperatingPoint
from .signals import _ct
from ..backends import simulate
from ..kernel import control_every


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


# ============================================================================ one scenario
def agree_above(a, b, omega, tol=0.01, output="qd", input="V"):
    """Lowest frequency [rad/s] above which |G_a − G_b|/|G_a| stays below ``tol`` (None: never)."""
    Ga, Gb = response(a, omega, output, input), response(b, omega, output, input)
    bad = np.flatnonzero(np.abs(Ga - Gb) / np.abs(Ga) >= tol)
    if len(bad) == 0:
        return float(omega[0])
    return float(omega[bad[-1] + 1]) if bad[-1] + 1 < len(omega) else None
