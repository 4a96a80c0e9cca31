"""Checks a command runs before it simulates, so that bad input costs no simulation time.

:func:`check_machine` builds the machine of the chosen mode once (milliseconds).  Errors mjbench
raises on purpose pass through; a plain ``ValueError``/``TypeError`` from deeper code (e.g.
``--set drive.R=abc`` reaching ``float()``) becomes a :class:`ScenarioError` naming the ``--set``
item responsible, instead of a traceback.  The value rules themselves belong to the scenario
schema (scenario.py); this is only the safety net at the CLI boundary.

:func:`simulation_errors` does the same around a simulation: a bare ``ValueError`` or arithmetic
error escaping a backend (e.g. ``math domain error`` once a non-physical run has blown up to
inf, before the backend's own divergence check saw it) is reported as
:class:`SimulationDiverged` with the ``--set`` items in force.
"""
from __future__ import annotations

import contextlib

from . import scenario as S
from .errors import MjbenchError, ScenarioError, SimulationDiverged

_PLAIN = (ValueError, TypeError, KeyError, ArithmeticError)


def _source(scn: dict) -> str | None:
    src = S.get(scn, "scenario.source")
    if not isinstance(src, str):
        return None
    return src[len("builtin:"):] if src.startswith("builtin:") else src


def check_machine(scn: dict, mode: str | None = None):
    """Build the machine of ``mode`` (default: the scenario's) or raise a readable error."""
    check_override_shapes(scn)
    try:
        S.make_machine(scn, mode)
    except MjbenchError:
        raise
    except _PLAIN as e:
        raise ScenarioError(_explain(scn, mode, e)) from None


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def check_override_shapes(scn: dict):
    """A --set value replacing a single number must not be a list, a table or a boolean: a single
    run would otherwise fail deep in the simulation (lists) or silently use 1.0 (``true``).
    Strings are left to the schema (some numeric keys accept e.g. "none")."""
    src = _source(scn)
    items = list(S.get(scn, "scenario.overrides", []) or [])
    if not items or not src:
        return
    base = S.load(src)
    for item in items:
        key = item.split("=", 1)[0]
        old, new = S.get(base, key), S.get(scn, key)
        if _is_number(old) and isinstance(new, (list, dict, bool)):
            kind = {list: "a list", dict: "a table", bool: "a boolean"}[type(new)]
            raise ScenarioError(f"--set {item}: {key} takes one number (the scenario has {old!r}), not {kind}")


def _explain(scn: dict, mode, err) -> str:
    name = S.get(scn, "scenario.name", "?")
    mode = mode or S.get(scn, "simulation.mode")
    items = list(S.get(scn, "scenario.overrides", []) or [])
    what = f"{type(err).__name__}: {err}"
    culprits = []
    src = _source(scn)
    if items and src:
        for item in items:  # which --set alone breaks the machine (only on this error path)
            try:
                S.make_machine(S.load(src, [item]), mode)
            except MjbenchError:
                culprits.append(item)
            except _PLAIN:
                culprits.append(item)
    if culprits:
        return (f"--set {' --set '.join(culprits)}: invalid value for scenario {name!r} (mode {mode!r}): "
                f"{what}")
    if items:
        return (f"scenario {name!r} (mode {mode!r}) cannot be built with --set {' --set '.join(items)}: "
                f"{what}")
    return f"scenario {name!r} (mode {mode!r}) cannot be built: {what}"


@contextlib.contextmanager
def simulation_errors(scn: dict):
    """Report a bare ValueError/ArithmeticError from a simulation as SimulationDiverged."""
    try:
        yield
    except MjbenchError:
        raise
    except (ValueError, ArithmeticError) as e:
        items = list(S.get(scn, "scenario.overrides", []) or [])
        sets = f" with --set {' --set '.join(items)}" if items else ""
        raise SimulationDiverged(
            f"the simulation of scenario {S.get(scn, 'scenario.name', '?')!r}{sets} failed "
            f"({type(e).__name__}: {e}): it most likely diverged; check the values for non-physical "
            f"ones, or reduce the time step (--set simulation.dt=...)") from e
