"""Optional compiled RK4 step of the batched, tabulated reduced model (numba; ``pip install mjbench[fast]``).

The same IEEE operations, in the same order, as the NumPy path of
:class:`mjbench.backends.reduced_batch.BatchReducedPlant` (and the scalar path of the single run):
no fast-math, no fused multiply-add, so the results are the same bits (tests/test_reduced_batch.py
runs both when numba is installed).  One loop over the simulations instead of ≈ 110 NumPy calls
per step: measured 4.7× cheaper for the plant step at N = 256 (docs/performance.md).

When: importing numba and loading the compiled function costs 0.7–3 s of CPU, so by default the
batch uses it only for work of at least :data:`MIN_RUN_STEPS` run-steps (N × steps; ≈ the break-even
of 0.4 µs saved per run-step) or once numba is loaded anyway.  ``MJBENCH_JIT=0`` never uses it,
``MJBENCH_JIT=1`` always (when installed).  Compiled once and cached on disk (``cache=True``).
Mechanisms with an untabulated external torque (a Python method) stay on the NumPy path.
The whole co-step loop compiled (not only the plant step) is :mod:`mjbench.backends.fused`
(:func:`fused_kernel`).
"""
from __future__ import annotations

import importlib.util
import math
import os
import sys

import numpy as np

AVAILABLE = importlib.util.find_spec("numba") is not None
MIN_RUN_STEPS = 2_000_000
_kernel = None
_fused = None


def wanted(run_steps: float, threshold: float = MIN_RUN_STEPS) -> bool:
    """Whether a job of ``run_steps`` (N × steps) should use compiled code that saves enough per
    run-step to pay for loading numba from ``threshold`` run-steps on."""
    mode = os.environ.get("MJBENCH_JIT", "")
    if mode == "0" or not AVAILABLE:
        return False
    return mode == "1" or "numba" in sys.modules or run_steps >= threshold


def rk4_table(*args):
    """The compiled step (imported and compiled on first use)."""
    global _kernel
    if _kernel is None:
        _kernel = _build()
    return _kernel(*args)


def fused_kernel():
    """The compiled co-step loop (:mod:`mjbench.backends.fused`), loaded on first use."""
    global _fused
    if _fused is None:
        from ._jit_kernels import run_pid  # imports numba

        _fused = run_pid
    return _fused


def _build():
    from ._jit_kernels import step  # imports numba

    return step
