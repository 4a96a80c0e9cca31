"""A constant torque or speed command for the ideal drives (``[drive] type = "torque"`` / ``"speed"``).

``[modes.NAME] type = "constant"`` with exactly one of ``torque`` [N·m] (for the ideal torque
source: the torque on the input joint) or ``speed`` [rad/s] (for the stiff speed source: the
commanded input speed), optionally ramped linearly from 0 over ``t_ramp``.  The open-loop voltage
controller (``type = "open"``) stays the DC motor's: its value is a voltage, so the scenario check
refuses it on an ideal drive rather than read volts as newton-metres (and refuses this one on a DC
motor, or a torque on the speed source).
"""
from __future__ import annotations

from collections import namedtuple
from typing import Literal

from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from mjbench.compiled import law
from mjbench.errors import ParameterError
from mjbench.fields import OptQ, Q, Strict

from . import register
from .openloop import ramped
from mjbench.control import Controller


class ConstantParams(Strict):
    """``[modes.NAME] type = "constant"``: a constant input torque or input speed command."""

    type: Literal["constant"] = "constant"
    torque: OptQ("torque", plausible=False) = Field(None, description="input torque (ideal torque source)")
    speed: OptQ("angular_velocity", plausible=False) = Field(None, description="commanded input speed (ideal speed source)")
    t_ramp: Q("time", ge=0.0, plausible=False) = Field(0.0, description="linear ramp from 0 over t_ramp (0: step)")

    @model_validator(mode="after")
    def _one(self):
        if (self.torque is None) == (self.speed is None):
            raise PydanticCustomError("mjbench_value", "give exactly one of torque [N·m] (with [drive] type = \"torque\") "
                                      "or speed [rad/s] (with [drive] type = \"speed\")")
        return self

    @property
    def kind(self) -> str:
        return "torque" if self.torque is not None else "speed"


ConstantP = namedtuple("ConstantP", "value t_ramp")


@law(outputs=("u",))
def constant_law(t, P, S):
    """u = ``value`` (ramped linearly from 0 over ``t_ramp`` s when t_ramp > 0)."""
    return ramped(P.value, t, P.t_ramp)


@register
class ConstantCommand(Controller):
    """u = a constant input torque [N·m] or input speed [rad/s]; optional linear ramp over ``t_ramp``."""

    type_name = "constant"
    Params = ConstantParams
    law = constant_law
    closed_loop = False

    def __init__(self, value, kind="torque", t_ramp=0.0):
        if kind not in ("torque", "speed"):
            raise ParameterError(f"constant command kind = {kind!r}: choose 'torque' or 'speed'")
        self.value, self.kind, self.t_ramp = value, kind, t_ramp

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        typ = getattr(drive, "type_name", None)
        if drive is not None and typ != p.kind:
            raise ParameterError(f"type = \"constant\" with {p.kind} = … needs [drive] type = \"{p.kind}\" "
                                 f"(this drive is type = \"{typ}\")")
        return cls(p.torque if p.kind == "torque" else p.speed, kind=p.kind, t_ramp=p.t_ramp)

    def parameters(self, T, z):
        return ConstantP(float(self.value), float(self.t_ramp))

    def linear(self, machine, op, T, h, angle="state"):
        """None: open loop, no feedback to linearise."""
        return None

    def running_speed(self, machine, q):
        """The commanded speed (speed source); 0 for a torque (it sets no speed)."""
        return float(self.value) if self.kind == "speed" else 0.0
