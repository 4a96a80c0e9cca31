"""The scenario schema: a user's mistakes become ONE error naming every problem, units convert,
implausible values warn, and a run's manifest repeats the run byte for byte."""
import math
import tomllib

import pytest

from mjbench import scenario as S
from mjbench.cli import main
from mjbench.errors import ScenarioError


def _raw(name="incerti2012"):
    raw, _ = S.read_raw(name)
    return raw


def _problems(raw, overrides=()):
    with pytest.raises(ScenarioError) as e:
        S.from_raw(raw, "test", overrides)
    return e.value.problems, str(e.value)


def test_misspelt_and_missing_tables():
    raw = _raw()
    raw["drvie"] = raw.pop("drive")
    probs, msg = _problems(raw)
    assert "drive: required table is missing ([drive] with R, L, k_m, J_m, z, lam ...)" in probs
    assert any(p.startswith("drvie: unknown table; allowed here:") and "drive" in p for p in probs)
    assert msg.startswith("scenario 'incerti2012' (test) has 2 problems:")


def test_missing_value_unknown_key_wrong_type_all_in_one_error():
    raw = _raw()
    del raw["mechanism"]["m2"]
    raw["simulation"]["dtt"] = 1e-4
    raw["drive"]["R"] = "1.5"
    raw["modes"]["pid"]["kpp"] = 40
    raw["drive"]["L"] = "9 m"  # wrong dimension
    probs, _ = _problems(raw)
    assert "mechanism.m2: required value is missing (coupler mass [kg])" in probs
    assert any(p.startswith("simulation.dtt: unknown key; allowed here: backend, dt, mode, record_dt, record_joints, t_end")
               for p in probs)
    assert any(p.startswith("drive.R: '1.5' is a number written as a string") for p in probs)
    assert any(p.startswith("modes.pid.kpp: unknown key; allowed here:") and "kp" in p for p in probs)
    assert any(p.startswith("drive.L: '9 m' has the wrong dimension (m); expected a inductance in H") for p in probs)
    assert len(probs) == 5


def test_non_physical_values_name_the_range():
    probs, _ = _problems(_raw(), ["drive.R=-1"])
    assert probs == ["drive.R: must be > 0 Ω, got -1"]
    probs, _ = _problems(_raw(), ["modes.pid.kp=nan"])
    assert probs == ["modes.pid.kp: must be a number, got nan"]
    probs, _ = _problems(_raw(), ["drive.R=abc"])
    assert probs[0].startswith("drive.R: 'abc' is not a number or a quantity with a unit")
    probs, _ = _problems(_raw(), ["metrics.chi_window=[0.5, 0.4]"])
    assert "need t0 < t1" in probs[0]
    probs, _ = _problems(_raw(), ["simulation.mode=smc"])
    assert probs[0].startswith("simulation.mode: 'smc' is not one of the [modes.*] tables")


def test_units_convert_to_si():
    raw = _raw()
    m, d = raw["mechanism"], raw["drive"]
    m.update(a="100 mm", b="30 cm", h_y="50 mm", theta2="0 deg", m2="2270 g")
    d.update(J_m="13 kg*cm^2", L="9 mH", k_m="0.48 V*s/rad")
    raw["modes"]["pid"]["omega0"] = "286.4789 rpm"
    scn = S.from_raw(raw, "test")
    ref = S.load("incerti2012")
    assert (scn.mechanism.a, scn.mechanism.b, scn.mechanism.h_y, scn.mechanism.m2) == pytest.approx((0.1, 0.3, 0.05, 2.27))
    assert (scn.drive.J_m, scn.drive.L, scn.drive.k_m) == pytest.approx((1.3e-3, 9e-3, 0.48))
    assert scn.modes["pid"].omega0 == pytest.approx(30.0, rel=1e-6)
    # the same machine as the SI file
    assert S.make_mechanism(scn).reduced(0.3) == pytest.approx(S.make_mechanism(ref).reduced(0.3), rel=1e-12)
    assert S.load("incerti2012", ['drive.L="9 mH"']).drive.L == pytest.approx(9e-3)


def test_millimetres_as_bare_numbers_warn():
    raw = _raw()
    for k in ("a", "b", "c", "h_x", "h_y", "f1", "f2", "f3"):
        raw["mechanism"][k] = raw["mechanism"][k] * 1000.0
    scn = S.from_raw(raw, "test")
    w = "\n".join(scn.warnings)
    assert "mechanism.a = 100 m is outside the plausible range" in w
    assert "did you mean 100 mm?" in w and "mechanism.c = 300 m" in w


def test_defaults_are_documented_and_visible():
    scn = S.load("incerti2012")
    r = scn.resolved()
    assert r["drive"]["i_max"] == "inf" and r["drive"]["T_0"] == 0.0
    assert r["initial"] == {"q0": 0.0, "qd0": 0.0, "I0": 0.0}
    assert r["multibody"]["integrator"] == "RK4" and r["reduced"]["method"] == "rk4"
    # the resolved scenario validates again to the same values
    again = S.from_raw(r, "resolved")
    assert again.resolved() == r


def test_cli_exit_2_and_one_message(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    text = S.read_raw("incerti2012")[0]
    text["drive"]["R"] = -1.0
    del text["mechanism"]["m2"]
    bad.write_text(_dump(text))
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "has 2 problems" in err and "drive.R: must be > 0 Ω, got -1" in err and "mechanism.m2" in err
    assert "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_manifest_repeats_the_run_byte_for_byte(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["run", "yigit2023", "--mode", "smc", "--t-end", "0.2", "--set", "drive.L=\"50 mH\"",
                 "--out", str(a), "--quiet", "--no-figure"]) == 0
    assert main(["run", str(a / "manifest.json"), "--out", str(b), "--quiet", "--no-figure"]) == 0
    for f in ("trajectory_multibody.csv", "trajectory_reduced.csv"):
        assert (a / f).read_bytes() == (b / f).read_bytes(), f


def _dump(raw):
    """TOML text of a nested dict of tables, scalars and arrays (enough for scenarios)."""
    lines = []

    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace('"', '\\"') + '"'
        if isinstance(v, float) and math.isinf(v):
            return "inf" if v > 0 else "-inf"
        if isinstance(v, list):
            if v and isinstance(v[0], dict):
                return None
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)

    def table(prefix, d):
        if prefix:
            lines.append(f"[{prefix}]")
        for k, v in d.items():
            if not isinstance(v, dict) and val(v) is not None:
                lines.append(f"{k} = {val(v)}")
        for k, v in d.items():
            if isinstance(v, dict):
                table(f"{prefix}.{k}" if prefix else k, v)
            elif isinstance(v, list) and v and isinstance(v[0], dict):
                for item in v:
                    lines.append(f"[[{prefix + '.' if prefix else ''}{k}]]")
                    for kk, vv in item.items():
                        lines.append(f"{kk} = {val(vv)}")

    table("", raw)
    text = "\n".join(lines) + "\n"
    tomllib.loads(text)
    return text
