"""Planar kinematics of a linkage with n ≥ 1 input joints (several motors), in body coordinates.

The constraints are those of :class:`~mjbench.mechanisms.linkage_kin.PlanarSystem` (two rows per
revolute or prismatic joint) with one driving row per input k, a revolute joint between bodies
i and j (i = −1: the ground):   θ_j − θ_i − q_k = 0.

Velocity coefficients are a matrix, V = ∂z/∂q (3·nbody × n): Φ_z V = E (E: the identity in the
driving rows).  Along an input velocity q̇ the body velocities are ż = V q̇ and the accelerations
z̈ = V q̈ + w(q̇), Φ_z w = γ(z, V q̇) (Haug's velocity-product terms, quadratic in q̇).  The reduced
model of the machine follows by projection (the loop constraints do no work along V):

    M̄(q) = Vᵀ M V,    c̄(q, q̇) = Vᵀ M w(q̇) = Σ_{j≤k} G_{·,jk} q̇_j q̇_k,    ḡ(q) = Vᵀ ∂E_p/∂z,

M the bodies' diagonal mass matrix (m, m, I_G); c̄'s coefficients G by polarisation of the
quadratic form (exact).  A serial chain (no loop) is the same system with no closing joints.
"""
from __future__ import annotations

import numpy as np

from ..linkage_kin import PlanarSystem, SolveError


