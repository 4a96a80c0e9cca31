"""The reduced plant of a machine with n inputs (one motor each): RK4 on

    M̄(q) q̈ + c̄(q, q̇) + ḡ(q) + D̄(q) q̇ = τ − c·q̇

with the mechanism's n-input model law (``model_form``; :mod:`mjbench.backends.reduced` builds the
plant): :func:`rk4_multi` for any n, :func:`rk4_two` for two inputs — the same operations in the same
order, written out in local variables (no state round trips, no loops over a run-time n).
"""
from __future__ import annotations

from collections import namedtuple

import math

from .. import compiled as C
from ..compiled.linalg import lu_factor, lu_solve
from ..drivetrain.gear import friction_term, mesh_torque_law
from ..mechanisms.linkage.multi import put_two

#: the n-input reduced plant's parameters: step, number of inputs, the drives' J_eq and viscous
#: coefficients (arrays n), the model law's parameters, the work space's offset in the state, the
#: number of the model's scratch channels
MultiP = namedtuple("MultiP", "h n Ja c model iw nch")


def multi_work(n: int) -> int:
    """Offset of :func:`rk4_multi`'s model work space in its state: y (2n), the stage state (2n),
    four stage accelerations and three stage velocities (n each)."""
    return 11 * n


def multi_state_size(n: int, channels: int) -> int:
    """Length of :func:`rk4_multi`'s state: :func:`multi_work`, the model's M̄ and bias (n² + n), its
    channels, the linear solve's matrix, right-hand side and pivots (n² + 2n)."""
    return multi_work(n) + n * n + n + channels + n * n + 2 * n


@C.law
def multi_accel(MODEL, t, S, iy, ia, TAU, P):
    """Accelerations q̈ (n) at the state S[iy:iy+2n] into S[ia:ia+n]: MODEL writes M̄ and the bias,
    then (M̄ + diag J_eq) q̈ = τ − c·q̇ − bias: one or two inputs in closed form (Cramer's rule; the
    matrix is symmetric positive definite, the determinant its two eigenvalues' product), more by
    LU factorisation with partial pivoting (:mod:`mjbench.compiled.linalg`)."""
    n = P.n
    iw = P.iw
    MODEL(S, iy, t, P.model, S, iw)
    ib = iw + n * n
    if n == 1:
        S[ia] = (TAU[0] - P.c[0] * S[iy + 1] - S[ib]) / (S[iw] + P.Ja[0])
        return
    if n == 2:
        a = S[iw] + P.Ja[0]
        b = S[iw + 1]
        c = S[iw + 2]
        d = S[iw + 3] + P.Ja[1]
        r0 = TAU[0] - P.c[0] * S[iy + 2] - S[ib]
        r1 = TAU[1] - P.c[1] * S[iy + 3] - S[ib + 1]
        S[ia], S[ia + 1] = solve2(a, b, c, d, r0, r1)
        return
    iA = ib + n + P.nch
    ir = iA + n * n
    ip = ir + n
    for i in range(n):
        for j in range(n):
            S[iA + i * n + j] = S[iw + i * n + j]
        S[iA + i * n + i] += P.Ja[i]
        S[ir + i] = TAU[i] - P.c[i] * S[iy + n + i] - S[ib + i]
    if lu_factor(S, iA, ip, n):
        lu_solve(S, iA, ip, n, ir)
        for i in range(n):
            S[ia + i] = S[ir + i]
    else:  # (M̄ + J_eq is positive definite: only NaN gets here)
        for i in range(n):
            S[ia + i] = math.nan


@C.law
def rk4_multi(MODEL, TAU, t, P, S, QO):
    """One classical RK4 step of the n-input reduced model with the axes' torques TAU held; the
    state S[0:2n] = (q, q̇); (q_a, q̇_a, 0, 0) of every axis into QO."""
    n = P.n
    h = P.h
    h2 = 0.5 * h
    h6 = h / 6.0
    ys = 2 * n
    a1 = 4 * n
    a2 = a1 + n
    a3 = a2 + n
    a4 = a3 + n
    u2 = a4 + n
    u3 = u2 + n
    u4 = u3 + n
    multi_accel(MODEL, t, S, 0, a1, TAU, P)
    rk4_stage(S, n, n, ys, h2, a1, u2, -1)
    multi_accel(MODEL, t + h2, S, ys, a2, TAU, P)
    rk4_stage(S, n, n, ys, h2, a2, u3, u2)
    multi_accel(MODEL, t + h2, S, ys, a3, TAU, P)
    rk4_stage(S, n, n, ys, h, a3, u4, u3)
    multi_accel(MODEL, t + h, S, ys, a4, TAU, P)
    rk4_finish(S, n, n, h6, a1, u2)
    multi_read(P, S, QO)


