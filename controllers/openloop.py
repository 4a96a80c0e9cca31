"""Open loop: a constant (or time-profiled) armature voltage (seed 000 Fig. 4, left column)."""
from __future__ import annotations

import numpy as np

from .base import Controller


class ConstantVoltage(Controller):
    """V_a = ``voltage`` [V] (scalar or (nsim,) array); optional linear ramp over ``t_ramp`` s."""

    def __init__(self, voltage, t_ramp=0.0):
        self.voltage = voltage
        self.t_ramp = t_ramp

    def reset(self):
        pass

    def __call__(self, t, y):
        tr = self.t_ramp
        if np.ndim(tr):  # (nsim,) ramp durations
            return np.where(t < tr, self.voltage * (t / np.where(tr > 0, tr, 1.0)), self.voltage)
        if tr > 0 and t < tr:
            return self.voltage * (t / tr)
        return self.voltage


def from_params(params, drive=None, mechanism=None):
    return ConstantVoltage(float(params["voltage"]), t_ramp=float(params.get("t_ramp", 0.0)))
