"""Function generation (Freudenstein): precision points at Chebyshev spacing or least squares, the
structural error by position analysis, the start angles searched."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import ParameterError
from .common import TWO_PI, Synthesis, _cross, _u, chebyshev_points, constraint, wrap
from .geometry import FourBar, _common_constraints


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
    xs = _fg_points(spec, method, n_points)
    design = _fg_design(spec, xs, d)
    info = {"method": method, "x_points": xs.tolist()}
    if phi0 is None or psi0 is None:
        score = _fg_score(design, spec, full_rotation, crank_rocker, min_transmission, max_link_ratio)
        phi0, psi0 = _fg_start_angles(score, phi0, psi0)
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
    cons = _fg_constraints(fb, sig, ok, ach, method, min_transmission, max_link_ratio, envelope, full_rotation,
                           crank_rocker, max_structural_error)
    return Synthesis("function-generator", fb,
                     {"function": spec.text, "x_range": [spec.x0, spec.x1], "dphi_deg": math.degrees(spec.dphi),
                      "dpsi_deg": math.degrees(spec.dpsi)}, ach, cons, info)


def _fg_points(spec: FunctionSpec, method, n_points) -> np.ndarray:
    """The x of the precision points (Chebyshev, 3) or of the least-squares points (n, evenly spaced)."""
    if method == "chebyshev":
        return chebyshev_points(spec.x0, spec.x1, 3)
    if method == "least-squares":
        if n_points < 4:
            raise ParameterError(f"function generator: least squares needs n_points >= 4, got {n_points}")
        return np.linspace(spec.x0, spec.x1, int(n_points))
    raise ParameterError(f"function generator: method {method!r}: choose chebyshev or least-squares")


def _fg_design(spec: FunctionSpec, xs, d):
    """``design(φ₀, ψ₀)`` → (FourBar or None, branch at every point, Freudenstein's K) through the
    points ``xs`` with ground length d."""
    def design(p0, s0):
        ph, ps = spec.phi(xs, p0), spec.psi(xs, s0)
        K = freudenstein_solve(ph, ps)
        fb, sig = _fg_linkage(K, d, ph, ps)
        return fb, sig, K
    return design


def _fg_score(design, spec, full_rotation, crank_rocker, min_transmission, max_link_ratio):
    """``score(φ₀, ψ₀)`` → (penalty of the violated constraints, max |structural error|)."""
    def score(p0, s0):
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
    return score


def _fg_start_angles(score, phi0, psi0):
    """(φ₀, ψ₀) [rad, in [0, 2π)]: the free ones searched on a 5° grid (smallest (penalty, error)),
    then refined by Nelder–Mead on 100·penalty + error."""
    from scipy.optimize import minimize

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
    return float(p0) % TWO_PI, float(s0) % TWO_PI


def _fg_constraints(fb, sig, ok, ach, method, min_transmission, max_link_ratio, envelope, full_rotation,
                    crank_rocker, max_structural_error) -> list:
    """The function generator's constraints: one branch, assembly over the range, precision points
    (Chebyshev), the common ones (full rotation, transmission, link ratio, envelope), the crank
    the shortest link, the structural error."""
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
    return cons
