"""The Python API (mjbench/api/, docs/api.md): the acceptance script of issue 27, the CLI's files
equal to the API's, a machine built in code equal to its scenario, typed errors, lazy imports,
and the type check of the public surface (mypy)."""
import json
import os
import pkgutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import mjbench as mjb
from mjbench.cli import main

ROOT = Path(__file__).resolve().parents[1]

#: issue 27's acceptance script, verbatim
ACCEPTANCE = '''\
import mjbench as mjb
scn = mjb.load("incerti2012", **{"drive.R": "2.2 ohm"})
res = scn.simulate(mode="pid", backend="both", t_end=0.5)
df = res.to_pandas()                       # one row per recorded sample, SI column names
print(res.metrics["backends"]["multibody"]["mean_crank_speed_rad_s"])
res.save("out_api")                        # the files `mjbench run` writes
'''

#: fields that differ between two runs of the same thing: when and how it was started, CPU/wall time
VOLATILE = {"created_utc", "command", "timing", "seconds", "seconds_search"}


@pytest.fixture(autouse=True)
def _cpython_loop(monkeypatch):
    """The CPython loop for every run here (the loop a run chose is written in metrics.json and the
    manifest: fixed, so that CLI and API runs of one test are compared whatever ran before)."""
    monkeypatch.setenv("MJBENCH_JIT", "0")


def _strip(doc):
    if isinstance(doc, dict):
        return {k: _strip(v) for k, v in doc.items() if k not in VOLATILE}
    if isinstance(doc, list):
        return [_strip(v) for v in doc]
    return doc


def assert_same_folder(a: Path, b: Path, binary=(".png",)):
    """Every file of two output folders equal: JSON content (volatile fields removed), CSV and the
    other files byte for byte; the same file names."""
    names = sorted(p.relative_to(a).as_posix() for p in a.rglob("*") if p.is_file())
    assert names == sorted(p.relative_to(b).as_posix() for p in b.rglob("*") if p.is_file())
    assert names
    for n in names:
        fa, fb = a / n, b / n
        if n.endswith(".json"):
            assert _strip(json.loads(fa.read_text())) == _strip(json.loads(fb.read_text())), n
        elif n.endswith(binary) or n.endswith(".csv"):
            assert fa.read_bytes() == fb.read_bytes(), n


# ============================================================================ acceptance
def test_acceptance_script_and_the_cli_writes_the_same_files(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(ACCEPTANCE, "acceptance.py", "exec"), {"__name__": "__main__"})
    printed = capsys.readouterr().out.strip()
    assert 20 < float(printed) < 40  # rad/s: the crank turns near the 30 rad/s set-point (PID K_p·t)
    assert main(["run", "incerti2012", "--mode", "pid", "--backend", "both", "--t-end", "0.5", "--set",
                 "drive.R=2.2 ohm", "--quiet", "--out", "out_cli"]) == 0
    assert_same_folder(tmp_path / "out_api", tmp_path / "out_cli")
    man = json.loads((tmp_path / "out_api" / "manifest.json").read_text())
    assert man["scenario"]["drive"]["R"] == pytest.approx(2.2) and man["overrides"] == ["drive.R=2.2 ohm"]
    assert sorted(os.listdir(tmp_path / "out_api")) == ["fig4.png", "manifest.json", "metrics.json",
                                                        "trajectory_multibody.csv", "trajectory_reduced.csv"]


def test_result_arrays_frames_and_plot(tmp_path):
    res = mjb.load("incerti2012").simulate("open", "both", "50 ms")
    mb, red = res["multibody"], res["reduced"]
    n = len(mb)
    assert n == 101 and mb.time.shape == (n,) and mb.time[-1] == pytest.approx(0.05)  # record_dt 0.5 ms
    assert mb.outputs.shape == (len(mb.columns) - 1, n) and mb.output_labels[0] == "crank_angle_rad"
    assert np.array_equal(res.column("voltage_V"), np.full(n, 25.0)) and res.time is not None
    df = res.to_pandas()
    assert list(df.columns[:3]) == ["backend", "t_s", "crank_angle_rad"] and len(df) == 2 * n
    assert np.array_equal(df[df.backend == "reduced"]["crank_speed_rad_s"].to_numpy(), red["crank_speed_rad_s"])
    assert list(red.to_pandas().columns) == list(red.columns)
    assert res.metrics["backends"]["reduced"] == red.metrics and res.warnings == []
    assert "multibody vs reduced crank speed" in res.summary()
    fig = res.plot(["crank_speed_rad_s", "current_A"])
    assert len(fig.axes) == 2 and len(fig.axes[0].lines) == 2
    import matplotlib.pyplot as plt

    plt.close(fig)
    with pytest.raises(KeyError, match="columns"):
        mb["crank_sped"]
    with pytest.raises(mjb.ParameterError, match="not a column"):
        res.plot("nope")


