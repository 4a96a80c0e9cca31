"""The signal set: what a control law (a controller, a reference) may read and write, by name.

A law of :mod:`mjbench.compiled` *declares* the signals it reads by the names of its parameters,
before its parameter tuple ``P`` and its state ``S`` — ``def pid_law(t, q, qd, qdd, phi_ref, om_ref,
acc_ref, P, S)`` — and the signals it writes with ``@law(outputs=("u",))``.  The kernel wires them
(:mod:`mjbench.kernel.wiring`): a law reads nothing it did not name, and adding a signal to this set
changes no existing law.

The set holds the time and, **per axis** (input coordinate and its drive; a one-motor machine has
axis 0), the signals below.  A name without a suffix is the law's own axis (the axis of the
component: a controller or reference bound to axis 1 reads axis 1's ``q``); ``name_k`` is axis k
explicitly (``q_0``, ``u_1``: a law for several axes); the parameter ``Y`` is the whole signal array
(for laws over n axes: index it with :func:`index` computed in ``parameters()``).

Values are those at the control sample (every controller period), SI units.
"""
from __future__ import annotations

import functools
import inspect
import re
from dataclasses import dataclass

from .errors import ParameterError

#: signals of the whole machine: name → (unit, meaning)
GLOBAL = {
    "t": ("s", "time of the control sample"),
}

#: signals of each axis: name → (unit, meaning).  Order = layout in the signal array.
AXIS = {
    "q": ("rad", "input coordinate as measured (after the sensor; ideal sensor: exact), input (crank) side"),
    "qd": ("rad/s", "input speed as measured"),
    "qdd": ("rad/s²", "input acceleration as measured: the backward difference (q̇_n − q̇_{n−1})/h over one co-step "
                      "(0 at the first sample)"),
    "I": ("A", "motor current as measured (ideal drives: 0)"),
    "phi_ref": ("rad", "angle reference, motor side (written by the axis's reference; 0 without one)"),
    "om_ref": ("rad/s", "speed reference, motor side"),
    "acc_ref": ("rad/s²", "acceleration reference, motor side"),
    "u": ("V | N·m | rad/s | A", "the controller's output, as it wrote it (the drive's command: a voltage; an ideal "
                                 "drive's torque or speed; a current reference with a current loop)"),
    "u_held": ("as u", "the command the drive holds now: the last output after the clip to [u_min, u_max] and the "
                       "sensor's one-sample delay"),
    "V": ("V", "voltage actually applied over the last co-step, after every limit: the limiter, the amplifier's "
               "current limit, a current loop's output, a PWM bridge's mean (ideal drives: their applied command)"),
    "tau": ("N·m", "torque the drive applied to the input coordinate over the last co-step (z × motor torque after the "
                   "gear efficiency, without the viscous part)"),
    "u_min": ("as u", "lower limit of the command (−v_max; −i_max for a current reference; an ideal drive's −T_max or "
                      "−speed_max)"),
    "u_max": ("as u", "upper limit of the command"),
    "v_max": ("V", "the drive's voltage limit (inf: none)"),
    "i_max": ("A", "the amplifier's current limit (inf: none)"),
    "z": ("1", "gear ratio φ̇/q̇ (motor turns per input turn)"),
}

#: the names a law may write (outputs): a controller its ``u``, a reference its three references
WRITABLE = ("u", "phi_ref", "om_ref", "acc_ref")
#: what a controller's law writes when it declares nothing; a reference's
CONTROLLER_OUTPUTS = ("u",)
REFERENCE_OUTPUTS = ("phi_ref", "om_ref", "acc_ref")

#: earlier names of the references (laws written before the signal set keep working)
ALIASES = {"phi_r": "phi_ref", "om_r": "om_ref", "acc_r": "acc_ref"}

NG = len(GLOBAL)
NA = len(AXIS)
_GINDEX = {n: i for i, n in enumerate(GLOBAL)}
_AINDEX = {n: i for i, n in enumerate(AXIS)}
_SUFFIX = re.compile(r"^(.+)_(\d+)$")


def size(naxes: int) -> int:
    """Length of the signal array of a machine with ``naxes`` axes."""
    return NG + NA * int(naxes)


def index(name: str, axis: int = 0) -> int:
    """Index of signal ``name`` (of ``axis`` for an axis signal) in the signal array."""
    if name in _GINDEX:
        return _GINDEX[name]
    return NG + NA * int(axis) + _AINDEX[name]


