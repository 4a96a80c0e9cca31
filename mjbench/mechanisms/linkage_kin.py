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
#: a change point is crossed from δ before it to δ after it (rad; halved where needed)
CROSS_DELTA = 0.02
#: largest relative jump of the velocity coefficients accepted as continuity across a change point
VELOCITY_CONTINUITY = 1e-4
#: conditioning κ = σ_min/σ_max below which a local minimum of κ may be a singular configuration
CHANGE_KAPPA = 1e-6
#: the singular configuration is a V of κ: κ(q* ± V_PROBE) at least 20× its minimum (rad)
V_PROBE = 1e-4
#: square systems of at least this many coordinates (30 links) are solved as sparse matrices, one
#: configuration at a time (a joint's rows touch two links: ≤ 6 non-zeros a row); smaller ones dense,
#: all configurations at once
SPARSE_MIN = 90

_Pt = namedtuple("_Pt", "q z v a kappa")  # a point of a branch: input angle, z, v = dz/dq, a = dv/dq, κ


def _hermite(pa, pb, q):
    """(z, v, a) at q between two branch points by cubic Hermite interpolation of z (v its
    derivative, a linear): guesses for later exact solves."""
    H = pb.q - pa.q
    t = (q - pa.q) / H
    h00, h10, h01, h11 = 2 * t ** 3 - 3 * t ** 2 + 1, t ** 3 - 2 * t ** 2 + t, -2 * t ** 3 + 3 * t ** 2, t ** 3 - t ** 2
    d00, d10, d01, d11 = 6 * t * t - 6 * t, 3 * t * t - 4 * t + 1, -6 * t * t + 6 * t, 3 * t * t - 2 * t
    z = h00 * pa.z + h10 * H * pa.v + h01 * pb.z + h11 * H * pb.v
    v = (d00 * pa.z + d01 * pb.z) / H + d10 * pa.v + d11 * pb.v
    return z, v, (1 - t) * pa.a + t * pb.a


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
        # the revolute joints, for Φ and Φ_z of all of them at once (body −1, the ground, is the
        # last column of :meth:`_frames`): joint rows, bodies, points, points turned by 90°
        rev = [(k, jt) for k, jt in enumerate(self.joints) if jt.kind == "R"]
        self._rk = np.array([k for k, _ in rev], dtype=int)
        self._ri = np.array([jt.i for _, jt in rev], dtype=int)
        self._rj = np.array([jt.j for _, jt in rev], dtype=int)
        self._rsi = np.array([jt.si for _, jt in rev], dtype=float).reshape(-1, 2)
        self._rsj = np.array([jt.sj for _, jt in rev], dtype=float).reshape(-1, 2)

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
    def _frames(self, z):
        """(x, y, cos θ, sin θ) of every body, (B, nbody + 1) each, the ground last (0, 0, 1, 0):
        the same operations as :meth:`_body`, body by body."""
        B = z.shape[0]
        x, y, c, s = (np.empty((B, self.nbody + 1)) for _ in range(4))
        for b in range(self.nbody):
            c[:, b], s[:, b] = _rot(z[:, 3 * b + 2])
        x[:, :-1], y[:, :-1] = z[:, 0::3], z[:, 1::3]
        x[:, -1], y[:, -1], c[:, -1], s[:, -1] = 0.0, 0.0, 1.0, 0.0
        return x, y, c, s

    def phi(self, z, q):
        """Φ(z, q), (B, m)."""
        z = np.atleast_2d(z)
        B = z.shape[0]
        out = np.empty((B, self.m))
        if len(self._rk):  # revolute joints: P_i − P_j, all at once (as :meth:`point` computes them)
            x, y, c, s = self._frames(z)
            i, j, si, sj = self._ri, self._rj, self._rsi, self._rsj
            out[:, 2 * self._rk] = ((x[:, i] + (c[:, i] * si[:, 0] - s[:, i] * si[:, 1]))
                                    - (x[:, j] + (c[:, j] * sj[:, 0] - s[:, j] * sj[:, 1])))
            out[:, 2 * self._rk + 1] = ((y[:, i] + (s[:, i] * si[:, 0] + c[:, i] * si[:, 1]))
                                        - (y[:, j] + (s[:, j] * sj[:, 0] + c[:, j] * sj[:, 1])))
        for k, jt in enumerate(self.joints):
            if jt.kind == "R":
                continue
            else:
                Pi = self.point(z, jt.i, jt.si)
                Pj = self.point(z, jt.j, jt.sj)
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
        if len(self._rk):  # revolute joints, all at once: ±I on the positions, ±A(θ)·S·s on the angle
            _, _, c, s = self._frames(z)
            for bod, pt, sign in ((self._ri, self._rsi, 1.0), (self._rj, self._rsj, -1.0)):
                on = bod >= 0
                b, r0, p0, p1 = bod[on], 2 * self._rk[on], -pt[on, 1], pt[on, 0]  # S·s = (−s_y, s_x)
                Jm[:, r0, 3 * b] = sign
                Jm[:, r0 + 1, 3 * b + 1] = sign
                ax, ay = c[:, b] * p0 - s[:, b] * p1, s[:, b] * p0 + c[:, b] * p1
                Jm[:, r0, 3 * b + 2] = ax if sign > 0 else -ax
                Jm[:, r0 + 1, 3 * b + 2] = ay if sign > 0 else -ay
        for k, jt in enumerate(self.joints):
            r0 = 2 * k
            i, j = jt.i, jt.j
            if jt.kind == "R":
                continue
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

    def centripetal(self, z, v, jt):
        """(cos, sin of body i's angle, ω_i, A_i s_i ω_i² − A_j s_j ω_j² (B, 2)) of joint ``jt`` at
        (z, v): the velocity-product term its two joint points contribute to γ."""
        i, j = jt.i, jt.j
        B = z.shape[0]
        wi = v[:, 3 * i + 2] if i >= 0 else np.zeros(B)
        wj = v[:, 3 * j + 2] if j >= 0 else np.zeros(B)
        _, _, ci, si_ = self._body(z, i)
        _, _, cj, sj_ = self._body(z, j)
        Asi = _apply(ci, si_, jt.si) if i >= 0 else np.zeros((B, 2))
        Asj = _apply(cj, sj_, jt.sj) if j >= 0 else np.zeros((B, 2))
        return ci, si_, wi, Asi * (wi * wi)[:, None] - Asj * (wj * wj)[:, None]

    def gamma(self, z, v):
        """Velocity-product terms γ(z, v) of Φ_z a = γ, (B, m)."""
        z, v = np.atleast_2d(z), np.atleast_2d(v)
        B = z.shape[0]
        out = np.zeros((B, self.m))
        for k, jt in enumerate(self.joints):
            i, j = jt.i, jt.j
            ci, si_, wi, term = self.centripetal(z, v, jt)
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
            if Jm.shape[1] >= SPARSE_MIN:
                return _sparse_solve(Jm, rhs)
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
        if Jm.shape[1] == Jm.shape[2] and Jm.shape[1] >= SPARSE_MIN:  # one factorisation for both
            lu = _sparse_factors(Jm)
            v = _sparse_apply(lu, rhs)
            return v, _sparse_apply(lu, self.gamma(z, v))
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

    def _q(self, q, B):
        """The input q for a batch of B configurations: (B,) (several inputs: (B, n), their class)."""
        return np.broadcast_to(np.asarray(q, dtype=float), (B,))

    def newton(self, z, q, tol=1e-13, maxit=12):
        """Newton on Φ(z, q) = 0 for a batch; returns (z, converged (B,) bool)."""
        z = np.array(np.atleast_2d(z), dtype=float)
        q = self._q(q, z.shape[0])
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

    def continuation(self, z0, q0, span=TWO_PI, n=120, min_step=1e-9, cond_tol=1e-9, cross=False):
        """Follow the branch of ``z0`` (assembled at q0) over q0 → q0 + span in n equal steps
        (subdivided where needed).  Returns (q (n+1,), z (n+1, 3n), v, a, change points).

        ``cross=False``: raises SolveError with the input angle where the branch ends (dead
        centre, no assembly) or crosses a singular configuration (the determinant of the augmented
        Jacobian changes sign); no change points.

        ``cross=True``: a singular configuration where branches meet (a change point: a
        parallelogram's flat positions) is located and crossed by continuity of velocity
        (:meth:`_cross`); its input angle is listed in the change points.  A step that lands next
        to one (κ < CHANGE_KAPPA) is not taken (its v, a come from a nearly singular solve): the
        crossing starts from the points before it.  Raises SolveError where the branch ends (the
        input locks) or where no branch continues the velocity."""
        qs = q0 + span * np.arange(n + 1) / n
        Z = np.empty((n + 1, self.nz))
        V = np.empty_like(Z)
        A = np.empty_like(Z)
        z = np.asarray(z0, float)
        v, a = self.kinematics(z[None])
        Z[0], V[0], A[0] = z, v[0], a[0]
        square = self.m == self.nz
        sign0 = self._det_sign(z) if square and not cross else 0.0
        fwd = span > 0
        changes = []
        hist = [_Pt(q0, z, v[0], a[0], self._kappa(z))] if cross else None
        vz, az = V[0], A[0]
        k, q, resume = 0, q0, False
        while k < n:
            qa, qb = qs[k], qs[k + 1]
            if not resume:
                q = qa
            resume = False
            h = qb - qa
            while (q < qb - 1e-15 * span) if fwd else (q > qb - 1e-15 * span):
                h = min(h, qb - q) if fwd else max(h, qb - q)
                zn = self.step(z, q, q + h, vz, az)
                if zn is None:
                    h *= 0.5
                    if abs(h) < min_step:
                        if not cross:
                            raise SolveError("continuation failed", q=q, kind="end", z=z)
                        # the solve fails near q + 2h: a singular point there, or the branch ends
                        landing = self._cross(hist, q + 2.0 * h, span)
                        break
                    continue
                if not cross:
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
                else:
                    kn = self._kappa(zn)
                    if kn < CHANGE_KAPPA:  # landed on (next to) a singular configuration: its velocity
                        landing = self._cross(hist, q + h, span)  # is not to be trusted; cross it from here
                        break
                    z, q = zn, q + h
                    vv, aa = self.kinematics(z[None])
                    vz, az = vv[0], aa[0]
                    hist.append(_Pt(q, z, vz, az, kn))
                    landing = self._dip(hist, span)
                    if landing is not None:
                        break
                h = min(2.0 * h, qb - qa) if fwd else max(2.0 * h, qb - qa)
            else:
                Z[k + 1], V[k + 1], A[k + 1] = z, vz, az
                k += 1
                continue
            # crossed a change point: from the launch point A (before it) to the landing point L
            qc, pa, pl = landing
            changes.append(qc)
            j = int(np.searchsorted(qs, pa.q, side="right")) if fwd else \
                int(np.searchsorted(-qs, -pa.q, side="right"))
            while j <= n and ((qs[j] <= pl.q) if fwd else (qs[j] >= pl.q)):
                Z[j], V[j], A[j] = _hermite(pa, pl, qs[j])
                j += 1
            k = j - 1
            z, q, vz, az = pl.z, pl.q, pl.v, pl.a
            hist = [pl]
            resume = True
        return qs, Z, V, A, changes

    # -------------------------------------------------------------- change points
    def _kappa(self, z):
        """Scaled σ_min/σ_max of the augmented Jacobian at one configuration (0: singular)."""
        s = self.singular_values(z[None])[0]
        return float(s[-1] / s[0]) if s[0] > 0 else 0.0

    def _solve_near(self, hist, q, maxit=40):
        """Configuration at input angle q on the branch of the points ``hist``: Newton from the
        second-order Taylor guess of the nearest point (z, converged)."""
        p = min(hist, key=lambda t: abs(t.q - q))
        t = q - p.q
        z, ok = self.newton((p.z + p.v * t + 0.5 * p.a * t * t)[None], q, tol=1e-12, maxit=maxit)
        return z[0], bool(ok[0])

    def _dip(self, hist, span):
        """After each accepted step: whether the last points bracket a singular configuration (a
        local minimum of the conditioning κ, or a sign change of det Φ_z); if so cross it
        (:meth:`_cross`) and return (q*, launch, landing), else None."""
        if len(hist) < 2:
            return None
        lo = None
        if self.m == self.nz and self._det_sign(hist[-1].z) != self._det_sign(hist[-2].z):
            lo, hi = hist[-2].q, hist[-1].q
        elif len(hist) >= 3 and hist[-2].kappa < hist[-3].kappa and hist[-2].kappa <= hist[-1].kappa:
            lo, hi = hist[-3].q, hist[-1].q
        if lo is None:
            return None
        qm, km, singular = self._locate(hist, lo, hi)
        if not singular:
            return None
        return self._cross(hist, qm, span, located=True)

    def _locate(self, hist, lo, hi):
        """Golden-section minimum of κ(q) on the branch over [lo, hi]: (q_min, κ_min, singular).
        Singular: κ_min is below CHANGE_KAPPA and the minimum is a V (κ at ±δ_V at least 20× larger)."""
        if hi < lo:
            lo, hi = hi, lo

        def kappa(q):
            return self._kappa(self._solve_near(hist, q)[0])

        g = 0.5 * (math.sqrt(5.0) - 1.0)
        a, b = lo, hi
        c, d = b - g * (b - a), a + g * (b - a)
        fc, fd = kappa(c), kappa(d)
        while b - a > 1e-10 * max(1.0, abs(hi - lo)):
            if fc < fd:
                b, d, fd = d, c, fc
                c = b - g * (b - a)
                fc = kappa(c)
            else:
                a, c, fc = c, d, fd
                d = a + g * (b - a)
                fd = kappa(d)
        qm, km = (c, fc) if fc < fd else (d, fd)
        if not km < CHANGE_KAPPA:
            return qm, km, False
        side = min(kappa(qm - V_PROBE), kappa(qm + V_PROBE))
        return qm, km, km < 0.05 * side

    def _cross(self, hist, qs_, span, located=False):
        """Cross the singular configuration near input angle qs_ by continuity of velocity: from
        the launch point A = qs_ − δ (on the incoming branch) to the landing point L = qs_ + δ,
        predicted z_A + v_A·2δ + ½a_A(2δ)², corrected by Newton; L is accepted when its velocity
        continues A's to second order, |v_L − v_A − ½(a_A + a_L)·2δ| ≤ VELOCITY_CONTINUITY·max|v|
        (a jump to another branch there changes v by O(1)).  δ = CROSS_DELTA, halved up to 6
        times.  Returns (q*, A, L), q* located by :meth:`_locate` between A and L; SolveError
        (kind "end": no configuration beyond — the branch ends, the input locks; kind
        "singular": only branches whose velocity jumps) otherwise."""
        sgn = 1.0 if span > 0 else -1.0
        C = self.col_scale
        reached = False
        for i in range(7):
            dl = CROSS_DELTA * 0.5 ** i
            qa, qb = qs_ - sgn * dl, qs_ + sgn * dl
            za, ok = self._solve_near([p for p in hist if sgn * (p.q - qs_) < 0] or hist[:1], qa)
            if not ok:
                continue
            va, aa = (x[0] for x in self.kinematics(za[None]))
            H = qb - qa
            zb, okb = self.newton((za + va * H + 0.5 * aa * H * H)[None], qb, tol=1e-13, maxit=30)
            if not okb[0]:
                continue
            reached = True
            zb = zb[0]
            vb, ab = (x[0] for x in self.kinematics(zb[None]))
            scale = max(np.max(np.abs(va * C)), np.max(np.abs(vb * C)), 1e-300)
            mismatch = np.max(np.abs((vb - va - 0.5 * (aa + ab) * H) * C)) / scale
            if mismatch <= VELOCITY_CONTINUITY:
                pa = _Pt(qa, za, va, aa, self._kappa(za))
                pl = _Pt(qb, zb, vb, ab, self._kappa(zb))
                qc = qs_ if located else self._locate([pa, pl], qa, qb)[0]
                return qc, pa, pl
        raise SolveError("singular" if reached else "end", q=qs_, kind="singular" if reached else "end",
                         z=hist[-1].z)

    def _det_sign(self, z):
        return float(np.linalg.slogdet(self.jac(z[None])[0])[0])


