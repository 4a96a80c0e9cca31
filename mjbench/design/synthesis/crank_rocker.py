"""Crank-rocker from the rocker swing ψ and the time ratio Q (two-position synthesis with quick
return; the free angle β maximising the minimum transmission angle)."""
from __future__ import annotations

import math

import numpy as np

from ...errors import ParameterError
from .common import TWO_PI, Synthesis, _cross, _golden, _u, constraint, imbalance_angle
from .geometry import FourBar, _common_constraints


def _crank_rocker_candidate(psi, alpha, beta, side, c=1.0, mid=0.5 * math.pi):
    """The crank-rocker of the construction for the angle β at C₁ and the side of the chord on
    which A lies (rocker pivot D at the origin, rocker c); None if invalid."""
    D = np.zeros(2)
    C1, C2 = c * _u(mid - 0.5 * psi), c * _u(mid + 0.5 * psi)
    L = float(np.hypot(*(C2 - C1)))
    t = (C2 - C1) / L
    if alpha > 1e-12:
        AC1 = L * math.sin(alpha + beta) / math.sin(alpha)
        AC2 = L * math.sin(beta) / math.sin(alpha)
        ang = side * beta
        d1 = np.array([t[0] * math.cos(ang) - t[1] * math.sin(ang), t[0] * math.sin(ang) + t[1] * math.cos(ang)])
        A = C1 + AC1 * d1
    else:  # Q = 1: A on the chord's line beyond one end; beta is then the distance beyond it
        if side > 0:
            A = C2 + beta * t
        else:
            A = C1 - beta * t
        AC1, AC2 = float(np.hypot(*(A - C1))), float(np.hypot(*(A - C2)))
    if abs(AC1 - AC2) < 1e-12 * L:
        return None
    ext_is_1 = AC1 > AC2
    a = 0.5 * abs(AC1 - AC2)
    b = 0.5 * (AC1 + AC2)
    Cext = C1 if ext_is_1 else C2
    Bext = A + a * (Cext - A) / np.hypot(*(Cext - A))
    sigma = int(np.sign(_cross(D - Bext, Cext - Bext)))
    if sigma == 0:
        return None
    fb = FourBar(A, D, a, b, c, sigma)
    dc = fb.dead_centres()
    if not dc or not fb.full_rotation():
        return None
    if abs(dc["swing"] - psi) > 1e-8:  # the construction's extremes are not this branch's
        return None
    return fb, dc


def crank_rocker(swing, time_ratio_Q, *, rocker_length=None, ground_length=None, min_transmission=None,
                 max_link_ratio=None, slow_swing="ccw", rocker_mid_angle=0.5 * math.pi, envelope=None,
                 beta=None) -> Synthesis:
    """Crank-rocker from the rocker swing ψ and the time ratio Q (slow stroke: the rocker turning
    ``slow_swing`` = "ccw" | "cw" while the crank turns counter-clockwise).  Scale: the rocker
    length or the ground length.  Free parameter β (given, or the value maximising the minimum
    transmission angle).  Crank pivot A at the origin."""
    psi, Q = float(swing), float(time_ratio_Q)
    if not (0 < psi < math.pi and Q >= 1):
        raise ParameterError(f"crank-rocker: need 0 < swing < 180° and time ratio >= 1, got {math.degrees(psi):g}°, {Q!r}")
    if (rocker_length is None) == (ground_length is None):
        raise ParameterError("crank-rocker: give exactly one of rocker_length, ground_length")
    alpha = imbalance_angle(Q)
    evaluate = _crank_rocker_family(psi, alpha, 1 if slow_swing == "ccw" else -1, rocker_mid_angle)
    best = _best_beta(evaluate, alpha, beta, max_link_ratio)
    if best is None:
        raise ParameterError(f"crank-rocker: no crank-rocker gives a {math.degrees(psi):g}° swing with time ratio "
                             f"{Q:g} turning the rocker {slow_swing} on the slow stroke")
    _, bv, side = best
    fb = evaluate(bv, side)
    k = (rocker_length / fb.c) if rocker_length is not None else (ground_length / fb.d)
    A0 = fb.A.copy()
    fb = FourBar((fb.A - A0) * k, (fb.D - A0) * k, fb.a * k, fb.b * k, fb.c * k, fb.sigma)
    dc = fb.dead_centres()
    slow = max(dc["arc_ext_to_fold"], dc["arc_fold_to_ext"])
    ach = {"swing_deg": math.degrees(dc["swing"]), "time_ratio": slow / (TWO_PI - slow),
           "min_transmission_deg": math.degrees(fb.mu_min()), **{k_.split()[1] + "_m": v for k_, v in fb.lengths.items()},
           "q_extended_rad": dc["extended"]["q"], "q_folded_rad": dc["folded"]["q"],
           "psi_extended_rad": dc["extended"]["psi"], "psi_folded_rad": dc["folded"]["psi"]}
    cons = [constraint("rocker swing", ach["swing_deg"], math.degrees(psi), "min", "°",
                       ok=abs(dc["swing"] - psi) <= 1e-9),
            constraint("time ratio", ach["time_ratio"], Q, "min", "1", ok=abs(ach["time_ratio"] - Q) <= 1e-9 * Q)]
    cons += _common_constraints(fb, min_transmission, max_link_ratio, envelope)
    return Synthesis("crank-rocker", fb, {"swing_deg": math.degrees(psi), "time_ratio": Q}, ach, cons,
                     {"alpha_deg": math.degrees(alpha), "beta": bv, "side": side, "slow_swing": slow_swing})


