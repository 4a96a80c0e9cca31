"""The scenario schema: every table of a scenario file as a typed, validated object (pydantic v2).

A scenario is parsed once, at load, by :func:`mjbench.validation.validate` into a :class:`Scenario`:

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

The field types (``Q``, ``OptQ``, ``Bool``, ``Strict``) live in the leaf module
:mod:`mjbench.fields` (re-exported here); this module imports no component, so the drive, the
mechanisms and the controllers import their field types without a cycle, and
:mod:`mjbench.validation` (which imports them all) assembles a scenario.
"""

import math
from typing import Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from .errors import ScenarioError
from .fields import Bool, OptQ, Q, Strict, UnitMeta, format_errors, jsonable
from .motionlaws import BezierLaw, PseudoPolynomialLaw
from .taskpath import PathParams

__all__ = ["Q", "OptQ", "Bool", "Strict", "UnitMeta", "format_errors", "Scenario", "ScenarioMeta", "Initial",
           "Simulation", "MultibodyOptions", "ReducedOptions", "Metrics", "LawParams", "OptimizeParams",
           "CheckParams", "FIGURE_KEYS"]


# ============================================================================ generic tables
class ScenarioMeta(Strict):
    """``[scenario]``: identification of the machine (no physics)."""

    name: str
    title: str = ""
    paper: str = Field("", description="the paper this scenario reproduces, e.g. 'Incerti 2012'")
    seed: str = Field("", description="internal index of the source paper (000 … 004)")
    description: str = ""


class Initial(Strict):
    """``[initial]``: state at t = 0.  Default: at rest at q = 0 with no current.  A machine with
    several inputs: one value per input (a list), or one for all."""

    q0: Q("angle") | list[Q("angle")] = 0.0
    qd0: Q("angular_velocity", plausible=False) | list[Q("angular_velocity", plausible=False)] = 0.0
    I0: Q("current", plausible=False) | list[Q("current", plausible=False)] = 0.0


class Simulation(Strict):
    """``[simulation]``: run length, co-simulation (control) step, recording, default mode/backend."""

    t_end: Q("time", gt=0.0, what="a run length")
    dt: Q("time", gt=0.0, le=0.01, what="a co-simulation step") = 1e-4
    record_dt: Q("time", gt=0.0, what="a recording interval") = 1e-3
    mode: str | None = Field(None, description="default [modes.NAME] to run")
    backend: Literal["multibody", "reduced", "both"] = "both"
    record_joints: Bool = Field(False, description="record every joint coordinate and rate (joint_<name>_rad, "
                                                   "joint_<name>_rate_rad_s / _m, _rate_m_s; docs/engine.md)")


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
    path: PathParams | None = None
    drives: dict[str, Any] = Field(default_factory=dict, description="per-axis drives of a machine with several "
                                   "inputs: [drives.JOINT] keys over [drive]")
    mode_axes: dict[str, dict[str, Any]] = Field(default_factory=dict, description="per-axis controllers of a mode "
                                                  "on a machine with several inputs: [modes.NAME.axes.JOINT] keys over "
                                                  "[modes.NAME] (the validated Params, by mode and joint)")
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

    @property
    def axes(self) -> tuple[str, ...]:
        """The input joints a machine described axis by axis names (``mechanism.inputs``: a list,
        even of one); () for a mechanism whose one input is implicit.  The one place the tables are
        read for it: nothing is built."""
        inputs = getattr(self.mechanism, "inputs", None)  # only the generic linkage's Params declare inputs
        return tuple(str(x) for x in inputs) if inputs else ()

    def mode(self, mode: str | None = None) -> str:
        """The mode to run: ``mode`` or the scenario's default, checked."""
        SE = ScenarioError
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
                out[name] = jsonable(v.model_dump(mode="python"))
            elif name == "modes":
                out[name] = {k: jsonable(m.model_dump(mode="python")) for k, m in v.items()}
                for k, ax in self.mode_axes.items():  # (each axis's whole table: re-loads to the same)
                    if k in out[name] and ax:
                        out[name][k]["axes"] = {j: jsonable(p.model_dump(mode="python")) for j, p in ax.items()}
            elif name == "mode_axes":
                continue
            elif name == "drives":  # (the axes' drives: Params by joint)
                if v:
                    out[name] = {k: jsonable(d.model_dump(mode="python")) for k, d in v.items()}
            else:
                out[name] = jsonable(v)
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


#: keys of a ``[[paper.figures]]`` entry (runner.paper_rows, verdicts.from_figure)
FIGURE_KEYS = ("name", "mode", "metric", "value", "band", "max", "min", "tolerance", "fitted", "unit", "note")