def _sparse_solve(Jm, rhs):
    """Jm x = rhs for a batch of large square Jacobians, each factorised sparse (SuperLU): a chain of
    81 bars is 243 coordinates with ≤ 6 non-zeros a row, where a dense batch costs 243³ a configuration.
    A singular matrix raises LinAlgError, as the dense solve does."""
    return _sparse_apply(_sparse_factors(Jm), rhs)


def _sparse_factors(Jm):
    """SuperLU factors of each matrix of a batch (B, n, n) (:func:`_sparse_solve`)."""
    from scipy.sparse import csc_matrix  # heavy: loaded by large linkages only (as assemble's scipy.optimize)
    from scipy.sparse.linalg import splu  # heavy: loaded by large linkages only

    mask = np.any(Jm != 0, axis=0)  # the batch's common pattern: one matrix, its values replaced
    cols, rows = np.nonzero(mask.T)  # column by column, rows ascending (CSC order)
    indptr = np.concatenate([[0], np.cumsum(mask.sum(axis=0))])
    vals = Jm[:, rows, cols]
    A = csc_matrix((vals[0].copy(), rows, indptr), shape=mask.shape)
    out = []
    for b in range(Jm.shape[0]):
        A.data[:] = vals[b]
        try:
            out.append(splu(A))
        except RuntimeError as e:  # SuperLU: "Factor is exactly singular"
            raise np.linalg.LinAlgError(str(e)) from None
    return out


