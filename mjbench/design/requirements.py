"""Requirements files: what a machine must do, validated like a scenario (pydantic, units, ONE
message listing every problem, exit 2).

::

    [design]      name, title, description
    [mechanism]   type = "slider-crank" | "crank-rocker" | "function-generator" | "motion-generator"
                  | "given" (the linkage of a scenario, re-sized) + the task's targets and constraints
    [mechanism.mass]  mass model of the synthesised links (uniform bars, ram, tool, extra inertias)
    [[loads]]     process forces on named points of the linkage (constant or a profile near the
                  end of a stroke)
    [duty]        the input speed (constant: bound χ_max) or a motion law per cycle ([duty.law]: bound
                  the tracking error), ambient
    [drive]       supply voltage, catalogue, amplifier current limit, flywheel allowed, ratios
    [control]     tuning objective, margins, budgets (mjbench tune)
    [verify]      multibody verification: tolerance, step

docs/design.md has the full reference.  Every physical value takes a unit (``"100 mm"``,
``"60 rpm"``, ``"8 kN"``); bare numbers are SI (angles in radians).
"""
from __future__ import annotations

import ast
import copy
import math
import os
import tomllib
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field, ValidationError, field_validator, model_validator
from pydantic_core import PydanticCustomError

from ..errors import ScenarioError
from ..schema import Bool, OptQ, Q, Strict, format_errors
from ..motionlaws import BezierLaw, PseudoPolynomialLaw
from ..linear import parse_margin
from ..errors import ParameterError
from .. import scenario as SC
from . import build as B
from . import synthesis as S
from .cam import CamReq

Length = Q("length", plausible=False)
Angle = Q("angle")
Point = tuple[Length, Length]

#: the named points of each synthesised linkage (for [[loads]] and trace)
def _err(msg, **ctx):
    return PydanticCustomError("mjbench_value", msg, ctx)


# ============================================================================ function expressions
_FUNCS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "log10": np.log10,
          "log2": np.log2, "sqrt": np.sqrt, "abs": np.abs, "arcsin": np.arcsin, "arccos": np.arccos,
          "arctan": np.arctan, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh}
_CONST = {"pi": math.pi, "e": math.e}
_OPS = (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd)


def compile_function(text: str):
    """y = f(x) from an expression in x (numbers, + − * / **, pi, e and the NumPy functions
    sin cos tan exp log log10 log2 sqrt abs arcsin arccos arctan sinh cosh tanh): a vectorised
    callable.  Anything else is refused (no Python evaluation of arbitrary code)."""
    try:
        tree = ast.parse(str(text).replace("^", "**"), mode="eval")
    except SyntaxError as e:
        raise ValueError(f"function {text!r} is not an expression in x ({e.msg})") from None

    def check(node):
        if isinstance(node, ast.Expression):
            return check(node.body)
        if isinstance(node, ast.BinOp) and isinstance(node.op, _OPS):
            return check(node.left) and check(node.right)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, _OPS):
            return check(node.operand)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return True
        if isinstance(node, ast.Name) and (node.id == "x" or node.id in _CONST):
            return True
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCS
                and len(node.args) == 1 and not node.keywords):
            return check(node.args[0])
        raise ValueError(f"function {text!r}: {ast.unparse(node)!r} is not allowed (use x, numbers, + - * / **, "
                         f"pi, e, {', '.join(sorted(_FUNCS))})")

    check(tree)
    code = compile(tree, "<function>", "eval")

    def f(x):
        with np.errstate(all="ignore"):
            return np.asarray(eval(code, {"__builtins__": {}}, {**_FUNCS, **_CONST, "x": np.asarray(x, float)}),
                              float) * np.ones_like(np.asarray(x, float))

    f.text = str(text)
    return f


# ============================================================================ tables
class Meta(Strict):
    """``[design]``: identification."""

    name: str
    title: str = ""
    description: str = ""