def test_to_pandas_without_pandas_says_how_to_install(monkeypatch):
    res = mjb.load("incerti2012").simulate("open", "reduced", 0.01)
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match="pip install pandas"):
        res.to_pandas()


def test_save_is_the_run_folder_and_refuses_a_full_one(tmp_path):
    scn = mjb.load("incerti2012", **{"modes.open.voltage": 20})
    res = mjb.simulate(scn, "open", "reduced", t_end=0.2)
    res.save(tmp_path / "api", figure=False)
    assert main(["run", "incerti2012", "--mode", "open", "--backend", "reduced", "--t-end", "0.2", "--set",
                 "modes.open.voltage=20", "--no-figure", "--quiet", "--out", str(tmp_path / "cli")]) == 0
    assert_same_folder(tmp_path / "api", tmp_path / "cli")
    with pytest.raises(mjb.OutputError, match="already holds"):
        res.save(tmp_path / "api")
    res.save(tmp_path / "api", force=True, figure=False)
    # a run's manifest repeats that run (mode, backend, t_end) from the API as from the CLI
    again = mjb.load(tmp_path / "api" / "manifest.json").simulate()
    assert again.mode == "open" and again.backends == ("reduced",)
    assert np.array_equal(again["reduced"].data, res["reduced"].data)


# ============================================================================ a machine in code
def test_machine_in_code_equals_its_scenario(tmp_path):
    """Mechanism, drive and controller built from keyword arguments give the bits of the TOML run."""
    mech = mjb.make_mechanism("fourbar", a=0.1, b=0.3, c=0.3, h_x=0.3, h_y=0.05, f1=0.05, f2=0.15, f3=0.15,
                              m1=0.42, m2=2.27, m3=2.27, J_G1=3.5e-4, J_G2=1.7e-2, J_G3=1.7e-2, k=1)
    drive = mjb.make_drive(R=2.0, L=9e-3, k_m=0.48, J_m=13e-4, J_a=9.8e-5, J_b=9.8e-5, z=1, lam=0.08, v_max=48)
    ctrl = mjb.make_controller("pid", drive=drive, mechanism=mech, kp=80, ki=32, kd=0.015, omega0=30,
                               kp_ramp=True, v_limit=48)
    res = mjb.simulate(mjb.Machine(mech, drive, ctrl), backend="both", t_end=0.05, record_dt=5e-4)
    ref = mjb.load("incerti2012").simulate("pid", "both", 0.05)
    for b in ("multibody", "reduced"):
        assert np.array_equal(res[b].data, ref[b].data), b
    assert res.mode is None and res.metrics["multibody_vs_reduced"]["max_rel_diff"] < 1e-3
    # its summary names what it is made of, not a scenario and a mode it does not have
    first = res.summary().splitlines()[0]
    assert first == ("machine built in code: fourbar mechanism, DC motor (z = 1, v_max 48 V), pid controller "
                     "(multibody, reduced, 0.05 s)")
    assert "mode None" not in res.summary() and "pid controller" in repr(res)
    assert ref.summary().startswith("scenario incerti2012, mode pid")
    res.save(tmp_path / "machine")  # no scenario, no manifest: the trajectories and metrics
    assert sorted(os.listdir(tmp_path / "machine")) == ["metrics.json", "trajectory_multibody.csv",
                                                        "trajectory_reduced.csv"]
    # units are converted like a scenario's values
    assert mjb.make_drive(R="2 ohm", L="9 mH", k_m=0.48, J_m="13 kg*cm^2", z=1, lam=0.08).L == pytest.approx(9e-3)
    assert mech.a == pytest.approx(mjb.make_mechanism("fourbar", **{**_fourbar(), "a": "100 mm"}).a)


