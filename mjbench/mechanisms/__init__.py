"""Mechanisms: one module per family, each a :class:`~mjbench.mechanisms.base.Mechanism`.

Registry (:class:`mjbench.registry.Registry`): ``[mechanism] type = NAME`` → the class registered
under NAME.  The built-in modules are imported on first use; a mechanism defined elsewhere (a user
module, a test) registers itself with the :func:`register` decorator::

    @mjbench.mechanisms.register
    class Pendulum(Mechanism):
        type_name = "pendulum"
        class Params(Strict): ...

and a mechanism of an installed package is found through its entry point (group
``mjbench.mechanisms``, name = type name, value = the class), with no edit to mjbench.
"""
from __future__ import annotations

from ..registry import GROUPS, Registry
from .base import Mechanism

#: built-in type names → module (imported lazily)
BUILTIN = {"fourbar": "mjbench.mechanisms.fourbar", "quickreturn": "mjbench.mechanisms.quickreturn",
           "platform": "mjbench.mechanisms.platform", "linkage": "mjbench.mechanisms.linkage",
           "mjcf": "mjbench.mechanisms.mjcf", "rotor": "mjbench.mechanisms.rotor",
           "cam": "mjbench.mechanisms.cam"}

#: the mechanism registry (built-ins, plugins of entry-point group ``mjbench.mechanisms``, registered classes)
REGISTRY = Registry("mechanism", Mechanism, BUILTIN, GROUPS[0], prefix=("mechanism",),
                    unknown="mechanism.type = {typ!r}", invalid="invalid [mechanism] table")


def register(cls):
    """Class decorator: make ``cls`` available as ``[mechanism] type = cls.type_name``."""
    return REGISTRY.register(cls)


def names() -> list[str]:
    """Every mechanism type name (built-ins, plugins, registered)."""
    return REGISTRY.names()


def get(type_name) -> type[Mechanism] | None:
    """The class of ``type_name`` (None if unknown)."""
    return REGISTRY.get(type_name)


def params_class(type_name, raw=None):
    """Params model for a raw ``[mechanism]`` table of type ``type_name`` (None if unknown)."""
    return REGISTRY.params_class(type_name, raw)


def build(params) -> Mechanism:
    """Mechanism object from its validated Params (``params.type`` selects the class)."""
    return REGISTRY.build(params)


def from_dict(table: dict) -> Mechanism:
    """Validate a ``[mechanism]`` table (dict with ``type``) and build the mechanism; a
    ScenarioError lists every problem (paths ``mechanism.<key>``)."""
    return REGISTRY.from_dict(table)


__all__ = ["Mechanism", "REGISTRY", "register", "names", "get", "params_class", "build", "from_dict"]