class MassModel(Strict):
    """``[mechanism.mass]``: masses of the synthesised links.  Links are uniform bars of
    ``bar_mass_per_length`` (m = ρL, I = mL²/12 about the centre); a balanced crank has its mass
    centre on its axis (a bar of twice its length centred there)."""

    bar_mass_per_length: float = Field(2.0, gt=0.0, description="mass per metre of the bars [kg/m]")
    crank_balanced: Bool = Field(True, description="crank counterweighted: mass centre on the axis")
    crank_inertia: Q("inertia", ge=0.0) = Field(0.0, description="extra inertia on the crank shaft (eccentric, hub)")
    slider_mass: Q("mass", ge=0.0) = Field(0.0, description="ram / slider with its tool (slider-crank)")
    tool_mass: Q("mass", ge=0.0) = Field(0.0, description="point mass at the output point (rocker tip or coupler point)")
    output_inertia: Q("inertia", ge=0.0) = Field(0.0, description="extra inertia on the rocker about its pivot")
    joint_damping: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous friction of every revolute joint")
    guide_damping: Q("lin_damping", ge=0.0) = Field(0.0, description="viscous friction of the slider guide")


class _MechBase(Strict):
    """A linkage synthesised from its task: what the design pipeline asks of every requirement type
    (:meth:`synthesize`, :meth:`requirement_rows`, the load points ``load_points``)."""

    #: the points a ``[[loads]]`` entry may name
    load_points: ClassVar[tuple] = ("crank.A", "crank.B", "coupler.B", "coupler.C", "rocker.D", "rocker.C")
    #: why the requirement takes no ``[[loads]]`` ("" when it takes them)
    loads_refused: ClassVar[str] = ""
    #: the four-bar's tool point (its weight, the loads' default)
    tool_at: ClassVar[str] = "rocker.C"

    min_transmission: OptQ("angle", gt=0.0, lt=0.5 * math.pi) = Field(
        None, description="minimum transmission angle over the turn")
    max_link_ratio: float | None = Field(None, gt=1.0, description="longest / shortest link")
    envelope: tuple[Length, Length] | None = Field(None, description="[width, height] of the swept bounding box")
    gravity: tuple[float, float] = Field((0.0, -9.81), description="gravity in the plane [m/s²]")
    mass: MassModel = Field(default_factory=MassModel)

    def _common(self) -> dict:
        return dict(min_transmission=self.min_transmission, max_link_ratio=self.max_link_ratio, envelope=self.envelope)

    def synthesis(self):
        """The closed-form synthesis of this linkage (:mod:`mjbench.design.synthesis`)."""
        raise NotImplementedError

    def table(self, req, geom, loads) -> dict:
        """The ``[mechanism]`` table of the synthesised geometry (:mod:`mjbench.design.build`)."""
        return B.fourbar_table(geom, self.mass, name=req.name, gravity=self.gravity, loads=loads, tool_at=self.tool_at)

    def synthesize(self, req) -> tuple:
        """(Synthesis, ``[mechanism]`` table, geometry) of the requirement."""
        syn = self.synthesis()
        geom = syn.geometry
        return syn, self.table(req, geom, [B.load_table(ld, geom) for ld in req.loads]), geom

    def task_rows(self, syn, an, syn_json, row, src) -> list:
        """The rows of this linkage's own task (stroke, swing, structural error, poses)."""
        return []

    def requirement_rows(self, req, syn, an, syn_json, ach, row) -> list:
        """Every requirement of the mechanism with the achieved value (``an``: mjbench analyze of the
        designed machine): its task (:meth:`task_rows`), the transmission angle, the synthesis's
        size constraints.  ``row``: the design report's row maker."""
        src = "mjbench analyze (own position solver)"
        rows = self.task_rows(syn, an, syn_json, row, src)
        trans = an["transmission_angles_deg"]
        if trans:
            mu = min(v["min"] for v in trans.values())
            if self.min_transmission is not None:
                rows.append(row("minimum transmission angle", math.degrees(self.min_transmission), mu, "min", "°", src))
            else:
                rows.append(row("minimum transmission angle", None, mu, "info", "°", src, ok=True))
        if syn is not None:
            for c in syn.constraints:
                if c["name"].startswith(("link-length", "envelope", "input crank")):
                    rows.append(row(c["name"], c["limit"], c["value"], {"max": "max", "min": "min"}.get(c["compare"], "true"),
                                    c["unit"], "synthesis (closed form)", ok=c["ok"]))
        return rows