def _fourbar():
    return dict(a=0.1, b=0.3, c=0.3, h_x=0.3, h_y=0.05, f1=0.05, f2=0.15, f3=0.15, m1=0.42, m2=2.27, m3=2.27,
                J_G1=3.5e-4, J_G2=1.7e-2, J_G3=1.7e-2, k=1)


def test_simulate_many_equals_single_runs():
    scns = [mjb.load("incerti2012", **{"drive.R": r}) for r in (1.8, 2.2)]
    many = mjb.simulate_many(scns, backend="both", t_end=0.03)
    for s, m in zip(scns, many):
        one = s.simulate(backend="both", t_end=0.03)
        for b in ("multibody", "reduced"):
            assert np.array_equal(m[b].data, one[b].data), b
        assert m.metrics["backends"]["reduced"]["peak_current_A"] == one.metrics["backends"]["reduced"]["peak_current_A"]
    drive = mjb.make_drive(R=2.0, L=9e-3, k_m=0.48, J_m=13e-4, z=1, lam=0.08)
    mech = mjb.make_mechanism("fourbar", **_fourbar())
    machines = [mjb.Machine(mech, drive, mjb.make_controller("open", voltage=v)) for v in (10.0, 20.0)]
    runs = mjb.simulate_many(machines, backend="reduced", t_end=0.03)
    assert [r["reduced"]["voltage_V"][-1] for r in runs] == [10.0, 20.0]
    with pytest.raises(mjb.ParameterError, match="t_end"):
        mjb.simulate_many(machines)


# ============================================================================ errors, warnings
def test_errors_are_typed_never_systemexit(tmp_path):
    with pytest.raises(mjb.ScenarioError) as e:
        mjb.load("incerti2012", **{"drive.R": -1, "drive.L": "9 kg"})
    assert len(e.value.problems) == 2 and "drive.R" in str(e.value)
    with pytest.raises(mjb.ScenarioError, match="unknown scenario"):
        mjb.load("no-such-scenario")
    with pytest.raises(mjb.ScenarioError, match="mode 'nope'"):
        mjb.load("incerti2012").simulate(mode="nope")
    with pytest.raises(mjb.ParameterError, match="choose multibody, reduced or both"):
        mjb.simulate("incerti2012", backend="mujoco")
    with pytest.raises(mjb.ParameterError, match="t_end"):
        mjb.simulate("incerti2012", t_end="-1 s")
    with pytest.raises(mjb.GeometryError, match="full turn"):
        mjb.load("incerti2012", **{"mechanism.a": 0.5}).simulate(t_end=0.01)
    with pytest.raises(mjb.SimulationDiverged, match="diverged at t = "):
        mjb.load("incerti2012", ["drive.v_max=inf", "modes.pid.v_limit=none", "modes.pid.kp=1e6"]).simulate(
            "pid", "reduced", 0.2)
    with pytest.raises(mjb.ScenarioError, match="drive"):
        mjb.make_drive(R=2.0)
    with pytest.raises(mjb.ParameterError, match="not a value"):
        mjb.load("incerti2012", **{"drive.R": object()})
    assert issubclass(mjb.OutputError, mjb.MjbenchError)


def test_values_and_overrides_read_back_like_set(tmp_path):
    scn = mjb.load("incerti2012", ["modes.pid.kp=100"], **{"drive.L": "9 mH", "modes.pid.v_limit": 40,
                                                          "metrics.chi_window": [0.1, 0.2]})
    assert scn.overrides == ["modes.pid.kp=100", "drive.L=9 mH", "modes.pid.v_limit=40",
                             "metrics.chi_window=[0.1, 0.2]"]
    assert scn.get("drive.L") == pytest.approx(9e-3) and scn.get("modes.pid.kp") == 100
    derived = scn.with_values(**{"drive.R": 2.5})
    assert derived.overrides[-1] == "drive.R=2.5" and derived.get("modes.pid.kp") == 100
    from_dict = mjb.load(mjb.load("incerti2012").spec.raw)
    assert from_dict.name == "incerti2012" and from_dict.source == ""
    with pytest.warns(mjb.MjbenchWarning, match="did you mean"):
        mjb.load("incerti2012", **{"mechanism.a": 100})
    coarse = mjb.load("incerti2012", **{"simulation.dt": "10 ms", "simulation.record_dt": "10 ms"})
    with pytest.warns(mjb.MjbenchWarning, match="simulation.dt"):
        res = coarse.simulate("open", "reduced", 0.3)
    assert res.warnings and res.metrics["plausibility"]["step"]["reduced"]["step_ok"] is False


