"""Optional compiled RK4 step of the batched, tabulated reduced model (numba; ``pip install mjbench[fast]``).

The same IEEE operations, in the same order, as the NumPy path of
:class:`mjbench.backends.reduced_batch.BatchReducedPlant` (and the scalar path of the single run):
no fast-math, no fused multiply-add, so the results are the same bits (tests/test_reduced_batch.py
runs both when numba is installed).  One loop over the simulations instead of ≈ 110 NumPy calls
per step: measured 4.7× cheaper for the plant step at N = 256 (docs/performance.md).  Used when
numba imports and the environment variable ``MJBENCH_JIT`` is not ``0``; compiled once and cached
on disk (``cache=True``).  Mechanisms with an untabulated external torque (a Python method) stay on
the NumPy path.
"""
from __future__ import annotations

import math
import os

import numpy as np

try:  # pragma: no cover - depends on the environment
    if os.environ.get("MJBENCH_JIT", "1") == "0":
        raise ImportError
    import numba
except ImportError:  # pragma: no cover
    numba = None

AVAILABLE = numba is not None


def enabled() -> bool:
    return AVAILABLE and os.environ.get("MJBENCH_JIT", "1") != "0"


if AVAILABLE:  # pragma: no branch
    @numba.njit(cache=True, inline="always")
    def _acc(qs, vv, ti, Jai, ci, ki, ni, bi, C, m, viscous):
        u = qs * ki
        fl = np.floor(u)  # a float, as the NumPy path (math.floor would return an integer)
        f = u - fl
        j = (np.int64(fl) % ni) + bi
        J = ((C[j, 3 * m] * f + C[j, 2 * m]) * f + C[j, m]) * f + C[j, 0]
        H = ((C[j, 3 * m + 1] * f + C[j, 2 * m + 1]) * f + C[j, m + 1]) * f + C[j, 1]
        E = ((C[j, 3 * m + 2] * f + C[j, 2 * m + 2]) * f + C[j, m + 2]) * f + C[j, 2]
        if viscous:
            D = ((C[j, 3 * m + 3] * f + C[j, 2 * m + 3]) * f + C[j, m + 3]) * f + C[j, 3]
            return (ti - (ci + D) * vv - E - H * vv * vv) / (Jai + J)
        return (ti - ci * vv - E - H * vv * vv) / (Jai + J)

    @numba.njit(cache=True)
    def rk4_table(q, v, tau, CT, base, nn, kk, Ja, c, h, m, viscous):
        """Advance every simulation one RK4 step in place (see the module docstring)."""
        h2 = 0.5 * h
        h6 = h / 6.0
        for i in range(q.shape[0]):
            qi, vi, ti, Jai, ci, ki, ni, bi = q[i], v[i], tau[i], Ja[i], c[i], kk[i], nn[i], base[i]
            if not (math.isfinite(qi) and math.isfinite(vi)):  # diverged: NaN, as the NumPy path
                q[i] = math.nan
                v[i] = math.nan
                continue
            a1 = _acc(qi, vi, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
            v2 = vi + h2 * a1
            a2 = _acc(qi + h2 * vi, v2, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
            v3 = vi + h2 * a2
            a3 = _acc(qi + h2 * v2, v3, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
            v4 = vi + h * a3
            a4 = _acc(qi + h * v3, v4, ti, Jai, ci, ki, ni, bi, CT, m, viscous)
            q[i] = qi + h6 * (vi + 2.0 * v2 + 2.0 * v3 + v4)
            v[i] = vi + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
else:  # pragma: no cover
    rk4_table = None
