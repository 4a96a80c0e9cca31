"""Design a machine from its requirements: linkage synthesis, motor / gearbox / flywheel sizing,
tuning and verification (``mjbench design REQUIREMENTS.toml --out DIR``; docs/design.md).

Python API::

    from mjbench.design import design, load_requirements
    res = design("mjbench/scenarios/requirements/press.toml", out="out/press")
    res["status"], res["checks"], res["requirements_table"]

Modules: :mod:`.requirements` (the file format), :mod:`.synthesis` (slider-crank, crank-rocker,
Freudenstein function generation, three-position motion generation; constraints),
:mod:`.build` (the linkage table, machine.toml), :mod:`.model` (the sizing model),
:mod:`.periodic` (periodic steady state by harmonic balance), :mod:`.sizing` (inverse dynamics,
gear ratio, flywheel, selection), :mod:`.catalogue`, :mod:`.thermal`, :mod:`.control`
(design rule, tuning), :mod:`.pipeline` (the command), :mod:`.law_duty` (a motion law per cycle:
sizing, the tracking servo, its harmonic balance, verification), :mod:`.report` (outputs).
"""
from __future__ import annotations
from .pipeline import design as _design
from .requirements import load


def design(requirements, out=None, force=False, log=print, verify=True, tune=None) -> dict:
    """Run the whole design; see :func:`mjbench.design.pipeline.design`."""

    return _design(requirements, out=out, force=force, log=log, verify=verify, tune=tune)


def load_requirements(path_or_name: str):
    """Validate a requirements file (a path or a built-in name) → Requirements."""

    return load(path_or_name)


__all__ = ["design", "load_requirements"]