# ============================================================================ studies: CLI = API
def test_sweep_cli_equals_api(tmp_path):
    args = ["--grid", "drive.R=1.8,2.2", "--t-end", "0.05", "--verify", "1", "--metric", "peak_current_A"]
    assert main(["sweep", "incerti2012", *args, "--quiet", "--out", str(tmp_path / "cli")]) == 0
    res = mjb.parameter_sweep("incerti2012", {"drive.R": [1.8, 2.2]}, t_end=0.05, verify=1, metric="peak_current_A",
                              out=tmp_path / "api")
    assert_same_folder(tmp_path / "cli", tmp_path / "api")
    assert [r["status"] for r in res.rows] == ["ok", "ok"] and res.verified[0]["metric"] == "peak_current_A"
    mem = mjb.load("incerti2012").sweep({"drive.R": ["1.8 ohm", "2.2 ohm"]}, t_end=0.05, verify=0)
    assert mem.out is None and list(mem.to_pandas()["peak_current_A"]) == [r["peak_current_A"] for r in res.rows]
    with pytest.raises(mjb.ParameterError, match="repeated"):
        mjb.parameter_sweep("incerti2012", {"drive.R": [2, 2.0]})


def test_tune_cli_equals_api(tmp_path, capsys):
    opts = dict(n_global=4, maxfev=3, t_end=0.1, verify=1)
    assert main(["tune", "incerti2012", "--controller", "pid", "--objective", "ise", "--global", "4", "--maxfev",
                 "3", "--t-end", "0.1", "--verify", "1", "--out", str(tmp_path / "cli")]) == 0
    res = mjb.tune_gains("incerti2012", "pid", "ise", **opts)
    res.save(tmp_path / "api")
    assert_same_folder(tmp_path / "cli", tmp_path / "api")
    report = res.report().split("\n", 1)[1]  # (the first line gives the seconds it took)
    assert set(res.best) == {"kp", "ki", "kd"} and res.feasible and report in capsys.readouterr().out
    with pytest.raises(mjb.ParameterError, match="not a gain"):
        mjb.tune_gains("incerti2012", "pid", bounds={"kq": (1, 2)})


def test_linearize_cli_equals_api_and_gives_python_control_objects(tmp_path):
    import control

    assert main(["linearize", "incerti2012", "--mode", "pid", "--angles", "2", "--no-multibody", "--at", "q=0.5",
                 "--out", str(tmp_path / "cli")]) == 0
    res = mjb.linearize("incerti2012", "pid", q=0.5, angles=2, multibody=False)
    res.save(tmp_path / "api")
    assert_same_folder(tmp_path / "cli", tmp_path / "api", binary=())
    assert isinstance(res.plant, control.StateSpace) and isinstance(res.loop.L, control.StateSpace)
    assert res.controller is res.loop.controller and res.margins.stable and res.operating_point.q == 0.5
    assert res.plant_multibody is None and "loop: GM" in res.summary()


def test_linear_result_has_a_typed_frozen_angle_family():
    import control

    lin = mjb.linearize("incerti2012", "pid", t=0.5, angles=4, multibody=False)
    fam = lin.family
    assert isinstance(fam, mjb.FrozenAngleFamily) and len(fam) == 4 and fam is lin.family
    assert np.allclose(fam.angles, np.arange(4) * np.pi / 2) and np.allclose(fam.speeds, 30.0)
    assert all(isinstance(L, control.StateSpace) and L.dt == 1e-4 for L in fam.L)
    assert fam[1].L is fam.L[1] and [a for a, _ in fam] == list(fam.angles)
    fa = lin.data["frozen_angle"]  # the typed family is what linear.json holds
    assert list(fam.phase_margins_deg) == fa["phase_margin_deg"] and list(fam.gain_margins_dB) == fa["gain_margin_dB"]
    assert fam.worst == fa["worst"] and fam.validity["verdict"] == fa["validity"]["verdict"]
    assert fam.nearest(-0.1) == 0 and fam.nearest(3.2) == 2
    assert mjb.linearize("incerti2012", "pid", angles=0, multibody=False).family is None


