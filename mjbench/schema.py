"""The scenario schema: every table of a scenario file as a typed, validated object (pydantic v2).

A scenario is parsed once, at load, by :func:`validate` into a :class:`Scenario`:

    [scenario]    ScenarioMeta       name, title, paper, description
    [mechanism]   <Mechanism>.Params chosen by ``type`` (registry: mjbench.mechanisms)
    [drive]       drive.DriveParams  DC motor + gearbox (+ optional drive-train elements)
    [initial]     Initial            q0, qd0, I0 (default: at rest at q = 0, no current)
    [simulation]  Simulation         t_end, dt, record_dt, mode, backend
    [multibody]   MultibodyOptions   MuJoCo integrator and constraint settings
    [reduced]     ReducedOptions     integrator of the reduced model
    [modes.NAME]  <Controller>.Params chosen by ``type`` (registry: controllers)
    [metrics]     Metrics            metric settings (χ window, steady-state start, ...)
    [law] [optimize] [check]         motion law and its residual-vibration study (platforms)
    [paper]       free-form          the paper's reported figures (read by mjbench.papers)
    [aliases]     {short: dotted}    short names for ``--set`` (targets are checked)

Rules: unknown tables or keys, missing required values, wrong types, wrong units and
non-physical values are collected into ONE :class:`~mjbench.errors.ScenarioError` that lists
every problem with its TOML path (``drive.R: must be > 0 Ω, got -1``).  Physical values may
carry a unit (``a = "60 mm"``, see :mod:`mjbench.units`); bare numbers are SI.  Defaults are
documented on each field; nothing physical is silently zero.
"""
from __future__ import annotations

import math
from typing import Annotated, Any, ClassVar, Literal

from pydantic import (BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, field_validator,
                      model_validator)
from pydantic_core import PydanticCustomError

from . import units as U
from .errors import ScenarioError

__all__ = ["Q", "OptQ", "Strict", "Scenario", "validate", "ScenarioMeta", "Initial", "Simulation",
           "MultibodyOptions", "ReducedOptions", "Metrics"]


# ============================================================================ field types
class UnitMeta:
    """Marker in a field's metadata: its quantity kind (SI unit) and what it is (warnings)."""

    __slots__ = ("kind", "what", "plausible")

    def __init__(self, kind, what="", plausible=True):
        self.kind, self.what, self.plausible = kind, what, plausible

    def __repr__(self):
        return f"UnitMeta({self.kind!r})"


def _converter(kind, bound, allow_none=False):
    label = U.KINDS[kind][1]

    def conv(v):
        if allow_none and (v is None or (isinstance(v, str) and v.strip().lower() == "none")):
            return None
        try:
            x = U.to_si(v, kind)
            bound.check(x, label)
        except U.UnitError as e:
            raise PydanticCustomError("mjbench_value", str(e)) from None
        return x

    return conv


def Q(kind: str, *, gt=None, ge=None, lt=None, le=None, finite=True, what="", plausible=True):
    """A physical float field of ``kind`` (SI unit of :data:`mjbench.units.KINDS`) with bounds."""
    b = U.Bound(gt, ge, lt, le, finite)
    return Annotated[float, BeforeValidator(_converter(kind, b)), UnitMeta(kind, what, plausible)]


def OptQ(kind: str, *, gt=None, ge=None, lt=None, le=None, finite=True, what="", plausible=True):
    """Like :func:`Q` but ``None`` / ``"none"`` is accepted (feature off)."""
    b = U.Bound(gt, ge, lt, le, finite)
    return Annotated[float | None, BeforeValidator(_converter(kind, b, allow_none=True)),
                     UnitMeta(kind, what, plausible)]


def _strict_bool(v):
    if not isinstance(v, bool):
        raise PydanticCustomError("mjbench_value", "must be true or false, got {v!r}", {"v": v})
    return v


Bool = Annotated[bool, BeforeValidator(_strict_bool)]