def _time_ratio_rows(an, joint: str, what: str, time_ratio: float, row, src) -> list:
    """The time ratio (slower / faster arc of ``joint``'s stroke, mjbench analyze) against the required one."""
    arcs = an["stroke_arcs_deg"].get(joint)
    if not arcs:
        return []
    Q = max(arcs.values()) / min(arcs.values())
    return [row(what, time_ratio, Q, "eq", "1", src, ok=abs(Q - time_ratio) <= 1e-3 * time_ratio)]


class SliderCrankReq(_MechBase):
    """Offset slider-crank from stroke and time ratio."""

    type: Literal["slider-crank"] = "slider-crank"
    stroke: Q("length", gt=0.0) = Field(description="slider stroke")
    time_ratio: float = Field(1.0, ge=1.0, le=3.0, description="slow (working) stroke time / return stroke time")
    offset: OptQ("length", gt=0.0) = Field(None, description="offset of the slide line (default: best transmission)")
    working_direction: tuple[float, float] = Field((0.0, -1.0), description="direction of the slow, working stroke")
    rod_ratio: float | None = Field(None, gt=1.0, description="rod / crank for time ratio 1 (default: from min_transmission)")

    @field_validator("working_direction")
    @classmethod
    def _w(cls, v):
        if not math.hypot(*v) > 0:
            raise _err("has zero length")
        return v

    load_points: ClassVar[tuple] = ("crank.O", "crank.B", "rod.B", "rod.C", "ram.C")

    def synthesis(self):
        return S.slider_crank(self.stroke, self.time_ratio, offset=self.offset, working_direction=self.working_direction,
                              rod_ratio=self.rod_ratio, **self._common())

    def table(self, req, geom, loads) -> dict:
        return B.slidercrank_table(geom, self.mass, name=req.name, gravity=self.gravity, loads=loads)

    def task_rows(self, syn, an, syn_json, row, src) -> list:
        st = an["strokes_m"].get("guide")
        return [row("stroke", self.stroke * 1e3, st * 1e3, "eq", "mm", src, ok=abs(st - self.stroke) <= 1e-6 * self.stroke),
                *_time_ratio_rows(an, "guide", "time ratio (slow / return stroke)", self.time_ratio, row, src)]


class CrankRockerReq(_MechBase):
    """Crank-rocker from rocker swing and time ratio."""

    type: Literal["crank-rocker"] = "crank-rocker"
    swing: Q("angle", gt=0.0, lt=math.pi) = Field(description="rocker swing")
    time_ratio: float = Field(1.0, ge=1.0, le=3.0)
    rocker_length: OptQ("length", gt=0.0) = None
    ground_length: OptQ("length", gt=0.0) = None
    slow_swing: Literal["ccw", "cw"] = Field("ccw", description="rocker direction on the slow stroke")
    rocker_mid_angle: Angle = Field(0.5 * math.pi, description="direction of the rocker at mid swing")

    @model_validator(mode="after")
    def _scale(self):
        if (self.rocker_length is None) == (self.ground_length is None):
            raise _err("give exactly one of rocker_length, ground_length (the scale)")
        return self

    def synthesis(self):
        return S.crank_rocker(self.swing, self.time_ratio, rocker_length=self.rocker_length,
                              ground_length=self.ground_length, slow_swing=self.slow_swing,
                              rocker_mid_angle=self.rocker_mid_angle, **self._common())

    def task_rows(self, syn, an, syn_json, row, src) -> list:
        sw = an["swings_deg"].get("D")
        return [row("rocker swing", math.degrees(self.swing), sw, "eq", "°", src,
                    ok=sw is not None and abs(sw - math.degrees(self.swing)) <= 1e-3),
                *_time_ratio_rows(an, "D", "time ratio (slow / fast swing)", self.time_ratio, row, src)]


