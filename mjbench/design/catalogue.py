"""Motor and gearbox catalogues (TOML or CSV), validated like scenarios (units, one message).

TOML: ``[[motors]]`` and ``[[gearboxes]]`` tables.  CSV: one row per item with a ``kind`` column
(``motor`` / ``gearbox``) and the same keys as columns (a cell may carry a unit: ``0.85 ohm``;
empty = default).  Keys:

motor
    name, voltage (nominal), R (terminal resistance at 25 °C), L, k_m (torque constant = back-EMF
    constant), J_rotor, T_cont (continuous torque at 25 °C ambient), T_peak, speed_max,
    R_th_wh (winding → housing) and R_th_ha (housing → ambient) [K/W], tau_w (winding) and tau_h
    (housing) thermal time constants, T_max (winding limit, °C), friction (Coulomb, motor
    shaft), viscous [N·m·s/rad], cost (optional, any unit: used for ranking)
gearbox
    name, ratio, efficiency, efficiency_back (default: efficiency), J_input (motor side),
    T_cont_out, T_peak_out (output torque ratings), speed_max_in, cost

The shipped ``example`` catalogue (mjbench/design/catalogues/example.toml) holds ILLUSTRATIVE
values shaped like the data sheets of small permanent-magnet DC motors and planetary gearboxes,
NOT any vendor's data: bring your vendors' data sheets.
"""
from __future__ import annotations

import csv
import io
import math
import os
import tomllib
from typing import Annotated

from pydantic import BeforeValidator, Field, ValidationError, model_validator
from pydantic_core import PydanticCustomError

from .. import units as U
from ..errors import ScenarioError
from ..schema import Q, Strict, format_errors


def _thermal_resistance(v):
    """K/W: a number, or a string with a unit convertible to kelvin per watt."""
    if isinstance(v, bool):
        raise PydanticCustomError("mjbench_value", "must be a number [K/W], got {v!r}", {"v": v})
    if isinstance(v, (int, float)):
        x = float(v)
    elif isinstance(v, str):
        try:
            x = float(v)
        except ValueError:
            try:
                reg = U.ureg()
                x = float(reg.Quantity(v.strip()).to("kelvin/watt").magnitude)
            except Exception:  # noqa: BLE001 - pint's parser errors vary
                raise PydanticCustomError("mjbench_value", "{v!r} is not a thermal resistance in K/W", {"v": v}) from None
    else:
        raise PydanticCustomError("mjbench_value", "must be a number [K/W], got {v!r}", {"v": v})
    if not (math.isfinite(x) and x > 0):
        raise PydanticCustomError("mjbench_value", "must be > 0 K/W, got {v!r}", {"v": v})
    return x


KperW = Annotated[float, BeforeValidator(_thermal_resistance)]


class Motor(Strict):
    """A permanent-magnet DC motor (see the module doc for the keys)."""

    name: str
    voltage: Q("voltage", gt=0.0) = Field(description="nominal voltage")
    R: Q("resistance", gt=0.0) = Field(description="terminal resistance at 25 °C")
    L: Q("inductance", ge=0.0) = Field(description="terminal inductance")
    k_m: Q("motor_constant", gt=0.0) = Field(description="torque constant = back-EMF constant")
    J_rotor: Q("inertia", gt=0.0) = Field(description="rotor inertia")
    T_cont: Q("torque", gt=0.0) = Field(description="continuous torque (25 °C ambient)")
    T_peak: Q("torque", gt=0.0) = Field(description="peak torque")
    speed_max: Q("angular_velocity", gt=0.0) = Field(description="maximum speed")
    R_th_wh: KperW = Field(description="thermal resistance winding → housing [K/W]")
    R_th_ha: KperW = Field(description="thermal resistance housing → ambient [K/W]")
    tau_w: Q("time", gt=0.0) = Field(description="winding thermal time constant")
    tau_h: Q("time", gt=0.0) = Field(description="housing (motor) thermal time constant")
    T_max: float = Field(125.0, gt=0.0, le=250.0, description="maximum winding temperature [°C]")
    friction: Q("torque", ge=0.0) = Field(0.0, description="Coulomb friction torque (no-load current × k_m)")
    viscous: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous friction")
    cost: float | None = Field(None, ge=0.0, description="price or any ranking figure")

    @model_validator(mode="after")
    def _peak(self):
        if self.T_peak < self.T_cont:
            raise PydanticCustomError("mjbench_value", "T_peak = {p:g} N·m is below T_cont = {c:g} N·m",
                                      {"p": self.T_peak, "c": self.T_cont})
        return self


