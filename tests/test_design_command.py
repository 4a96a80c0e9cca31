"""`mjbench design` end to end: the shipped requirements files, the outputs (machine.toml accepted by
run / analyze / tune / render), infeasible designs (exit 1), bad input (exit 2), the paper-study
group and the old spellings.  The full command (tuning + multibody verification) runs on two
examples; the others through their cheap stages, one of them verified."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mjbench.cli import main
from mjbench.design import pipeline as DP
from mjbench.design.requirements import builtin_names, load as load_req
from mjbench.outputs import read_json

EXAMPLES = ("press", "rocker", "function", "motion", "seed000", "seed000-law", "cam")  # seed000-law: a motion
# law per cycle (tests/test_design_law.py runs it end to end); cam: tests/test_design_cam.py


def _checks_ok(res):
    assert res["checks"], "no checks"
    for c in res["checks"]:
        assert c["ok"], c
        if "current" in c["name"] or "torque" in c["name"]:
            assert c["tolerance"] == 0.02
    return {c["name"]: c for c in res["checks"]}


#: the multibody verification runs of the designs run in this module (captured, not re-run)
RUNS = {}


@pytest.fixture(scope="module")
def press(tmp_path_factory):
    out = tmp_path_factory.mktemp("press") / "d"
    orig = DP.measure

    def keep(tr, *a, **k):
        RUNS["press"] = tr
        return orig(tr, *a, **k)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(DP, "measure", keep)
        rc = main(["design", "press", "--out", str(out), "--quiet"])
    return rc, out, read_json(out / "design.json")


def test_shipped_requirement_files():
    assert set(builtin_names()) == set(EXAMPLES)
    kinds = {n: load_req(n).mechanism.type for n in EXAMPLES}
    assert kinds == {"press": "slider-crank", "rocker": "crank-rocker", "function": "function-generator",
                     "motion": "motion-generator", "seed000": "given", "seed000-law": "given", "cam": "cam"}
    assert load_req("seed000-law").duty.law is not None and load_req("seed000").duty.law is None


def test_press_end_to_end(press):
    rc, out, res = press
    assert rc == 0 and res["status"] == "ok" and res["failures"] == []
    assert sorted(os.listdir(out)) == ["design.html", "design.json", "design.md", "design.png", "machine.toml"]
    ch = _checks_ok(res)
    assert ch["motor current RMS [A]"]["rel_diff"] != 0.0  # a real comparison, not a copy
    # requirements vs achieved: the kinematics measured by mjbench analyze (own solver), the drive by the run
    rows = {r["name"]: r for r in res["requirements_table"]}
    assert rows["stroke"]["achieved"] == pytest.approx(100.0, abs=1e-4)
    assert rows["time ratio (slow / return stroke)"]["achieved"] == pytest.approx(1.2, rel=1e-3)
    assert rows["minimum transmission angle"]["achieved"] >= 45.0
    assert rows["speed fluctuation χ"]["achieved"] <= 0.05
    assert all(r["ok"] for r in res["requirements_table"])
    assert res["synthesis"]["solver_check"]["residual"] <= 1e-9
    # the sizing: a catalogue drive with a flywheel; the ratio study's closed form and brute force reported
    assert res["catalogue"]["illustrative"] and res["chosen"]["flywheel_kgm2"] > 0
    assert res["sizing"]["n_feasible"] >= 1 and res["sizing"]["ratio_sweep"]["z_closed_form"] > 0
    assert res["control"]["source"].startswith("tuned") and res["control"]["tune"]["evaluations"] > 1
    # the times are recorded; their cost is measured in scripts/bench_parts/design.py, not here (a timed
    # assertion fails on a loaded machine: 5.13 s against 5 s once, beside a `make demo`)
    t = res["timing"]
    assert 0 < t["synthesis_and_sizing_cpu_s"] <= t["total_cpu_s"]
    md = (out / "design.md").read_text()
    assert "Requirements vs achieved" in md and "illustrative values" in md and "✘" not in md
    html = (out / "design.html").read_text()
    assert "<table>" in html and "design.png" in html


def mechanism_torque(mech, t, q, qd, qdd, J_b=0.0):
    """The torque the mechanism (and a crank-shaft inertia J_b) needs along a recorded motion, by its
    own inverse dynamics — no drive model involved: (J + J_b)q̈ + ½J'q̇² + E_p' − Q_ext; and Q_ext."""
    J, dJ, dEp = (np.asarray(x, float) * np.ones_like(q) for x in mech.reduced(q))
    Q = np.asarray(mech.external_torque(q, qd, t), float) * np.ones_like(q)
    return (J + J_b) * qdd + 0.5 * dJ * qd * qd + dEp - Q, Q


def test_press_gearbox_torque_is_what_the_mechanism_receives(press):
    """Issue 35: design.json's gearbox output torque (prediction and verification) against the torque
    the multibody run's mechanism receives (its own inverse dynamics on the recorded motion) and
    against the energy per cycle (the forming load's work and the joints' friction).  The old report
    (η applied to the rotor's inertia and friction) gave 84.2 N·m peak against 93.7 and 34.5 J per
    cycle against 35.3."""
    from mjbench import scenario as S

    _, out, res = press
    tr = RUNS["press"]
    mach = S.make_machine(S.load(out / "machine.toml"))
    a, b = res["verification"]["achieved"]["cycle_s"]
    sel = (tr.t >= a - 1e-12) & (tr.t <= b + 1e-12)
    t, qd = tr.t[sel], tr.qd[sel]
    T, Q = mechanism_torque(mach.mechanism, t, tr.q[sel], qd, tr.qdd[sel], mach.drive.J_b)
    rms = float(np.sqrt(np.trapezoid(T ** 2, t) / (t[-1] - t[0])))
    peak = float(np.max(np.abs(T)))
    for fig in ("prediction", "achieved"):
        doc = res["prediction"] if fig == "prediction" else res["verification"]["achieved"]
        assert doc["gear_torque_rms_Nm"] == pytest.approx(rms, rel=0.005), fig  # measured 2e-4 (was −7.9 %)
        assert doc["gear_torque_peak_Nm"] == pytest.approx(peak, rel=0.005), fig  # measured 4e-4 (was −10 %)
    loads = -float(np.trapezoid(Q * qd, t))  # work of the forming load and the joints' friction per cycle [J]
    assert loads > 30.0
    assert res["prediction"]["gear_work_per_cycle_J"] == pytest.approx(loads, rel=0.003)  # measured 2e-4 (was −2.1 %)
    assert res["verification"]["achieved"]["gear_work_per_cycle_J"] == pytest.approx(loads, rel=0.003)
    rows = {r["name"]: r for r in res["requirements_table"]}  # the ratings are checked against these figures
    assert rows["gearbox output torque peak ≤ T_peak_out"]["achieved"] == res["verification"]["achieved"][
        "gear_torque_peak_Nm"]


def test_press_machine_toml_runs_unchanged(press, tmp_path):
    _, out, res = press
    toml = str(out / "machine.toml")
    assert main(["run", toml, "--backend", "reduced", "--t-end", "0.3", "--no-figure", "--quiet",
                 "--out", str(tmp_path / "run")]) == 0
    assert main(["analyze", toml, "--out", str(tmp_path / "an")]) == 0
    an = read_json(tmp_path / "an" / "analysis.json")
    assert an["strokes_m"]["guide"] == pytest.approx(0.1, rel=1e-6)
    assert main(["tune", toml, "--controller", "pid", "--global", "2", "--maxfev", "1", "--verify", "0",
                 "--t-end", "0.5", "--objective", "ise", "--out", str(tmp_path / "tune")]) == 0
    env = {**os.environ, "MUJOCO_GL": "egl"}
    r = subprocess.run([os.path.join(os.path.dirname(sys.executable), "mjbench"), "render", toml, "--out",
                        str(tmp_path / "v.mp4"), "--t-end", "0.1", "--width", "160", "--height", "96", "--no-progress"],
                       capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "v.mp4").stat().st_size > 1000


def test_seed000_resized_end_to_end(tmp_path):
    """The seed-000 four-bar kept as it is (scenario incerti2012's [mechanism]), re-sized for 30 rad/s."""
    from mjbench import scenario as S

    res = DP.design("seed000", out=tmp_path / "d", log=lambda *a: None)
    assert res["status"] == "ok", res["failures"]
    assert res["mechanism"] == S.load("incerti2012").raw["mechanism"]
    _checks_ok(res)
    rows = {r["name"]: r for r in res["requirements_table"]}
    assert rows["mean input speed"]["achieved"] == pytest.approx(30.0, rel=1e-3)
    assert rows["speed fluctuation χ"]["achieved"] <= 0.03
    assert res["timing"]["synthesis_and_sizing_cpu_s"] > 0  # (recorded; its cost is measured in scripts, not here)


@pytest.mark.parametrize("name", ["rocker", "function", "motion"])
def test_examples_synthesis_and_sizing(name):
    """The other examples through synthesis and sizing (no tuning, no simulation)."""
    res = DP.design(name, verify=False, tune=False, log=lambda *a: None)
    assert res["status"] == "ok", res["failures"]
    assert all(c["ok"] for c in res["synthesis"]["constraints"])
    assert res["synthesis"]["solver_check"]["residual"] <= 1e-9
    assert res["synthesis"]["solver_check"]["branch_max_position_diff_m"] <= 1e-9
    assert res["chosen"]["ok"] and res["sizing"]["n_feasible"] >= 1
    assert res["timing"]["synthesis_and_sizing_cpu_s"] > 0  # (recorded; its cost is measured in scripts, not here)
    rows = {r["name"]: r for r in res["requirements_table"]}
    if name == "rocker":
        assert rows["rocker swing"]["achieved"] == pytest.approx(60.0, abs=1e-3)
        assert rows["time ratio (slow / fast swing)"]["achieved"] == pytest.approx(1.25, rel=1e-3)
    if name == "function":
        assert rows["precision points met (solver)"]["achieved"] <= 1e-9
        err = rows["structural error (max |ψ − ψ_desired|)"]
        assert err["required"] == pytest.approx(1.5) and 0 < err["achieved"] <= 1.5 and err["ok"]
    if name == "motion":
        assert rows["poses met, position (solver)"]["achieved"] <= 1e-9


def test_motion_example_verified_on_the_multibody_backend():
    res = DP.design("motion", tune=False, log=lambda *a: None)
    assert res["status"] == "ok", res["failures"]
    _checks_ok(res)
    assert res["control"]["source"].startswith("design rule")


def _variant(tmp_path, name, edits):
    """A shipped requirements file with some values changed, written to tmp_path."""
    from mjbench.design.build import toml_dumps
    from mjbench.design.requirements import read

    raw, _ = read(name)
    for table, key, value in edits:
        raw.setdefault(table, {})[key] = value
    p = tmp_path / f"{name}.toml"
    p.write_text(toml_dumps(raw))
    return p


def test_infeasible_drive_exits_1_with_the_closest_candidate(tmp_path, capsys):
    p = _variant(tmp_path, "press", [("drive", "supply_voltage", "12 V")])
    out = tmp_path / "o"
    assert main(["design", str(p), "--out", str(out)]) == 1
    text = capsys.readouterr().out
    assert "INFEASIBLE" in text and "closest candidate" in text and "FAILS (sizing)" in text
    res = read_json(out / "design.json")
    assert res["status"] == "infeasible" and res["closest"]["motor"] and res["failures"]
    assert all(f["stage"] == "sizing" for f in res["failures"])
    assert not (out / "machine.toml").exists()  # never a silent best effort
    assert "INFEASIBLE" in (out / "design.md").read_text()


def test_infeasible_synthesis_exits_1_naming_the_constraint(tmp_path, capsys):
    p = _variant(tmp_path, "press", [("mechanism", "min_transmission", "60 deg")])
    assert main(["design", str(p)]) == 1
    text = capsys.readouterr().out
    assert "FAILS (synthesis): minimum transmission angle: 47.201°, below the required 60° by 21.3 %" in text


def test_bad_requirements_are_one_message_exit_2(tmp_path, capsys):
    (tmp_path / "bad.toml").write_text(
        '[design]\nname = "bad"\n[mechanism]\ntype = "crank-rocker"\nswing = "200 deg"\ntime_ratio = 1.2\n'
        '[[loads]]\npoint = "ram.C"\ndirection = [0, 1]\nforce = "1 kN"\n[duty]\nspeed = "60 V"\n'
        '[drive]\nsupply_voltage = "48 V"\ncatalogue = "none.csv"\n[control]\nmargins = ["pm>45"]\n')
    out = tmp_path / "o"
    assert main(["design", str(tmp_path / "bad.toml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mjbench: error: requirements 'bad'")
    for part in ("mechanism.swing", "loads[0].point", "duty.speed", "control.margins", "drive.catalogue"):
        assert part in err, err
    assert not out.exists()
    assert main(["design", "no-such-requirements"]) == 2
    assert "built-in requirements file" in capsys.readouterr().err


def test_design_examples_report_rows(press):
    """The `make demo` report entry of a design (mjbench/papers/design_examples.py): rows with
    verdicts computed from the numbers."""
    from pathlib import Path

    from mjbench import papers
    from mjbench.reproduce import CaseRun, _normalise_row

    mod = papers.module("design")
    assert {c.scenario for c in mod.CASES} == set(EXAMPLES) and all(c.kind == "design" for c in mod.CASES)
    _, out, res = press
    ctx = CaseRun(mod.CASES[0], None, Path(out).parent, extra={"design": res})
    rows = [_normalise_row(r) for r in mod.rows(ctx)]
    assert rows and all(r["verdict"]["ok"] for r in rows if r["verdict"]["ok"] is not None)
    assert any(r["name"].startswith("prediction: motor current RMS") for r in rows)


def test_paper_group_and_old_spellings(tmp_path, capsys):
    assert main(["paper", "yigit2023", "design", "--starts", "1", "--backend", "none"]) == 0
    out = capsys.readouterr()
    assert "Table I" in out.out and "note" not in out.err
    assert main(["design", "quickreturn", "--starts", "1", "--backend", "none", "--out", str(tmp_path / "q")]) == 0
    err = capsys.readouterr().err
    assert "`mjbench paper yigit2023 design`" in err and err.count("\n") == 1
    assert (tmp_path / "q" / "design.json").is_file()
    assert main(["paper", "hulako2025", "demand", "--json"]) in (0, 1)
    out = capsys.readouterr()
    json.loads(out.out)
    assert "note" not in out.err
    assert main(["demand", "hulako2025-model1", "--json"]) in (0, 1)
    assert "`mjbench paper hulako2025 demand`" in capsys.readouterr().err
    # a paper-study option on the general command is refused, not ignored
    assert main(["design", "press", "--starts", "2"]) == 2
    assert "paper yigit2023 design" in capsys.readouterr().err
    # calibrate under the group: its scenario defaults to the paper's
    from mjbench.cli import build_parser

    args = build_parser(["paper", "incerti2012", "calibrate"]).parse_args(["paper", "incerti2012", "calibrate"])
    assert args.scenario == "incerti2012" and args.paper_study and args.func.__name__ == "cmd_calibrate"
    args = build_parser(["calibrate"]).parse_args(["calibrate", "incerti2012"])
    assert args.paper_study is False
