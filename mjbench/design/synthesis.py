"""Kinematic synthesis of planar linkages: closed forms, Freudenstein, three-position motion generation.

Every routine returns a :class:`Synthesis`: the geometry (a :class:`SliderCrank` or a
:class:`FourBar`, each with its own closed-form position analysis), the targets, what the geometry
achieves (computed by that closed-form analysis, not copied from the targets) and the constraints
with a computed pass/fail.  No simulation, no mjbench mechanism: pure NumPy (the conversion to a
``[mechanism] type = "linkage"`` table is :mod:`mjbench.design.build`; the tests solve that table
with mjbench's own position solver and compare).

Conventions: lengths in metres, angles in radians, counter-clockwise positive; the input crank
turns counter-clockwise (q increasing, as mjbench drives it).

* **Slider-crank with offset** from stroke S and time ratio Q (Norton, *Design of Machinery*,
  ch. 3, quick-return mechanisms: Q = (180° + α)/(180° − α); Hartenberg & Denavit, *Kinematic
  Synthesis of Linkages*, 1964): with the two dead-centre distances
  A₁ = l + r, A₂ = l − r, the triangle crank centre / dead-centre slider positions gives
  S² = A₁² + A₂² − 2A₁A₂cos α and A₁A₂ sin α = S·e (twice its area), so for any offset
  0 < e < S/(2 tan(α/2)): A₁ ± A₂ = √(S² + 2A₁A₂(1 ± cos α)).  The offset is chosen to maximise
  the minimum transmission angle μ_min = 90° − asin((r + e)/l) unless given.
* **Crank-rocker** from rocker swing ψ and time ratio Q (the same references: two-position
  synthesis with quick return): the crank pivot A sees the chord C₁C₂ of the rocker's extreme
  positions under the imbalance angle α (inscribed angle), |AC_ext| = a + b, |AC_fold| = b − a;
  the one free parameter (the angle β at C₁ of the triangle AC₁C₂) maximises μ_min.
* **Function generation** (Freudenstein 1955, *Trans. ASME* 77:853): K₁cos φ − K₂cos ψ + cos(φ − ψ)
  = K₃ with K₁ = d/c, K₂ = d/a, K₃ = (a² − b² + c² + d²)/(2ac); three precision points at
  Chebyshev spacing x_j = (x₀ + x₁)/2 − (x₁ − x₀)/2·cos((2j − 1)π/6), or least squares over N
  points; the structural error ψ_generated − ψ_desired is computed by position analysis.
* **Motion generation** through three coupler poses (Sandor & Erdman, *Advanced Mechanism Design*
  vol. 2; Hartenberg & Denavit: circle points / centre points): a moving pivot fixed in the
  coupler is at its three positions on a circle whose centre is the ground pivot (circumcentre);
  with the ground pivot given, the moving pivot is the circumcentre of the ground pivot's three
  positions seen from the coupler (inversion).

Constraints reported for every design: Grashof type and full rotation of the input, branch defect
(precision positions on different assembly branches), order defect (poses not reached in their
order turning the crank forward), minimum transmission angle, link-length ratio, envelope.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError

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


# ============================================================================ geometries
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


# ============================================================================ results
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


# ============================================================================ slider-crank
def slider_crank_from(S, alpha, e):
    """(r, l) of the offset slider-crank with stroke S, imbalance angle α and offset e (closed
    form above); None if e is outside (0, S/(2 tan(α/2)))."""
    if alpha <= 0:
        return None
    P = S * e / math.sin(alpha)
    plus = S * S + 2 * P * (1 + math.cos(alpha))
    minus = S * S - 2 * P * (1 - math.cos(alpha))
    if e <= 0 or minus <= 0:
        return None
    s1, s2 = math.sqrt(plus), math.sqrt(minus)
    return 0.5 * s2, 0.5 * s1  # r = (A₁ − A₂)/2, l = (A₁ + A₂)/2


def slider_crank(stroke, time_ratio_Q, *, offset=None, min_transmission=None, max_link_ratio=None,
                 working_direction=(0.0, -1.0), envelope=None, rod_ratio=None, origin=(0.0, 0.0)) -> Synthesis:
    """Offset slider-crank from the stroke and the time ratio (slow stroke along
    ``working_direction`` with the crank turning counter-clockwise).  Free parameter: the offset
    (given, or the one that maximises the minimum transmission angle).  Q = 1: in-line, the rod
    is ``rod_ratio``·r (default: the shortest rod meeting ``min_transmission``, else 4r)."""
    S, Q = float(stroke), float(time_ratio_Q)
    if not (S > 0 and Q >= 1):
        raise ParameterError(f"slider-crank: need stroke > 0 and time ratio >= 1, got {S!r}, {Q!r}")
    alpha = imbalance_angle(Q)
    info = {"alpha_deg": math.degrees(alpha)}
    if alpha < 1e-12:
        r = 0.5 * S
        if rod_ratio is not None:
            l = rod_ratio * r
        elif min_transmission is not None:
            l = r / math.cos(min_transmission) * (1 + 1e-9)
        else:
            l = 4.0 * r
        e = 0.0
        info["offset_choice"] = "in-line (time ratio 1)"
    else:
        e_max = S / (2 * math.tan(0.5 * alpha))
        info["offset_max_m"] = e_max

        def mu_of(ev):
            rl = slider_crank_from(S, alpha, ev)
            if rl is None:
                return -1.0
            r_, l_ = rl
            return 0.5 * math.pi - math.asin(min(1.0, (r_ + ev) / l_))

        if offset is not None:
            e = float(offset)
            info["offset_choice"] = "given"
            if mu_of(e) < 0:
                raise ParameterError(f"slider-crank: offset = {e:g} m is outside (0, {e_max:.6g}) m for stroke "
                                     f"{S:g} m and time ratio {Q:g}")
        else:
            grid = np.linspace(0.0, e_max, 2001)[1:-1]
            vals = np.array([mu_of(x) for x in grid])
            k = int(np.argmax(vals))
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
            e = _golden(lambda x: -mu_of(x), lo, hi)
            info["offset_choice"] = "maximum of the minimum transmission angle"
        r, l = slider_crank_from(S, alpha, e)
    sc = SliderCrank(np.asarray(origin, float), r, l, e, np.asarray(working_direction, float))
    dc = sc.dead_centres()
    ach = {"stroke_m": dc["stroke"], "time_ratio": dc["arc_along_w"] / dc["arc_against_w"],
           "min_transmission_deg": math.degrees(sc.mu_min()), "r_m": r, "l_m": l, "offset_m": e,
           "q_extended_rad": dc["extended"]["q"], "q_folded_rad": dc["folded"]["q"],
           "u_extended_m": dc["extended"]["u"], "u_folded_m": dc["folded"]["u"]}
    cons = [constraint("stroke", dc["stroke"], S, "min", "m", ok=abs(dc["stroke"] - S) <= 1e-9 * S),
            constraint("time ratio (slow stroke along the working direction)", ach["time_ratio"], Q, "min", "1",
                       ok=abs(ach["time_ratio"] - Q) <= 1e-9 * Q),
            constraint("minimum transmission angle", ach["min_transmission_deg"],
                       None if min_transmission is None else math.degrees(min_transmission), "min", "°"),
            constraint("link-length ratio (rod / crank)", l / r, max_link_ratio, "max", "1")]
    if envelope is not None:
        q = np.linspace(0, TWO_PI, 721)
        s = sc.solve(q)
        w, h = _envelope_of([sc.O, s["B"], s["C"]])
        cons += [constraint("envelope width", w, envelope[0], "max", "m"),
                 constraint("envelope height", h, envelope[1], "max", "m")]
    return Synthesis("slider-crank", sc, {"stroke_m": S, "time_ratio": Q}, ach, cons, info)


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


# ============================================================================ crank-rocker
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
    want = 1 if slow_swing == "ccw" else -1
    best = None

    def evaluate(bv, side):
        cand = _crank_rocker_candidate(psi, alpha, bv, side, 1.0, rocker_mid_angle)
        if cand is None:
            return None
        fb, dc = cand
        slow_dir = dc["direction_ext_to_fold"] if dc["arc_ext_to_fold"] >= dc["arc_fold_to_ext"] else -dc["direction_ext_to_fold"]
        if alpha > 1e-12 and slow_dir != want:
            return None
        return fb

    if alpha > 1e-12:
        grid = np.linspace(0.0, math.pi - alpha, 721)[1:-1]
    else:
        grid = np.geomspace(1e-3, 20.0, 721)
    for side in (1, -1):
        if beta is not None:
            fb = evaluate(float(beta), side)
            if fb is not None and (best is None or fb.mu_min() > best[0]):
                best = (fb.mu_min(), float(beta), side)
            continue
        vals = []
        for bv in grid:
            fb = evaluate(bv, side)
            ok_ratio = fb is not None and (max_link_ratio is None or
                                           max(fb.a, fb.b, fb.c, fb.d) / min(fb.a, fb.b, fb.c, fb.d) <= max_link_ratio)
            vals.append(fb.mu_min() if (fb is not None and ok_ratio) else -1.0)
        vals = np.array(vals)
        if np.max(vals) < 0:  # nothing within the link ratio: keep the best regardless (reported)
            vals = np.array([(evaluate(bv, side).mu_min() if evaluate(bv, side) is not None else -1.0) for bv in grid])
        k = int(np.argmax(vals))
        if vals[k] < 0:
            continue
        lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]

        def neg(bv, side=side):
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
        if best is None or fb.mu_min() > best[0]:
            best = (fb.mu_min(), bv, side)
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


# ============================================================================ function generation
def freudenstein_solve(phi, psi, weights=None):
    """(K₁, K₂, K₃) of K₁cos φ − K₂cos ψ + cos(φ − ψ) = K₃ through the (φ_j, ψ_j): exact for 3
    points, least squares for more.  Batched: phi, psi (..., n)."""
    phi, psi = np.asarray(phi, float), np.asarray(psi, float)
    M = np.stack([np.cos(phi), -np.cos(psi), -np.ones_like(phi)], axis=-1)
    rhs = -np.cos(phi - psi)
    if phi.shape[-1] == 3:
        return np.linalg.solve(M, rhs[..., None])[..., 0]
    if weights is not None:
        w = np.sqrt(np.asarray(weights, float))
        M, rhs = M * w[..., None], rhs * w
    MT = np.swapaxes(M, -1, -2)
    return np.linalg.solve(MT @ M, (MT @ rhs[..., None]))[..., 0]


def lengths_from_K(K, d):
    """Signed (a, b², c) from Freudenstein's K and the ground length d."""
    K = np.asarray(K, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = d / K[..., 0]
        a = d / K[..., 1]
        b2 = a * a + c * c + d * d - 2 * a * c * K[..., 2]
    return a, b2, c


@dataclass
class FunctionSpec:
    """y = f(x) over [x0, x1] generated as ψ = ψ₀ + (y − y₀)·Δψ/(y₁ − y₀) for the input
    φ = φ₀ + (x − x₀)·Δφ/(x₁ − x₀) (angles from the line A→D)."""

    f: object
    x0: float
    x1: float
    dphi: float
    dpsi: float
    text: str = ""

    def __post_init__(self):
        self.y0, self.y1 = float(self.f(np.array([self.x0]))[0]), float(self.f(np.array([self.x1]))[0])
        if not (math.isfinite(self.y0) and math.isfinite(self.y1)) or self.y0 == self.y1:
            raise ParameterError(f"function {self.text or self.f}: f(x0) = {self.y0!r} and f(x1) = {self.y1!r} "
                                 f"must be finite and different")

    def phi(self, x, phi0):
        return phi0 + (np.asarray(x, float) - self.x0) * self.dphi / (self.x1 - self.x0)

    def psi(self, x, psi0):
        y = np.asarray(self.f(np.asarray(x, float)), float)
        return psi0 + (y - self.y0) * self.dpsi / (self.y1 - self.y0)

    def x_of_phi(self, phi, phi0):
        return self.x0 + (np.asarray(phi, float) - phi0) * (self.x1 - self.x0) / self.dphi


def _fg_linkage(K, d, phi_pts, psi_pts):
    """FourBar of Freudenstein's K (A at the origin, D at (d, 0)) with the branch of the first
    precision point, and the branch at every point; None if b² ≤ 0 or a length is infinite."""
    a, b2, c = lengths_from_K(K, d)
    if not (np.isfinite(a) and np.isfinite(c) and b2 > 0 and a != 0 and c != 0):
        return None, None
    b = math.sqrt(b2)
    A, D = np.zeros(2), np.array([d, 0.0])
    Bj = A + a * _u(phi_pts)
    Cj = D + c * _u(psi_pts)
    sig = np.sign(_cross(D - Bj, Cj - Bj)).astype(int)
    fb = FourBar(A, D, abs(a), b, abs(c), int(sig[0]) or 1, crank_offset=(math.pi if a < 0 else 0.0),
                 rocker_offset=(math.pi if c < 0 else 0.0))
    return fb, sig


def structural_error(fb: FourBar, spec: FunctionSpec, phi0, psi0, n=201):
    """ψ generated − ψ desired over [x0, x1] (n points, position analysis on the linkage's branch):
    (x, error [rad], ok)."""
    x = np.linspace(spec.x0, spec.x1, n)
    phi = spec.phi(x, phi0)
    sol = fb.solve(phi + fb.crank_offset)
    psi_gen = sol["theta4"] - fb.rocker_offset
    err = wrap(psi_gen - spec.psi(x, psi0))
    return x, err, bool(np.all(sol["ok"]))


def function_generator(spec: FunctionSpec, *, ground_length=1.0, phi0=None, psi0=None, method="chebyshev",
                       n_points=3, min_transmission=None, max_link_ratio=None, envelope=None,
                       full_rotation=True, crank_rocker=True, max_structural_error=None) -> Synthesis:
    """Freudenstein function generator: three Chebyshev precision points (``method =
    "chebyshev"``) or least squares over ``n_points`` evenly spaced points (``"least-squares"``).
    φ₀/ψ₀ given, or searched (5° grid, then Nelder–Mead) for the smallest structural error among
    the designs that meet the constraints (crank turning fully, no branch defect, transmission
    angle, link ratio; ``crank_rocker``: the crank the shortest link, so that the output oscillates)."""
    d = float(ground_length)
    if method == "chebyshev":
        xs = chebyshev_points(spec.x0, spec.x1, 3)
    elif method == "least-squares":
        if n_points < 4:
            raise ParameterError(f"function generator: least squares needs n_points >= 4, got {n_points}")
        xs = np.linspace(spec.x0, spec.x1, int(n_points))
    else:
        raise ParameterError(f"function generator: method {method!r}: choose chebyshev or least-squares")

    def design(p0, s0):
        ph, ps = spec.phi(xs, p0), spec.psi(xs, s0)
        K = freudenstein_solve(ph, ps)
        fb, sig = _fg_linkage(K, d, ph, ps)
        return fb, sig, K

    def score(p0, s0):
        """(penalty, max |structural error|) of the design at (φ₀, ψ₀)."""
        fb, sig, _ = design(p0, s0)
        if fb is None:
            return 1e9, math.inf
        pen = 0.0
        if np.any(sig != sig[0]):
            pen += 10.0
        if full_rotation and not fb.full_rotation():
            pen += 10.0
        if crank_rocker and fb.a > min(fb.b, fb.c, fb.d):
            pen += 1.0 + fb.a / min(fb.b, fb.c, fb.d) - 1.0
        if min_transmission is not None:
            pen += max(0.0, min_transmission - fb.mu_min())
        if max_link_ratio is not None:
            L = [fb.a, fb.b, fb.c, fb.d]
            pen += max(0.0, max(L) / min(L) / max_link_ratio - 1.0)
        _, err, ok = structural_error(fb, spec, p0, s0, 61)
        if not ok:
            pen += 10.0
        return pen, float(np.max(np.abs(err))) if ok else math.inf

    info = {"method": method, "x_points": xs.tolist()}
    if phi0 is None or psi0 is None:
        g = np.radians(np.arange(0.0, 360.0, 5.0))
        P0 = g if phi0 is None else np.array([phi0])
        S0 = g if psi0 is None else np.array([psi0])
        best = None
        for p0 in P0:
            for s0 in S0:
                pen, e = score(p0, s0)
                key = (pen, e)
                if best is None or key < best[0]:
                    best = (key, p0, s0)
        (_, _), p0, s0 = best
        from scipy.optimize import minimize

        free = [phi0 is None, psi0 is None]

        def obj(z):
            pp = z[0] if free[0] else phi0
            ss = (z[-1] if free[1] else psi0)
            pen, e = score(pp, ss)
            return 100.0 * pen + (e if math.isfinite(e) else 1e3)

        z0 = [v for v, fr in zip((p0, s0), free) if fr]
        res = minimize(obj, z0, method="Nelder-Mead", options={"xatol": 1e-9, "fatol": 1e-12, "maxiter": 400})
        if res.fun <= obj(z0):
            zz = list(res.x)
            p0 = zz.pop(0) if free[0] else phi0
            s0 = zz.pop(0) if free[1] else psi0
        phi0, psi0 = float(p0) % TWO_PI, float(s0) % TWO_PI
        info["start_angles"] = "searched (5° grid + Nelder-Mead): smallest structural error meeting the constraints"
    else:
        info["start_angles"] = "given"
    fb, sig, K = design(phi0, psi0)
    if fb is None:
        raise ParameterError("function generator: Freudenstein's equations give no real linkage (b² ≤ 0) for these "
                             "ranges and start angles")
    x, err, ok = structural_error(fb, spec, phi0, psi0, 401)
    ph, ps = spec.phi(xs, phi0), spec.psi(xs, psi0)
    sol = fb.solve(ph + fb.crank_offset)
    pp_err = wrap(sol["theta4"] - fb.rocker_offset - ps)
    fs = abs(spec.dpsi)
    ach = {"K": [float(k) for k in K], **{k_.split()[1] + "_m": v for k_, v in fb.lengths.items()},
           "phi0_deg": math.degrees(phi0), "psi0_deg": math.degrees(psi0),
           "precision_point_error_rad": float(np.max(np.abs(pp_err))),
           "structural_error_max_deg": float(np.degrees(np.max(np.abs(err)))),
           "structural_error_max_rel": float(np.max(np.abs(err)) / fs),
           "structural_error_rms_deg": float(np.degrees(np.sqrt(np.mean(err ** 2)))),
           "min_transmission_deg": math.degrees(fb.mu_min())}
    info.update(spec=spec, phi_points=ph.tolist(), psi_points=ps.tolist(), branches=sig.tolist(),
                structural_error_curve={"x": x[::8].tolist(), "err_deg": np.degrees(err[::8]).tolist()})
    cons = [constraint("no branch defect (precision points on one assembly branch)", bool(np.all(sig == sig[0])),
                       compare="true", note=f"branches at the precision points: {sig.tolist()}"),
            constraint("positions assemble over the whole range", ok, compare="true")]
    if method == "chebyshev":
        cons.append(constraint("precision points met (closed-form analysis)", ach["precision_point_error_rad"], 1e-9,
                               "max", "rad"))
    cons += _common_constraints(fb, min_transmission, max_link_ratio, envelope)
    if not full_rotation:
        cons[2 + (method == "chebyshev")]["note"] += " (not required)"
        cons[2 + (method == "chebyshev")]["ok"] = True
    if crank_rocker:
        cons.append(constraint("output oscillates (crank-rocker: the crank is the shortest link)",
                               bool(fb.a <= min(fb.b, fb.c, fb.d)), compare="true", note=fb.grashof()["kind"]))
    if max_structural_error is not None:
        cons.append(constraint("structural error (max |ψ − ψ_desired|)", ach["structural_error_max_deg"],
                               math.degrees(max_structural_error), "max", "°"))
    return Synthesis("function-generator", fb,
                     {"function": spec.text, "x_range": [spec.x0, spec.x1], "dphi_deg": math.degrees(spec.dphi),
                      "dpsi_deg": math.degrees(spec.dpsi)}, ach, cons, info)


# ============================================================================ motion generation
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
    return mA, A, mB, Dp
