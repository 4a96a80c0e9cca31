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
    """Base class of every controller (see the module docstring for the protocol)."""

    #: scenario ``[modes.NAME] type`` of this class
    type_name: ClassVar[str] = ""
    #: pydantic model of the ``[modes.NAME]`` table
    Params: ClassVar[type | None] = None
    #: names of the attributes that make up the controller's discrete state
    STATE: ClassVar[tuple[str, ...]] = ()
    #: sample period [s]; 0 = every co-simulation step
    period: float = 0.0

    @classmethod
    @abc.abstractmethod
    def from_params(cls, params, drive=None, mechanism=None, scenario=None) -> "Controller":
        """Build the controller from its validated Params (and the machine it controls)."""

    @abc.abstractmethod
    def reset(self) -> None:
        """Clear the state (called by the kernel before every run)."""

    @abc.abstractmethod
    def __call__(self, t, y: Measurement):
        """One control sample: time [s] and measurement → armature voltage [V]."""

    def state(self) -> dict:
        """The current discrete state {name: value} (copies of the attributes in ``STATE``)."""
        return {k: getattr(self, k) for k in self.STATE}

    def describe(self) -> dict:
        return {"type": self.type_name or type(self).__name__, "period_s": self.period,
                **{k: v for k, v in vars(self).items() if not k.startswith("_") and k not in self.STATE
                   and _plain(v)}}


def _plain(v):
    return isinstance(v, (int, float, str, bool, type(None)))
