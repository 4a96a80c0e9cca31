"""Motion generation through three coupler poses: centre points and circle points (inversion), the
order defect, a search of the pivots meeting the constraints."""
from __future__ import annotations

import math

import numpy as np

from ...errors import ParameterError
from .common import TWO_PI, Synthesis, _ang, _cross, circumcentre, constraint, fold, wrap
from .geometry import FourBar, _common_constraints


def _rotT(th, v):
    """R(θ)ᵀ·v for arrays: v (..., 2), θ broadcast."""
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1]], axis=-1)


def _rot(th, v):
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def centre_point(poses, m):
    """Ground pivot (circumcentre of the moving pivot's three positions) of the moving pivot m
    (coupler-frame coordinates, (..., 2)) for poses (3, 3) = (x, y, θ) rows."""
    P = np.asarray(poses, float)
    m = np.asarray(m, float)
    W = [P[j, :2] + _rot(P[j, 2], m) for j in range(3)]
    return circumcentre(*W), W


def circle_point(poses, G):
    """Moving pivot (coupler frame) whose three positions lie on a circle about the ground pivot G:
    the circumcentre of G seen from the coupler in the three poses (inversion)."""
    P = np.asarray(poses, float)
    G = np.asarray(G, float)
    g = [_rotT(P[j, 2], G - P[j, :2]) for j in range(3)]
    return circumcentre(*g)


def _mg_fourbar(poses, mA, A, mB, Dp):
    """FourBar with the input dyad (moving pivot mA → ground A) and the output dyad (mB → D): the
    coupler point is the pose origin; returns (fb, φ_j, σ_j)."""
    P = np.asarray(poses, float)
    Bj = np.array([P[j, :2] + _rot(P[j, 2], mA) for j in range(3)])
    Cj = np.array([P[j, :2] + _rot(P[j, 2], mB) for j in range(3)])
    a = float(np.hypot(*(Bj[0] - A)))
    c = float(np.hypot(*(Cj[0] - Dp)))
    b = float(np.hypot(*(mB - mA)))
    sig = np.sign(_cross(Dp - Bj, Cj - Bj)).astype(int)
    phi = _ang(Bj - A)
    # coupler point (the pose origin) in the coupler frame: origin B, x along B→C
    th3 = math.atan2(*(mB - mA)[::-1])
    Pc = _rotT(th3, -mA)
    fb = FourBar(A, Dp, a, b, c, int(sig[0]) or 1, P=(float(Pc[0]), float(Pc[1])))
    return fb, phi, sig


def _order_ok(phi):
    """Poses reached in order 1 → 2 → 3 turning the crank counter-clockwise."""
    d2 = (phi[1] - phi[0]) % TWO_PI
    d3 = (phi[2] - phi[0]) % TWO_PI
    return bool(d2 < d3)


def motion_generator(poses, *, ground_pivots=None, moving_pivots=None, min_transmission=None, max_link_ratio=None,
                     envelope=None, search_box=None, n_candidates=400, seed=0) -> Synthesis:
    """Four-bar whose coupler frame passes through three poses (x, y, θ), reached in order turning
    the crank forward.  Give the two ground pivots (input first), or the two moving pivots
    (coupler frame), or neither: the moving pivots are then searched (Sobol candidates in
    ``search_box`` = [[xmin, ymin], [xmax, ymax]] of the coupler frame + Nelder–Mead) for the
    largest minimum transmission angle meeting the constraints."""
    P = np.asarray(poses, float)
    if P.shape != (3, 3):
        raise ParameterError(f"motion generator: need three poses [x, y, θ], got shape {P.shape}")
    info = {}
    if ground_pivots is not None:
        A, Dp = (np.asarray(g, float) for g in ground_pivots)
        mA, mB = circle_point(P, A), circle_point(P, Dp)
        if not (np.all(np.isfinite(mA)) and np.all(np.isfinite(mB))):
            raise ParameterError("motion generator: a ground pivot's three inverted positions are collinear "
                                 "(its moving pivot is at infinity: a slider); move the pivot")
        info["pivots"] = "ground pivots given; moving pivots by inversion (circle points)"
    elif moving_pivots is not None:
        mA, mB = (np.asarray(m, float) for m in moving_pivots)
        (A, _), (Dp, _) = centre_point(P, mA), centre_point(P, mB)
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(Dp))):
            raise ParameterError("motion generator: a moving pivot's three positions are collinear (no centre point)")
        info["pivots"] = "moving pivots given; ground pivots as centre points"
    else:
        mA, A, mB, Dp = _search_pivots(P, min_transmission, max_link_ratio, envelope, search_box, n_candidates, seed)
        info["pivots"] = (f"moving pivots searched ({n_candidates} Sobol candidates per dyad in the coupler frame, "
                          f"then Nelder–Mead): largest minimum transmission angle meeting the constraints")
    fb, phi, sig = _mg_fourbar(P, mA, A, mB, Dp)
    sol = fb.solve(phi)
    pos_err = float(np.max(np.hypot(*(sol["P"] - P[:, :2]).T)))
    ang_err = float(np.max(np.abs(wrap(sol["theta3"] - _ang(np.asarray(mB) - np.asarray(mA)) - P[:, 2]))))
    ach = {**{k_.split()[1] + "_m": v for k_, v in fb.lengths.items()}, "input_angles_deg": np.degrees(phi).tolist(),
           "pose_position_error_m": pos_err, "pose_angle_error_rad": ang_err,
           "min_transmission_deg": math.degrees(fb.mu_min()),
           "A": fb.A.tolist(), "D": fb.D.tolist(), "moving_pivot_A": np.asarray(mA).tolist(),
           "moving_pivot_B": np.asarray(mB).tolist()}
    cons = [constraint("no branch defect (the three poses on one assembly branch)", bool(np.all(sig == sig[0])),
                       compare="true", note=f"branches: {sig.tolist()}"),
            constraint("no order defect (poses reached 1 → 2 → 3 turning the crank forward)", _order_ok(phi),
                       compare="true", note="input angles " + ", ".join(f"{x:.2f}°" for x in np.degrees(phi))),
            constraint("poses met (closed-form analysis), position", pos_err, 1e-9 * max(1.0, fb.d), "max", "m"),
            constraint("poses met (closed-form analysis), angle", ang_err, 1e-9, "max", "rad")]
    cons += _common_constraints(fb, min_transmission, max_link_ratio, envelope)
    return Synthesis("motion-generator", fb, {"poses": P.tolist()}, ach, cons, {**info, "input_angles": phi.tolist(),
                                                                                   "branches": sig.tolist()})


