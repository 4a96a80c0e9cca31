"""What a controller sees and the small protocol every controller follows.

A controller is a small system (Drake's vocabulary): an output port (the armature voltage [V]),
an input port (a :class:`Measurement`), a sample ``period`` [s] and a visible discrete state.
The co-step kernel (:mod:`mjbench.kernel`) calls it once per control sample — every
``period`` seconds, or at every co-simulation step when ``period`` is 0 — and holds the output
in between.

**A controller is a law** (:mod:`mjbench.compiled`): one scalar function

    law(t, q, q̇, q̈, I, φ_ref, φ̇_ref, φ̈_ref, P, S) → u

of the crank-side measurement and the motor-side reference (from the controller's
``reference``, itself a law: :mod:`controllers.reference`), with parameters ``P`` (a namedtuple
built by :meth:`Controller.parameters` once per run from the sample period T and the gear ratio
z) and state ``S`` (a float array laid out as ``STATE``, fresh for every run).  The same function
is called by the object (``controller(t, y)``), by the kernel's loop in CPython and by the
compiled loop (numba): one implementation, the same bits.  The state of the Python calls is
visible through ``controller.state()``; nothing is shared between runs of a batch.

A new controller = one module with a :class:`Controller` subclass carrying ``type_name``, a
pydantic ``Params`` model (``[modes.NAME] type = type_name``), ``law``, ``STATE`` and
``parameters``, decorated with ``@controllers.register``; nothing else changes
(docs/CONTRIBUTING.md).  Invalid parameters raise :class:`mjbench.errors.ParameterError`.

Capabilities are methods of the class: :meth:`Controller.linear` (the discrete-time linear
counterpart for ``mjbench linearize`` and ``tune --margin``), :meth:`Controller.linear_reference`,
:meth:`Controller.running_speed`, :meth:`Controller.hold_offset` (``linear.step_check``).  A
controller without one raises a ParameterError naming the missing capability.
"""
from __future__ import annotations

import abc
from typing import ClassVar


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