class Gearbox(Strict):
    """A gear reducer (see the module doc for the keys)."""

    name: str
    ratio: float = Field(gt=1.0, description="input turns per output turn")
    efficiency: float = Field(1.0, gt=0.0, le=1.0)
    efficiency_back: float | None = Field(None, gt=0.0, le=1.0)
    J_input: Q("inertia", ge=0.0) = Field(0.0, description="inertia at the input (motor side)")
    T_cont_out: Q("torque", gt=0.0) = Field(description="continuous output torque")
    T_peak_out: Q("torque", gt=0.0) = Field(description="peak output torque")
    speed_max_in: Q("angular_velocity", gt=0.0) = Field(description="maximum input speed")
    cost: float | None = Field(None, ge=0.0)

    @property
    def eta_back(self) -> float:
        return self.efficiency if self.efficiency_back is None else self.efficiency_back


#: the gearbox of a direct drive (z = 1): lossless, no limits of its own
DIRECT = None


class Catalogue(Strict):
    """Validated motors and gearboxes; ``illustrative``: the file says its values are examples."""

    motors: list[Motor] = Field(default_factory=list)
    gearboxes: list[Gearbox] = Field(default_factory=list)
    title: str = ""
    illustrative: bool = False
    source: str = Field("", exclude=True)

    @model_validator(mode="after")
    def _names(self):
        for what, items in (("motors", self.motors), ("gearboxes", self.gearboxes)):
            names = [x.name for x in items]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise PydanticCustomError("mjbench_value", "{w}: names used twice: {d}", {"w": what, "d": dup})
        if not self.motors:
            raise PydanticCustomError("mjbench_value", "the catalogue lists no motor")
        return self


def example_path() -> str:
    import importlib.resources

    return str(importlib.resources.files("mjbench").joinpath("design", "catalogues", "example.toml"))


def load(path_or_name: str, base: str = "") -> Catalogue:
    """A catalogue file (TOML or CSV), or ``"example"`` (the shipped illustrative one)."""
    if path_or_name == "example":
        path = example_path()
    else:
        path = path_or_name if os.path.isabs(path_or_name) or not base else os.path.join(base, path_or_name)
    if os.path.isdir(path):
        raise ScenarioError(f"catalogue {path_or_name!r} is a folder ({path}): give a TOML or CSV file")
    if not os.path.isfile(path):
        raise ScenarioError(f"catalogue {path_or_name!r}: no such file ({path})")
    with open(path, "rb") as f:
        data = f.read()
    if path.lower().endswith(".csv"):
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as e:
            raise ScenarioError(f"catalogue {path}: not UTF-8 text (byte {e.start}): save the CSV as UTF-8") from None
        raw = _from_csv(text, path)
    else:
        try:
            raw = tomllib.loads(data.decode("utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
            raise ScenarioError(f"catalogue {path}: not valid TOML: {e}") from None
    try:
        cat = Catalogue.model_validate(raw)
    except ValidationError as e:
        lines = format_errors(e, (), Catalogue)
        raise ScenarioError(f"catalogue {path} has {len(lines)} problem{'s' if len(lines) > 1 else ''}:\n  "
                            + "\n  ".join(lines), problems=lines) from None
    cat.source = path
    return cat


def _from_csv(text: str, path: str) -> dict:
    try:
        rows = list(csv.DictReader(io.StringIO(text)))
    except csv.Error as e:
        raise ScenarioError(f"catalogue {path}: not a readable CSV ({e})") from None
    out = {"motors": [], "gearboxes": []}
    problems = []
    if not rows:
        raise ScenarioError(f"catalogue {path}: no rows (expected a header with a 'kind' column and one row per item)")
    for k, row in enumerate(rows, start=2):
        if None in row:  # more cells than the header has columns: they would be ignored
            problems.append(f"line {k}: {len(row[None])} cell(s) more than the header's columns (a ragged row)")
            continue
        kind = (row.pop("kind", "") or "").strip().lower()
        item = {}
        for key, val in row.items():
            if key is None or val is None or not str(val).strip():
                continue
            v = str(val).strip()
            try:
                v = float(v)
            except ValueError:
                pass
            item[key.strip()] = v
        if kind == "motor":
            out["motors"].append(item)
        elif kind == "gearbox":
            out["gearboxes"].append(item)
        else:
            problems.append(f"line {k}: kind = {kind!r}: must be 'motor' or 'gearbox'")
    if problems:
        raise ScenarioError(f"catalogue {path}: " + "; ".join(problems), problems=problems)
    return out


def select(cat: Catalogue, motors=None, gearboxes=None) -> Catalogue:
    """The catalogue restricted to the named items (unknown names are an error naming them)."""
    out = cat.model_copy()
    for what, names in (("motors", motors), ("gearboxes", gearboxes)):
        if names is None:
            continue
        have = {x.name: x for x in getattr(cat, what)}
        bad = [n for n in names if n not in have]
        if bad:
            raise ScenarioError(f"drive.{what}: {bad} not in the catalogue {cat.source} ({', '.join(have)})")
        setattr(out, what, [have[n] for n in names])
    return out