class Strict(BaseModel):
    """Base of every scenario table: unknown keys are errors; values validated on assignment."""

    model_config = ConfigDict(extra="forbid", validate_default=True, validate_assignment=True,
                              arbitrary_types_allowed=True, frozen=False)

    def to_dict(self) -> dict:
        """Plain, JSON-ready dict (SI floats; ±inf written as the strings "inf"/"-inf")."""
        return _jsonable(self.model_dump(mode="python", exclude_none=False))


def _jsonable(o):
    if isinstance(o, dict):
        return {k: _jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_jsonable(v) for v in o]
    if isinstance(o, float) and math.isinf(o):
        return "inf" if o > 0 else "-inf"
    return o


# ============================================================================ generic tables
class ScenarioMeta(Strict):
    """``[scenario]``: identification of the machine (no physics)."""

    name: str
    title: str = ""
    paper: str = Field("", description="the paper this scenario reproduces, e.g. 'Incerti 2012'")
    seed: str = Field("", description="internal index of the source paper (000 … 004)")
    description: str = ""


class Initial(Strict):
    """``[initial]``: state at t = 0.  Default: at rest at q = 0 with no current."""

    q0: Q("angle") = 0.0
    qd0: Q("angular_velocity", plausible=False) = 0.0
    I0: Q("current", plausible=False) = 0.0


class Simulation(Strict):
    """``[simulation]``: run length, co-simulation (control) step, recording, default mode/backend."""

    t_end: Q("time", gt=0.0, what="a run length")
    dt: Q("time", gt=0.0, le=0.01, what="a co-simulation step") = 1e-4
    record_dt: Q("time", gt=0.0, what="a recording interval") = 1e-3
    mode: str | None = Field(None, description="default [modes.NAME] to run")
    backend: Literal["multibody", "reduced", "both"] = "both"


class MultibodyOptions(Strict):
    """``[multibody]``: MuJoCo options.  RK4 is the validated default; Euler/implicitfast are
    faster but less accurate (docs/validation.md)."""

    integrator: Literal["RK4", "Euler", "implicit", "implicitfast"] = "RK4"
    solref: tuple[float, float] | None = Field(None, description="loop-closure solref (default: 3·dt, 1; mechanisms/base.py)")
    solimp: tuple[float, float, float, float, float] | None = None
    iterations: int = Field(100, ge=1)
    tolerance: float = Field(1e-12, gt=0.0)

    def as_options(self, dt: float) -> dict:
        o = {"integrator": self.integrator, "timestep": float(dt), "iterations": self.iterations,
             "tolerance": self.tolerance}
        if self.solref is not None:
            o["solref"] = list(self.solref)
        if self.solimp is not None:
            o["solimp"] = list(self.solimp)
        return o


class ReducedOptions(Strict):
    """``[reduced]``: integrator of the reduced model over one co-simulation step."""

    method: Literal["rk4", "solve_ivp"] = "rk4"
    model: Literal["table", "closed"] = Field(
        "table", description="rigid mechanisms: tabulated J, J', E_p' (error ≤ 1e-9, fast) or the closed forms")
    rtol: float = Field(1e-10, gt=0.0)
    atol: float = Field(1e-12, gt=0.0)


class Metrics(Strict):
    """``[metrics]``: settings of the metrics (all optional)."""

    chi_window: tuple[Q("time", ge=0.0, plausible=False), Q("time", ge=0.0, plausible=False)] | None = Field(
        None, description="window [t0, t1] of the windowed χ (seed 000 §III: 0.375–0.5 s)")
    chi_average: Literal["mean", "midrange"] = "mean"
    steady_start: OptQ("time", ge=0.0, plausible=False) = Field(
        None, description="start of the steady-state window (default: half the run)")
    omega_d: OptQ("angular_velocity", plausible=False) = Field(
        None, description="crank-speed set-point for the steady-error metrics (default: from the controller)")
    settle_time: OptQ("time", ge=0.0, plausible=False) = Field(None, description="tracking errors judged after this time")
    band_rel: float = Field(0.10, gt=0.0, description="settling band, fraction of the set-point")
    rise_fraction: float = Field(0.90, gt=0.0, le=1.0, description="rise time: first time at this fraction")
    crank_error_band: OptQ("angular_velocity", plausible=False) = None
    backend_tolerance: float = Field(1e-3, gt=0.0, description="multibody vs reduced: max |Δα̇|/peak before a warning")

    @model_validator(mode="after")
    def _window(self):
        if self.chi_window is not None and not self.chi_window[1] > self.chi_window[0]:
            raise PydanticCustomError("mjbench_value", "chi_window = {w}: need t0 < t1 [s]", {"w": list(self.chi_window)})
        return self


