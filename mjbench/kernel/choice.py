"""Which loop runs a composition and how it is obtained: the CPython loop (the template unrolled and
specialised, :mod:`.pyloop`) or the compiled one (:func:`mjbench.compiled.jit.loop_for`).

**When compiled** (:func:`choose_loop`): numba installed and every component compiles, and the
job is large enough to pay numba's start-up (≈ 0.35 s of CPU to import numba and load a cached
kernel, against ≈ 2–3 µs saved per co-step: :data:`mjbench.kernel.program.MIN_STEPS`, or the plant's
own threshold, or less when a component's form declares one: ``flags["min_steps"]``, e.g. a
multi-input model table whose CPython evaluation costs ≈ 85 µs a call), or numba is already loaded,
or ``MJBENCH_JIT=1``.  ``MJBENCH_JIT=0`` always runs CPython; ``MJBENCH_JIT=check``
runs the compiled loop with every array access bounds-checked (a law writing past its state is
then an error naming it, never a crash).  The reason for the choice is recorded (``meta["loop"]``,
``meta["loop_reason"]``).
"""
from __future__ import annotations

import math
import types

from .. import compiled as C
from .. import environment
from ..compiled import jit
from ..errors import ParameterError
from . import loop as LP
from . import inline, pyloop, unroll
from .program import MIN_STEPS, Program

#: the values ``MJBENCH_JIT`` may take
JIT_MODES = environment.JIT_VALUES

_PY_LOOPS: dict = {}


def loop_env() -> dict:
    """What every loop module holds besides a composition's slots and constants."""
    return {"math": math, "clip": C.clip, "isfinite": C.isfinite, "track": C.track, "MAX_SPEED": LP.MAX_SPEED,
            "MAX_CURRENT": LP.MAX_CURRENT}


def python_loop(program: Program, inline_laws: bool = True):
    """The loop executed by CPython for this composition (the unrolled template's code, its laws
    written into it: :mod:`.inline`; ``inline_laws=False``: called, the reference of the tests)."""
    key = (program.key, inline_laws)
    shared = program.compiled and not program.twins  # (a loop holding a run's twins is that run's alone)
    fn = _PY_LOOPS.get(key) if shared else None
    if fn is None:
        env = {**loop_env(), **program.env()}
        code, aliases, laws = pyloop.code(program.naxes, program.nctrl, program.flags,
                                          env if inline_laws else None)  # specialised, kept
        for name, path in aliases.items():  # the inlined laws' globals (mjbench/kernel/inline.py)
            env[name] = inline.resolve(path, env)
        fn = types.FunctionType(code, env, "_loop")
        fn.__mjbench_inlined__ = tuple((inline.resolve(path, env), first) for path, first in laws)
        if shared:
            _PY_LOOPS[key] = fn  # (its globals hold the laws: their ids in the key stay unique)
    return fn


def loop_function(program: Program, mode: str):
    """The loop of ``mode`` ("python", "compiled", "check") for this composition."""
    if mode == "python":
        return python_loop(program)

    return jit.loop_for(program, unroll.source(program.naxes, program.nctrl), check=mode == "check")


def jit_mode(loop: str | None = None) -> str:
    """The loop asked for: ``loop`` or ``MJBENCH_JIT`` → "", "python", "compiled" or "check"
    (ParameterError naming the value otherwise)."""
    if loop is not None:
        v = str(loop).lower()
        if v not in JIT_MODES:
            raise ParameterError(f"loop = {loop!r}: choose python, compiled or check")
        return JIT_MODES[v]
    return environment.jit()  # (MJBENCH_JIT checked in one place: mjbench/environment.py)


def choose_loop(program: Program, run_steps: float, loop: str | None = None) -> tuple[str, str]:
    """("compiled" | "check" | "python", why) for a job of ``run_steps`` co-steps (all runs together)."""

    mode = jit_mode(loop)
    if mode == "python":
        return "python", "CPython loop requested (MJBENCH_JIT=0 / loop='python')"
    if not program.compiled:
        if mode in ("compiled", "check") and program.broken:  # a law that breaks the contract: say so
            raise ParameterError("the compiled loop was requested but " + "; ".join(program.broken))
        return "python", "; ".join(program.reasons)  # (a component without a law: CPython, said why)
    if mode == "check":
        why = "compiled loop with bounds checks requested (MJBENCH_JIT=check)"
    elif mode == "compiled":
        why = "compiled loop requested (MJBENCH_JIT=1 / loop='compiled')"
    elif jit.loaded():
        why = "numba already loaded"
    elif run_steps >= program.min_steps:
        why = f"{int(run_steps):,} co-steps ≥ {int(program.min_steps):,} (pays numba's start-up)"
    else:
        return "python", (f"{int(run_steps):,} co-steps < {int(program.min_steps):,}: numba's start-up would cost more "
                          f"than it saves")
    if not jit.available():
        if mode in ("compiled", "check"):
            raise ParameterError("the compiled loop was requested (MJBENCH_JIT / loop) but numba is not installed")
        return "python", "numba is not installed"
    failure = jit.law_failure(program)  # a law numba refused earlier in this process (contract)
    if failure:
        if mode in ("compiled", "check"):
            raise ParameterError(failure)
        return "python", failure
    return ("check" if mode == "check" else "compiled"), why


def preload(run_steps: float) -> bool:
    """Load numba now when a design loop plans ``run_steps`` co-steps over all its runs and that
    pays for the start-up (then every later run of the process is compiled); → whether loaded."""

    if jit_mode() == "python" or not jit.available():
        return False
    if jit.loaded() or run_steps >= MIN_STEPS:
        jit.init()
        return True
    return False


__all__ = ["JIT_MODES", "choose_loop", "jit_mode", "loop_env", "loop_function", "preload", "python_loop"]
