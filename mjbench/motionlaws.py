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
"""
from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import BPoly
from scipy.special import comb

from .errors import ParameterError

#: two exponents closer than this (relative) make Z̄ numerically singular
GAMMA_TOL = 1e-9


class MotionLaw:
    """Base class: rest-to-rest motor move of ``Phi`` rad in ``T`` s."""

    kind = "law"

    def __init__(self, Phi: float, T: float):
        Phi, T = float(Phi), float(T)
        if not (math.isfinite(Phi) and Phi != 0.0):
            raise ParameterError(f"law.Phi = {Phi!r}: total motor rotation must be finite and non-zero [rad]")
        if not (math.isfinite(T) and T > 0.0):
            raise ParameterError(f"law.T = {T!r}: motion time must be finite and > 0 [s]")
        self.Phi, self.T = Phi, T

    # subclasses implement _inside(t, order) for t in [0, T] (array) -> list of derivatives 0..order
    def evaluate(self, t, order: int = 3):
        """(φ, φ̇, φ̈, φ⃛)[:order+1] at times t [s] (array or scalar); motor at rest outside [0, T]."""
        t = np.asarray(t, dtype=float)
        scalar = t.ndim == 0
        t = np.atleast_1d(t)
        tc = np.clip(t, 0.0, self.T)
        out = self._inside(tc, order)
        before, after = t < 0.0, t > self.T
        out[0] = np.where(before, 0.0, np.where(after, self.Phi, out[0]))
        for k in range(1, order + 1):
            out[k] = np.where(before | after, 0.0, out[k])
        if scalar:
            out = [float(o[0]) for o in out]
        return tuple(out)

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
        """A ``controllers`` reference ``(t, y) -> (φ_ref, φ̇_ref, φ̈_ref)`` (times ``scale``),
        starting at ``t0`` [s]."""
        return LawReference(self, scale, t0)


class LawReference:
    """Reference object for ``controllers.PID`` (motor shaft position, speed, acceleration)."""

    def __init__(self, law, scale=1.0, t0=0.0):
        self.law, self.scale, self.t0 = law, scale, t0

    def reset(self):
        pass

    def __call__(self, t, y=None):
        tl = float(t) - self.t0
        s = self.scale
        if tl > self.law.T:  # at rest after the move: no law evaluation on the hot path
            return s * self.law.Phi, 0.0, 0.0
        if tl < 0.0:
            return 0.0, 0.0, 0.0
        p, v, a = self.law.evaluate(tl, 2)
        return s * p, s * v, s * a


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

    def _inside(self, t, order):
        u = 1.0 - t / self.T
        Phi, T = self.Phi, self.T
        out = [None] * (order + 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            pw = [u[None, :] ** (self.gammas[:, None] - k) for k in range(order + 1)]
        out[0] = Phi * (1.0 - self.C @ pw[0])
        for k in range(1, order + 1):  # Eq 18
            coef = pochhammer_falling(self.gammas, k) * self.C
            out[k] = (-1.0) ** (k + 1) * Phi / T ** k * (coef @ pw[k])
        return out

    def accel_terms(self):
        """φ̈(t) = Σ a_i·u^{e_i}, u = 1 − t/T: returns (a_i [rad/s²], e_i) (Eq 10)."""
        a = -self.Phi / self.T ** 2 * pochhammer_falling(self.gammas, 2) * self.C
        return a, self.gammas - 2.0

    def describe(self):
        return {"kind": self.kind, "Phi": self.Phi, "T": self.T, "gammas": self.gammas.tolist(),
                "C": self.C.tolist()}


def polynomial_345(Phi: float, T: float) -> PseudoPolynomialLaw:
    """The standard 3-4-5 polynomial (γ = 3, 4, 5; C = 10, −15, 6)."""
    return PseudoPolynomialLaw(Phi, T, (3.0, 4.0, 5.0))


# ====================================================================== Bezier laws
def bernstein(n: int, i: int, lam):
    """B(n, i, λ) = C(n, i)·λ^i·(1 − λ)^{n−i} (seed 003 Eq 11, corrected exponent n − i)."""
    lam = np.asarray(lam, dtype=float)
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
        self._bp = [BPoly(self.S[:, None], [0.0, self.T])]
        for _ in range(3):  # Eq 13 applied repeatedly: velocity, acceleration, jerk polygons
            self._bp.append(self._bp[-1].derivative())

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

    def _inside(self, t, order):
        return [self._bp[k](t) for k in range(order + 1)]

    def accel_bpoly(self):
        return self._bp[2]

    def describe(self):
        return {"kind": self.kind, "Phi": self.Phi, "T": self.T, "m": self.m, "p": self.p,
                "interior": self.interior.tolist(), "interior_over_Phi": self.params.tolist()}


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
