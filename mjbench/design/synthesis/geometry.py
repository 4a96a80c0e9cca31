"""The synthesised geometries with their own closed-form position analysis: :class:`FourBar`
(Grashof type, dead centres, transmission angle) and :class:`SliderCrank`; the constraints every
four-bar design reports."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .common import CHANGE_POINT, TOL, TWO_PI, _ang, _cross, _envelope_of, _u, constraint, fold, wrap


@dataclass
class FourBar:
    """Four-bar A–B–C–D: crank AB = a about the ground pivot A (the input), coupler BC = b,
    rocker DC = c about the ground pivot D; branch ``sigma`` = sign of (D − B) × (C − B).
    ``P``: a coupler point in the coupler frame (origin B, x along B→C).  ``crank_offset``,
    ``rocker_offset``: the angles added to the crank and rocker link angles to give the angles a
    synthesis uses (π when Freudenstein returned a negative length)."""

    A: np.ndarray
    D: np.ndarray
    a: float
    b: float
    c: float
    sigma: int = 1
    P: tuple | None = None
    crank_offset: float = 0.0
    rocker_offset: float = 0.0

    def __post_init__(self):
        self.A = np.asarray(self.A, float)
        self.D = np.asarray(self.D, float)

    @property
    def d(self) -> float:
        return float(np.hypot(*(self.D - self.A)))

    @property
    def lengths(self) -> dict:
        return {"crank a": self.a, "coupler b": self.b, "rocker c": self.c, "ground d": self.d}

    def solve(self, q):
        """Closed-form position at crank angles q (the crank link's angle): B, C, P (world),
        θ₃ (coupler), θ₄ (rocker), the transmission angle μ (unfolded) and ``ok`` (assemblable)."""
        q = np.asarray(q, float)
        B = self.A + self.a * _u(q)
        Dl = self.D - B
        e = np.hypot(Dl[..., 0], Dl[..., 1])
        cg = (self.b ** 2 + e ** 2 - self.c ** 2) / (2 * self.b * e)
        ok = np.abs(cg) <= 1 + 1e-12
        g = np.arccos(np.clip(cg, -1.0, 1.0))
        th3 = _ang(Dl) + self.sigma * g
        C = B + self.b * _u(th3)
        th4 = _ang(C - self.D)
        cm = (self.b ** 2 + self.c ** 2 - e ** 2) / (2 * self.b * self.c)
        mu = np.arccos(np.clip(cm, -1.0, 1.0))
        out = {"B": B, "C": C, "theta3": th3, "theta4": th4, "mu": mu, "ok": ok}
        if self.P is not None:
            out["P"] = B + self.P[0] * _u(th3) + self.P[1] * _u(th3 + 0.5 * np.pi)
        return out

    def full_rotation(self) -> bool:
        """The crank turns fully: |BD| ∈ [|d − a|, d + a] stays strictly within [|b − c|, b + c]
        (a change-point linkage, s + l = p + q, touches a bound: it passes a singular position where
        the branch can switch, so it does not count)."""
        d, a, b, c = self.d, self.a, self.b, self.c
        s = max(a, b, c, d)
        return bool(d + a < b + c - CHANGE_POINT * s and abs(d - a) > abs(b - c) + CHANGE_POINT * s)

    def grashof(self) -> dict:
        """Grashof class (s + l vs p + q) and the kind of motion of the input."""
        L = {"a": self.a, "b": self.b, "c": self.c, "d": self.d}
        v = sorted(L.values())
        s, l_, p, q = v[0], v[3], v[1], v[2]
        shortest = min(L, key=L.get)
        grashof = s + l_ <= p + q + TOL * l_
        kind = ("crank-rocker" if shortest == "a" else "double-crank (drag link)" if shortest == "d"
                else "double-rocker" if shortest == "b" else "rocker-crank") if grashof else "non-Grashof triple-rocker"
        return {"grashof": bool(grashof), "s_plus_l": s + l_, "p_plus_q": p + q, "kind": kind}

    def mu_min(self) -> float:
        """Minimum transmission angle over a full crank turn (folded), at |BD| = d ± a (closed form);
        0 if the crank cannot turn fully."""
        if not self.full_rotation():
            return 0.0
        b, c = self.b, self.c
        vals = []
        for e in (abs(self.d - self.a), self.d + self.a):
            vals.append(float(fold(np.arccos(np.clip((b * b + c * c - e * e) / (2 * b * c), -1, 1)))))
        return min(vals)

    def dead_centres(self) -> dict:
        """Crank-rocker dead centres (the rocker stops): extended (|AC| = a + b) and folded
        (|AC| = b − a) on this branch: crank angles, rocker angles; the two crank arcs and the
        rocker's direction on the arc from extended to folded (+1 CCW)."""
        out = {}
        for kind, R in (("extended", self.a + self.b), ("folded", self.b - self.a)):
            C = _circle_circle(self.A, R, self.D, self.c)
            if C is None:
                return {}
            best = None
            for Ck in C:
                v = Ck - self.A
                uh = v / np.hypot(*v)
                B = self.A + (self.a if kind == "extended" else -self.a) * uh
                s = np.sign(_cross(self.D - B, Ck - B))
                if s == self.sigma:
                    best = (Ck, B)
            if best is None:
                return {}
            Ck, B = best
            out[kind] = {"q": float(_ang(B - self.A) % TWO_PI), "psi": float(_ang(Ck - self.D)), "C": Ck}
        arc = (out["folded"]["q"] - out["extended"]["q"]) % TWO_PI
        mid = out["extended"]["q"] + 0.5 * arc
        h = 1e-6
        sol = self.solve(np.array([mid - h, mid + h]))
        dpsi = wrap(sol["theta4"][1] - sol["theta4"][0])
        out["arc_ext_to_fold"] = float(arc)
        out["arc_fold_to_ext"] = float(TWO_PI - arc)
        out["direction_ext_to_fold"] = int(np.sign(dpsi))
        out["swing"] = float(abs(wrap(out["folded"]["psi"] - out["extended"]["psi"])))
        return out


def _circle_circle(P0, r0, P1, r1):
    """The two intersections of circles (P0, r0), (P1, r1), or None."""
    d = P1 - P0
    L = float(np.hypot(*d))
    if L == 0 or L > r0 + r1 + 1e-12 * (r0 + r1) or L < abs(r0 - r1) - 1e-12 * (r0 + r1):
        return None
    x = (r0 * r0 - r1 * r1 + L * L) / (2 * L)
    h = math.sqrt(max(0.0, r0 * r0 - x * x))
    e = d / L
    n = np.array([-e[1], e[0]])
    return [P0 + x * e + h * n, P0 + x * e - h * n]


@dataclass
class SliderCrank:
    """Offset slider-crank: crank r about O, rod l, slider pin C on the line parallel to the working
    direction ``w`` at signed offset e (the line passes at −e along n = w rotated +90° from O).
    With e > 0 and the crank turning counter-clockwise, the stroke along +w is the slow one."""

    O: np.ndarray
    r: float
    l: float
    e: float
    w: np.ndarray = field(default_factory=lambda: np.array([0.0, -1.0]))

    def __post_init__(self):
        self.O = np.asarray(self.O, float)
        w = np.asarray(self.w, float)
        self.w = w / np.hypot(*w)

    @property
    def n(self):
        return np.array([-self.w[1], self.w[0]])

    @property
    def w_angle(self) -> float:
        return float(math.atan2(self.w[1], self.w[0]))

    @property
    def lengths(self) -> dict:
        return {"crank r": self.r, "rod l": self.l, "offset e": self.e}

    def solve(self, q):
        """Closed form at crank angles q (world): B, C (world), u = the slider coordinate along w
        from O, the rod angle to the slide line β and μ = 90° − |β|."""
        q = np.asarray(q, float)
        th = q - self.w_angle  # canonical crank angle (x along w)
        y = self.r * np.sin(th) + self.e
        ok = np.abs(y) <= self.l * (1 + 1e-12)
        x = self.r * np.cos(th) + np.sqrt(np.clip(self.l ** 2 - y ** 2, 0.0, None))
        B = self.O + self.r * _u(q)
        C = self.O + x[..., None] * self.w - self.e * self.n
        beta = np.arcsin(np.clip(y / self.l, -1, 1))
        return {"B": B, "C": C, "u": x, "beta": beta, "mu": 0.5 * np.pi - np.abs(beta), "ok": ok}

    def dead_centres(self) -> dict:
        """Extended (far, u₁ = √((l + r)² − e²)) and folded (near, u₂ = √((l − r)² − e²)) dead
        centres: crank angles (world) and slider coordinates; the stroke, imbalance angle α and
        the crank arc of the stroke along +w."""
        r, l, e = self.r, self.l, self.e
        if not (l > r and abs(e) < l - r):
            return {}
        u1 = math.sqrt((l + r) ** 2 - e * e)
        u2 = math.sqrt((l - r) ** 2 - e * e)
        th1 = -math.asin(e / (l + r))
        th2 = math.pi - math.asin(e / (l - r))
        q1 = (th1 + self.w_angle) % TWO_PI
        q2 = (th2 + self.w_angle) % TWO_PI
        return {"extended": {"q": q1, "u": u1}, "folded": {"q": q2, "u": u2}, "stroke": u1 - u2,
                "alpha": math.asin(e / (l - r)) - math.asin(e / (l + r)),
                "arc_along_w": (q1 - q2) % TWO_PI, "arc_against_w": (q2 - q1) % TWO_PI}

    def mu_min(self) -> float:
        """90° − asin((r + |e|)/l): the rod's largest angle to the slide line."""
        return 0.5 * math.pi - math.asin(min(1.0, (self.r + abs(self.e)) / self.l))


def fourbar_envelope(fb: FourBar, n=721) -> tuple:
    q = np.linspace(0.0, TWO_PI, n)
    s = fb.solve(q)
    pts = [fb.A, fb.D, s["B"], s["C"]] + ([s["P"]] if "P" in s else [])
    return _envelope_of(pts)


def _common_constraints(fb: FourBar, min_transmission, max_link_ratio, envelope) -> list:
    g = fb.grashof()
    out = [constraint("input crank turns fully (Grashof crank-rocker or drag link)", fb.full_rotation(),
                      compare="true", note=f"{g['kind']}: s + l = {g['s_plus_l']:.6g} m vs p + q = {g['p_plus_q']:.6g} m")]
    mu = math.degrees(fb.mu_min())
    out.append(constraint("minimum transmission angle", mu, None if min_transmission is None else
                          math.degrees(min_transmission), "min", "°"))
    L = [fb.a, fb.b, fb.c, fb.d]
    ratio = max(L) / min(L)
    out.append(constraint("link-length ratio (longest / shortest)", ratio, max_link_ratio, "max", "1"))
    if envelope is not None:
        w, h = fourbar_envelope(fb) if fb.full_rotation() else (math.inf, math.inf)
        out.append(constraint("envelope width", w, envelope[0], "max", "m"))
        out.append(constraint("envelope height", h, envelope[1], "max", "m"))
    return out
