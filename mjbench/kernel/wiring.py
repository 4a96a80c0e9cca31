"""Signals wired to laws by name: the adapters between the signal array and a control law.

A control law (a controller's, a reference's) reads the signals named by its parameters and writes
the signals it declares (:mod:`mjbench.signals`).  For a law bound to an axis, :func:`wire` resolves
the names once, at composition, and :func:`adapter_source` writes a three-line adapter

    def CTRL_0(Y, P, S):
        r = _law_CTRL_0(Y[1], Y[2], Y[3], Y[5], Y[6], Y[7], P, S)
        Y[8] = r

that CPython executes and numba inlines (the same source: the same bits).  The law itself never
sees the array, so a new signal in the set changes no law.
"""
from __future__ import annotations

import inspect
import weakref
from dataclasses import dataclass

from .. import signals as SIG
from ..errors import ParameterError
from ..signals import law_parameters


@dataclass(frozen=True)
class Wiring:
    """A law's resolved signals: ``reads`` (signal-array indices, or -1 for the whole array ``Y``,
    in parameter order) and ``writes`` (indices of its outputs, in return order)."""

    reads: tuple
    writes: tuple
    names: tuple
    outputs: tuple

    def source(self, name: str, target: str) -> str:
        """The adapter's source (:func:`adapter_source`): what the compiled loop's module holds."""
        return adapter_source(name, target, self)


def wire(form, axis: int, naxes: int, default_outputs: tuple, what: str) -> Wiring:
    """Resolve ``form``'s law's signal names for a component on ``axis``; ParameterError (one line
    naming ``what``, the law and the name) for a name outside the set or a write to a read-only signal."""
    fn = form.law
    key = (len(form.fn_args), tuple(form.outputs or ()), axis, naxes, tuple(default_outputs))
    try:
        return _WIRINGS[fn][key]  # (resolved once per law and place: a sweep composes a run per row)
    except (KeyError, TypeError):
        pass
    w = _wire(form, axis, naxes, default_outputs, what)
    try:
        _WIRINGS.setdefault(fn, {})[key] = w
    except TypeError:  # (a callable that cannot be weakly referenced)
        pass
    return w


#: each law's resolved wirings while it lives, by (function arguments, outputs, axis, axes, default outputs)
_WIRINGS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _wire(form, axis: int, naxes: int, default_outputs: tuple, what: str) -> Wiring:
    fn = form.law
    names = law_parameters(fn, len(form.fn_args))
    reads = []
    for n in names:
        if n == "Y":
            reads.append(-1)
            continue
        try:
            reads.append(SIG.resolve(n, axis, naxes).index())
        except SIG.UnknownSignal as e:
            raise ParameterError(f"{what}: law {_name(fn)} reads {e.args[0]}") from None
    outs = tuple(form.outputs or getattr(fn, "__mjbench_outputs__", None) or default_outputs)
    writes = []
    for n in outs:
        try:
            r = SIG.resolve(n, axis, naxes)
        except SIG.UnknownSignal as e:
            raise ParameterError(f"{what}: law {_name(fn)} declares the output {e.args[0]}") from None
        if r.name not in SIG.WRITABLE:
            raise ParameterError(f"{what}: law {_name(fn)} declares the output {n!r}, which is read-only (a law "
                                 f"writes {', '.join(SIG.WRITABLE)})")
        writes.append(r.index())
    return Wiring(tuple(reads), tuple(writes), tuple(names), outs)


def adapter_source(name: str, target: str, w: Wiring) -> str:
    """Source of the adapter ``name(Y, P, S)`` calling ``target`` with the signals of ``w``."""
    args = ", ".join("Y" if i < 0 else f"Y[{i}]" for i in w.reads)
    args = (args + ", " if args else "") + "P, S"
    lines = [f"def {name}(Y, P, S):", f"    r = {target}({args})"]
    if len(w.writes) == 1:
        lines.append(f"    Y[{w.writes[0]}] = r")
    else:
        lines += [f"    Y[{i}] = r[{j}]" for j, i in enumerate(w.writes)]
    return "\n".join(lines) + "\n"


def python_adapter(name: str, fn, w: Wiring):
    """The adapter of :func:`adapter_source` as a Python function calling ``fn`` (the CPython loop)."""
    env = {"_target": fn}
    src = adapter_source(name, "_target", w)
    exec(compile(src, f"<mjbench wiring {name}>", "exec"), env)  # noqa: S102
    env[name].source = src  # (what mjbench/kernel/inline.py reads)
    return env[name]


def call(fn, w: Wiring, values: dict, P, S):
    """Call a law outside the kernel with signals given by name (``values``: resolved names → value;
    missing ones are 0): what ``Controller.__call__`` and the generic linearisation use."""
    args = [values.get(n, 0.0) for n in w.names]
    return fn(*args, P, S)


def _name(fn) -> str:
    return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"


__all__ = ["Wiring", "law_parameters", "wire", "adapter_source", "python_adapter", "call"]
