"""Open loop: a constant (or ramped) armature voltage (seed 000 Fig. 4, left column)."""
from __future__ import annotations

from collections import namedtuple
from typing import Literal

from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from mjbench.compiled import law
from mjbench.fields import Q, Strict

from . import register
from mjbench.control import Controller


class OpenParams(Strict):
    """``[modes.NAME] type = "open"``: constant armature voltage, optional linear ramp."""

    type: Literal["open"] = "open"
    voltage: Q("voltage", finite=True) = Field(description="armature voltage")
    t_ramp: Q("time", ge=0.0, plausible=False) = Field(0.0, description="linear ramp from 0 over t_ramp (0: step)")

    @model_validator(mode="before")
    @classmethod
    def _signal_hint(cls, data):
        """A step or a time series is a ``signal`` mode: say so instead of a type error."""
        if isinstance(data, dict):
            v = data.get("voltage")
            key = "voltage" if isinstance(v, (list, tuple)) else next((k for k in ("t_step", "t", "file") if k in data),
                                                                       None)
            if key is not None:
                raise PydanticCustomError(
                    "mjbench_value", "{key} = {val}: type = \"open\" is a constant voltage (optionally ramped over "
                    "t_ramp); for a step or any time series use type = \"signal\" with t = [...] and voltage = [...] "
                    "(a step at 0.1 s: t = [0, 0.1], voltage = [0, 24], interpolation = \"hold\")",
                    {"key": key, "val": repr(data[key])})
        return data

    def command_bound(self) -> float:
        """The largest |voltage| the mode commands [V] (the duty figures: a limiter at or above it never acts)."""
        return abs(float(self.voltage))


OpenP = namedtuple("OpenP", "voltage t_ramp")


@law
def ramped(value, t, tr):
    """``value``, ramped linearly from 0 over ``tr`` s when tr > 0 (open loop and constant command)."""
    if tr > 0.0 and t < tr:
        return value * (t / tr)
    return value


@law(outputs=("u",))
def open_law(t, P, S):
    """V_a = ``voltage`` (ramped linearly from 0 over ``t_ramp`` s when t_ramp > 0)."""
    return ramped(P.voltage, t, P.t_ramp)


@register
class ConstantVoltage(Controller):
    """V_a = ``voltage`` [V]; optional linear ramp over ``t_ramp`` s."""

    type_name = "open"
    Params = OpenParams
    law = open_law
    closed_loop = False

    def __init__(self, voltage, t_ramp=0.0):
        self.voltage = voltage
        self.t_ramp = t_ramp

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        return cls(p.voltage, t_ramp=p.t_ramp)

    def parameters(self, T, z):
        return OpenP(float(self.voltage), float(self.t_ramp))

    def command_bound(self) -> float:
        """The largest |voltage| it commands [V]."""
        return abs(float(self.voltage))

    def linear(self, machine, op, T, h, angle="state"):
        """None: open loop, no feedback to linearise (the plant alone is the system)."""
        return None

    def running_speed(self, machine, q):
        """The constant-inertia steady speed at the voltage: V·k_m·z / (R·z²λ + (k_m·z)²) [rad/s]."""
        d = machine.drive
        km, z = float(d.k_m), float(d.z)
        return float(self.voltage) * km * z / (float(d.R) * float(d.crank_damping) + (km * z) ** 2)
