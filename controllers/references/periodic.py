"""A motion law over one cycle, repeated: the reference of a crank that turns continuously.

``[modes.NAME.reference] type = "law"`` with ``period = P`` [s]: the scenario's ``[law]`` (a
rest-to-rest move of the motor by Φ in T ≤ P, motor side) is repeated every period, each cycle
starting where the previous one ended, Φ further:

    φ_ref(t) = scale·(k·Φ + φ(t − t0 − k·P)),   k = ⌊(t − t0)/P⌋  (k = 0 before t0: at rest),

with its derivatives; between T and P of each cycle the motor dwells (φ stays at (k+1)·Φ).  A
crank driven once round per cycle (an indexing table, a transfer, a press run by a servo) has
Φ = 2π·z.  The law (:func:`periodic_law_reference`) takes the motion law's own scalar law as its
first argument, as :func:`controllers.references.law.law_reference` does: the kernel, compiled or
not, and the Python calls run the same formula.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from mjbench.compiled import law
from mjbench.errors import ParameterError

from mjbench import compiled as C
from mjbench.law_reference import LawReference

#: the reference's parameters: scale (motor rad per law rad), start time [s], period [s], the law's
#: rotation Φ per cycle [rad], the motion law's P
PeriodicLawP = namedtuple("PeriodicLawP", "scale t0 period Phi motion")


@law(outputs=("phi_ref", "om_ref", "acc_ref"))
def periodic_law_reference(MOTION, t, P, S):
    """(φ, φ̇, φ̈) of the motion law repeated every ``period`` with +Φ per cycle, times ``scale``
    (at rest at 0 before t0)."""
    tau = t - P.t0
    k = 0.0
    if tau >= P.period:
        k = math.floor(tau / P.period)
        tau = tau - k * P.period
    p, v, a, j = MOTION(tau, 2, P.motion)
    s = P.scale
    return s * (k * P.Phi + p), s * v, s * a


class PeriodicLawReference(LawReference):
    """A motion law (:class:`mjbench.motionlaws.MotionLaw`, a rest-to-rest move of Φ in T) repeated
    every ``period`` ≥ T [s], +Φ per cycle: φ_ref(t) = scale·(k·Φ + φ(t − t0 − k·period))."""

    STATE = ()
    law = periodic_law_reference

    def __init__(self, motion, period, scale=1.0, t0=0.0):
        period = float(period)
        if not (math.isfinite(period) and period > 0):
            raise ParameterError(f"reference.period = {period!r}: must be a finite time > 0 [s]")
        if period < float(motion.T) * (1.0 - 1e-12):
            raise ParameterError(f"reference.period = {period:g} s is shorter than the motion law's move time "
                                 f"law.T = {float(motion.T):g} s: one move per period does not fit")
        self.period = period
        super().__init__(motion, scale, t0)

    def form(self, T, z):
        mf = self.motion.motion_form()
        return C.Form(periodic_law_reference,
                      PeriodicLawP(self.scale, self.t0, self.period, float(self.motion.Phi), mf.P),
                      self.initial_state(), fn_args=(mf,))

    def metrics(self, tr, machine, config) -> dict:
        """None: a repeated move has no rest after it to measure a residual vibration in."""
        return {}

    def crank_speed_at(self, machine, q):
        """The mean input speed Φ/(period·z) [rad/s]."""
        return float(self.motion.Phi) / self.period / float(machine.drive.z)

    def cycle(self, t):
        """The cycle index k of times t [s] (array): ⌊(t − t0)/period⌋, 0 before t0."""
        tau = np.asarray(t, dtype=float) - self.t0
        return np.where(tau >= self.period, np.floor(tau / self.period), 0.0)
