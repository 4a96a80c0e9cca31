"""The component interface of controllers and references: what the kernel and the studies use.

A controller is a small system (Drake's vocabulary): it reads named signals (:mod:`mjbench.signals`:
the measurement, its references, the applied voltage, the drive's limits …) at a sample ``period``
[s] and writes its output ``u`` (the drive's command), with a visible discrete state.  The co-step
kernel (:mod:`mjbench.kernel`) calls it once per control sample — every ``period`` seconds, or at
every co-simulation step when ``period`` is 0 — and holds the output in between.

**A controller is a law** (:mod:`mjbench.compiled`): one scalar function whose parameters name the
signals it reads, then its parameter tuple ``P`` (:meth:`Controller.parameters`, computed once per
run from the sample period T and the gear ratio z) and its state ``S`` (laid out as ``STATE``,
fresh for every run)::

    @law(outputs=("u",))
    def pid_law(t, q, qd, qdd, phi_ref, om_ref, acc_ref, P, S): ...

The same function is called by the object (``controller(t, y)``), by the kernel's loop in CPython
and by the compiled loop (numba): one implementation, the same bits.  A reference is a law the same
way, writing ``phi_ref``, ``om_ref``, ``acc_ref`` (motor side).

A new controller = one module with a :class:`Controller` subclass carrying ``type_name``, a
pydantic ``Params`` model (``[modes.NAME] type = type_name``), ``law``, ``STATE`` and
``parameters``, registered with ``@controllers.register`` (or an entry point); nothing else
changes (docs/CONTRIBUTING.md).  Invalid parameters raise :class:`mjbench.errors.ParameterError`.

Capabilities are methods and attributes of the class — never asked by type or field name
elsewhere: :meth:`Controller.linear` (the linear counterpart; by default the law linearised
numerically, :mod:`mjbench.linearise`), :meth:`Controller.linear_reference`,
:meth:`Controller.running_speed`, :meth:`Controller.setpoint`, :meth:`Controller.hold_offset`,
:meth:`Controller.hold`, :attr:`Controller.closed_loop`, :meth:`Controller.metrics`.
"""
from __future__ import annotations

import abc
import copy
import math
from collections import namedtuple
from typing import ClassVar

import numpy as np

from . import compiled as C
from . import signals as SIG
from .errors import ParameterError
from .linearise import LAW_INPUTS, hold_offset, law_counterpart
from .registry import GROUPS, Registry
from .signals import call_law, law_signals  # noqa: F401 - part of the component interface

#: inputs and outputs of a reference's linear counterpart
REF_INPUTS = ("q_set", "qd_set", "q", "qd")
REF_OUTPUTS = ("q_ref", "qd_ref", "qdd_ref")
FD_Q = 1e-6  #: [rad] central-difference step for derivatives in q


class Measurement:
    """Signals available to a controller at one control instant (SI units).

    t [s]; q, qd, qdd: input (crank) angle [rad], speed [rad/s], acceleration [rad/s²];
    phi, omega, omega_dot: the same on the motor shaft (× gear ratio z); current [A].
    ``qdd`` is the backward difference (α̇_n − α̇_{n−1})/h over the last co-simulation step, as a
    digital controller differencing its speed signal sees it; both backends define it the same
    way (0 at the first sample).
    """

    __slots__ = ("t", "q", "qd", "qdd", "phi", "omega", "omega_dot", "current", "z")

    def __init__(self, z=1.0):
        self.z = z
        self.t = self.q = self.qd = self.qdd = 0.0
        self.phi = self.omega = self.omega_dot = self.current = 0.0

    def set(self, t, q, qd, qdd, current):
        """Fill every field from the input-coordinate values (motor side = z × crank side)."""
        z = self.z
        self.t, self.q, self.qd, self.qdd, self.current = t, q, qd, qdd, current
        self.phi, self.omega, self.omega_dot = z * q, z * qd, z * qdd
        return self

    def signals(self) -> dict:
        """The measurement as named signals (:mod:`mjbench.signals`)."""
        return {"t": self.t, "q": self.q, "qd": self.qd, "qdd": self.qdd, "I": self.current, "z": self.z}


