"""Planar closed-chain kinematics in body coordinates, for the generic linkage (the package linkage/).

Coordinates (Haug 1989, *Computer-Aided Kinematics and Dynamics of Mechanical Systems*, ch. 2-3):
each moving link b has z_b = (x_b, y_b, θ_b), the position of its mass centre G_b and the angle
of its frame [m, m, rad]; ground is fixed (r = 0, θ = 0).  A point with local coordinates s
(relative to G, link axes) is at r_b + A(θ_b)·s.  Constraints Φ(z, q) = 0, two rows per joint:

* revolute (points s_i on link i, s_j on link j):   r_i + A_i s_i − r_j − A_j s_j = 0
* prismatic (point s_j of link j on the line of link i through s_i along the unit vector u_i,
  relative angle fixed at φ₀):   n_i·(P_j − P_i) = 0 with n_i = A_i S u_i,   θ_j − θ_i − φ₀ = 0
* driving (the input joint, revolute, ground → input link c):   θ_c − q = 0

(S = 90° rotation.)  Velocity coefficients v = dz/dq solve Φ_z v = e (e: 1 in the driving row,
Φ_q = −e), and their derivatives a = dv/dq solve Φ_z a = γ(z, v), with γ the velocity-product
terms of Φ̈ (Haug's γ, here per unit input speed):

* revolute:   γ = A_i s_i θ'_i² − A_j s_j θ'_j²
* prismatic:  γ = (n·d) θ'_i² + 2 θ'_i (A_i u_i)·d' − n·(A_i s_i θ'_i² − A_j s_j θ'_j²),
  d = P_j − P_i, d' = dd/dq;  angle and driving rows: γ = 0.

Everything is vectorised over a batch of B configurations (arrays (B, 3n)); the position solve
is Newton on Φ (least squares if the system has redundant rows).  ``continuation`` follows the
assembly branch of a starting configuration over one input turn.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass, field

import numpy as np

from ..compiled import law
from ..spline import periodic_cubic

TWO_PI = 2.0 * math.pi


@dataclass
class KJoint:
    """A joint in solver form.  i, j: body indices (−1 = ground); si, sj: points relative to the
    bodies' mass centres in link axes (ground: world); u: prismatic axis (unit, link-i axes);
    phi0: prismatic relative angle θ_j − θ_i [rad]."""

    name: str
    kind: str  # "R" | "P"
    i: int
    j: int
    si: np.ndarray
    sj: np.ndarray
    u: np.ndarray | None = None
    phi0: float = 0.0


class SolveError(Exception):
    """Raised by the solver; ``q`` is the input angle where it failed (None: at assembly)."""

    def __init__(self, message, q=None, kind="singular", z=None):
        super().__init__(message)
        self.q, self.kind, self.z = q, kind, z


def _rot(th):
    return np.cos(th), np.sin(th)


def _apply(c, s, p):
    """A(θ)·p for a batch (c, s: (B,)) and a fixed 2-vector p → (B, 2)."""
    out = np.empty(np.shape(c) + (2,))
    p0, p1 = float(p[0]), float(p[1])
    np.multiply(c, p0, out=out[..., 0])
    out[..., 0] -= s * p1
    np.multiply(s, p0, out=out[..., 1])
    out[..., 1] += c * p1
    return out


@dataclass
class PlanarSystem:
    """Constraint equations of a planar linkage with ``nbody`` moving links."""

    nbody: int
    joints: list
    input_body: int  #: link driven by the input (its angle is q)
    L: float = 1.0  #: characteristic length [m] for scaling position rows/columns
    #: higher pairs (gear pairs, belts, racks; :class:`mjbench.mechanisms.linkage.gears.KGear`): one
    #: row each after the joints' rows, before the driving row
    gears: list = field(default_factory=list)
    _m: int = field(init=False)

    def __post_init__(self):
        self._m = 2 * len(self.joints) + len(self.gears) + 1
        n = self.nbody
        self.nz = 3 * n
        # row scale: length rows 1/L, angle rows 1;   column scale: positions 1/L, angles 1
        rs = []
        for jt in self.joints:
            rs += [1.0 / self.L, 1.0 / self.L] if jt.kind == "R" else [1.0 / self.L, 1.0]
        rs += [1.0 / self.L] * len(self.gears)  # gear rows are slips at the pitch point [m]
        rs.append(1.0)
        self.row_scale = np.array(rs)
        self.col_scale = np.tile([1.0 / self.L, 1.0 / self.L, 1.0], n)

    @property
    def m(self):
        return self._m

    # -------------------------------------------------------------- helpers
    def _body(self, z, b):
        """(r (B,2), θ (B,), c, s) of body b; ground → zeros."""
        B = z.shape[0]
        if b < 0:
            zero = np.zeros(B)
            return np.zeros((B, 2)), zero, np.ones(B), zero
        th = z[:, 3 * b + 2]
        c, s = _rot(th)
        return z[:, 3 * b:3 * b + 2], th, c, s

    def point(self, z, b, p):
        """World position of local point p (relative to G_b) of body b, (B, 2)."""
        r, _, c, s = self._body(z, b)
        return r + _apply(c, s, p)

    def point_vel(self, z, v, b, p):
        """d/dq of the world position of point p of body b for velocity coefficients v, (B, 2)."""
        if b < 0:
            return np.zeros((z.shape[0], 2))
        _, _, c, s = self._body(z, b)
        w = v[:, 3 * b + 2]
        Sp = np.array([-p[1], p[0]])
        return v[:, 3 * b:3 * b + 2] + _apply(c, s, Sp) * w[:, None]

    def point_acc(self, z, v, a, b, p):
        """d²/dq² of the world position of point p of body b, (B, 2)."""
        if b < 0:
            return np.zeros((z.shape[0], 2))
        _, _, c, s = self._body(z, b)
        w, al = v[:, 3 * b + 2], a[:, 3 * b + 2]
        Sp = np.array([-p[1], p[0]])
        return a[:, 3 * b:3 * b + 2] + _apply(c, s, Sp) * al[:, None] - _apply(c, s, p) * (w * w)[:, None]

    # -------------------------------------------------------------- equations
    def phi(self, z, q):
        """Φ(z, q), (B, m)."""
        z = np.atleast_2d(z)
        B = z.shape[0]
        out = np.empty((B, self.m))
        for k, jt in enumerate(self.joints):
            Pi = self.point(z, jt.i, jt.si)
            Pj = self.point(z, jt.j, jt.sj)
            if jt.kind == "R":
                out[:, 2 * k:2 * k + 2] = Pi - Pj
            else:
                _, thi, ci, si_ = self._body(z, jt.i)
                _, thj, _, _ = self._body(z, jt.j)
                n = _apply(ci, si_, np.array([-jt.u[1], jt.u[0]]))
                out[:, 2 * k] = np.einsum("bk,bk->b", n, Pj - Pi)
                out[:, 2 * k + 1] = thj - thi - jt.phi0
        r0 = 2 * len(self.joints)
        for g, gr in enumerate(self.gears):
            out[:, r0 + g] = gr.phi(self, z)
        out[:, -1] = z[:, 3 * self.input_body + 2] - q
        return out

    def jac(self, z):
        """Φ_z, (B, m, 3n)."""
        z = np.atleast_2d(z)
        B = z.shape[0]
        Jm = np.zeros((B, self.m, self.nz))
        eye = np.eye(2)
        for k, jt in enumerate(self.joints):
            r0 = 2 * k
            i, j = jt.i, jt.j
            if jt.kind == "R":
                if i >= 0:
                    _, _, c, s = self._body(z, i)
                    Jm[:, r0:r0 + 2, 3 * i:3 * i + 2] = eye
                    Jm[:, r0:r0 + 2, 3 * i + 2] = _apply(c, s, np.array([-jt.si[1], jt.si[0]]))
                if j >= 0:
                    _, _, c, s = self._body(z, j)
                    Jm[:, r0:r0 + 2, 3 * j:3 * j + 2] = -eye
                    Jm[:, r0:r0 + 2, 3 * j + 2] = -_apply(c, s, np.array([-jt.sj[1], jt.sj[0]]))
            else:
                _, _, ci, si_ = self._body(z, i)
                n = _apply(ci, si_, np.array([-jt.u[1], jt.u[0]]))
                Pi = self.point(z, i, jt.si)
                Pj = self.point(z, j, jt.sj)
                d = Pj - Pi
                if j >= 0:
                    _, _, cj, sj_ = self._body(z, j)
                    Jm[:, r0, 3 * j:3 * j + 2] = n
                    Jm[:, r0, 3 * j + 2] = np.einsum("bk,bk->b", n, _apply(cj, sj_, np.array([-jt.sj[1], jt.sj[0]])))
                    Jm[:, r0 + 1, 3 * j + 2] = 1.0
                if i >= 0:
                    Au = _apply(ci, si_, jt.u)
                    Jm[:, r0, 3 * i:3 * i + 2] = -n
                    Jm[:, r0, 3 * i + 2] = (-np.einsum("bk,bk->b", Au, d)
                                            - np.einsum("bk,bk->b", n, _apply(ci, si_, np.array([-jt.si[1], jt.si[0]]))))
                    Jm[:, r0 + 1, 3 * i + 2] = -1.0
        r0 = 2 * len(self.joints)
        for g, gr in enumerate(self.gears):
            gr.jac(self, z, Jm[:, r0 + g])
        Jm[:, -1, 3 * self.input_body + 2] = 1.0
        return Jm

    def gamma(self, z, v):
        """Velocity-product terms γ(z, v) of Φ_z a = γ, (B, m)."""
        z, v = np.atleast_2d(z), np.atleast_2d(v)
        B = z.shape[0]
        out = np.zeros((B, self.m))
        for k, jt in enumerate(self.joints):
            i, j = jt.i, jt.j
            wi = v[:, 3 * i + 2] if i >= 0 else np.zeros(B)
            wj = v[:, 3 * j + 2] if j >= 0 else np.zeros(B)
            _, _, ci, si_ = self._body(z, i)
            _, _, cj, sj_ = self._body(z, j)
            Asi = _apply(ci, si_, jt.si) if i >= 0 else np.zeros((B, 2))
            Asj = _apply(cj, sj_, jt.sj) if j >= 0 else np.zeros((B, 2))
            term = Asi * (wi * wi)[:, None] - Asj * (wj * wj)[:, None]
            if jt.kind == "R":
                out[:, 2 * k:2 * k + 2] = term
            else:
                n = _apply(ci, si_, np.array([-jt.u[1], jt.u[0]]))
                Au = _apply(ci, si_, jt.u)
                d = self.point(z, j, jt.sj) - self.point(z, i, jt.si)
                dd = self.point_vel(z, v, j, jt.sj) - self.point_vel(z, v, i, jt.si)
                out[:, 2 * k] = (np.einsum("bk,bk->b", n, d) * wi * wi
                                 + 2.0 * wi * np.einsum("bk,bk->b", Au, dd)
                                 - np.einsum("bk,bk->b", n, term))
        r0 = 2 * len(self.joints)
        for g, gr in enumerate(self.gears):
            out[:, r0 + g] = gr.gamma(self, z, v)
        return out

    # -------------------------------------------------------------- linear algebra
    def _solve(self, Jm, rhs):
        """Solve Jm x = rhs for a batch (least squares if Jm has more rows than columns)."""
        if Jm.shape[1] == Jm.shape[2]:
            return np.linalg.solve(Jm, rhs[..., None])[..., 0]
        R, C = self.row_scale, self.col_scale
        if Jm.shape[0] == 1:
            sol = np.linalg.lstsq(Jm[0] * R[:, None] / C[None, :], rhs[0] * R, rcond=None)[0]
            return (sol / C)[None]
        # redundant rows (a ternary joint's cycle, the planets of an epicyclic stage): least squares by
        # batched QR (full column rank: the driving row takes the one freedom); 3-4x faster than pinv
        Q, Rr = np.linalg.qr(Jm * R[None, :, None] / C[None, None, :])
        y = np.einsum("bji,bj->bi", Q, rhs * R[None, :])
        return np.linalg.solve(Rr, y[..., None])[..., 0] / C[None, :]

    def velocity(self, z):
        """Velocity coefficients v = dz/dq, (B, 3n)."""
        z = np.atleast_2d(z)
        rhs = np.zeros((z.shape[0], self.m))
        rhs[:, -1] = 1.0
        return self._solve(self.jac(z), rhs)

    def kinematics(self, z):
        """(v, a): velocity coefficients and their derivatives dv/dq, (B, 3n) each."""
        z = np.atleast_2d(z)
        Jm = self.jac(z)
        rhs = np.zeros((z.shape[0], self.m))
        rhs[:, -1] = 1.0
        v = self._solve(Jm, rhs)
        a = self._solve(Jm, self.gamma(z, v))
        return v, a

    def singular_values(self, z):
        """Singular values (B, 3n) of the scaled augmented Jacobian (largest first)."""
        Jm = self.jac(z) * self.row_scale[None, :, None] / self.col_scale[None, None, :]
        return np.linalg.svd(Jm, compute_uv=False)

    # -------------------------------------------------------------- position solve
    def residual_norm(self, z, q):
        """Largest scaled residual |Φ| per configuration (lengths / L), (B,)."""
        return np.max(np.abs(self.phi(z, q) * self.row_scale[None, :]), axis=1)

    def newton(self, z, q, tol=1e-13, maxit=12):
        """Newton on Φ(z, q) = 0 for a batch; returns (z, converged (B,) bool)."""
        z = np.array(np.atleast_2d(z), dtype=float)
        q = np.broadcast_to(np.asarray(q, dtype=float), (z.shape[0],))
        ok = np.zeros(z.shape[0], dtype=bool)
        for _ in range(maxit):
            F = self.phi(z, q)
            err = np.max(np.abs(F * self.row_scale[None, :]), axis=1)
            ok = np.isfinite(err) & (err < tol)
            if ok.all():
                break
            idx = np.flatnonzero(~ok)
            with np.errstate(all="ignore"):
                try:
                    dz = self._solve(self.jac(z[idx]), -F[idx])
                except np.linalg.LinAlgError:
                    return z, ok
            z[idx] += dz
        else:
            err = self.residual_norm(z, q)
            ok = np.isfinite(err) & (err < tol)
        return z, ok

    def assemble(self, z0, q, tol=1e-12, anchor=0.1, free=False):
        """Assembly from a rough guess z0 whose link angles pick the branch: Levenberg-Marquardt
        on Φ plus a soft pull ``anchor``·(θ − θ₀) of every angle towards the guess (so the
        closest assembly to the stated angles is found), then on Φ alone, then Newton.
        ``free``: without the driving constraint (the input moves too; no Newton).
        Returns (z, scaled residual)."""
        from scipy.optimize import least_squares

        R, C = self.row_scale, self.col_scale
        z0 = np.asarray(z0, float)
        th0 = z0[2::3].copy()
        nb = len(th0)
        rows = slice(0, self.m - 1) if free else slice(0, self.m)

        def f(x):
            return (self.phi((x / C)[None], q)[0] * R)[rows]

        def jac(x):
            return (self.jac((x / C)[None])[0] * R[:, None] / C[None, :])[rows]

        def fa(x):
            return np.concatenate([f(x), anchor * (x[2::3] - th0)])

        def ja(x):
            Ja = np.zeros((nb, len(x)))
            Ja[np.arange(nb), 3 * np.arange(nb) + 2] = anchor
            return np.vstack([jac(x), Ja])

        kw = dict(xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
        x = z0 * C
        if anchor > 0:
            x = least_squares(fa, x, jac=ja, method="lm", **kw).x
        nrow = self.m - 1 if free else self.m
        x = least_squares(f, x, jac=jac, method="lm" if nrow >= self.nz else "trf", **kw).x
        z = (x / C)[None]
        if free:
            return z[0], float(np.max(np.abs(f(x)), initial=0.0))
        z2, ok = self.newton(z, q, tol=tol)
        if ok[0]:
            z = z2
        return z[0], float(self.residual_norm(z, q)[0])

    def step(self, z, q0, q1, v=None, a=None):
        """One continuation step from (z, q0) to q1: second-order predictor, Newton corrector.
        Returns the new configuration or None (no convergence, or a jump to another branch)."""
        h = q1 - q0
        if v is None:
            v, a = self.kinematics(z[None])
            v, a = v[0], a[0]
        pred = z + v * h + 0.5 * a * h * h
        zn, ok = self.newton(pred[None], q1, maxit=8)
        if not ok[0]:
            return None
        corr = np.max(np.abs((zn[0] - pred) * self.col_scale))
        move = np.max(np.abs(v * h * self.col_scale))
        if corr > 0.1 * move + 1e-9:
            return None  # the corrector went far from the predicted point: maybe another branch
        return zn[0]

    def continuation(self, z0, q0, span=TWO_PI, n=120, min_step=1e-9, cond_tol=1e-9):
        """Follow the branch of ``z0`` (assembled at q0) over q0 → q0 + span in n equal steps
        (subdivided where needed).  Returns (q (n+1,), z (n+1, 3n), v, a).  Raises SolveError
        with the input angle where the branch ends (dead centre, no assembly) or crosses a
        singular configuration (the determinant of the augmented Jacobian changes sign, or its
        scaled condition falls below ``cond_tol``)."""
        qs = q0 + span * np.arange(n + 1) / n
        Z = np.empty((n + 1, self.nz))
        V = np.empty_like(Z)
        A = np.empty_like(Z)
        z = np.asarray(z0, float)
        v, a = self.kinematics(z[None])
        Z[0], V[0], A[0] = z, v[0], a[0]
        square = self.m == self.nz
        sign0 = self._det_sign(z) if square else 0.0
        fwd = span > 0
        for k in range(n):
            qa, qb = qs[k], qs[k + 1]
            q = qa
            h = qb - qa
            vz, az = V[k], A[k]
            while (q < qb - 1e-15 * span) if fwd else (q > qb - 1e-15 * span):
                h = min(h, qb - q) if fwd else max(h, qb - q)
                zn = self.step(z, q, q + h, vz, az)
                if zn is None:
                    h *= 0.5
                    if abs(h) < min_step:
                        raise SolveError("continuation failed", q=q, kind="end", z=z)
                    continue
                if square:
                    sg = self._det_sign(zn)
                    if sg != sign0:  # crossed a singular configuration: locate it by the signed σ_min
                        s1 = sign0 * self.singular_values(z[None])[0, -1]
                        s2 = sg * self.singular_values(zn[None])[0, -1]
                        qs_ = q + h * s1 / (s1 - s2) if s1 != s2 else q + h
                        raise SolveError("singular", q=qs_, kind="singular", z=z)
                z, q = zn, q + h
                vv, aa = self.kinematics(z[None])
                vz, az = vv[0], aa[0]
                h = min(2.0 * h, qb - qa) if fwd else max(2.0 * h, qb - qa)
            Z[k + 1], V[k + 1], A[k + 1] = z, vz, az
        return qs, Z, V, A

    def _det_sign(self, z):
        return float(np.linalg.slogdet(self.jac(z[None])[0])[0])


# ============================================================================ tables
class PeriodicTable:
    """Periodic cubic splines of k channels over one input turn, u = q − q0 ∈ [0, 2π).

    ``values`` (N, k) at the nodes u_i = 2π·i/N.  Channel values at any q (scalar or array),
    ``q`` taken modulo 2π; a scalar path in plain Python floats (no NumPy call) for the hot loop.
    """

    def __init__(self, q0, values):

        values = np.asarray(values, dtype=float)
        N, k = values.shape
        self.q0, self.N, self.k = float(q0), N, k
        self.h = TWO_PI / N
        h = self.h
        # coefficients in the normalised coordinate t ∈ [0, 1): c3 t³ + c2 t² + c1 t + c0
        c = periodic_cubic(values)  # (4, N, k): t^0 … t^3
        self.coef = np.stack([c[3], c[2], c[1], c[0]], axis=0)  # (4, N, k): t^3 … t^0
        self._inv_h = 1.0 / h
        # the scalar law's parameters: row c = channel c's (c3, c2, c1, c0) of cell 0, then cell 1, …
        # (a channel's cells side by side: the cells a run visits in turn share cache lines)
        rows = np.ascontiguousarray(self.coef.transpose(2, 1, 0).reshape(k, 4 * N))
        self.P = PTableP(rows, self.q0, self._inv_h, N, N - 1 if N & (N - 1) == 0 else -1)

    def locate(self, q):
        u = (np.asarray(q, dtype=float) - self.q0) * self._inv_h
        i = np.floor(u)
        t = u - i
        return np.mod(i.astype(np.int64), self.N), t

    def __call__(self, q, channels=None):
        """Values (…, k) (or the listed channels) at q (array or scalar)."""
        i, t = self.locate(q)
        c = self.coef[:, i, :] if channels is None else self.coef[:, i][..., channels]
        t = t[..., None]
        return ((c[0] * t + c[1]) * t + c[2]) * t + c[3]

    def scalar3(self, q):
        """Channels 0, 1, 2 at a Python float q (:func:`ptable_channel`)."""
        P = self.P
        return ptable_channel(q, 0, P), ptable_channel(q, 1, P), ptable_channel(q, 2, P)

    def scalar(self, q, ch):
        """One channel at a Python float q (:func:`ptable_channel`)."""
        return ptable_channel(q, ch, self.P)


#: a periodic table's parameters for :func:`ptable_channel`: rows (k, 4N) — channel c's Horner
#: coefficients (t³, t², t, 1) of cell 0, then cell 1, … —, q0, N/2π, N, and M = N − 1 when N is a
#: power of two (the cell i mod N is then i & M, without an integer division), else −1
PTableP = namedtuple("PTableP", "rows q0 inv_h N M")


@law
def ptable_channel(q, ch, T):
    """Channel ``ch`` of a :class:`PeriodicTable` at input angle q: cell ⌊(q − q0)·N/2π⌋ mod N,
    one Horner evaluation in its local coordinate t ∈ [0, 1); NaN at a non-finite angle."""
    u = (q - T.q0) * T.inv_h
    if not abs(u) < 1e15:
        return math.nan
    i = math.floor(u)
    t = u - i
    b = 4 * ((i & T.M) if T.M >= 0 else i % T.N)
    R = T.rows
    return ((R[ch, b] * t + R[ch, b + 1]) * t + R[ch, b + 2]) * t + R[ch, b + 3]


def _angle_ranges(alpha, mask):
    """Contiguous [lo, hi] ranges of alpha where mask is True (wrapping at 2π)."""
    n = len(alpha)
    step = alpha[1] - alpha[0]
    idx = np.flatnonzero(mask)
    ranges, start, prev = [], idx[0], idx[0]
    for i in idx[1:]:
        if i != prev + 1:
            ranges.append((start, prev))
            start = i
        prev = i
    ranges.append((start, prev))
    if len(ranges) > 1 and ranges[0][0] == 0 and ranges[-1][1] == n - 1:
        first = ranges.pop(0)
        last = ranges.pop()
        ranges.append((last[0], first[1] + n))
    return [(alpha[s % n], alpha[s % n] + (e - s) * step) for s, e in ranges]
