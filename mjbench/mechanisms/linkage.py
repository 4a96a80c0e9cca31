"""Generic single-DOF planar linkage from a link/joint description (``[mechanism] type = "linkage"``).

Description (docs/linkages.md has the full reference and examples):

* ``ground``: named points of the frame (pivots, points on slide lines) [m];
* ``links.NAME``: rigid links — ``mass``, ``com`` (mass centre in the link frame), ``inertia``
  (about the mass centre, normal to the plane), ``points`` (named, in the link frame), optional
  ``point_masses`` (bearings, tools at named points) and ``angle`` (approximate angle of the link
  frame in the stated pose: it picks the assembly branch);
* ``joints``: revolute (``at = ["crank.B", "coupler.B"]``) or prismatic (``at = ["ground.G",
  "ram.P"]``, ``axis`` = slide direction in the first link's frame, ``angle`` = fixed θ₂ − θ₁);
  optional viscous ``damping``;
* ``input``: the driven joint (revolute, ground → input link; q = angle of the input link's frame);
  ``input_angle``: q of the stated pose; ``gravity`` (vector in the plane);
* optional ``springs`` (linear spring + damper between two points) and ``loads`` (a force on a
  point along a fixed direction, constant or a table of the point's coordinate, optionally only
  on one stroke of the point).

From that one description come two independent models:

* the **reduced model** from our own kinematics (:mod:`linkage_kin`): Newton position solve of the
  loop-closure equations in body coordinates, branch followed by continuation from the stated pose
  over one input turn; velocity coefficients v = dz/dq from the constraint Jacobian and their
  derivatives a = dv/dq from the velocity-product terms (analytic, no differencing); then
  J = vᵀMv, J' = 2vᵀMa, E_p' = −Σ m g·v_G + Σ k (ℓ − ℓ₀) ℓ'.  Tabulated on a uniform grid over
  one turn (periodic cubic splines; accuracy measured at the interval midpoints against the exact
  solve and stored in ``table_info``);
* the **MJCF** (:meth:`Linkage.build_spec`): a kinematic tree (spanning tree of the joint graph,
  prismatic joints preferred as tree joints) with every other joint closed by a ``connect``
  equality between sites (solref/solimp as fourbar.py), springs as spatial tendons, point loads
  and the damping of loop-closing hinges as generalised forces (``multibody_load``, from the
  tree's own kinematics; only the on/off stroke of a gated load is read from the description's
  kinematics).

In MuJoCo the plane (x, y) maps to (x, z); hinges turn about −y (angles counter-clockwise as in
the description), so gravity (g_x, g_y) becomes (g_x, 0, g_y).
"""
from __future__ import annotations

import hashlib
import math
from collections import deque, namedtuple
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from .. import compiled as C
from ..backends.table import table_model
from ..compiled import law
from ..errors import GeometryError
from ..schema import OptQ, Q, Strict
from . import register
from .base import Mechanism, closure_solref, new_spec
from .linkage_kin import KJoint, PeriodicTable, PlanarSystem, SolveError, TWO_PI, ptable_channel

AXIS = (0.0, -1.0, 0.0)  #: hinge axis in MuJoCo: description angles are counter-clockwise in (x, z)
GROUND = "ground"
COARSE_STEPS = 90  #: continuation steps over one turn (subdivided automatically where needed)
TABLE_NODES = (2048, 4096, 8192, 16384)  #: grid sizes tried until the table is accurate enough
TABLE_TARGET = 1e-10  #: target relative interpolation error of J, J', E_p' (max over a turn / max |·|)
COND_TOL = 1e-9  #: σ_min/σ_max of the scaled constraint Jacobian below this = singular (dead centre)
PALETTE = ([0.85, 0.25, 0.2, 1], [0.2, 0.55, 0.85, 1], [0.3, 0.7, 0.3, 1], [0.95, 0.6, 0.1, 1],
           [0.6, 0.3, 0.7, 1], [0.1, 0.65, 0.65, 1], [0.75, 0.45, 0.3, 1], [0.45, 0.45, 0.8, 1])

Length = Q("length", plausible=False)
Point = tuple[Length, Length]


# ============================================================================ description (schema)
class LinkSpec(Strict):
    """``[mechanism.links.NAME]``: a rigid link.  Frame: any; points, mass centre in it."""

    mass: Q("mass", ge=0.0, what="a link mass") = Field(description="link mass")
    com: Point = Field((0.0, 0.0), description="mass centre in the link frame")
    inertia: Q("inertia", ge=0.0, what="a link inertia") = Field(description="inertia about the mass centre, normal to the plane")
    points: dict[str, Point] = Field(description="named points in the link frame, e.g. {A = [0, 0], B = [0.1, 0]}")
    angle: Q("angle") = Field(0.0, description="approximate angle of the link frame in the stated pose (assembly branch)")
    point_masses: dict[str, Q("mass", ge=0.0)] = Field(default_factory=dict,
                                                        description="point masses at named points (bearings, tools)")

    @model_validator(mode="after")
    def _pm(self):
        bad = [k for k in self.point_masses if k not in self.points]
        if bad:
            raise PydanticCustomError("mjbench_value", "point_masses at {b}: not among the link's points {p}",
                                      {"b": bad, "p": sorted(self.points)})
        if not self.points:
            raise PydanticCustomError("mjbench_value", "a link needs at least one named point")
        return self


class JointSpec(Strict):
    """``[[mechanism.joints]]``: a revolute or prismatic joint between two links (or ground)."""

    name: str
    type: Literal["revolute", "prismatic"] = "revolute"
    at: tuple[str, str] = Field(description='["link1.point", "link2.point"] ("ground.NAME" for a frame point)')
    axis: tuple[float, float] | None = Field(None, description="prismatic: slide direction in link 1's frame")
    angle: Q("angle") = Field(0.0, description="prismatic: fixed relative angle θ_link2 − θ_link1")
    damping: float = Field(0.0, ge=0.0, description="viscous friction [N·m·s/rad revolute, N·s/m prismatic]")

    @model_validator(mode="after")
    def _axis(self):
        if self.type == "prismatic":
            if self.axis is None:
                raise PydanticCustomError("mjbench_value", "joint {n}: a prismatic joint needs axis = [ux, uy] "
                                          "(slide direction in the first link's frame)", {"n": repr(self.name)})
            if not math.hypot(*self.axis) > 0:
                raise PydanticCustomError("mjbench_value", "joint {n}: axis = {a} has zero length",
                                          {"n": repr(self.name), "a": list(self.axis)})
        elif self.axis is not None:
            raise PydanticCustomError("mjbench_value", "joint {n}: axis is for prismatic joints only", {"n": repr(self.name)})
        return self


class SpringSpec(Strict):
    """``[[mechanism.springs]]``: linear spring and/or damper between two points."""

    name: str = ""
    between: tuple[str, str] = Field(description='["link.point", "link.point"]')
    stiffness: Q("lin_stiffness", ge=0.0, plausible=False) = 0.0
    length: OptQ("length", ge=0.0) = Field(None, description="free length (required with stiffness)")
    damping: Q("lin_damping", ge=0.0) = 0.0

    @model_validator(mode="after")
    def _len(self):
        if self.stiffness > 0 and self.length is None:
            raise PydanticCustomError("mjbench_value", "spring {b}: stiffness > 0 needs a free length",
                                      {"b": list(self.between)})
        return self


