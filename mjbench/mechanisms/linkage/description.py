"""The description of a linkage: the ``[mechanism] type = "linkage"`` table and its parts.

* ``ground``: named points of the frame (pivots, points on slide lines) [m];
* ``links.NAME`` (:class:`LinkSpec`): rigid links — ``mass``, ``com`` (mass centre in the link
  frame), ``inertia`` (about the mass centre, normal to the plane), ``points`` (named, in the link
  frame), optional ``point_masses`` and ``angle`` (approximate angle of the link frame in the
  stated pose: it picks the assembly branch);
* ``joints`` (:class:`JointSpec`): revolute or prismatic, optional viscous ``damping``;
* ``springs`` (:class:`SpringSpec`) and ``loads`` (:class:`LoadSpec`: a force on a point or a
  torque on a link, constant or tabulated, optionally on one stroke only);
* ``input``, ``input_angle``, ``gravity``, ``trace``, ``table_nodes`` (:class:`LinkageParams`).

Each table is validated field by field; :class:`LinkageParams` then checks the structure
(:func:`.topology.topology_problems`).  docs/linkages.md §1 is the reference.
"""

import math
from typing import Literal

from pydantic import Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from ...fields import OptQ, Q, Strict
from .gears import GearSpec, gear_edges, gear_problems
from .topology import GROUND, topology_problems

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
    the ends) — or the same table over the stroke, measured from the end of the active stroke:
    ``profile`` = [[distance before the end [m], force], ...] or ``profile_fraction`` =
    [[fraction of the stroke before the end (0-1), force], ...] (as design requirements give
    loads; ``active`` must then name the stroke: the end of ``stroke_against`` is the point's
    smallest s over a turn, of ``stroke_along`` its largest; converted to s/F when the mechanism
    is built).  ``active``: always, or only on the stroke where — with the input turning forward
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
    profile: list[tuple[Length, Q("force", plausible=False)]] | None = Field(
        None, description="point load: [[distance before the end of the active stroke, force], ...]")
    profile_fraction: list[tuple[float, Q("force", plausible=False)]] | None = Field(
        None, description="point load: [[fraction of the stroke before the end of the active stroke, force], ...]")
    active: Literal["always", "stroke_along", "stroke_against"] = "always"

    @model_validator(mode="after")
    def _law(self):
        if self.link is not None:
            return self._torque_law()
        what = self.point or "?"
        extra = [k for k in ("torque", "q", "T") if getattr(self, k) is not None]
        prof = [k for k in ("profile", "profile_fraction") if getattr(self, k) is not None]
        if extra:
            raise PydanticCustomError("mjbench_value", "load on {p}: {k} belong to a torque load (give link = ...)",
                                      {"p": what, "k": ", ".join(extra)})
        if self.point is None or self.direction is None:
            raise PydanticCustomError("mjbench_value", "a load needs point and direction (a force on a point) or "
                                      "link (a torque on a link)")
        if not math.hypot(*self.direction) > 0:
            raise PydanticCustomError("mjbench_value", "load on {p}: direction has zero length", {"p": self.point})
        table = self.s is not None or self.F is not None
        if (self.force is not None) + table + len(prof) != 1:
            raise PydanticCustomError("mjbench_value", "load on {p}: give one of force, the table s, F (the point's "
                                      "coordinate), profile (distance before the stroke's end) or profile_fraction "
                                      "(fraction of the stroke before its end)", {"p": self.point})
        if prof:
            rows = getattr(self, prof[0])
            if len(rows) < 2:
                raise PydanticCustomError("mjbench_value", "load on {p}: {k} needs at least two points",
                                          {"p": self.point, "k": prof[0]})
            if self.active == "always":
                raise PydanticCustomError("mjbench_value", "load on {p}: a {k} is measured from the end of a stroke: set "
                                          "active = 'stroke_along' or 'stroke_against'", {"p": self.point, "k": prof[0]})
            hs = sorted(h for h, _ in rows)
            hi = 1.0 if prof[0] == "profile_fraction" else math.inf
            if hs[0] < 0 or hs[-1] > hi or any(b <= a for a, b in zip(hs, hs[1:])):
                raise PydanticCustomError("mjbench_value", "load on {p}: the {k} positions must be distinct and "
                                          "{r}", {"p": self.point, "k": prof[0],
                                                  "r": "in [0, 1]" if hi == 1.0 else ">= 0"})
        if table:
            if self.s is None or self.F is None or len(self.s) != len(self.F) or len(self.s) < 2:
                raise PydanticCustomError("mjbench_value", "load on {p}: s and F need the same length >= 2",
                                          {"p": self.point})
            _increasing(self.s, "s", self.point)
        return self

    def _torque_law(self):
        where = f"link {self.link}"
        if self.force is not None or self.F is not None or self.profile is not None or self.profile_fraction is not None:
            raise PydanticCustomError("mjbench_value", "torque load on {w}: give torque or the table T (force, F and "
                                      "the profiles are a point load's)", {"w": where})
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
    input: str | None = Field(None, description="name of the driven joint (revolute, ground → input link)")
    input_angle: Q("angle") = Field(0.0, description="input angle q of the stated pose (link angles)")
    inputs: list[str] | None = Field(None, description="the driven joints of a machine with several motors (revolute; "
                                                       "instead of input): one axis each, in this order")
    input_angles: list[Q("angle")] | None = Field(None, description="each input's coordinate in the stated pose "
                                                                    "(a joint's relative angle; default 0)")
    input_ranges: list[tuple[Q("angle"), Q("angle")]] | None = Field(
        None, description="several inputs: the range of each input the reduced model is tabulated over "
                          "(default: a full turn, periodic)")
    gravity: tuple[Q("acceleration", plausible=False), Q("acceleration", plausible=False)] = Field(
        (0.0, -9.81), description="gravity in the plane [m/s²] ((0, 0): plane horizontal)")
    springs: list[SpringSpec] = Field(default_factory=list)
    loads: list[LoadSpec] = Field(default_factory=list)
    gears: list[GearSpec] = Field(default_factory=list, description="gear pairs, belts, racks (docs/higher_pairs.md §1)")
    trace: str | None = Field(None, description='"link.point" traced in videos (default: the first load point)')
    table_nodes: int | None = Field(None, ge=64, le=65536, description="grid of the reduced-model table (default: automatic)")
    reduced_model: Literal["table", "solve"] | None = Field(
        None, description="several inputs: the reduced model in the loop — 'table' (1 or 2 inputs; their default) "
                          "or 'solve' (the loops solved by Newton at every evaluation; the default beyond 2 inputs)")

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
    def _inputs(self):
        if (self.input is None) == (self.inputs is None):
            raise PydanticCustomError("mjbench_value", "give input = \"JOINT\" (one motor) or inputs = [\"J1\", "
                                      "\"J2\", …] (one motor per joint), not both")
        if self.inputs is None and self.reduced_model is not None:
            raise PydanticCustomError("mjbench_value", "reduced_model: a machine with several inputs (inputs = [...]) "
                                      "only; one input's model is always tabulated")
        if self.inputs is not None:
            if not self.inputs or len(set(self.inputs)) != len(self.inputs):
                raise PydanticCustomError("mjbench_value", "inputs = {i}: name each driven joint once",
                                          {"i": list(self.inputs)})
            n = len(self.inputs)
            for key in ("input_angles", "input_ranges"):
                v = getattr(self, key)
                if v is not None and len(v) != n:
                    raise PydanticCustomError("mjbench_value", "{k}: {m} values for {n} inputs",
                                              {"k": key, "m": len(v), "n": n})
            for lo, hi in self.input_ranges or ():
                if not hi > lo:
                    raise PydanticCustomError("mjbench_value", "input_ranges: [{a}, {b}] needs lo < hi [rad]",
                                              {"a": lo, "b": hi})
        return self

    @property
    def input_list(self) -> list:
        """The driven joints, in axis order (one: ``[input]``)."""
        return list(self.inputs) if self.inputs is not None else [self.input]

    @model_validator(mode="after")
    def _topology(self):
        problems = gear_problems(self)
        problems = problems or topology_problems(self, gear_edges(self))
        if problems:
            raise PydanticCustomError("mjbench_value", "{m}", {"m": "; ".join(problems)})
        return self