class Controller(abc.ABC):
    """Base class of every controller (see the module docstring for the protocol).

    A controller with a compiled form sets ``law`` (a :func:`mjbench.compiled.law` reading named
    signals, then ``P`` from :meth:`parameters` and ``S`` laid out as ``STATE``) and optionally
    ``reference`` (a :class:`Reference`).  Its ``__call__`` then runs that law (one implementation
    for Python calls, the CPython kernel and the compiled kernel).  A law that takes other laws as
    leading arguments (SMC's model of the plant) overrides :meth:`form` and :meth:`form_law`.  A
    controller without a law overrides ``__call__`` and runs in the CPython kernel only (the run
    says why)."""

    #: scenario ``[modes.NAME] type`` of this class
    type_name: ClassVar[str] = ""
    #: pydantic model of the ``[modes.NAME]`` table
    Params: ClassVar[type | None] = None
    #: names of the controller's state variables (the law's ``S[0]``, ``S[1]`` …)
    STATE: ClassVar[tuple[str, ...]] = ()
    #: the control law (None: no compiled form, ``__call__`` is overridden)
    law: ClassVar = None
    #: whether the output depends on the measurement (False: an open-loop command; frest and tune
    #: then measure or tune nothing closed)
    closed_loop: ClassVar[bool] = True
    #: whether a parameter of the law changes with time (K_p·t): :meth:`frozen` fixes it at a time
    time_varying: bool = False
    #: sample period [s]; 0 = every co-simulation step
    period: float = 0.0
    #: the axis whose signals the law reads without a suffix (a machine with several motors)
    axis: int = 0
    #: the motor-side reference this controller tracks (None: none)
    reference = None
    #: the gains ``mjbench tune`` may search: {Params field: (lo, hi)}, the field's admissible
    #: interval (0 <= lo < hi, hi may be inf).  Empty: ``tune`` cannot tune this controller.
    TUNABLE: ClassVar[dict[str, tuple[float, float]]] = {}
    #: named variants for ``tune --controller NAME``: {NAME: Params fields held fixed while tuning}
    TUNE_VARIANTS: ClassVar[dict[str, dict]] = {}

    @classmethod
    @abc.abstractmethod
    def from_params(cls, params, drive=None, mechanism=None, scenario=None) -> "Controller":
        """Build the controller from its validated Params (and the machine it controls)."""

    def parameters(self, T: float, z: float):
        """The law's parameter tuple for sample period T [s] (the co-simulation step when
        ``period`` = 0) and gear ratio z (motor per crank).  Everything derived from the
        controller's settings is computed here, once per run (never shared state)."""
        raise NotImplementedError(f"{type(self).__name__} has a law but no parameters()")

    def initial_state(self):
        """The law's state at the start of a run (default: zeros, one per ``STATE`` name)."""
        return np.zeros(len(self.STATE))

    def form(self, T: float, machine):
        """The compiled form for the kernel (:class:`mjbench.compiled.Form`; its reference as the
        child ``"reference"``), or None when the class has no law (the kernel then wraps
        ``__call__`` in a Python adapter)."""
        if self.law is None:
            return None
        z = float(machine.drives[self.axis].z) if machine is not None else 1.0
        return C.Form(type(self).law, self.parameters(T, z), self.initial_state(), children=self._children(T, z),
                      what=f"controller {self.type_name or type(self).__name__!r}")

    def _children(self, T, z) -> dict:
        if self.reference is None:
            return {}
        return {"reference": reference_form(self.reference, T, z)}

    def reset(self) -> None:
        """Clear the state before a run (Python calls; the kernel starts every run from
        :meth:`initial_state`)."""
        self._S = self.initial_state()
        self._P = self._P_z = None
        if self.reference is not None:
            self.reference.reset()

    def prepare(self, T: float) -> "Controller":
        """Set the sample period T [s] the Python calls assume when ``period`` is 0 (the kernel
        passes its co-step h; a law whose parameters depend on T — a discretised filter — needs it
        for calls outside the kernel).  Kept across ``reset()``."""
        self._T = float(T)
        self._P = None
        return self

    def __call__(self, t, y: Measurement, signals: dict | None = None):
        """One control sample: time [s] and measurement → the command (runs the law).  ``signals``:
        further named signals (the applied voltage ``V`` …; absent ones read 0)."""
        if getattr(self, "_S", None) is None:
            self.reset()
        if self._P is None or self._P_z != y.z:
            T = self.period if self.period > 0 else getattr(self, "_T", 0.0)
            self._P = self.parameters(T, float(y.z))
            self._P_z = y.z
        values = y.signals()
        values["t"] = float(t)
        if signals:
            values.update(signals)
        if self.reference is not None:
            values["phi_ref"], values["om_ref"], values["acc_ref"] = self.reference(t, y)
        return call_law(self.form_law(), values, self._P, self._S)

    def form_law(self):
        """The law as the kernel calls it (with its function arguments bound, if any)."""
        return type(self).law

    def state(self) -> dict:
        """The current discrete state of the Python calls {name: value} (``STATE`` order)."""
        S = getattr(self, "_S", None)
        if S is None:
            self.reset()
            S = self._S
        return {k: float(S[i]) for i, k in enumerate(self.STATE)}

    def describe(self) -> dict:
        return {"type": self.type_name or type(self).__name__, "period_s": self.period,
                **{k: v for k, v in vars(self).items() if not k.startswith("_") and k not in self.STATE
                   and _plain(v)}}

    # ------------------------------------------------------------------ capabilities
    def linear(self, machine, op, T: float, h: float, angle: str = "state"):
        """The control law's linear counterpart: a discrete-time ``control.StateSpace`` at period
        T (inputs :data:`LAW_INPUTS`: q_ref, qd_ref, qdd_ref, q, qd, qd_prev, I, input side; output
        V), linearised at the operating point ``op``; h is the co-step (the backward-difference
        acceleration).  None: open loop (no feedback).  Default: the law itself linearised
        numerically around the point, its state included (:func:`mjbench.linearise.law_counterpart`);
        a class may write its own (the tests compare both)."""
        if not self.closed_loop:
            return None
        return law_counterpart(self, machine, op, T, h, angle)

    def linear_reference(self, machine, op, T: float, h: float, feedback: bool = True):
        """The reference's linear counterpart (inputs q_set, qd_set, q, qd → q_ref, qd_ref, qdd_ref):
        the reference object's ``linear``; without a reference object the set-points pass through
        (a controller with its own set-point, e.g. SMC's ω_d)."""
        ref = self.reference
        if ref is None:
            return passthrough_reference(T)
        return ref.linear(machine, op, T, h, feedback)

    def running_speed(self, machine, q: float) -> float:
        """The input speed [rad/s] the controller asks for at angle q (its reference's; 0 when it
        cannot say)."""
        fn = getattr(self.reference, "crank_speed_at", None)
        v = fn(machine, q) if fn is not None else None
        return 0.0 if v is None else float(v)

    def setpoint(self, machine) -> dict | None:
        """The speed the controller holds, on both shafts: ``{"input_rad_s", "motor_rad_s", "z", "source"}``
        (``source``: the parameter it was given by and its shaft, e.g. ``"omega_crank (crank shaft)"``;
        ``metrics.json "setpoint"``, the printed summary), or None when it has
        no constant set-point (a motion law, an open-loop command).  Default: from the reference's
        constant speed, if any."""
        fn = getattr(self.reference, "setpoint", None)
        return fn(machine) if fn is not None else None

    def hold_offset(self, machine, op) -> float:
        """Angle offset [rad, input side] of a reference that makes the controller output the
        operating point's voltage V* at the point (``linear.step_check``, ``frest`` start there,
        steady).  Default: found numerically from the law — the offset q_off at which the law,
        fed the point's measurement and a constant-speed reference through q* + q_off, outputs V*
        (a controller whose output does not depend on the angle error raises)."""
        return hold_offset(self, machine, op)

    def hold(self, machine, op):
        """This controller held at the operating point ``op``: time-varying gains frozen at t*
        (:meth:`frozen`), the reference replaced by a constant speed q̇* through q* + the hold
        offset (so the output at the point is V*; through q* itself for a law whose output does not
        depend on the angle error).  What ``frest`` runs."""
        ctrl = self.frozen(op.t)
        if ctrl.reference is not None:
            z = float(machine.drive.z)
            try:
                q_off = ctrl.hold_offset(machine, op)
            except ParameterError:  # its output does not depend on the angle: the reference through q* itself
                q_off = 0.0
            ctrl.reference = ConstantSpeed(z * op.qd, phi0=z * (op.q + q_off))
        ctrl.reset()
        return ctrl

    def frozen(self, t: float) -> "Controller":
        """A copy with every time-varying parameter frozen at time t (default: a plain copy)."""
        return copy.copy(self)

    def metrics(self, trajectory, machine, config) -> dict:
        """Metric families this controller adds to a run's metrics (default: its reference's)."""
        fn = getattr(self.reference, "metrics", None)
        return fn(trajectory, machine, config) if fn is not None else {}