class LoadSpec(Strict):
    """``[[mechanism.loads]]``: a force on a point along a fixed direction (world frame), or a
    torque on a link (``link``).

    **Point load** (``point``, ``direction``): magnitude ``force`` (constant) or a table ``s``/``F``
    of the point's coordinate along the direction, s = P·d [m] (piecewise linear, constant beyond
    the ends).  ``active``: always, or only on the stroke where — with the input turning forward
    (q increasing) — the point moves along (``stroke_along``) or against (``stroke_against``) the
    direction, i.e. where ds/dq > 0 or < 0.  The gate depends on the input angle only (a process
    timed by the stroke, as seed 004's working-stroke window), not on the momentary direction of
    rotation.

    **Torque load** (``link``): a torque T on the link, counter-clockwise positive in the
    description's plane, reacted by the frame (a brake, a process torque, a motor on the frame
    driving that link).  Magnitude ``torque`` (constant) or a table ``T`` against the input angle
    ``q`` [rad] (piecewise linear in the angle reduced into [q₀, q₀ + 2π), q₀ the first entry;
    constant beyond the ends) or against a point's stroke ``s`` (then ``point`` and ``direction``
    define s = P·d as for a point load).  ``active``: always, or only where the link turns along
    (``stroke_along``: dθ_link/dq > 0) or against (``stroke_against``: dθ_link/dq < 0) the torque's
    positive sense as the input turns forward.  Its generalised force on the input is
    T·dθ_link/dq (virtual work)."""

    name: str = ""
    point: str | None = Field(None, description='"link.point": the loaded point (a torque load: the point of its stroke table)')
    direction: tuple[float, float] | None = Field(None, description="direction of a positive force / of the stroke s (normalised)")
    force: Q("force", plausible=False) | None = None
    s: list[Length] | None = None
    F: list[Q("force", plausible=False)] | None = None
    link: str | None = Field(None, description="torque load: the link the torque acts on (reaction on the frame)")
    torque: Q("torque", plausible=False) | None = Field(None, description="torque load: constant torque, counter-clockwise")
    q: list[Q("angle")] | None = Field(None, description="torque load: input angles of the table T(q)")
    T: list[Q("torque", plausible=False)] | None = Field(None, description="torque load: torques of the table (against q or s)")
    active: Literal["always", "stroke_along", "stroke_against"] = "always"

    @model_validator(mode="after")
    def _law(self):
        if self.link is not None:
            return self._torque_law()
        what = self.point or "?"
        extra = [k for k in ("torque", "q", "T") if getattr(self, k) is not None]
        if extra:
            raise PydanticCustomError("mjbench_value", "load on {p}: {k} belong to a torque load (give link = ...)",
                                      {"p": what, "k": ", ".join(extra)})
        if self.point is None or self.direction is None:
            raise PydanticCustomError("mjbench_value", "a load needs point and direction (a force on a point) or "
                                      "link (a torque on a link)")
        if not math.hypot(*self.direction) > 0:
            raise PydanticCustomError("mjbench_value", "load on {p}: direction has zero length", {"p": self.point})
        table = self.s is not None or self.F is not None
        if (self.force is None) == (not table):
            raise PydanticCustomError("mjbench_value", "load on {p}: give either force or the table s, F",
                                      {"p": self.point})
        if table:
            if self.s is None or self.F is None or len(self.s) != len(self.F) or len(self.s) < 2:
                raise PydanticCustomError("mjbench_value", "load on {p}: s and F need the same length >= 2",
                                          {"p": self.point})
            _increasing(self.s, "s", self.point)
        return self

    def _torque_law(self):
        where = f"link {self.link}"
        if self.force is not None or self.F is not None:
            raise PydanticCustomError("mjbench_value", "torque load on {w}: give torque or the table T (force and F "
                                      "are a point load's)", {"w": where})
        if (self.torque is None) == (self.T is None):
            raise PydanticCustomError("mjbench_value", "torque load on {w}: give either torque or the table T with q "
                                      "(input angles) or s (a point's stroke)", {"w": where})
        if self.T is not None:
            if (self.q is None) == (self.s is None):
                raise PydanticCustomError("mjbench_value", "torque load on {w}: the table T needs exactly one of q "
                                          "(input angles [rad]) or s (the stroke of point along direction [m])",
                                          {"w": where})
            x = self.q if self.q is not None else self.s
            if len(x) != len(self.T) or len(x) < 2:
                raise PydanticCustomError("mjbench_value", "torque load on {w}: {a} and T need the same length >= 2",
                                          {"w": where, "a": "q" if self.q is not None else "s"})
            _increasing(x, "q" if self.q is not None else "s", where)
            if self.q is not None and not self.q[-1] - self.q[0] <= 2.0 * math.pi + 1e-12:
                raise PydanticCustomError("mjbench_value", "torque load on {w}: the angles q span {d:.4g} rad, more than "
                                          "one turn (2π)", {"w": where, "d": self.q[-1] - self.q[0]})
        elif self.q is not None or self.s is not None:
            raise PydanticCustomError("mjbench_value", "torque load on {w}: q or s without a table T", {"w": where})
        stroke = self.s is not None
        if stroke and (self.point is None or self.direction is None):
            raise PydanticCustomError("mjbench_value", "torque load on {w}: a table against the stroke s needs point "
                                      "and direction (s = P·d)", {"w": where})
        if not stroke and (self.point is not None or self.direction is not None):
            raise PydanticCustomError("mjbench_value", "torque load on {w}: point and direction define the stroke of "
                                      "a table T(s) and would be ignored here", {"w": where})
        if stroke and not math.hypot(*self.direction) > 0:
            raise PydanticCustomError("mjbench_value", "torque load on {w}: direction has zero length", {"w": where})
        return self


def _increasing(x, name, where):
    if any(b <= a for a, b in zip(x, x[1:])):
        raise PydanticCustomError("mjbench_value", "load on {p}: {n} must be increasing", {"p": where, "n": name})


class LinkageParams(Strict):
    """``[mechanism] type = "linkage"``: a single-DOF planar linkage (docs/linkages.md)."""

    type: Literal["linkage"] = "linkage"
    name: str = "linkage"
    ground: dict[str, Point] = Field(default_factory=dict, description="named frame points [m]")
    links: dict[str, LinkSpec]
    joints: list[JointSpec]
    input: str = Field(description="name of the driven joint (revolute, ground → input link)")
    input_angle: Q("angle") = Field(0.0, description="input angle q of the stated pose (link angles)")
    gravity: tuple[Q("acceleration", plausible=False), Q("acceleration", plausible=False)] = Field(
        (0.0, -9.81), description="gravity in the plane [m/s²] ((0, 0): plane horizontal)")
    springs: list[SpringSpec] = Field(default_factory=list)
    loads: list[LoadSpec] = Field(default_factory=list)
    trace: str | None = Field(None, description='"link.point" traced in videos (default: the first load point)')
    table_nodes: int | None = Field(None, ge=64, le=65536, description="grid of the reduced-model table (default: automatic)")

    @field_validator("links")
    @classmethod
    def _names(cls, v):
        if GROUND in v:
            raise PydanticCustomError("mjbench_value", "'ground' is reserved for the frame: rename the link")
        for k in v:
            if not k or any(ch in k for ch in ". /"):
                raise PydanticCustomError("mjbench_value", "link name {k!r}: no '.', '/' or spaces", {"k": k})
        return v

    @model_validator(mode="after")
    def _topology(self):
        problems = topology_problems(self)
        if problems:
            raise PydanticCustomError("mjbench_value", "{m}", {"m": "; ".join(problems)})
        return self


def _ref(text):
    """'link.point' → (link, point)."""
    if not isinstance(text, str) or text.count(".") != 1:
        return None, None
    a, b = text.split(".")
    return a, b


def topology_problems(p: LinkageParams) -> list:
    """Structural problems of a description (unknown links/points, duplicates, zero-length links,
    input joint, connectivity, input not in a loop), each naming the element."""
    out = []
    names = set(p.links)
    pts = {GROUND: dict(p.ground), **{k: dict(v.points) for k, v in p.links.items()}}
    seen = set()

    def check_ref(ref, where):
        link, pt = _ref(ref)
        if link is None:
            out.append(f"{where}: {ref!r} is not 'link.point'")
            return None
        if link not in pts:
            out.append(f"{where}: link {link!r} is not defined (links: {', '.join(sorted(names)) or 'none'}, ground)")
            return None
        if pt not in pts[link]:
            out.append(f"{where}: link {link!r} has no point {pt!r} (points: {', '.join(sorted(pts[link])) or 'none'})")
            return None
        return link, pt

    edges = []
    for k, j in enumerate(p.joints):
        where = f"joints[{k}] ({j.name!r})"
        if j.name in seen:
            out.append(f"{where}: joint name used twice")
        seen.add(j.name)
        a = check_ref(j.at[0], where)
        b = check_ref(j.at[1], where)
        if a and b:
            if a[0] == b[0]:
                out.append(f"{where}: joins link {a[0]!r} to itself")
            else:
                edges.append((j.name, a[0], b[0], j.type))
    for k, s in enumerate(p.springs):
        for ref in s.between:
            check_ref(ref, f"springs[{k}]")
    for k, ld in enumerate(p.loads):
        if ld.point is not None:
            check_ref(ld.point, f"loads[{k}]")
        if ld.link is not None and ld.link not in names:
            out.append(f"loads[{k}]: link {ld.link!r} is not a moving link (links: {', '.join(sorted(names)) or 'none'}); "
                       f"a torque on the frame does no work")
    if p.trace is not None:
        check_ref(p.trace, "trace")
    # zero-length links: every point used by a revolute joint at the same place
    for name, L in p.links.items():
        used = set()
        for j in p.joints:
            if j.type != "revolute":
                continue
            for ref in j.at:
                lk, pt = _ref(ref)
                if lk == name and pt in L.points:
                    used.add(pt)
        if len(used) >= 2:
            xy = np.array([L.points[u] for u in sorted(used)])
            span = float(np.max(np.linalg.norm(xy[:, None, :] - xy[None, :, :], axis=-1)))
            if span <= 1e-9:
                out.append(f"links.{name}: zero length: its joint points {', '.join(sorted(used))} coincide")
    # input joint
    jin = next((j for j in p.joints if j.name == p.input), None)
    if jin is None:
        out.append(f"input = {p.input!r}: no joint of that name (joints: {', '.join(j.name for j in p.joints)})")
    elif jin.type != "revolute":
        out.append(f"input = {p.input!r}: the input joint must be revolute (a crank driven through the gearbox)")
    else:
        la, lb = _ref(jin.at[0])[0], _ref(jin.at[1])[0]
        if GROUND not in (la, lb):
            out.append(f"input = {p.input!r}: the input joint must connect the ground to the input link "
                       f"(the motor sits on the frame); it joins {la!r} and {lb!r}")
    if out:
        return out
    # connectivity: every link reachable from ground
    adj = {n: [] for n in list(names) + [GROUND]}
    for nm, a, b, _ in edges:
        adj[a].append((b, nm))
        adj[b].append((a, nm))
    reach, dq = {GROUND}, deque([GROUND])
    while dq:
        u = dq.popleft()
        for w, _ in adj[u]:
            if w not in reach:
                reach.add(w)
                dq.append(w)
    lost = sorted(names - reach)
    if lost:
        out.append(f"links {', '.join(lost)}: not connected to the ground through joints")
        return out
    # the input joint must be in a closed loop (not a bridge of the joint graph)
    a, b = _ref(jin.at[0])[0], _ref(jin.at[1])[0]
    reach, dq = {a}, deque([a])
    while dq:
        u = dq.popleft()
        for w, nm in adj[u]:
            if nm == jin.name:
                continue
            if w not in reach:
                reach.add(w)
                dq.append(w)
    if b not in reach:
        out.append(f"input = {p.input!r}: the input joint is not in a closed loop (nothing but this joint "
                   f"connects {b if a == GROUND else a!r} to the ground), so it drives no linkage")
    return out


