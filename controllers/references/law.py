"""The scenario's motion law as a motor-shaft reference (seeds 001/003: the servo tracks φ(t)).

``[modes.NAME.reference] type = "law"`` uses the scenario's ``[law]`` table; ``t0`` [s] delays the
start of the move.  The law gives φ, φ̇, φ̈ of the motor; the reference is exactly that (motor
side), so a servo's feed-forward sees the law's own derivatives.
"""
from __future__ import annotations

from typing import Literal

from pydantic import Field

from mjbench.errors import ParameterError
from mjbench.schema import Q, Strict


class LawReferenceParams(Strict):
    type: Literal["law"] = "law"
    t0: Q("time", ge=0.0, plausible=False) = Field(0.0, description="start of the move [s]")


def from_params(p, drive=None, mechanism=None, scenario=None):
    law = getattr(scenario, "law", None)
    if law is None:
        raise ParameterError("reference type 'law' needs a [law] table in the scenario")
    return law.build().as_reference(t0=p.t0)
