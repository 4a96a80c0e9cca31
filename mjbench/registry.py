"""One registry class for every kind of named component: mechanisms, controllers and drive types.

A scenario names a component by its type (``[mechanism] type = "fourbar"``, ``[modes.pid] type =
"pid"``); the kind's :class:`Registry` maps the name to the class, found in this order:

1. a class registered in this process (``@registry.register``: a user module, a test file);
2. a built-in (``BUILTIN``: name → module, imported on first use);
3. a plugin: an entry point of the kind's group in an installed distribution
   (``[project.entry-points."mjbench.mechanisms"]`` ``my-yoke = "my_pkg.yoke:MyYoke"``);
   the entry point's name is the type name, its value the class (or a module that registers it
   when imported).  Plugins are imported only when their name is asked for, or when every name is
   listed (:meth:`Registry.names`; a plugin that fails to import is then skipped with a warning,
   and the error is raised when its own name is asked for).

Scenario files can come from plugins too (group ``mjbench.scenarios``: the value names a package
whose folder holds ``*.toml`` files; :func:`mjbench.scenario.builtin_names`).

Nothing else in mjbench changes for a plugin: its mechanism or controller runs in every command,
batched and compiled (the kernel compiles any component that provides laws; docs/CONTRIBUTING.md).
"""
from __future__ import annotations

import importlib
import sys
import warnings
from importlib import metadata

from pydantic import ValidationError

from .errors import ScenarioError
from .fields import format_errors

__all__ = ["Registry", "entry_points", "PluginWarning", "GROUPS"]

#: the entry-point groups of plugins: mechanisms, controllers, scenario folders, drive types
GROUPS = ("mjbench.mechanisms", "mjbench.controllers", "mjbench.scenarios", "mjbench.drives")

_EP_CACHE: dict = {}


class PluginWarning(UserWarning):
    """An installed plugin could not be loaded (its name is skipped in listings)."""


def entry_points(group: str) -> dict:
    """{name: EntryPoint} of an entry-point group over the installed distributions (cached per
    ``sys.path``: a folder added to it at run time is seen)."""
    key = (group, tuple(sys.path))
    hit = _EP_CACHE.get(key)
    if hit is None:
        hit = {}
        for ep in metadata.entry_points(group=group):
            hit.setdefault(ep.name, ep)
        _EP_CACHE[key] = hit
    return hit


def _origin(ep) -> str:
    dist = getattr(ep, "dist", None)
    name = getattr(dist, "name", None) if dist is not None else None
    return f"entry point {ep.group} {ep.name} = {ep.value!r} (distribution {name or '?'})"