# ============================================================================ compiled description
class _Edge:
    """A tree joint oriented parent → child (link frames): revolute at p (parent) / c (child);
    prismatic: the child moves by d·u along the parent's axis u, relative angle phi."""

    __slots__ = ("k", "name", "kind", "parent", "child", "p", "c", "u", "phi", "line_first")

    def __init__(self, **kw):
        for k, v in kw.items():
            setattr(self, k, v)


def _deg(q):
    return f"{math.degrees(q) % 360.0:.1f}°"


def _rot2(th):
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s], [s, c]])


class _Compiled:
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
        kin = p.joints[self.jindex[p.input]]
        la, lb = _ref(kin.at[0])[0], _ref(kin.at[1])[0]
        self.input_link = lb if la == GROUND else la
        self.sys = PlanarSystem(n, self.kjoints, self.index[self.input_link], self.L)
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

    # ------------------------------------------------------------------ spanning tree
    def _tree(self):
        """Kruskal: input joint first, then prismatic joints, then revolute joints to the ground,
        then the other revolute joints (closures are then revolute, ``connect`` equalities, away
        from the frame where possible: a shallow tree).  Oriented from the ground by BFS."""
        p = self.p
        order = [self.jindex[p.input]]
        order += [k for k, j in enumerate(p.joints) if j.type == "prismatic" and k not in order]
        order += [k for k, j in enumerate(p.joints) if GROUND in (self.jlinks[k][0], self.jlinks[k][2])
                  and k not in order]
        order += [k for k, j in enumerate(p.joints) if k not in order]
        root = {n: n for n in self.links + [GROUND]}

        def find(x):
            while root[x] != x:
                root[x] = root[root[x]]
                x = root[x]
            return x

        tree, self.closures = [], []
        for k in order:
            l1, _, l2, _ = self.jlinks[k]
            a, b = find(l1), find(l2)
            if a != b:
                root[a] = b
                tree.append(k)
            else:
                self.closures.append(k)
        self.closures.sort()
        adj = {n: [] for n in self.links + [GROUND]}
        for k in tree:
            l1, _, l2, _ = self.jlinks[k]
            adj[l1].append((l2, k))
            adj[l2].append((l1, k))
        self.edges, self.parent_of = [], {GROUND: None}
        dq = deque([GROUND])
        while dq:
            u = dq.popleft()
            for w, k in sorted(adj[u], key=lambda t: order.index(t[1])):
                if w in self.parent_of:
                    continue
                self.parent_of[w] = (u, k)
                dq.append(w)
                self.edges.append(self._edge(k, u, w))
        self.tree = tree

    def _edge(self, k, parent, child):
        j = self.p.joints[k]
        l1, p1, l2, p2 = self.jlinks[k]
        first = parent == l1
        pp = self.pts[parent][p1 if first else p2]
        cc = self.pts[child][p2 if first else p1]
        if j.type == "revolute":
            return _Edge(k=k, name=j.name, kind="R", parent=parent, child=child, p=pp, c=cc, u=None, phi=0.0,
                         line_first=first)
        u = np.array(j.axis, float) / math.hypot(*j.axis)
        phi0 = float(j.angle)
        if first:  # parent owns the line
            return _Edge(k=k, name=j.name, kind="P", parent=parent, child=child, p=pp, c=cc, u=u, phi=phi0,
                         line_first=True)
        return _Edge(k=k, name=j.name, kind="P", parent=parent, child=child, p=pp, c=cc,
                     u=-(_rot2(-phi0) @ u), phi=-phi0, line_first=False)

    def cycle_of(self, k):
        """Joint names of the fundamental loop closed by joint k (tree path + k)."""
        l1, _, l2, _ = self.jlinks[k]

        def path(x):
            out = []
            while self.parent_of.get(x) is not None:
                u, e = self.parent_of[x]
                out.append((x, e))
                x = u
            return out

        pa, pb = path(l1), path(l2)
        ea, eb = [e for _, e in pa], [e for _, e in pb]
        common = set(ea) & set(eb)
        ks = [e for e in ea if e not in common] + [e for e in eb if e not in common] + [k]
        return [self.p.joints[e].name for e in sorted(set(ks))]

    # ------------------------------------------------------------------ configurations
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

    # ------------------------------------------------------------------ dynamics channels
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

    # ------------------------------------------------------------------ the branch over one turn
    def build(self):
        """Assemble at the stated pose, check the mobility, follow the branch over one input turn
        and tabulate the reduced model.  GeometryError naming joints and input angles otherwise."""
        p, sysm = self.p, self.sys
        q0 = float(p.input_angle)
        self.q0 = q0
        z_free, res_free = sysm.assemble(self.guess(q0), q0, free=True)
        if res_free < 1e-9:  # the loops close near the stated pose (input free): count the freedom there
            self._mobility(z_free)
        z_ref, res = sysm.assemble(z_free if res_free < 1e-9 else self.guess(q0), q0)
        if not res < 1e-9:
            self._no_assembly(q0, z_ref)
        if not res_free < 1e-9:
            self._mobility(z_ref)
        try:
            qs, Z, V, A = sysm.continuation(z_ref, q0, TWO_PI, COARSE_STEPS, cond_tol=COND_TOL)
        except SolveError as e:
            self._branch_failure(e, z_ref, q0)
        dz = Z[-1] - Z[0]
        w = np.round(dz[2::3] / TWO_PI)
        pos_err = np.max(np.abs(np.delete(dz, np.s_[2::3]))) / self.L if self.n else 0.0
        ang_err = np.max(np.abs(dz[2::3] - TWO_PI * w))
        if pos_err > 1e-7 or ang_err > 1e-7:
            raise GeometryError(
                f"linkage {p.name!r}: after one input turn from the stated pose the linkage arrives in a different "
                f"assembly (position gap {pos_err * self.L:.3g} m): the branch passes a branch (change) point, where "
                f"the assembly mode can switch; check link angles and dimensions")
        self.w = w
        self.coarse = (qs, Z, V, A)
        self.z_ref = z_ref
        self._tables()
        return self

    def _mobility(self, z):
        p, sysm = self.p, self.sys
        Jm = sysm.jac(z[None])[0] * sysm.row_scale[:, None] / sysm.col_scale[None, :]
        sv = np.linalg.svd(Jm[:-1], compute_uv=False)
        rank = int(np.sum(sv > 1e-9 * max(sv[0], 1e-300)))
        nz = sysm.nz
        dof = nz - rank
        grubler = 3 * self.n - 2 * len(p.joints)
        head = (f"linkage {p.name!r} has {dof} degree{'s' if dof != 1 else ''} of freedom at the stated pose "
                f"(3·{self.n} link coordinates − rank {rank} of the joint constraints; Grübler count {grubler})")
        if dof == 0:
            k_in = self.jindex[p.input]
            names = sorted({nm for k in self.closures for nm in self.cycle_of(k) if p.joints[k_in].name in self.cycle_of(k)})
            raise GeometryError(f"{head}: it is a rigid structure — the loop(s) through joints {', '.join(names)} lock "
                                f"the input joint {p.input!r}; a single-input machine needs exactly 1 "
                                f"(remove a link or a joint, or free one)")
        U, S, Vt = np.linalg.svd(Jm)
        if dof >= 2:
            null = Vt[-(dof - 1):] / sysm.col_scale[None, :]
            names = self._moving_joints(z, null)
            raise GeometryError(f"{head}: with the input joint {p.input!r} held, joints {', '.join(names)} can still "
                                f"move; a single-input machine needs exactly 1 (add a link or a joint, or lock the "
                                f"extra freedom)")
        if S[-1] < COND_TOL * S[0]:
            names = self._moving_joints(z, Vt[-1:] / sysm.col_scale[None, :])
            raise GeometryError(f"linkage {p.name!r}: the stated pose (input angle {_deg(float(p.input_angle))}) is a "
                                f"dead centre of the input: joints {', '.join(names)} can move with the input held")

    def _moving_joints(self, z, null):
        r = np.abs(self.joint_rates(np.repeat(z[None], len(null), 0), null))
        for k, jt in enumerate(self.kjoints):
            if jt.kind == "P":
                r[:, k] /= self.L
        r = r.max(axis=0)
        return [self.p.joints[k].name for k in np.flatnonzero(r > 1e-6 * max(r.max(), 1e-300))
                if self.p.joints[k].name != self.p.input]

    def _gap_joint(self, z, q):
        F = self.sys.phi(z[None], q)[0]
        best, name = -1.0, ""
        for k, jt in enumerate(self.kjoints):
            g = math.hypot(F[2 * k], F[2 * k + 1]) if jt.kind == "R" else abs(F[2 * k])
            if g > best:
                best, name = g, jt.name
        return name, best

    def _closable(self, q, guesses):
        """Smallest scaled closure residual at input angle q over assemblies from the guesses."""
        best, zb = math.inf, None
        for g in guesses:
            z, res = self.sys.assemble(g, q)
            if res < best:
                best, zb = res, z
        return best, zb

    def _no_assembly(self, q0, z):
        p = self.p
        name, gap = self._gap_joint(z, q0)
        qs = q0 + TWO_PI * np.arange(72) / 72
        ok, prev = np.zeros(72, bool), None
        for i, q in enumerate(qs):
            res, zz = self._closable(q, [self.guess(q)] + ([prev] if prev is not None else []))
            ok[i] = res < 1e-9
            prev = zz if ok[i] else prev
        if not ok.any():
            raise GeometryError(f"linkage {p.name!r} cannot be assembled at any input angle: the closest assembly at "
                                f"{_deg(q0)} leaves a gap of {gap:.4g} m at joint {name!r} (loop {', '.join(self._loop_names(name))}); "
                                f"check the link dimensions")
        raise GeometryError(f"linkage {p.name!r}: the loop {', '.join(self._loop_names(name))} cannot close for input "
                            f"angles {_ranges_text(qs, ~ok)} (5° scan), including the stated pose at {_deg(q0)} "
                            f"(gap {gap:.4g} m at joint {name!r}); the input cannot make the full turn")

    def _loop_names(self, jname):
        k = self.jindex[jname]
        if k in self.closures:
            return self.cycle_of(k)
        loops = [self.cycle_of(c) for c in self.closures if jname in self.cycle_of(c)]
        return loops[0] if loops else [jname]

    def _branch_failure(self, e, z_ref, q0):
        p, sysm = self.p, self.sys
        qf, zf = e.q, e.z
        try:
            sysm.continuation(z_ref, q0, -TWO_PI, COARSE_STEPS, cond_tol=COND_TOL)
            qb, zb = qf - TWO_PI, zf
        except SolveError as e2:
            qb, zb = e2.q, e2.z
        lo, hi = qf, qb + TWO_PI
        qm = 0.5 * (lo + hi)
        res, zm = self._closable(qm, [zf, zb])
        if res > 1e-8:
            name, gap = self._gap_joint(zm, qm)
            raise GeometryError(
                f"linkage {p.name!r}: the loop {', '.join(self._loop_names(name))} cannot close for input angles "
                f"{_deg(lo)}..{_deg(hi)} (at {_deg(qm)} the closest assembly leaves a {gap:.4g} m gap at joint "
                f"{name!r}); the input cannot make the full turn — a crank needs a linkage that assembles at every "
                f"input angle (e.g. Grashof: shortest + longest ≤ sum of the other two, crank the shortest)")
        Jm = sysm.jac(zf[None])[0] * sysm.row_scale[:, None] / sysm.col_scale[None, :]
        Vt = np.linalg.svd(Jm)[2]
        names = self._moving_joints(zf, Vt[-1:] / sysm.col_scale[None, :])
        raise GeometryError(
            f"linkage {p.name!r}: the position solve hits a dead centre or branch point at input angle {_deg(qf)} "
            f"(the constraint Jacobian becomes singular: joints {', '.join(names)} can move with the input held); "
            f"the input cannot drive the linkage through it")

    # ------------------------------------------------------------------ tables
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

    def _tables(self):
        p, sysm = self.p, self.sys
        q0 = self.q0
        nch = 5 + 2 * len(self.loads)
        self.nch = nch
        info = {}
        sizes = [int(p.table_nodes)] if p.table_nodes else list(TABLE_NODES)
        for N in sizes:
            u = TWO_PI * np.arange(N) / N
            z, v, a = self.exact(q0 + u, self._coarse_guess(u))
            sv = sysm.singular_values(z)
            bad = sv[:, -1] < COND_TOL * sv[:, 0]
            if bad.any():
                qf = q0 + u[np.argmax(bad)]
                raise GeometryError(f"linkage {p.name!r}: dead centre at input angle {_deg(qf)} (the constraint "
                                    f"Jacobian is singular there); the input cannot drive the linkage through it")
            ch = self.channels(z, v, a)
            zp = z.copy()
            zp[:, 2::3] -= self.w[None, :] * u[:, None]
            table = PeriodicTable(q0, np.hstack([ch, zp]))
            um = u + 0.5 * TWO_PI / N
            zm, vm, am = self.exact(q0 + um, self._coarse_guess(um))
            exact = self.channels(zm, vm, am)
            est = table(q0 + um)[:, :nch]
            scale = np.max(np.abs(exact), axis=0)
            scale[1:3] = np.maximum(scale[1:3], 1e-9 * max(scale[0], 1e-300))
            rel = np.max(np.abs(est - exact), axis=0) / np.where(scale > 0, scale, 1.0)
            info = {"nodes": N, "rel_error_J": float(rel[0]), "rel_error_dJ": float(rel[1]),
                    "rel_error_dEp": float(rel[2]), "rel_error_Ep": float(rel[3]),
                    "min_sigma_ratio": float(np.min(sv[:, -1] / sv[:, 0]))}
            self.table = table
            if max(rel[:3]) <= TABLE_TARGET:
                break
        self.table_info = info

    def z_guess(self, q):
        """Configurations (B, 3n) interpolated from the table (add the windings)."""
        q = np.atleast_1d(np.asarray(q, float))
        zp = self.table(q)[:, self.nch:]
        zp[:, 2::3] += self.w[None, :] * (q - self.q0)[:, None]
        return zp