def _sparse_apply(lu, rhs):
    """x (B, n) from the factors of :func:`_sparse_factors` and right-hand sides (B, n)."""
    out = np.empty(np.shape(rhs))
    for b, f in enumerate(lu):
        out[b] = f.solve(np.ascontiguousarray(rhs[b], dtype=float))
    return out


# ============================================================================ tables
class PeriodicTable:
    """Periodic cubic splines of k channels over one period of the input, u = q − q0 ∈ [0, P)
    (P = ``period``: one turn, 2π, or the turns after which a path through change points repeats).

    ``values`` (N, k) at the nodes u_i = P·i/N.  Channel values at any q (scalar or array),
    ``q`` taken modulo P; a scalar path in plain Python floats (no NumPy call) for the hot loop.
    """

    def __init__(self, q0, values, period=TWO_PI):

        values = np.asarray(values, dtype=float)
        N, k = values.shape
        self.q0, self.N, self.k = float(q0), N, k
        self.period = float(period)
        self.h = self.period / N
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
#: coefficients (t³, t², t, 1) of cell 0, then cell 1, … —, q0, N/P (P the period), N, and M = N − 1 when N is a
#: power of two (the cell i mod N is then i & M, without an integer division), else −1
PTableP = namedtuple("PTableP", "rows q0 inv_h N M")


