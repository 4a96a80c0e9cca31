"""Physical quantities in scenario files: a bare number is SI, a string carries its unit.

    a = 0.06            # SI (m)
    a = "60 mm"         # converted to 0.06 m by pint
    J_m = "13 kg*cm^2"  L = "9 mH"  omega0 = "286.5 rpm"  theta1 = "30 deg"
    omega0 = "10 Hz"    # an angular velocity in cycles per second: 2π·10 rad/s (not 10 rad/s)

Each physical field of the scenario tables (:func:`mjbench.fields.Q`) is declared with a *kind*
(``length``, ``inertia``, ``resistance`` ...) that fixes its SI unit, the dimension a string must
have, and a plausible range.  A value outside the plausible range is accepted but produces a
plausibility warning (``Scenario.warnings``, printed by the CLI) that suggests the likely unit
slip ("mechanism.a = 60 m is outside 1e-4 … 20 m for a link length; did you mean 60 mm?").

Angles are dimensionless for pint, so it would read "10 Hz" as 10 rad/s; here a frequency unit
given to a quantity that carries an angle is cycles per second (1 Hz = 2π rad/s), and an angular
rate given to a frequency is converted the other way (:func:`to_si`).

pint is imported (≈1 s to build its registry) only when a string with a unit is met.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

#: kind → (SI unit as pint parses it, label for messages, plausible range (lo, hi) of |value| in SI)
KINDS: dict[str, tuple[str, str, tuple[float, float] | None]] = {
    "length": ("m", "m", (1e-4, 20.0)),
    "mass": ("kg", "kg", (1e-6, 2e3)),
    "inertia": ("kg*m**2", "kg·m²", (1e-12, 1e3)),
    "resistance": ("ohm", "Ω", (1e-3, 1e3)),
    "inductance": ("H", "H", (1e-8, 10.0)),
    "motor_constant": ("N*m/A", "N·m/A", (1e-5, 50.0)),
    "angle": ("rad", "rad", None),
    "angular_velocity": ("rad/s", "rad/s", (1e-6, 1e5)),
    "angular_acceleration": ("rad/s**2", "rad/s²", None),
    "time": ("s", "s", (1e-8, 1e5)),
    "frequency": ("Hz", "Hz", (1e-3, 1e8)),
    "voltage": ("V", "V", (1e-3, 1e5)),
    "current": ("A", "A", (1e-4, 1e5)),
    "torque": ("N*m", "N·m", (0.0, 1e5)),
    "force": ("N", "N", (0.0, 1e7)),
    "rot_damping": ("N*m*s/rad", "N·m·s/rad", (0.0, 1e4)),
    "rot_stiffness": ("N*m/rad", "N·m/rad", (1e-6, 1e9)),
    "lin_stiffness": ("N/m", "N/m", (1e-3, 1e10)),
    "lin_damping": ("N*s/m", "N·s/m", (0.0, 1e7)),
    "acceleration": ("m/s**2", "m/s²", (0.0, 1e3)),
    "speed": ("m/s", "m/s", (0.0, 1e3)),
    "power": ("W", "W", None),
    "ratio": ("", "1", None),
    # controller gains (motor side): voltage per error unit
    "gain_v_per_rad_s": ("V*s/rad", "V·s/rad", None),
    "gain_v_per_rad": ("V/rad", "V/rad", None),
    "gain_v_per_rad_s2": ("V*s**2/rad", "V·s²/rad", None),
    "gain_per_s": ("1/s", "1/s", None),
    "gain_v_per_a": ("V/A", "V/A", None),
    "gain_v_per_a_s": ("V/(A*s)", "V/(A·s)", None),
}

#: alternative units tried when a bare number is implausible, per dimension of the SI unit
_SUGGEST = {
    "m": ("mm", "cm"),
    "kg": ("g",),
    "kg*m**2": ("kg*mm**2", "kg*cm**2", "g*cm**2"),
    "H": ("mH", "uH"),
    "rad/s": ("rpm",),
    "s": ("ms",),
    "N*m/A": ("mN*m/A",),
}


_UREG = None


def ureg():
    """The shared pint UnitRegistry (built on first use)."""
    global _UREG
    if _UREG is None:
        import pint

        _UREG = pint.UnitRegistry()
    return _UREG


class UnitError(ValueError):
    """A value's unit is missing, unknown or of the wrong dimension (message ready for the user)."""