class Controller(abc.ABC):
    """Base class of every controller (see the module docstring for the protocol).

    A controller with a compiled form sets ``law`` (a :func:`mjbench.compiled.law` of signature
    ``law(t, q, q̇, q̈, I, φ_ref, φ̇_ref, φ̈_ref, P, S) → u``: crank-side measurement, motor-side
    reference, parameters ``P`` from :meth:`parameters`, state ``S`` laid out as ``STATE``) and
    optionally ``reference`` (a :class:`controllers.reference.Reference`).  Its ``__call__`` then
    runs that law (one implementation for Python calls, the CPython kernel and the compiled
    kernel).  A law that takes other laws as leading arguments (SMC's model of the plant)
    overrides :meth:`form` and :meth:`form_law`.  A controller without a law overrides
    ``__call__`` and runs in the CPython kernel only (the run says why)."""

    #: scenario ``[modes.NAME] type`` of this class
    type_name: ClassVar[str] = ""
    #: pydantic model of the ``[modes.NAME]`` table
    Params: ClassVar[type | None] = None
    #: names of the controller's state variables (the law's ``S[0]``, ``S[1]`` …)
    STATE: ClassVar[tuple[str, ...]] = ()
    #: the control law (None: no compiled form, ``__call__`` is overridden)
    law: ClassVar = None
    #: sample period [s]; 0 = every co-simulation step
    period: float = 0.0
    #: the motor-side reference this controller tracks (None: none)
    reference = None
    #: the gains ``mjbench tune`` may search: {Params field: (lo, hi)}, the field's admissible
    #: interval (0 <= lo < hi, hi may be inf).  The search is log-scaled, within ×/÷ ``--span`` of
    #: the scenario's value (or ``--bounds``) clipped to (lo, hi); a finite interval is the search
    #: box when the scenario's value is 0.  Empty: ``tune`` cannot tune this controller.
    TUNABLE: ClassVar[dict[str, tuple[float, float]]] = {}
    #: named variants for ``tune --controller NAME``: {NAME: Params fields held fixed while tuning}
    #: (PID: ``pid`` constant K_p, ``pid-tv`` K_p·t).  Empty: the type name, nothing held.
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
        import numpy as np

        return np.zeros(len(self.STATE))

    def form(self, T: float, machine):
        """The compiled form for the kernel (:class:`mjbench.compiled.Form`; its reference as the
        child ``"reference"``), or None when the class has no law (the kernel then wraps
        ``__call__`` in a Python adapter)."""
        from mjbench import compiled as C

        if self.law is None:
            return None
        z = float(machine.drive.z) if machine is not None else 1.0
        return C.Form(type(self).law, self.parameters(T, z), self.initial_state(), children=self._children(T, z))

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

    def __call__(self, t, y: Measurement):
        """One control sample: time [s] and measurement → armature voltage [V] (runs the law)."""
        if getattr(self, "_S", None) is None:
            self.reset()
        if self._P is None or self._P_z != y.z:
            T = self.period if self.period > 0 else getattr(self, "_T", 0.0)
            self._P = self.parameters(T, float(y.z))
            self._P_z = y.z
        ref = self.reference(t, y) if self.reference is not None else (0.0, 0.0, 0.0)
        return self.form_law()(float(t), float(y.q), float(y.qd), float(y.qdd), float(y.current), *ref, self._P,
                               self._S)

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
        T (inputs q_ref, qd_ref, qdd_ref, q, qd, qd_prev, I, input side; output V), linearised at
        the operating point ``op`` (:class:`mjbench.linear.OperatingPoint`); h is the co-step (the
        backward-difference acceleration).  ``angle = "frozen"``: the angle is a parameter of a
        model-based law.  None: open loop (no feedback).  A class without this capability raises."""
        from mjbench.errors import ParameterError

        raise ParameterError(f"controller type {self.type_name or type(self).__name__!r} has no linear counterpart "
                             f"(capability linear(machine, op, T, h) not defined by {type(self).__name__})")

    def linear_reference(self, machine, op, T: float, h: float, feedback: bool = True):
        """The reference's linear counterpart (inputs q_set, qd_set, q, qd → q_ref, qd_ref, qdd_ref):
        the reference object's ``linear``; without a reference object the set-points pass through
        (a controller with its own set-point, e.g. SMC's ω_d)."""
        from mjbench import linear as LN
        from mjbench.errors import ParameterError

        ref = self.reference
        if ref is None:
            return LN.passthrough_reference(T)
        fn = getattr(ref, "linear", None)
        if fn is None:
            raise ParameterError(f"reference {type(ref).__name__} has no linear counterpart (capability "
                                 f"linear(machine, op, T, h, feedback) not defined)")
        return fn(machine, op, T, h, feedback)

    def running_speed(self, machine, q: float) -> float:
        """The input speed [rad/s] the controller asks for at angle q (its reference's; 0 when it
        cannot say)."""
        fn = getattr(self.reference, "crank_speed_at", None)
        v = fn(machine, q) if fn is not None else None
        return 0.0 if v is None else float(v)

    def hold_offset(self, machine, op) -> float:
        """Angle offset [rad, input side] of a reference that makes the controller output the
        operating point's voltage V* at the point (``linear.step_check`` starts there, steady).
        A class without this capability raises."""
        from mjbench.errors import ParameterError

        raise ParameterError(f"step_check: controller type {self.type_name or type(self).__name__!r} not supported "
                             f"(capability hold_offset(machine, op) not defined by {type(self).__name__}; "
                             f"pid and servo have it)")


def reference_form(ref, T: float, z: float):
    """A reference's compiled form, or a Python adapter of its ``__call__(t, y)`` when it has none."""
    from mjbench import compiled as C

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


def _plain(v):
    return isinstance(v, (int, float, str, bool, type(None)))