def _ranges_text(qs, mask):
    """'a..b, c..d' (degrees) for the runs of True in mask over the grid qs (wrapping)."""
    from .fourbar import _angle_ranges

    return ", ".join(f"{_deg(lo)}..{_deg(hi)}" for lo, hi in _angle_ranges(qs, mask))


_CACHE: dict = {}


def compiled(p: LinkageParams) -> _Compiled:
    """The compiled, built linkage of a description (cached by its content)."""
    key = hashlib.sha1(p.model_dump_json().encode()).hexdigest()
    hit = _CACHE.get(key)
    if hit is None:
        if len(_CACHE) > 32:
            _CACHE.clear()
        hit = _CACHE[key] = _Compiled(p).build()
    return hit


# ============================================================================ the mechanism
class Linkage(Mechanism):
    """A single-DOF planar linkage from its description (see the module docstring)."""

    type_name = "linkage"
    Params = LinkageParams
    #: where the reduced model comes from (printed next to every multibody-vs-reduced figure)
    reduced_source = "independent: own loop-closure kinematics (Newton + constraint Jacobian)"

    def __init__(self, params: LinkageParams):
        self.params = params
        self.name = params.name
        self.input_joint = params.input
        self.c = c = compiled(params)
        self.table_info = dict(c.table_info)
        t = c.table
        self._tab3, self._tab1, self._tab = t.scalar3, t.scalar, t
        self._has_ext = bool(c.damped or any(s.damping > 0 for _, _, s in c.springs) or c.loads)
        self._loads = [(5 + 2 * k, 6 + 2 * k, _force_law(ld, k)) for k, (_, _, ld) in enumerate(c.loads)]
        self.loads_P = _loads_params([ld for _, _, ld in c.loads])
        self.ext_P = LinkageExtP(t.P, self.loads_P)
        self._mb = None

    @classmethod
    def from_params(cls, p):
        return cls(p)

    # ------------------------------------------------------------------ reduced model
    def reduced(self, q):
        """J(q) [kg·m²], dJ/dq [kg·m²/rad], dE_p/dq [N·m] from the table (accuracy: ``table_info``)."""
        if isinstance(q, float):
            return self._tab3(q)
        v = self._tab(q, [0, 1, 2])
        return v[..., 0], v[..., 1], v[..., 2]

    def reduced_exact(self, q):
        """(J, J', E_p') solved at q (array) without the table: Newton + analytic kinematics."""
        z, v, a = self.c.exact(q)
        ch = self.c.channels(z, v, a)
        return ch[:, 0], ch[:, 1], ch[:, 2]

    def potential_energy(self, q):
        """Gravity (zero level y = 0) + spring energy E_p(q) [J]."""
        if isinstance(q, float):
            return self._tab1(q, 3)
        return self._tab(q, [3])[..., 0]

    def damping_factor(self, q):
        """Σ c_j·(joint rate / q̇)² + Σ c_s·(dℓ/dq)² [N·m·s/rad]: viscous friction reduced to q."""
        if isinstance(q, float):
            return self._tab1(q, 4)
        return self._tab(q, [4])[..., 0]

    def reduced_viscous(self, q):
        """D(q) when the external torque is viscous only (no point loads): the reduced backends
        then tabulate it with J; None with loads (external_torque is called at every stage)."""
        if self._loads:
            return None
        return self.damping_factor(q)

    def external_torque(self, q, qd, t):
        """Viscous friction of joints and dampers, −D(q)·q̇, plus the point loads F(s)·ds/dq
        [N·m] (a gated load acts where ds/dq has the sign of its stroke, see LoadSpec;
        :func:`linkage_torque`)."""
        if not self._has_ext:
            return 0.0 * q
        P = self.ext_P
        return C.vectorize(lambda a, b: linkage_torque(a, b, P), q, qd)

    def model_form(self):
        """The reduced model as a law: the spline table of J, ½J', E_p' (and D when the external
        torque is viscous only); with point loads, plus :func:`linkage_torque` (:func:`linkage_model`)."""
        from .base import table_form

        tf = table_form(self)
        if not self._loads:
            return tf
        return C.Form(linkage_model, LinkageModelP(tf.P, self.ext_P), flags=dict(tf.flags))

    def load_forces(self, q, qd):
        """[(s, ṡ, F)] of every load at (q, q̇): a point load's coordinate along its direction [m],
        its rate [m/s] and the force [N]; a torque load's table abscissa (its point's stroke [m] or
        the reduced input angle [rad]; 0 for a constant torque), its link's rate θ̇ [rad/s] and the
        torque [N·m]."""
        out = []
        P = self.loads_P
        for k, (ks, kd, law) in enumerate(self._loads):
            v = self._tab(q, [ks, kd])
            s, ds = v[..., 0], v[..., 1]
            if P.spec[k, 7] != 0.0:
                s = C.vectorize(lambda a, k=k: load_abscissa(k, a, P, self.c.table.P), q + 0.0 * ds)
            out.append((s, ds * qd, law(s, ds)))
        return out

    # ------------------------------------------------------------------ kinematics for drawings
    def state(self, q):
        """(z, v, a) solved at q (array): body coordinates (x_G, y_G, θ) per link and their first
        and second derivatives with respect to q."""
        return self.c.exact(q)

    def points(self, q):
        z = self.c.z_guess(np.ravel(np.asarray(q, float)))
        pts = self.c.world_points(z)
        shape = np.shape(q)
        return {k: (x.reshape(shape), y.reshape(shape)) if shape else (float(x[0]), float(y[0]))
                for k, (x, y) in pts.items()}

    def trace_point(self, q):
        ref = self.params.trace or _first_load_point(self.params)
        if ref is None:
            return None
        return self.points(q)[ref]

    def describe(self) -> dict:
        return self.params.to_dict()

    def linkage_view(self):
        """Itself: its own kinematics (link lines, joints) for ``mjbench analyze``."""
        return self

    def input_positions(self, n: int):
        """n input angles over one turn from the stated pose's input angle."""
        return self.c.q0 + 2.0 * np.pi * np.arange(n) / n, "rad"

    # ------------------------------------------------------------------ kinematic analysis
    def kinematic_analysis(self, q):
        """Over input angles q (array): velocity ratios of every joint, slide strokes, transmission
        angles, toggle (collinear) and limit positions.  See docs/linkages.md §6 for definitions."""
        c, p = self.c, self.params
        q = np.asarray(q, float)
        z, v, _ = c.exact(q)
        rates = c.joint_rates(z, v)
        slides = c.slide_positions(z)
        pts = c.world_points(z)
        out = {"ratios": {}, "ratio_units": {}, "strokes_m": {}, "swings_deg": {}, "stroke_arcs_deg": {},
               "transmission": {}, "toggles": {}, "limit_positions": {}}
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
        # revolute points of each link (its "link line" if binary)
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
        couplers = {n for n in binary if n not in grounded}  # floating two-force members
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
            # toggle: both links binary: their lines through the joint become collinear
            if l1 in binary and l2 in binary:
                o1 = [x for x in binary[l1] if x != p1][0]
                o2 = [x for x in binary[l2] if x != p2][0]
                u1 = _vec(pts, f"{l1}.{o1}", f"{l1}.{p1}")
                u2 = _vec(pts, f"{l2}.{o2}", f"{l2}.{p2}")
                cross = u1[0] * u2[1] - u1[1] * u2[0]
                dot = u1[0] * u2[0] + u1[1] * u2[1]

                def crossf(x, l1=l1, l2=l2, o1=o1, o2=o2, p1=p1, p2=p2):
                    pp = c.world_points(c.exact(x)[0])
                    a1, a2 = _vec(pp, f"{l1}.{o1}", f"{l1}.{p1}"), _vec(pp, f"{l2}.{o2}", f"{l2}.{p2}")
                    return a1[0] * a2[1] - a1[1] * a2[0]

                roots = self._refine(_roots(q, cross), crossf)
                kinds = ["folded" if np.interp(r, q, dot) > 0 else "extended" for r in roots]
                out["toggles"][j.name] = [{"q": float(r), "kind": kd, "links": [l1, l2]} for r, kd in zip(roots, kinds)]
        return out

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

    # ------------------------------------------------------------------ MJCF
    def build_spec(self, armature: float = 0.0, options=None):
        """MjSpec: links as bodies of a kinematic tree (hinge / slide joints named after the
        description's joints), every other joint a site ``connect`` equality, springs as spatial
        tendons.  ``armature`` [kg·m²] is added to the input joint.  Options as fourbar.py
        (timestep, integrator, solref, solimp, iterations, tolerance)."""
        import mujoco

        c, p = self.c, self.params
        o = dict(options or {})
        h = float(o.get("timestep", 1e-4))
        spec = new_spec(self.name, o, gravity=(float(c.g[0]), 0.0, float(c.g[1])))
        world = spec.worldbody
        world.add_light(pos=[0, -3, 3], dir=[0, 1, -1], diffuse=[0.8, 0.8, 0.8])
        rad = 0.01 * self._extent()  # display sizes (geoms are massless)
        gray = [0.45, 0.45, 0.5, 1]
        bodies = {GROUND: world}
        # ground: pivots of revolute joints, guides of prismatic joints
        ranges = self._slide_ranges()
        for k, j in enumerate(p.joints):
            l1, p1, l2, p2 = c.jlinks[k]
            if GROUND not in (l1, l2):
                continue
            gp = c.pts[GROUND][p1 if l1 == GROUND else p2]
            if j.type == "revolute":
                world.add_geom(name=f"pivot_{j.name}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                               size=[1.8 * rad, 1.5 * rad, 0], pos=[gp[0], 0.0, gp[1]],
                               quat=[0.7071068, 0.7071068, 0, 0], rgba=gray, contype=0, conaffinity=0)
            elif l1 == GROUND:
                u = np.array(j.axis, float) / math.hypot(*j.axis)
                lo, hi = ranges.get(k, (0.0, 0.0))
                mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo) + 4 * rad
                ang = math.atan2(u[1], u[0])
                ctr = gp + mid * u
                world.add_geom(name=f"guide_{j.name}", type=mujoco.mjtGeom.mjGEOM_BOX,
                               size=[half, 0.5 * rad, 0.7 * rad], pos=[ctr[0], 2.5 * rad, ctr[1]],
                               quat=_quat(ang), rgba=gray, contype=0, conaffinity=0)
        for e in c.edges:
            parent = bodies[e.parent]
            ang = e.phi if e.kind == "P" else 0.0
            pos = e.p - _rot2(ang) @ e.c
            body = parent.add_body(name=e.child, pos=[pos[0], 0.0, pos[1]], quat=_quat(ang))
            bodies[e.child] = body
            j = p.joints[e.k]
            if e.kind == "R":
                jt = body.add_joint(name=e.name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(AXIS),
                                    pos=[e.c[0], 0.0, e.c[1]])
            else:
                ax = _rot2(-ang) @ e.u
                jt = body.add_joint(name=e.name, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[ax[0], 0.0, ax[1]])
            jt.damping = [float(j.damping), 0.0, 0.0]
            if e.name == p.input:
                jt.armature = float(armature)
            b = c.index[e.child]
            body.mass = max(float(c.mass[b]), 1e-9)
            body.ipos = [float(c.com[b][0]), 0.0, float(c.com[b][1])]
            Iy = max(float(c.inertia[b]), 1e-12)
            body.inertia = [0.6 * Iy, Iy, 0.6 * Iy]  # only I_yy (hinge axis) matters
            body.explicitinertial = True
            self._link_geoms(mujoco, body, e.child, rad, PALETTE[b % len(PALETTE)])
        for name, pts in c.pts.items():
            for k, v in pts.items():
                bodies[name].add_site(name=f"{name}.{k}", pos=[v[0], 0.0, v[1]], size=[1.1 * rad, 0, 0],
                                      rgba=[0.15, 0.15, 0.15, 1])
        if p.trace or _first_load_point(p):
            ref = p.trace or _first_load_point(p)
            lk, pt = _ref(ref)
            v = c.pts[lk][pt]
            bodies[lk].add_site(name="trace", pos=[v[0], 0.0, v[1]], size=[1.6 * rad, 0, 0], rgba=[1, 0.8, 0.1, 1])
        solref, solimp = closure_solref(o, h)
        for k in c.closures:
            j = p.joints[k]
            if j.type != "revolute":
                raise GeometryError(f"linkage {p.name!r}: joint {j.name!r} closes a loop made only of prismatic "
                                    f"joints; MJCF loops are closed at revolute joints (add or reorder a revolute)")
            spec.add_equality(name=f"closure_{j.name}", type=mujoco.mjtEq.mjEQ_CONNECT,
                              objtype=mujoco.mjtObj.mjOBJ_SITE, name1=j.at[0], name2=j.at[1],
                              solref=solref, solimp=solimp)
        # the assembled stated pose as a keyframe (a user opening the exported file sees it closed)
        z0, _, _ = c.exact([c.q0])
        vals, _ = self._tree_values(z0)
        kids = {}
        for e in c.edges:  # MuJoCo numbers bodies (and their joints) depth-first, children in order
            kids.setdefault(e.parent, []).append(e)
        order, stack = [], list(reversed(kids.get(GROUND, [])))
        while stack:
            e = stack.pop()
            order.append(e)
            stack += list(reversed(kids.get(e.child, [])))
        spec.add_key(name="assembled", qpos=[float(vals[e.name]) for e in order])
        for k, (_, _, s) in enumerate(c.springs):
            t = spec.add_tendon(name=s.name or f"spring{k}", stiffness=[float(s.stiffness), 0, 0],
                                damping=[float(s.damping), 0, 0], width=1.2 * rad, rgba=[0.9, 0.6, 0.1, 1])
            L0 = float(s.length) if s.length is not None else 0.0
            t.springlength = [L0, L0] if s.stiffness > 0 else [0.0, 0.0]
            t.wrap_site(s.between[0])
            t.wrap_site(s.between[1])
        return spec

    def _link_geoms(self, mujoco, body, name, rad, rgba):
        pts = np.array(list(self.c.pts[name].values())).reshape(-1, 2)
        uniq = np.unique(np.round(pts, 12), axis=0)
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

    def _extent(self):
        """Largest span of the drawing over one turn [m] (display sizes)."""
        q = self.c.q0 + TWO_PI * np.arange(90) / 90
        pts = self.c.world_points(self.c.z_guess(q))
        xs = np.concatenate([np.ravel(x) for x, _ in pts.values()])
        ys = np.concatenate([np.ravel(y) for _, y in pts.values()])
        return max(float(np.ptp(xs)), float(np.ptp(ys)), 1e-3)

    def _slide_ranges(self):
        """Travel (min, max) of every ground prismatic joint over one turn [m]."""
        q = self.c.q0 + TWO_PI * np.arange(720) / 720
        d = self.c.slide_positions(self.c.z_guess(q))
        return {k: (float(np.nanmin(d[:, k])), float(np.nanmax(d[:, k]))) for k in range(d.shape[1])
                if not np.isnan(d[0, k])}

    def _tree_values(self, z, v=None):
        """Joint values (and rates per unit q if v) of the tree joints from body coordinates."""
        c = self.c
        o, th = c.frames(z)
        o, th = o[0], th[0]
        vals, rates = {}, {}
        if v is not None:
            jr = c.joint_rates(z, v)[0]
        for e in c.edges:
            if e.kind == "R":
                tp = th[c.index[e.parent]] if e.parent != GROUND else 0.0
                vals[e.name] = th[c.index[e.child]] - tp
                if v is not None:
                    rates[e.name] = jr[e.k] if e.line_first else -jr[e.k]
            else:
                d = c.slide_positions(z)[0, e.k]
                vals[e.name] = d
                if v is not None:
                    rates[e.name] = jr[e.k]
        return vals, rates

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        z, _, _ = self.c.exact([float(q0)])
        vals, _ = self._tree_values(z)
        qpos = np.array(model.qpos0, dtype=float)
        for name, val in vals.items():
            qpos[model.joint(name).qposadr[0]] = val
        qpos[model.joint(self.input_joint).qposadr[0]] = q0
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        z, v, _ = self.c.exact([float(q0)])
        _, rates = self._tree_values(z, v)
        qvel = np.zeros(model.nv)
        for name, r in rates.items():
            qvel[model.joint(name).dofadr[0]] = r * qd0
        return qvel

    def joint_states(self, model, q):
        """(qpos (B, nq), qvel per unit input speed (B, nv)) at input angles q (array): what
        :meth:`initial_qpos` / :meth:`initial_qvel` give, solved for every angle at once (the
        reduced backend's joint columns, :mod:`mjbench.backends.joints`)."""
        c = self.c
        q = np.atleast_1d(np.asarray(q, float))
        z, v, _ = c.exact(q)
        _, th = c.frames(z)
        jr = c.joint_rates(z, v)
        sl = c.slide_positions(z)
        qpos = np.tile(np.asarray(model.qpos0, float), (len(q), 1))
        qvel = np.zeros((len(q), model.nv))
        for e in c.edges:
            jn = model.joint(e.name)
            a, d = int(jn.qposadr[0]), int(jn.dofadr[0])
            if e.kind == "R":
                tp = th[:, c.index[e.parent]] if e.parent != GROUND else 0.0
                qpos[:, a] = th[:, c.index[e.child]] - tp
                qvel[:, d] = jr[:, e.k] if e.line_first else -jr[:, e.k]
            else:
                qpos[:, a] = sl[:, e.k]
                qvel[:, d] = jr[:, e.k]
        qpos[:, int(model.joint(self.input_joint).qposadr[0])] = q
        return qpos, qvel


    # ------------------------------------------------------------------ multibody loads
    def has_multibody_load(self) -> bool:
        c = self.c
        return bool(c.loads or any(self.params.joints[k].damping > 0 for k in c.closures))

    def _mb_setup(self, model):
        """Per-model addresses: tree chains of the load points and of the damped closures."""
        hit = self._mb
        if hit is not None and hit[0] is model:
            return hit[1]
        c, p = self.c, self.params
        by_child = {e.child: e for e in c.edges}

        def chain(link):
            out = []
            while link != GROUND:
                e = by_child[link]
                jn = model.joint(e.name)
                out.append((e, int(jn.qposadr[0]), int(jn.dofadr[0])))
                link = e.parent
            return out[::-1]

        damp = []
        for k in c.closures:
            j = p.joints[k]
            if j.damping <= 0:
                continue
            l1, _, l2, _ = c.jlinks[k]
            h1 = {d for e, _, d in chain(l1) if e.kind == "R"} if l1 != GROUND else set()
            h2 = {d for e, _, d in chain(l2) if e.kind == "R"} if l2 != GROUND else set()
            damp.append((float(j.damping), sorted(h2 - h1), sorted(h1 - h2)))
        raw_loads, raw_torques = [], []
        for k, ld in enumerate(p.loads):
            if ld.link is not None:  # a torque on a link: T on every hinge of its chain from the ground
                raw_torques.append((k, [da for e, _, da in chain(ld.link) if e.kind == "R"]))
                continue
            lk, pt = _ref(ld.point)
            d = np.array(ld.direction, float) / math.hypot(*ld.direction)
            raw_loads.append((k, chain(lk) if lk != GROUND else [], c.pts[lk][pt], d))
        dofs = sorted({dd for _, a, b in damp for dd in a + b} | {da for _, ch, _, _ in raw_loads for _, _, da in ch}
                      | {da for _, hs in raw_torques for da in hs})
        idx = {d: i for i, d in enumerate(dofs)}
        torques = [(k, self._loads[k][1], [idx[d] for d in hs]) for k, hs in raw_torques]
        damp = [(cd, [(idx[d], d) for d in a], [(idx[d], d) for d in b]) for cd, a, b in damp]
        loads, affine = [], []
        for k, ch, pt, d in raw_loads:
            cc = tuple((idx[da], qa, da, e.kind == "R", float(e.p[0]), float(e.p[1]), float(e.c[0]), float(e.c[1]),
                        float(e.u[0]) if e.u is not None else 0.0, float(e.u[1]) if e.u is not None else 0.0,
                        float(e.phi)) for e, qa, da in ch)
            if all(not el[3] for el in cc):
                # slides only (a ram on its guide): s is affine in the slide values, s = s0 + Σ k_i·d_i,
                # and the generalised force on slide i is F·k_i (k_i = its world direction · load direction)
                th, s0, terms = 0.0, 0.0, []
                ox = oy = 0.0
                for i, qa, da, _, p0, p1, c0, c1, u0, u1, phi in cc:
                    cP, sP = math.cos(th), math.sin(th)
                    ox, oy = ox + cP * p0 - sP * p1, oy + sP * p0 + cP * p1
                    terms.append((i, qa, da, (cP * u0 - sP * u1) * d[0] + (sP * u0 + cP * u1) * d[1]))
                    th += phi
                    cc_, ss_ = math.cos(th), math.sin(th)
                    ox, oy = ox - (cc_ * c0 - ss_ * c1), oy - (ss_ * c0 + cc_ * c1)
                cc_, ss_ = math.cos(th), math.sin(th)
                s0 = (ox + cc_ * pt[0] - ss_ * pt[1]) * d[0] + (oy + ss_ * pt[0] + cc_ * pt[1]) * d[1]
                affine.append((self._loads[k][1], float(s0), tuple(terms), k))
                continue
            loads.append((self._loads[k][1], cc, float(pt[0]), float(pt[1]), float(d[0]), float(d[1]), k))
        jin = model.joint(self.input_joint)
        setup = (damp, loads, affine, dofs, int(jin.dofadr[0]), int(jin.qposadr[0]), 0.5 * float(model.opt.timestep),
                 torques)
        self._mb = (model, setup)
        return setup

    def load_form(self, model, data):
        """Point and torque loads and the viscous friction of loop-closing hinges as a law (:func:`linkage_load`)."""
        if not self.has_multibody_load():
            return None
        damp, loads, affine, dofs, ina, qina, h2, torques = self._mb_setup(model)
        # torque loads: the hinges (f slots) of the link's chain, each gets +T
        tptr, tslot = [0], []
        for _, _, slots in torques:
            tslot += slots
            tptr.append(len(tslot))
        # damped closures: entries (f slot, dof, ±1) of each, in order (plus, then minus)
        dptr, dslot, ddof, dsign = [0], [], [], []
        for cd, plus, minus in damp:
            for i, d in plus:
                dslot.append(i), ddof.append(d), dsign.append(1.0)
            for i, d in minus:
                dslot.append(i), ddof.append(d), dsign.append(-1.0)
            dptr.append(len(dslot))
        # loads on slides only: s = s0 + Σ kk·(slide value at mid-step)
        aptr, at = [0], []
        for kd, s0, terms, law in affine:
            at += [(i, qa, da, kk) for i, qa, da, kk in terms]
            aptr.append(len(at))
        # loads through the tree's chain of hinges and slides
        cptr, ce = [0], []
        for kd, ch, *_ in loads:
            ce += [el for el in ch]
            cptr.append(len(ce))
        i64 = (lambda v: np.array(v, dtype=np.int64))
        f64 = (lambda v: np.array(v, dtype=float))
        cols = list(zip(*ce)) if ce else [()] * 11
        P = LinkageLoadP(
            data.qpos, data.qvel, data.qfrc_applied, ina, qina, h2, self.c.table.P, self.loads_P,
            f64([cd for cd, _, _ in damp]), i64(dptr), i64(dslot), i64(ddof), f64(dsign),
            i64([law for _, _, _, law in affine]), i64([kd for kd, _, _, _ in affine]),
            f64([s0 for _, s0, _, _ in affine]), i64(aptr), i64([x[0] for x in at]), i64([x[1] for x in at]),
            i64([x[2] for x in at]), f64([x[3] for x in at]),
            i64([ld[-1] for ld in loads]), i64([ld[0] for ld in loads]), i64(cptr),
            f64([ld[2] for ld in loads]), f64([ld[3] for ld in loads]), f64([ld[4] for ld in loads]),
            f64([ld[5] for ld in loads]),
            i64(cols[0]), i64(cols[1]), i64(cols[2]), f64(cols[3]), f64(cols[4]), f64(cols[5]), f64(cols[6]),
            f64(cols[7]), f64(cols[8]), f64(cols[9]), f64(cols[10]),
            np.zeros(max(len(ce), 1)), np.zeros(max(len(ce), 1)), np.zeros(max(len(dofs), 1)), i64(dofs),
            i64([k for k, _, _ in torques]), i64([kd for _, kd, _ in torques]), i64(tptr), i64(tslot))
        return C.Form(linkage_load, P)

    def multibody_load(self, model, data, t: float) -> None:
        """Point and torque loads and the viscous friction of loop-closing hinges as generalised forces
        of the MuJoCo tree (:func:`linkage_load`, evaluated once)."""
        f = self.load_form(model, data)
        if f is not None:
            linkage_load(float(t), C.python_view(f.P))


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


