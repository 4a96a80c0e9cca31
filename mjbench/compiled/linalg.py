"""Small dense linear algebra as laws (:mod:`mjbench.compiled`): an LU factorisation with partial
pivoting in place in a work array, and its solve — the n-input reduced plant's (M̄ + J_eq)·q̈ = r for
three or more inputs (:func:`mjbench.backends.reduced_multi.multi_accel`) and the solved model's
loop-closure Jacobian Φ_z (:mod:`mjbench.mechanisms.linkage.multi_solve`).  Row-major matrices;
the pivots kept as floats in the work array."""
from __future__ import annotations

from . import law


@law
def lu_factor(W, iA, ip, m):
    """LU factorisation of the m × m matrix W[iA:iA+m²] (row-major) in place, partial pivoting: the
    multipliers below the diagonal, U on and above it, row c's pivot row in W[ip+c].  False if a
    pivot is 0 or NaN (a singular matrix)."""
    for c in range(m):
        piv = c
        big = abs(W[iA + c * m + c])
        for r in range(c + 1, m):
            v = abs(W[iA + r * m + c])
            if v > big:
                big = v
                piv = r
        W[ip + c] = float(piv)
        if not big > 0.0:
            return False
        if piv != c:
            for j in range(m):
                tmp = W[iA + c * m + j]
                W[iA + c * m + j] = W[iA + piv * m + j]
                W[iA + piv * m + j] = tmp
        d = W[iA + c * m + c]
        for r in range(c + 1, m):
            f = W[iA + r * m + c] / d
            W[iA + r * m + c] = f
            for j in range(c + 1, m):
                W[iA + r * m + j] -= f * W[iA + c * m + j]
    return True


@law
def lu_solve(W, iA, ip, m, ib):
    """x of A·x = b for the factorisation of :func:`lu_factor`; b at W[ib:ib+m], overwritten by x (the
    row swaps, then forward and back substitution: the operations of Gaussian elimination on b)."""
    for c in range(m):
        piv = int(W[ip + c])
        if piv != c:
            tmp = W[ib + c]
            W[ib + c] = W[ib + piv]
            W[ib + piv] = tmp
    for r in range(1, m):
        acc = W[ib + r]
        for j in range(r):
            acc -= W[iA + r * m + j] * W[ib + j]
        W[ib + r] = acc
    for r in range(m - 1, -1, -1):
        acc = W[ib + r]
        for j in range(r + 1, m):
            acc -= W[iA + r * m + j] * W[ib + j]
        W[ib + r] = acc / W[iA + r * m + r]


__all__ = ["lu_factor", "lu_solve"]
