"""The MJCF of a linkage (a ``mujoco.MjSpec``), built from its description.

Links are bodies of a kinematic tree (the spanning tree of :mod:`.topology`), hinges about
:data:`~mjbench.mechanisms.base.HINGE_AXIS` and slides named after the description's joints;
every other joint closes its loop with a site ``connect`` equality (:func:`~mjbench.mechanisms.base.closure_solref`);
springs are spatial tendons; the stated pose is the keyframe ``assembled``.  Geoms are massless
drawings (link outlines, pivots, guides, slider blocks).  docs/linkages.md §4.
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import GeometryError
from ..base import HINGE_AXIS, closure_solref, new_spec
from ..linkage_kin import TWO_PI
from .gears import add_gear_equalities, add_gear_geoms
from .topology import GROUND, _ref, _rot2

PALETTE = ([0.85, 0.25, 0.2, 1], [0.2, 0.55, 0.85, 1], [0.3, 0.7, 0.3, 1], [0.95, 0.6, 0.1, 1],
           [0.6, 0.3, 0.7, 1], [0.1, 0.65, 0.65, 1], [0.75, 0.45, 0.3, 1], [0.45, 0.45, 0.8, 1])
GRAY = [0.45, 0.45, 0.5, 1]


def _quat(ang):
    """Quaternion of a rotation by ang (counter-clockwise in the description plane) = about −y."""
    return [math.cos(0.5 * ang), 0.0, -math.sin(0.5 * ang), 0.0]


def _hull(pts):
    """Convex hull (counter-clockwise) of 2-D points (monotone chain)."""
    P = sorted(map(tuple, pts))
    if len(P) <= 2:
        return [np.array(x) for x in P]

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for x in P:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], x) <= 0:
            lower.pop()
        lower.append(x)
    for x in reversed(P):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], x) <= 0:
            upper.pop()
        upper.append(x)
    return [np.array(x) for x in lower[:-1] + upper[:-1]]


def _first_load_point(p):
    """The point of the first load that has one ("link.point"), or None."""
    return next((ld.point for ld in p.loads if ld.point is not None), None)


class MjSpecMixin:
    """The MJCF builder of :class:`~.mechanism.Linkage` (``self.c``: the compiled description)."""

    def build_spec(self, armature: float = 0.0, options=None):
        """MjSpec: links as bodies of a kinematic tree (hinge / slide joints named after the
        description's joints), every other joint a site ``connect`` equality, springs as spatial
        tendons.  ``armature`` [kg·m²] is added to the input joint.  Options as fourbar.py
        (timestep, integrator, solref, solimp, iterations, tolerance)."""
        import mujoco

        c = self.c
        o = dict(options or {})
        h = float(o.get("timestep", 1e-4))
        spec = new_spec(self.name, o, gravity=(float(c.g[0]), 0.0, float(c.g[1])))
        world = spec.worldbody
        world.add_light(pos=[0, -3, 3], dir=[0, 1, -1], diffuse=[0.8, 0.8, 0.8])
        rad = 0.01 * self._extent()  # display sizes (geoms are massless)
        self._ground_geoms(mujoco, world, rad)
        bodies = self._bodies(mujoco, world, armature, rad)
        self._sites(bodies, rad)
        self._closures(mujoco, spec, o, h)
        if c.gears:  # higher pairs: tendon equalities and pitch circles (gears.py)
            add_gear_equalities(self, spec, o, h)
            add_gear_geoms(self, bodies, rad)
        self._keyframe(spec)
        self._springs(spec, rad)
        return spec

    def _ground_geoms(self, mujoco, world, rad):
        """The frame's drawings: a pivot at every revolute joint to the ground, a guide along every
        slide line the ground owns (over the slide's travel)."""
        c, p = self.c, self.params
        ranges = self._slide_ranges()
        for k, j in enumerate(p.joints):
            l1, p1, l2, p2 = c.jlinks[k]
            if GROUND not in (l1, l2):
                continue
            gp = c.pts[GROUND][p1 if l1 == GROUND else p2]
            if j.type == "revolute":
                world.add_geom(name=f"pivot_{j.name}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                               size=[1.8 * rad, 1.5 * rad, 0], pos=[gp[0], 0.0, gp[1]],
                               quat=[0.7071068, 0.7071068, 0, 0], rgba=GRAY, contype=0, conaffinity=0)
            elif l1 == GROUND:
                u = np.array(j.axis, float) / math.hypot(*j.axis)
                lo, hi = ranges.get(k, (0.0, 0.0))
                mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo) + 4 * rad
                ang = math.atan2(u[1], u[0])
                ctr = gp + mid * u
                world.add_geom(name=f"guide_{j.name}", type=mujoco.mjtGeom.mjGEOM_BOX,
                               size=[half, 0.5 * rad, 0.7 * rad], pos=[ctr[0], 2.5 * rad, ctr[1]],
                               quat=_quat(ang), rgba=GRAY, contype=0, conaffinity=0)

    def _bodies(self, mujoco, world, armature, rad) -> dict:
        """One body per link down the spanning tree, its tree joint (hinge about HINGE_AXIS or
        slide), mass properties (I_yy about the hinge axis) and drawings → {link: body}."""
        c, p = self.c, self.params
        bodies = {GROUND: world}
        for e in c.edges:
            parent = bodies[e.parent]
            ang = e.phi if e.kind == "P" else 0.0
            pos = e.p - _rot2(ang) @ e.c
            body = parent.add_body(name=e.child, pos=[pos[0], 0.0, pos[1]], quat=_quat(ang))
            bodies[e.child] = body
            j = p.joints[e.k]
            if e.kind == "R":
                jt = body.add_joint(name=e.name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(HINGE_AXIS),
                                    pos=[e.c[0], 0.0, e.c[1]])
            else:
                ax = _rot2(-ang) @ e.u
                jt = body.add_joint(name=e.name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[ax[0], 0.0, ax[1]])
            jt.damping = [float(j.damping), 0.0, 0.0]
            inputs = p.input_list
            if e.name in inputs:  # the reflected drive inertia on each input joint (one value, or one per input)
                arm = armature[inputs.index(e.name)] if isinstance(armature, (tuple, list)) else armature
                jt.armature = float(arm)
            b = c.index[e.child]
            body.mass = max(float(c.mass[b]), 1e-9)
            body.ipos = [float(c.com[b][0]), 0.0, float(c.com[b][1])]
            Iy = max(float(c.inertia[b]), 1e-12)
            body.inertia = [0.6 * Iy, Iy, 0.6 * Iy]  # only I_yy (hinge axis) matters
            body.explicitinertial = True
            self._link_geoms(mujoco, body, e.child, rad, PALETTE[b % len(PALETTE)])
        return bodies

    def _sites(self, bodies, rad):
        """A site at every named point ("link.point": the closures and tendons attach there) and the
        traced point's site ``trace``."""
        c, p = self.c, self.params
        for name, pts in c.pts.items():
            for k, v in pts.items():
                bodies[name].add_site(name=f"{name}.{k}", pos=[v[0], 0.0, v[1]], size=[1.1 * rad, 0, 0],
                                      rgba=[0.15, 0.15, 0.15, 1])
        if p.trace or _first_load_point(p):
            ref = p.trace or _first_load_point(p)
            lk, pt = _ref(ref)
            v = c.pts[lk][pt]
            bodies[lk].add_site(name="trace", pos=[v[0], 0.0, v[1]], size=[1.6 * rad, 0, 0], rgba=[1, 0.8, 0.1, 1])

    def _closures(self, mujoco, spec, o, h):
        """A site ``connect`` equality at every joint outside the tree (revolute by construction)."""
        p = self.params
        solref, solimp = closure_solref(o, h)
        for k in self.c.closures:
            j = p.joints[k]
            if j.type != "revolute":
                raise GeometryError(f"linkage {p.name!r}: joint {j.name!r} closes a loop made only of prismatic "
                                    f"joints; MJCF loops are closed at revolute joints (add or reorder a revolute)")
            spec.add_equality(name=f"closure_{j.name}", type=mujoco.mjtEq.mjEQ_CONNECT,
                              objtype=mujoco.mjtObj.mjOBJ_SITE, name1=j.at[0], name2=j.at[1],
                              solref=solref, solimp=solimp)

    def _keyframe(self, spec):
        """The assembled stated pose as the keyframe ``assembled`` (a user opening the exported file
        sees it closed)."""
        c = self.c
        vals, _ = self._tree_values(self._stated_z())
        kids = {}
        for e in c.edges:  # MuJoCo numbers bodies (and their joints) depth-first, children in order
            kids.setdefault(e.parent, []).append(e)
        order, stack = [], list(reversed(kids.get(GROUND, [])))
        while stack:
            e = stack.pop()
            order.append(e)
            stack += list(reversed(kids.get(e.child, [])))
        spec.add_key(name="assembled", qpos=[float(vals[e.name]) for e in order])

    def _springs(self, spec, rad):
        """Springs and dampers as spatial tendons between their two sites."""
        for k, (_, _, s) in enumerate(self.c.springs):
            t = spec.add_tendon(name=s.name or f"spring{k}", stiffness=[float(s.stiffness), 0, 0],
                                damping=[float(s.damping), 0, 0], width=1.2 * rad, rgba=[0.9, 0.6, 0.1, 1])
            L0 = float(s.length) if s.length is not None else 0.0
            t.springlength = [L0, L0] if s.stiffness > 0 else [0.0, 0.0]
            t.wrap_site(s.between[0])
            t.wrap_site(s.between[1])

    def _link_geoms(self, mujoco, body, name, rad, rgba):
        pts = np.array(list(self.c.pts[name].values())).reshape(-1, 2)
        uniq = _unique_rows(np.round(pts, 12))
        segs = []
        if len(uniq) == 2:
            segs = [(uniq[0], uniq[1])]
        elif len(uniq) >= 3:
            hull = _hull(uniq)
            segs = [(hull[i], hull[(i + 1) % len(hull)]) for i in range(len(hull))] if len(hull) > 2 else \
                [(hull[0], hull[-1])]
        for a, b in segs:
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[a[0], 0, a[1], b[0], 0, b[1]],
                          size=[rad, 0, 0], rgba=rgba, contype=0, conaffinity=0, mass=0)
        # a slider block at the sliding point of every prismatic joint this link slides on
        for k, j in enumerate(self.params.joints):
            if j.type != "prismatic":
                continue
            l1, p1, l2, p2 = self.c.jlinks[k]
            if l2 != name:
                continue
            v = self.c.pts[name][p2]
            ang = math.atan2(j.axis[1], j.axis[0]) + 0.0  # axis in link-1 axes = link-2 axes rotated by angle
            ang -= float(j.angle)
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[4 * rad, 1.5 * rad, 3 * rad],
                          pos=[v[0], 0.0, v[1]], quat=_quat(ang), rgba=rgba, contype=0, conaffinity=0, mass=0)
        if not segs:
            v = uniq[0]
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[1.5 * rad, 0, 0], pos=[v[0], 0, v[1]],
                          rgba=rgba, contype=0, conaffinity=0, mass=0)

    def _drawing_z(self, n: int):
        """Configurations (B, 3n) spanning the motion, for display sizes: one period in n steps."""
        return self.c.z_guess(self.c.q0 + self.c.period * np.arange(n) / n)

    def _extent(self):
        """Largest span of the drawing over one turn [m] (display sizes)."""
        pts = self.c.world_points(self._drawing_z(90))
        xs = np.concatenate([np.ravel(x) for x, _ in pts.values()])
        ys = np.concatenate([np.ravel(y) for _, y in pts.values()])
        return max(float(np.ptp(xs)), float(np.ptp(ys)), 1e-3)

    def _slide_ranges(self):
        """Travel (min, max) of every ground prismatic joint over one period [m]."""
        d = self.c.slide_positions(self._drawing_z(720))
        return {k: (float(np.nanmin(d[:, k])), float(np.nanmax(d[:, k]))) for k in range(d.shape[1])
                if not np.isnan(d[0, k])}


def _unique_rows(a):
    """``np.unique(a, axis=0)`` for a float array (the rows sorted, each once) without ``np.unique``,
    which imports ``numpy.ma`` (≈ 10 ms) in every process that builds a linkage's model; a negative
    zero (two rows that compare equal with different bits): ``np.unique`` itself."""
    if np.any(np.signbit(a) & (a == 0.0)) or not np.all(np.isfinite(a)):
        return np.unique(a, axis=0)
    rows = sorted({tuple(float(v) for v in r) for r in a})
    return np.array(rows, dtype=a.dtype).reshape(-1, a.shape[1])
