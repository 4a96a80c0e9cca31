"""The unit strings read without pint (mjbench.units' fast path) give pint's float, bit for bit.

The fast path reproduces pint's arithmetic over a table of pint's own definitions; these tests check
the table against pint's registry, then every unit string of the shipped scenarios, the docs and
the tests — and a grid of every name the table knows, with prefixes, products, quotients and powers —
against pint itself, for every quantity kind: the same float (compared as bits) or, where pint
refuses (a wrong dimension), a fall back to pint and its message."""
import json
import math
import os
import re
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from mjbench import units as U

pint = pytest.importorskip("pint")
ROOT = Path(__file__).resolve().parents[1]
#: where unit strings are written: the shipped scenarios and catalogues, the docs, the tests, the examples
CORPUS = ("mjbench/scenarios/**/*.toml", "mjbench/design/catalogues/*.toml", "tests/**/*.py", "tests/data/**/*.toml",
          "docs/**/*.md", "docs/notebooks/*.ipynb", "README.md", "scripts/examples/*.py")
#: a quoted "<number> <unit>" (escaped quotes of JSON or Python strings excluded)
QUOTED = re.compile(r"""["']([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\s*[A-Za-zµμΩ°(][^"'\n\\]{0,40})["']""")


def _bits(x):
    return struct.pack("<d", x)


@pytest.fixture(scope="module")
def reg():
    return U.ureg()


_TARGETS: dict = {}


def _target(kind, reg):
    """(pint unit of kind, its dimensionality)."""
    hit = _TARGETS.get(kind)
    if hit is None:
        si = U.KINDS[kind][0]
        t = reg.Unit(si) if si else reg.dimensionless
        hit = _TARGETS[kind] = (t, t.dimensionality)
    return hit


def _same_as_pint(text, kind, reg, q=None):
    """(fast value or None, pint value or None (a dimension error)); asserts they agree.  pint's value
    is to_si's pint path (the strings the fast path does not know)."""
    fast = U._fast_to_si(text, kind)
    q = reg.Quantity(text) if q is None else q
    target, dims = _target(kind, reg)
    if q.dimensionality != dims:  # pint raises DimensionalityError: the fast path must leave it to pint
        assert fast is None, f"{text!r} as {kind}: pint refuses it, the fast path gave {fast!r}"
        return fast, None
    ref = float(q.to(target).magnitude) * U._cycle_factor(q, kind, reg)
    if fast is not None:
        assert _bits(fast) == _bits(ref), f"{text!r} as {kind}: fast {fast!r} vs pint {ref!r}"
    return fast, ref


def _all_kinds(text, reg):
    """How many kinds the fast path converted (each checked against pint)."""
    q = reg.Quantity(text)
    return sum(_same_as_pint(text, kind, reg, q)[0] is not None for kind in U.KINDS)


def corpus():
    """{unit string: first file it appears in} over CORPUS (strings pint reads as a quantity with a unit)."""
    found = {}
    for pattern in CORPUS:
        for f in sorted(ROOT.glob(pattern)):
            if f.name == Path(__file__).name:  # (this file's own examples of what pint alone reads)
                continue
            for m in QUOTED.finditer(f.read_text(encoding="utf-8")):
                if any(c in m.group(1) for c in "(@"):  # "+3 (3 %)", "180.0° @ 0.1667 s": prose, never a value
                    continue
                if "°" in m.group(1):  # pint's preprocessor reads the degree sign: such a value takes pint's path
                    continue
                found.setdefault(m.group(1).strip(), f.relative_to(ROOT).as_posix())
    return found


