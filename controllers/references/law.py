"""The scenario's motion law as a motor-shaft reference (seeds 001/003: the servo tracks φ(t)).

``[modes.NAME.reference] type = "law"`` uses the scenario's ``[law]`` table; ``t0`` [s] delays the
start of the move; ``period`` [s] repeats it, +Φ per cycle (a crank turning continuously:
:mod:`controllers.references.periodic`).  The law gives φ, φ̇, φ̈ of the motor; the reference is
exactly that (motor side), so a servo's feed-forward sees the law's own derivatives.

The reference is the law :func:`law_reference`, which takes the motion law's own scalar law
(``MOTION(t, order, P)``: :func:`mjbench.motionlaws.pseudopoly_motion`,
:func:`~mjbench.motionlaws.bezier_motion`, :func:`~mjbench.motionlaws.shaped_motion`) as its
first argument: the kernel, compiled or not, and ``law.evaluate`` run the same formula.
"""
from __future__ import annotations

from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field

from mjbench.compiled import law
from mjbench.errors import ParameterError
from mjbench.fields import OptQ, Q, Strict

from mjbench.law_reference import LawRefP, LawReference, law_reference  # noqa: F401 - the reference's class and law

from .periodic import PeriodicLawReference


class LawReferenceParams(Strict):
    type: Literal["law"] = "law"
    t0: Q("time", ge=0.0, plausible=False) = Field(0.0, description="start of the move [s]")
    period: OptQ("time", gt=0.0, plausible=False) = Field(
        None, description="repeat the move every period [s] (≥ law.T), +Φ per cycle (none: one move)")


def from_params(p, drive=None, mechanism=None, scenario=None):
    motion = getattr(scenario, "law", None)
    if motion is None:
        raise ParameterError("reference type 'law' needs a [law] table in the scenario")
    if p.period is not None:
        return PeriodicLawReference(motion.build(), p.period, t0=p.t0)
    return motion.build().as_reference(t0=p.t0)
