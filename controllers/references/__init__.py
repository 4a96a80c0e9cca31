"""References for speed/position controllers (``[modes.NAME.reference] type = ...``).

Each reference is a law ``law(t, q, q̇, q̈, I, P, S) -> (phi_ref, omega_ref, omega_dot_ref)`` on the
MOTOR shaft [rad, rad/s, rad/s²], run by the kernel (compiled or not) and by the object's
``__call__(t, y)`` (see :mod:`controllers.reference`).

* ``coupler_speed`` — :mod:`controllers.references.coupler_speed`, seed 002 Eq 17: crank-speed
  reference for a prescribed coupler-point speed V_C (constant, piecewise-constant or tabulated).
* ``path`` — :mod:`mjbench.taskpath`: every axis of a machine with several inputs tracks its joint
  trajectory along the scenario's ``[path]`` (the end effector's path, inverse kinematics);
* ``law`` — :mod:`controllers.references.law`: the scenario's ``[law]`` motion law (seeds 001/003);
  with ``period``, the law repeated every period, +Φ per cycle
  (:mod:`controllers.references.periodic`: a crank turning continuously under a motion law).
"""
from __future__ import annotations
from mjbench.errors import ParameterError
from mjbench.taskpath import PathReferences

from .coupler_speed import CouplerSpeed
from .law import from_params


def build(params, drive=None, mechanism=None, scenario=None):
    """Reference object from its validated Params (``params.type`` selects the module)."""
    if params.type == "coupler_speed":
        return CouplerSpeed.from_params(params, drive=drive, mechanism=mechanism)
    if params.type == "law":
        return from_params(params, drive=drive, mechanism=mechanism, scenario=scenario)
    if params.type == "path":
        path = getattr(scenario, "path", None)
        if path is None:
            raise ParameterError("reference type 'path' needs a [path] table in the scenario")
        if not hasattr(mechanism, "inverse_kinematics"):
            raise ParameterError("reference type 'path' needs a mechanism with several inputs (inverse kinematics)")
        return PathReferences(mechanism, path)
    raise ParameterError(f"reference.type = {params.type!r}: choose 'coupler_speed', 'law' or 'path'")
