"""Drive types: what turns the mechanism's input (``[drive] type = ...``).

Each drive type is one :class:`Drive` subclass with ``type_name`` and its own ``Params`` (a
:class:`mjbench.fields.Strict` model of the ``[drive]`` table, ``type = "<name>"``, physical fields
with units) whose ``build()`` gives the drive object, registered in :data:`REGISTRY` (the same
:class:`mjbench.registry.Registry` as mechanisms and controllers: ``@mjbench.drives.register``, or
an installed package's entry point in the group ``mjbench.drives``).  The co-step kernel
(:mod:`mjbench.kernel`) calls a drive only through its laws, bound by slot from ``drive.form(h)``
— ``limit`` (DLIMIT), ``mean`` (DMEAN), ``torque`` (DTORQUE), ``step`` (DSTEP), ``record`` (DREC)
— so a new drive type needs no kernel change.  What the object
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

from typing import ClassVar

from ..errors import ParameterError
from ..registry import GROUPS, Registry

#: built-in drive types → the module that registers them
BUILTIN = {"dcmotor": "mjbench.drive", "torque": "mjbench.drives.ideal", "speed": "mjbench.drives.ideal"}
DEFAULT = "dcmotor"  #: ``[drive]`` without ``type``


class DriveCapabilityError(ParameterError, AttributeError):
    """A quantity a drive type does not have was asked for (an ideal torque source has no armature
    resistance): a ParameterError naming it (the CLI's one-line error), and an AttributeError so that
    ``getattr(drive, name, default)`` still falls back."""


class Drive:
    """Base of every drive type: ``type_name`` (``[drive] type``), ``Params`` (the table's model,
    with ``type: Literal[type_name]`` defaulting to it) and the object the kernel drives (see the
    module docstring for what it offers)."""

    #: ``[drive] type`` of this class
    type_name: ClassVar[str] = ""
    #: pydantic model of the ``[drive]`` table
    Params: ClassVar[type | None] = None

    @classmethod
    def from_params(cls, params, **kw):
        """The drive object from its validated Params (default: ``params.build()``)."""
        return params.build()


#: the drive registry (built-ins, plugins of entry-point group ``mjbench.drives``, registered classes)
REGISTRY = Registry("drive", Drive, BUILTIN, GROUPS[3], prefix=("drive",), unknown="drive.type = {typ!r}",
                    invalid="invalid [drive] table")


def register(cls):
    """Class decorator on a :class:`Drive` subclass: ``[drive] type = cls.type_name``."""
    return REGISTRY.register(cls)


def names() -> list[str]:
    """Every drive type name (built-ins, plugins, registered)."""
    return REGISTRY.names()


def get(type_name):
    """The drive class of ``type_name`` (None if unknown)."""
    return REGISTRY.get(type_name)


def params_class(type_name):
    """The Params model of a drive type (None if unknown)."""
    return REGISTRY.params_class(type_name)


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


__all__ = ["Drive", "REGISTRY", "register", "names", "get", "params_class", "validate", "type_of",
           "DriveCapabilityError", "BUILTIN"]
