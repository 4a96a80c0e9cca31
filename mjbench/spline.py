"""Periodic cubic splines on uniform nodes, in the cell's normalised coordinate (NumPy only).

The tabulated reduced model (:mod:`mjbench.backends.table`) and the generic linkage's periodic
tables (:class:`mjbench.mechanisms.linkage_kin.PeriodicTable`) interpolate quantities sampled at n
uniform nodes over one period.  On uniform nodes the C² periodic cubic spline has a circulant
system for its nodal slopes s_i (in units of the cell, t = (x − x_i)/h ∈ [0, 1)):

    s_{i−1} + 4·s_i + s_{i+1} = 3·(y_{i+1} − y_{i−1})        (indices mod n)

whose eigenvalues are 4 + 2·cos(2πk/n) ∈ [2, 6] (condition number ≤ 3): it is solved by one real
FFT.  The cell i polynomial is the cubic Hermite one, y_i + s_i t + (3Δ − 2s_i − s_{i+1}) t²
+ (s_i + s_{i+1} − 2Δ) t³ with Δ = y_{i+1} − y_i.  This is the spline
``scipy.interpolate.CubicSpline(bc_type="periodic")`` computes (the same interpolant: the periodic
C² cubic spline through the nodes is unique; the coefficients agree to rounding, ≈ 1e-16 of the
values, tests/test_spline.py), without importing SciPy's interpolation package (≈ 40 MB and
≈ 0.1–0.2 s of CPU for every process that builds a table).
"""
from __future__ import annotations

import numpy as np


def periodic_cubic(y) -> np.ndarray:
    """Coefficients (4, n, ...) — c₀, c₁, c₂, c₃ of cell i in t = (x − x_i)/h, ascending powers — of
    the periodic cubic spline through ``y`` (n, ...) sampled at n uniform nodes over one period
    (the node x_n = x_0 + period is not given: y_n = y_0)."""
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n < 3:
        raise ValueError(f"a periodic cubic spline needs at least 3 nodes, got {n}")
    nxt = np.roll(y, -1, axis=0)
    rhs = 3.0 * (nxt - np.roll(y, 1, axis=0))
    lam = 4.0 + 2.0 * np.cos(2.0 * np.pi * np.arange(n // 2 + 1) / n)
    lam = lam.reshape((-1,) + (1,) * (y.ndim - 1))
    s = np.fft.irfft(np.fft.rfft(rhs, axis=0) / lam, n, axis=0)
    s1 = np.roll(s, -1, axis=0)
    d = nxt - y
    return np.stack([y, s, 3.0 * d - 2.0 * s - s1, s + s1 - 2.0 * d])