def _loads_params(specs) -> "LoadsP":
    """The parameters of :func:`load_force` and :func:`load_abscissa` for the load descriptions
    ``specs`` (in order; a torque load's magnitude is its torque, its abscissa s or the angle q)."""
    rows, xs, Fs = [], [], []
    for k, ld in enumerate(specs):
        gate = {"always": 0.0, "stroke_along": 1.0, "stroke_against": -1.0}[ld.active]
        const = ld.force if ld.link is None else ld.torque
        angle = ld.link is not None and ld.q is not None
        q0 = float(ld.q[0]) if angle else 0.0
        if const is not None:
            rows.append((0.0, float(const), gate, float(len(xs)), 0.0, 5.0 + 2 * k, 6.0 + 2 * k, 0.0, 0.0))
        else:
            x = ld.q if angle else ld.s
            y = ld.T if ld.link is not None else ld.F
            rows.append((1.0, 0.0, gate, float(len(xs)), float(len(x)), 5.0 + 2 * k, 6.0 + 2 * k, float(angle), q0))
            xs += [float(v) for v in x]
            Fs += [float(v) for v in y]
    return LoadsP(np.array(rows, dtype=float).reshape(-1, 9), np.array([xs, Fs], dtype=float).reshape(2, -1))


def _force_law(ld: LoadSpec, k: int = 0):
    """F(s, ds/dq) [N] of one load (:func:`load_force`; scalars or arrays)."""
    P = _loads_params([ld])
    return lambda s, sd: C.vectorize(lambda a, b: load_force(0, a, b, P), s, sd)


