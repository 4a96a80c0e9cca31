"""The reduced (Eksergian) model of a compiled linkage and its table over one turn.

:meth:`ReducedMixin.channels`: J = vᵀMv, J' = 2vᵀMa, E_p', E_p, the viscous factor D and the
loads' coordinates from the body coordinates z, their velocity coefficients v = dz/dq and
derivatives a = dv/dq (docs/linkages.md §2.1).  :meth:`ReducedMixin._tables`: those channels and
the configurations as periodic cubic splines on a uniform grid, refined until the interpolation
error measured at every interval midpoint against the exact solve is below ``TABLE_TARGET``
(``table_info``, docs/linkages.md §2.3).
"""
from __future__ import annotations

import numpy as np

from ...errors import GeometryError
from ..linkage_kin import PeriodicTable
from ..table import DJ_FLOOR
from .assembly import COND_TOL
from .kinematics import _bary_weights, _deg, _lagrange

TABLE_NODES = (2048, 4096, 8192, 16384)  #: grid sizes tried until the table is accurate enough
TABLE_TARGET = 1e-10  #: target relative interpolation error of J, J', E_p' (max over a turn / max |·|)
NEAR_CHANGE = 0.1  #: midpoints within this of a change point are reported apart from the table's error [rad]
#: the table's nodes are checked for a dead centre by the SVD of their Jacobians, every node while the
#: work stays within that of 2048 nodes of 60 coordinates (20 links); a larger linkage every k-th node
#: (the continuation has already checked the conditioning along the branch, step by step)
SVD_BUDGET = 2048 * 60 ** 3


