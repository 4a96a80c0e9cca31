"""The n-input reduced model solved at every evaluation (no table): the loop-closure equations of
:mod:`.multi_kin` solved by Newton in the compiled loop, for machines the grid table does not cover
(three or more inputs: a tensor-product table over ℝⁿ would need Nⁿ cells) or when a scenario asks
for it (``[mechanism] reduced_model = "solve"``; docs/linkages.md §8.4).

At each evaluation, at the inputs q and rates q̇ (docs/linkages.md §8.4, :mod:`.multi_kin`):

1. z from Φ(z, q) = 0 by Newton (Φ_z Δz = Φ), warm-started from the previous evaluation's z moved by
   its V·Δq (the first evaluation of a run walks from the stated pose to q in :data:`START_STEPS`
   steps: the stated pose's assembly branch), converged when every scaled residual is ≤
   :data:`NEWTON_TOL` (lengths relative to the linkage's size L);
2. V = ∂z/∂q from Φ_z V = E (E: the identity in the driving rows) and w from Φ_z w = γ(z, V q̇), with
   one LU factorisation of Φ_z at the converged z (partial pivoting);
3. M̄ = VᵀMV, and the bias c̄ + ḡ + D̄q̇ = Vᵀ(M w + ∂E_p/∂z) + Σ_k c_k (r_k·q̇) r_k, with r_k the
   damped joint k's relative rate per unit input rate.

These are the operations :meth:`.multi.MultiCompiled.channels_n` does in NumPy for the table, on
one configuration, written as a law (the same formulas, another implementation: the tests compare
the two, and both with MuJoCo).  Revolute joints, gravity and joint damping; prismatic joints,
springs and higher pairs are refused in one line (:func:`solve_params`).  A configuration where the
Newton iteration does not converge (a singular configuration, a loop that cannot close) gives NaN:
the run stops as diverged at that time.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ... import compiled as C
from ...compiled.linalg import lu_factor, lu_solve
from ...errors import GeometryError

#: scaled residual below which a Newton iterate is converged (lengths / L, angles in rad)
NEWTON_TOL = 1e-13
#: Newton iterations at most per solve
NEWTON_MAX = 30
#: steps of the first evaluation's walk from the stated pose to the run's initial inputs
START_STEPS = 64

#: the solved model's parameters: inputs n, coordinates nz (= rows), revolute joints (bodies i, j;
#: points s_i, s_j relative to the mass centres, (nr, 2)), the inputs' joints' bodies (i, j), the
#: diagonal of M (nz), ∂E_p/∂z (gravity, nz), the damped joints (indices into the revolute ones, and
#: their coefficients), the row scale of Φ, the stated pose (z, q)
SolveP = namedtuple("SolveP", "n nz ri rj si sj di dj mdiag dEdz dk dc rs z_ref q_ref")


def scratch_size(n: int, nz: int) -> int:
    """Slots the solved model uses (:func:`solve_core`'s layout): a flag, (q, q̇) in (2n), M̄ and the
    bias out (n² + n), z and the last q (nz + n), Φ_z's LU and pivots (nz² + nz), V (nz·n), w, Φ and
    the body velocities (3·nz)."""
    return 1 + 2 * n + n * n + n + nz + n + nz * nz + nz + nz * n + 3 * nz


@C.law
def _turn(W, iz, b, sx, sy):
    """A(θ_b)·s: the local vector s = (sx, sy) of body b turned to the world (b < 0, the ground: s)."""
    if b < 0:
        return sx, sy
    th = W[iz + 3 * b + 2]
    c = math.cos(th)
    s = math.sin(th)
    return c * sx - s * sy, s * sx + c * sy


@C.law
def _phi(P, W, iz, iq, out):
    """Φ(z, q) into W[out:out+nz]: two rows per revolute joint (P_i − P_j), one per input
    (θ_j − θ_i − q_k), the inputs q at W[iq:iq+n]."""
    nr = P.ri.shape[0]
    for k in range(nr):
        i = P.ri[k]
        j = P.rj[k]
        ax, ay = _turn(W, iz, i, P.si[k, 0], P.si[k, 1])
        bx, by = _turn(W, iz, j, P.sj[k, 0], P.sj[k, 1])
        if i >= 0:
            ax += W[iz + 3 * i]
            ay += W[iz + 3 * i + 1]
        if j >= 0:
            bx += W[iz + 3 * j]
            by += W[iz + 3 * j + 1]
        W[out + 2 * k] = ax - bx
        W[out + 2 * k + 1] = ay - by
    r0 = 2 * nr
    for k in range(P.n):
        i = P.di[k]
        j = P.dj[k]
        thi = W[iz + 3 * i + 2] if i >= 0 else 0.0
        W[out + r0 + k] = W[iz + 3 * j + 2] - thi - W[iq + k]


@C.law
def _jac(P, W, iz, iJ):
    """Φ_z (nz × nz, row-major) into W[iJ:]: a revolute joint's rows ±I on the bodies' positions and
    ±∂(A s)/∂θ = ±(−(A s)_y, (A s)_x) on their angles; a driving row ±1 on the two angles."""
    nz = P.nz
    for r in range(nz * nz):
        W[iJ + r] = 0.0
    nr = P.ri.shape[0]
    for k in range(nr):
        r = iJ + 2 * k * nz
        i = P.ri[k]
        j = P.rj[k]
        if i >= 0:
            ax, ay = _turn(W, iz, i, P.si[k, 0], P.si[k, 1])
            W[r + 3 * i] = 1.0
            W[r + nz + 3 * i + 1] = 1.0
            W[r + 3 * i + 2] = -ay
            W[r + nz + 3 * i + 2] = ax
        if j >= 0:
            bx, by = _turn(W, iz, j, P.sj[k, 0], P.sj[k, 1])
            W[r + 3 * j] = -1.0
            W[r + nz + 3 * j + 1] = -1.0
            W[r + 3 * j + 2] = by
            W[r + nz + 3 * j + 2] = -bx
    r0 = 2 * nr
    for k in range(P.n):
        r = iJ + (r0 + k) * nz
        W[r + 3 * P.dj[k] + 2] = 1.0
        if P.di[k] >= 0:
            W[r + 3 * P.di[k] + 2] = -1.0


@C.law
def _newton(P, W, iz, iq, iJ, ip, iF):
    """z (W[iz:]) solved at the inputs W[iq:iq+n] from its current value; True when converged."""
    nz = P.nz
    for it in range(NEWTON_MAX):
        _phi(P, W, iz, iq, iF)
        err = 0.0
        for r in range(nz):
            e = abs(W[iF + r] * P.rs[r])
            if not e <= err:  # (NaN too)
                err = e
        if err <= NEWTON_TOL:
            return True
        if not err < 1e6:
            return False
        _jac(P, W, iz, iJ)
        if not lu_factor(W, iJ, ip, nz):
            return False
        lu_solve(W, iJ, ip, nz, iF)
        for r in range(nz):
            W[iz + r] -= W[iF + r]
    return False


@C.law(inline=False)
def solve_core(P, W, ic):
    """The model at the inputs (q, q̇) = W[ic+1 : ic+1+2n] into W[ic+1+2n:]: M̄ (n×n, row-major) and
    the bias (n); NaN where the loops cannot be solved.  W[ic] = 0 on a run's first evaluation (then
    1): z is walked there from the stated pose, else warm-started from the last evaluation."""
    n = P.n
    nz = P.nz
    iqv = ic + 1
    iout = iqv + 2 * n
    iz = iout + n * n + n
    ilast = iz + nz
    iJ = ilast + n
    ip = iJ + nz * nz
    iV = ip + nz
    iw = iV + nz * n
    iF = iw + nz
    iv = iF + nz
    ok = True
    if W[ic] == 0.0:
        for r in range(nz):
            W[iz + r] = P.z_ref[r]
        for s in range(1, START_STEPS + 1):
            f = s / START_STEPS
            for k in range(n):
                W[ilast + k] = P.q_ref[k] + f * (W[iqv + k] - P.q_ref[k])
            if not _newton(P, W, iz, ilast, iJ, ip, iF):
                ok = False
                break
        W[ic] = 1.0
    else:  # the first-order prediction z + V·(q − q_last) from the last evaluation's V
        for r in range(nz):
            acc = 0.0
            for k in range(n):
                acc += W[iV + r * n + k] * (W[iqv + k] - W[ilast + k])
            W[iz + r] += acc
    if ok:
        ok = _newton(P, W, iz, iqv, iJ, ip, iF)
    if ok:
        _jac(P, W, iz, iJ)
        ok = lu_factor(W, iJ, ip, nz)
    if not ok:
        for r in range(n * n + n):
            W[iout + r] = math.nan
        W[ic] = 0.0  # (the next evaluation starts again from the stated pose)
        return
    for k in range(n):
        W[ilast + k] = W[iqv + k]
    # V: one column per input (the driving row's unit right-hand side)
    r0 = nz - n
    for k in range(n):
        for r in range(nz):
            W[iF + r] = 0.0
        W[iF + r0 + k] = 1.0
        lu_solve(W, iJ, ip, nz, iF)
        for r in range(nz):
            W[iV + r * n + k] = W[iF + r]
    # the body velocities v = V q̇ and γ(z, v): A_i s_i ω_i² − A_j s_j ω_j² per revolute joint
    for r in range(nz):
        acc = 0.0
        for k in range(n):
            acc += W[iV + r * n + k] * W[iqv + n + k]
        W[iv + r] = acc
    nr = P.ri.shape[0]
    for r in range(2 * nr, nz):
        W[iw + r] = 0.0  # (the driving rows: γ = 0)
    for k in range(nr):  # (the ground's terms vanish: ω = 0)
        ax, ay = _turn(W, iz, P.ri[k], P.si[k, 0], P.si[k, 1])
        bx, by = _turn(W, iz, P.rj[k], P.sj[k, 0], P.sj[k, 1])
        wi = W[iv + 3 * P.ri[k] + 2] if P.ri[k] >= 0 else 0.0
        wj = W[iv + 3 * P.rj[k] + 2] if P.rj[k] >= 0 else 0.0
        W[iw + 2 * k] = ax * (wi * wi) - bx * (wj * wj)
        W[iw + 2 * k + 1] = ay * (wi * wi) - by * (wj * wj)
    lu_solve(W, iJ, ip, nz, iw)
    # M̄ = VᵀMV; bias = Vᵀ(M w + ∂E_p/∂z) + Σ c_k (r_k·q̇) r_k
    for a in range(n):
        for b in range(a, n):
            acc = 0.0
            for r in range(nz):
                acc += W[iV + r * n + a] * P.mdiag[r] * W[iV + r * n + b]
            W[iout + a * n + b] = acc
            W[iout + b * n + a] = acc
        acc = 0.0
        for r in range(nz):
            acc += W[iV + r * n + a] * (P.mdiag[r] * W[iw + r] + P.dEdz[r])
        W[iout + n * n + a] = acc
    for m in range(P.dk.shape[0]):
        k = P.dk[m]
        i = P.ri[k]
        j = P.rj[k]
        rate = W[iv + 3 * j + 2] - (W[iv + 3 * i + 2] if i >= 0 else 0.0)
        for a in range(n):
            ra = W[iV + (3 * j + 2) * n + a] - (W[iV + (3 * i + 2) * n + a] if i >= 0 else 0.0)
            W[iout + n * n + a] += P.dc[m] * rate * ra


@C.law
def solve_joint_rate(P, W, ic, i, j, a):
    """From the last evaluation of :func:`solve_core` (scratch at W[ic:]): the rate of the hinge between
    bodies i and j (−1: the ground), θ̇_j − θ̇_i (a < 0), or its rate per unit rate of input a,
    ∂(θ_j − θ_i)/∂q_a (a ≥ 0) — V's rows, read where the evaluation left them."""
    n = P.n
    nz = P.nz
    iV = ic + 1 + 2 * n + n * n + n + nz + n + nz * nz + nz
    if a < 0:
        iv = iV + nz * n + 2 * nz
        return W[iv + 3 * j + 2] - (W[iv + 3 * i + 2] if i >= 0 else 0.0)
    return W[iV + (3 * j + 2) * n + a] - (W[iV + (3 * i + 2) * n + a] if i >= 0 else 0.0)


