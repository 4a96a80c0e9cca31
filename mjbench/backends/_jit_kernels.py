"""The numba kernels of :mod:`mjbench.backends._jit` (imported only when the compiled step is used)."""
import math

import numba
import numpy as np


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
def step(q, v, tau, CT, base, nn, kk, Ja, c, h, m, viscous):
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
