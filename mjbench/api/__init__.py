"""The Python API of mjbench (re-exported by :mod:`mjbench`: ``import mjbench as mjb``).

Each name is imported on first use (``import mjbench`` loads neither NumPy nor MuJoCo).  The CLI
commands are thin layers over these functions (docs/api.md).
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..errors import GeometryError, MjbenchError, ParameterError, ScenarioError, SimulationDiverged
    from ..machine import Machine
    from ..outputs import OutputError
    from .analysis import Analysis, FrozenAngleFamily, LinearResult, TransmissionAngle, analyze_mechanism, linearize
    from .bridges import FrequencyResponse, export_fmu, frequency_response
    from .build import make_controller, make_drive, make_mechanism
    from .components import ComponentType, list_components
    from .design_loops import SweepResult, TuneResult, parameter_sweep, tune_gains
    from .holding import HoldPoint, StepCheck, hold_point, step_check
    from .motion_law import LawOptimization, optimize_motion_law
    from .motor import MotorFit, identify_motor
    from .papers import paper_cases, reproduce_papers
    from .results import Result, Run
    from .scenarios import MjbenchWarning, Scenario, list_scenarios, load
    from .simulation import simulate, simulate_many
    from .video import render_video

#: public name → module that defines it (relative to mjbench)
PUBLIC = {
    # scenarios
    "load": ".api.scenarios", "list_scenarios": ".api.scenarios", "Scenario": ".api.scenarios",
    "MjbenchWarning": ".api.scenarios",
    # component types (mechanisms, controllers, drives; plugins included)
    "list_components": ".api.components", "ComponentType": ".api.components",
    # a machine in code
    "make_mechanism": ".api.build", "make_drive": ".api.build", "make_controller": ".api.build",
    "Machine": ".machine",
    # simulations and results
    "simulate": ".api.simulation", "simulate_many": ".api.simulation", "Result": ".api.results",
    "Run": ".api.results",
    # studies
    "parameter_sweep": ".api.design_loops", "SweepResult": ".api.design_loops",
    "tune_gains": ".api.design_loops", "TuneResult": ".api.design_loops",
    "linearize": ".api.analysis", "LinearResult": ".api.analysis", "FrozenAngleFamily": ".api.analysis",
    "hold_point": ".api.holding", "HoldPoint": ".api.holding", "step_check": ".api.holding",
    "StepCheck": ".api.holding",
    "analyze_mechanism": ".api.analysis", "Analysis": ".api.analysis", "TransmissionAngle": ".api.analysis",
    "render_video": ".api.video", "identify_motor": ".api.motor", "MotorFit": ".api.motor",
    "reproduce_papers": ".api.papers", "paper_cases": ".api.papers",
    "optimize_motion_law": ".api.motion_law", "LawOptimization": ".api.motion_law",
    "frequency_response": ".api.bridges", "FrequencyResponse": ".api.bridges", "export_fmu": ".api.bridges",
    # errors
    "MjbenchError": ".errors", "ParameterError": ".errors", "GeometryError": ".errors",
    "ScenarioError": ".errors", "SimulationDiverged": ".errors", "OutputError": ".outputs",
}

__all__ = sorted(PUBLIC)


def resolve(name: str) -> Any:
    """The public object ``name`` (imports its module on first use)."""
    try:
        mod = PUBLIC[name]
    except KeyError:
        raise AttributeError(f"module 'mjbench' has no attribute {name!r}") from None
    return getattr(importlib.import_module(mod, "mjbench"), name)


def __getattr__(name: str) -> Any:
    if name in PUBLIC:
        value = resolve(name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mjbench.api' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(PUBLIC))
