"""mjbench — a MuJoCo testbed for machines driven by an electric motor under feedback control.

Data path: scenario (TOML) → mechanism + drive + controller (Machine) → backend (multibody or
reduced) → Trajectory → metrics, plots, video, report.

From Python (docs/api.md)::

    import mjbench as mjb
    scn = mjb.load("incerti2012", **{"drive.R": "2.2 ohm"})
    res = scn.simulate(mode="pid", backend="both", t_end=0.5)
    res.to_pandas(); res.metrics; res.plot(); res.save("out")

Every public name is imported on first use: ``import mjbench`` loads neither NumPy, MuJoCo nor
pydantic.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ._version import __version__

if TYPE_CHECKING:
    from .api import (Analysis, ComponentType, FrequencyResponse, FrozenAngleFamily, GeometryError, HoldPoint,
                      LawOptimization, LinearResult, Machine, MjbenchError, MjbenchWarning, MotorFit, OutputError,
                      ParameterError, Result, Run, Scenario, ScenarioError, SimulationDiverged, StepCheck,
                      SweepResult, TransmissionAngle, TuneResult, analyze_mechanism, export_fmu,
                      frequency_response, hold_point, identify_motor, linearize, list_components, list_scenarios,
                      load, make_controller, make_drive, make_mechanism, optimize_motion_law, paper_cases,
                      parameter_sweep, render_video, reproduce_papers, simulate, simulate_many, step_check,
                      tune_gains)

__all__ = ["Analysis", "ComponentType", "FrequencyResponse", "FrozenAngleFamily", "GeometryError", "HoldPoint",
           "LawOptimization", "LinearResult", "Machine", "MjbenchError", "MjbenchWarning", "MotorFit",
           "OutputError", "ParameterError", "Result", "Run", "Scenario", "ScenarioError", "SimulationDiverged",
           "StepCheck", "SweepResult", "TransmissionAngle", "TuneResult", "__version__", "analyze_mechanism",
           "export_fmu", "frequency_response", "hold_point", "identify_motor", "linearize", "list_components",
           "list_scenarios", "load", "make_controller", "make_drive", "make_mechanism", "optimize_motion_law",
           "paper_cases", "parameter_sweep", "render_video", "reproduce_papers", "simulate", "simulate_many",
           "step_check", "tune_gains"]


def __getattr__(name: str) -> Any:
    """The public API, imported on first use (module ``__getattr__``, PEP 562)."""
    if name not in __all__:  # (e.g. a submodule not imported yet: the import system then imports it)
        raise AttributeError(f"module 'mjbench' has no attribute {name!r}")
    import importlib

    api = importlib.import_module("mjbench.api")  # (not `from . import api`: that would ask this hook again)
    value = api.resolve(name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