class Registry:
    """Component classes of one ``kind`` ("mechanism", "controller", "drive"), keyed by ``type_name``.

    ``base``: the class every registered class must subclass; ``builtin``: {name: module} of the
    shipped ones; ``group``: the entry-point group of plugins; ``prefix``, ``unknown``, ``invalid``:
    how errors name the table (``("modes", "{typ}")``, "mechanism.type = {typ!r}", "invalid [mechanism]
    table"; ``{typ}`` is the type named by the table)."""

    def __init__(self, kind: str, base: type, builtin: dict, group: str, prefix=None, unknown: str = "",
                 invalid: str = ""):
        self.kind, self.base, self.builtin, self.group = kind, base, dict(builtin), group
        self.prefix = tuple(prefix) if prefix is not None else (kind, "{typ}")
        self.unknown = unknown or f"{kind} type = {{typ!r}}"
        self.invalid = invalid or f"invalid {kind} table"
        self._classes: dict[str, type] = {}

    # ------------------------------------------------------------------ registration
    def register(self, cls):
        """Class decorator: make ``cls`` available under ``cls.type_name``."""
        if not (isinstance(cls, type) and issubclass(cls, self.base)):
            raise TypeError(f"register: {cls!r} is not a {self.base.__name__} subclass")
        if not cls.type_name or cls.Params is None:
            raise TypeError(f"register: {cls.__name__} needs class attributes type_name and Params")
        home = self.builtin.get(cls.type_name)
        if home is not None and not (cls.__module__ == home or cls.__module__.startswith(home + ".")):
            raise TypeError(f"register: {_ident(cls)} has type_name = {cls.type_name!r}, a built-in {self.kind} type "
                            f"({home}); give it a name of its own")
        old = self._classes.get(cls.type_name)
        if old is not None and old is not cls and _ident(old) != _ident(cls):
            raise TypeError(f"register: {self.kind} type {cls.type_name!r} is already {_ident(old)}; "
                            f"{_ident(cls)} needs another type_name")
        self._classes[cls.type_name] = cls
        return cls

    def _load_builtin(self, name: str) -> None:
        importlib.import_module(self.builtin[name])

    def _load_plugin(self, name: str) -> None:
        ep = entry_points(self.group)[name]
        if name in self.builtin:
            raise ScenarioError(f"{_origin(ep)}: {name!r} is a built-in {self.kind} type; a plugin needs its own name")
        try:
            obj = ep.load()
        except Exception as e:  # noqa: BLE001 - any import error of a third-party package
            raise ScenarioError(f"{_origin(ep)} cannot be loaded: {type(e).__name__}: {e}") from e
        if isinstance(obj, type) and issubclass(obj, self.base):
            tn = getattr(obj, "type_name", None)
            if tn != name:
                raise ScenarioError(f"{_origin(ep)}: the class {obj.__name__} has type_name = {tn!r}, but the entry "
                                    f"point is named {name!r}: they must be the same"
                                    + (f" ({tn!r} is a built-in {self.kind} type: choose another)"
                                       if tn in self.builtin else ""))
            if name not in self._classes:
                try:
                    self.register(obj)
                except TypeError as e:
                    raise ScenarioError(f"{_origin(ep)}: {e}") from None
        cls = self._classes.get(name)
        if cls is None:
            raise ScenarioError(f"{_origin(ep)} did not register a {self.kind} type named {name!r} "
                                f"(point it at a {self.base.__name__} subclass with type_name = {name!r})")

    # ------------------------------------------------------------------ lookup
    def get(self, name):
        """The class registered as ``name`` (built-ins and plugins imported on demand), or None."""
        if not isinstance(name, str):
            return None
        if name not in self._classes:
            if name in self.builtin:
                self._load_builtin(name)
            elif name in entry_points(self.group):
                self._load_plugin(name)
        return self._classes.get(name)

    def names(self) -> list[str]:
        """Every type name: built-ins, plugins (each imported; a broken one is skipped with a
        :class:`PluginWarning`) and classes registered in this process."""
        for name in self.builtin:
            if name not in self._classes:
                self._load_builtin(name)
        for name, ep in entry_points(self.group).items():
            if name in self.builtin:
                warnings.warn(f"{_origin(ep)}: {name!r} is a built-in {self.kind} type; the plugin is ignored",
                              PluginWarning, stacklevel=2)
            elif name not in self._classes:
                try:
                    self._load_plugin(name)
                except ScenarioError as e:
                    warnings.warn(str(e), PluginWarning, stacklevel=2)
        return sorted(self._classes)

    def plugins(self) -> dict:
        """{type name: "distribution entry point"} of the installed plugins of this kind."""
        return {name: _origin(ep) for name, ep in entry_points(self.group).items()}

    def params_class(self, name, raw=None):
        """The Params model of type ``name`` for a raw table (None if the name is unknown)."""
        cls = self.get(name)
        if cls is None:
            return None
        pick = getattr(cls, "params_for", None)
        return pick(raw if raw is not None else {}) if pick is not None else cls.Params

    # ------------------------------------------------------------------ construction
    def build(self, params, **kw):
        """The component object from its validated Params (``params.type`` selects the class)."""
        return self.get(params.type).from_params(params, **kw)

    def validate(self, table: dict):
        """A raw table (dict with ``type``) → its validated Params; a ScenarioError lists every problem."""
        typ = table.get("type")
        pcls = self.params_class(typ, table)
        if pcls is None:
            raise ScenarioError(f"{self.unknown.format(typ=typ)}: choose one of {', '.join(self.names())}")
        try:
            return pcls.model_validate(table)
        except ValidationError as e:
            lines = format_errors(e, tuple(p.format(typ=typ) for p in self.prefix), pcls)
            raise ScenarioError(f"{self.invalid}:\n  " + "\n  ".join(lines), problems=lines) from None

    def from_dict(self, table: dict, **kw):
        """Validate a raw table and build the component (``kw``: what ``from_params`` takes)."""
        return self.build(self.validate(table), **kw)


def _ident(cls) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"