@C.law
def solve_model(S, iy, t, P, W, iw):
    """:func:`.multi.multi_model`'s interface: the model at (q, q̇) = S[iy:iy+2n] — M̄ into
    W[iw:iw+n²], the bias into W[iw+n²:iw+n²+n] — its scratch at W[iw+n²+n:] (:func:`solve_core`)."""
    n = P.n
    ic = iw + n * n + n
    for k in range(2 * n):
        W[ic + 1 + k] = S[iy + k]
    solve_core(P, W, ic)
    io = ic + 1 + 2 * n
    for r in range(n * n + n):
        W[iw + r] = W[io + r]


@C.law
def solve_two(q0, q1, v0, v1, t, P, W, ic):
    """:func:`.multi.two_model`'s interface (two inputs): (M̄₀₀, M̄₀₁, M̄₁₁, bias₀, bias₁) at q = (q0, q1),
    q̇ = (v0, v1), its scratch at W[ic:] (:func:`solve_core`)."""
    W[ic + 1] = q0
    W[ic + 2] = q1
    W[ic + 3] = v0
    W[ic + 4] = v1
    solve_core(P, W, ic)
    return W[ic + 5], W[ic + 6], W[ic + 8], W[ic + 9], W[ic + 10]


def solve_params(c) -> SolveP:
    """:class:`SolveP` of a built multi-input description ``c`` (:class:`.multi.MultiCompiled`);
    GeometryError naming what the solved model does not take."""
    name = c.p.name
    if any(jt.kind != "R" for jt in c.kjoints):
        raise GeometryError(f"linkage {name!r}: reduced_model = 'solve' takes revolute joints only (prismatic: "
                            f"{', '.join(jt.name for jt in c.kjoints if jt.kind != 'R')}); use 1 or 2 inputs "
                            f"with the table")
    if c.springs or c.gears:
        raise GeometryError(f"linkage {name!r}: reduced_model = 'solve' takes no springs or gears yet; use 1 or 2 "
                            f"inputs with the table")
    nz = c.sys.nz
    if c.sys.m != nz:
        raise GeometryError(f"linkage {name!r}: reduced_model = 'solve' needs independent loop constraints "
                            f"({c.sys.m} equations for {nz} link coordinates)")
    js = c.kjoints
    mdiag = np.stack([c.mass, c.mass, c.inertia], axis=1).reshape(-1)
    gx, gy = c.g
    dE = np.zeros((c.n, 3))
    dE[:, 0] = -c.mass * gx
    dE[:, 1] = -c.mass * gy
    damped = [k for k in c.damped]
    return SolveP(int(c.ninputs), int(nz), np.array([jt.i for jt in js], dtype=np.int64),
                  np.array([jt.j for jt in js], dtype=np.int64),
                  np.array([jt.si for jt in js], dtype=float).reshape(-1, 2),
                  np.array([jt.sj for jt in js], dtype=float).reshape(-1, 2),
                  np.array([i for i, _ in c.drivers], dtype=np.int64), np.array([j for _, j in c.drivers], dtype=np.int64),
                  np.ascontiguousarray(mdiag), np.ascontiguousarray(dE.reshape(-1)),
                  np.array(damped, dtype=np.int64), np.array([c.p.joints[k].damping for k in damped], dtype=float),
                  np.ascontiguousarray(c.sys.row_scale, dtype=float), np.array(c.z_ref, dtype=float),
                  np.array(c.q_ref, dtype=float))


__all__ = ["SolveP", "solve_model", "solve_two", "solve_core", "solve_joint_rate", "solve_params", "scratch_size",
           "NEWTON_TOL",
           "START_STEPS"]
