"""Open loop from a time series: the drive's input read from a table of times and values.

``[modes.NAME] type = "signal"`` with ``t`` [s] and one of ``voltage`` [V] (a DC motor),
``torque`` [N·m] (``[drive] type = "torque"``) or ``speed`` [rad/s] (``[drive] type = "speed"``),
as arrays of the same length — or ``file``, a CSV file with a header row whose first column is the
time (``t`` or ``t_s``) and whose second column is named for the quantity (``voltage`` or
``voltage_V``, ``torque`` or ``torque_Nm``, ``speed`` or ``speed_rad_s``), SI values.
``interpolation`` must be stated:

* ``"hold"``: each value holds from its time until the next one (a zero-order hold: steps);
* ``"linear"``: straight lines between the points.

Before the first time the first value holds, after the last time the last one.  The times must
increase strictly.  A step of 24 V at 0.1 s: ``t = [0, 0.1]``, ``voltage = [0, 24]``,
``interpolation = "hold"``.  From Python the arrays may be NumPy arrays
(``mjb.make_controller("signal", t=t, voltage=v, interpolation="linear")``).

The law (:func:`signal_law`) looks the time up in the table, starting where its last look-up ended
(state ``index``), so a run costs O(1) per sample; the controller's ``period`` samples it like any
other controller's output (0: every co-simulation step).
"""
from __future__ import annotations

import csv
import math
import os
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from mjbench.compiled import law
from mjbench.errors import ParameterError, ScenarioError
from mjbench.fields import Q, Strict

from . import register
from .base import Controller

#: the quantities a signal may drive, with their CSV column names and the drive type each needs
KINDS = {"voltage": (("voltage", "voltage_V"), "dcmotor"), "torque": (("torque", "torque_Nm"), "torque"),
         "speed": (("speed", "speed_rad_s"), "speed")}


def _array(v):
    return v.tolist() if isinstance(v, np.ndarray) else v


class SignalParams(Strict):
    """``[modes.NAME] type = "signal"``: the drive's input from a table of times and values."""

    type: Literal["signal"] = "signal"
    t: list[Q("time", plausible=False, finite=True)] | None = Field(None, description="sample times [s], increasing")
    voltage: list[Q("voltage", plausible=False, finite=True)] | None = Field(None, description="armature voltages (DC motor)")
    torque: list[Q("torque", plausible=False, finite=True)] | None = Field(None, description="input torques (torque source)")
    speed: list[Q("angular_velocity", plausible=False, finite=True)] | None = Field(
        None, description="commanded input speeds (speed source)")
    file: str | None = Field(None, description="CSV file: time column, then the value column (instead of t and the values)")
    source_file: str | None = Field(None, description="the CSV file the values were read from (a record)")
    interpolation: Literal["hold", "linear"] = Field(description="hold: steps (zero-order hold); linear: lines")
    period: Q("time", ge=0.0, plausible=False) = Field(0.0, description="sample period (0: every co-simulation step)")

    @field_validator("t", "voltage", "torque", "speed", mode="before")
    @classmethod
    def _arrays(cls, v):
        return _array(v)

    @model_validator(mode="after")
    def _table(self):
        given = [k for k in KINDS if getattr(self, k) is not None]
        if self.file is not None:
            if given or self.t is not None:
                raise PydanticCustomError("mjbench_value", "give file or the arrays t and {k}, not both",
                                          {"k": " / ".join(KINDS)})
            return self
        if len(given) != 1 or self.t is None:
            raise PydanticCustomError("mjbench_value", "needs t and exactly one of voltage [V], torque [N·m] or speed "
                                      "[rad/s] (arrays of the same length), or a CSV file")
        _check(self.t, getattr(self, given[0]), given[0])
        return self

    @property
    def kind(self) -> str | None:
        """The quantity the signal gives (None while it is still a file name)."""
        return next((k for k in KINDS if getattr(self, k) is not None), None)

    def command_bound(self):
        """The largest |value| [V for a voltage] (the duty figures: a limiter at or above it never acts)."""
        return None if self.kind is None else float(np.max(np.abs(getattr(self, self.kind))))


def _check(t, u, kind):
    if len(t) != len(u) or len(t) < 1:
        raise PydanticCustomError("mjbench_value", "t and {k} need the same length >= 1 (got {a} and {b})",
                                  {"k": kind, "a": len(t), "b": len(u)})
    bad = next((i for i in range(1, len(t)) if not t[i] > t[i - 1]), None)
    if bad is not None:
        raise PydanticCustomError("mjbench_value", "t must increase strictly: t[{i}] = {b} s after t[{j}] = {a} s",
                                  {"i": bad, "j": bad - 1, "a": f"{t[bad - 1]:g}", "b": f"{t[bad]:g}"})


