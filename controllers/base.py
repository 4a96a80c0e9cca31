"""What a controller sees and the small protocol every controller follows.

A controller is a small system (Drake's vocabulary): an output port (the armature voltage [V]),
an input port (a :class:`Measurement`), a sample ``period`` [s] and a visible discrete state.
The co-step kernel (:mod:`mjbench.kernel`) calls it once per control sample — every
``period`` seconds, or at every co-simulation step when ``period`` is 0 — and holds the output
in between; ``reset()`` clears the state before a run.  The state is in public attributes listed
in ``STATE`` (``controller.state()`` returns them), never hidden.

Every controller accepts scalars or NumPy arrays of shape (nsim,) for its gains and signals (a
batch of N simulations runs one controller object with (nsim,) gains).  Invalid parameters raise
:class:`mjbench.errors.ParameterError` (the CLI: one message, exit 2).

A new controller = one module with a :class:`Controller` subclass carrying ``type_name`` and a
pydantic ``Params`` model (``[modes.NAME] type = type_name``), decorated with
``@controllers.register``; nothing else changes.
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
    optionally ``reference`` (an object with ``form(T, z)``).  Its ``__call__`` then runs that law
    (one implementation for Python calls, the CPython kernel and the compiled kernel).  A
    controller without a law overrides ``__call__`` and runs in the CPython kernel only."""

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
        """The compiled form for the kernel (:class:`mjbench.compiled.Form`), or a Python adapter
        when the class has no law."""
        from mjbench import compiled as C

        z = float(machine.drive.z) if machine is not None else 1.0
        if self.law is None:
            return None
        children = {}
        if self.reference is not None:
            children["reference"] = reference_form(self.reference, T, z)
        return C.Form(type(self).law, self.parameters(T, z), self.initial_state(), children=children)

    def reset(self) -> None:
        """Clear the state before a run (Python calls; the kernel starts every run from
        :meth:`initial_state`)."""
        self._S = self.initial_state()
        self._P = self._P_z = None
        if self.reference is not None:
            self.reference.reset()

    def __call__(self, t, y: Measurement):
        """One control sample: time [s] and measurement → armature voltage [V] (runs the law)."""
        if getattr(self, "_S", None) is None:
            self.reset()
        if self._P is None or self._P_z != y.z:
            self._P = self.parameters(self.period, y.z)
            self._P_z = y.z
        ref = self.reference(t, y) if self.reference is not None else (0.0, 0.0, 0.0)
        return self.form_law()(t, y.q, y.qd, y.qdd, y.current, *ref, self._P, self._S)

    def form_law(self):
        """The law as the kernel calls it (with its function arguments bound, if any)."""
        return type(self).law

    def state(self) -> dict:
        """The current discrete state {name: value} (copies of the attributes in ``STATE``)."""
        S = getattr(self, "_S", None)
        if S is None:
            self.reset()
            S = self._S
        return {k: float(S[i]) for i, k in enumerate(self.STATE)}

    def describe(self) -> dict:
        return {"type": self.type_name or type(self).__name__, "period_s": self.period,
                **{k: v for k, v in vars(self).items() if not k.startswith("_") and k not in self.STATE
                   and _plain(v)}}


def reference_form(ref, T: float, z: float):
    """A reference's compiled form, or a Python adapter of its ``__call__(t, y)`` when it has none."""
    from mjbench import compiled as C

    fn = getattr(ref, "form", None)
    if fn is not None:
        return fn(T, z)
    y = Measurement(z=z)

    def adapter(t, q, qd, qdd, I, P, S):
        return ref(t, y.set(t, q, qd, qdd, I))
    return C.python_form(adapter, f"reference {type(ref).__name__} has no compiled form (no law)")


def _plain(v):
    return isinstance(v, (int, float, str, bool, type(None)))