# ============================================================================ motion law study
class LawParams(Strict):
    """``[law]``: a rest-to-rest motion law of the motor (seeds 001/003)."""

    kind: Literal["pseudopoly", "bezier"] = "pseudopoly"
    Phi: Q("angle", plausible=False) | None = Field(None, description="total motor rotation [rad]")
    revolutions: float | None = Field(None, description="total motor rotation in revolutions (instead of Phi)")
    T: Q("time", gt=0.0, what="a motion time")
    gammas: list[float] | None = Field(None, description="pseudopoly exponents (default 3, 4, 5)")
    m: int = Field(2, ge=0, description="bezier continuity order")
    p: int = Field(3, ge=0, description="bezier free interior ordinates")
    interior: list[float] | None = Field(None, description="bezier interior ordinates [rad]")
    interior_over_Phi: list[float] | None = None

    #: keys of each law family (the others' keys are refused, never ignored)
    FAMILY_KEYS: ClassVar[dict] = {"pseudopoly": ("gammas",), "bezier": ("m", "p", "interior", "interior_over_Phi")}

    @model_validator(mode="after")
    def _phi(self):
        if (self.Phi is None) == (self.revolutions is None):
            raise PydanticCustomError("mjbench_value", "give exactly one of Phi [rad] or revolutions")
        foreign = [(k, fam) for fam, keys in self.FAMILY_KEYS.items() if fam != self.kind for k in keys
                   if k in self.model_fields_set]
        if foreign:
            raise PydanticCustomError(
                "mjbench_value", "{keys} is a key of the {fam} law family, but this law is kind = {kind}, whose shape "
                "keys are {own} (a key of another family would be ignored)",
                {"keys": ", ".join(f"law.{k}" for k, _ in foreign), "fam": foreign[0][1], "kind": repr(self.kind),
                 "own": ", ".join(self.FAMILY_KEYS[self.kind])})
        if self.kind == "bezier" and self.interior is not None and self.interior_over_Phi is not None:
            raise PydanticCustomError("mjbench_value", "give law.interior or law.interior_over_Phi, not both")
        return self

    @property
    def Phi_rad(self) -> float:
        return float(self.Phi) if self.Phi is not None else 2.0 * math.pi * float(self.revolutions)

    def build(self):
        from .motionlaws import BezierLaw, PseudoPolynomialLaw

        if self.kind == "pseudopoly":
            return PseudoPolynomialLaw(self.Phi_rad, self.T, self.gammas or (3.0, 4.0, 5.0))
        interior = self.interior
        if interior is None and self.interior_over_Phi is not None:
            interior = [v * self.Phi_rad for v in self.interior_over_Phi]
        return BezierLaw(self.Phi_rad, self.T, self.m, self.p, interior)


class OptimizeParams(Strict):
    """``[optimize]``: residual-vibration optimisation of the law (0 = no limit)."""

    method: Literal["BFGS", "SLSQP"] = "BFGS"
    gtol: float = Field(1e-13, gt=0.0)
    maxiter: int = Field(500, ge=1)
    max_speed: Q("angular_velocity", ge=0.0, plausible=False) = 0.0
    max_accel: Q("angular_acceleration", ge=0.0, plausible=False) = 0.0
    max_torque: Q("torque", ge=0.0, plausible=False) = 0.0


class CheckParams(Strict):
    """``[check]``: cross-checks of the motion-law study."""

    multibody: Bool = True
    multibody_dt: Q("time", gt=0.0, le=0.01) = 1e-3
    t_after: Q("time", gt=0.0) = 0.5
    sensitivity: list[float] = Field(default_factory=lambda: [-0.05, -0.025, 0.0, 0.025, 0.05])
    shapers: list[Literal["ZV", "ZVD"]] = Field(default_factory=lambda: ["ZV", "ZVD"])


