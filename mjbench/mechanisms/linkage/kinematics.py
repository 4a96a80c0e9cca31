"""Configurations of a compiled linkage from its body coordinates (the position solver's results).

Body coordinates z = (x_G, y_G, θ) per moving link (:mod:`mjbench.mechanisms.linkage_kin`, which
holds the constraint equations, Newton, continuation and the periodic tables); from them:
link frames, world points, joint rates per unit input rate, slide displacements; the exact
solve at given input angles (:meth:`KinematicsMixin.exact`) and the configurations interpolated
from the table (:meth:`KinematicsMixin.z_guess`).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ...errors import GeometryError
from ..linkage_kin import TWO_PI
from .topology import GROUND, _rot2

BRIDGE_HALF = 0.02  #: configurations within this of a change point come from its bridge [rad]
BRIDGE_POINTS = 6  #: exact solves on each side of a change point (the bridge's nodes)
#: configurations solved together are chunked so that their dense Jacobians hold at most this many
#: numbers (64 MB): a chain of 81 bars (243 coordinates) solves 142 at a time, a four-bar all at once
EXACT_CHUNK = 1 << 23


def _deg(q):
    return f"{math.degrees(q) % 360.0:.1f}°"


class KinematicsMixin:
    """Configurations of the compiled description (:class:`.model._Compiled`)."""

    def guess(self, q):
        """Rough configuration from the stated link angles, propagated down the tree (the
        closures left open), input link at q."""
        z = np.zeros(3 * self.n)
        pose = {GROUND: (np.zeros(2), 0.0)}
        for e in self.edges:
            oP, thP = pose[e.parent]
            AP = _rot2(thP)
            if e.kind == "R":
                th = q if e.child == self.input_link else float(self.p.links[e.child].angle)
                o = oP + AP @ e.p - _rot2(th) @ e.c
            else:
                th = thP + e.phi
                o = oP + AP @ e.p - _rot2(th) @ e.c
            pose[e.child] = (o, th)
            b = self.index[e.child]
            z[3 * b:3 * b + 2] = o + _rot2(th) @ self.com[b]
            z[3 * b + 2] = th
        return z

    def frames(self, z):
        """Link-frame origins (B, n, 2) and angles (B, n) from body coordinates (B, 3n)."""
        z = np.atleast_2d(z)
        th = z[:, 2::3]
        c, s = np.cos(th), np.sin(th)
        g = z.reshape(z.shape[0], self.n, 3)[:, :, :2]
        cx, cy = self.com[:, 0], self.com[:, 1]
        o = np.stack([g[..., 0] - (c * cx - s * cy), g[..., 1] - (s * cx + c * cy)], axis=-1)
        return o, th

    def world_points(self, z):
        """{"link.point": (x (B,), y (B,))} for every named point (ground included)."""
        o, th = self.frames(z)
        c, s = np.cos(th), np.sin(th)
        out = {}
        B = o.shape[0]
        for name, pts in self.pts.items():
            b = self.index[name]
            for k, v in pts.items():
                if b < 0:
                    out[f"{name}.{k}"] = (np.full(B, v[0]), np.full(B, v[1]))
                else:
                    out[f"{name}.{k}"] = (o[:, b, 0] + c[:, b] * v[0] - s[:, b] * v[1],
                                          o[:, b, 1] + s[:, b] * v[0] + c[:, b] * v[1])
        return out

    def joint_rates(self, z, v):
        """Relative rates of every joint per unit input rate, (B, njoints): revolute θ'_2 − θ'_1
        [rad/rad], prismatic slide rate [m/rad]."""
        z, v = np.atleast_2d(z), np.atleast_2d(v)
        sysm = self.sys
        out = np.empty((z.shape[0], len(self.kjoints)))
        for k, jt in enumerate(self.kjoints):
            wi = v[:, 3 * jt.i + 2] if jt.i >= 0 else 0.0
            wj = v[:, 3 * jt.j + 2] if jt.j >= 0 else 0.0
            if jt.kind == "R":
                out[:, k] = wj - wi
            else:
                Pi, Pj = sysm.point(z, jt.i, jt.si), sysm.point(z, jt.j, jt.sj)
                Vi, Vj = sysm.point_vel(z, v, jt.i, jt.si), sysm.point_vel(z, v, jt.j, jt.sj)
                th = z[:, 3 * jt.i + 2] if jt.i >= 0 else np.zeros(z.shape[0])
                c, s = np.cos(th), np.sin(th)
                Au = np.stack([c * jt.u[0] - s * jt.u[1], s * jt.u[0] + c * jt.u[1]], axis=-1)
                ASu = np.stack([-s * jt.u[0] - c * jt.u[1], c * jt.u[0] - s * jt.u[1]], axis=-1)
                out[:, k] = np.einsum("bk,bk->b", Vj - Vi, Au) + np.einsum("bk,bk->b", Pj - Pi, ASu) * wi
        return out

    def slide_positions(self, z):
        """Slide displacement d of every prismatic joint (B, njoints; NaN for revolute) [m]."""
        z = np.atleast_2d(z)
        out = np.full((z.shape[0], len(self.kjoints)), np.nan)
        for k, jt in enumerate(self.kjoints):
            if jt.kind != "P":
                continue
            Pi, Pj = self.sys.point(z, jt.i, jt.si), self.sys.point(z, jt.j, jt.sj)
            th = z[:, 3 * jt.i + 2] if jt.i >= 0 else np.zeros(z.shape[0])
            c, s = np.cos(th), np.sin(th)
            Au = np.stack([c * jt.u[0] - s * jt.u[1], s * jt.u[0] + c * jt.u[1]], axis=-1)
            out[:, k] = np.einsum("bk,bk->b", Pj - Pi, Au)
        return out

    def exact(self, q, guess=None):
        """(z, v, a) solved at input angles q (array) from guesses (default: the table).  Within
        BRIDGE_HALF of a change point, where the constraint Jacobian is (nearly) singular and v, a
        are not defined by it alone, from the change point's bridge (:meth:`_bridge_eval`)."""
        q = np.atleast_1d(np.asarray(q, float))
        near = self._near_change(q)
        if near is not None:
            z, v, a = (np.empty((len(q), 3 * self.n)) for _ in range(3))
            far = near < 0
            if far.any():
                z[far], v[far], a[far] = self.exact(q[far], None if guess is None else np.atleast_2d(guess)[far])
            for b in np.unique(near[~far]):
                sel = near == b
                z[sel], v[sel], a[sel] = self._bridge_eval(b, q[sel])
            return z, v, a
        z0 = self.z_guess(q) if guess is None else np.atleast_2d(guess)
        chunk = max(1, EXACT_CHUNK // (3 * self.n) ** 2)
        if len(q) > chunk:  # a large linkage: bounded memory (the same result, configuration by configuration)
            parts = [self.exact(q[i:i + chunk], z0[i:i + chunk]) for i in range(0, len(q), chunk)]
            return tuple(np.concatenate(x) for x in zip(*parts))
        z, ok = self.sys.newton(z0, q)
        if not ok.all():
            bad = q[~ok][0]
            raise GeometryError(f"linkage {self.p.name!r}: the position solve does not converge at input angle "
                                f"{_deg(bad)} (q = {bad:.6g} rad)")
        if getattr(self, "changes", None):
            z = self._polish(z, q)
        v, a = self.sys.kinematics(z)
        return z, v, a

    def _polish(self, z, q):
        """One more Newton step after convergence: near a change point the Jacobian's conditioning
        (σ_min ∝ distance) turns the solve's tolerance into a position error; this takes the
        residual to rounding."""
        F = self.sys.phi(z, q)
        return z + self.sys._solve(self.sys.jac(z), -F)

    # ------------------------------------------------------------------ change points
    def _offset(self, q, qc):
        """q − qc reduced into [−period/2, period/2), and the whole periods removed."""
        P = self.period
        d = q - qc
        k = np.floor(d / P + 0.5)
        return d - k * P, k

    def _near_change(self, q, within=None):
        """Index of the change point whose bridge covers each q (−1: none), or None if no q is near one
        (``within``: closer than that [rad] instead of the bridge's half-width)."""
        if not getattr(self, "bridges", None):
            return None
        near = np.full(len(q), -1)
        for b, br in enumerate(self.bridges):
            near[np.abs(self._offset(q, br.q)[0]) < (br.half if within is None else within)] = b
        return near if (near >= 0).any() else None

    def _bridges(self):
        """For every change point q*: exact (z, v, a) at q* ± BRIDGE_HALF·k, k = 1…BRIDGE_POINTS, on the
        followed branch (Newton from the coarse branch, far enough from q* to be well conditioned);
        inside ±BRIDGE_HALF, configurations are their Lagrange interpolant (:meth:`_bridge_eval`):
        the branch is analytic through q*, where the solve alone is singular.  Half-width reduced
        when change points are closer than 14·BRIDGE_HALF."""
        self.bridges = []
        qs = self.changes
        if not qs:
            return
        P = self.period
        gaps = np.diff(np.append(qs, qs[0] + P))
        half = min(BRIDGE_HALF, float(np.min(gaps)) / (2 * BRIDGE_POINTS + 2))
        k = np.arange(1, BRIDGE_POINTS + 1, dtype=float)
        offs = half * np.concatenate([-k[::-1], k])
        for qc in qs:
            qq = qc + offs
            z, ok = self.sys.newton(self._wrapped_guess(qq), qq)
            z = self._polish(z, qq)
            if not ok.all():
                raise GeometryError(f"linkage {self.p.name!r}: the position solve does not converge next to the change "
                                    f"point at input angle {_deg(qc)} (q = {qq[~ok][0]:.6g} rad)")
            v, a = self.sys.kinematics(z)
            self.bridges.append(_Bridge(float(qc), half, offs, z, v, a, _bary_weights(offs)))

    def _bridge_eval(self, b, q):
        """(z, v, a) at input angles q (within the half-width of change point b) from its bridge."""
        br = self.bridges[b]
        t, k = self._offset(q, br.q)
        L = _lagrange(br.offs, br.weights, t)  # (B, points)
        z, v, a = L @ br.z, L @ br.v, L @ br.a
        z[:, 2::3] += (TWO_PI * self.w)[None, :] * k[:, None]
        return z, v, a

    def _wrapped_guess(self, q):
        """Configurations (B, 3n) at any input angles from the coarse branch (whole periods added)."""
        P = self.period
        u = q - self.q0
        k = np.floor(u / P)
        z = self._coarse_guess(u - k * P)
        z[:, 2::3] += (TWO_PI * self.w)[None, :] * k[:, None]
        return z

    def _coarse_guess(self, u):
        qs, Z, V, _ = self.coarse
        du = qs[1] - qs[0]
        x = np.clip(u / du, 0.0, len(qs) - 1 - 1e-12)
        i = np.minimum(np.floor(x).astype(int), len(qs) - 2)
        t = (x - i)[:, None]
        h00, h10, h01, h11 = 2 * t ** 3 - 3 * t ** 2 + 1, t ** 3 - 2 * t ** 2 + t, -2 * t ** 3 + 3 * t ** 2, t ** 3 - t ** 2
        return h00 * Z[i] + h10 * du * V[i] + h01 * Z[i + 1] + h11 * du * V[i + 1]

    def z_guess(self, q):
        """Configurations (B, 3n) interpolated from the table (add the windings)."""
        q = np.atleast_1d(np.asarray(q, float))
        zp = self.table(q)[:, self.nch:]
        zp[:, 2::3] += self.wrate[None, :] * (q - self.q0)[:, None]
        return zp

    @property
    def wrate(self):
        """Mean rate of every link angle along the followed path (whole turns per period) [rad/rad]."""
        return self.w * (TWO_PI / self.period)


#: a change point's bridge: q* [rad], half-width [rad], stencil offsets (2k,), (z, v, a) there, weights
_Bridge = namedtuple("_Bridge", "q half offs z v a weights")


def _bary_weights(x):
    """Barycentric weights of Lagrange interpolation on the nodes x."""
    d = x[:, None] - x[None, :]
    np.fill_diagonal(d, 1.0)
    return 1.0 / np.prod(d, axis=1)


def _lagrange(x, w, t):
    """Lagrange basis (B, nodes) at the points t (none of them a node: the bridge nodes lie outside
    its half-width)."""
    d = np.asarray(t, float)[:, None] - x[None, :]
    c = w[None, :] / d
    return c / c.sum(axis=1, keepdims=True)