class MultiPlanarSystem(PlanarSystem):
    """:class:`PlanarSystem` with several driving rows: ``drivers`` [(i, j)] (body indices of each
    input joint's two links, −1 = ground), q a vector (B, n)."""

    def __init__(self, nbody, joints, drivers, L=1.0):
        self.drivers = [(int(i), int(j)) for i, j in drivers]
        super().__init__(nbody, joints, self.drivers[0][1], L)
        self.ninputs = len(self.drivers)
        self._m = 2 * len(self.joints) + self.ninputs
        rs = []
        for jt in self.joints:
            rs += [1.0 / self.L, 1.0 / self.L] if jt.kind == "R" else [1.0 / self.L, 1.0]
        rs += [1.0] * self.ninputs
        self.row_scale = np.array(rs)

    def _q(self, q, B):
        q = np.asarray(q, dtype=float)
        return np.broadcast_to(q.reshape(-1, self.ninputs) if q.ndim else q, (B, self.ninputs))

    def phi(self, z, q):
        z = np.atleast_2d(z)
        B = z.shape[0]
        nj = 2 * len(self.joints)
        out = super().phi(z, 0.0)  # the joints' rows (the driving rows are written below)
        out = np.concatenate([out[:, :nj], np.zeros((B, self.ninputs))], axis=1)
        q = self._q(q, B)
        for k, (i, j) in enumerate(self.drivers):
            thj = z[:, 3 * j + 2]
            thi = z[:, 3 * i + 2] if i >= 0 else 0.0
            out[:, 2 * len(self.joints) + k] = thj - thi - q[:, k]
        return out

    def jac(self, z):
        z = np.atleast_2d(z)
        J1 = super().jac(z)
        B = z.shape[0]
        r0 = 2 * len(self.joints)
        Jm = np.zeros((B, self.m, self.nz))
        Jm[:, :r0] = J1[:, :r0]
        for k, (i, j) in enumerate(self.drivers):
            Jm[:, r0 + k, 3 * j + 2] = 1.0
            if i >= 0:
                Jm[:, r0 + k, 3 * i + 2] = -1.0
        return Jm

    def gamma(self, z, v):
        g = super().gamma(z, v)
        r0 = 2 * len(self.joints)
        return np.concatenate([g[:, :r0], np.zeros((g.shape[0], self.ninputs))], axis=1)

    def drive_rhs(self, B):
        """E (B, m, n): the identity in the driving rows."""
        E = np.zeros((B, self.m, self.ninputs))
        r0 = 2 * len(self.joints)
        for k in range(self.ninputs):
            E[:, r0 + k, k] = 1.0
        return E

    def vmatrix(self, z):
        """V = ∂z/∂q (B, 3n, n)."""
        z = np.atleast_2d(z)
        Jm = self.jac(z)
        E = self.drive_rhs(z.shape[0])
        return np.stack([self._solve(Jm, E[:, :, k]) for k in range(self.ninputs)], axis=-1)

    def accel_terms(self, z, V, qd):
        """w(q̇) (B, 3n): the body accelerations at q̈ = 0 for input rates qd (B, n)."""
        v = np.einsum("bzk,bk->bz", V, qd)
        return self._solve(self.jac(z), self.gamma(z, v))

    def velocity(self, z):  # the first input's column (what PlanarSystem's callers expect)
        return self.vmatrix(z)[:, :, 0]

    def move(self, z, q0, q1, min_step=1e-9, max_frac=0.25):
        """Follow the assembly branch of z (assembled at inputs q0) along the straight segment to q1
        (predictor z + VΔq + ½wΔq², Newton corrector, steps halved until each converges close to
        its prediction).  Raises :class:`SolveError` (with the inputs where it stopped) at a
        singular configuration or where the loops cannot close."""
        z = np.asarray(z, float).copy()
        q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
        d = q1 - q0
        s, h = 0.0, min(1.0, max_frac / max(float(np.max(np.abs(d))), 1e-300))
        while s < 1.0 - 1e-15:
            h = min(h, 1.0 - s)
            qa = q0 + s * d
            V = self.vmatrix(z[None])[0]
            dq = h * d
            w = self.accel_terms(z[None], V[None], dq[None])[0]
            pred = z + V @ dq + 0.5 * w
            zn, ok = self.newton(pred[None], qa + dq)
            corr = np.max(np.abs((zn[0] - pred) * self.col_scale)) if ok[0] else np.inf
            move = np.max(np.abs((V @ dq) * self.col_scale))
            if not ok[0] or corr > 0.1 * move + 1e-9:
                h *= 0.5
                if h * float(np.max(np.abs(d))) < min_step:
                    raise SolveError("the loops cannot be followed further", q=qa, kind="end", z=z)
                continue
            z, s = zn[0], s + h
            h = min(2.0 * h, 1.0)
        return z

    def predict_correct(self, Z, Q, dq):
        """Configurations Z (B, 3n) at inputs Q moved by dq (B, n): the second-order prediction
        (velocity matrix and acceleration terms) corrected by Newton at Q + dq → (Z, converged, the
        correction's size, the predicted move's size), both sizes scaled per coordinate."""
        V = self.vmatrix(Z)
        W = self.accel_terms(Z, V, dq)
        step = np.einsum("bzk,bk->bz", V, dq)
        pred = Z + step + 0.5 * W
        Zn, ok = self.newton(pred, Q + dq)
        corr = np.max(np.abs((Zn - pred) * self.col_scale[None, :]), axis=1)
        move = np.max(np.abs(step * self.col_scale[None, :]), axis=1)
        return Zn, ok, corr, move

    def move_batch(self, Z, Q0, Q1, max_step=0.1, min_step=1e-7):
        """:meth:`move` for a batch of configurations Z (B, 3n) at inputs Q0 (B, n), all moved along
        their own straight segments to Q1 in common substeps (halved for all while any fails).
        Returns Z at Q1; raises :class:`SolveError` naming the first configuration that cannot follow."""
        Z = np.array(Z, float)
        Q0, Q1 = np.asarray(Q0, float), np.asarray(Q1, float)
        D = Q1 - Q0
        span = float(np.max(np.abs(D))) if D.size else 0.0
        if span == 0.0:
            return Z
        s, h = 0.0, min(1.0, max_step / span)
        while s < 1.0 - 1e-15:
            h = min(h, 1.0 - s)
            Qa = Q0 + s * D
            Zn, ok, corr, move = self.predict_correct(Z, Qa, h * D)
            good = ok & (corr <= 0.1 * move + 1e-9)
            if not good.all():
                h *= 0.5
                if h * span < min_step:
                    b = int(np.flatnonzero(~good)[0])
                    raise SolveError("the loops cannot be followed further", q=Qa[b], kind="end", z=Z[b])
                continue
            Z, s = Zn, s + h
            h = min(2.0 * h, 1.0)
        return Z


__all__ = ["MultiPlanarSystem"]