# ============================================================================ the scenario
class Scenario(Strict):
    """A validated scenario.  ``mechanism`` and every ``modes`` entry are the Params objects of
    their registered type; ``raw`` is the dict the file gave (overrides applied), ``source`` where
    it came from."""

    scenario: ScenarioMeta
    mechanism: Any
    drive: Any
    initial: Initial = Field(default_factory=Initial)
    simulation: Simulation
    multibody: MultibodyOptions = Field(default_factory=MultibodyOptions)
    reduced: ReducedOptions = Field(default_factory=ReducedOptions)
    modes: dict[str, Any] = Field(default_factory=dict)
    metrics: Metrics = Field(default_factory=Metrics)
    law: LawParams | None = None
    optimize: OptimizeParams | None = None
    check: CheckParams | None = None
    paper: dict[str, Any] = Field(default_factory=dict, description="the paper's reported figures (free form)")
    aliases: dict[str, str] = Field(default_factory=dict)

    # set by the loader, not part of the file
    source: str = Field("", exclude=True)
    overrides: list[str] = Field(default_factory=list, exclude=True)
    raw: dict = Field(default_factory=dict, exclude=True, repr=False)
    warnings: list[str] = Field(default_factory=list, exclude=True)

    model_config = ConfigDict(extra="forbid", arbitrary_types_allowed=True, validate_assignment=False)

    @field_validator("modes")
    @classmethod
    def _mode_names(cls, v):
        for k in v:
            if not str(k).replace("_", "").replace("-", "").isalnum():
                raise PydanticCustomError("mjbench_value", "mode name {k!r}: use letters, digits, _ or -", {"k": k})
        return v

    # ------------------------------------------------------------------ convenience
    @property
    def name(self) -> str:
        return self.scenario.name

    def mode(self, mode: str | None = None) -> str:
        """The mode to run: ``mode`` or the scenario's default, checked."""
        from .errors import ScenarioError as SE

        m = mode or self.simulation.mode
        if m is None:
            if len(self.modes) == 1:
                return next(iter(self.modes))
            raise SE(f"scenario {self.name!r}: no mode given and simulation.mode is not set; "
                     f"modes: {sorted(self.modes)}")
        if m not in self.modes:
            raise SE(f"mode {m!r} is not defined in scenario {self.name!r}; modes: {sorted(self.modes) or 'none'}")
        return m

    def multibody_options(self) -> dict:
        return self.multibody.as_options(self.simulation.dt)

    def resolved(self) -> dict:
        """Every value of the scenario, SI, defaults filled in (JSON-ready; re-loadable)."""
        out = {}
        for name in type(self).model_fields:
            if name in ("source", "overrides", "raw", "warnings"):
                continue
            v = getattr(self, name)
            if v is None or (name in ("paper", "aliases") and not v):
                continue
            if isinstance(v, BaseModel):
                out[name] = _jsonable(v.model_dump(mode="python"))
            elif name == "modes":
                out[name] = {k: _jsonable(m.model_dump(mode="python")) for k, m in v.items()}
            else:
                out[name] = _jsonable(v)
        return out

    def get(self, dotted: str, default=None):
        """Value at a dotted path of the validated scenario (aliases resolved)."""
        node: Any = self
        for p in self.aliases.get(dotted, dotted).split("."):
            if isinstance(node, dict):
                if p not in node:
                    return default
                node = node[p]
            elif isinstance(node, BaseModel):
                if p not in type(node).model_fields:
                    return default
                node = getattr(node, p)
            else:
                return default
        return default if node is None else node


