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

The common units are converted without pint (:func:`fast_convert`): pint's own arithmetic — its
parser's products, quotients and integer powers, its conversion factor from the definitions'
scales (the same floats, multiplied in the same order) — over a small table of its definitions
(SI base and derived units with their prefixes, deg, rpm, rev, min …), so the result is the float
pint gives, bit for bit (tests/test_units_fast.py checks every unit string of the scenarios, docs
and tests against pint).  Anything else — another unit, other syntax, a wrong dimension — goes to
pint (imported, ≈ 1 s to build its registry, only then), whose messages are the errors.
"""
from __future__ import annotations

import math
import re
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
    fast = _fast_to_si(text, kind)
    if fast is not None:
        return fast
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
            conv = _fast_quantity(a, alt, si)
            if conv is None:
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



# ============================================================================ without pint
# pint's default registry (pint 0.25, default_en.txt) for the units scenarios use: name → (scale,
# reference).  A base unit's reference is its dimension (a string; "" for the radian, dimensionless);
# a derived unit's is its definition ((name, exponent), …) in pint's order.  The scales are pint's
# own objects (int or float, as its definition parser leaves them): pint multiplies them in its
# conversion factor, and 60 ** -1 is not 60.0 ** -1 in every case.  tests/test_units_fast.py checks
# every entry against pint's registry (scale, type, reference, name resolution).
_BASE = {"meter": "[length]", "gram": "[mass]", "second": "[time]", "ampere": "[current]",
         "kelvin": "[temperature]", "radian": ""}
_DEFS: dict = {
    "pi": (3.141592653589793, ()),
    "degree": (0.005555555555555556, (("pi", 1), ("radian", 1))),
    "turn": (2, (("pi", 1), ("radian", 1))),
    "minute": (60, (("second", 1),)),
    "hour": (60, (("minute", 1),)),
    "revolutions_per_minute": (1.0, (("turn", 1), ("minute", -1))),
    "hertz": (1.0, (("second", -1),)),
    "newton": (1.0, (("kilogram", 1), ("meter", 1), ("second", -2))),
    "joule": (1, (("newton", 1), ("meter", 1))),
    "watt": (1.0, (("joule", 1), ("second", -1))),
    "coulomb": (1, (("ampere", 1), ("second", 1))),
    "volt": (1.0, (("joule", 1), ("coulomb", -1))),
    "ohm": (1.0, (("volt", 1), ("ampere", -1))),
    "weber": (1, (("volt", 1), ("second", 1))),
    "henry": (1.0, (("weber", 1), ("ampere", -1))),
}
#: SI prefixes: symbol → (pint's name, its scale)
_PREFIX = {"G": ("giga", 1000000000.0), "M": ("mega", 1000000.0), "k": ("kilo", 1000.0), "c": ("centi", 0.01),
           "m": ("milli", 0.001), "u": ("micro", 1e-06), "µ": ("micro", 1e-06), "μ": ("micro", 1e-06),
           "n": ("nano", 1e-09)}
#: unit symbol → (pint's name, the prefixes it takes here)
_SYMBOLS = {"m": ("meter", "kcmuµμn"), "g": ("gram", "km"), "s": ("second", "muµμn"), "A": ("ampere", "kmuµμ"),
            "V": ("volt", "kmuµμ"), "ohm": ("ohm", "Mkm"), "Ω": ("ohm", "Mkm"), "H": ("henry", "muµμn"),
            "N": ("newton", "Mkm"), "W": ("watt", "Mkm"), "J": ("joule", "km"), "Hz": ("hertz", "GMkm"),
            "rad": ("radian", "m"), "rpm": ("revolutions_per_minute", "k"), "K": ("kelvin", ""),
            "C": ("coulomb", ""), "Wb": ("weber", ""), "deg": ("degree", ""), "min": ("minute", ""),
            "hr": ("hour", ""), "turn": ("turn", "")}
#: spelled-out names (and plurals pint accepts) → pint's name
_WORDS = {"meter": "meter", "meters": "meter", "metre": "meter", "gram": "gram", "grams": "gram",
          "kilogram": "kilogram", "kilograms": "kilogram", "second": "second", "seconds": "second",
          "sec": "second", "millisecond": "millisecond", "milliseconds": "millisecond", "ampere": "ampere",
          "amperes": "ampere", "amp": "ampere", "volt": "volt", "volts": "volt", "ohms": "ohm", "henry": "henry",
          "newton": "newton", "newtons": "newton", "watt": "watt", "watts": "watt", "joule": "joule",
          "joules": "joule", "hertz": "hertz", "radian": "radian", "radians": "radian", "degree": "degree",
          "degrees": "degree", "revolution": "turn", "revolutions": "turn", "turns": "turn", "cycle": "turn",
          "minute": "minute", "minutes": "minute", "hour": "hour", "hours": "hour", "kelvin": "kelvin",
          "millimeter": "millimeter", "millimeters": "millimeter", "centimeter": "centimeter",
          "centimeters": "centimeter"}


def _unit_table():
    names, defs = dict(_WORDS), dict(_DEFS)
    for sym, (name, prefixes) in _SYMBOLS.items():
        names[sym] = name
        for p in prefixes:
            pname, scale = _PREFIX[p]
            names[p + sym] = pname + name
            defs[pname + name] = (scale, ((name, 1),))
    return names, defs


_NAMES, _UNITS = _unit_table()
_NUMBER = re.compile(r"([+-]?)(\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)(\s*)")
_TOKENS = re.compile(r"\s*(\*\*|\^|[*/()]|-?\d+|[A-Za-zµμΩ_]+)")
_PLAIN = re.compile(r"\d+\.?\d*")
_GLUED = frozenset("abcdfghijklmnopqrstuvwxyzABCDFGHIJKLMNOPQRSTUVWXYZ")
_INT = re.compile(r"-?\d+")
_ROOT_CACHE: dict = {}


def _mul(a: dict, b: dict, sign: int) -> dict:
    """pint's UnitsContainer product (sign 1) or quotient (−1): a's keys first, a zero exponent dropped."""
    new = dict(a)
    for k, v in b.items():
        new[k] = new.get(k, 0) + sign * v
        if new[k] == 0:
            del new[k]
    return new


def _units_of(expr: str) -> dict | None:
    """The units of ``expr`` as pint's parser builds them (names and exponents in its order), or None
    when the expression is outside the fast path (unknown name, other syntax)."""
    toks, pos = [], 0
    expr = expr.strip()
    while pos < len(expr):
        m = _TOKENS.match(expr, pos)
        if m is None or m.end() == pos:
            return None
        toks.append(m.group(1))
        pos = m.end()
        while pos < len(expr) and expr[pos].isspace():
            pos += 1
    if not toks:
        return None
    i = 0

    def factor():
        nonlocal i
        if i >= len(toks):
            return None
        t = toks[i]
        i += 1
        if t == "(":
            u = product()
            if u is None or i >= len(toks) or toks[i] != ")":
                return None
            i += 1
        elif t == "1":
            u = {}
        elif t in _NAMES:
            u = {_NAMES[t]: 1}
        else:
            return None
        if i < len(toks) and toks[i] in ("**", "^"):
            i += 1
            if i >= len(toks) or not _INT.fullmatch(toks[i]) or int(toks[i]) == 0:
                return None
            n = int(toks[i])
            i += 1
            u = {k: v * n for k, v in u.items()}
        return u

    def product():
        nonlocal i
        u = factor()
        while u is not None and i < len(toks) and toks[i] != ")":
            sign = 1
            if toks[i] in ("*", "/"):
                sign = 1 if toks[i] == "*" else -1
                i += 1
            v = factor()
            if v is None:
                return None
            u = _mul(u, v, sign)
        return u

    u = product()
    return u if u is not None and i == len(toks) else None


def _root(units: dict):
    """pint's ``_get_root_units``: (factor, base units) of ``units``: the scales gathered as a
    fraction keyed by value (equal scales cancel), then multiplied numerator first, in pint's order."""
    key = tuple(units.items())
    hit = _ROOT_CACHE.get(key)
    if hit is not None:
        return hit
    if not units:
        return 1, {}
    acc: dict = {}
    num: dict = {}
    den: dict = {}

    def walk(ref, exp):
        for name, e in ref:
            e2 = exp * e
            if name in _BASE:
                acc[name] = acc.get(name, 0) + e2
                continue
            scale, sub = _UNITS[name]
            if e2 < 0:
                den[scale] = den.get(scale, 0) - e2
            else:
                num[scale] = num.get(scale, 0) + e2
            walk(sub, e2)

    walk(units.items(), 1)
    while any(f in den for f in num):
        for f, e in num.items():
            if f in den and e >= den[f]:
                num[f] -= den[f]
                del den[f]
        for f, e in den.items():
            if f in num and e >= num[f]:
                den[f] -= num[f]
                del num[f]
    factor = 1
    for f, e in num.items():
        if e != 0:
            factor *= f ** e
    for f, e in den.items():
        if e != 0:
            factor *= f ** -e
    out = _ROOT_CACHE[key] = (factor, {k: v for k, v in acc.items() if v != 0})
    return out