def _hold_scenario():
    return mjb.load("incerti2012", **{"modes.pid.kp_ramp": False, "modes.pid.kp": 40.0, "modes.pid.omega0": 0.0,
                                      "modes.pid.v_limit": "none", "drive.v_max": float("inf")})


def test_hold_point_and_step_check():
    from scipy.optimize import brentq

    scn = _hold_scenario()
    mach = scn.machine()
    mech, d = mach.mechanism, mach.drive
    ki, z = scn.get("modes.pid.ki"), d.z
    hp = mjb.hold_point(scn)  # the reference angle 0: K_i·(0 − z·q) = R·E_p'(q)/(z·k_m)
    q_e = brentq(lambda q: -ki * z * q - d.R * mech.reduced(q)[2] / (z * d.k_m), -1.0, 1.0, xtol=1e-15)
    assert hp.q == pytest.approx(q_e, abs=1e-12) and hp.q_ref == 0.0 and hp.offset == pytest.approx(-q_e)
    assert hp.I == pytest.approx(mech.reduced(q_e)[2] / (z * d.k_m), rel=1e-12) and hp.V == pytest.approx(d.R * hp.I)
    run = mjb.simulate(hp.machine, backend="reduced", t_end=0.2)  # the machine started there stays there
    assert np.max(np.abs(run["reduced"]["crank_angle_rad"] - hp.q)) < 1e-9
    at3 = mjb.hold_point(scn, q=3.0)  # any angle: the reference that holds it
    assert at3.q == 3.0 and at3.q_ref == pytest.approx(3.0 + at3.V / (ki * z))
    run = mjb.simulate(at3.machine, backend="reduced", t_end=0.2)
    assert np.max(np.abs(run["reduced"]["crank_angle_rad"] - 3.0)) < 1e-9
    sc = mjb.step_check(scn, q=3.0, dq=0.03, t_end=0.5, backend="reduced")
    assert sc.q_rel_error < 2e-3 and sc.qd_rel_error < 2e-3  # docs/linear.md §6: 1 % step, 0.10 % on MuJoCo
    assert sc.t.shape == sc.q_sim.shape == sc.q_lin.shape and 0.005 < sc.q_lin[-1] < 0.03  # (slow integral)
    assert sc.to_pandas().shape == (len(sc.t), 5) and "step check at q* = 3" in sc.summary()
    # a machine built in code works the same, and its run equals the scenario's
    on_mach = mjb.step_check(mach, q=3.0, dq=0.03, t_end=0.5, backend="reduced")
    assert np.array_equal(on_mach.q_sim, sc.q_sim)
    with pytest.raises(mjb.ParameterError, match="hold_offset"):
        mjb.hold_point("incerti2012", "open")
    with pytest.raises(mjb.ParameterError, match="not both"):
        mjb.hold_point(scn, q=1.0, q_ref=0.0)
    with pytest.raises(mjb.ParameterError, match="give a step"):
        mjb.step_check(scn, q=3.0)


