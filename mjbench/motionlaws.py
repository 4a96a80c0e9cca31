"""Motion laws for point-to-point moves of a servomotor (seeds 001 and 003), vectorised in t.

Every law is a rest-to-rest move of the motor from 0 to ``Phi`` [rad] in ``T`` [s]:
``law.evaluate(t)`` returns ``(position [rad], velocity [rad/s], acceleration [rad/s²],
jerk [rad/s³])`` for an array of times; outside [0, T] the motor is at rest (0 before, Phi after).

* :class:`PseudoPolynomialLaw` — seed 001 Eqs 8-23:
      φ(t) = Φ·[1 − Σ_{i=0..n} C_i·(1 − t/T)^{γ_i}]                              (Eq 17)
  n boundary conditions at both ends (derivatives 1..n vanish at 0 and T, Eqs 11/20); the
  coefficients C_i solve Z̄·c̄ = ū (Eqs 21-23), with Z̄[k, i] = P(γ_i, k) = Π_{r<k}(γ_i − r)
  (Eq 19) built automatically.  Integer exponents give the classical polynomials (3-4-5:
  C = 10, −15, 6, Table II).  The exponents must be distinct (Z̄ singular otherwise) and larger
  than n (else (1 − t/T)^{γ−n} does not vanish at t = T: the seed does not say so, errata 001).
* :class:`BezierLaw` — seed 003 Eqs 10-21: a Bezier curve on equally spaced knots
      φ(t) = Σ_{i=0..n_s} S_i·B(n_s, i, t/T),  B(n, i, λ) = C(n, i)·λ^i·(1 − λ)^{n−i}  (Eqs 17, 11)
  (errata: Eq 11 prints the exponent n − 1), with the first m+1 ordinates 0, the last m+1 equal
  to Φ (continuity up to order m at both ends, Eq 16) and p free interior ordinates:
  n_s = 2m + p + 1.  The derivative polygons are Eq 13 (V_i, A_i of Eqs 18-19); the integral
  polygon is the corrected Eq 14 (:func:`integral_polygon`).  Evaluation uses
  ``scipy.interpolate.BPoly`` (Bernstein basis on [0, T]).

Shape parameters (what an optimiser moves): ``law.params`` and ``law.with_params(x)`` — the
exponents γ for the pseudo-polynomial law, the interior ordinates normalised by Φ for Bezier.

**One formula.**  Each law is evaluated by one scalar *law* (:mod:`mjbench.compiled`):
``MOTION(t, order, P) → (φ, φ̇, φ̈, φ⃛)`` (:func:`pseudopoly_motion`, :func:`bezier_motion`; derivatives
above ``order`` are 0) from coefficient arrays in ``P`` (:meth:`MotionLaw.motion_form`).  The
methods ``evaluate``/``position``/``velocity``/… apply it elementwise to arrays; the servo's
reference (:class:`mjbench.law_reference.LawReference`) calls the same law in the co-step
kernel, compiled or not.  The Bezier curves are evaluated in the Bernstein basis by a Horner
scheme in λ/(1 − λ) (or (1 − λ)/λ past the middle), the derivative curves from the derivative
polygons (Eq 13).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .compiled import law
from .errors import ParameterError
from .law_reference import LawReference
from . import compiled as C

#: two exponents closer than this (relative) make Z̄ numerically singular
GAMMA_TOL = 1e-9


class MotionLaw:
    """Base class: rest-to-rest motor move of ``Phi`` rad in ``T`` s.

    A subclass provides :meth:`motion_form` (its law and coefficients); ``evaluate`` and the
    other methods run that law."""

    kind = "law"

    def __init__(self, Phi: float, T: float):
        Phi, T = float(Phi), float(T)
        if not (math.isfinite(Phi) and Phi != 0.0):
            raise ParameterError(f"law.Phi = {Phi!r}: total motor rotation must be finite and non-zero [rad]")
        if not (math.isfinite(T) and T > 0.0):
            raise ParameterError(f"law.T = {T!r}: motion time must be finite and > 0 [s]")
        self.Phi, self.T = Phi, T

    def motion_form(self):
        """The law's compiled form: ``Form(MOTION, P)`` with ``MOTION(t, order, P) → (φ, φ̇, φ̈, φ⃛)``
        [rad, rad/s, rad/s², rad/s³] at time t [s] (at rest outside [0, T])."""

        if type(self).evaluate is not MotionLaw.evaluate:  # a law with its own Python evaluation
            ev = self.evaluate

            def adapter(t, order, P):
                out = ev(t, order)
                return tuple(float(out[k]) if k <= order else 0.0 for k in range(4))
            return C.python_form(adapter, f"{type(self).__name__} has no motion law (motion_form)")
        raise NotImplementedError(f"{type(self).__name__} defines neither motion_form() nor evaluate()")

    def _motion(self):
        m = self.__dict__.get("_motion_cache")
        if m is None:
            f = self.motion_form()
            m = self.__dict__["_motion_cache"] = (f.bound(), f.P)
        return m

    def evaluate(self, t, order: int = 3):
        """(φ, φ̇, φ̈, φ⃛)[:order+1] at times t [s] (array or scalar); motor at rest outside [0, T]."""
        fn, P = self._motion()
        order = int(order)
        ta = np.asarray(t, dtype=float)
        if ta.ndim == 0:
            out = fn(float(ta), order, P)
            return tuple(float(out[k]) for k in range(order + 1))
        rows = np.array([fn(x, order, P) for x in ta.ravel().tolist()], dtype=float).reshape(-1, 4)
        return tuple(rows[:, k].reshape(ta.shape) for k in range(order + 1))

    __call__ = evaluate

    def position(self, t):
        return self.evaluate(t, 0)[0]

    def velocity(self, t):
        return self.evaluate(t, 1)[1]

    def acceleration(self, t):
        return self.evaluate(t, 2)[2]

    def jerk(self, t):
        return self.evaluate(t, 3)[3]

    def peaks(self, n: int = 4001) -> dict:
        """Peak |velocity| [rad/s], |acceleration| [rad/s²], |jerk| [rad/s³] on a grid of n points."""
        t = np.linspace(0.0, self.T, n)
        _, v, a, j = self.evaluate(t, 3)
        return {"speed": float(np.max(np.abs(v))), "accel": float(np.max(np.abs(a))),
                "jerk": float(np.max(np.abs(j[1:-1])))}

    def as_reference(self, scale: float = 1.0, t0: float = 0.0):
        """A motor-side reference (:class:`mjbench.law_reference.LawReference`) tracking this
        law (times ``scale``), starting at ``t0`` [s]."""
        return LawReference(self, scale, t0)


@law
def _upow(u, e):
    """u^e for u ∈ [0, 1] (u = 0: 0 for e > 0, 1 for e = 0, +inf for e < 0)."""
    if u > 0.0:
        return u ** e
    if e > 0.0:
        return 0.0
    return 1.0 if e == 0.0 else math.inf


#: the pseudo-polynomial law's coefficients: Φ, T, number of terms, exponents γ_i, C_i, and per
#: derivative k = 1..3 the factor (−1)^{k+1}·Φ/T^k and the products P(γ_i, k)·C_i (Eq 18)
PseudoPolyP = namedtuple("PseudoPolyP", "Phi T n g C f1 f2 f3 c1 c2 c3")


@law
def pseudopoly_motion(t, order, P):
    """Seed 001 Eqs 17-18: φ = Φ·[1 − Σ C_i·u^{γ_i}], dᵏφ/dtᵏ = (−1)^{k+1}·Φ/T^k·Σ P(γ_i, k)·C_i·u^{γ_i−k},
    u = 1 − t/T; at rest outside [0, T]; derivatives above ``order`` are 0."""
    if t < 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if t > P.T:
        return P.Phi, 0.0, 0.0, 0.0
    u = 1.0 - t / P.T
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    for i in range(P.n):
        g = P.g[i]
        s0 += P.C[i] * _upow(u, g)
        if order >= 1:
            s1 += P.c1[i] * _upow(u, g - 1.0)
        if order >= 2:
            s2 += P.c2[i] * _upow(u, g - 2.0)
        if order >= 3:
            s3 += P.c3[i] * _upow(u, g - 3.0)
    return P.Phi * (1.0 - s0), P.f1 * s1, P.f2 * s2, P.f3 * s3


@law
def bernstein_sum(c, m, lam):
    """Σ_{i=0..m} c_i·λ^i·(1 − λ)^{m−i} (binomials folded into c) by Horner's scheme in
    x = λ/(1 − λ) for λ ≤ ½, in (1 − λ)/λ above (|x| ≤ 1); 0 for m < 0."""
    if m < 0:
        return 0.0
    if lam <= 0.5:
        x = lam / (1.0 - lam)
        acc = c[m]
        for i in range(m - 1, -1, -1):
            acc = acc * x + c[i]
        return acc * (1.0 - lam) ** float(m)
    x = (1.0 - lam) / lam
    acc = c[0]
    for i in range(1, m + 1):
        acc = acc * x + c[i]
    return acc * lam ** float(m)


#: the Bezier law's coefficients: Φ, T, degree n_s, and the control polygons of φ, φ̇, φ̈, φ⃛
#: (Eq 13 applied k times) times the binomials C(n_s − k, i)
BezierP = namedtuple("BezierP", "Phi T n b0 b1 b2 b3")


@law
def bezier_motion(t, order, P):
    """Seed 003 Eqs 17-21: φ(t) = Σ S_i·B(n_s, i, t/T) and its derivatives from the derivative
    polygons; at rest outside [0, T]; derivatives above ``order`` are 0."""
    if t < 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if t > P.T:
        return P.Phi, 0.0, 0.0, 0.0
    lam = t / P.T
    n = P.n
    p = bernstein_sum(P.b0, n, lam)
    v = bernstein_sum(P.b1, n - 1, lam) if order >= 1 else 0.0
    a = bernstein_sum(P.b2, n - 2, lam) if order >= 2 else 0.0
    j = bernstein_sum(P.b3, n - 3, lam) if order >= 3 else 0.0
    return p, v, a, j


#: a shaped law's impulses (amplitudes A_j, times t_j, count) and its base law's parameters
ShapedP = namedtuple("ShapedP", "A tj n base")


@law
def shaped_motion(BASE, t, order, P):
    """An input-shaped law φ_s(t) = Σ A_j·φ(t − t_j) (and derivatives); BASE the base law."""
    p = 0.0
    v = 0.0
    a = 0.0
    j = 0.0
    for k in range(P.n):
        bp, bv, ba, bj = BASE(t - P.tj[k], order, P.base)
        A = P.A[k]
        p += A * bp
        v += A * bv
        a += A * ba
        j += A * bj
    return p, v, a, j


def shaped_form(base: "MotionLaw", amplitudes, times):
    """``Form(shaped_motion, ShapedP, fn_args=(base law,))`` of an impulse sequence applied to ``base``."""

    bf = base.motion_form()
    A = np.ascontiguousarray(amplitudes, dtype=float)
    tj = np.ascontiguousarray(times, dtype=float)
    return C.Form(shaped_motion, ShapedP(A, tj, int(A.size), bf.P), fn_args=(bf,))


# ====================================================================== pseudo-polynomial laws
def pochhammer_falling(gamma, k: int):
    """P(γ, k) = Π_{r=0}^{k−1} (γ − r) (seed 001 Eq 19), vectorised over γ."""
    g = np.asarray(gamma, dtype=float)
    out = np.ones_like(g)
    for r in range(k):
        out = out * (g - r)
    return out


def boundary_matrix(gammas, n: int | None = None):
    """Z̄ of seed 001 Eq 23: row k holds P(γ_i, k), k = 0..n (n = len(γ) − 1 by default)."""
    g = np.asarray(gammas, dtype=float)
    n = len(g) - 1 if n is None else n
    return np.vstack([pochhammer_falling(g, k) for k in range(n + 1)])


def solve_coefficients(gammas):
    """C_i of seed 001 Eqs 21-22 for exponents γ_0..γ_n (n boundary conditions at each end).

    Raises ParameterError if the exponents are not finite, not distinct, or not > n."""
    g = np.asarray(gammas, dtype=float).ravel()
    if g.size < 2:
        raise ParameterError(f"law.gammas = {g.tolist()}: need at least 2 exponents (n >= 1 boundary condition)")
    if not np.all(np.isfinite(g)):
        raise ParameterError(f"law.gammas = {g.tolist()}: exponents must be finite")
    n = g.size - 1
    small = [(i, float(v)) for i, v in enumerate(g) if v <= n]
    if small:
        raise ParameterError(
            f"law.gammas = {g.tolist()}: with {g.size} exponents the law imposes n = {n} boundary "
            f"conditions, which needs every γ_i > n = {n} (else derivative n of (1 − t/T)^γ does "
            f"not vanish at t = T); too small: " + ", ".join(f"γ_{i} = {v:g}" for i, v in small))
    gs = np.sort(g)
    gap = np.min(np.diff(gs))
    if gap <= GAMMA_TOL * max(1.0, float(np.max(np.abs(g)))):
        i = int(np.argmin(np.diff(gs)))
        raise ParameterError(
            f"law.gammas = {g.tolist()}: exponents must be distinct (γ = {gs[i]:g} and {gs[i+1]:g} "
            f"differ by {gap:.3g}; the matrix Z̄ of seed 001 Eq 23 is singular)")
    Z = boundary_matrix(g)
    u = np.zeros(n + 1)
    u[0] = 1.0
    return np.linalg.solve(Z, u)


def coefficients_three(g0, g1, g2):
    """Closed-form C_0, C_1, C_2 of seed 001 Eq 16 (three exponents, n = 2)."""
    return (g1 * g2 / ((g2 - g0) * (g1 - g0)), g0 * g2 / ((g1 - g0) * (g1 - g2)),
            g0 * g1 / ((g0 - g2) * (g1 - g2)))


class PseudoPolynomialLaw(MotionLaw):
    """Seed 001 Eq 17: φ(t) = Φ·[1 − Σ C_i·(1 − t/T)^{γ_i}] with n = len(γ) − 1 boundary conditions."""

    kind = "pseudopoly"

    def __init__(self, Phi: float, T: float, gammas=(3.0, 4.0, 5.0)):
        super().__init__(Phi, T)
        self.gammas = np.asarray(gammas, dtype=float).ravel().copy()
        self.C = solve_coefficients(self.gammas)
        self.n = self.gammas.size - 1

    @property
    def params(self):
        return self.gammas.copy()

    def with_params(self, x):
        return PseudoPolynomialLaw(self.Phi, self.T, x)

    def motion_form(self):

        g, Cc, Phi, T = self.gammas, self.C, self.Phi, self.T
        f = [(-1.0) ** (k + 1) * Phi / T ** k for k in (1, 2, 3)]
        c = [np.ascontiguousarray(pochhammer_falling(g, k) * Cc) for k in (1, 2, 3)]
        return C.Form(pseudopoly_motion, PseudoPolyP(Phi, T, int(g.size), np.ascontiguousarray(g),
                                                     np.ascontiguousarray(Cc), *f, *c))

    def accel_terms(self):
        """φ̈(t) = Σ a_i·u^{e_i}, u = 1 − t/T: returns (a_i [rad/s²], e_i) (Eq 10)."""
        a = -self.Phi / self.T ** 2 * pochhammer_falling(self.gammas, 2) * self.C
        return a, self.gammas - 2.0

    def describe(self):
        return {"kind": self.kind, "Phi": self.Phi, "T": self.T, "gammas": self.gammas.tolist(),
                "C": self.C.tolist()}


# ====================================================================== Bezier laws
def bernstein(n: int, i: int, lam):
    """B(n, i, λ) = C(n, i)·λ^i·(1 − λ)^{n−i} (seed 003 Eq 11, corrected exponent n − i)."""
    lam = np.asarray(lam, dtype=float)
    from scipy.special import comb

    return comb(n, i) * lam ** i * (1.0 - lam) ** (n - i)


def derivative_polygon(y, x0: float, xn: float):
    """Ordinates of the derivative polygon (seed 003 Eq 13): y*_i = n/(x_n − x_0)·(y_{i+1} − y_i)."""
    y = np.asarray(y, dtype=float)
    n = y.size - 1
    return n / (xn - x0) * np.diff(y)


def integral_polygon(y, x0: float, xn: float, y0: float = 0.0):
    """Ordinates of the integral polygon (n+2 knots) of a Bezier curve with n+1 equally spaced
    knots (seed 003 Eq 14, corrected — errata): ỹ_0 = y0 (the integration constant),
    ỹ_i = ỹ_{i−1} + (x_n − x_0)/(n+1)·y_{i−1}, i = 1..n+1."""
    y = np.asarray(y, dtype=float)
    n = y.size - 1
    return y0 + np.concatenate([[0.0], np.cumsum(y) * (xn - x0) / (n + 1)])


def bezier_integral(y, x0: float, xn: float) -> float:
    """Definite integral over [x_0, x_n] (seed 003 Eq 15) = (x_n − x_0)/(n+1)·Σ y_i."""
    y = np.asarray(y, dtype=float)
    return float((xn - x0) / y.size * np.sum(y))


class BezierLaw(MotionLaw):
    """Seed 003: Bezier displacement law with continuity order m and p free interior ordinates.

    ``interior``: the p interior ordinates S_{m+1}..S_{m+p} [rad]; default: on the straight line
    from P_m = (t_m, 0) to P_{m+p+1} = (t_{m+p+1}, Φ) (the "linear polygon")."""

    kind = "bezier"

    def __init__(self, Phi: float, T: float, m: int = 2, p: int = 3, interior=None):
        super().__init__(Phi, T)
        if int(m) != m or m < 0:
            raise ParameterError(f"law.m = {m!r}: continuity order must be an integer >= 0")
        if int(p) != p or p < 0:
            raise ParameterError(f"law.p = {p!r}: number of interior points must be an integer >= 0")
        self.m, self.p = int(m), int(p)
        if interior is None:
            interior = self.Phi * linear_interior(self.p)
        interior = np.asarray(interior, dtype=float).ravel()
        if interior.size != self.p:
            raise ParameterError(f"law.interior has {interior.size} values; p = {self.p} interior ordinates expected")
        if not np.all(np.isfinite(interior)):
            raise ParameterError(f"law.interior = {interior.tolist()}: ordinates must be finite")
        self.interior = interior.copy()
        self.n_s = 2 * self.m + self.p + 1
        self.S = np.concatenate([np.zeros(self.m + 1), self.interior, np.full(self.m + 1, self.Phi)])

    @property
    def params(self):
        return self.interior / self.Phi

    def with_params(self, x):
        return BezierLaw(self.Phi, self.T, self.m, self.p, np.asarray(x, dtype=float) * self.Phi)

    def polygons(self):
        """Control-polygon ordinates (S, V, A, jerk) of Eqs 17-21 (V, A by Eqs 18-19)."""
        S = self.S
        V = derivative_polygon(S, 0.0, self.T)
        A = derivative_polygon(V, 0.0, self.T)
        Jk = derivative_polygon(A, 0.0, self.T)
        return S, V, A, Jk

    def knots(self, k: int = 0):
        """Abscissas [s] of the (n_s + 1 − k) equally spaced knots of polygon k."""
        return np.linspace(0.0, self.T, self.n_s + 1 - k)

    def motion_form(self):
        from scipy.special import comb

        n = self.n_s
        polys = self.polygons()
        b = []
        for k, y in enumerate(polys):  # Eq 13 applied k times; binomials of degree n − k folded in
            b.append(np.ascontiguousarray(y * comb(n - k, np.arange(y.size)) if y.size else np.zeros(1)))
        return C.Form(bezier_motion, BezierP(self.Phi, self.T, int(n), *b))

    def accel_bpoly(self):
        """The acceleration curve as a ``scipy.interpolate.BPoly`` (its derivatives at the ends:
        the analytic residual-vibration integral of :mod:`mjbench.vibration`)."""
        from scipy.interpolate import BPoly

        return BPoly(self.polygons()[2][:, None], [0.0, self.T])

    def describe(self):
        return {"kind": self.kind, "Phi": self.Phi, "T": self.T, "m": self.m, "p": self.p,
                "interior": self.interior.tolist(), "interior_over_Phi": self.params.tolist()}


# ====================================================================== cycloidal law
#: the cycloidal law's parameters: Φ, T
CycloidalP = namedtuple("CycloidalP", "Phi T")


@law
def cycloidal_motion(t, order, P):
    """The cycloidal rest-to-rest law: φ = Φ·(τ − sin(2πτ)/2π), τ = t/T, and its derivatives
    φ̇ = Φ/T·(1 − cos 2πτ), φ̈ = 2πΦ/T²·sin 2πτ, φ⃛ = 4π²Φ/T³·cos 2πτ; at rest outside [0, T];
    derivatives above ``order`` are 0.  Velocity and acceleration vanish at both ends (the jerk does
    not: Φ·4π²/T³ there)."""
    if t < 0.0:
        return 0.0, 0.0, 0.0, 0.0
    if t > P.T:
        return P.Phi, 0.0, 0.0, 0.0
    w = 2.0 * math.pi / P.T
    tau = t / P.T
    s = math.sin(w * t)
    c = math.cos(w * t)
    p = P.Phi * (tau - s / (2.0 * math.pi))
    v = P.Phi / P.T * (1.0 - c) if order >= 1 else 0.0
    a = P.Phi / P.T * w * s if order >= 2 else 0.0
    j = P.Phi / P.T * w * w * c if order >= 3 else 0.0
    return p, v, a, j


class CycloidalLaw(MotionLaw):
    """The cycloidal law (a cam designer's classic, e.g. Norton, *Cam Design and Manufacturing
    Handbook*, ch. 3): the displacement of a point on a circle of circumference Φ rolling along the
    move, φ = Φ·(t/T − sin(2πt/T)/2π); zero speed and acceleration at both ends."""

    kind = "cycloidal"

    @property
    def params(self):
        return np.zeros(0)

    def with_params(self, x):
        return CycloidalLaw(self.Phi, self.T)

    def motion_form(self):
        return C.Form(cycloidal_motion, CycloidalP(self.Phi, self.T))

    def describe(self):
        return {"kind": self.kind, "Phi": self.Phi, "T": self.T}


def linear_interior(p: int):
    """Interior ordinates / Φ on the straight line from P_m (0) to P_{m+p+1} (Φ): j/(p+1)."""
    return np.arange(1, p + 1) / (p + 1.0)


def make_law(params: dict) -> MotionLaw:
    """Scenario ``[law]`` table → law.  kind = "pseudopoly" (gammas) | "bezier" (m, p, interior
    [rad] or interior_over_Phi); Phi [rad] or revolutions; T [s]."""
    p = {k: v for k, v in params.items() if not k.startswith("_")}
    kind = p.pop("kind", "pseudopoly")
    if "revolutions" in p:
        Phi = 2.0 * math.pi * float(p.pop("revolutions"))
        p.pop("Phi", None)
    elif "Phi" in p:
        Phi = float(p.pop("Phi"))
    else:
        raise ParameterError("law.Phi [rad] or law.revolutions is required")
    if "T" not in p:
        raise ParameterError("law.T [s] (motion time) is required")
    T = float(p.pop("T"))
    if kind == "pseudopoly":
        law = PseudoPolynomialLaw(Phi, T, p.pop("gammas", (3.0, 4.0, 5.0)))
    elif kind == "bezier":
        interior = p.pop("interior", None)
        rel = p.pop("interior_over_Phi", None)
        if interior is None and rel is not None:
            interior = np.asarray(rel, dtype=float) * Phi
        law = BezierLaw(Phi, T, int(p.pop("m", 2)), int(p.pop("p", 3)), interior)
    else:
        raise ParameterError(f"law.kind = {kind!r}: choose 'pseudopoly' or 'bezier'")
    if p:
        raise ParameterError(f"unknown [law] parameters: {sorted(p)}")
    return law
