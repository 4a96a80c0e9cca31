"""Shared parts of the synthesis routines: constants, angle helpers, constraint rows, the result
(:class:`Synthesis`) and a golden-section search."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

TWO_PI = 2.0 * math.pi
#: numerical slack of the closed-form feasibility tests [relative]
TOL = 1e-12
#: |BD| closer than this (relative to the longest link) to a bound of [|b − c|, b + c]: a change point
CHANGE_POINT = 1e-6


# ============================================================================ helpers
def imbalance_angle(Q: float) -> float:
    """α of the time ratio Q = (π + α)/(π − α) [rad] (Norton, Design of Machinery, ch. 3)."""
    return math.pi * (Q - 1.0) / (Q + 1.0)


def time_ratio(alpha: float) -> float:
    """Q = (π + α)/(π − α)."""
    return (math.pi + alpha) / (math.pi - alpha)


def chebyshev_points(x0: float, x1: float, n: int) -> np.ndarray:
    """Chebyshev spacing of n precision points over [x0, x1] (Freudenstein 1955):
    x_j = (x0 + x1)/2 − (x1 − x0)/2·cos((2j − 1)π/(2n)), j = 1..n."""
    j = np.arange(1, n + 1)
    return 0.5 * (x0 + x1) - 0.5 * (x1 - x0) * np.cos((2 * j - 1) * np.pi / (2 * n))


def _u(th):
    th = np.asarray(th, float)
    return np.stack([np.cos(th), np.sin(th)], axis=-1)


def _cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def _ang(v):
    return np.arctan2(v[..., 1], v[..., 0])


def wrap(x):
    """Angle(s) to (−π, π]."""
    return -((-np.asarray(x, float) + np.pi) % TWO_PI - np.pi)


def fold(mu):
    """Transmission angle folded to [0, π/2] (mjbench.analyze's convention: the angle between
    the two link lines, whichever is acute)."""
    mu = np.asarray(mu, float)
    return np.minimum(mu, np.pi - mu)


def circumcentre(p1, p2, p3):
    """Centre of the circle through three points (arrays (..., 2)); NaN where collinear."""
    p1, p2, p3 = (np.asarray(p, float) for p in (p1, p2, p3))
    a, b = p2 - p1, p3 - p1
    det = 2.0 * _cross(a, b)
    aa, bb = np.sum(a * a, -1), np.sum(b * b, -1)
    scale = np.maximum(aa, bb)
    bad = np.abs(det) <= 1e-12 * np.where(scale > 0, scale, 1.0)
    det = np.where(bad, np.nan, det)
    x = (b[..., 1] * aa - a[..., 1] * bb) / det
    y = (a[..., 0] * bb - b[..., 0] * aa) / det
    return p1 + np.stack([x, y], axis=-1)


def constraint(name, value, limit=None, compare="min", unit="", ok=None, note=""):
    """One reported constraint: the value, its limit (``compare``: "min" = value ≥ limit, "max" =
    value ≤ limit, "true" = a condition) and the computed pass/fail."""
    if ok is None:
        if compare == "true":
            ok = bool(value)
        elif limit is None:
            ok = True
        elif compare == "min":
            ok = bool(value >= limit * (1 - 1e-12) - 1e-15)
        elif compare == "max":
            ok = bool(value <= limit * (1 + 1e-12) + 1e-15)
        else:
            ok = bool(value)
    return {"name": name, "value": value, "limit": limit, "compare": compare, "unit": unit, "ok": bool(ok),
            "note": note}


@dataclass
class Synthesis:
    """A synthesised linkage: ``kind``, its geometry, targets, achieved values (closed-form
    analysis of the geometry) and constraints (each with a computed ``ok``)."""

    kind: str
    geometry: object
    targets: dict
    achieved: dict
    constraints: list
    info: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return all(c["ok"] for c in self.constraints)

    def failures(self) -> list:
        return [c for c in self.constraints if not c["ok"]]


def _envelope_of(points: list) -> tuple:
    """(width, height) of the bounding box of point arrays (N, 2)."""
    P = np.vstack([np.atleast_2d(p) for p in points])
    P = P[np.all(np.isfinite(P), axis=1)]
    return float(np.ptp(P[:, 0])), float(np.ptp(P[:, 1]))


def _golden(f, lo, hi, tol=1e-13, maxit=200):
    """Minimum of a unimodal f on [lo, hi] (golden-section search)."""
    g = (math.sqrt(5) - 1) / 2
    a, b = lo, hi
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(maxit):
        if abs(b - a) <= tol * max(1.0, abs(a) + abs(b)):
            break
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(d)
    return 0.5 * (a + b)