def test_the_table_is_pints_registry(reg):
    """Every name resolves as pint resolves it; every definition has pint's scale (same type, same
    float) and reference; the base units are pint's, with their dimensions; the prefixes' scales too."""
    for token, name in U._NAMES.items():
        assert reg.get_name(token) == name, token
    for name, (scale, ref) in U._UNITS.items():
        d = reg._units[name]
        assert not d.is_base, name
        s = d.converter.scale
        assert type(scale) is type(s) and repr(scale) == repr(s), (name, scale, s)
        assert tuple((reg.get_name(k), v) for k, v in d.reference.items()) == ref, name
    for name, dim in U._BASE.items():
        d = reg._units[name]
        assert d.is_base and dict(d.reference) == ({dim: 1} if dim else {"[]": 1}), name
    for pname, scale in U._PREFIX.values():
        s = reg._prefixes[pname].converter.scale
        assert type(scale) is type(s) and repr(scale) == repr(s), pname


def test_every_unit_string_of_scenarios_docs_and_tests_is_pints_float(reg):
    """Each unit string found in the scenarios, catalogues, docs and tests, as every quantity kind:
    the fast path gives pint's float bit for bit, and it knows every one of them (no pint needed)."""
    found = corpus()
    strings = {}
    for text, where in found.items():
        try:
            q = reg.Quantity(text)
        except Exception:  # noqa: BLE001 - prose that only looks like a quantity
            continue
        if isinstance(q, reg.Quantity) and q.unit_items():
            strings[text] = where
    assert len(strings) > 150 and {"60 mm", "13 kg*cm^2", "-93 deg", "286.5 rpm", "9 mH"} <= set(strings)
    unknown = []
    for text, where in sorted(strings.items()):
        if not _all_kinds(text, reg) and U.fast_convert(text, "kelvin/watt") is None:
            unknown.append(f"{text!r} ({where})")
    assert not unknown, "not on the fast path: " + ", ".join(unknown)


def test_every_name_of_the_table_with_numbers(reg):
    """Every name the fast path knows, after several spellings of a number, as every kind."""
    numbers = ["1", "7", "-2.5", "0.001", "1e3", "6.9724e-4", "-0", "-0.0", "+3", ".5", "286.5"]
    no_kind = set()
    for i, token in enumerate(U._NAMES):
        for number in (numbers[i % len(numbers)], numbers[(i + 5) % len(numbers)]):
            if not _all_kinds(f"{number} {token}", reg):
                no_kind.add(U._NAMES[token])
    # units of no scenario quantity of their own (parts of products: V = J/C, H = Wb/A; K/W of a catalogue)
    assert no_kind <= {"kelvin", "coulomb", "weber", "joule", "kilojoule", "millijoule"}, no_kind
    for number in numbers:
        for token in ("mm", "deg", "rpm", "kg*cm^2", "mH", "Hz"):
            _all_kinds(f"{number} {token}", reg)


def test_products_quotients_and_powers(reg):
    """Combinations as the scenarios write them (kg*cm^2, N*m*s/rad, V/(A*s), 1/s …), over prefixes."""
    names = ["m", "mm", "cm", "km", "um", "g", "kg", "mg", "s", "ms", "us", "min", "A", "mA", "V", "mV", "ohm", "Ω",
             "kohm", "H", "mH", "uH", "N", "kN", "mN", "W", "kW", "J", "Hz", "kHz", "rad", "mrad", "deg", "rpm",
             "krpm", "turn", "revolution", "K"]
    forms = ["{a}*{b}", "{a}*{b}^2", "{a}*{b}**2", "{a}/{b}", "{a}/{b}**2", "{a}*{b}/{c}", "{a}/({b}*{c})",
             "{a} {b}", "1/{a}", "{a}**-1", "({a}/{b})^2", "{a}*{b}*{c}"]
    n = 0
    for i, a in enumerate(names):
        for j in range(0, len(names), 5):
            b, c = names[(i + j + 1) % len(names)], names[(3 * i + j) % len(names)]
            n += _all_kinds("13.7 " + forms[(i + j) % len(forms)].format(a=a, b=b, c=c), reg)
    assert n > 100
    # the forms of the scenarios themselves are all on the fast path
    for text, kind in (("13 kg*cm^2", "inertia"), ("0.48 V*s/rad", "gain_v_per_rad_s"), ("20 mN*m", "torque"),
                       ("2e4 N*m/rad", "rot_stiffness"), ("60 V/krpm", "gain_v_per_rad_s"), ("2 1/s", "angular_velocity"),
                       ("1 Hz/s", "angular_acceleration"), ("3 V/(A*s)", "gain_v_per_a_s"), ("60mm", "length")):
        assert U._fast_to_si(text, kind) is not None, text