def to_si(value, kind: str) -> float:
    """``value`` (number = SI, or string "<number> <unit>") → float in the SI unit of ``kind``."""
    si, label, _ = KINDS[kind]
    if isinstance(value, bool):
        raise UnitError(f"must be a number [{label}], got {value!r}")
    if isinstance(value, (int, float)):
        return float(value)
    if not isinstance(value, str):
        raise UnitError(f"must be a number [{label}] or a string with a unit, got {type(value).__name__} {value!r}")
    text = value.strip()
    low = text.lower()
    if low in ("inf", "+inf", "infinity"):
        return math.inf
    if low in ("-inf", "-infinity"):
        return -math.inf
    try:
        float(text)
    except ValueError:
        pass
    else:
        raise UnitError(f"{value!r} is a number written as a string: write it bare ({text}, SI: {label}) "
                        f"or with its unit ('{text} {label}')")
    import pint

    reg = ureg()
    try:
        q = reg.Quantity(text)
    except (pint.errors.UndefinedUnitError, pint.errors.DefinitionSyntaxError, ValueError, TypeError,
            AttributeError, AssertionError) as e:
        raise UnitError(f"{value!r} is not a number or a quantity with a unit ({e})") from None
    except Exception as e:  # pint raises various parser errors on garbage text
        raise UnitError(f"{value!r} is not a number or a quantity with a unit ({type(e).__name__})") from None
    if not isinstance(q, reg.Quantity):
        q = reg.Quantity(q)
    target = reg.Unit(si) if si else reg.dimensionless
    try:
        return float(q.to(target).magnitude) * _cycle_factor(q, kind, reg)
    except pint.errors.DimensionalityError:
        got = f"{q.units:~}" or "no unit"
        raise UnitError(f"{value!r} has the wrong dimension ({got}); expected a {kind.replace('_', ' ')} "
                        f"in {label} or a compatible unit") from None


def _angle_powers(q, reg) -> tuple[int, int]:
    """(angle power, cycle power) of a quantity's unit: the power of radian in it (rad, deg, rpm, rev
    all carry one) and the power of frequency units without an angle (Hz, kHz: cycles per second)."""
    angle = cycles = 0
    for name, exp in q.unit_items():
        root = dict(reg.get_root_units(name)[1]._units)
        if root.get("radian"):
            angle += exp * root["radian"]
        elif root == {"second": -1}:
            cycles += exp
    return angle, cycles


def _cycle_factor(q, kind: str, reg) -> float:
    """Factor that makes a frequency given to an angular quantity (or an angular rate given to a
    frequency) mean what it says: pint treats the radian as dimensionless, so "10 Hz" converts to
    10 rad/s and "10 rad/s" to 10 Hz.  Here 1 Hz = 1 cycle/s = 2π rad/s for every kind whose SI unit
    carries an angle (angular velocity and acceleration, gains per rad/s …), and 2π rad/s = 1 Hz for
    a frequency.  A unit that already names its angle (rad/s, rpm, deg/s, rev/min) is converted by pint."""
    si = KINDS[kind][0]
    if not si:
        return 1.0
    want = dict(reg.get_root_units(si)[1]._units).get("radian", 0)
    angle, cycles = _angle_powers(q, reg)
    if angle == 0 and cycles != 0 and cycles == want:
        return (2.0 * math.pi) ** cycles  # Hz → rad/s (V/Hz → V·s/rad: 1/2π)
    if kind == "frequency" and angle == 1 and cycles == 0:
        return 1.0 / (2.0 * math.pi)  # rad/s, rpm → Hz
    return 1.0


@dataclass(frozen=True)
class Bound:
    """Allowed range of a field: ``gt``/``ge``/``lt``/``le`` (SI); ``finite`` rejects ±inf."""

    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    finite: bool = True

    def check(self, v: float, label: str) -> None:
        def fmt(x):
            return f"{x:g} {label}".strip() if label and label != "1" else f"{x:g}"

        if math.isnan(v):
            raise UnitError("must be a number, got nan")
        if self.finite and math.isinf(v):
            raise UnitError(f"must be finite, got {v}")
        if self.gt is not None and not v > self.gt:
            raise UnitError(f"must be > {fmt(self.gt)}, got {v:g}")
        if self.ge is not None and not v >= self.ge:
            raise UnitError(f"must be >= {fmt(self.ge)}, got {v:g}")
        if self.lt is not None and not v < self.lt:
            raise UnitError(f"must be < {fmt(self.lt)}, got {v:g}")
        if self.le is not None and not v <= self.le:
            raise UnitError(f"must be <= {fmt(self.le)}, got {v:g}")


def plausibility(v: float, kind: str, what: str = "") -> str | None:
    """A warning text if |v| (SI) lies outside the plausible range of ``kind``, else None."""
    si, label, rng = KINDS[kind]
    if rng is None or v == 0 or not math.isfinite(v):
        return None
    lo, hi = rng
    a = abs(v)
    if lo <= a <= hi:
        return None
    hint = ""
    reg = None
    for alt in _SUGGEST.get(si, ()):
        try:
            if reg is None:
                reg = ureg()
            conv = float(reg.Quantity(a, alt).to(si).magnitude)
        except Exception:  # noqa: BLE001 - a suggestion only
            continue
        if lo <= conv <= hi:
            hint = f"; did you mean {v:g} {alt}? (bare numbers are SI: {label})"
            break
    if not hint:
        hint = f"; bare numbers are SI ({label})"
    return (f"= {v:g} {label} is outside the plausible range {lo:g} … {hi:g} {label}"
            f"{' for ' + what if what else ''}{hint}")
