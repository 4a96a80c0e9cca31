"""What a controller sees and the tiny protocol it follows.

A controller is an object with ``reset()`` and ``__call__(t, y) -> V`` called once per control
step by whichever backend runs the machine.  ``y`` is a :class:`Measurement` the backend fills in
place (no allocation per step); every field is a float or an array of shape (nsim,).
Controllers never clip to the drive limit themselves unless given ``v_limit`` (then they use it
for anti-windup); the drive's limiter is applied by the backend anyway.
"""
from __future__ import annotations


class Measurement:
    """Signals available to a controller at one control instant (SI units).

    t [s]; q, qd, qdd: input (crank) angle [rad], speed [rad/s], acceleration [rad/s²];
    phi, omega, omega_dot: the same on the motor shaft (× gear ratio z); current [A].
    ``qdd`` is the backward difference (α̇_n − α̇_{n−1})/h over the last control period, as a
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


class Controller:
    """Base class: override ``__call__``; ``reset`` clears internal state."""

    def reset(self):  # pragma: no cover - trivial
        pass

    def __call__(self, t, y: Measurement):  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self) -> dict:
        return {"type": type(self).__name__,
                **{k: v for k, v in vars(self).items() if not k.startswith("_") and _plain(v)}}


def _plain(v):
    return isinstance(v, (int, float, str, bool, type(None)))
