"""Linear analysis of a machine with python-control: plant, controller, loop, margins, modes.

A machine (mechanism + drive + controller) is linearised at an *operating point* — input angle
q*, input speed q̇* (crank side, rad/s), current I*, time t* (for K_p·t and time-dependent loads);
by default I* is, running, the current that sustains q̇* on average over a turn (a linkage's q̈* ≠ 0
at the point) and, at rest, the current that holds q̈ = 0 (:func:`operating_point`).  Everything returned is a python-control object
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

Layout (one module per concern; every name is importable from ``mjbench.linear``):
``signals`` (constants, signal names), ``point`` (operating point), ``mechanics`` (the linearised
reduced and MuJoCo mechanics), ``plant`` (plants, sampling, frequency responses, modes),
``controller`` (controller counterparts), ``loop`` (loop, margins, bandwidth), ``family``
(frozen-angle families, margin constraints, the K_p·t ramp limit), ``steps`` (step responses and
the nonlinear step check), ``study`` (``mjbench linearize``'s study).
"""
from __future__ import annotations

from .signals import FD_Q, FD_MB, LOCK_FACTOR, MEAS, SETPOINTS, LAW_INPUTS, REF_INPUTS, REF_OUTPUTS
from .point import OperatingPoint, operating_point
from .mechanics import (
    Mechanics, rigid_mechanics, reduced_mechanics, multibody_mechanics, to_input_coordinates, freeze_angle)
from .plant import (
    plant, sample, reduced_plant, multibody_plant, frequency_grid, response, frequency_difference, Mode,
    s_poles, modes, locked_input_machine, transmission_modes)
from .controller import (
    running_speed, reference_gain, setpoint_reference, passthrough_reference, pid_law, pid_controller,
    controller_counterpart)
from .loop import Loop, loop, Margins, bandwidth, loop_margins, margins, analyse
from .family import (
    Family, VALID_BELOW, FAILS_ABOVE, frozen_angle_family, worst_case, frozen_validity, MARGIN_KEYS,
    parse_margin, plant_family, family_margins, margin_violation, kp_ramp_limit)
from .steps import (
    step_response, rise_time, StepRefP, step_reference_law, StepReference, step_check, agree_above)
from .study import matrices, plain, study

__all__ = [
    "FD_Q", "FD_MB", "LOCK_FACTOR", "MEAS", "SETPOINTS", "LAW_INPUTS", "REF_INPUTS", "REF_OUTPUTS",
    "OperatingPoint", "operating_point", "Mechanics", "rigid_mechanics", "reduced_mechanics",
    "multibody_mechanics", "to_input_coordinates", "freeze_angle", "plant", "sample", "reduced_plant",
    "multibody_plant", "frequency_grid", "response", "frequency_difference", "Mode", "s_poles", "modes",
    "locked_input_machine", "transmission_modes", "running_speed", "reference_gain", "setpoint_reference",
    "passthrough_reference", "pid_law", "pid_controller", "controller_counterpart", "Loop", "loop",
    "Margins", "bandwidth", "loop_margins", "margins", "analyse", "Family", "VALID_BELOW", "FAILS_ABOVE",
    "frozen_angle_family", "worst_case", "frozen_validity", "MARGIN_KEYS", "parse_margin", "plant_family",
    "family_margins", "margin_violation", "kp_ramp_limit", "step_response", "rise_time", "StepRefP",
    "step_reference_law", "StepReference", "step_check", "agree_above", "matrices", "plain", "study"]