def read_csv(path: str) -> tuple[str, list, list]:
    """(kind, times, values) of a signal CSV file (module doc); a ScenarioError names the problem."""
    try:
        with open(path, newline="") as f:
            rows = [r for r in csv.reader(f) if r and not r[0].lstrip().startswith("#")]
    except OSError as e:
        raise ScenarioError(f"signal file {path}: cannot read it ({e.strerror})") from None
    if len(rows) < 2 or len(rows[0]) < 2:
        raise ScenarioError(f"signal file {path}: needs a header row (t, then voltage/torque/speed) and at least one row")
    head = [h.strip() for h in rows[0]]
    if head[0] not in ("t", "t_s"):
        raise ScenarioError(f"signal file {path}: the first column must be the time, named t or t_s (got {head[0]!r})")
    kind = next((k for k, (names, _) in KINDS.items() if head[1] in names), None)
    if kind is None:
        raise ScenarioError(f"signal file {path}: the second column must be one of "
                            f"{', '.join(n for names, _ in KINDS.values() for n in names)} (got {head[1]!r})")
    t, u = [], []
    for n, r in enumerate(rows[1:], start=2):
        try:
            a, b = float(r[0]), float(r[1])
        except (ValueError, IndexError):
            raise ScenarioError(f"signal file {path}, line {n}: not two numbers: {','.join(r)!r}") from None
        if not (math.isfinite(a) and math.isfinite(b)):
            raise ScenarioError(f"signal file {path}, line {n}: values must be finite")
        t.append(a)
        u.append(b)
    return kind, t, u


SignalP = namedtuple("SignalP", "t u n linear")


@law(outputs=("u",))
def signal_law(t, P, S):
    """u(t) from the table (P.t, P.u) of P.n points: held (P.linear False) or linearly interpolated
    between them; the first value before P.t[0], the last after P.t[n−1].  S[0]: the index k of
    the last table time at or before t, where the next look-up starts."""
    k = int(S[0])
    while k + 1 < P.n and P.t[k + 1] <= t:
        k += 1
    while k > 0 and P.t[k] > t:
        k -= 1
    S[0] = k
    if t <= P.t[0]:
        return P.u[0]
    if k + 1 >= P.n or not P.linear:
        return P.u[k]
    f = (t - P.t[k]) / (P.t[k + 1] - P.t[k])
    return P.u[k] + f * (P.u[k + 1] - P.u[k])


@register
class Signal(Controller):
    """Open loop: the drive's input from a table of times and values (module doc)."""

    type_name = "signal"
    Params = SignalParams
    STATE = ("index",)
    law = signal_law

    def __init__(self, t, u, kind="voltage", interpolation="linear", period=0.0):
        if kind not in KINDS:
            raise ParameterError(f"signal kind = {kind!r}: choose voltage, torque or speed")
        if interpolation not in ("hold", "linear"):
            raise ParameterError(f"signal interpolation = {interpolation!r}: choose 'hold' or 'linear'")
        self.t = np.array(t, dtype=float).ravel()
        self.u = np.array(u, dtype=float).ravel()
        if not (np.all(np.isfinite(self.t)) and np.all(np.isfinite(self.u))):
            raise ParameterError("signal: t and the values must be finite")
        try:
            _check(list(self.t), list(self.u), kind)
        except PydanticCustomError as e:
            raise ParameterError(f"signal: {e.message()}") from None
        self.kind, self.interpolation, self.period = kind, interpolation, float(period)

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        kind, t, u = p.kind, p.t, getattr(p, p.kind) if p.kind else None
        if kind is None:  # a file not read by the scenario loader (a table given in Python)
            source = getattr(scenario, "source", "") if scenario is not None else ""
            kind, t, u = read_csv(resolve(p.file, source))
        need = KINDS[kind][1]
        typ = getattr(drive, "type_name", None)
        if drive is not None and typ != need:
            raise ParameterError(f"type = \"signal\" with {kind} = … needs [drive] type = \"{need}\" "
                                 f"(this drive is type = \"{typ}\")")
        return cls(t, u, kind, p.interpolation, p.period)

    @classmethod
    def resolve_paths(cls, table: dict, source: str) -> None:
        """A ``file`` is read when the scenario loads: the table gets ``t`` and the values (so a run's
        manifest holds them) and ``source_file``, the file's absolute path (a record)."""
        f = table.get("file")
        if not isinstance(f, str):
            return
        path = resolve(f, source)
        kind, t, u = read_csv(path)
        del table["file"]
        table.update({"t": t, kind: u, "source_file": os.path.abspath(path)})

    def parameters(self, T, z):
        return SignalP(self.t, self.u, int(len(self.t)), self.interpolation == "linear")

    def command_bound(self) -> float:
        """The largest |value| of the table."""
        return float(np.max(np.abs(self.u)))

    def linear(self, machine, op, T, h, angle="state"):
        """None: open loop, no feedback to linearise."""
        return None


def resolve(path: str, source: str) -> str:
    """A signal file's path: absolute, or relative to the scenario file (``source``), else to the
    working folder."""
    if os.path.isabs(path):
        return path
    if source and os.path.exists(source):
        return os.path.normpath(os.path.join(os.path.dirname(source), path))
    return path
