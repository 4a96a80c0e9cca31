"""Controllers: small objects with ``reset()`` and one call per control step, backend-agnostic.

``u = controller(t, y)`` returns the armature voltage [V] from a :class:`Measurement` y.
Each controller accepts scalars or NumPy arrays of shape (nsim,) for its gains and signals.
"""
from .base import Controller, Measurement
from .openloop import ConstantVoltage
from .pid import PID
from .reference import ConstantSpeed

__all__ = ["Controller", "Measurement", "ConstantVoltage", "PID", "ConstantSpeed"]

import importlib as _importlib

#: controller type (scenario ``[modes.X] type``) → module providing ``from_params``
TYPES = {"open": "controllers.openloop", "pid": "controllers.pid",
         "smc": "controllers.smc",
         "servo": "controllers.servo"}


def make(params: dict, drive=None, mechanism=None):
    """Build a controller from a scenario table ``{"type": ..., **parameters}``."""
    params = dict(params)
    typ = params.pop("type", None)
    if typ not in TYPES:
        raise ValueError(f"controller type {typ!r}: choose one of {sorted(TYPES)}")
    return _importlib.import_module(TYPES[typ]).from_params(params, drive=drive, mechanism=mechanism)
