"""The kinematic analysis of a linkage (what ``mjbench analyze`` shows of its kinematics).

Over input angles q: velocity ratios of every joint, their limit positions (a ratio's zeros,
refined by secant iterations on exact solves), strokes of the prismatic joints and swings of the
oscillating ones, the input arcs of both strokes; transmission angles where a floating binary link
drives a link farther from the input; toggles (two binary links through a joint collinear).
Definitions: docs/linkages.md §9.
"""
from __future__ import annotations

import math
from collections import deque

import numpy as np

from ..linkage_kin import TWO_PI
from .topology import GROUND


def _vec(pts, a, b):
    """World vector from point a to point b, (x (B,), y (B,))."""
    return pts[b][0] - pts[a][0], pts[b][1] - pts[a][1]


def _fold(u, w):
    """Angle between the lines of u and w folded to [0, π/2] [rad]."""
    dot = np.abs(u[0] * w[0] + u[1] * w[1])
    n = np.hypot(u[0], u[1]) * np.hypot(w[0], w[1])
    return np.arccos(np.clip(dot / np.where(n > 0, n, 1.0), 0.0, 1.0))


def _roots(q, f):
    """Input angles where the sampled periodic f(q) changes sign (linear interpolation)."""
    f = np.asarray(f, float)
    f2 = np.append(f, f[0])
    q2 = np.append(q, q[0] + TWO_PI)
    pos = f2 >= 0.0
    i = np.flatnonzero((pos[:-1] != pos[1:]) & np.isfinite(f2[:-1]) & np.isfinite(f2[1:]))
    den = f2[i + 1] - f2[i]
    return q2[i] - f2[i] * (q2[i + 1] - q2[i]) / np.where(den != 0, den, 1.0)


