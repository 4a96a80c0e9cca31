"""Open loop: a constant (or ramped) armature voltage (seed 000 Fig. 4, left column)."""
from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from mjbench.schema import Q, Strict

from . import register
from .base import Controller


class OpenParams(Strict):
    """``[modes.NAME] type = "open"``: constant armature voltage, optional linear ramp."""

    type: Literal["open"] = "open"
    voltage: Q("voltage", finite=True) = Field(description="armature voltage")
    t_ramp: Q("time", ge=0.0, plausible=False) = Field(0.0, description="linear ramp from 0 over t_ramp (0: step)")


@register
class ConstantVoltage(Controller):
    """V_a = ``voltage`` [V] (scalar or (nsim,) array); optional linear ramp over ``t_ramp`` s."""

    type_name = "open"
    Params = OpenParams

    def __init__(self, voltage, t_ramp=0.0):
        self.voltage = voltage
        self.t_ramp = t_ramp

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        return cls(p.voltage, t_ramp=p.t_ramp)

    def reset(self):
        pass

    def __call__(self, t, y):
        tr = self.t_ramp
        if np.ndim(tr):  # (nsim,) ramp durations
            return np.where(t < tr, self.voltage * (t / np.where(tr > 0, tr, 1.0)), self.voltage)
        if tr > 0 and t < tr:
            return self.voltage * (t / tr)
        return self.voltage
