"""Drive types: what turns the mechanism's input (``[drive] type = ...``).

Each drive type is one class with its own ``Params`` (a :class:`mjbench.schema.Strict` model of
the ``[drive]`` table, ``type = "<name>"``, physical fields with units) whose ``build()`` gives the
drive object.  The co-step kernel (:mod:`mjbench.kernel`) calls a drive only through its laws,
bound by slot from ``drive.form(h)`` — ``limit`` (DLIMIT), ``mean`` (DMEAN), ``torque`` (DTORQUE),
``step`` (DSTEP), ``record`` (DREC) — so a new drive type needs no kernel change.  What the object
offers besides (``docs/engine.md``, "Drive types"):

* ``form(h)``: its :class:`~mjbench.compiled.Form` (parameters ``P`` with at least ``z``, the
  gear ratio the kernel uses for the motor speed z·q̇ and the input torque z·T_m; the five laws);
* ``forms(h, every, plant)``: the drive-train elements' forms (``{}`` = none); a key ``"limit"``
  (lo, hi) sets the kernel's clip of the controller output;
* ``J_eq``, ``crank_damping``: the inertia and viscous coefficient it adds on the input joint
  (MuJoCo armature and damping; the same terms in the reduced model), integrated inside the step;
* ``z``, ``train`` (None: no drive-train elements), ``as_dict()``, optionally ``diagnose(machine, h)``
  (the likely cause of a divergence, '' if none).

Built in: ``dcmotor`` (:class:`mjbench.drive.DCMotorDrive`, the default), ``torque`` and
``speed`` (:mod:`mjbench.drives.ideal`: an ideal torque source, a stiff speed source).
"""
from __future__ import annotations

import importlib

from ..errors import ParameterError

#: built-in drive types → the module that registers them
BUILTIN = {"dcmotor": "mjbench.drive", "torque": "mjbench.drives.ideal", "speed": "mjbench.drives.ideal"}
DEFAULT = "dcmotor"  #: ``[drive]`` without ``type``

_REGISTRY: dict = {}


class DriveCapabilityError(ParameterError, AttributeError):
    """A quantity a drive type does not have was asked for (an ideal torque source has no armature
    resistance): a ParameterError naming it (the CLI's one-line error), and an AttributeError so that
    ``getattr(drive, name, default)`` still falls back."""


def register(params_cls):
    """Class decorator on a drive's Params model: ``[drive] type = <its type literal>``."""
    default = params_cls.model_fields["type"].default
    if not isinstance(default, str) or not default:
        raise TypeError(f"register: {params_cls.__name__} needs a field type = \"<name>\" with that default")
    _REGISTRY[default] = params_cls
    return params_cls


def names() -> list[str]:
    for mod in set(BUILTIN.values()):
        importlib.import_module(mod)
    return sorted(_REGISTRY)


def params_class(type_name):
    """The Params model of a drive type (None if unknown)."""
    if not isinstance(type_name, str):
        return None
    if type_name not in _REGISTRY and type_name in BUILTIN:
        importlib.import_module(BUILTIN[type_name])
    return _REGISTRY.get(type_name)


def type_of(raw) -> str:
    """The drive type a raw ``[drive]`` table asks for (default ``dcmotor``)."""
    return raw.get("type", DEFAULT) if isinstance(raw, dict) else DEFAULT


def validate(raw: dict):
    """Validate a raw ``[drive]`` table with the model of its ``type`` (pydantic ValidationError on
    bad values; ParameterError naming the choices for an unknown type)."""
    cls = params_class(type_of(raw))
    if cls is None:
        raise ParameterError(f"drive.type: {type_of(raw)!r} is not a known drive type; choose one of "
                             f"{', '.join(names())}")
    return cls.model_validate(raw)


__all__ = ["register", "names", "params_class", "validate", "type_of", "DriveCapabilityError", "BUILTIN"]