class AnalysisViewMixin:
    """:meth:`kinematic_analysis` of :class:`~.mechanism.Linkage` (``self.c``: the compiled description)."""

    def kinematic_analysis(self, q):
        """Over input angles q (array): velocity ratios of every joint, slide strokes, transmission
        angles, toggle (collinear) and limit positions.  See docs/linkages.md §9 for definitions."""
        c = self.c
        q = np.asarray(q, float)
        z, v, _ = c.exact(q)
        out = {"ratios": {}, "ratio_units": {}, "strokes_m": {}, "swings_deg": {}, "stroke_arcs_deg": {},
               "transmission": {}, "toggles": {}, "limit_positions": {}}
        self._joint_rows(q, z, v, out)
        self._transmission_and_toggles(q, z, v, out)
        return out

    def _joint_rows(self, q, z, v, out):
        """Into ``out``: every joint's velocity ratio and limit positions, a slide's stroke, a swing,
        the input arcs of the two strokes of an oscillating joint."""
        c, p = self.c, self.params
        rates = c.joint_rates(z, v)
        slides = c.slide_positions(z)
        th = z[:, 2::3]
        for k, j in enumerate(p.joints):
            if j.name == p.input:
                continue
            out["ratios"][j.name] = rates[:, k]
            out["ratio_units"][j.name] = "rad/rad" if j.type == "revolute" else "m/rad"
            roots = self._refine(_roots(q, rates[:, k]), lambda x, k=k: c.joint_rates(*c.exact(x)[:2])[:, k])
            out["limit_positions"][j.name] = [float(x) for x in roots]
            if j.type == "prismatic":  # stroke: extremes at the limit positions (exact solve there)
                ext = slides[:, k]
                if len(roots):
                    ext = np.concatenate([ext, c.slide_positions(c.exact(roots)[0])[:, k]])
                out["strokes_m"][j.name] = float(np.ptp(ext))
            else:  # swing of a joint that does not turn fully (relative angle range)
                jt = c.kjoints[k]
                rel = (th[:, jt.j] if jt.j >= 0 else 0.0) - (th[:, jt.i] if jt.i >= 0 else 0.0)
                w = (c.w[jt.j] if jt.j >= 0 else 0.0) - (c.w[jt.i] if jt.i >= 0 else 0.0)
                if w == 0 and len(roots):
                    zr = c.exact(roots)[0]
                    relr = (zr[:, 3 * jt.j + 2] if jt.j >= 0 else 0.0) - (zr[:, 3 * jt.i + 2] if jt.i >= 0 else 0.0)
                    out["swings_deg"][j.name] = float(np.degrees(np.ptp(np.concatenate([rel, np.atleast_1d(relr)]))))
            if len(roots) == 2:  # the two strokes of an oscillating joint: input arcs with ds/dq > 0 and < 0
                a1 = float((roots[1] - roots[0]) % TWO_PI)
                mid = roots[0] + 0.5 * a1
                up = float(np.interp(mid, q, rates[:, k], period=TWO_PI)) > 0
                out["stroke_arcs_deg"][j.name] = {"increasing": math.degrees(a1 if up else TWO_PI - a1),
                                                  "decreasing": math.degrees(TWO_PI - a1 if up else a1)}

    def _binary_links(self):
        """(binary {link: its two revolute points} of the links with exactly two revolute points and
        no slide, couplers: the binary links not joined to the ground — floating two-force members)."""
        c, p = self.c, self.params
        rpts = {n: [] for n in c.links}
        prism = {n: [] for n in c.links}
        for k, j in enumerate(p.joints):
            l1, p1, l2, p2 = c.jlinks[k]
            for lk, pt in ((l1, p1), (l2, p2)):
                if lk != GROUND:
                    (rpts if j.type == "revolute" else prism)[lk].append((k, pt))
        grounded = {lk for l1, _, l2, _ in c.jlinks if GROUND in (l1, l2) for lk in (l1, l2)}
        binary = {n: sorted({pt for _, pt in v}) for n, v in rpts.items()}
        binary = {n: v for n, v in binary.items() if len(v) == 2 and not prism[n]}
        couplers = {n for n in binary if n not in grounded}
        return binary, couplers

    def _transmission_and_toggles(self, q, z, v, out):
        """Into ``out``: the transmission angle at every joint where a floating binary link drives a
        link farther from the input, and the toggles of every joint between two binary links."""
        c, p = self.c, self.params
        pts = c.world_points(z)
        binary, couplers = self._binary_links()
        dist = self._distances()
        for k, j in enumerate(p.joints):
            if j.type != "revolute":
                continue
            l1, p1, l2, p2 = c.jlinks[k]
            if GROUND in (l1, l2):
                continue
            for L, pL, K, pK in ((l1, p1, l2, p2), (l2, p2, l1, p1)):
                if L not in couplers or K == c.input_link or dist.get(K, 0) <= dist.get(L, 0):
                    continue
                other = [x for x in binary[L] if x != pL][0]
                line = _vec(pts, f"{L}.{pL}", f"{L}.{other}")
                mu = self._mu(k, K, pK, line, z, v, pts)
                if mu is not None:
                    out["transmission"][f"{j.name} ({L} on {K})"] = mu
            if l1 in binary and l2 in binary:  # toggle: their lines through the joint become collinear
                out["toggles"][j.name] = self._toggles(q, pts, binary, l1, p1, l2, p2)

    def _toggles(self, q, pts, binary, l1, p1, l2, p2):
        """Input angles where the binary links l1, l2 through their joint (points p1, p2) are
        collinear: [{q, kind ("folded" | "extended"), links}]."""
        c = self.c
        o1 = [x for x in binary[l1] if x != p1][0]
        o2 = [x for x in binary[l2] if x != p2][0]
        u1 = _vec(pts, f"{l1}.{o1}", f"{l1}.{p1}")
        u2 = _vec(pts, f"{l2}.{o2}", f"{l2}.{p2}")
        cross = u1[0] * u2[1] - u1[1] * u2[0]
        dot = u1[0] * u2[0] + u1[1] * u2[1]

        def crossf(x):
            pp = c.world_points(c.exact(x)[0])
            a1, a2 = _vec(pp, f"{l1}.{o1}", f"{l1}.{p1}"), _vec(pp, f"{l2}.{o2}", f"{l2}.{p2}")
            return a1[0] * a2[1] - a1[1] * a2[0]

        roots = self._refine(_roots(q, cross), crossf)
        kinds = ["folded" if np.interp(r, q, dot) > 0 else "extended" for r in roots]
        return [{"q": float(r), "kind": kd, "links": [l1, l2]} for r, kd in zip(roots, kinds)]

    @staticmethod
    def _refine(roots, fn, iters=4, h=1e-4):
        """Secant iterations on exact evaluations fn(q_array) from the grid's linear roots."""
        r = np.asarray(roots, float)
        if len(r) == 0:
            return r
        a, b = r - h, r + h
        fa, fb = fn(a), fn(b)
        for _ in range(iters):
            den = np.where(fb != fa, fb - fa, 1.0)
            new = b - fb * (b - a) / den
            a, fa = b, fb
            b, fb = new, fn(new)
        return np.where(np.isfinite(b) & (np.abs(b - r) < 0.05), b, r)

    def _distances(self):
        """Joint-graph distance of every link from the input link, not passing through the ground."""
        c = self.c
        adj = {n: set() for n in c.links}
        for l1, _, l2, _ in c.jlinks:
            if GROUND not in (l1, l2):
                adj[l1].add(l2)
                adj[l2].add(l1)
        dist, dq = {c.input_link: 0}, deque([c.input_link])
        while dq:
            u = dq.popleft()
            for w in adj[u]:
                if w not in dist:
                    dist[w] = dist[u] + 1
                    dq.append(w)
        return dist

    def _mu(self, k, K, pK, line, z, v, pts):
        """Transmission angle at joint k where the binary link (force along ``line``) drives link K
        at its point pK: against K's ground pivot arm, its ground slide, else its point velocity."""
        c, p = self.c, self.params
        for kk, j in enumerate(p.joints):
            l1, p1, l2, p2 = c.jlinks[kk]
            if {l1, l2} != {K, GROUND}:
                continue
            if j.type == "revolute":
                pkO = p2 if l2 == K else p1
                if pkO == pK:
                    continue
                arm = _vec(pts, f"{K}.{pkO}", f"{K}.{pK}")
                return _fold(line, arm)
            u = np.array(j.axis, float)
            if l2 == K:  # the ground owns the line: its direction is fixed
                ang = _fold(line, (np.full_like(line[0], u[0]), np.full_like(line[0], u[1])))
                return 0.5 * np.pi - ang
        b, s_ = c._body_point(K, pK)
        vel = c.sys.point_vel(z, v, b, s_)
        mu = 0.5 * np.pi - _fold(line, (vel[:, 0], vel[:, 1]))
        speed = np.hypot(vel[:, 0], vel[:, 1])
        return np.where(speed > 1e-9 * c.L, mu, np.nan)