# ============================================================================ validation
def _allowed_keys(model_cls, loc):
    """Field names of the model at ``loc`` (for 'unknown key' messages), or None."""
    cls = model_cls
    for p in loc:
        if cls is None or not isinstance(cls, type) or not issubclass(cls, BaseModel):
            return None
        f = cls.model_fields.get(p) if isinstance(p, str) else None
        if f is None:
            return None
        ann = f.annotation
        cls = _model_in(ann)
    if cls is not None and isinstance(cls, type) and issubclass(cls, BaseModel):
        return sorted(k for k, v in cls.model_fields.items() if not v.exclude)
    return None


def _model_in(ann):
    import typing

    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    for a in typing.get_args(ann) or ():
        m = _model_in(a)
        if m is not None:
            return m
    return None


def format_errors(err: ValidationError, prefix: tuple = (), model_cls=None) -> list[str]:
    """One line per problem: ``path: message`` (pydantic's wording made readable)."""
    lines = []
    for e in err.errors(include_url=False):
        loc = tuple(prefix) + tuple(str(p) for p in e["loc"])
        path = ".".join(loc) or "(top level)"
        typ = e["type"]
        inp = e.get("input")
        if typ == "missing":
            msg = "required value is missing"
            desc = _field_description(model_cls, e["loc"]) if model_cls else ""
            if desc:
                msg += f" ({desc})"
        elif typ == "extra_forbidden":
            allowed = _allowed_keys(model_cls, e["loc"][:-1]) if model_cls else None
            kind = "table" if isinstance(inp, dict) else "key"
            msg = f"unknown {kind}"
            if allowed:
                msg += f"; allowed here: {', '.join(allowed)}"
        elif typ.startswith("mjbench"):
            msg = e["msg"]
        elif typ in ("literal_error", "enum"):
            msg = e["msg"].replace("Input should be", "must be") + f", got {inp!r}"
        elif typ in ("float_parsing", "float_type", "int_parsing", "int_type", "bool_parsing", "bool_type",
                     "string_type", "dict_type", "list_type", "tuple_type", "model_type", "int_from_float"):
            msg = e["msg"].replace("Input should be", "must be") + f", got {inp!r}"
        else:
            msg = e["msg"].replace("Input should be", "must be").replace("Value error, ", "")
            if inp is not None and not isinstance(inp, (dict, list)):
                msg += f", got {inp!r}"
        lines.append(f"{path}: {msg}")
    return lines


def _field_description(model_cls, loc):
    cls = model_cls
    for i, p in enumerate(loc):
        if cls is None or not isinstance(cls, type) or not issubclass(cls, BaseModel):
            return ""
        f = cls.model_fields.get(str(p))
        if f is None:
            return ""
        if i == len(loc) - 1:
            d = f.description or ""
            um = next((m for m in f.metadata if isinstance(m, UnitMeta)), None)
            if um is None:
                for a in _annot_args(f.annotation):
                    um = um or a
            unit = f"[{U.KINDS[um.kind][1]}]" if isinstance(um, UnitMeta) else ""
            return " ".join(x for x in (d, unit) if x)
        cls = _model_in(f.annotation)
    return ""


def _annot_args(ann):
    import typing

    out = []
    for a in typing.get_args(ann) or ():
        if isinstance(a, UnitMeta):
            out.append(a)
        out.extend(_annot_args(a))
    return out


def _plausibility(model: BaseModel, prefix: str, sink: list):
    """Plausibility warnings of every physical field of ``model`` (recursively)."""
    for name, f in type(model).model_fields.items():
        v = getattr(model, name, None)
        um = next((m for m in f.metadata if isinstance(m, UnitMeta)), None)
        path = f"{prefix}.{name}" if prefix else name
        if um is not None and um.plausible and isinstance(v, float):
            msg = U.plausibility(v, um.kind, um.what)
            if msg:
                sink.append(f"{path} {msg}")
        elif isinstance(v, BaseModel):
            _plausibility(v, path, sink)


