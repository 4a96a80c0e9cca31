"""Scenarios: TOML files holding every parameter of a run, with documented assumptions.

Layout (see ``mjbench/scenarios/incerti2012.toml``)::

    [scenario]   name, title, seed, description
    [mechanism]  type = "<module in mjbench.mechanisms>" + its parameters (from_params)
    [drive]      type = "dcmotor" (default) + DCMotorDrive fields
    [initial]    q0 [rad], qd0 [rad/s], I0 [A]
    [simulation] t_end, dt, record_dt, mode, backend
    [multibody]  MuJoCo options (integrator, timestep, solref, solimp)
    [reduced]    method = "rk4" | "solve_ivp"
    [modes.<name>] type = "<controller type>" + its parameters (controllers.make)
    [metrics]    windows and settings of the metrics
    [paper]      figures the paper reports, for comparison
    [aliases]    short --set names, e.g. vc = "modes.pid.reference.vc"

``--set key=value`` overrides any dotted key (``drive.R=2.5``, ``modes.pid.kp=100``) or alias;
the value is parsed as TOML (numbers, booleans, arrays, strings) and falls back to a string.
"""
from __future__ import annotations

import copy
import importlib
import importlib.resources
import os
import tomllib

from .errors import ScenarioError

SCENARIO_DIR = "scenarios"


def builtin_names():
    """Names of the scenarios shipped in the package."""
    files = importlib.resources.files("mjbench").joinpath(SCENARIO_DIR)
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))


def load(name_or_path: str, overrides=()) -> dict:
    """Load a built-in scenario by name, or a TOML file by path, and apply ``key=value`` overrides."""
    if os.path.exists(name_or_path):
        with open(name_or_path, "rb") as f:
            text = f.read()
        source = os.path.abspath(name_or_path)
    else:
        res = importlib.resources.files("mjbench").joinpath(SCENARIO_DIR, f"{name_or_path}.toml")
        if not res.is_file():
            raise ScenarioError(f"unknown scenario {name_or_path!r}: not a file, and not one of the "
                                f"built-in scenarios {builtin_names()}")
        text = res.read_bytes()
        source = f"builtin:{name_or_path}"
    try:
        scn = tomllib.loads(text.decode("utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(f"scenario {name_or_path!r} is not valid TOML: {e}") from None
    scn.setdefault("scenario", {}).setdefault("name", os.path.splitext(os.path.basename(name_or_path))[0])
    scn["scenario"]["source"] = source
    apply_overrides(scn, overrides)
    return scn


def parse_value(text: str):
    """Parse a --set value as TOML (1e-3, true, [1, 2], "s"), falling back to the raw string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(scn: dict, overrides) -> dict:
    aliases = scn.get("aliases", {})
    applied = scn.setdefault("scenario", {}).setdefault("overrides", [])
    for item in overrides or ():
        if "=" not in item:
            raise ScenarioError(f"--set {item!r}: expected key=value, e.g. drive.R=2.5")
        key, text = item.split("=", 1)
        key = aliases.get(key.strip(), key.strip())
        set_key(scn, key, parse_value(text.strip()))
        applied.append(f"{key}={text.strip()}")
    return scn


def set_key(scn: dict, key: str, value):
    """Set a dotted key; the parent tables must exist and the key must already be defined
    (so a typo is an error, not a silently ignored parameter) unless its table allows extras."""
    parts = key.split(".")
    node = scn
    for i, p in enumerate(parts[:-1]):
        if not isinstance(node, dict) or p not in node:
            raise ScenarioError(f"--set {key}: no table {'.'.join(parts[: i + 1])!r} in the scenario "
                                f"(tables: {sorted(k for k, v in node.items() if isinstance(v, dict))})")
        node = node[p]
    leaf = parts[-1]
    if not isinstance(node, dict):
        raise ScenarioError(f"--set {key}: {'.'.join(parts[:-1])!r} is not a table")
    if leaf not in node and not node.get("_open", False):
        raise ScenarioError(f"--set {key}: unknown key {leaf!r}; known keys here: {sorted(node)}")
    node[leaf] = value


def get(scn: dict, key: str, default=None):
    node = scn
    for p in key.split("."):
        if not isinstance(node, dict) or p not in node:
            return default
        node = node[p]
    return node


def _strip(d: dict) -> dict:
    """Drop documentation-only keys (leading underscore) from a parameter table."""
    return {k: v for k, v in d.items() if not k.startswith("_")}


def make_mechanism(scn: dict):
    params = _strip(copy.deepcopy(scn.get("mechanism", {})))
    typ = params.pop("type", None)
    if not typ:
        raise ScenarioError("scenario has no [mechanism] type")
    try:
        mod = importlib.import_module(f"mjbench.mechanisms.{typ}")
    except ModuleNotFoundError:
        raise ScenarioError(f"mechanism.type = {typ!r}: no module mjbench.mechanisms.{typ}") from None
    return mod.from_params(params)


def make_drive(scn: dict):
    from .drive import DCMotorDrive

    params = _strip(copy.deepcopy(scn.get("drive", {})))
    typ = params.pop("type", "dcmotor")
    if typ != "dcmotor":
        mod = importlib.import_module(f"mjbench.drives.{typ}")
        return mod.from_params(params)
    try:
        return DCMotorDrive(**params)
    except TypeError as e:
        raise ScenarioError(f"[drive]: {e}") from None


def modes(scn: dict):
    return sorted(scn.get("modes", {}))


def make_machine(scn: dict, mode: str | None = None):
    """Scenario → Machine (mechanism + drive + controller of the chosen mode)."""
    import controllers

    from .machine import Machine

    mode = mode or get(scn, "simulation.mode")
    if mode not in scn.get("modes", {}):
        raise ScenarioError(f"mode {mode!r} is not defined in scenario {scn['scenario']['name']!r}; "
                            f"modes: {modes(scn)}")
    mech = make_mechanism(scn)
    drive = make_drive(scn)
    ctrl = controllers.make(_strip(copy.deepcopy(scn["modes"][mode])), drive=drive, mechanism=mech)
    init = scn.get("initial", {})
    return Machine(mech, drive, ctrl, q0=float(init.get("q0", 0.0)), qd0=float(init.get("qd0", 0.0)),
                   I0=float(init.get("I0", 0.0)))
