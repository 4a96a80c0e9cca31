"""Controllers: small objects with a sample period, ``reset()`` and one call per control sample.

``u = controller(t, y)`` returns the armature voltage [V] from a :class:`Measurement` y by running
the controller's law (one scalar function the co-step kernel also runs, compiled or not); the
protocol is in :mod:`controllers.base`.  Registry (:class:`mjbench.registry.Registry`):
``[modes.NAME] type = T`` → the class registered under T (built-ins imported lazily;
:func:`register` adds one; an installed package's controller is found through its entry point,
group ``mjbench.controllers``).
"""
from __future__ import annotations

import importlib as _importlib

from mjbench.registry import GROUPS, Registry

from .base import Controller, Measurement

#: built-in controller types → module
BUILTIN = {"open": "controllers.openloop", "pid": "controllers.pid", "smc": "controllers.smc",
           "servo": "controllers.servo",
           "fmu": "controllers.fmu", "constant": "controllers.constant", "signal": "controllers.signal"}

#: the controller registry (built-ins, plugins of entry-point group ``mjbench.controllers``, registered classes)
REGISTRY = Registry("controller", Controller, BUILTIN, GROUPS[1], prefix=("modes", "{typ}"),
                    unknown="controller type = {typ!r}", invalid="invalid controller table")


def register(cls):
    """Class decorator: make ``cls`` available as ``[modes.NAME] type = cls.type_name``."""
    return REGISTRY.register(cls)


def names() -> list[str]:
    """Every controller type name (built-ins, plugins, registered)."""
    return REGISTRY.names()


def get(type_name):
    """The class of ``type_name`` (None if unknown)."""
    return REGISTRY.get(type_name)


def params_class(type_name, raw=None):
    """Params model of controller type ``type_name`` (None if unknown)."""
    return REGISTRY.params_class(type_name, raw)


def build(params, drive=None, mechanism=None, scenario=None) -> Controller:
    """Controller object from its validated Params (``params.type`` selects the class)."""
    return REGISTRY.build(params, drive=drive, mechanism=mechanism, scenario=scenario)


def from_dict(table: dict, drive=None, mechanism=None, scenario=None) -> Controller:
    """Validate a ``[modes.NAME]`` table (dict with ``type``) and build the controller; a
    ScenarioError lists every problem."""
    return REGISTRY.from_dict(table, drive=drive, mechanism=mechanism, scenario=scenario)


def __getattr__(name):  # convenience: controllers.PID, controllers.ConstantVoltage ...
    lazy = {"PID": "controllers.pid", "ConstantVoltage": "controllers.openloop", "SlidingMode": "controllers.smc",
            "CascadeServo": "controllers.servo", "ConstantSpeed": "controllers.reference"}
    if name in lazy:
        return getattr(_importlib.import_module(lazy[name]), name)
    raise AttributeError(name)


__all__ = ["Controller", "Measurement", "REGISTRY", "register", "names", "get", "params_class", "build", "from_dict"]