@C.law
def rk4_stage(S, m, n, ys, hs, ia, iu, iv):
    """One RK4 stage's state at S[ys:] from the state y at S[0:] — m coordinates, coordinate j at
    p = j + ⌊j/n⌋·n and its rate at p + n (n = m: (q, q̇); m = 2n: (q, q̇, δ, δ̇)) —: the stage rates
    u_j = ẏ_j + hs·a_j (a at S[ia:], u into S[iu:]) and positions y_p + hs·v_j (v: the state's rates
    when iv < 0, else the previous stage's, S[iv:])."""
    for j in range(m):
        p = j + (j // n) * n
        S[iu + j] = S[p + n] + hs * S[ia + j]
        v = S[p + n] if iv < 0 else S[iv + j]
        S[ys + p] = S[p] + hs * v
        S[ys + p + n] = S[iu + j]


@C.law
def rk4_finish(S, m, n, h6, a1, u2):
    """The RK4 step's end: y_p += h/6·(v + 2u₂ + 2u₃ + u₄), ẏ_p += h/6·(a₁ + 2a₂ + 2a₃ + a₄) over the m
    coordinates of :func:`rk4_stage` (the four accelerations from S[a1:], the three stage rates from
    S[u2:], m apart)."""
    for j in range(m):
        p = j + (j // n) * n
        x = S[p]
        v = S[p + n]
        S[p] = x + h6 * (v + 2.0 * S[u2 + j] + 2.0 * S[u2 + m + j] + S[u2 + 2 * m + j])
        S[p + n] = v + h6 * (S[a1 + j] + 2.0 * S[a1 + m + j] + 2.0 * S[a1 + 2 * m + j] + S[a1 + 3 * m + j])


@C.law
def multi_read(P, S, QO):
    """(q_a, q̇_a, 0, 0) of every axis into QO."""
    n = P.n
    for a in range(n):
        QO[4 * a] = S[a]
        QO[4 * a + 1] = S[n + a]
        QO[4 * a + 2] = 0.0
        QO[4 * a + 3] = 0.0


@C.law
def solve2(a, b, c, d, r0, r1):
    """x of [[a, b], [c, d]]·x = r by Cramer's rule (the matrix M̄ + diag J_eq is symmetric positive
    definite: the determinant is its two eigenvalues' product).  The determinant's reciprocal is taken
    once and multiplies both numerators: it depends on the matrix alone, so in the co-step it is
    ready before the right-hand side (which waits for the bias), and no division is left on the
    RK4 stage's dependency chain — the five-bar's 1 s reduced run ≈ 5 % shorter than with two
    divisions (docs/performance.md §8; x is then within ≈ 1 ulp more of the exact quotient)."""
    inv = 1.0 / (a * d - b * c)
    return (d * r0 - b * r1) * inv, (a * r1 - c * r0) * inv


@C.law
def accel_two(MODEL, q0, q1, v0, v1, t, TAU, P, S):
    """:func:`multi_accel` for two inputs at (q, q̇) = (q0, q1, v0, v1): MODEL(q0, q1, v0, v1, t, P.model,
    S, 4) → (M̄₀₀, M̄₀₁, M̄₁₁, bias₀, bias₁) with its scratch at S[4:] (:func:`rk4_two` keeps its state in
    S[0:4] and the rest in local variables; a constant offset: the scratch's addresses are constants
    of the compiled code)."""
    m00, m01, m11, g0, g1 = MODEL(q0, q1, v0, v1, t, P.model, S, 4)
    r0 = TAU[0] - P.c[0] * v0 - g0
    r1 = TAU[1] - P.c[1] * v1 - g1
    return solve2(m00 + P.Ja[0], m01, m01, m11 + P.Ja[1], r0, r1)


@C.law
def rk4_two(MODEL, TAU, t, P, S, QO):
    """:func:`rk4_multi` for two inputs (P.n = 2), its loops written out in local variables: the same
    operations in the same order (the same bits); the model law is scalar (:func:`accel_two`)."""
    h = P.h
    h2 = 0.5 * h
    h6 = h / 6.0
    x0 = S[0]
    x1 = S[1]
    v0 = S[2]
    v1 = S[3]
    a10, a11 = accel_two(MODEL, x0, x1, v0, v1, t, TAU, P, S)
    u20 = v0 + h2 * a10
    u21 = v1 + h2 * a11
    a20, a21 = accel_two(MODEL, x0 + h2 * v0, x1 + h2 * v1, u20, u21, t + h2, TAU, P, S)
    u30 = v0 + h2 * a20
    u31 = v1 + h2 * a21
    a30, a31 = accel_two(MODEL, x0 + h2 * u20, x1 + h2 * u21, u30, u31, t + h2, TAU, P, S)
    u40 = v0 + h * a30
    u41 = v1 + h * a31
    a40, a41 = accel_two(MODEL, x0 + h * u30, x1 + h * u31, u40, u41, t + h, TAU, P, S)
    q0 = x0 + h6 * (v0 + 2.0 * u20 + 2.0 * u30 + u40)
    q1 = x1 + h6 * (v1 + 2.0 * u21 + 2.0 * u31 + u41)
    w0 = v0 + h6 * (a10 + 2.0 * a20 + 2.0 * a30 + a40)
    w1 = v1 + h6 * (a11 + 2.0 * a21 + 2.0 * a31 + a41)
    S[0] = q0
    S[1] = q1
    S[2] = w0
    S[3] = w1
    QO[0] = q0
    QO[1] = w0
    QO[2] = 0.0
    QO[3] = 0.0
    QO[4] = q1
    QO[5] = w1
    QO[6] = 0.0
    QO[7] = 0.0


# ============================================================================ compliant gears per axis
#: the plant of a machine with several motors and a compliant gear on some axes
#: (:mod:`mjbench.drivetrain.axes`): step, number of inputs, the drives' J_eq and z²λ (arrays n), the
#: axes' gears (:class:`mjbench.drivetrain.axes.AxesGearP`), the model law's parameters (multi
#: interface), the work space's offset in the state, the number of the model's scratch channels
GearPlantP = namedtuple("GearPlantP", "h n Ja c gear model iw nch")


def gear_work(n: int) -> int:
    """Offset of :func:`rk4_axes_gear`'s model work space in its state: y = (q, q̇, δ, δ̇) (4n), the stage
    state (4n), four stage accelerations (q̈, δ̈: 2n each), three stage velocities (q̇, δ̇: 2n each)."""
    return 22 * n


def gear_state_size(n: int, channels: int) -> int:
    """Length of :func:`rk4_axes_gear`'s state: :func:`gear_work`, the model's M̄ and bias (n² + n), its
    channels, the linear solve's matrix, right-hand side, pivots and the mesh torques (n² + 3n)."""
    return gear_work(n) + n * n + n + channels + n * n + 3 * n


@C.law
def two_as_multi(MODEL, S, iy, t, P, W, iw):
    """A two-input model law with the scalar interface (:func:`accel_two`'s MODEL) called with the
    n-input one: M̄ (row-major) and the bias into W[iw:iw+6], its scratch after them."""
    m00, m01, m11, b0, b1 = MODEL(S[iy], S[iy + 1], S[iy + 2], S[iy + 3], t, P, W, iw + 6)
    put_two(W, iw, m00, m01, m11, b0, b1)


@C.law
def axes_gear_accel(MODEL, t, S, iy, ia, TAU, P):
    """Accelerations (q̈ into S[ia:ia+n], δ̈ into S[ia+n:ia+2n]) at the state y = (q, q̇, δ, δ̇) at S[iy:]
    of n inputs, axis k behind a compliant gear when P.gear.comp[k] (docs/drivetrain.md §7):

        (M̄ + diag J_k) q̈ = r,   r_k = T_g,k − bias_k (compliant; J_k = J_b,k: the crank side),
                                  r_k = τ_k − c_k·q̇_k − bias_k (rigid; J_k = J_eq,k),
        J_mo,k·θ̈_m,k = τ_k − c_k·θ̇_m,k − T_g,k + the motor's friction,   δ̈_k = θ̈_m,k − q̈_k,

    T_g,k = :func:`mesh_torque_law` (δ_k, δ̇_k) the mesh torque, θ_m,k = q_k + δ_k the motor at the output
    (the one-motor law :func:`mjbench.drivetrain.gear.compliant_accel`, per axis); a rigid axis's δ
    stays 0.  The linear solve by LU factorisation with partial pivoting."""
    n = P.n
    iw = P.iw
    G = P.gear
    MODEL(S, iy, t, P.model, S, iw)
    ib = iw + n * n
    iA = ib + n + P.nch
    ir = iA + n * n
    ip = ir + n
    ig = ip + n
    for i in range(n):
        for j in range(n):
            S[iA + i * n + j] = S[iw + i * n + j]
    for k in range(n):
        if G.comp[k]:
            tg = mesh_torque_law(S[iy + 2 * n + k], S[iy + 3 * n + k], G.k[k], G.c[k], G.hb[k])
            S[ig + k] = tg
            S[iA + k * n + k] += G.Jb[k]
            S[ir + k] = tg - S[ib + k]
        else:
            S[iA + k * n + k] += P.Ja[k]
            S[ir + k] = TAU[k] - P.c[k] * S[iy + n + k] - S[ib + k]
    if lu_factor(S, iA, ip, n):
        lu_solve(S, iA, ip, n, ir)
        for i in range(n):
            S[ia + i] = S[ir + i]
    else:  # (M̄ + diag J is positive definite: only NaN gets here)
        for i in range(n):
            S[ia + i] = math.nan
    for k in range(n):
        if G.comp[k]:
            wm = S[iy + n + k] + S[iy + 3 * n + k]
            tm = TAU[k] - P.c[k] * wm - S[ig + k]
            if G.friction:
                tm = friction_term(tm, wm, G.T, k)
            S[ia + n + k] = tm / G.Jm[k] - S[ia + k]
        else:
            S[ia + n + k] = 0.0


@C.law
def rk4_axes_gear(MODEL, TAU, t, P, S, QO):
    """One classical RK4 step of n inputs with compliant gears (:func:`axes_gear_accel`), the axes'
    torques TAU held; the state S[0:4n] = (q, q̇, δ, δ̇); (q_a, q̇_a, δ_a, δ̇_a) of every axis into QO."""
    n = P.n
    n2 = 2 * n
    h = P.h
    h2 = 0.5 * h
    h6 = h / 6.0
    ys = 4 * n
    a1 = 8 * n
    a2 = a1 + n2
    a3 = a2 + n2
    a4 = a3 + n2
    u2 = a4 + n2
    u3 = u2 + n2
    u4 = u3 + n2
    axes_gear_accel(MODEL, t, S, 0, a1, TAU, P)  # (coordinates q, δ; their rates n further: rk4_stage)
    rk4_stage(S, n2, n, ys, h2, a1, u2, -1)
    axes_gear_accel(MODEL, t + h2, S, ys, a2, TAU, P)
    rk4_stage(S, n2, n, ys, h2, a2, u3, u2)
    axes_gear_accel(MODEL, t + h2, S, ys, a3, TAU, P)
    rk4_stage(S, n2, n, ys, h, a3, u4, u3)
    axes_gear_accel(MODEL, t + h, S, ys, a4, TAU, P)
    rk4_finish(S, n2, n, h6, a1, u2)
    axes_gear_read(P, S, QO)


@C.law
def axes_gear_read(P, S, QO):
    """(q_a, q̇_a, δ_a, δ̇_a) of every axis into QO (δ = 0 on a rigid axis)."""
    n = P.n
    for a in range(n):
        QO[4 * a] = S[a]
        QO[4 * a + 1] = S[n + a]
        QO[4 * a + 2] = S[2 * n + a]
        QO[4 * a + 3] = S[3 * n + a]


@C.law
def axes_gear_write(out, b, P, S):
    """The compliant axes' deflections δ, then their rates δ̇ into ``out[b:]`` (the mechanism's
    internal coordinates ``<axis>:gear_deflection``)."""
    n = P.n
    idx = P.gear.axes
    m = len(idx)
    for i in range(m):
        out[b + i] = S[2 * n + idx[i]]
        out[b + m + i] = S[3 * n + idx[i]]