# ============================================================================ references
class Reference:
    """Base of the references: a law ``(signals…, P, S) → (φ_ref, φ̇_ref, φ̈_ref)`` [rad, rad/s,
    rad/s², motor side] reading named signals (seed 002's on-line reference reads the measured
    angle), with parameters ``P`` (:meth:`parameters`, once per run) and state ``S``
    (:meth:`initial_state`, laid out as ``STATE``).  The kernel calls it in its REF slot (compiled
    or in CPython); ``__call__(t, y)`` runs the same law from Python with the object's own state
    (``reset()`` clears it).  A reference whose law takes other laws as leading arguments (a motion
    law, a speed profile) overrides :meth:`form` and lists them in ``Form.fn_args``."""

    law = None
    STATE: tuple = ()
    #: sample period the Python calls assume [s] (the kernel passes the controller's)
    period = 0.0

    def parameters(self, T, z):
        """The law's parameter tuple for control period T [s] and gear ratio z (motor per crank)."""
        raise NotImplementedError(f"{type(self).__name__} has a law but no parameters()")

    def initial_state(self):
        return np.zeros(len(self.STATE))

    def form(self, T, z):
        """The reference's compiled form (:class:`mjbench.compiled.Form`) for period T and ratio z."""
        return C.Form(type(self).law, self.parameters(T, z), self.initial_state(),
                      what=f"reference {type(self).__name__}")

    def reset(self):
        """Fresh state for the Python calls (the kernel starts every run from :meth:`initial_state`)."""
        self._S = self.initial_state()
        self._fn = self._P = self._z = None

    def _prepare(self, z):
        f = self.form(float(getattr(self, "period", 0.0) or 0.0), z)
        self._fn, self._P, self._z = f.bound(), f.P, z

    def __call__(self, t, y=None):
        """(φ_ref, φ̇_ref, φ̈_ref) at time t [s] for the measurement y (None: zeros, z = 1)."""
        if getattr(self, "_S", None) is None:
            self.reset()
        z = float(getattr(y, "z", 1.0)) if y is not None else 1.0
        if self._fn is None or self._z != z:
            self._prepare(z)
        values = y.signals() if y is not None else {"z": 1.0}
        values["t"] = float(t)
        return tuple(call_law(self._fn, values, self._P, self._S))

    def state(self) -> dict:
        if getattr(self, "_S", None) is None:
            self.reset()
        return {k: float(self._S[i]) for i, k in enumerate(self.STATE)}

    # ------------------------------------------------------------------ capabilities
    def linear(self, machine, op, T, h, feedback=True):
        """The reference's linear counterpart (python-control, discrete time at period T): inputs
        q_set, qd_set, q, qd → q_ref, qd_ref, qdd_ref (input side).  Default, for a reference of
        time only (it does not read the measurement): q_ref = q_set + Σ T·qd_set (exactly ω₀·t
        for a step), q̇_ref = qd_set, q̈_ref = 0 (a set-point step is not differentiated).  A
        reference that reads the measured angle overrides this (``CouplerSpeed``)."""
        return setpoint_reference(T)

    def crank_speed_at(self, machine, q):
        """The input speed [rad/s] this reference asks for at angle q (linear analysis' running
        point); None when it has no single answer."""
        return None


