"""The operating point a machine is linearised at (:func:`operating_point`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .signals import _sgn


# ============================================================================ operating point
@dataclass
class OperatingPoint:
    """Where the machine is linearised (SI, input side): angle q [rad], speed qd [rad/s],
    current I [A], voltage V [V] (R·I + k_m·z·q̇, dI/dt = 0), drive torque tau [N·m] (without
    the viscous part), acceleration qdd [rad/s²] at that state, time t [s], internal coordinates
    x and rates xd."""

    q: float
    qd: float
    I: float
    V: float
    tau: float
    qdd: float = 0.0
    t: float = 0.0
    x: tuple = ()
    xd: tuple = ()

    def as_dict(self) -> dict:
        return {"q_rad": self.q, "qd_rad_s": self.qd, "I_A": self.I, "V_V": self.V, "tau_Nm": self.tau,
                "qdd_rad_s2": self.qdd, "t_s": self.t, "x": list(self.x), "xd": list(self.xd)}


def _accel(machine, q, qd, x, xd, tau, t):
    """(q̈, ẍ) of the reduced model (drive inertia and viscous friction included)."""
    d = machine.drive
    return machine.mechanism.reduced_accel(t, q, qd, tuple(x), tuple(xd), tau, float(d.J_eq), float(d.crank_damping))


def _holding_torque(machine, q, qd, x, xd, t):
    """Drive torque τ that gives q̈ = 0 at the state (q̈ is affine in τ)."""
    a0 = _accel(machine, q, qd, x, xd, 0.0, t)[0]
    a1 = _accel(machine, q, qd, x, xd, 1.0, t)[0]
    return -a0 / (a1 - a0)


def operating_point(machine, q=0.0, qd=0.0, I=None, t=0.0, x=None, xd=None, n_mean: int = 72) -> OperatingPoint:
    """The operating point at (q, q̇) [rad, rad/s].  ``I=None``: at rest (q̇ = 0) the current that
    holds q̈ = 0 there (gravity balanced); running (q̇ ≠ 0) the current that sustains the speed
    on average over a turn (the mean of the holding currents at q̇ over ``n_mean`` angles): a
    linkage running at constant speed is not at a stationary point — its q̈* ≠ 0 follows.  The
    frozen-angle model (:func:`freeze_angle`) does not depend on I*."""
    mech, d = machine.mechanism, machine.drive
    nx = len(mech.internal)
    x = tuple(float(v) for v in (x or (0.0,) * nx))
    xd = tuple(float(v) for v in (xd or (0.0,) * nx))
    for name, v in (("q", q), ("omega", qd), ("t", t)):
        if not math.isfinite(float(v)):
            raise ParameterError(f"operating point {name} = {v!r}: must be finite")
    q, qd, t = float(q), float(qd), float(t)
    z, km = float(d.z), float(d.k_m)
    fric = float(d.T_0) * _sgn(z * qd)
    if I is None:
        if qd == 0.0:
            tau = _holding_torque(machine, q, qd, x, xd, t)
        else:
            qs = np.linspace(0.0, 2 * np.pi, int(n_mean), endpoint=False)
            tau = float(np.mean([_holding_torque(machine, qq, qd, x, xd, t) for qq in qs]))
        I = (tau / z + fric) / km
    I = float(I)
    if not math.isfinite(I):
        raise ParameterError(f"operating point current I = {I!r}: must be finite")
    tau = z * (km * I - fric)
    V = float(d.R) * I + km * z * qd
    qdd = float(_accel(machine, q, qd, x, xd, tau, t)[0])
    return OperatingPoint(q, qd, I, V, tau, qdd, t, x, xd)
