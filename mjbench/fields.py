"""Field types of every scenario table (a leaf module: it imports only pydantic and :mod:`mjbench.units`).

A table is a :class:`Strict` pydantic model; a physical value is a :func:`Q` field (its quantity
kind fixes the SI unit, the bounds are checked, a string may carry a unit), :func:`OptQ` when
``None`` turns a feature off, :data:`Bool` a strict true/false.  :func:`format_errors` turns a
pydantic ``ValidationError`` into one readable line per problem (``drive.R: must be > 0 Ω, got -1``).

Mechanisms (``Params``), controllers (``Params``), the drive and the drive-train elements declare
their tables with these types; :mod:`mjbench.schema` assembles the scenario from them.  Nothing here
imports a component, so every component module can import it at module level.
"""

import math
import typing
from typing import Annotated

from pydantic import AllowInfNan, BaseModel, BeforeValidator, ConfigDict, ValidationError
from pydantic_core import PydanticCustomError

from . import units as U

__all__ = ["UnitMeta", "Q", "OptQ", "Bool", "Strict", "jsonable", "format_errors", "unit_meta"]


class UnitMeta:
    """Marker in a field's metadata: its quantity kind (SI unit) and what it is (warnings)."""

    __slots__ = ("kind", "what", "plausible")

    def __init__(self, kind, what="", plausible=True):
        self.kind, self.what, self.plausible = kind, what, plausible

    def __repr__(self):
        return f"UnitMeta({self.kind!r})"


def _converter(kind, bound, allow_none=False):
    label = U.KINDS[kind][1]

    def conv(v):
        if allow_none and (v is None or (isinstance(v, str) and v.strip().lower() == "none")):
            return None
        try:
            x = U.to_si(v, kind)
            bound.check(x, label)
        except U.UnitError as e:
            raise PydanticCustomError("mjbench_value", str(e)) from None
        return x

    return conv


def Q(kind: str, *, gt=None, ge=None, lt=None, le=None, finite=True, what="", plausible=True):
    """A physical float field of ``kind`` (SI unit of :data:`mjbench.units.KINDS`) with bounds
    (``finite=False``: ±inf allowed, e.g. a limit that is off)."""
    b = U.Bound(gt, ge, lt, le, finite)
    return Annotated[float, AllowInfNan(not finite), BeforeValidator(_converter(kind, b)), UnitMeta(kind, what, plausible)]


def OptQ(kind: str, *, gt=None, ge=None, lt=None, le=None, finite=True, what="", plausible=True):
    """Like :func:`Q` but ``None`` / ``"none"`` is accepted (feature off)."""
    b = U.Bound(gt, ge, lt, le, finite)
    return Annotated[float | None, AllowInfNan(not finite), BeforeValidator(_converter(kind, b, allow_none=True)),
                     UnitMeta(kind, what, plausible)]


def _strict_bool(v):
    if not isinstance(v, bool):
        raise PydanticCustomError("mjbench_value", "must be true or false, got {v!r}", {"v": v})
    return v


Bool = Annotated[bool, BeforeValidator(_strict_bool)]


class Strict(BaseModel):
    """Base of every scenario table: unknown keys are errors; values validated on assignment."""

    # (allow_inf_nan=False: a plain number field refuses nan and ±inf; a Q(..., finite=False) limit takes inf)
    model_config = ConfigDict(extra="forbid", validate_default=True, validate_assignment=True,
                              arbitrary_types_allowed=True, frozen=False, allow_inf_nan=False)

    def to_dict(self) -> dict:
        """Plain, JSON-ready dict (SI floats; ±inf written as the strings "inf"/"-inf")."""
        return jsonable(self.model_dump(mode="python", exclude_none=False))


def jsonable(o):
    """``o`` with ±inf floats written as the strings "inf"/"-inf" (dicts, lists and tuples walked)."""
    if isinstance(o, dict):
        return {k: jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, float) and math.isinf(o):
        return "inf" if o > 0 else "-inf"
    return o


def unit_meta(field) -> UnitMeta | None:
    """The :class:`UnitMeta` of a pydantic field (its own metadata first, then its annotation's)."""
    um = next((m for m in field.metadata if isinstance(m, UnitMeta)), None)
    if um is None:
        for a in _annot_args(field.annotation):
            um = um or a
    return um


# ============================================================================ error messages
def _model_in(ann):
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    for a in typing.get_args(ann) or ():
        m = _model_in(a)
        if m is not None:
            return m
    return None


def _annot_args(ann):
    out = []
    for a in typing.get_args(ann) or ():
        if isinstance(a, UnitMeta):
            out.append(a)
        out.extend(_annot_args(a))
    return out


def _allowed_keys(model_cls, loc):
    """Field names of the model at ``loc`` (for 'unknown key' messages), or None."""
    cls = model_cls
    for p in loc:
        if cls is None or not isinstance(cls, type) or not issubclass(cls, BaseModel):
            return None
        f = cls.model_fields.get(p) if isinstance(p, str) else None
        if f is None:
            return None
        ann = f.annotation
        cls = _model_in(ann)
    if cls is not None and isinstance(cls, type) and issubclass(cls, BaseModel):
        return sorted(k for k, v in cls.model_fields.items() if not v.exclude)
    return None


def _field_description(model_cls, loc):
    cls = model_cls
    for i, p in enumerate(loc):
        if cls is None or not isinstance(cls, type) or not issubclass(cls, BaseModel):
            return ""
        f = cls.model_fields.get(str(p))
        if f is None:
            return ""
        if i == len(loc) - 1:
            d = f.description or ""
            um = unit_meta(f)
            unit = f"[{U.KINDS[um.kind][1]}]" if isinstance(um, UnitMeta) else ""
            return " ".join(x for x in (d, unit) if x)
        cls = _model_in(f.annotation)
    return ""


_TYPE_ERRORS = ("float_parsing", "float_type", "int_parsing", "int_type", "bool_parsing", "bool_type",
                "string_type", "dict_type", "list_type", "tuple_type", "model_type", "int_from_float")


def _message(e: dict, model_cls) -> str:
    """The readable message of one pydantic error ``e``."""
    typ = e["type"]
    inp = e.get("input")
    if typ == "missing":
        msg = "required value is missing"
        desc = _field_description(model_cls, e["loc"]) if model_cls else ""
        return msg + (f" ({desc})" if desc else "")
    if typ == "extra_forbidden":
        allowed = _allowed_keys(model_cls, e["loc"][:-1]) if model_cls else None
        msg = f"unknown {'table' if isinstance(inp, dict) else 'key'}"
        return msg + (f"; allowed here: {', '.join(allowed)}" if allowed else "")
    if typ.startswith("mjbench"):
        return e["msg"]
    if typ in ("literal_error", "enum") or typ in _TYPE_ERRORS:
        return e["msg"].replace("Input should be", "must be") + f", got {inp!r}"
    msg = e["msg"].replace("Input should be", "must be").replace("Value error, ", "")
    if inp is not None and not isinstance(inp, (dict, list)):
        msg += f", got {inp!r}"
    return msg


def format_errors(err: ValidationError, prefix: tuple = (), model_cls=None) -> list[str]:
    """One line per problem: ``path: message`` (pydantic's wording made readable)."""
    lines = []
    for e in err.errors(include_url=False):
        loc = tuple(prefix) + tuple(str(p) for p in e["loc"])
        lines.append(f"{'.'.join(loc) or '(top level)'}: {_message(e, model_cls)}")
    return lines