class FunctionReq(_MechBase):
    """Four-bar function generator (Freudenstein)."""

    type: Literal["function-generator"] = "function-generator"
    function: str = Field(description="y = f(x), an expression in x, e.g. 'log10(x)'")
    x_range: tuple[float, float] = Field(description="[x0, x1]")
    input_range: Q("angle", gt=0.0, le=2 * math.pi) = Field(description="crank rotation Δφ over [x0, x1]")
    output_range: Angle = Field(description="rocker rotation Δψ over [y0, y1] (negative: clockwise)")
    input_start: OptQ("angle") = Field(None, description="φ0 from the line A→D (default: searched)")
    output_start: OptQ("angle") = Field(None, description="ψ0 (default: searched)")
    method: Literal["chebyshev", "least-squares"] = "chebyshev"
    points: int = Field(3, ge=3, le=1000, description="precision points (3 for chebyshev)")
    ground_length: Q("length", gt=0.0) = Field(description="A→D (the scale)")
    full_rotation: Bool = Field(True, description="the crank must turn fully (a motor-driven machine)")
    max_structural_error: OptQ("angle", gt=0.0) = Field(None, description="largest |ψ − ψ_desired| allowed")

    @field_validator("function")
    @classmethod
    def _f(cls, v):
        try:
            compile_function(v)
        except ValueError as e:
            raise _err("{m}", m=str(e)) from None
        return v

    @model_validator(mode="after")
    def _range(self):
        x0, x1 = self.x_range
        if not x1 > x0:
            raise _err("x_range = {r}: need x0 < x1", r=list(self.x_range))
        f = compile_function(self.function)
        y = f(np.linspace(x0, x1, 201))
        if not np.all(np.isfinite(y)):
            raise _err("function {f!r} is not finite over x_range {r}", f=self.function, r=list(self.x_range))
        if y[0] == y[-1]:
            raise _err("function {f!r} has f(x0) = f(x1): no output range to scale", f=self.function)
        if self.output_range == 0:
            raise _err("output_range must not be 0")
        if self.method == "chebyshev" and self.points != 3:
            raise _err("method chebyshev uses 3 precision points (points = {p}); use least-squares for more",
                       p=self.points)
        if self.method == "least-squares" and self.points < 4:
            raise _err("method least-squares needs points >= 4, got {p}", p=self.points)
        return self

    def synthesis(self):
        spec = S.FunctionSpec(compile_function(self.function), self.x_range[0], self.x_range[1], self.input_range,
                              self.output_range, self.function)
        return S.function_generator(spec, ground_length=self.ground_length, phi0=self.input_start,
                                    psi0=self.output_start, method=self.method, n_points=self.points,
                                    full_rotation=self.full_rotation, max_structural_error=self.max_structural_error,
                                    **self._common())

    def task_rows(self, syn, an, syn_json, row, src) -> list:
        sc = syn_json.get("solver_check", {})
        what, where = "structural error (max |ψ − ψ_desired|)", "mjbench position solver, 201 points"
        if self.max_structural_error is not None:
            rows = [row(what, math.degrees(self.max_structural_error), sc.get("structural_error_max_deg_solver"),
                        "max", "°", where)]
        else:
            rows = [row(what, None, sc.get("structural_error_max_deg_solver"), "info", "°", where, ok=True)]
        if self.method == "chebyshev":
            rows.append(row("precision points met (solver)", 1e-9, sc.get("angle_residual_rad"), "max", "rad",
                            "mjbench position solver"))
        return rows


