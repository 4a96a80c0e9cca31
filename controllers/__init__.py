"""Controllers: small objects with a sample period, ``reset()`` and one call per control sample.

``u = controller(t, y)`` returns the armature voltage [V] from a :class:`Measurement` y by running
the controller's law (one scalar function the co-step kernel also runs, compiled or not); the
protocol is in :mod:`controllers.base`.  Registry: ``[modes.NAME] type = T`` → the class
registered under T (built-ins imported lazily; :func:`register` adds one).
"""
from __future__ import annotations

import importlib as _importlib

from .base import Controller, Measurement

#: built-in controller types → module
BUILTIN = {"open": "controllers.openloop", "pid": "controllers.pid", "smc": "controllers.smc",
           "servo": "controllers.servo",
           "fmu": "controllers.fmu"}

_REGISTRY: dict[str, type[Controller]] = {}


def register(cls):
    """Class decorator: make ``cls`` available as ``[modes.NAME] type = cls.type_name``."""
    if not (isinstance(cls, type) and issubclass(cls, Controller)):
        raise TypeError(f"register: {cls!r} is not a Controller subclass")
    if not cls.type_name or cls.Params is None:
        raise TypeError(f"register: {cls.__name__} needs class attributes type_name and Params")
    _REGISTRY[cls.type_name] = cls
    return cls


def names() -> list[str]:
    for mod in BUILTIN.values():
        _importlib.import_module(mod)
    return sorted(_REGISTRY)


def get(type_name):
    if type_name not in _REGISTRY and type_name in BUILTIN:
        _importlib.import_module(BUILTIN[type_name])
    return _REGISTRY.get(type_name)


def params_class(type_name, raw=None):
    cls = get(type_name) if isinstance(type_name, str) else None
    return None if cls is None else cls.Params


def build(params, drive=None, mechanism=None, scenario=None) -> Controller:
    """Controller object from its validated Params (``params.type`` selects the class)."""
    return get(params.type).from_params(params, drive=drive, mechanism=mechanism, scenario=scenario)


def from_dict(table: dict, drive=None, mechanism=None, scenario=None) -> Controller:
    """Validate a ``[modes.NAME]`` table (dict with ``type``) and build the controller; a
    ScenarioError lists every problem."""
    from pydantic import ValidationError

    from mjbench.errors import ScenarioError
    from mjbench.schema import format_errors

    typ = table.get("type")
    pcls = params_class(typ)
    if pcls is None:
        raise ScenarioError(f"controller type = {typ!r}: choose one of {', '.join(names())}")
    try:
        p = pcls.model_validate(table)
    except ValidationError as e:
        lines = format_errors(e, ("modes", typ), pcls)
        raise ScenarioError("invalid controller table:\n  " + "\n  ".join(lines), problems=lines) from None
    return build(p, drive=drive, mechanism=mechanism, scenario=scenario)


def __getattr__(name):  # convenience: controllers.PID, controllers.ConstantVoltage ...
    lazy = {"PID": "controllers.pid", "ConstantVoltage": "controllers.openloop", "SlidingMode": "controllers.smc",
            "CascadeServo": "controllers.servo", "ConstantSpeed": "controllers.reference"}
    if name in lazy:
        return getattr(_importlib.import_module(lazy[name]), name)
    raise AttributeError(name)


__all__ = ["Controller", "Measurement", "register", "names", "get", "params_class", "build", "from_dict"]
