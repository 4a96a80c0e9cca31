"""`mjbench analyze`: every mechanism type, numbers against independent closed forms, outputs."""
import json
import math

import numpy as np
import pytest

from mjbench import analyze as A
from mjbench import scenario as S
from mjbench.cli import main


def test_fourbar_transmission_angle_and_toggles_against_closed_form():
    """Seed 000: transmission angle = |γ − β| folded (FourBar.transmission_angle); the crank-coupler
    toggles are where the rocker stops (its velocity ratio R = 0, Appendix B)."""
    scn = S.load("incerti2012")
    fb = S.make_mechanism(scn)
    res = A.analyze(scn, n=720)
    q = np.asarray(res["curves"]["q"])
    mu = np.asarray(res["curves"]["mu:C (coupler on rocker)"])
    assert np.max(np.abs(mu - fb.transmission_angle(q))) < 1e-9
    assert np.max(np.abs(np.asarray(res["curves"]["ratio:D"]) - fb.ratios(q)[3])) < 1e-9
    tg = sorted(t["q"] for t in res["toggles"]["B"])
    assert len(tg) == 2
    for t in tg:
        assert abs(fb.ratios(t)[3]) < 1e-9  # rocker at rest (grid root refined by secant steps)
    assert {f["kind"] for f in res["flags"]} >= {"toggle", "poor_transmission", "limit_position"}


def test_quickreturn_design_figures_against_closed_form():
    scn = S.load("yigit2023")
    qr = S.make_mechanism(scn)
    res = A.analyze(scn, n=720)
    assert res["transmission_angles_deg"]["C (rod on slider)"]["min"] == pytest.approx(
        math.degrees(qr.min_transmission_angle()), abs=1e-3)
    assert res["strokes_m"]["slide"] == pytest.approx(qr.stroke, abs=1e-9)
    arcs = res["stroke_arcs_deg"]["slide"]
    assert arcs["decreasing"] / arcs["increasing"] == pytest.approx(qr.time_ratio, rel=1e-6)


def test_constant_speed_torque_balances_the_energy_per_turn():
    """At constant speed ∮(½J'ω² + E_p')dq = 0, so the mean input torque × 2π is the work of the
    loads and friction per turn: for the quick-return at 5 rad/s the 50 N cut over the stroke."""
    scn = S.load("yigit2023")
    qr = S.make_mechanism(scn)
    res = A.analyze(scn, speeds=[5.0], n=2880)
    row = res["speeds"][0]
    assert row["energy_per_rev_J"] == pytest.approx(50.0 * qr.stroke, rel=2e-3)  # 2880-point mean
    # motor side: T_m = T/z + λ·z·ω, I = T_m/k_m, V = R·I + L·dI/dt + k_m·z·ω
    d = scn.drive
    Tin = np.asarray(res["curves"]["T_in@5"])
    assert row["motor_torque_Nm"]["max"] == pytest.approx(Tin.max() / d.z + d.lam * d.z * 5.0, rel=1e-12)
    assert row["motor_line_torque_Nm"] == pytest.approx(d.k_m * (d.v_max - d.k_m * d.z * 5.0) / d.R, rel=1e-12)


def test_platform_is_not_applicable(tmp_path, capsys):
    assert main(["analyze", "incerti-belt", "--out", str(tmp_path)]) == 0
    assert "not applicable" in capsys.readouterr().out
    assert json.loads((tmp_path / "analysis.json").read_text())["applicable"] is False


def test_cli_outputs_and_speed_units(tmp_path, capsys):
    out = tmp_path / "a"
    assert main(["analyze", "press-slidercrank", "--speed", "60 rpm", "--speed", "3.0", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "stroke of guide: 80.10 mm" in text and "analysis took" in text
    res = json.loads((out / "analysis.json").read_text())
    assert [r["input_speed_rad_s"] for r in res["speeds"]] == pytest.approx([2 * math.pi, 3.0])
    assert res["timing"]["cpu_s"] > 0
    for f in ("reduced_model.png", "kinematics.png", "torque_speed.png"):
        assert (out / f).stat().st_size > 10000
    assert main(["analyze", "press-slidercrank", "--speed", "fast"]) == 2
    assert "--speed 'fast'" in capsys.readouterr().err
    assert main(["analyze", "press-slidercrank", "--speed", "-3"]) == 2


def test_output_folder_whole_or_refused(tmp_path, capsys):
    """analyze stages its folder like every command (docs/outputs.md): a non-empty --out is refused
    before computing (exit 2), --force replaces it whole."""
    out = tmp_path / "a"
    out.mkdir()
    (out / "old.txt").write_text("x")
    assert main(["analyze", "sixbar-watt2", "--points", "64", "--out", str(out)]) == 2
    assert "already holds" in capsys.readouterr().err and sorted(p.name for p in out.iterdir()) == ["old.txt"]
    assert main(["analyze", "sixbar-watt2", "--points", "64", "--out", str(out), "--force"]) == 0
    assert not (out / "old.txt").exists() and (out / "analysis.json").exists()


def test_kinematics_come_from_the_mechanism_class():
    """Each mechanism provides its kinematics (Mechanism.kinematics / linkage_view): the four-bar and
    the quick-return through their generic-linkage twin, a linkage its own, an MJCF model its joint
    rates — which says which rows it cannot give and why; a drive-train wrapper delegates."""
    from mjbench.drivetrain import Friction
    from mjbench.drivetrain.gear import DrivenMechanism

    fb = S.make_mechanism(S.load("incerti2012"))
    assert type(fb.linkage_view()).__name__ == "Linkage" and fb.linkage_view().linkage_view() is not None
    res = A.analyze(S.load("mjcf-fourbar"), n=180)
    assert res["kinematics_source"].startswith("MuJoCo model")
    assert set(res["kinematics_unavailable"]) == {"transmission_angles", "toggles"}
    assert "link lines" in res["kinematics_unavailable"]["transmission_angles"]
    assert res["velocity_ratios"] and not res["transmission_angles_deg"]
    assert "no transmission angles: an MJCF model has no link lines" in A.summary_text(res)
    lk = A.analyze(S.load("sixbar-watt2"), n=180)
    assert lk["kinematics_source"] == "own linkage kinematics" and lk["kinematics_unavailable"] == {}
    scn = S.load("incerti2012")
    wrapped = DrivenMechanism(fb, S.make_drive(scn), None, Friction(0.01))
    q = np.linspace(0.0, 2 * np.pi, 90, endpoint=False)
    a, b = fb.kinematics(q), wrapped.kinematics(q)
    np.testing.assert_array_equal(a["ratios"]["D"], b["ratios"]["D"])
    assert wrapped.render_view() == fb.render_view()
