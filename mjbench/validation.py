"""A raw scenario (a dict as parsed from TOML, overrides applied) → a validated :class:`~mjbench.schema.Scenario`.

:func:`validate` checks every table — the mechanism and each ``[modes.NAME]`` through their
registries (:mod:`mjbench.mechanisms`, :mod:`controllers`, plugins included), the drive
(:class:`mjbench.drive.DriveParams`), the generic tables of :mod:`mjbench.schema` — then the
cross-field rules, and raises ONE :class:`~mjbench.errors.ScenarioError` listing every problem
with its TOML path.  A valid scenario gets its plausibility warnings (likely unit slips).

Import order (no cycle): :mod:`mjbench.fields` (field types, leaf) ← :mod:`mjbench.schema`,
the drive, the mechanisms, the controllers ← this module ← :mod:`mjbench.scenario`.
"""
from __future__ import annotations

import difflib
from typing import Any

from pydantic import BaseModel, ValidationError

from .control import REGISTRY as CR

from . import drives
from . import mechanisms as MR
from . import metrics as M
from . import units as U
from .drive import DriveParams
from .errors import ScenarioError
from .fields import UnitMeta, format_errors
from .schema import FIGURE_KEYS, Scenario
from .verdicts import from_figure

__all__ = ["validate"]


def validate(raw: dict, source: str = "", overrides=()) -> Scenario:
    """Validate a scenario dict (as parsed from TOML, overrides applied) → :class:`Scenario`.
    Raises ONE ScenarioError listing every problem."""
    problems: list[str] = []
    if not isinstance(raw, dict):
        raise ScenarioError(f"scenario {source}: not a table")
    raw = dict(raw)
    mech = _mechanism(raw, problems)
    drive = _drive(raw, problems)
    axis_drives = _axis_drives(raw, mech, problems)
    mraw_all, modes, mode_axes = _modes(raw, mech, problems)
    scn = _generic_tables(raw, mech, drive, problems)
    if scn is not None:
        scn.modes = modes
        scn.mode_axes = mode_axes
        problems += _cross_checks(scn, raw, mraw_all, mech, drive)
        _initial_from_stated_pose(scn, mech, raw)
    if problems:
        _raise(raw, source, problems)
    scn.mechanism, scn.drive = mech, drive
    scn.drives = axis_drives
    scn.source, scn.overrides, scn.raw = source, list(overrides), raw
    scn.warnings = _warnings(scn, modes)
    return scn


# ============================================================================ the tables
def _mechanism(raw: dict, problems: list):
    """The ``[mechanism]`` table through the mechanism registry → its Params (None on a problem)."""
    mraw = raw.get("mechanism")
    if mraw is None:
        problems.append("mechanism: required table is missing ([mechanism] with type = ...)")
        return None
    if not isinstance(mraw, dict):
        problems.append(f"mechanism: must be a table, got {mraw!r}")
        return None
    typ = mraw.get("type")
    cls = MR.params_class(typ, mraw)
    if cls is None:
        problems.append(f"mechanism.type: {'required value is missing' if typ is None else repr(typ) + ' is not a known mechanism'}; "
                        f"choose one of {', '.join(MR.names())}")
        return None
    try:
        return cls.model_validate(mraw)
    except ValidationError as e:
        problems += format_errors(e, ("mechanism",), cls)
    return None


def _drive(raw: dict, problems: list):
    """The ``[drive]`` table → the Params of its ``type`` (:mod:`mjbench.drives`: DriveParams for
    the default ``dcmotor``; None on a problem)."""
    draw = raw.get("drive")
    if draw is None:
        problems.append("drive: required table is missing ([drive] with R, L, k_m, J_m, z, lam ...)")
    elif not isinstance(draw, dict):
        problems.append(f"drive: must be a table, got {draw!r}")
    else:
        cls = drives.params_class(drives.type_of(draw)) or (DriveParams if "type" not in draw else None)
        if cls is None:
            problems.append(f"drive.type: {drives.type_of(draw)!r} is not a known drive type; choose one of "
                            f"{', '.join(drives.names())}")
            return None
        if hasattr(cls, "expand"):  # values derived from others of the table (a motor's datasheet)
            draw, more = cls.expand(draw)
            if more:
                problems += more
                return None
        try:
            return cls.model_validate(draw)
        except ValidationError as e:
            problems += format_errors(e, ("drive",), cls)
    return None