def test_the_plausibility_suggestions_convert_as_pint(reg):
    for si, alts in U._SUGGEST.items():
        for alt in alts:
            for a in (100.0, 0.37, 13.0, 2270.0):
                fast = U._fast_quantity(a, alt, si)
                assert fast is not None and _bits(fast) == _bits(float(reg.Quantity(a, alt).to(si).magnitude))


def test_what_the_fast_path_does_not_know_goes_to_pint(reg):
    """Other units and syntax: pint converts them (the same answer as before); the fast path stays out."""
    for text, kind, si in (("3 inch", "length", 0.0762), ("1 lbf", "force", 4.4482216152605),
                           ("2 meter per second", "speed", 2.0), ("1 yard", "length", 0.9144),
                           ("5 degC", "ratio", None)):
        assert U._fast_to_si(text, kind) is None
        if si is not None:
            assert U.to_si(text, kind) == pytest.approx(si, rel=1e-12)


def test_unit_errors_stay_informative():
    """A wrong dimension names the unit given and the kind and unit expected (pint's path, as before);
    in a scenario, the key."""
    with pytest.raises(U.UnitError, match=r"'60 mm' has the wrong dimension \(mm\); expected a mass in kg"):
        U.to_si("60 mm", "mass")
    with pytest.raises(U.UnitError, match=r"'1 Hz' has the wrong dimension \(Hz\); expected a angle in rad"):
        U.to_si("1 Hz", "angle")
    with pytest.raises(U.UnitError, match="is not a number or a quantity with a unit"):
        U.to_si("60 blorts", "length")
    from mjbench import scenario as S
    from mjbench.errors import ScenarioError

    with pytest.raises(ScenarioError) as e:
        S.load("press-slidercrank", ['mechanism.input_angle="90 mm"', 'drive.L="6 kg"'])
    msg = str(e.value)
    assert "mechanism.input_angle: '90 mm' has the wrong dimension (mm); expected a angle in rad" in msg
    assert "drive.L: '6 kg' has the wrong dimension (kg); expected a inductance in H" in msg


def test_loading_the_shipped_scenarios_does_not_import_pint(tmp_path):
    """Every built-in scenario (their unit strings), an override with a unit and a plausibility
    warning with its suggested unit: without pint."""
    code = ("import json, sys\n"
            "from mjbench import scenario as S\n"
            "names = list(S.shipped_names())\n"
            "for n in names:\n"
            "    S.load(n)\n"
            "w = S.load('incerti2012', ['mechanism.a=100', 'drive.J_m=\"13 kg*cm^2\"']).warnings\n"
            "print(json.dumps({'pint': 'pint' in sys.modules, 'n': len(names), 'w': w}))\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                       env={**os.environ, "MUJOCO_GL": "egl"})
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout.strip().splitlines()[-1])
    assert out["n"] >= 10 and not out["pint"], out
    assert any("did you mean 100 mm?" in w for w in out["w"]), out["w"]


def test_thermal_resistance_of_a_catalogue(reg):
    for text in ("8.0 K/W", "1.5 K/W", "2 kelvin/watt", "4 K/kW"):
        fast = U.fast_convert(text, "kelvin/watt")
        assert fast is not None and _bits(fast) == _bits(float(reg.Quantity(text).to("kelvin/watt").magnitude))
    assert U.fast_convert("8 K/m", "kelvin/watt") is None
    assert math.isclose(U.fast_convert("8 K/W", "kelvin/watt"), 8.0)