def _mg_quality(P, mA, mB, min_transmission, max_link_ratio, envelope):
    """Vectorised score of candidate pairs (..., 2): (penalty, −μ_min)."""
    GA, WA = centre_point(P, mA)
    GB, WB = centre_point(P, mB)
    a = np.linalg.norm(WA[0] - GA, axis=-1)
    c = np.linalg.norm(WB[0] - GB, axis=-1)
    d = np.linalg.norm(GB - GA, axis=-1)
    b = np.linalg.norm(mB - mA, axis=-1)
    full = (d + a <= b + c) & (np.abs(d - a) >= np.abs(b - c))
    pen = np.where(full, 0.0, 10.0)
    sig = [np.sign(_cross(GB - WA[j], WB[j] - WA[j])) for j in range(3)]
    pen += np.where((sig[0] == sig[1]) & (sig[1] == sig[2]), 0.0, 10.0)
    phi = [_ang(WA[j] - GA) for j in range(3)]
    order = ((phi[1] - phi[0]) % TWO_PI) < ((phi[2] - phi[0]) % TWO_PI)
    pen += np.where(order, 0.0, 10.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mus = [fold(np.arccos(np.clip((b * b + c * c - e * e) / (2 * b * c), -1, 1))) for e in (np.abs(d - a), d + a)]
        mu = np.where(full, np.minimum(*mus), 0.0)
        L = np.stack([a, b, c, d])
        ratio = L.max(axis=0) / L.min(axis=0)
    if min_transmission is not None:
        pen += np.maximum(0.0, min_transmission - mu)
    if max_link_ratio is not None:
        pen += np.maximum(0.0, ratio / max_link_ratio - 1.0)
    if envelope is not None:  # pivots and pose points within the box (the full-turn envelope is checked after)
        N = np.shape(a)
        for k, lim in enumerate(envelope):
            vals = np.stack([GA[..., k], GB[..., k]] + [np.broadcast_to(P[j, k], N) for j in range(3)])
            pen += np.maximum(0.0, np.ptp(vals, axis=0) / lim - 1.0)
    bad = ~np.isfinite(mu) | ~np.isfinite(pen) | ~np.isfinite(ratio)
    pen = np.where(bad, 1e9, pen)
    return pen, np.where(bad, 0.0, mu)


def _search_pivots(P, min_transmission, max_link_ratio, envelope, box, n, seed):
    from scipy.optimize import minimize
    from scipy.stats import qmc

    span = max(np.ptp(P[:, 0]), np.ptp(P[:, 1]), 1e-3)
    if box is None:
        box = [[-2.0 * span, -2.0 * span], [2.0 * span, 2.0 * span]]
    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    U = qmc.Sobol(2, scramble=True, seed=seed).random_base2(max(1, math.ceil(math.log2(max(2, int(n))))))[:int(n)]
    M = lo + U * (hi - lo)
    mA = np.repeat(M, len(M), axis=0)
    mB = np.tile(M, (len(M), 1))
    best = None
    for swap in (False, True):
        a_, b_ = (mB, mA) if swap else (mA, mB)
        pen, mu = _mg_quality(P, a_, b_, min_transmission, max_link_ratio, envelope)
        key = pen - 1e-3 * mu
        k = int(np.argmin(key))
        if best is None or key[k] < best[0]:
            best = (key[k], a_[k].copy(), b_[k].copy())

    def obj(z):
        pen, mu = _mg_quality(P, z[None, :2], z[None, 2:], min_transmission, max_link_ratio, envelope)
        return float(pen[0] - 1e-3 * mu[0])

    z0 = np.concatenate([best[1], best[2]])
    res = minimize(obj, z0, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-14, "maxiter": 2000})
    z = res.x if res.fun <= obj(z0) else z0
    mA, mB = z[:2], z[2:]
    (A, _), (Dp, _) = centre_point(P, mA), centre_point(P, mB)
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(Dp))):
        raise ParameterError(f"motion generator: no moving pivot in the search box {np.asarray(box).tolist()} has its "
                             f"three positions on a circle (finite ground pivot): widen search_box or change the poses")
    return mA, A, mB, Dp