def validate(raw: dict, source: str = "", overrides=()) -> Scenario:
    """Validate a scenario dict (as parsed from TOML, overrides applied) → :class:`Scenario`.
    Raises ONE ScenarioError listing every problem."""
    import controllers as CR

    from . import mechanisms as MR
    from .drive import DriveParams

    problems: list[str] = []
    if not isinstance(raw, dict):
        raise ScenarioError(f"scenario {source}: not a table")
    raw = dict(raw)
    # sub-tables validated through their registries
    mech, drive, modes = None, None, {}
    mraw = raw.get("mechanism")
    if mraw is None:
        problems.append("mechanism: required table is missing ([mechanism] with type = ...)")
    elif not isinstance(mraw, dict):
        problems.append(f"mechanism: must be a table, got {mraw!r}")
    else:
        typ = mraw.get("type")
        cls = MR.params_class(typ, mraw)
        if cls is None:
            problems.append(f"mechanism.type: {'required value is missing' if typ is None else repr(typ) + ' is not a known mechanism'}; "
                            f"choose one of {', '.join(MR.names())}")
        else:
            try:
                mech = cls.model_validate(mraw)
            except ValidationError as e:
                problems += format_errors(e, ("mechanism",), cls)
    draw = raw.get("drive")
    if draw is None:
        problems.append("drive: required table is missing ([drive] with R, L, k_m, J_m, z, lam ...)")
    elif not isinstance(draw, dict):
        problems.append(f"drive: must be a table, got {draw!r}")
    else:
        try:
            drive = DriveParams.model_validate(draw)
        except ValidationError as e:
            problems += format_errors(e, ("drive",), DriveParams)
    mraw_all = raw.get("modes", {})
    if not isinstance(mraw_all, dict):
        problems.append(f"modes: must be a table of [modes.NAME] tables, got {mraw_all!r}")
        mraw_all = {}
    for name, table in mraw_all.items():
        if not isinstance(table, dict):
            problems.append(f"modes.{name}: must be a table, got {table!r}")
            continue
        typ = table.get("type")
        cls = CR.params_class(typ, table)
        if cls is None:
            problems.append(f"modes.{name}.type: {'required value is missing' if typ is None else repr(typ) + ' is not a known controller'}; "
                            f"choose one of {', '.join(CR.names())}")
            continue
        try:
            modes[name] = cls.model_validate(table)
        except ValidationError as e:
            problems += format_errors(e, ("modes", name), cls)
    top = {k: v for k, v in raw.items() if k not in ("mechanism", "drive", "modes")}
    top.update(mechanism=mech, drive=drive, modes={})
    scn = None
    try:
        scn = Scenario.model_validate(top)
    except ValidationError as e:
        problems += format_errors(e, (), Scenario)
    if scn is not None:
        scn.modes = modes
        # cross-field checks
        if scn.simulation.mode is not None and scn.simulation.mode not in mraw_all:
            problems.append(f"simulation.mode: {scn.simulation.mode!r} is not one of the [modes.*] tables "
                            f"({', '.join(sorted(mraw_all)) or 'none defined'})")
        if scn.simulation.record_dt < scn.simulation.dt * (1 - 1e-9):
            problems.append(f"simulation.record_dt: must be >= dt = {scn.simulation.dt:g} s, got {scn.simulation.record_dt:g}")
        for alias, target in scn.aliases.items():
            if not _path_exists(raw, target, scn):
                problems.append(f"aliases.{alias}: target {target!r} is not a key of this scenario")
        if mech is not None and drive is not None:
            problems += drive.check_against(scn)  # drive-train tables vs modes and step
        for tbl in ("optimize", "check"):
            if getattr(scn, tbl) is not None and scn.law is None:
                problems.append(f"{tbl}: the [{tbl}] table belongs to a motion-law study and this scenario has no "
                                f"[law] table (it would be ignored)")
        problems += _figure_problems(scn.paper, mraw_all)
        _initial_from_stated_pose(scn, mech, raw)
    if problems:
        where = f" ({source})" if source else ""
        name = (raw.get("scenario") or {}).get("name", "?") if isinstance(raw.get("scenario"), dict) else "?"
        if len(problems) == 1:
            raise ScenarioError(f"scenario {name!r}{where}: {problems[0]}", problems=problems)
        raise ScenarioError(f"scenario {name!r}{where} has {len(problems)} problems:\n  "
                            + "\n  ".join(problems), problems=problems)
    scn.mechanism, scn.drive = mech, drive
    scn.source, scn.overrides, scn.raw = source, list(overrides), raw
    sink: list[str] = []
    for sec in ("mechanism", "drive", "initial", "simulation", "law"):
        v = getattr(scn, sec)
        if isinstance(v, BaseModel):
            _plausibility(v, sec, sink)
    for name, mp in modes.items():
        _plausibility(mp, f"modes.{name}", sink)
    scn.warnings = sink
    return scn