def test_analyze_a_mechanism_or_machine_built_in_code(tmp_path):
    kw = _fourbar()
    mech = mjb.make_mechanism("fourbar", **kw)
    drive = mjb.make_drive(R=2.0, L=9e-3, k_m=0.48, J_m=13e-4, J_a=9.8e-5, J_b=9.8e-5, z=1, lam=0.08, v_max=48)
    pid = mjb.make_controller("pid", drive=drive, mechanism=mech, kp=80, ki=32, kd=0.015, omega0=30)
    ref = mjb.analyze_mechanism("incerti2012", points=90)
    an = mjb.analyze_mechanism(mjb.Machine(mech, drive, pid), points=90)  # speed: the PID's set-point
    for key in ("speeds", "transmission", "transmission_angles_deg", "reduced", "flags", "curves", "drive"):
        assert an.data[key] == ref.data[key], key
    assert an.scenario is None and an.summary().startswith("machine built in code (fourbar)")
    alone = mjb.analyze_mechanism(mech, ["30 rad/s"], points=90)  # no drive: the input torque only
    assert alone.data["drive"] is None and "motor_torque_Nm" not in alone.data["speeds"][0]
    assert alone.data["speeds"][0]["input_torque_Nm"] == ref.data["speeds"][0]["input_torque_Nm"]
    assert "no drive given" in alone.summary()
    alone.save(tmp_path / "an")
    assert sorted(os.listdir(tmp_path / "an")) == ["analysis.json", "kinematics.png", "reduced_model.png",
                                                   "torque_speed.png"]
    # transmission angles: a stable key (the joint) and the display label (the links' names)
    mu = an.transmission["C"]
    assert mu.key == "C" and mu.label == "C (coupler on rocker)" and an.data["transmission"]["C"]["label"] == mu.label
    assert np.array_equal(mu.mu, an.curves["mu:C (coupler on rocker)"]) and mu.min_deg == pytest.approx(39.8, abs=0.05)  # 90 points
    assert ref.data["transmission_angles_deg"][mu.label]["key"] == "C"
    raw = mjb.load("press-slidercrank").spec.raw
    renamed = {**raw, "mechanism": {**raw["mechanism"], "links": {("con_rod" if k == "rod" else k): v
                                                                  for k, v in raw["mechanism"]["links"].items()}}}
    renamed["mechanism"]["joints"] = [{**j, "at": [a.replace("rod.", "con_rod.") for a in j["at"]]}
                                      for j in raw["mechanism"]["joints"]]
    a, b = mjb.analyze_mechanism(raw, points=64), mjb.analyze_mechanism(renamed, points=64)
    assert list(a.transmission) == list(b.transmission) and a.transmission.keys() == {"C"}
    assert a.transmission["C"].label != b.transmission["C"].label
    assert a.transmission["C"].min_deg == pytest.approx(b.transmission["C"].min_deg, abs=1e-12)


def test_to_toml_round_trips_every_shipped_scenario(tmp_path):
    import tomllib

    for name in mjb.list_scenarios():
        scn = mjb.load(name)
        path = tmp_path / f"{name}.toml"
        text = scn.to_toml(path)
        assert path.read_text() == text and tomllib.loads(text) == scn.spec.raw, name
        again = mjb.load(path)
        assert again.resolved() == scn.resolved() and again.name == scn.name, name
    # overrides are written as values; a run of the file equals the scenario's, bit for bit
    scn = mjb.load("mjcf-fourbar", **{"drive.R": "2.2 ohm", "simulation.record_dt": "1 ms"})
    scn.to_toml(tmp_path / "x.toml")
    again = mjb.load(tmp_path / "x.toml")
    assert again.get("drive.R") == pytest.approx(2.2) and again.overrides == []
    a, b = (s.simulate("open", "both", 0.02) for s in (scn, again))
    for bk in ("multibody", "reduced"):
        assert np.array_equal(a[bk].data, b[bk].data)
    with pytest.raises(mjb.OutputError, match="force=True"):
        scn.to_toml(tmp_path / "x.toml")
    scn.to_toml(tmp_path / "x.toml", force=True)


def test_sweep_of_a_scenario_made_from_a_dict(tmp_path):
    raw = mjb.load("incerti2012").spec.raw
    kw = dict(t_end=0.05, verify=0)
    by_name = mjb.parameter_sweep("incerti2012", {"drive.R": [1.8, 2.2]}, **kw)
    res = mjb.parameter_sweep(raw, {"drive.R": [1.8, 2.2]}, out=tmp_path / "sw", **kw)
    assert [r["peak_current_A"] for r in res.rows] == [r["peak_current_A"] for r in by_name.rows]
    assert (tmp_path / "sw" / "scenario.toml").is_file()  # the file the rows re-load
    assert mjb.load(tmp_path / "sw" / "scenario.toml").resolved() == mjb.load(raw).resolved()
    again = mjb.parameter_sweep(mjb.load(raw), {"drive.R": [1.8, 2.2]}, out=tmp_path / "sw", **kw)  # resumed
    assert again.ran == 0 and again.rows == res.rows
    other = mjb.load(raw, **{"drive.L": "10 mH"})
    with pytest.raises(mjb.ParameterError, match="another scenario"):
        mjb.parameter_sweep(mjb.load(other.spec.raw), {"drive.R": [1.8, 2.2]}, out=tmp_path / "sw", **kw)
    with pytest.raises(mjb.ScenarioError):  # a bad key: no folder left behind
        mjb.parameter_sweep(raw, {"drive.Rx": [1.0]}, out=tmp_path / "bad", **kw)
    assert not (tmp_path / "bad").exists()