ConstantSpeedP = namedtuple("ConstantSpeedP", "omega0 z")


@C.law(outputs=SIG.REFERENCE_OUTPUTS)
def constant_speed_law(t, q, P, S):
    """φ_ref = φ_start + ω₀·t, φ̇_ref = ω₀, φ̈_ref = 0 (motor side).  S[0] = φ_start (NaN: taken
    from the first measurement, φ_start = z·q − ω₀·t)."""
    if math.isnan(S[0]):
        S[0] = P.z * q - P.omega0 * t
    return S[0] + P.omega0 * t, P.omega0, 0.0 * P.omega0


class ConstantSpeed(Reference):
    """Incerti 2012 §II-D: φ̇_ref = ω₀, φ_ref = φ₀ + ω₀·t, φ̈_ref = 0.

    ``phi0`` [rad] (motor side): the reference angle at t = 0; ``None`` (default) starts it from the
    first measurement (φ_ref = φ at the first sample), so a machine started at q0 ≠ 0 has no
    initial position error (the integral term K_i·(φ_ref − φ) starts at zero; for q0 = 0 this is
    the paper's φ_ref = ω₀·t)."""

    STATE = ("phi_start",)
    law = constant_speed_law

    def __init__(self, omega0: float, phi0: float | None = None):
        self.omega0 = omega0
        self.phi0 = phi0
        self.reset()

    def parameters(self, T, z):
        return ConstantSpeedP(float(self.omega0), float(z))

    def initial_state(self):
        return np.array([math.nan if self.phi0 is None else float(self.phi0)])

    def crank_speed_at(self, machine, q):
        return float(self.omega0) / float(machine.drive.z)

    def setpoint(self, machine) -> dict:
        z = float(machine.drive.z)
        return {"input_rad_s": float(self.omega0) / z, "motor_rad_s": float(self.omega0), "z": z,
                "source": "omega0 (motor shaft)"}

    @property
    def phi_start(self):
        """φ_start [rad] of the Python calls (state; None before the first call)."""
        v = self.state()["phi_start"]
        return None if math.isnan(v) else v


