"""Scenarios: TOML files holding every parameter of a machine, parsed once into typed objects.

``load(name_or_path, overrides)`` reads a built-in scenario (``mjbench/scenarios/NAME.toml``), a
TOML file, or a run's ``manifest.json`` (its fully resolved scenario), applies ``--set key=value``
overrides to the raw tables and validates the whole through the schema
(:mod:`mjbench.schema`): the result is a :class:`~mjbench.schema.Scenario`, or ONE
:class:`~mjbench.errors.ScenarioError` listing every problem with its TOML path.

``--set key=value`` overrides any dotted key (``drive.R=2.5``, ``modes.pid.kp=100``,
``drive.L="9 mH"``) or an alias of ``[aliases]``; the value is parsed as TOML (numbers, booleans,
arrays, strings) and falls back to a string, then validated like the file.
"""
from __future__ import annotations

import copy
import hashlib
import importlib.resources
import json
import os
import tomllib
import warnings
from pathlib import Path

import numpy as np

from . import mechanisms
from .control import REGISTRY as CONTROLLERS
from .errors import ScenarioError
from .registry import GROUPS, PluginWarning, entry_points
from .schema import Scenario
from .validation import validate
from .machine import Machine

SCENARIO_DIR = "scenarios"


def check_model_files(man: dict, where: str) -> None:
    """Refuse to repeat a run whose model file changed (or vanished) since the manifest was
    written: its results would silently differ.  ``where``: the manifest's path (messages)."""
    for path, info in (man.get("model_files") or {}).items():
        want = info.get("sha256") if isinstance(info, dict) else None
        if not want:
            continue
        copy = os.path.join(os.path.dirname(os.path.abspath(where)), info.get("copy", "")) if info.get("copy") else ""
        keep = f"; the run's copy is {copy}" if copy and os.path.isfile(copy) else ""
        if not os.path.isfile(path):
            raise ScenarioError(f"{where}: the model file {path} of that run no longer exists, so the manifest cannot "
                                f"repeat it{keep}")
        with open(path, "rb") as f:
            now = hashlib.sha256(f.read()).hexdigest()
        if now != want:
            raise ScenarioError(f"{where}: the model file {path} changed since that run (SHA-256 {want[:12]}… then, "
                                f"{now[:12]}… now): the manifest would run another model; restore the file{keep}, or "
                                f"run the scenario TOML to simulate the new model")


def builtin_names():
    """Names of the scenarios ``load`` accepts by name: those shipped in the package and those of
    installed plugins (:func:`plugin_scenarios`)."""
    return sorted(set(shipped_names()) | set(plugin_scenarios()))


def _shipped_file(name: str):
    """A file of the shipped scenarios' folder: a plain path when the package is a folder on disk
    (importlib.resources' readers cost ≈ 10 ms to import), else through importlib.resources."""
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), SCENARIO_DIR)
    if os.path.isdir(here):
        return Path(here, name)
    return importlib.resources.files("mjbench").joinpath(SCENARIO_DIR, name)


def shipped_names():
    """Names of the scenarios shipped in the package (``mjbench/scenarios/NAME.toml``)."""
    files = importlib.resources.files("mjbench").joinpath(SCENARIO_DIR)
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))


def plugin_scenarios() -> dict:
    """{name: TOML file} of the scenarios of installed plugins: every ``NAME.toml`` in the folder of
    a package named by an entry point of group ``mjbench.scenarios`` (a name already shipped keeps
    the shipped file).  A plugin package that cannot be imported is skipped with a warning."""
    shipped, out = set(shipped_names()), {}
    for ep in entry_points(GROUPS[2]).values():
        try:
            folder = importlib.resources.files(ep.value.split(":")[0])
            files = sorted((p for p in folder.iterdir() if p.name.endswith(".toml")), key=lambda p: p.name)
        except Exception as e:  # noqa: BLE001 - a third-party package
            warnings.warn(f"scenario plugin {ep.name} = {ep.value!r} cannot be read: {type(e).__name__}: {e}",
                          PluginWarning, stacklevel=2)
            continue
        for f in files:
            name = f.name[:-5]
            if name not in shipped:
                out.setdefault(name, f)
    return out