def test_analyze_cli_equals_api(tmp_path):
    assert main(["analyze", "press-slidercrank", "--speed", "60 rpm", "--points", "64", "--out",
                 str(tmp_path / "cli")]) == 0
    res = mjb.analyze_mechanism("press-slidercrank", ["60 rpm"], points=64)
    res.save(tmp_path / "api")
    assert_same_folder(tmp_path / "cli", tmp_path / "api", binary=())
    assert res.applicable and res.curves["q"].shape == (64,) and res.to_pandas().shape[0] == 64
    assert res.data["plausibility"]["model"]["models_agree"] is True and res.warnings == []


def test_identify_cli_equals_api(tmp_path, capsys):
    data = tmp_path / "rec.csv"
    assert main(["identify", "--data", str(data), "--synthetic", "--out", str(tmp_path / "cli")]) == 0
    from mjbench.identify import read_record

    rec = read_record(str(data))  # the record as arrays (a DataFrame works the same)
    res = mjb.identify_motor({"t_s": rec["t"], "voltage_V": rec["V"], "motor_speed_rad_s": rec["omega"],
                              "current_A": rec["I"]}, source=str(data))
    res.save(tmp_path / "api")
    assert_same_folder(tmp_path / "cli", tmp_path / "api", binary=())
    assert res.values["R"] == pytest.approx(2.0, rel=0.02) and res.drive["k_m"] == pytest.approx(0.48, rel=0.02)
    from mjbench.commands.identify import SEED000_MOTOR

    assert res.report(truth=SEED000_MOTOR) in capsys.readouterr().out
    with pytest.raises(mjb.ParameterError, match="every parameter is fixed"):
        mjb.identify_motor(data, fix=dict.fromkeys(("R", "L", "K", "J", "b", "T_c"), 1.0))
    with pytest.raises(mjb.ParameterError, match="no such file"):
        mjb.identify_motor(tmp_path / "missing.csv")


def test_frequency_response_cli_equals_api_and_fmu_export(tmp_path):
    opts = ["--lines", "4", "--periods", "2", "--settle", "0.05", "--period", "0.1", "--band", "60,2000"]
    # seed 000's PID sits on its ±48 V limiter there: measured, written, flagged saturated, exit 1 (issue 35)
    assert main(["frest", "incerti2012", *opts, "--out", str(tmp_path / "cli")]) == 1
    res = mjb.frequency_response("incerti2012", lines=4, periods=2, settle=0.05, period=0.1, band=(60, 2000))
    assert res.data["saturation"]["saturated"] and "SATURATED" in res.summary()
    res.save(tmp_path / "api")
    assert_same_folder(tmp_path / "cli", tmp_path / "api", binary=())
    import control

    assert isinstance(res.frd["plant"], control.FrequencyResponseData) and res.omega.shape == (4,)
    fmu = mjb.export_fmu("incerti2012", tmp_path / "m.fmu", backend="reduced")
    import zipfile

    assert "modelDescription.xml" in zipfile.ZipFile(fmu).namelist()
    with pytest.raises(mjb.ParameterError, match="force=True"):
        mjb.export_fmu("incerti2012", fmu)


def test_optimize_motion_law_cli_equals_api(tmp_path, capsys):
    assert main(["optimize-law", "incerti-bezier", "--no-multibody", "--no-plots", "--out", str(tmp_path / "cli")]) == 0
    res = mjb.optimize_motion_law("incerti-bezier", multibody=False)
    res.save(tmp_path / "api", plots=False)
    assert_same_folder(tmp_path / "cli", tmp_path / "api", binary=())
    assert res.report["reduction_orders"] > 3 and res.summary() in capsys.readouterr().out