class ReducedMixin:
    """The reduced-model channels and table of the compiled description (:class:`.model._Compiled`)."""

    def channels(self, z, v, a):
        """Reduced-model channels (B, k): J, J', E_p', E_p, D (viscous factor Σc·rate²), then two
        per load: a point load's s = P·d and ds/dq; a torque load's stroke s (0 without a point)
        and its link's dθ/dq."""
        z, v, a = np.atleast_2d(z), np.atleast_2d(v), np.atleast_2d(a)
        B = z.shape[0]
        m, I = self.mass, self.inertia
        V = v.reshape(B, self.n, 3)
        A = a.reshape(B, self.n, 3)
        Z = z.reshape(B, self.n, 3)
        J = (m * (V[..., 0] ** 2 + V[..., 1] ** 2) + I * V[..., 2] ** 2).sum(axis=1)
        dJ = 2.0 * (m * (V[..., 0] * A[..., 0] + V[..., 1] * A[..., 1]) + I * V[..., 2] * A[..., 2]).sum(axis=1)
        gx, gy = self.g
        Ep = -(m * (gx * Z[..., 0] + gy * Z[..., 1])).sum(axis=1)
        dEp = -(m * (gx * V[..., 0] + gy * V[..., 1])).sum(axis=1)
        D = np.zeros(B)
        if self.damped:
            rates = self.joint_rates(z, v)
            for k in self.damped:
                D += self.p.joints[k].damping * rates[:, k] ** 2
        sysm = self.sys
        for (ba, pa), (bb, pb), s in self.springs:
            d = sysm.point(z, bb, pb) - sysm.point(z, ba, pa)
            dd = sysm.point_vel(z, v, bb, pb) - sysm.point_vel(z, v, ba, pa)
            ell = np.linalg.norm(d, axis=1)
            dell = np.einsum("bk,bk->b", d, dd) / np.where(ell > 0, ell, 1.0)
            if s.stiffness > 0:
                Ep = Ep + 0.5 * s.stiffness * (ell - s.length) ** 2
                dEp = dEp + s.stiffness * (ell - s.length) * dell
            if s.damping > 0:
                D = D + s.damping * dell ** 2
        cols = [J, dJ, dEp, Ep, D]
        for bp, d, ld in self.loads:
            cols.append(sysm.point(z, *bp) @ d if bp is not None else np.zeros(B))
            if ld.link is not None:
                cols.append(v[:, 3 * self.index[ld.link] + 2].copy())
            else:
                cols.append(sysm.point_vel(z, v, *bp) @ d)
        return np.stack(cols, axis=1)

    def _tables(self):
        p, sysm = self.p, self.sys
        q0, P = self.q0, self.period
        nch = 5 + 2 * len(self.loads)
        self.nch = nch
        info = {}
        sizes = [int(p.table_nodes)] if p.table_nodes else list(TABLE_NODES)
        for N in sizes:
            u = P * np.arange(N) / N
            z, v, a = self.exact(q0 + u, self._coarse_guess(u))
            bridged = self._near_change(q0 + u)
            solved = np.ones(N, bool) if bridged is None else bridged < 0  # (a bridge's nodes are singular by design)
            stride = max(1, -(-N * sysm.nz ** 3 // SVD_BUDGET))
            solved[np.arange(N) % stride != 0] = False
            sv = sysm.singular_values(z[solved])
            bad = sv[:, -1] < COND_TOL * sv[:, 0]
            if bad.any():
                qf = (q0 + u[solved])[np.argmax(bad)]
                raise GeometryError(f"linkage {p.name!r}: dead centre at input angle {_deg(qf)} (the constraint "
                                    f"Jacobian is singular there); the input cannot drive the linkage through it")
            ch = self.channels(z, v, a)
            zp = z.copy()
            zp[:, 2::3] -= self.wrate[None, :] * u[:, None]
            table = PeriodicTable(q0, np.hstack([ch, zp]), period=P)
            um = u + 0.5 * P / N
            zm, vm, am = self.exact(q0 + um, self._coarse_guess(um))
            exact = self.channels(zm, vm, am)
            est = table(q0 + um)[:, :nch]
            scale = np.max(np.abs(exact), axis=0)
            # J' against J per radian where J hardly varies (a parallelogram: J' ≡ 0 but for rounding;
            # the backend's table judges it the same way, mechanisms/table.py)
            scale[1] = max(scale[1], DJ_FLOOR * scale[0], 1e-300)
            scale[2] = max(scale[2], 1e-9 * max(scale[0], 1e-300))
            err = np.abs(est - exact) / np.where(scale > 0, scale, 1.0)[None, :]
            # the solve's conditioning near a change point (σ_min ∝ distance) limits the exact values
            # there, not the table: those midpoints are reported apart (rel_error_near_change_points)
            nearby = self._near_change(q0 + um, NEAR_CHANGE)
            away = slice(None) if nearby is None else nearby < 0
            rel = np.max(err[away], axis=0)
            info = {"nodes": N, "rel_error_J": float(rel[0]), "rel_error_dJ": float(rel[1]),
                    "rel_error_dEp": float(rel[2]), "rel_error_Ep": float(rel[3]),
                    "min_sigma_ratio": float(np.min(sv[:, -1] / sv[:, 0]))}
            if self.changes:
                info.update(period_rad=float(P), change_points_rad=[float(x) for x in self.changes],
                            rel_error_near_change_points=float(np.max(err[~away][:, :3])),
                            bridge_rel_error=self._bridge_error(scale))
            self.table = table
            if max(rel[:3]) <= TABLE_TARGET:
                break
        self.table_info = info

    def _bridge_error(self, scale):
        """Estimated error of the change points' bridges: the channels J, J', E_p' at q* and q* ± half/2
        from the whole stencil against the stencil without its outermost nodes, relative to their
        largest value over the period (the larger of the two interpolants' difference)."""
        worst = 0.0
        for br in self.bridges:
            q = br.q + br.half * np.array([-0.5, 0.0, 0.5])
            t = self._offset(q, br.q)[0]
            L = _lagrange(br.offs, br.weights, t)
            full = self.channels(L @ br.z, L @ br.v, L @ br.a)
            inner = br.offs[1:-1]
            L2 = _lagrange(inner, _bary_weights(inner), t)
            short = self.channels(*(L2 @ x[1:-1] for x in (br.z, br.v, br.a)))
            worst = max(worst, float(np.max(np.abs(full - short)[:, :3] / np.where(scale[:3] > 0, scale[:3], 1.0))))
        return worst