# ============================================================================ forms for the kernel
def reference_form(ref, T: float, z: float):
    """A reference's compiled form, or a Python adapter of its ``__call__(t, y)`` when it has none."""
    fn = getattr(ref, "form", None)
    if fn is not None:
        return fn(T, z)
    reset = getattr(ref, "reset", None)
    if reset is not None:  # the adapter runs the object's own state: fresh for this run
        reset()
    y = Measurement(z=z)

    def adapter(t, q, qd, qdd, I, P, S):
        return ref(t, y.set(t, q, qd, qdd, I))
    return C.python_form(adapter, f"reference {type(ref).__name__} has no compiled form (no law)")


def controller_form(ctrl, h: float, every: int, machine) -> C.Form:
    """The controller's form; a controller without one (a plain ``__call__(t, y)``) runs through a
    Python adapter reading the whole signal array (the loop then runs in CPython): it gets the
    measurement, and every named signal when its ``__call__`` takes ``signals``."""
    fn = getattr(ctrl, "form", None)
    f = fn(h * every, machine) if fn is not None else None
    if f is not None:
        return f
    reset = getattr(ctrl, "reset", None)
    if reset is not None:  # a plain Python controller keeps its state in itself: start it afresh
        reset()
    axis = int(getattr(ctrl, "axis", 0) or 0)
    y = Measurement(z=machine.drives[axis].z)
    idx = {n: SIG.index(n, axis) for n in SIG.AXIS}
    it = SIG.index("t")
    takes = _takes_signals(ctrl)

    def adapter(Y, P, S):
        t = Y[it]
        y.set(t, Y[idx["q"]], Y[idx["qd"]], Y[idx["qdd"]], Y[idx["I"]])
        if takes:
            return ctrl(t, y, {n: Y[i] for n, i in idx.items()})
        return ctrl(t, y)

    return C.python_form(adapter, f"{type(ctrl).__name__} has no compiled form (no law): the CPython loop runs it")


def _takes_signals(ctrl) -> bool:
    import inspect

    try:
        return "signals" in inspect.signature(ctrl.__call__).parameters
    except (TypeError, ValueError):
        return False