def test_reproduce_papers_is_what_the_cli_runs(tmp_path, monkeypatch):
    """The report folder is written by reproduce_papers (whole or not at all) for `reproduce` and
    `demo`; the cases themselves (minutes) are run by tests/test_report.py."""
    from mjbench import reproduce as R

    calls = []

    def fake(which, out_dir, **kw):
        calls.append((which, kw["quick"], kw["video"]))
        (Path(out_dir) / "report.md").write_text(f"{which}\n")
        return [{"case": which}]

    monkeypatch.setattr(R, "reproduce", fake)
    assert main(["reproduce", "incerti-bezier", "--no-video", "--out", str(tmp_path / "cli")]) == 0
    assert main(["demo", "--no-video", "--out", str(tmp_path / "demo")]) == 0
    assert mjb.reproduce_papers(tmp_path / "api", "incerti-bezier", video=False) == [{"case": "incerti-bezier"}]
    assert_same_folder(tmp_path / "cli", tmp_path / "api")
    assert calls == [("incerti-bezier", False, False), ("all", True, False), ("incerti-bezier", False, False)]
    with pytest.raises(mjb.ScenarioError, match="unknown reproduce case"):
        mjb.reproduce_papers(tmp_path / "x", "nope")
    assert not (tmp_path / "x").exists() and "incerti-bezier" in [c.name for c in mjb.paper_cases()]


def test_render_video(tmp_path):
    info = mjb.render_video("incerti2012", tmp_path / "v.mp4", t_end=0.1, width=160, height=120)
    assert info["frames"] == 4 and (tmp_path / "v.mp4").stat().st_size > 1000
    with pytest.raises(mjb.OutputError, match=r"\.mp4 or \.gif"):
        mjb.render_video("incerti2012", tmp_path / "v.avi")


# ============================================================================ the docs' examples
def _python_blocks(path):
    text = (ROOT / path).read_text(encoding="utf-8")
    return [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]


def test_docs_examples_run(tmp_path, monkeypatch, capsys):
    """README's "From Python" block and docs/api.md's examples run as written."""
    monkeypatch.chdir(tmp_path)
    api_blocks = _python_blocks("docs/api.md")
    assert api_blocks[0] == ACCEPTANCE  # the acceptance script, run by the first test
    readme = [b for b in _python_blocks("README.md") if "import mjbench as mjb" in b]
    assert len(readme) == 1
    ns = {"__name__": "__main__"}
    exec(compile(readme[0], "README.md", "exec"), ns)
    assert (tmp_path / "out_api" / "manifest.json").is_file() and ns["speed"].shape == (1001,)
    assert list(ns["table"]["status"]) == ["ok"] * 3 and 0 < ns["lin"].margins.phase_margin_deg < 90
    exec(compile("import mjbench as mjb\n" + api_blocks[1], "docs/api.md", "exec"), {"__name__": "__main__"})


# ============================================================================ the package
def test_import_is_cheap_and_names_resolve():
    # import mjbench loads nothing heavy; resolving mjbench.load loads what a scenario is validated with
    # (NumPy, pydantic) but not MuJoCo, pandas or matplotlib (a simulation, a table, a figure load those)
    code = ("import sys, mjbench; heavy = ('numpy', 'mujoco', 'pydantic', 'pandas', 'matplotlib', 'numba', 'scipy');"
            "print([m for m in heavy if m in sys.modules]); mjbench.load;"
            "print([m for m in heavy if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split("\n")[:2] == ["[]", "['numpy', 'pydantic']"]
    for name in mjb.__all__:
        assert getattr(mjb, name) is not None, name
    assert set(mjb.__all__) - {"__version__"} == set(mjb.api.PUBLIC) and set(mjb.__all__) <= set(dir(mjb))
    # a public name equal to a submodule's would be replaced by the module once that is imported
    modules = {m.name for m in pkgutil.iter_modules(mjb.__path__)}
    assert not modules & set(mjb.__all__)
    with pytest.raises(AttributeError):
        mjb.no_such_name  # noqa: B018
    assert (ROOT / "mjbench" / "py.typed").is_file()


def test_public_api_type_checks():
    """mypy on mjbench/__init__.py and mjbench/api/ ([tool.mypy] in pyproject.toml)."""
    cache = os.path.join(tempfile.gettempdir(), "mjbench-mypy-cache")
    p = subprocess.run([sys.executable, "-m", "mypy", "--cache-dir", cache], cwd=ROOT, capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "Success: no issues found" in p.stdout