Linkage.Params = LinkageParams
register(Linkage)


# ============================================================================ laws
#: the loads: ``spec`` one row per load — kind (0 constant F0, 1 table), F0, gate (0 always, +1 on
#: the stroke along its direction, −1 against), the table's start t0 and length tn in ``xf``, the
#: periodic-table channels of s and of the gate's rate g (point: ds/dq; torque: dθ_link/dq), the
#: abscissa (0: s; 1: the input angle reduced into [q₀, q₀ + 2π)) and q₀ —, ``xf`` (2, ·) the
#: tables' abscissae (row 0) and forces or torques (row 1) (few arrays: each array a compiled law
#: reads costs a reference-count update).  A torque load's generalised force is T·dθ_link/dq, a
#: point load's F·ds/dq: the same product of the magnitude and the gate's rate.
LoadsP = namedtuple("LoadsP", "spec xf")
#: the external torque: the linkage's periodic table, the loads
LinkageExtP = namedtuple("LinkageExtP", "tab loads")
#: the reduced model: the spline table (mjbench.backends.table), the external torque's parameters
LinkageModelP = namedtuple("LinkageModelP", "table ext")
#: the MuJoCo loads: live qpos, qvel, qfrc_applied, the input's dof and qpos, h/2, the periodic
#: table, the loads; damped closures (coefficient, entries dptr[k]..dptr[k+1]: f slot, dof, sign);
#: loads on slides only (load, s channel… terms aptr[k]..: f slot, qpos, dof, gain); loads through a
#: chain (load, ds/dq channel, elements cptr[k]..cptr[k+1], point in its link, direction; elements:
#: f slot, qpos, dof, hinge, p, c, u, φ); work arrays (per element a, b; f per dof) and the dofs;
#: torque loads (load, dθ/dq channel, the f slots of the link chain's hinges tptr[k]..tptr[k+1])
LinkageLoadP = namedtuple("LinkageLoadP", "qpos qvel qfrc ina qina h2 tab loads dc dptr dslot ddof dsign "
                                          "aload akd as0 aptr ai aqa ada akk cload ckd cptr cpt0 cpt1 cdx cdy "
                                          "ei eqa eda ehinge ep0 ep1 ec0 ec1 eu0 eu1 ephi wa wb f dofs "
                                          "tload tkd tptr tslot")


