"""The compiled description: everything derived once from a linkage description, cached by content.

:class:`_Compiled` holds the combined mass properties (point masses by the parallel-axis theorem),
the solver's joints (:class:`~mjbench.mechanisms.linkage_kin.KJoint`, points relative to the mass
centres), the MJCF's spanning tree (:mod:`.topology`), springs and loads; :meth:`build` assembles
it, follows the branch over one turn (:mod:`.assembly`) and tabulates the reduced model
(:mod:`.reduced`); configurations come from :mod:`.kinematics`.  :func:`compiled` caches built
descriptions by the hash of their content.
"""
from __future__ import annotations

import hashlib
import math

import numpy as np

from ...compiled import cache
from ..linkage_kin import KJoint, PlanarSystem
from .assembly import AssemblyMixin
from .description import LinkageParams
from .gears import compile_gears
from .kinematics import KinematicsMixin
from .reduced import ReducedMixin
from .topology import GROUND, TreeMixin, _ref


class _Compiled(TreeMixin, KinematicsMixin, AssemblyMixin, ReducedMixin):
    """Everything derived once from a description: mass properties, solver joints, spanning tree,
    the kinematic branch over one turn and the reduced-model table (cached by description)."""

    def __init__(self, p: LinkageParams):
        self.p = p
        self.links = list(p.links)
        self.index = {n: i for i, n in enumerate(self.links)}
        self.index[GROUND] = -1
        n = len(self.links)
        self.n = n
        # link-frame points, combined mass properties (point masses by the parallel-axis theorem)
        self.pts = {GROUND: {k: np.array(v, float) for k, v in p.ground.items()}}
        self.mass, self.inertia, self.com = np.zeros(n), np.zeros(n), np.zeros((n, 2))
        for i, (name, L) in enumerate(p.links.items()):
            self.pts[name] = {k: np.array(v, float) for k, v in L.points.items()}
            c = np.array(L.com, float)
            pm = [(mk, self.pts[name][k]) for k, mk in L.point_masses.items() if mk > 0]
            mt = L.mass + sum(mk for mk, _ in pm)
            ct = (L.mass * c + sum(mk * pk for mk, pk in pm)) / mt if mt > 0 else c
            It = L.inertia + L.mass * float(np.sum((c - ct) ** 2)) + sum(mk * float(np.sum((pk - ct) ** 2)) for mk, pk in pm)
            self.mass[i], self.inertia[i], self.com[i] = mt, It, ct
        span = [1e-6]
        for name in [GROUND] + self.links:
            xy = np.array(list(self.pts[name].values())).reshape(-1, 2)
            if len(xy) > 1:
                span.append(float(np.max(np.linalg.norm(xy[:, None] - xy[None], axis=-1))))
        self.L = max(span)  #: characteristic length [m]: the largest link or frame span
        g = np.array(p.gravity, float)
        self.g = g
        # solver joints (points relative to the mass centre, link axes)
        self.kjoints = []
        self.jlinks = []  # (link1, pt1, link2, pt2)
        for j in p.joints:
            (l1, p1), (l2, p2) = _ref(j.at[0]), _ref(j.at[1])
            self.jlinks.append((l1, p1, l2, p2))
            i1, i2 = self.index[l1], self.index[l2]
            s1 = self.pts[l1][p1] - (self.com[i1] if i1 >= 0 else 0.0)
            s2 = self.pts[l2][p2] - (self.com[i2] if i2 >= 0 else 0.0)
            if j.type == "revolute":
                self.kjoints.append(KJoint(j.name, "R", i1, i2, s1, s2))
            else:
                u = np.array(j.axis, float) / math.hypot(*j.axis)
                self.kjoints.append(KJoint(j.name, "P", i1, i2, s1, s2, u, float(j.angle)))
        self.jindex = {j.name: k for k, j in enumerate(p.joints)}
        kin = p.joints[self.jindex[p.input_list[0]]]
        la, lb = _ref(kin.at[0])[0], _ref(kin.at[1])[0]
        self.input_link = lb if la == GROUND else la
        self.gears = compile_gears(self)  # higher pairs: one solver row each (gears.py)
        self.sys = PlanarSystem(n, self.kjoints, self.index[self.input_link], self.L, self.gears)
        self._tree()
        # springs, loads (points relative to G)
        self.springs = []
        for s in p.springs:
            (la, pa), (lb, pb) = _ref(s.between[0]), _ref(s.between[1])
            self.springs.append((self._body_point(la, pa), self._body_point(lb, pb), s))
        self.loads = []  # (body point of its stroke or None, unit direction or None, spec)
        for ld in p.loads:
            if ld.point is None:  # a torque load with a constant or an input-angle table
                self.loads.append((None, None, ld))
                continue
            lk, pt = _ref(ld.point)
            d = np.array(ld.direction, float) / math.hypot(*ld.direction)
            self.loads.append((self._body_point(lk, pt), d, ld))
        self.damped = [k for k, j in enumerate(p.joints) if j.damping > 0]

    def _body_point(self, link, pt):
        """(body index, point relative to G in link axes; ground: world point)."""
        b = self.index[link]
        return b, self.pts[link][pt] - (self.com[b] if b >= 0 else 0.0)


_CACHE: dict = {}
#: the user cache's folder of built linkages (:func:`mjbench.compiled.cache.store_object`); None: not
#: kept on disk (scripts/bench_parts/linkage.py times the build itself)
DISK_FOLDER: str | None = "linkages"


def compiled(p: LinkageParams) -> _Compiled:
    """The compiled, built linkage of a description (:func:`built`)."""
    return built(p, _Compiled, _CACHE)


def built(p, cls, memory: dict, limit: int = 32, kind: str = ""):
    """``cls(p).build()``, cached in ``memory`` by the description's content and on disk in the user
    cache by its content, the class and the code's version (:func:`mjbench.compiled.cache.code_version`),
    so a second command does not assemble and tabulate it again (nor import ``scipy.optimize`` for it).
    ``kind``: the built object gets ``content_key`` = "kind:<hash of the description>" (its tables' key)."""
    text = p.model_dump_json()
    hit = memory.get(text)  # (by the text itself: its hash is needed only for a new description)
    if hit is None:
        if len(memory) > limit:
            memory.clear()
        key = hashlib.sha1(text.encode()).hexdigest()
        disk = (hashlib.sha256(f"{cls.__qualname__}\n{text}\n{cache.code_version()}".encode()).hexdigest()[:40]
                if DISK_FOLDER else "")
        if disk:
            hit = cache.load_object(DISK_FOLDER, disk, f"built linkage {p.name!r}")
            if type(hit) is not cls or hit.p != p:
                hit = None
        if hit is None:
            hit = cls(p).build()
            if kind:
                hit.content_key = f"{kind}:{key}"
            if disk:
                cache.store_object(DISK_FOLDER, disk, hit)
        memory[text] = hit
    return hit