def _dims(base: dict) -> dict:
    return {_BASE[k]: v for k, v in base.items() if _BASE[k]}


def _fast_factor(src: dict, dst: dict):
    """pint's conversion factor src → dst (its ``convert``), or None when the dimensions differ."""
    if src == dst:
        return None, True
    if _dims(_root(src)[1]) != _dims(_root(dst)[1]):
        return None, False
    return _root(_mul(src, dst, -1))[0], True


def _fast_quantity(magnitude, unit, si: str):
    """``magnitude`` in ``unit`` (text, or units as :func:`_units_of` gives them) converted to ``si`` as
    pint does (``Quantity(magnitude, unit).to(si)``), or None."""
    src = _units_of(unit) if isinstance(unit, str) else unit
    dst = _units_of(si) if si else {}
    if src is None or dst is None:
        return None
    f, ok = _fast_factor(src, dst)
    if not ok:
        return None
    return float(magnitude if f is None else magnitude * f)


def _fast_parse(text: str):
    """"<number> <units>" → (pint's magnitude: int or float, units) or None."""
    m = _NUMBER.match(text)
    if m is None:
        return None
    sign, num, gap = m.groups()
    rest = text[m.end():]
    if not rest or (not gap and not (_PLAIN.fullmatch(num) and rest[0] in _GLUED)):
        return None  # "60mm" reads as 60*mm in pint; anything less plain: pint decides
    try:
        mag = int(num)
    except ValueError:
        mag = float(num)
    if sign == "-":
        mag = mag * -1
    units = _units_of(rest)
    return None if units is None else (mag, units)