@dataclass(frozen=True)
class Ref:
    """A resolved signal name: ``name`` in the set, its ``axis`` (None: a global signal)."""

    name: str
    axis: int | None

    def index(self) -> int:
        return index(self.name, self.axis or 0)


class UnknownSignal(KeyError):
    """A name that is not in the signal set (:func:`resolve`)."""


def resolve(name: str, axis: int, naxes: int) -> Ref:
    """The signal a law's parameter ``name`` means for a component on ``axis`` of a machine with
    ``naxes`` axes: ``t`` (global), ``q`` (the component's axis), ``q_1`` (axis 1).  Raises
    :class:`UnknownSignal` with the reason."""
    name = ALIASES.get(name, name)
    if name in GLOBAL:
        return Ref(name, None)
    if name in AXIS:
        return Ref(name, int(axis))
    m = _SUFFIX.match(name)
    if m and ALIASES.get(m.group(1), m.group(1)) in AXIS:
        k = int(m.group(2))
        if k >= naxes:
            raise UnknownSignal(f"{name!r} names axis {k}, but the machine has {naxes} axis(es) (0 … {naxes - 1})")
        return Ref(ALIASES.get(m.group(1), m.group(1)), k)
    raise UnknownSignal(f"{name!r} is not a signal; the set: {', '.join(names())} (per axis; name_k for axis k)")


def names() -> list[str]:
    """Every signal name (global, then per axis)."""
    return list(GLOBAL) + list(AXIS)


def describe() -> list[tuple[str, str, str, str]]:
    """(name, scope, unit, meaning) of every signal, for docs and ``mjbench list --signals``."""
    return ([(n, "machine", u, m) for n, (u, m) in GLOBAL.items()] +
            [(n, "axis", u, m) for n, (u, m) in AXIS.items()])


# ----------------------------------------------------------------------------- a law's signals
_PARAMS: dict = {}


def law_parameters(fn, nfn: int) -> list[str]:
    """The signal names a law reads: its parameters after ``nfn`` function arguments, before its
    parameter tuple and state (the last two)."""
    key = (fn, getattr(fn, "__code__", None))  # (read once per law: ≈ 25 µs a signature, four a run)
    params = _PARAMS.get(key)
    if params is None:
        try:
            params = list(inspect.signature(fn).parameters)
        except (TypeError, ValueError):
            raise ParameterError(f"{_law_name(fn)}: its parameters cannot be read (a law is a plain def function)") \
                from None
        if len(_PARAMS) > 4096:
            _PARAMS.clear()
        _PARAMS[key] = params
    if len(params) < nfn + 2:
        raise ParameterError(f"{_law_name(fn)}: a control law takes its signals, then its parameter tuple and its state "
                             f"(… P, S); it has {len(params)} parameter(s)")
    return params[nfn:-2]


def _law_name(fn) -> str:
    return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"


def law_signals(fn, nfn: int = 0) -> list[str]:
    """The signal names a law reads (its parameters after ``nfn`` function arguments, before P, S)."""
    return law_parameters(fn, nfn)


def call_law(fn, values: dict, P, S, nfn: int = 0):
    """Run a control law outside the kernel with the signals given by name (absent ones: 0; the
    earlier names ``phi_r`` … are read as ``phi_ref`` …)."""
    names = _names(fn, nfn)
    return fn(*[float(values.get(ALIASES.get(n, n), 0.0)) for n in names], P, S)


_NAMES: dict = {}


def _names(fn, nfn):
    """The signal names ``fn`` reads (cached per law; a partial — a law with its function arguments
    bound — by its law and the number of bound arguments)."""
    base, skip = fn, nfn
    if isinstance(fn, functools.partial):
        base, skip = fn.func, nfn + len(fn.args)
    key = (base, skip)
    n = _NAMES.get(key)
    if n is None:
        params = list(inspect.signature(base).parameters)
        n = _NAMES[key] = params[skip:-2]
    return n


__all__ = ["GLOBAL", "AXIS", "WRITABLE", "CONTROLLER_OUTPUTS", "REFERENCE_OUTPUTS", "size", "index", "Ref",
           "resolve", "names", "describe", "UnknownSignal", "NG", "NA", "ALIASES",
           "law_parameters", "law_signals", "call_law"]