def _axis_drives(raw: dict, mech, problems: list) -> dict:
    """``[drives.JOINT]`` tables of a machine with several inputs: each axis's drive, its keys over
    ``[drive]`` → {joint: Params}."""
    tables = raw.get("drives") or {}
    if not isinstance(tables, dict):
        problems.append(f"drives: must be a table of [drives.JOINT] tables, got {tables!r}")
        return {}
    inputs = list(getattr(mech, "inputs", None) or []) if mech is not None else []
    base = raw.get("drive") if isinstance(raw.get("drive"), dict) else {}
    out = {}
    for name, table in tables.items():
        if inputs and name not in inputs:
            problems.append(f"drives.{name}: not an input joint; the inputs are {', '.join(inputs)}")
            continue
        if not inputs:
            problems.append(f"drives.{name}: [drives.JOINT] tables are for a mechanism with several inputs "
                            f"(inputs = [...]); this one has one: use [drive]")
            continue
        if not isinstance(table, dict):
            problems.append(f"drives.{name}: must be a table, got {table!r}")
            continue
        merged = {**base, **table} if "type" not in table or table.get("type") == base.get("type") else dict(table)
        cls = drives.params_class(drives.type_of(merged)) or (DriveParams if "type" not in merged else None)
        if cls is None:
            problems.append(f"drives.{name}.type: {drives.type_of(merged)!r} is not a known drive type")
            continue
        try:
            out[name] = cls.model_validate(merged)
        except ValidationError as e:
            problems += format_errors(e, ("drives", name), cls)
    return out


def _modes(raw: dict, mech, problems: list) -> tuple[dict, dict, dict]:
    """The ``[modes.NAME]`` tables through the controller registry → (raw tables, {name: Params},
    {name: {joint: Params}} of the ``[modes.NAME.axes.JOINT]`` tables)."""
    modes, axes = {}, {}
    mraw_all = raw.get("modes", {})
    if not isinstance(mraw_all, dict):
        problems.append(f"modes: must be a table of [modes.NAME] tables, got {mraw_all!r}")
        mraw_all = {}
    for name, table in mraw_all.items():
        if not isinstance(table, dict):
            problems.append(f"modes.{name}: must be a table, got {table!r}")
            continue
        base = {k: v for k, v in table.items() if k != "axes"}
        typ = base.get("type")
        cls = CR.params_class(typ, base)
        if cls is None:
            problems.append(f"modes.{name}.type: {'required value is missing' if typ is None else repr(typ) + ' is not a known controller'}; "
                            f"choose one of {', '.join(CR.names())}")
            continue
        try:
            modes[name] = cls.model_validate(base)
        except ValidationError as e:
            problems += format_errors(e, ("modes", name), cls)
        if "axes" in table:
            axes[name] = _mode_axes(name, base, table["axes"], cls, mech, problems)
    return mraw_all, modes, axes


def _mode_axes(name: str, base: dict, tables, cls, mech, problems: list) -> dict:
    """``[modes.NAME.axes.JOINT]`` of a machine with several inputs: an axis's own controller of the
    mode, its keys over the mode's (gains, set-point, reference) → {joint: Params}."""
    where = f"modes.{name}.axes"
    if not isinstance(tables, dict):
        problems.append(f"{where}: must be a table of [{where}.JOINT] tables, got {tables!r}")
        return {}
    inputs = list(getattr(mech, "inputs", None) or []) if mech is not None else []
    if mech is not None and not inputs:
        problems.append(f"{where}: per-axis tables are for a mechanism with several inputs (inputs = [...]); "
                        f"this one has one")
        return {}
    if getattr(CR.get(base.get("type")), "multi_axis", False):
        problems.append(f"{where}: {base.get('type')!r} is one controller for all axes: it takes no per-axis tables")
        return {}
    out = {}
    for joint, table in tables.items():
        if inputs and joint not in inputs:
            problems.append(f"{where}.{joint}: not an input joint; the inputs are {', '.join(inputs)}")
            continue
        if not isinstance(table, dict):
            problems.append(f"{where}.{joint}: must be a table, got {table!r}")
            continue
        if table.get("type", base.get("type")) != base.get("type"):
            problems.append(f"{where}.{joint}.type: an axis runs its mode's controller ({base.get('type')!r}); "
                            f"define another mode for another controller")
            continue
        try:
            out[joint] = cls.model_validate({**base, **table})
        except ValidationError as e:
            problems += format_errors(e, ("modes", name, "axes", joint), cls)
    return out


