"""Checks a command runs before it simulates, so that bad input costs no simulation time.

Value rules (types, units, ranges, unknown keys) belong to the scenario schema
(:mod:`mjbench.schema`), applied when the scenario is loaded.  :func:`check_machine` then builds
the machine of the chosen mode once (milliseconds): geometry that cannot assemble, a controller
that cannot be built ... surface here, before any simulation.  Errors mjbench raises on purpose
pass through; a plain ``ValueError``/``TypeError`` from deeper code becomes a
:class:`ScenarioError` naming the ``--set`` items in force instead of a traceback.

:func:`simulation_errors` does the same around a simulation: a bare ``ValueError`` or arithmetic
error escaping a backend is reported as :class:`SimulationDiverged` with the ``--set`` items in
force.
"""
from __future__ import annotations

import contextlib

from . import scenario as S
from .errors import MjbenchError, ScenarioError, SimulationDiverged

_PLAIN = (ValueError, TypeError, KeyError, ArithmeticError)


def check_machine(scn, mode: str | None = None):
    """Build the machine of ``mode`` (default: the scenario's) or raise a readable error."""
    try:
        S.make_machine(scn, mode)
    except MjbenchError:
        raise
    except _PLAIN as e:
        sets = f" with --set {' --set '.join(scn.overrides)}" if scn.overrides else ""
        raise ScenarioError(f"scenario {scn.name!r} (mode {mode or scn.simulation.mode!r}) cannot be built{sets}: "
                            f"{type(e).__name__}: {e}") from None


@contextlib.contextmanager
def simulation_errors(scn):
    """Report a bare ValueError/ArithmeticError from a simulation as SimulationDiverged."""
    try:
        yield
    except MjbenchError:
        raise
    except (ValueError, ArithmeticError) as e:
        sets = f" with --set {' --set '.join(scn.overrides)}" if scn.overrides else ""
        raise SimulationDiverged(
            f"the simulation of scenario {scn.name!r}{sets} failed ({type(e).__name__}: {e}): it most likely "
            f"diverged; check the values for non-physical ones, or reduce the time step (--set simulation.dt=...)") from e