class MotionReq(_MechBase):
    """Four-bar motion generator through three coupler poses."""

    type: Literal["motion-generator"] = "motion-generator"
    poses: list[tuple[Length, Length, Angle]] = Field(description="three poses [x, y, angle] of the coupler frame")
    ground_pivots: list[Point] | None = Field(None, description="[[xA, yA], [xD, yD]] (input first)")
    moving_pivots: list[Point] | None = Field(None, description="coupler-frame moving pivots (input first)")
    search_box: list[Point] | None = Field(None, description="[[xmin, ymin], [xmax, ymax]] of the coupler frame")
    candidates: int = Field(256, ge=16, le=4096, description="Sobol candidates per dyad in the search")

    @model_validator(mode="after")
    def _poses(self):
        if len(self.poses) != 3:
            raise _err("need exactly three poses, got {n}", n=len(self.poses))
        if self.ground_pivots is not None and self.moving_pivots is not None:
            raise _err("give ground_pivots or moving_pivots, not both")
        for name in ("ground_pivots", "moving_pivots", "search_box"):
            v = getattr(self, name)
            if v is not None and len(v) != 2:
                raise _err("{n} needs two points, got {k}", n=name, k=len(v))
            if v is not None and math.hypot(v[1][0] - v[0][0], v[1][1] - v[0][1]) <= 1e-9:
                raise _err("{n}: the two points are the same ({p}): they must differ", n=name, p=list(v[0]))
        if self.search_box is not None and not all(self.search_box[1][i] > self.search_box[0][i] for i in (0, 1)):
            raise _err("search_box = {b}: need [[xmin, ymin], [xmax, ymax]] with xmin < xmax and ymin < ymax",
                       b=[list(x) for x in self.search_box])
        scale = max(1e-3, max(math.hypot(x, y) for x, y, _ in self.poses))
        for i in range(3):
            for j in range(i + 1, 3):
                (xi, yi, ai), (xj, yj, aj) = self.poses[i], self.poses[j]
                turn = abs(math.remainder(aj - ai, 2 * math.pi))
                if math.hypot(xj - xi, yj - yi) <= 1e-9 * scale and turn <= 1e-9:
                    raise _err("poses {i} and {j} are the same pose ({p}): three different poses are needed (a "
                               "pivot's three positions would not define its circle)", i=i + 1, j=j + 1,
                               p=[float(xi), float(yi), float(ai)])
        (x1, y1, a1), (x2, y2, a2), (x3, y3, a3) = self.poses
        same_angle = all(abs(math.remainder(a - a1, 2 * math.pi)) <= 1e-9 for a in (a2, a3))
        if same_angle and abs((x2 - x1) * (y3 - y1) - (y2 - y1) * (x3 - x1)) <= 1e-12 * scale ** 2:
            raise _err("the poses are a pure translation along a line (one angle, collinear positions): every pivot's "
                       "three positions are then collinear and no four-bar passes them (a slider would)")
        return self

    load_points: ClassVar[tuple] = ("crank.A", "crank.B", "coupler.B", "coupler.C", "coupler.P", "rocker.D", "rocker.C")
    tool_at: ClassVar[str] = "coupler.P"

    def synthesis(self):
        return S.motion_generator(self.poses, ground_pivots=self.ground_pivots, moving_pivots=self.moving_pivots,
                                  search_box=self.search_box, n_candidates=self.candidates, **self._common())

    def task_rows(self, syn, an, syn_json, row, src) -> list:
        sc = syn_json.get("solver_check", {})
        return [row("poses met, position (solver)", 1e-9, sc.get("position_residual_m"), "max", "m",
                    "mjbench position solver"),
                row("poses met, angle (solver)", 1e-9, sc.get("angle_residual_rad"), "max", "rad",
                    "mjbench position solver")]


class GivenReq(Strict):
    """An existing mechanism (the ``[mechanism]`` of a scenario), re-sized."""

    type: Literal["given"] = "given"
    scenario: str = Field(description="built-in scenario name or TOML path (relative to the requirements file)")

    load_points: ClassVar = None
    loads_refused: ClassVar[str] = "a given mechanism keeps the loads of its scenario ([[mechanism.loads]] there)"

    def synthesize(self, req) -> tuple:
        """(None, the scenario's ``[mechanism]`` table, None): nothing to synthesise."""
        path = req.path(self.scenario)
        scn = SC.load(path if os.path.exists(path) else self.scenario)
        return None, copy.deepcopy(scn.raw["mechanism"]), None

    def requirement_rows(self, req, syn, an, syn_json, ach, row) -> list:
        return []


MECHANISMS = {c.model_fields["type"].default: c for c in (SliderCrankReq, CrankRockerReq, FunctionReq, MotionReq,
                                                          GivenReq, CamReq)}


class LoadReq(Strict):
    """``[[loads]]``: a process force on a named point of the linkage, along a fixed direction.
    ``force`` (constant) or ``profile`` = [[distance before the end of the stroke, force], ...]
    (the stroke that ``active`` selects; piecewise linear, zero beyond)."""

    name: str = ""
    point: str = Field(description='"link.point" of the synthesised linkage, e.g. "ram.C"')
    direction: tuple[float, float] = Field(description="direction of a positive force (world)")
    force: OptQ("force", plausible=False) = None
    profile: list[tuple[Length, Q("force", plausible=False)]] | None = None
    active: Literal["always", "stroke_along", "stroke_against"] = "always"

    @model_validator(mode="after")
    def _law(self):
        if not math.hypot(*self.direction) > 0:
            raise _err("direction has zero length")
        if (self.force is None) == (self.profile is None):
            raise _err("give either force or profile")
        if self.profile is not None:
            if len(self.profile) < 2:
                raise _err("profile needs at least two points")
            if self.active == "always":
                raise _err("a profile is measured from the end of a stroke: set active = 'stroke_along' or "
                           "'stroke_against'")
            if any(h < 0 for h, _ in self.profile):
                raise _err("profile distances must be >= 0")
        return self