def _generic_tables(raw: dict, mech, drive, problems: list):
    """Every other table through the :class:`Scenario` model (None on a problem)."""
    top = {k: v for k, v in raw.items() if k not in ("mechanism", "drive", "modes", "drives")}
    top.update(mechanism=mech, drive=drive, modes={})
    try:
        return Scenario.model_validate(top)
    except ValidationError as e:
        problems += format_errors(e, (), Scenario)
    return None


# ============================================================================ cross-field rules
def _cross_checks(scn, raw: dict, mraw_all: dict, mech, drive) -> list:
    """Rules between tables: the default mode exists, record_dt ≥ dt, aliases name keys, the
    drive-train tables fit the modes and step, study tables have their law, paper figures."""
    out = []
    if scn.simulation.mode is not None and scn.simulation.mode not in mraw_all:
        out.append(f"simulation.mode: {scn.simulation.mode!r} is not one of the [modes.*] tables "
                   f"({', '.join(sorted(mraw_all)) or 'none defined'})")
    if scn.simulation.record_dt < scn.simulation.dt * (1 - 1e-9):
        out.append(f"simulation.record_dt: must be >= dt = {scn.simulation.dt:g} s, got {scn.simulation.record_dt:g}")
    for alias, target in scn.aliases.items():
        if not _path_exists(raw, target, scn):
            out.append(f"aliases.{alias}: target {target!r} is not a key of this scenario")
    if mech is not None and drive is not None:
        out += drive.check_against(scn)  # drive-train tables vs modes and step
    for tbl in ("optimize", "check"):
        if getattr(scn, tbl) is not None and scn.law is None:
            out.append(f"{tbl}: the [{tbl}] table belongs to a motion-law study and this scenario has no "
                       f"[law] table (it would be ignored)")
    out += _figure_problems(scn.paper, mraw_all)
    return out


def _raise(raw: dict, source: str, problems: list):
    where = f" ({source})" if source else ""
    name = (raw.get("scenario") or {}).get("name", "?") if isinstance(raw.get("scenario"), dict) else "?"
    if len(problems) == 1:
        raise ScenarioError(f"scenario {name!r}{where}: {problems[0]}", problems=problems)
    raise ScenarioError(f"scenario {name!r}{where} has {len(problems)} problems:\n  "
                        + "\n  ".join(problems), problems=problems)


def _figure_problems(paper: dict, modes: dict) -> list:
    """``[[paper.figures]]`` entries checked like the rest of the file: a table each, known keys,
    an existing ``mode``, a ``metric`` a run computes, exactly one of value/band/max/min — else a
    figure would silently vanish from the report or read 'not computed'."""
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
        if known is None:
            known = M.known_metrics()
        out += _figure_entry(f"{where} ({fig.get('name', 'unnamed')!r})", fig, modes, known)
    return out


def _figure_entry(where: str, fig: dict, modes: dict, known: list) -> list:
    """The problems of one ``[[paper.figures]]`` table."""
    out = []
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
    for p in parts:
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


# ============================================================================ plausibility
def _warnings(scn, modes: dict) -> list[str]:
    """Plausibility warnings of every physical value of a valid scenario."""
    sink: list[str] = []
    for sec in ("mechanism", "drive", "initial", "simulation", "law"):
        v = getattr(scn, sec)
        if isinstance(v, BaseModel):
            _plausibility(v, sec, sink)
    for name, mp in modes.items():
        _plausibility(mp, f"modes.{name}", sink)
    sink += getattr(scn.drive, "datasheet_warnings", list)()
    return sink


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
