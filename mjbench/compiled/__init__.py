"""One source for every law: pure scalar functions that Python calls and numba compiles.

A *law* is a plain Python function of floats, ints, a parameter tuple ``P`` and a state array
``S`` (read with ``P.name``, ``S[i]``; only ``+ − × ÷``, comparisons, ``math`` functions and calls
to other laws).  The same function is

* called by the component's Python object (``PID.__call__``, ``DCMotorDrive.current_step`` …),
* executed by the co-step kernel's loop in CPython (:mod:`mjbench.kernel`, the reference), and
* compiled by numba together with the kernel's loop (the fast path), with the same IEEE
  operations in the same order (no fast-math, no fused multiply-add): the same bits.

A component *declares* its compiled form: a :class:`Form` (its law, its parameters ``P`` — a
namedtuple of numbers and arrays, computed once per run from the component's parameters and the
co-simulation step — and its initial state ``S0``).  A component without one runs the kernel in
CPython (:class:`Form` with ``compiled=False`` and the reason), and the run says so
(``"loop": "python"``, ``"loop_reason"``).

Writing a law (docs/CONTRIBUTING.md): decorate it with :func:`law`; never import numba or NumPy
in it; keep every value a float (or an int used as a count/index); write the state only through
``S[i] = ...``; return a float or a tuple of floats.  numba is imported only when a run is
compiled (:mod:`mjbench.compiled.jit`).
"""
from __future__ import annotations

import functools
import math
import types
from collections import namedtuple
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

#: every law, in definition order (registered with numba when the JIT is first used)
LAWS: list = []
#: functions with one Python implementation and one numba implementation (bindings, not formulas)
BRIDGES: list = []
_jit_ready = False
#: (register law, register bridge) of the started JIT (:func:`mjbench.compiled.jit.init` sets them):
#: a law defined after the JIT started is registered through them (the JIT is above this module)
_JIT_HOOKS: tuple = ()


def law(fn: Callable | None = None, *, outputs: tuple | None = None, inline: bool = True) -> Callable:
    """Mark ``fn`` as a law: a pure scalar function numba can compile (see the module docstring).

    ``@law`` or ``@law(outputs=("u",))``: a control law (a controller's, a reference's) names the
    signals it reads by its parameters and declares the signals it writes (:mod:`mjbench.signals`;
    a controller's default ``("u",)``, a reference's its three references).  The function itself is
    returned unchanged (Python calls it directly); when the compiled loop is first used every law
    is registered with numba so that laws can call each other by name."""
    if fn is None:
        return lambda f: law(f, outputs=outputs, inline=inline)
    fn.__mjbench_law__ = True
    if not inline:  # a large law called in several places: one compiled function (compile time, code size)
        fn.__mjbench_inline__ = False
    if outputs is not None:
        fn.__mjbench_outputs__ = tuple(outputs)
    LAWS.append(fn)
    if _jit_ready:  # a law defined after the JIT started (a plugin imported late)
        _JIT_HOOKS[0](fn)
    return fn


def bridge(numba_impl: str):
    """Mark ``fn`` as a bridge: its Python body runs in CPython, ``numba_impl`` (the name of a
    function in :mod:`mjbench.compiled._numba` returning the compiled implementation) in compiled
    code.  Used for calls that are not formulas (MuJoCo's ``mj_step`` through its C address)."""
    def deco(fn):
        BRIDGES.append((fn, numba_impl))
        if _jit_ready:
            _JIT_HOOKS[1](fn, numba_impl)
        return fn
    return deco


NoParams = namedtuple("NoParams", ())
NO_PARAMS = NoParams()
NO_STATE = np.zeros(0)


@dataclass
class Form:
    """The compiled form of one component in one run.

    ``law``: the function the kernel calls in this component's slot; ``P``: its parameters (a
    namedtuple of floats, ints, bools and float/int NumPy arrays, read-only); ``S0``: its initial
    state (float64 array, copied for every run); ``laws``: further functions of a component with
    several slots (a plant's ``closure``, ``write``, …); ``flags``: what the component asks of the
    kernel (e.g. ``{"model": True}`` for a controller that evaluates the reduced model);
    ``compiled``: False when the law is a Python adapter numba cannot compile, with ``reason``;
    ``children``: sub-forms the kernel wires into slots of their own (a controller's reference);
    ``fn_args``: forms whose *laws* this law takes as its leading arguments (a plant's dynamics
    model, a controller's model of the plant); their parameters are part of this form's ``P``.

    ``python``: optionally, the law's *CPython twin* for this form: a function with the slot's
    signature that performs the same floating-point operations in the same order, specialised to
    this form's parameters (constants written into its code, loops over them unrolled, live arrays
    read through memoryviews) — the CPython loop calls it instead of the law (the compiled loop
    never does); the same bits, at a fraction of the per-call cost of a generic law reading its
    parameter tables.  A twin belongs to one form (one run): loops that hold one are not shared."""

    law: Callable
    P: Any = NO_PARAMS
    S0: np.ndarray = field(default_factory=lambda: NO_STATE)
    laws: dict = field(default_factory=dict)
    flags: dict = field(default_factory=dict)
    compiled: bool = True
    reason: str = ""
    children: dict = field(default_factory=dict)
    fn_args: tuple = ()
    outputs: tuple = ()
    what: str = ""
    python: Callable | None = None

    def __post_init__(self):
        S0 = self.S0
        if not (type(S0) is np.ndarray and S0.ndim == 1 and S0.dtype == np.float64 and S0.flags.c_contiguous):
            self.S0 = np.ascontiguousarray(S0, dtype=np.float64).reshape(-1)
        if self.compiled and not getattr(self.law, "__mjbench_law__", False):
            self.compiled = False
            self.reason = self.reason or f"{_name(self.law)} is not a law (@mjbench.compiled.law)"
        for name, fn in self.laws.items():
            if self.compiled and not getattr(fn, "__mjbench_law__", False):
                self.compiled = False
                self.reason = self.reason or f"{_name(fn)} ({name}) is not a law"

        for f in self.fn_args:
            if self.compiled and not f.compiled:
                self.compiled = False
                self.reason = self.reason or f.reason

    def state(self) -> np.ndarray:
        """A fresh copy of the initial state (one per run: nothing is shared across a batch)."""
        return self.S0.copy()

    def bound(self) -> Callable:
        """The slot function for CPython: the law's twin (``python``) if it has one, else the law with
        its ``fn_args`` laws bound in front."""
        if self.python is not None:
            return self.python
        if not self.fn_args:
            return self.law
        return functools.partial(self.law, *(f.bound() for f in self.fn_args))

    @property
    def twins(self) -> tuple:
        """The CPython twins of this form and of its function arguments (:attr:`python`)."""
        return ((self.python,) if self.python is not None else ()) + tuple(t for f in self.fn_args for t in f.twins)

    @property
    def ident(self) -> tuple:
        """The function objects of this form (their ids): a law re-defined in this process (an
        edited module re-imported) is a new composition even under the same name."""
        return (id(self.law),) + tuple(i for f in self.fn_args for i in f.ident)

    @property
    def key(self) -> str:
        """The composition this form stands for (its law and its function arguments' laws)."""
        k = qualname(self.law)
        if self.fn_args:
            k += "(" + ",".join(f.key for f in self.fn_args) + ")"
        return k