@law
def load_force(k, s, sd, L):
    """Force [N] of load k at its coordinate s with ds/dq = sd: 0 off its stroke (gate·sd ≤ 0 for a
    gated load), else F0 (constant) or the table F(s), piecewise linear, constant beyond the ends."""
    sp = L.spec
    g = sp[k, 2]
    if g != 0.0 and not (g * sd > 0.0):
        return 0.0
    if sp[k, 0] == 0.0:
        return sp[k, 1]
    a = int(sp[k, 3])
    n = int(sp[k, 4])
    X = L.xf
    if s <= X[0, a]:
        return X[1, a]
    if s >= X[0, a + n - 1]:
        return X[1, a + n - 1]
    lo = 0
    hi = n - 1  # s(lo) <= s < s(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if X[0, a + mid] <= s:
            lo = mid
        else:
            hi = mid
    x0 = X[0, a + lo]
    tt = (s - x0) / (X[0, a + lo + 1] - x0)
    return X[1, a + lo] + tt * (X[1, a + lo + 1] - X[1, a + lo])


@law
def load_abscissa(k, q, L, T):
    """The abscissa of load k's table at input angle q: its point's coordinate s (periodic-table
    channel, ``T``), or for a torque table against the input angle, q reduced into [q₀, q₀ + 2π)
    (q₀ its first angle); NaN at a non-finite angle."""
    sp = L.spec
    if sp[k, 7] == 0.0:
        return ptable_channel(q, int(sp[k, 5]), T)
    q0 = sp[k, 8]
    u = q - q0
    if not abs(u) < 1e15:
        return math.nan
    return q0 + (u - TWO_PI * math.floor(u / TWO_PI))


@law
def linkage_torque(q, qd, P):
    """The external torque on the input [N·m]: −D(q)·q̇ (viscous joints and dampers, table channel
    4) plus Σ F_k(s_k)·ds_k/dq of the point loads and Σ T_k·dθ_k/dq of the torque loads
    (:func:`load_force`, :func:`load_abscissa`)."""
    T = P.tab
    Q = -ptable_channel(q, 4, T) * qd
    L = P.loads
    sp = L.spec
    for k in range(len(sp)):
        s = load_abscissa(k, q, L, T)
        ds = ptable_channel(q, int(sp[k, 6]), T)
        Q = Q + load_force(k, s, ds, L) * ds
    return Q


@law
def linkage_model(q, qd, t, P):
    """The reduced model law: the spline table's (J, ½J', E_p') and :func:`linkage_torque` as Q_ext."""
    J, H, E, Q = table_model(q, qd, t, P.table)
    return J, H, E, Q + linkage_torque(q, qd, P.ext)