class DutyLaw(Strict):
    """``[duty.law]``: the crank follows a rest-to-rest motion law once round per cycle (one turn
    in ``move_fraction`` of the cycle, then it dwells), the cycle repeated (mjbench/motionlaws.py,
    the scenario's ``[law]`` kinds)."""

    kind: Literal["pseudopoly", "bezier"] = Field("pseudopoly", description="law family")
    gammas: list[float] | None = Field(None, description="pseudopoly exponents (default 3, 4, 5: the 3-4-5 law)")
    m: int = Field(2, ge=0, description="bezier continuity order")
    p: int = Field(3, ge=0, description="bezier free interior ordinates")
    interior_over_Phi: list[float] | None = Field(None, description="bezier interior ordinates / 2π")
    move_fraction: float = Field(1.0, gt=0.0, le=1.0, description="part of the cycle the turn takes (the rest: dwell)")

    @model_validator(mode="after")
    def _family(self):
        own = {"pseudopoly": ("gammas",), "bezier": ("m", "p", "interior_over_Phi")}
        foreign = [k for fam, keys in own.items() if fam != self.kind for k in keys if k in self.model_fields_set]
        if foreign:
            raise _err("{keys} belong to another law family than kind = {kind!r} (they would be ignored)",
                       keys=", ".join(foreign), kind=self.kind)
        return self

    def build(self, T_cycle: float):
        """The crank's law over one cycle: 2π in move_fraction × T_cycle [s] (crank side)."""

        T = self.move_fraction * float(T_cycle)
        if self.kind == "pseudopoly":
            return PseudoPolynomialLaw(2.0 * math.pi, T, self.gammas or (3.0, 4.0, 5.0))
        interior = None if self.interior_over_Phi is None else [2.0 * math.pi * v for v in self.interior_over_Phi]
        return BezierLaw(2.0 * math.pi, T, self.m, self.p, interior)


class Duty(Strict):
    """``[duty]``: the input (crank) speed — constant, or a motion law per cycle (``[duty.law]``) —
    and its bounds: the speed fluctuation χ_max (constant speed), the tracking error (law)."""

    speed: OptQ("angular_velocity", gt=0.0) = Field(None, description="crank speed (a law: the mean), e.g. '60 rpm'")
    cycles_per_minute: float | None = Field(None, gt=0.0, description="instead of speed: strokes per minute")
    chi_max: float | None = Field(None, gt=0.0, lt=1.0, description="bound of χ = (ω_max − ω_min)/ω_mean per cycle")
    law: DutyLaw | None = Field(None, description="the crank follows this motion law once round per cycle")
    tracking_error_max: OptQ("angle", gt=0.0) = Field(
        None, description="a law duty: largest crank-angle error |q_ref − q| allowed in steady state")
    ambient_temperature: float = Field(25.0, ge=-40.0, le=100.0, description="[°C]")

    @model_validator(mode="after")
    def _speed(self):
        if (self.speed is None) == (self.cycles_per_minute is None):
            raise _err("give exactly one of speed, cycles_per_minute")
        if self.law is not None and self.chi_max is not None:
            raise _err("chi_max bounds the speed fluctuation at constant speed; a motion-law duty prescribes the speed "
                       "(bound its tracking error: tracking_error_max)")
        if self.law is None and self.tracking_error_max is not None:
            raise _err("tracking_error_max needs a motion law ([duty.law]); at constant speed bound chi_max")
        return self

    @property
    def cycle_time(self) -> float:
        """One cycle (one crank turn) [s]."""
        return 2.0 * math.pi / self.omega

    @property
    def omega(self) -> float:
        return float(self.speed) if self.speed is not None else 2 * math.pi * float(self.cycles_per_minute) / 60.0