def _fast_to_si(text: str, kind: str):
    """:func:`to_si` of a string without pint, or None (pint decides: another unit, other syntax, an
    error).  The same float as pint's path: magnitude × pint's factor, × the cycle factor."""
    parsed = _fast_parse(text)
    si = KINDS[kind][0]
    dst = _units_of(si) if si else {}
    if parsed is None or dst is None:
        return None
    mag, src = parsed
    f, ok = _fast_factor(src, dst)
    if not ok:
        return None
    value = float(mag if f is None else mag * f)
    # the cycle factor (:func:`_cycle_factor`) from the same root units
    if not si:
        return value * 1.0
    want = _root(dst)[1].get("radian", 0)
    angle = cycles = 0
    for name, exp in src.items():
        root = _root({name: 1})[1]
        if root.get("radian"):
            angle += exp * root["radian"]
        elif root == {"second": -1}:
            cycles += exp
    if angle == 0 and cycles != 0 and cycles == want:
        return value * (2.0 * math.pi) ** cycles
    if kind == "frequency" and angle == 1 and cycles == 0:
        return value * (1.0 / (2.0 * math.pi))
    return value * 1.0


def fast_convert(text: str, unit: str):
    """A quantity string converted to ``unit`` (a unit expression, e.g. ``"kelvin/watt"``) as pint
    would, without pint; None when the fast path does not know it (then ask pint)."""
    parsed = _fast_parse(str(text).strip())
    return None if parsed is None else _fast_quantity(parsed[0], parsed[1], unit)