@law
def ptable_channel(q, ch, T):
    """Channel ``ch`` of a :class:`PeriodicTable` at input angle q: cell ⌊(q − q0)·N/P⌋ mod N,
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


#: the coupler point's arc length over one turn for :func:`arc_length_law`: n intervals of
#: h = 2π/n, path length L [m], s(α_i) [m] and S(α_i) = ds/dα [m/rad] at the n + 1 nodes
ArcP = namedtuple("ArcP", "n h L s dsdq")


@law
def arc_length_law(alpha, P):
    """s(α) [m] travelled since α = 0, cumulative over turns: cubic Hermite interpolation of the
    tabulated s(α_i) with slopes S(α_i) on one turn; NaN for a non-finite angle."""
    if not abs(alpha) < 1e15:
        return math.nan
    tw = 2.0 * math.pi
    turns = math.floor(alpha / tw)
    x = (alpha - turns * tw) / P.h
    i = int(x)
    if i > P.n - 1:
        i = P.n - 1
    if i < 0:
        i = 0
    u = x - i
    h = P.h
    u2 = u * u
    u3 = u2 * u
    y = ((2.0 * u3 - 3.0 * u2 + 1.0) * P.s[i] + (u3 - 2.0 * u2 + u) * h * P.dsdq[i]
         + (3.0 * u2 - 2.0 * u3) * P.s[i + 1] + (u3 - u2) * h * P.dsdq[i + 1])
    return y + turns * P.L