class DriveReq(Strict):
    """``[drive]``: what the drive may use."""

    supply_voltage: Q("voltage", gt=0.0) = Field(description="DC supply of the amplifier")
    catalogue: str = Field("example", description="'example' (illustrative values) or a CSV/TOML file")
    current_limit: OptQ("current", gt=0.0) = Field(None, description="amplifier current limit (default: the motor's peak)")
    voltage_headroom: float = Field(0.10, ge=0.0, lt=0.9, description="fraction of the supply kept for control")
    direct_drive: Bool = Field(False, description="also consider motors without gearbox (z = 1)")
    motors: list[str] | None = Field(None, description="only these catalogue motors")
    gearboxes: list[str] | None = Field(None, description="only these catalogue gearboxes")
    flywheel: Bool = Field(True, description="a flywheel is allowed")
    flywheel_location: Literal["motor", "crank"] = Field(
        "motor", description="on the motor shaft (z² times as effective; its torque passes the gearbox) or on the crank")
    flywheel_max: OptQ("inertia", gt=0.0) = Field(None, description="largest flywheel (at its location)")


class ControlReq(Strict):
    """``[control]``: the speed PID (a motion-law duty: the cascade servo), tuned by mjbench tune
    within the box the sizing model allows."""

    tune: Bool = Field(True, description="tune the gains (mjbench.tune); false: the design rule's")
    objective: Literal["chi", "ise", "iae", "itae", "tracking_rms", "tracking_peak"] | None = Field(
        None, description="tune objective (default: chi of the last cycle; a law duty: tracking_rms)")
    tracking_bandwidth_ratio: float = Field(
        20.0, gt=0.0, le=1000.0, description="a law duty's design rule: velocity-loop crossover / (2π / move time)")
    margins: list[str] = Field(default_factory=lambda: ["pm>=45", "ms<=2"], description="tune --margin constraints")
    bandwidth_ratio: float = Field(0.5, gt=0.0, le=20.0, description="design rule: crossover / cycle frequency")
    n_global: int = Field(12, ge=1, le=1024)
    maxfev: int = Field(16, ge=0, le=1000)
    margin_angles: int = Field(6, ge=1, le=72)

    @field_validator("margins")
    @classmethod
    def _m(cls, v):

        for m in v:
            try:
                parse_margin(m)
            except ParameterError as e:
                raise _err("{m}", m=str(e).replace("--margin ", "")) from None
        return v


class VerifyReq(Strict):
    """``[verify]``: the multibody verification."""

    tolerance: float = Field(0.02, gt=0.0, lt=1.0, description="predicted vs simulated, relative (torque, current)")
    dt: Q("time", gt=0.0, le=1e-3) = 1e-4
    cycles: int = Field(3, ge=2, le=50, description="simulated cycles from the predicted steady state")


class Requirements(Strict):
    """A validated requirements file (``mechanism`` is the Params of its ``type``)."""

    design: Meta
    mechanism: object
    loads: list[LoadReq] = Field(default_factory=list)
    duty: Duty
    drive: DriveReq
    control: ControlReq = Field(default_factory=ControlReq)
    verify: VerifyReq = Field(default_factory=VerifyReq)
    source: str = Field("", exclude=True)
    raw: dict = Field(default_factory=dict, exclude=True, repr=False)

    @model_validator(mode="after")
    def _objective(self):
        law = self.duty.law is not None
        if self.control.objective is None:
            self.control.objective = "tracking_rms" if law else "chi"
        elif law != self.control.objective.startswith("tracking"):
            raise _err("control.objective = {o!r}: a {what} duty is tuned for {want}",
                       o=self.control.objective, what="motion-law" if law else "constant-speed",
                       want="tracking_rms or tracking_peak" if law else "chi, ise, iae or itae")
        return self

    @property
    def name(self) -> str:
        return self.design.name

    def path(self, rel: str) -> str:
        """A path of the file made absolute relative to the requirements file."""
        if os.path.isabs(rel) or not self.source or self.source.startswith("builtin:"):
            return rel
        return os.path.join(os.path.dirname(self.source), rel)


REQUIREMENTS_DIR = ("scenarios", "requirements")


