"""mjbench's environment variables, read and checked in one place (docs/outputs.md).

Each reader returns the checked value, or raises a :class:`~mjbench.errors.ParameterError` naming
the variable, its value and what it accepts — never a traceback, a silently ignored value or a
misleading message further on.  ``mjbench`` checks them all before it does anything (:func:`check`).

| variable | meaning | accepted |
|---|---|---|
| ``MJBENCH_JIT`` | loop choice | ``0`` / ``python`` (always CPython), ``1`` / ``compiled`` (always compiled), ``check`` (compiled, bounds-checked, the failing law named); unset or empty: automatic |
| ``MJBENCH_MAX_RECORD_MB`` | largest record a run allocates [MiB] | a finite number > 0 (default: half the available memory) |
| ``MJBENCH_MAX_SWEEP_ROWS`` | largest sweep | a whole number ≥ 1 (default 100 000) |
| ``MJBENCH_DASK_TIMEOUT`` | seconds a sweep waits for a Dask scheduler, and for workers when the cluster has none | a finite number > 0 (default 5; workers: 60) |
| ``MJBENCH_CACHE_DIR`` | compiled code's cache folder | a writable folder (otherwise a temporary one, with a note) |
"""
from __future__ import annotations

import math
import os

from .errors import ParameterError

#: MJBENCH_JIT's accepted spellings → the loop they ask for ("" = automatic)
JIT_VALUES = {"": "", "0": "python", "python": "python", "1": "compiled", "compiled": "compiled", "check": "check"}


def _raw(name: str) -> str | None:
    v = os.environ.get(name)
    return None if v is None or v.strip() == "" else v.strip()


def jit() -> str:
    """``MJBENCH_JIT`` → "" (automatic), "python", "compiled" or "check"."""
    v = _raw("MJBENCH_JIT")
    if v is None:
        return ""
    mode = JIT_VALUES.get(v.lower())
    if mode is None:
        raise ParameterError(f"MJBENCH_JIT = {v!r}: must be 0 (or python: always the CPython loop), 1 (or compiled: "
                             f"always the compiled loop), check (compiled, bounds-checked), or unset (automatic)")
    return mode


def _number(name: str, ok, must: str, unset_means: str) -> float | None:
    """The variable ``name`` as a number, None when unset; ParameterError unless ``ok(x)``."""
    v = _raw(name)
    if v is None:
        return None
    try:
        x = float(v)
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and ok(x)):
        raise ParameterError(f"{name} = {v!r}: must be {must} (unset it for {unset_means})")
    return x


def _positive(name: str, what: str, unset_means: str) -> float | None:
    return _number(name, lambda x: x > 0, f"a finite number of {what} > 0", unset_means)


def max_record_mb() -> float | None:
    """``MJBENCH_MAX_RECORD_MB`` [MiB], None when unset."""
    return _positive("MJBENCH_MAX_RECORD_MB", "MiB", "half the available memory")


def max_sweep_rows() -> int | None:
    """``MJBENCH_MAX_SWEEP_ROWS``, None when unset."""
    x = _number("MJBENCH_MAX_SWEEP_ROWS", lambda x: x >= 1 and x == int(x), "a whole number of rows >= 1", "100,000")
    return None if x is None else int(x)


def dask_timeout(default: float) -> float:
    """``MJBENCH_DASK_TIMEOUT`` [s], ``default`` when unset."""
    x = _positive("MJBENCH_DASK_TIMEOUT", "seconds", f"{default:g} s")
    return default if x is None else x


def check() -> None:
    """Every variable above, checked (the first bad one raises)."""
    jit()
    max_record_mb()
    max_sweep_rows()
    dask_timeout(5.0)
