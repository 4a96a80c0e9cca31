"""Mechanisms: one module per family, each a :class:`~mjbench.mechanisms.base.Mechanism`.

Registry: ``[mechanism] type = NAME`` → the class registered under NAME.  The built-in modules
are imported on first use; a mechanism defined elsewhere (a user module, a test) registers itself
with the :func:`register` decorator::

    @mjbench.mechanisms.register
    class Pendulum(Mechanism):
        type_name = "pendulum"
        class Params(Strict): ...
"""
from __future__ import annotations

import importlib

from .base import Mechanism

#: built-in type names → module (imported lazily)
BUILTIN = {"fourbar": "mjbench.mechanisms.fourbar", "quickreturn": "mjbench.mechanisms.quickreturn",
           "platform": "mjbench.mechanisms.platform", "linkage": "mjbench.mechanisms.linkage",
           "mjcf": "mjbench.mechanisms.mjcf", "rotor": "mjbench.mechanisms.rotor"}

_REGISTRY: dict[str, type[Mechanism]] = {}


def register(cls):
    """Class decorator: make ``cls`` available as ``[mechanism] type = cls.type_name``."""
    if not (isinstance(cls, type) and issubclass(cls, Mechanism)):
        raise TypeError(f"register: {cls!r} is not a Mechanism subclass")
    if not cls.type_name or cls.Params is None:
        raise TypeError(f"register: {cls.__name__} needs class attributes type_name and Params")
    _REGISTRY[cls.type_name] = cls
    return cls


def _load_builtins():
    for mod in BUILTIN.values():
        importlib.import_module(mod)


def names() -> list[str]:
    _load_builtins()
    return sorted(_REGISTRY)


def get(type_name) -> type[Mechanism] | None:
    if type_name not in _REGISTRY and type_name in BUILTIN:
        importlib.import_module(BUILTIN[type_name])
    return _REGISTRY.get(type_name)


def params_class(type_name, raw=None):
    """Params model for a raw ``[mechanism]`` table of type ``type_name`` (None if unknown)."""
    cls = get(type_name) if isinstance(type_name, str) else None
    return None if cls is None else cls.params_for(raw if raw is not None else {})


def build(params) -> Mechanism:
    """Mechanism object from its validated Params (``params.type`` selects the class)."""
    cls = get(params.type)
    return cls.from_params(params)


def from_dict(table: dict) -> Mechanism:
    """Validate a ``[mechanism]`` table (dict with ``type``) and build the mechanism; a
    ScenarioError lists every problem (paths ``mechanism.<key>``)."""
    from pydantic import ValidationError

    from ..errors import ScenarioError
    from ..schema import format_errors

    typ = table.get("type")
    pcls = params_class(typ, table)
    if pcls is None:
        raise ScenarioError(f"mechanism.type = {typ!r}: choose one of {', '.join(names())}")
    try:
        p = pcls.model_validate(table)
    except ValidationError as e:
        lines = format_errors(e, ("mechanism",), pcls)
        raise ScenarioError("invalid [mechanism] table:\n  " + "\n  ".join(lines), problems=lines) from None
    return build(p)


__all__ = ["Mechanism", "register", "names", "get", "params_class", "build", "from_dict"]