def read_raw(name_or_path: str) -> tuple[dict, str]:
    """The raw tables of a scenario (TOML file, built-in name or manifest.json) and its source."""
    if isinstance(name_or_path, os.PathLike):
        name_or_path = os.fspath(name_or_path)
    if not isinstance(name_or_path, str) or not name_or_path:
        raise ScenarioError(f"scenario {name_or_path!r}: give a built-in name, a TOML path or a manifest.json path "
                            f"(a non-empty string or path), not {type(name_or_path).__name__}")
    if os.path.exists(name_or_path):
        if os.path.isdir(name_or_path):
            raise ScenarioError(f"scenario {name_or_path!r} is a directory; give a TOML file, a manifest.json "
                                f"or a built-in name ({', '.join(builtin_names())})")
        with open(name_or_path, "rb") as f:
            text = f.read()
        source = os.path.abspath(name_or_path)
        if name_or_path.endswith(".json"):
            try:
                man = json.loads(text.decode("utf-8"))
            except (ValueError, UnicodeDecodeError) as e:
                raise ScenarioError(f"{name_or_path}: not valid JSON ({e})") from None
            if not isinstance(man, dict) or not isinstance(man.get("scenario"), dict):
                raise ScenarioError(f"{name_or_path}: not an mjbench manifest (no 'scenario' table)")
            check_model_files(man, name_or_path)  # a changed model file would silently run another model
            return copy.deepcopy(man["scenario"]), source
    else:
        res = _shipped_file(f"{name_or_path}.toml")
        source = f"builtin:{name_or_path}"
        if not res.is_file():
            res = plugin_scenarios().get(name_or_path)
            if res is None:
                raise ScenarioError(f"unknown scenario {name_or_path!r}: not a file, and not one of the "
                                    f"built-in scenarios {builtin_names()}")
            source = os.path.abspath(str(res))  # a plugin's file: its own folder resolves its paths
        text = res.read_bytes()
    try:
        raw = tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ScenarioError(f"scenario {name_or_path!r} is not valid TOML: {e}") from None
    if isinstance(raw.get("scenario"), dict):
        raw["scenario"].setdefault("name", os.path.splitext(os.path.basename(name_or_path))[0])
    return raw, source


def load(name_or_path: str, overrides=()) -> Scenario:
    """Load and validate a scenario (built-in name, TOML path or manifest.json) with overrides."""
    raw, source = read_raw(name_or_path)
    return from_raw(raw, source, overrides)


def from_raw(raw: dict, source: str = "", overrides=()) -> Scenario:
    """Validate raw tables (a dict as parsed from TOML) with ``key=value`` overrides applied."""
    raw = copy.deepcopy(raw)
    applied = apply_overrides(raw, overrides)
    _resolve_paths(raw, source)
    return validate(raw, source, applied)


def _resolve_paths(raw: dict, source: str) -> None:
    """Let the mechanism class and the controller classes make file paths of their tables absolute
    (relative to the scenario file; ``mjcf``: the model file; a ``signal`` mode: its CSV file, read
    into the table), so a manifest re-runs from anywhere."""
    table = raw.get("mechanism")
    if isinstance(table, dict) and isinstance(table.get("type"), str):
        cls = mechanisms.get(table["type"])
        hook = getattr(cls, "resolve_paths", None) if cls is not None else None
        if hook is not None:
            hook(table, source)
    modes = raw.get("modes")
    for name, table in (modes.items() if isinstance(modes, dict) else ()):
        if isinstance(table, dict) and isinstance(table.get("type"), str) and "file" in table:
            hook = getattr(CONTROLLERS.get(table["type"]), "resolve_paths", None)
            try:
                if hook is not None:
                    hook(table, source)
            except ScenarioError as e:
                raise ScenarioError(f"modes.{name}.file: {e}") from None


def with_values(scn: Scenario, values: dict) -> Scenario:
    """A new validated scenario with dotted keys set to Python values ({"drive.R": 2.1, ...})."""
    raw = copy.deepcopy(scn.raw)
    aliases = raw.get("aliases", {}) if isinstance(raw.get("aliases"), dict) else {}
    applied = list(scn.overrides)
    for key, value in values.items():
        k = aliases.get(key, key)
        set_key(raw, k, value)
        applied.append(f"{k}={value!r}")
    return validate(raw, scn.source, applied)