class FunctionController:
    """A plain Python function as the controller: ``f(t, y) -> u``, with ``y`` a mapping of the
    trajectory's column names to their present values at the control sample — ``t_s``,
    ``crank_angle_rad``, ``crank_speed_rad_s``, ``crank_accel_rad_s2``, ``motor_speed_rad_s``,
    ``current_A`` (as measured: after the sensor, if the drive has one), ``voltage_V`` (applied over
    the last co-step), ``torque_crank_Nm`` (the drive torque applied over the last co-step, without
    the viscous part) — and every signal name of :mod:`mjbench.signals` (``q``, ``V``, ``u_max`` …).
    Sampled every ``period`` s (0: every co-step); it runs the CPython loop (a Python function is
    not a law) and the run says so in ``loop_reason``."""

    closed_loop = True
    time_varying = False
    reference = None
    axis = 0
    type_name = "function"

    def __init__(self, fn, period: float = 0.0):
        if not callable(fn):
            raise ParameterError(f"controller = {fn!r}: give a function f(t, y) -> u (or a controller object)")
        self.fn, self.period = fn, float(period)
        self.__name__ = getattr(fn, "__name__", "function")

    def reset(self):
        pass

    def __call__(self, t, y, signals=None):
        s = dict(signals or {})
        z = float(getattr(y, "z", 1.0))
        view = {"t_s": float(t), "crank_angle_rad": float(y.q), "crank_speed_rad_s": float(y.qd),
                "crank_accel_rad_s2": float(y.qdd), "motor_speed_rad_s": z * float(y.qd), "current_A": float(y.current),
                "voltage_V": float(s.get("V", math.nan)), "torque_crank_Nm": float(s.get("tau", math.nan))}
        view.update({k: float(v) for k, v in s.items()})
        view["t"] = float(t)
        u = self.fn(float(t), view)
        try:
            u = float(u)
        except (TypeError, ValueError):
            raise ParameterError(f"controller function {self.__name__}: returned {u!r} at t = {t:.6g} s; it must "
                                 f"return a number (the drive's command)") from None
        if not math.isfinite(u):
            raise ParameterError(f"controller function {self.__name__}: returned {u!r} at t = {t:.6g} s (not finite)")
        return u

    def describe(self) -> dict:
        return {"type": "function", "function": f"{getattr(self.fn, '__module__', '?')}.{self.__name__}",
                "period_s": self.period}

    def setpoint(self, machine):
        return None

    def metrics(self, trajectory, machine, config) -> dict:
        return {}

    def hold(self, machine, op):
        raise ParameterError("a controller function has no operating-point hold (frest, step checks): use a "
                             "controller class")

    def frozen(self, t):
        return self

    def linear(self, machine, op, T, h, angle="state"):
        raise ParameterError("a controller function has no linear counterpart: write it as a law (a Controller "
                             "class) to get one numerically (docs/CONTRIBUTING.md)")


# ============================================================================ linear counterparts
def _ct():
    import control

    return control


def setpoint_reference(T):
    """A time-based reference as a DT system at period T (constant speed, motion law): q_ref =
    q_set + Σ T·qd_set (exactly ω0·t for a step), q̇_ref = qd_set, q̈_ref = 0 (a set-point step is
    not differentiated).  Inputs q_set, qd_set, q, qd → q_ref, qd_ref, qdd_ref."""
    ct = _ct()
    A = np.array([[1.0]])
    B = np.array([[0.0, T, 0.0, 0.0]])
    Cm = np.array([[1.0], [0.0], [0.0]])
    D = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    return ct.ss(A, B, Cm, D, T, inputs=list(REF_INPUTS), outputs=list(REF_OUTPUTS), states=["qref_int"],
                 name="reference")


def passthrough_reference(T):
    """The set-points themselves (a controller with its own set-point, e.g. SMC's ω_d): q_ref =
    q_set, q̇_ref = qd_set, q̈_ref = 0."""
    ct = _ct()
    return ct.ss(np.zeros((0, 0)), np.zeros((0, 4)), np.zeros((3, 0)),
                 [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 0, 0]], T, inputs=list(REF_INPUTS),
                 outputs=list(REF_OUTPUTS), name="reference")


def _plain(v):
    return isinstance(v, (int, float, str, bool, type(None)))


# ============================================================================ the registry
#: built-in controller types → the module that registers them (imported on first use, by name: the
#: engine finds controllers through this registry, never by importing them)
BUILTIN = {"open": "controllers.openloop", "pid": "controllers.pid", "smc": "controllers.smc",
           "servo": "controllers.servo", "fmu": "controllers.fmu", "constant": "controllers.constant",
           "computed_torque": "controllers.computed_torque", "signal": "controllers.signal"}

#: the controller registry (built-ins, plugins of entry-point group ``mjbench.controllers``, registered classes)
REGISTRY = Registry("controller", Controller, BUILTIN, GROUPS[1], prefix=("modes", "{typ}"),
                    unknown="controller type = {typ!r}", invalid="invalid controller table")


__all__ = ["Measurement", "Controller", "Reference", "ConstantSpeed", "constant_speed_law", "reference_form",
           "controller_form", "setpoint_reference", "passthrough_reference", "LAW_INPUTS", "REF_INPUTS",
           "REF_OUTPUTS", "FD_Q", "call_law", "law_signals", "REGISTRY", "BUILTIN", "FunctionController"]