@law
def linkage_load(t, P):
    """The point and torque loads and the damping of loop-closing hinges as generalised forces of
    the MuJoCo tree, before each step (:meth:`Linkage.load_form`): closure damping from the relative
    rate at the step's start; a load's point from the tree's own kinematics at the predicted
    mid-point qpos + ½·h·qvel, F(s) through the point Jacobian, its stroke gate from ds/dq at the
    input's mid-step angle (the description's kinematics); a torque T on a link: +T on every hinge
    of the link's chain from the ground (its virtual work T·δθ_link: the link's angle is the sum of
    those hinge angles), T at the input's mid-step angle (an angle table: MuJoCo's own input angle;
    a stroke table's s and the gate's dθ_link/dq: the description's kinematics).  The input dof's
    force (the drive torque) is added to, every other touched dof is set."""
    f = P.f
    for i in range(len(f)):
        f[i] = 0.0
    qpos = P.qpos
    qvel = P.qvel
    h2 = P.h2
    for k in range(len(P.dc)):
        w = 0.0
        for e in range(P.dptr[k], P.dptr[k + 1]):
            if P.dsign[e] > 0.0:
                w = w + qvel[P.ddof[e]]
            else:
                w = w - qvel[P.ddof[e]]
        tau = -P.dc[k] * w
        for e in range(P.dptr[k], P.dptr[k + 1]):
            if P.dsign[e] > 0.0:
                f[P.dslot[e]] = f[P.dslot[e]] + tau
            else:
                f[P.dslot[e]] = f[P.dslot[e]] - tau
    q_mid = qpos[P.qina] + h2 * qvel[P.ina]
    for k in range(len(P.aload)):
        sv = P.as0[k]
        for e in range(P.aptr[k], P.aptr[k + 1]):
            sv = sv + P.akk[e] * (qpos[P.aqa[e]] + h2 * qvel[P.ada[e]])
        sp = ptable_channel(q_mid, P.akd[k], P.tab)
        F = load_force(P.aload[k], sv, sp, P.loads)
        for e in range(P.aptr[k], P.aptr[k + 1]):
            f[P.ai[e]] = f[P.ai[e]] + F * P.akk[e]
    for k in range(len(P.cload)):
        th = 0.0
        cP = 1.0
        sP = 0.0
        ox = 0.0
        oy = 0.0
        for e in range(P.cptr[k], P.cptr[k + 1]):
            val = qpos[P.eqa[e]] + h2 * qvel[P.eda[e]]
            px = ox + cP * P.ep0[e] - sP * P.ep1[e]
            py = oy + sP * P.ep0[e] + cP * P.ep1[e]
            if P.ehinge[e] != 0.0:
                P.wa[e] = px
                P.wb[e] = py
                th = th + val
            else:
                ux = cP * P.eu0[e] - sP * P.eu1[e]
                uy = sP * P.eu0[e] + cP * P.eu1[e]
                px = px + val * ux
                py = py + val * uy
                P.wa[e] = ux
                P.wb[e] = uy
                th = th + P.ephi[e]
            cP = math.cos(th)
            sP = math.sin(th)
            ox = px - (cP * P.ec0[e] - sP * P.ec1[e])
            oy = py - (sP * P.ec0[e] + cP * P.ec1[e])
        x = ox + cP * P.cpt0[k] - sP * P.cpt1[k]
        y = oy + sP * P.cpt0[k] + cP * P.cpt1[k]
        dx = P.cdx[k]
        dy = P.cdy[k]
        sp = ptable_channel(q_mid, P.ckd[k], P.tab)
        F = load_force(P.cload[k], x * dx + y * dy, sp, P.loads)
        for e in range(P.cptr[k], P.cptr[k + 1]):
            if P.ehinge[e] != 0.0:
                f[P.ei[e]] = f[P.ei[e]] + F * ((P.wb[e] - y) * dx + (x - P.wa[e]) * dy)
            else:
                f[P.ei[e]] = f[P.ei[e]] + F * (P.wa[e] * dx + P.wb[e] * dy)
    for k in range(len(P.tload)):  # torques on links: +T on every hinge of the link's chain
        i = P.tload[k]
        T = load_force(i, load_abscissa(i, q_mid, P.loads, P.tab), ptable_channel(q_mid, P.tkd[k], P.tab), P.loads)
        for e in range(P.tptr[k], P.tptr[k + 1]):
            f[P.tslot[e]] = f[P.tslot[e]] + T
    for i in range(len(P.dofs)):
        d = P.dofs[i]
        if d == P.ina:
            P.qfrc[d] += f[i]
        else:
            P.qfrc[d] = f[i]


# ============================================================================ equivalents of the hand-coded mechanisms
def table_from_fourbar(fb) -> dict:
    """The ``[mechanism]`` table of a :class:`~mjbench.mechanisms.fourbar.FourBar` written as a
    generic linkage (same notation as tests/data/linkages/incerti2012.toml): link frames at the
    proximal joints along the link lines, joint point masses as point masses, hinge damping."""
    beta, gamma = (float(v) for v in fb.angles(0.0))
    pol = (lambda r, t: [r * math.cos(t), r * math.sin(t)])
    jm = fb.joint_masses
    pt = fb.coupler_point
    return {
        "type": "linkage", "name": f"{fb.name}-linkage", "input": "A", "input_angle": 0.0,
        "gravity": [0.0, -float(fb.g)], "trace": "coupler.P",
        "ground": {"A": [0.0, 0.0], "D": [float(fb.h_x), float(fb.h_y)]},
        "links": {
            "crank": {"mass": fb.m[0], "com": pol(fb.f[0], fb.theta[0]), "inertia": fb.J_G[0],
                      "points": {"A": [0.0, 0.0], "B": [fb.a, 0.0]},
                      "point_masses": {k: v for k, v in (("A", jm.get("A", 0.0)), ("B", jm.get("B", 0.0))) if v}},
            "coupler": {"mass": fb.m[1], "com": pol(fb.f[1], fb.theta[1]), "inertia": fb.J_G[1],
                        "points": {"B": [0.0, 0.0], "C": [fb.b, 0.0], "P": pol(pt.f, pt.theta)}, "angle": beta},
            "rocker": {"mass": fb.m[2], "com": pol(fb.f[2], fb.theta[2]), "inertia": fb.J_G[2],
                       "points": {"D": [0.0, 0.0], "C": [fb.c, 0.0]}, "angle": gamma,
                       "point_masses": {k: v for k, v in (("C", jm.get("C", 0.0)), ("D", jm.get("D", 0.0))) if v}},
        },
        "joints": [{"name": "A", "at": ["ground.A", "crank.A"], "damping": fb.damping_A},
                   {"name": "B", "at": ["crank.B", "coupler.B"], "damping": fb.joint_damping},
                   {"name": "C", "at": ["coupler.C", "rocker.C"], "damping": fb.damping_C},
                   {"name": "D", "at": ["ground.D", "rocker.D"], "damping": fb.joint_damping}],
    }


def table_from_quickreturn(qr) -> dict:
    """The seed-004 quick-return (:class:`~mjbench.mechanisms.quickreturn.QuickReturn`) as a
    generic linkage (tests/data/linkages/yigit2023.toml); the cutting force on the "stroke"
    profile becomes a load against the slider on its working stroke (other profiles: no load)."""
    k = qr.kin(0.0)
    H = qr.a + qr.b
    loads = []
    if qr.cut_profile == "stroke" and qr.cut_force > 0:
        loads = [{"name": "cut", "point": "slider.C", "direction": [-qr.working_direction, 0.0],
                  "force": float(qr.cut_force), "active": "stroke_against"}]
    return {
        "type": "linkage", "name": f"{qr.name}-linkage", "input": "A0", "input_angle": 0.0,
        "gravity": [0.0, -float(qr.g)], "trace": "slider.C",
        "ground": {"A0": [0.0, qr.a], "B0": [0.0, 0.0], "S": [0.0, H]},
        "links": {
            "crank": {"mass": qr.m2, "com": [qr.c2, 0.0], "inertia": qr.I_G2,
                      "points": {"A0": [0.0, 0.0], "A": [qr.r2, 0.0]}},
            "block": {"mass": qr.m_block, "inertia": qr.I_block, "points": {"A": [0.0, 0.0]},
                      "angle": float(k["th3"])},
            "lever": {"mass": qr.m3, "com": [qr.c3, 0.0], "inertia": qr.I_G3,
                      "points": {"B0": [0.0, 0.0], "B": [qr.r3, 0.0]}, "angle": float(k["th3"])},
            "rod": {"mass": qr.m4, "com": [qr.c4, 0.0], "inertia": qr.I_G4,
                    "points": {"B": [0.0, 0.0], "C": [qr.r4, 0.0]}, "angle": float(k["th4"])},
            "slider": {"mass": qr.m5, "inertia": 0.0, "points": {"C": [0.0, 0.0]}},
        },
        "joints": [{"name": "A0", "at": ["ground.A0", "crank.A0"]},
                   {"name": "A", "at": ["crank.A", "block.A"]},
                   {"name": "slot", "type": "prismatic", "at": ["lever.B0", "block.A"], "axis": [1.0, 0.0]},
                   {"name": "B0", "at": ["ground.B0", "lever.B0"]},
                   {"name": "B", "at": ["lever.B", "rod.B"]},
                   {"name": "C", "at": ["rod.C", "slider.C"]},
                   {"name": "slide", "type": "prismatic", "at": ["ground.S", "slider.C"], "axis": [1.0, 0.0]}],
        "loads": loads,
    }


def equivalent(mech):
    """A :class:`Linkage` equivalent to a mechanism (kinematic analysis of the built-in four-bar
    and quick-return: velocity ratios, transmission angles, toggles), or None: the mechanism's own
    :meth:`~mjbench.mechanisms.base.Mechanism.linkage_view`."""
    return mech.linkage_view()
