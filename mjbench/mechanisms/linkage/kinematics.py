"""Configurations of a compiled linkage from its body coordinates (the position solver's results).

Body coordinates z = (x_G, y_G, θ) per moving link (:mod:`mjbench.mechanisms.linkage_kin`, which
holds the constraint equations, Newton, continuation and the periodic tables); from them:
link frames, world points, joint rates per unit input rate, slide displacements; the exact
solve at given input angles (:meth:`KinematicsMixin.exact`) and the configurations interpolated
from the table (:meth:`KinematicsMixin.z_guess`).
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import GeometryError
from .topology import GROUND, _rot2


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
        """(z, v, a) solved at input angles q (array) from guesses (default: the table)."""
        q = np.atleast_1d(np.asarray(q, float))
        z0 = self.z_guess(q) if guess is None else np.atleast_2d(guess)
        z, ok = self.sys.newton(z0, q)
        if not ok.all():
            bad = q[~ok][0]
            raise GeometryError(f"linkage {self.p.name!r}: the position solve does not converge at input angle "
                                f"{_deg(bad)} (q = {bad:.6g} rad)")
        v, a = self.sys.kinematics(z)
        return z, v, a

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
        zp[:, 2::3] += self.w[None, :] * (q - self.q0)[:, None]
        return zp
