"""The component types mjbench knows: mechanisms, controllers and drive types (``mjbench list``).

Each kind has one :class:`mjbench.registry.Registry`: the built-in types, the plugins of installed
packages (entry-point groups ``mjbench.mechanisms``, ``mjbench.controllers``, ``mjbench.drives``)
and the classes registered in this process.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .. import control
from ..errors import ParameterError
from .. import drives
from .. import mechanisms
from ..registry import entry_points
from ..tune import declared_specs

#: the kinds of components, in listing order
KINDS = ("mechanism", "controller", "drive")


@dataclass(frozen=True)
class ComponentType:
    """One registered component type.

    Attributes
    ----------
    kind : {"mechanism", "controller", "drive"}
    name : str
        The type name a scenario gives (``[mechanism] type = name``, ``[modes.NAME] type = name``,
        ``[drive] type = name``).
    origin : {"built-in", "plugin", "registered"}
        Shipped with mjbench, found through an installed package's entry point, or registered in
        this process (``@register`` in a user module or a test).
    source : str
        The class (``module.Class``); a plugin's also names its distribution.
    tunable : dict of str to tuple of str
        Controllers: the ``tune --controller`` names the class declares (``Controller.TUNABLE``,
        ``TUNE_VARIANTS``) → the gains each searches; empty when it declares none.
    """

    kind: str
    name: str
    origin: str
    source: str
    tunable: dict[str, tuple[str, ...]]


def list_components(kind: str | None = None) -> list[ComponentType]:
    """Every registered mechanism, controller and drive type (or those of one ``kind``), plugins
    included, sorted by kind and name.

    A plugin that cannot be imported is left out with a :class:`mjbench.registry.PluginWarning`
    (its error is raised when a scenario names it).

    Parameters
    ----------
    kind : {"mechanism", "controller", "drive"}, optional
        One kind only (default: all three).

    Returns
    -------
    list of ComponentType
    """

    if kind is not None and kind not in KINDS:
        raise ParameterError(f"list_components: kind = {kind!r}: choose one of {', '.join(KINDS)}")
    out = []
    for k in KINDS if kind is None else (kind,):
        reg = _registry(k)
        for name in reg.names():
            out.append(_describe(k, reg, name))
    return out


def _registry(kind: str) -> Any:
    if kind == "mechanism":

        return mechanisms.REGISTRY
    if kind == "controller":
        return control.REGISTRY

    return drives.REGISTRY


def _describe(kind: str, reg: Any, name: str) -> ComponentType:

    cls = reg.get(name)
    source = f"{cls.__module__}.{cls.__qualname__}"
    if name in reg.builtin:
        origin = "built-in"
    elif name in entry_points(reg.group):
        dist = getattr(entry_points(reg.group)[name], "dist", None)
        origin, source = "plugin", f"{source} (distribution {getattr(dist, 'name', '?')})"
    else:
        origin = "registered"
    tunable: dict[str, tuple[str, ...]] = {}
    if kind == "controller":

        tunable = {t: spec.params for t, spec in declared_specs(cls).items()}
    return ComponentType(kind, name, origin, source, tunable)
