"""Controller counterparts: the controller (and its reference) as a discrete-time
``control.StateSpace`` at its period; the PID of Incerti 2012 Eq 16."""
from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .point import OperatingPoint
from .signals import FD_Q, LAW_INPUTS, REF_INPUTS, REF_OUTPUTS, _ct
from ..control import passthrough_reference, setpoint_reference  # noqa: F401 - (re-exported by mjbench.linear)
from ..kernel import control_every


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