def python_form(fn: Callable, reason: str, **kw) -> Form:
    """A form whose law is a Python adapter (runs in CPython only)."""
    return Form(fn, compiled=False, reason=reason, **kw)


def _name(fn) -> str:
    return f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"


def qualname(fn) -> str:
    """``module:qualname`` of a function (``id`` appended for one numba cannot import by name)."""
    mod, qual = getattr(fn, "__module__", ""), getattr(fn, "__qualname__", repr(fn))
    if mod == "__main__" or "<" in qual:
        return f"{mod}:{qual}@{id(fn):x}"
    return f"{mod}:{qual}"


def python_view(P):
    """``P`` for the CPython loop: every NumPy array becomes a memoryview of it (scalar reads as
    Python floats, ≈ 3× faster than ndarray indexing; writes reach the array)."""
    if isinstance(P, np.ndarray):
        return memoryview(P)
    if isinstance(P, tuple) and hasattr(P, "_fields"):
        if any(isinstance(v, np.ndarray) or (isinstance(v, tuple) and hasattr(v, "_fields")) for v in P):
            return type(P)(*(python_view(v) for v in P))
    return P


# ----------------------------------------------------------------------------- shared small laws
@law
def sgn(x):
    """sgn x: 1, −1 or 0 (NaN → 0)."""
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@law
def clip(x, lo, hi):
    """x limited to [lo, hi] (±inf: no limit; NaN passes)."""
    return lo if x < lo else (hi if x > hi else x)


@law
def isfinite(x):
    return not (math.isnan(x) or math.isinf(x))


@law
def track(a, i, x, t):
    """The running extremes of a signal at a[i:i+4] — largest value, its time, smallest value, its
    time — with the value x at time t (a strictly larger or smaller value moves them: the first time
    an extreme is reached is kept)."""
    if x > a[i]:
        a[i] = x
        a[i + 1] = t
    if x < a[i + 2]:
        a[i + 2] = x
        a[i + 3] = t


class _ArrayMath:
    """``math`` for :func:`array_twin`: the same functions, elementwise over NumPy arrays."""

    sin, cos, tan, sqrt, exp, log = np.sin, np.cos, np.tan, np.sqrt, np.exp, np.log
    atan2, atan, asin, acos, hypot, fabs = np.arctan2, np.arctan, np.arcsin, np.arccos, np.hypot, np.abs
    floor, isnan, isinf, copysign, tanh = np.floor, np.isnan, np.isinf, np.copysign, np.tanh
    nan, inf, pi = math.nan, math.inf, math.pi


def array_twin(fn: Callable) -> Callable:
    """The law ``fn`` evaluated elementwise over NumPy arrays: its own code object, with ``math``
    bound to NumPy's functions — the same formula, not a copy, for analysis and tables over many
    angles.  Only for laws without branches on their values and without calls to other laws (the
    elementwise results may differ from the scalar law in the last bit where NumPy's vectorised
    sin/cos/exp round differently)."""
    g = dict(fn.__globals__)
    g["math"] = _ArrayMath
    return types.FunctionType(fn.__code__, g, fn.__name__ + "_array", fn.__defaults__, fn.__closure__)


def vectorize(fn: Callable, *args):
    """``fn`` of scalar arguments applied elementwise when any argument is an array (Python loop;
    for post-processing, never on the hot path) → float or ndarray of the broadcast shape."""
    if not any(isinstance(a, np.ndarray) and a.ndim > 0 for a in args):
        return fn(*[float(a) if isinstance(a, (np.floating, np.ndarray)) else a for a in args])
    arrs = np.broadcast_arrays(*[np.asarray(a, dtype=float) for a in args])
    out = np.empty(arrs[0].shape)
    flat = [a.reshape(-1) for a in arrs]
    o = out.reshape(-1)
    for i in range(o.size):
        o[i] = fn(*[float(a[i]) for a in flat])
    return out


__all__ = ["law", "bridge", "Form", "python_form", "NoParams", "NO_PARAMS", "NO_STATE", "sgn", "clip",
           "isfinite", "track", "vectorize", "array_twin", "python_view", "LAWS"]