def builtin_names() -> list:
    import importlib.resources

    d = importlib.resources.files("mjbench").joinpath(*REQUIREMENTS_DIR)
    return sorted(p.name[:-5] for p in d.iterdir() if p.name.endswith(".toml")) if d.is_dir() else []


def read(path_or_name: str) -> tuple[dict, str]:
    """Raw tables of a requirements file (a path, or a built-in name of mjbench/scenarios/requirements)."""
    import importlib.resources

    if os.path.exists(path_or_name):
        if os.path.isdir(path_or_name):
            raise ScenarioError(f"requirements {path_or_name!r} is a directory; give a TOML file")
        with open(path_or_name, "rb") as f:
            text = f.read()
        source = os.path.abspath(path_or_name)
    else:
        res = importlib.resources.files("mjbench").joinpath(*REQUIREMENTS_DIR, f"{path_or_name}.toml")
        if not res.is_file():
            raise ScenarioError(f"requirements {path_or_name!r}: no such file, and not a built-in requirements "
                                f"file ({', '.join(builtin_names())})")
        text = res.read_bytes()
        source = f"builtin:{path_or_name}"
    try:
        raw = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ScenarioError(f"requirements {path_or_name!r} is not valid TOML: {e}") from None
    return raw, source


def load(path_or_name: str) -> Requirements:
    raw, source = read(path_or_name)
    return validate(raw, source)


def validate(raw: dict, source: str = "") -> Requirements:
    """Validate raw tables → :class:`Requirements`, or ONE ScenarioError listing every problem."""
    problems: list[str] = []
    if not isinstance(raw, dict):
        raise ScenarioError(f"requirements {source}: not a table")
    mech = None
    mraw = raw.get("mechanism")
    if mraw is None:
        problems.append("mechanism: required table is missing ([mechanism] with type = ...)")
    elif not isinstance(mraw, dict):
        problems.append(f"mechanism: must be a table, got {mraw!r}")
    else:
        cls = MECHANISMS.get(mraw.get("type"))
        if cls is None:
            typ = mraw.get("type")
            problems.append(f"mechanism.type: {'required value is missing' if typ is None else repr(typ) + ' is not a synthesis task'}; "
                            f"choose one of {', '.join(MECHANISMS)}")
        else:
            try:
                mech = cls.model_validate(mraw)
            except ValidationError as e:
                problems += format_errors(e, ("mechanism",), cls)
    top = {k: v for k, v in raw.items() if k != "mechanism"}
    top["mechanism"] = None
    req = None
    try:
        req = Requirements.model_validate(top)
    except ValidationError as e:
        problems += format_errors(e, (), Requirements)
    typ = mraw.get("type") if isinstance(mraw, dict) else None
    dr = raw.get("drive") if isinstance(raw.get("drive"), dict) else {}
    cat = dr.get("catalogue")
    if isinstance(cat, str) and cat != "example":
        base = os.path.dirname(source) if source and not source.startswith("builtin:") else ""
        path = cat if os.path.isabs(cat) or not base else os.path.join(base, cat)
        if not os.path.isfile(path):
            problems.append(f"drive.catalogue: no such file {path!r} (a CSV or TOML catalogue, or 'example')")
    loads = raw.get("loads") if isinstance(raw.get("loads"), list) else []
    if typ in MECHANISMS:
        cls = MECHANISMS[typ]
        pts = cls.load_points
        for k, ld in enumerate(loads):
            pt = ld.get("point") if isinstance(ld, dict) else None
            if pts is not None and isinstance(pt, str) and pt not in pts:
                problems.append(f"loads[{k}].point: {pt!r} is not a point of the {typ} ({', '.join(pts)})")
        if cls.loads_refused and loads:
            problems.append(f"loads: {cls.loads_refused}")
    if problems:
        name = (raw.get("design") or {}).get("name", "?") if isinstance(raw.get("design"), dict) else "?"
        where = f" ({source})" if source else ""
        if len(problems) == 1:
            raise ScenarioError(f"requirements {name!r}{where}: {problems[0]}", problems=problems)
        raise ScenarioError(f"requirements {name!r}{where} has {len(problems)} problems:\n  " + "\n  ".join(problems),
                            problems=problems)
    req.mechanism = mech
    req.source, req.raw = source, raw
    return req