def parse_value(text: str):
    """Parse a --set value as TOML (1e-3, true, [1, 2], "s"), falling back to the raw string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(raw: dict, overrides) -> list[str]:
    """Apply ``key=value`` items to the raw tables (aliases resolved); returns them as applied.
    Whether the key exists and the value is valid is checked by the schema afterwards."""
    aliases = raw.get("aliases", {}) if isinstance(raw.get("aliases"), dict) else {}
    applied = []
    for item in overrides or ():
        if "=" not in item:
            raise ScenarioError(f"--set {item!r}: expected key=value, e.g. drive.R=2.5")
        key, text = item.split("=", 1)
        key = aliases.get(key.strip(), key.strip())
        if not key or any(not p for p in key.split(".")):
            raise ScenarioError(f"--set {item!r}: {key!r} is not a dotted key such as drive.R")
        set_key(raw, key, parse_value(text.strip()))
        applied.append(f"{key}={text.strip()}")
    return applied


def set_key(raw: dict, key: str, value):
    """Set a dotted key in the raw tables, creating tables on the way (the schema then rejects a
    key it does not know, naming it and the allowed ones)."""
    parts = key.split(".")
    node = raw
    for i, p in enumerate(parts[:-1]):
        nxt = node.get(p)
        if nxt is None:
            nxt = node[p] = {}
        elif not isinstance(nxt, dict):
            raise ScenarioError(f"--set {key}: {'.'.join(parts[: i + 1])!r} is a value, not a table")
        node = nxt
    node[parts[-1]] = value


def make_mechanism(scn: Scenario):

    return mechanisms.build(scn.mechanism)


def make_drive(scn: Scenario):
    return scn.drive.build()


def modes(scn: Scenario):
    return sorted(scn.modes)


def make_machine(scn: Scenario, mode: str | None = None):
    """Scenario → Machine (mechanism + drive + controller of the chosen mode)."""

    mode = scn.mode(mode)
    mech = make_mechanism(scn)
    init = scn.initial
    n = mech.n_inputs
    if n == 1:
        drive = make_drive(scn)
        ctrl = CONTROLLERS.build(scn.modes[mode], drive=drive, mechanism=mech, scenario=scn)
        return Machine(mech, drive, ctrl, q0=init.q0, qd0=init.qd0, I0=init.I0)
    # several inputs: a drive per input ([drives.JOINT] over [drive])
    drives = [(scn.drives.get(name) or scn.drive).build() for name in mech.input_joints]
    return multi_machine(scn, mech, drives, scn.modes[mode], scn.mode_axes.get(mode, {}))


def multi_machine(scn: Scenario, mech, drives, params, own=None):
    """A machine with several motors: one controller of ``params`` for all axes (a class that says
    ``multi_axis``), else one per axis with its axis's reference, built from that axis's own table
    ``own[joint]`` ([modes.NAME.axes.JOINT], keys over the mode's) or else ``params``."""
    init = scn.initial
    own = own or {}
    if getattr(CONTROLLERS.get(params.type), "multi_axis", False):
        ctrl = CONTROLLERS.build(params, drive=drives[0], mechanism=mech, scenario=scn)
    else:
        ctrl = []
        for k, d in enumerate(drives):
            c = CONTROLLERS.build(own.get(mech.input_joints[k], params), drive=d, mechanism=mech, scenario=scn)
            ref = getattr(c, "reference", None)
            if hasattr(ref, "for_axis"):  # the joint trajectories of every axis: this axis's
                c.reference = ref.for_axis(k)
            ctrl.append(c)
    q0 = init.q0 if np.ndim(init.q0) else mech.stated_inputs
    return Machine(mech, list(drives), ctrl, q0=q0, qd0=init.qd0, I0=init.I0)


def get(scn: Scenario, key: str, default=None):
    """Value at a dotted key of the validated scenario (aliases resolved), or ``default``."""
    return scn.get(key, default)