def _crank_rocker_family(psi, alpha, want, mid):
    """``evaluate(β, side)``: the unit-rocker crank-rocker of the construction (its rocker turning
    ``want`` = +1 ccw / −1 cw on the slow stroke), or None."""
    def evaluate(bv, side):
        cand = _crank_rocker_candidate(psi, alpha, bv, side, 1.0, mid)
        if cand is None:
            return None
        fb, dc = cand
        slow_dir = dc["direction_ext_to_fold"] if dc["arc_ext_to_fold"] >= dc["arc_fold_to_ext"] else -dc["direction_ext_to_fold"]
        if alpha > 1e-12 and slow_dir != want:
            return None
        return fb
    return evaluate


def _best_beta(evaluate, alpha, beta, max_link_ratio):
    """(μ_min, β, side) of the best crank-rocker over both sides of the chord: β given, or the grid
    maximum (within the link ratio when any is) refined by golden section; None if none exists."""
    if alpha > 1e-12:
        grid = np.linspace(0.0, math.pi - alpha, 721)[1:-1]
    else:
        grid = np.geomspace(1e-3, 20.0, 721)
    best = None
    for side in (1, -1):
        if beta is not None:
            fb = evaluate(float(beta), side)
            if fb is not None and (best is None or fb.mu_min() > best[0]):
                best = (fb.mu_min(), float(beta), side)
            continue
        found = _best_beta_on_side(evaluate, grid, side, max_link_ratio)
        if found is not None and (best is None or found[0] > best[0]):
            best = found
    return best


def _best_beta_on_side(evaluate, grid, side, max_link_ratio):
    """(μ_min, β, side) maximising the minimum transmission angle on one side, or None."""
    def ratio_ok(fb):
        return max_link_ratio is None or max(fb.a, fb.b, fb.c, fb.d) / min(fb.a, fb.b, fb.c, fb.d) <= max_link_ratio

    vals = []
    for bv in grid:
        fb = evaluate(bv, side)
        vals.append(fb.mu_min() if (fb is not None and ratio_ok(fb)) else -1.0)
    vals = np.array(vals)
    if np.max(vals) < 0:  # nothing within the link ratio: keep the best regardless (reported)
        vals = np.array([(evaluate(bv, side).mu_min() if evaluate(bv, side) is not None else -1.0) for bv in grid])
    k = int(np.argmax(vals))
    if vals[k] < 0:
        return None
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]

    def neg(bv):
        fb = evaluate(bv, side)
        if fb is None:
            return 1.0
        if max_link_ratio is not None and max(fb.a, fb.b, fb.c, fb.d) / min(fb.a, fb.b, fb.c, fb.d) > max_link_ratio and vals[k] >= 0:
            return 1.0 - 1e-9 * fb.mu_min()
        return -fb.mu_min()

    bv = _golden(neg, lo, hi)
    fb = evaluate(bv, side)
    if fb is None or neg(bv) > neg(grid[k]):
        bv, fb = float(grid[k]), evaluate(float(grid[k]), side)
    return fb.mu_min(), bv, side