#: keys of a ``[[paper.figures]]`` entry (runner.paper_rows, verdicts.from_figure)
FIGURE_KEYS = ("name", "mode", "metric", "value", "band", "max", "min", "tolerance", "fitted", "unit", "note")


def _figure_problems(paper: dict, modes: dict) -> list:
    """``[[paper.figures]]`` entries checked like the rest of the file: a table each, known keys,
    an existing ``mode``, a ``metric`` a run computes, exactly one of value/band/max/min — else a
    figure would silently vanish from the report or read 'not computed'."""
    import difflib

    from . import metrics as M
    from .verdicts import from_figure

    figs = (paper or {}).get("figures")
    if figs is None:
        return []
    if not isinstance(figs, list):
        return ["paper.figures: must be an array of tables ([[paper.figures]])"]
    out, known = [], None
    for i, fig in enumerate(figs):
        where = f"paper.figures[{i}]"
        if not isinstance(fig, dict):
            out.append(f"{where}: must be a table, got {fig!r}")
            continue
        where = f"{where} ({fig.get('name', 'unnamed')!r})"
        extra = [k for k in fig if k not in FIGURE_KEYS]
        if extra:
            out.append(f"{where}: unknown key {', '.join(map(repr, extra))}; allowed: {', '.join(FIGURE_KEYS)}")
        if not isinstance(fig.get("name"), str):
            out.append(f"{where}.name: required (a string)")
        mode = fig.get("mode")
        if mode is not None and mode not in modes:
            near = difflib.get_close_matches(str(mode), list(modes), n=1)
            out.append(f"{where}.mode: {mode!r} is not one of the [modes.*] tables ({', '.join(sorted(modes)) or 'none'})"
                       + (f"; did you mean {near[0]!r}?" if near else ""))
        metric = fig.get("metric")
        if known is None:
            known = M.known_metrics()
        if not isinstance(metric, str):
            out.append(f"{where}.metric: required (the name of a metric of the run)")
        elif metric not in known:
            near = difflib.get_close_matches(metric, known, n=1)
            out.append(f"{where}.metric: {metric!r} is not a metric mjbench computes"
                       + (f"; did you mean {near[0]!r}?" if near else "") + f" (known: {', '.join(known)})")
        try:
            from_figure(fig)
        except (ValueError, TypeError) as e:
            out.append(f"{where}: {e}")
    return out


def _initial_from_stated_pose(scn, mech, raw) -> None:
    """A mechanism described in a stated pose (``input_angle``: a generic linkage, a user MJCF)
    starts there unless ``[initial] q0`` says otherwise: q0 defaults to the stated input angle,
    never silently to 0 (a description drawn at 90° would otherwise start a quarter turn away)."""
    angle = getattr(mech, "input_angle", None)
    init = raw.get("initial") if isinstance(raw.get("initial"), dict) else {}
    if angle is None or "q0" in init:
        return
    scn.initial.q0 = float(angle)


def _path_exists(raw, dotted, scn) -> bool:
    node: Any = raw
    parts = dotted.split(".")
    for i, p in enumerate(parts):
        if isinstance(node, dict) and p in node:
            node = node[p]
            continue
        # not written in the file: allowed if the schema knows it (a default)
        return scn.get(".".join(parts)) is not None or _schema_has(scn, parts)
    return True


def _schema_has(scn, parts) -> bool:
    node: Any = scn
    for p in parts:
        if isinstance(node, BaseModel):
            if p not in type(node).model_fields:
                return False
            node = getattr(node, p)
        elif isinstance(node, dict):
            if p not in node:
                return False
            node = node[p]
        else:
            return False
    return True
