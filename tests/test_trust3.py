"""Issue 26, "Trust, round 3": no silently wrong result, no traceback, resources checked first.

Table-driven: every bad input of the issue's families → exit status and the key words of the ONE
line on stderr (no traceback: the CLI is called in-process, so a traceback would fail the test).
Then the behaviours: tune's infeasible constraints (exit 1), a resumed sweep written byte for byte
as a fresh one, a Dask worker killed mid-sweep, the optimize-law case that hung, metrics named by
what they compute, the reduced model checked against MuJoCo's mass matrix, the step-size flag, a
linkage starting in its stated pose, MJCF model files in manifests, disk full.
"""
import errno
import json
import math
import os
import shutil
import threading
import time
from pathlib import Path

import pytest

from mjbench import scenario as S
from mjbench.cli import main

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "mjbench" / "scenarios" / "models" / "fourbar_user.xml"


def run_cli(args, capsys):
    """(exit status, stderr) of ``mjbench ARGS`` in-process."""
    code = main([str(a) for a in args])
    return code, capsys.readouterr().err


def one_line(err):
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("mjbench: error:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ============================================================================ bad input → exit 2, one line
def _csv(tmp, name, text):
    p = tmp / name
    p.write_text(text)
    return p


GOOD_ROWS = "".join(f"{0.001 * i},{12.0},{float(i)},{0.5}\n" for i in range(30))
HEADER = "t_s,voltage_V,motor_speed_rad_s,current_A\n"

CASES = [
    # --- sweep: every CLI value checked like a scenario value, names against the known ones
    ("sweep-grid-key-twice", ["sweep", "incerti2012", "--grid", "drive.R=2", "--grid", "drive.R=3", "--out", "{o}"],
     ["--grid drive.R is given twice", "one --grid"]),
    ("sweep-grid-repeated-value", ["sweep", "incerti2012", "--grid", "drive.R=2,2", "--grid", "drive.R=3", "--out", "{o}"],
     ["value 2 is repeated"]),
    ("sweep-grid-alias-and-key", ["sweep", "hulako2025-model1", "--grid", "vc=0.1,0.2", "--grid",
                                  "modes.pid.reference.vc=0.3", "--out", "{o}"],
     ["same scenario key modes.pid.reference.vc"]),
    ("sweep-range-bad-n", ["sweep", "incerti2012", "--grid", "drive.R=1:3:x", "--out", "{o}"], ["lo:hi:n"]),
    ("sweep-too-many-rows", ["sweep", "incerti2012", "--grid", "drive.R=1:3:100000000", "--out", "{o}"],
     ["100,000,000 rows", "MJBENCH_MAX_SWEEP_ROWS"]),
    ("sweep-metric-typo", ["sweep", "incerti2012", "--grid", "drive.R=2,3", "--metric", "peak_curent_A", "--verify", "1",
                           "--out", "{o}"], ["--metric 'peak_curent_A'", "did you mean 'peak_current_A'"]),
    ("sweep-samples-negative", ["sweep", "incerti2012", "--samples", "-3", "--perturb", "drive.R=5%", "--out", "{o}"],
     ["--samples", "must be an integer >= 0", "-3"]),
    ("sweep-samples-text", ["sweep", "incerti2012", "--samples", "x", "--out", "{o}"], ["--samples", "'x'"]),
    ("sweep-seed-unused", ["sweep", "incerti2012", "--grid", "drive.R=2,3", "--seed", "4", "--out", "{o}"],
     ["--seed has no effect", "--samples is 0"]),
    ("sweep-verify-multibody", ["sweep", "incerti2012", "--grid", "drive.R=2,3", "--backend", "multibody", "--verify",
                                "2", "--out", "{o}"], ["--verify has no effect"]),
    ("sweep-scheduler-malformed", ["sweep", "incerti2012", "--grid", "drive.R=2,3", "--scheduler", "notaurl",
                                   "--out", "{o}"], ["--scheduler 'notaurl'", "tcp://HOST:PORT"]),
    ("sweep-perturb-100pct", ["sweep", "incerti2012", "--samples", "3", "--perturb", "drive.R=150%", "--out", "{o}"],
     ["--perturb", "less than 100 %"]),
    # --- tune
    ("tune-bounds-unknown-gain", ["tune", "incerti2012", "--controller", "pid-tv", "--bounds", "kq=1:10"],
     ["'kq' is not a gain", "kp, ki, kd"]),
    ("tune-bounds-bad-interval", ["tune", "incerti2012", "--controller", "pid-tv", "--bounds", "kp=10:1"],
     ["0 < LO < HI"]),
    ("tune-global-0", ["tune", "incerti2012", "--controller", "pid-tv", "--global", "0"], ["--global", ">= 1"]),
    ("tune-span-negative", ["tune", "incerti2012", "--controller", "pid-tv", "--span", "-2"], ["--span", "> 1", "-2"]),
    ("tune-margin-mode-alone", ["tune", "incerti2012", "--controller", "pid", "--margin-mode", "constraint"],
     ["--margin-mode has no effect", "--margin"]),
    ("tune-margin-malformed", ["tune", "incerti2012", "--controller", "pid", "--margin", "pm=>45"], ["--margin 'pm=>45'"]),
    ("tune-verify-multibody", ["tune", "incerti2012", "--controller", "pid", "--backend", "multibody", "--verify", "2"],
     ["--verify has no effect"]),
    # --- linearize, demand, render, analyze, run
    ("linearize-omega-huge", ["linearize", "incerti2012", "--at", "omega=1e9", "--out", "{o}"], ["--at omega=1e+09",
                                                                                               "<= 100000"]),
    ("linearize-t-negative", ["linearize", "incerti2012", "--at", "t=-5", "--out", "{o}"], ["--at t=-5", ">= 0"]),
    ("linearize-key-twice", ["linearize", "incerti2012", "--at", "q=1,q=2", "--out", "{o}"], ["--at q is given twice"]),
    ("linearize-angles-negative", ["linearize", "incerti2012", "--angles", "-1", "--out", "{o}"], ["--angles", ">= 0"]),
    ("demand-vc-zero", ["demand", "hulako2025-model1", "--vc", "0"], ["--vc", "must be > 0"]),
    ("demand-set-vc-zero", ["demand", "hulako2025-model1", "--set", "vc=0"], ["--set vc=0", "must be > 0"]),
    ("demand-no-coupler-reference", ["demand", "incerti2012", "--vc", "0.2"], ["no coupler-speed reference"]),
    ("render-huge-frame", ["render", "incerti2012", "--width", "100000", "--height", "100000", "--out", "{o}/v.mp4"],
     ["--width", "<= 7,680"]),
    ("render-odd-frame", ["render", "incerti2012", "--width", "101", "--out", "{o}/v.mp4"], ["101x540", "even"]),
    ("render-crf", ["render", "incerti2012", "--crf", "60", "--out", "{o}/v.mp4"], ["--crf", "<= 51"]),
    ("analyze-points-huge", ["analyze", "press-slidercrank", "--points", "1e8"], ["--points", "<= 1,000,000"]),
    ("analyze-mu-min", ["analyze", "press-slidercrank", "--mu-min", "100"], ["--mu-min", "<= 90"]),
    ("run-t-end-negative", ["run", "incerti2012", "--t-end", "-1", "--out", "{o}"], ["--t-end", "> 0 s"]),
    ("run-t-end-nan", ["run", "incerti2012", "--t-end", "nan", "--out", "{o}"], ["--t-end", "nan"]),
    ("run-t-end-unit", ["run", "incerti2012", "--t-end", "5 kg", "--out", "{o}"], ["--t-end", "wrong dimension"]),
    ("run-fast-multibody-reduced", ["run", "incerti2012", "--backend", "reduced", "--fast-multibody", "Euler",
                                    "--out", "{o}"], ["--fast-multibody has no effect"]),
    # --- optimize-law: a key of another law family
    ("optimize-law-foreign-key", ["optimize-law", "incerti-bezier", "--set", "law.gammas=[3,4]", "--out", "{o}"],
     ["law.gammas is a key of the pseudopoly law family", "kind = 'bezier'"]),
    ("optimize-law-foreign-key-2", ["optimize-law", "incerti-belt", "--set", "law.p=2", "--out", "{o}"],
     ["law.p is a key of the bezier law family"]),
    ("optimize-law-degenerate-start", ["optimize-law", "incerti-belt", "--set", "law.gammas=[4.5,4.52,6]", "--out", "{o}"],
     ["initial pseudopoly law is degenerate", "exponents collapsing"]),
    # --- identify --data: file, row and column named
    ("identify-missing", ["identify", "--data", "{t}/nope.csv"], ["nope.csv: no such file"]),
    ("identify-folder", ["identify", "--data", "{t}"], ["is a folder"]),
    ("identify-empty", ["identify", "--data", ("empty.csv", "")], ["empty.csv is empty"]),
    ("identify-header-only", ["identify", "--data", ("head.csv", HEADER)], ["holds a header but no samples"]),
    ("identify-nan", ["identify", "--data", ("nan.csv", HEADER + GOOD_ROWS + "0.5,12,nan,0.5\n")],
     ["row 32, column motor_speed_rad_s", "nan is not a finite number"]),
    ("identify-inf", ["identify", "--data", ("inf.csv", HEADER + "0.0,inf,1,0.5\n" + GOOD_ROWS)],
     ["row 2, column voltage_V", "inf is not a finite number"]),
    ("identify-text", ["identify", "--data", ("text.csv", HEADER + "".join(GOOD_ROWS.splitlines(True)[:5]) + "0.9,twelve,1,0.5\n")],
     ["column voltage_V", "'twelve' is not a number"]),
    ("identify-ragged", ["identify", "--data", ("rag.csv", HEADER + "0,1,2\n" + GOOD_ROWS)],
     ["row 2: 3 fields, the header has 4", "ragged"]),
    ("identify-semicolons", ["identify", "--data", ("semi.csv", HEADER.replace(",", ";") + GOOD_ROWS.replace(",", ";"))],
     ["row 1: the columns are separated by semicolons"]),
    ("identify-time-not-increasing", ["identify", "--data", ("time.csv", HEADER + GOOD_ROWS + "0.001,1,1,1\n")],
     ["row 32, column t_s", "not after the previous"]),
    ("identify-fix-unknown", ["identify", "--data", ("ok1.csv", HEADER + GOOD_ROWS), "--fix", "Rx=2"],
     ["--fix 'Rx=2'", "not a parameter"]),
    ("identify-fix-negative", ["identify", "--data", ("ok2.csv", HEADER + GOOD_ROWS), "--fix", "R=-2"],
     ["--fix 'R=-2'", "> 0"]),
]


@pytest.mark.parametrize("name,args,words", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_and_exit_2(name, args, words, tmp_path, capsys):
    out = tmp_path / "out"
    argv = []
    for a in args:
        if isinstance(a, tuple):
            argv.append(_csv(tmp_path, *a))
        else:
            argv.append(a.format(o=out, t=tmp_path))
    t0 = time.perf_counter()
    code, err = run_cli(argv, capsys)
    assert code == 2, err
    line = one_line(err)
    for w in words:
        assert w in line, (w, line)
    assert not out.exists() or not any(out.iterdir())  # nothing written
    assert time.perf_counter() - t0 < 20  # checked before any real work


def test_unreachable_scheduler_is_one_line_within_seconds(tmp_path, capsys, monkeypatch):
    pytest.importorskip("dask.distributed")
    monkeypatch.setenv("MJBENCH_DASK_TIMEOUT", "1")
    t0 = time.perf_counter()
    code, err = run_cli(["sweep", "incerti2012", "--grid", "drive.R=2,3", "--scheduler", "tcp://127.0.0.1:1",
                         "--out", tmp_path / "o"], capsys)
    assert code == 2 and "no Dask scheduler answered within 1 s" in one_line(err)
    assert time.perf_counter() - t0 < 15
    assert not (tmp_path / "o").exists()  # no empty folder left


# ============================================================================ scenario files: nothing ignored
BUILTIN = ROOT / "mjbench" / "scenarios"


def _edited(tmp_path, name, old, new, out="s.toml"):
    """A built-in scenario's TOML text with ``old`` replaced by ``new`` (once), as a user file."""
    text = (BUILTIN / f"{name}.toml").read_text()
    assert old in text
    p = tmp_path / out
    p.write_text(text.replace(old, new, 1))
    return p


@pytest.mark.parametrize("old,new,words", [
    ('metric = "chi_window"', 'metric = "chi_windw"', ["metric: 'chi_windw' is not a metric", "did you mean 'chi_window'"]),
    ('mode = "open"\nmetric', 'mode = "opne"\nmetric', ["mode: 'opne' is not one of the [modes.*]", "did you mean 'open'"]),
    ('value = 54.3', 'value = 54.3\ntolerence = 0.1', ["unknown key 'tolerence'"]),
    ('value = 54.3', 'value = 54.3\nmax = 60.0', ["exactly one of value, band, max, min"]),
    ('[[paper.figures]]', '[optimize]\nmethod = "BFGS"\n\n[[paper.figures]]', ["optimize: the [optimize] table",
                                                                              "no [law] table"]),
    ("press:axis = [0.0, 1.0]", "", ["joint 'guide': a prismatic joint needs axis"]),  # (was an unformatted {n!r})
], ids=["figure-metric", "figure-mode", "figure-key", "figure-two-compares", "optimize-without-law", "prismatic-axis"])
def test_scenario_keys_that_would_be_ignored_are_refused(tmp_path, capsys, old, new, words):
    name = "incerti2012"
    if old.startswith("press:"):
        name, old = "press-slidercrank", old[len("press:"):]
    p = _edited(tmp_path, name, old, new)
    code, err = run_cli(["run", p, "--out", tmp_path / "o"], capsys)
    assert code == 2
    line = one_line(err)
    for w in words:
        assert w in line, (w, line)


def test_every_figure_metric_of_the_builtins_is_known():
    from mjbench import metrics as M

    known = set(M.known_metrics())
    for name in S.builtin_names():
        for fig in S.load(name).paper.get("figures", []) or []:
            assert fig["metric"] in known, (name, fig["metric"])


def test_known_metric_names_are_what_summary_computes():
    """The names --metric and [[paper.figures]] are checked against are the ones the code writes."""
    from mjbench import metrics as M
    from mjbench.backends import simulate

    scn = S.load("incerti2012", ["drive.i_max=40", "drive.i_rated=20"])  # every duty figure: limits, rating
    mach = S.make_machine(scn, "pid")
    tr = simulate(mach, "reduced", 0.6, record_dt=5e-4)
    m = M.summary(tr, chi_window=scn.metrics.chi_window, drive=mach.drive)
    numeric = {k for k, v in m.items() if isinstance(v, (int, float))}
    # every numeric one named, no stale name (chi_sampling_s: only a run read back from its CSV, without
    # the interval statistics, has χ from its samples)
    assert numeric == set(M.SUMMARY_METRICS) - {"chi_sampling_s"}
    assert "chi_sampling_s" not in m  # χ from every co-step: not labelled with a sampling grid
    from mjbench.runner import mode_metrics, run_mode

    for name, mode, group, names in (("incerti-belt", "servo", "residual_vibration", M.RESIDUAL_METRICS),
                                     ("hulako2025-model1", "pid", "coupler_speed", M.COUPLER_METRICS)):
        scn = S.load(name)
        res = mode_metrics(scn, mode, run_mode(scn, mode, ("reduced",), t_end=min(scn.simulation.t_end, 1.5)))
        got = res["backends"]["reduced"][group]
        assert {k for k, v in got.items() if isinstance(v, (int, float)) or v is None} <= set(names) <= set(got), name


# ============================================================================ user MJCF
def _mjcf(tmp_path, xml_edit=None, trace="mid"):
    """A user MJCF scenario (mjcf-fourbar) reading its own copy of the model file."""
    xml = MODEL.read_text()
    path = tmp_path / "m.xml"
    path.write_text(xml_edit(xml) if xml_edit else xml)
    p = _edited(tmp_path, "mjcf-fourbar", 'file = "models/fourbar_user.xml"', f'file = "{path}"', "m.toml")
    p.write_text(p.read_text().replace('trace = "mid"', f'trace = "{trace}"'))
    return p, path


@pytest.mark.parametrize("cmd", ["run", "render"])
def test_mjcf_trace_site_that_does_not_exist(tmp_path, capsys, cmd):
    p, _ = _mjcf(tmp_path, trace="nowhere")
    out = tmp_path / ("o" if cmd == "run" else "v.mp4")
    code, err = run_cli([cmd, p, "--out", out, "--t-end", "0.05"], capsys)
    assert code == 2 and "mechanism.trace = 'nowhere': no site or body of that name" in one_line(err)
    assert not out.exists()


def test_mjcf_input_hinge_with_a_range_is_refused(tmp_path, capsys):
    p, _ = _mjcf(tmp_path, lambda x: x.replace('<joint name="motor"/>', '<joint name="motor" range="-1 1"/>'))
    code, err = run_cli(["run", p, "--backend", "reduced", "--t-end", "0.05", "--out", tmp_path / "o"], capsys)
    assert code == 2 and "the hinge has a range [-1, 1]" in one_line(err)


def test_mjcf_manifest_holds_the_model_hash_and_refuses_a_changed_file(tmp_path, capsys):
    p, xml = _mjcf(tmp_path)
    out = tmp_path / "o"
    assert run_cli(["run", p, "--backend", "reduced", "--t-end", "0.05", "--no-figure", "--quiet", "--out", out],
                   capsys)[0] == 0
    man = json.loads((out / "manifest.json").read_text())
    info = man["model_files"][str(xml)]
    import hashlib
    assert info["sha256"] == hashlib.sha256(xml.read_bytes()).hexdigest()
    assert (out / info["copy"]).read_bytes() == xml.read_bytes()  # the run's copy of the model
    # unchanged: the manifest repeats the run
    assert run_cli(["run", out / "manifest.json", "--no-figure", "--quiet", "--out", tmp_path / "again"], capsys)[0] == 0
    # changed: refused, naming the file and the copy
    xml.write_text(xml.read_text().replace('mass="0.42"', 'mass="0.5"'))
    code, err = run_cli(["run", out / "manifest.json", "--out", tmp_path / "o2"], capsys)
    line = one_line(err)
    assert code == 2 and "changed since that run" in line and str(xml) in line and "model/m.xml" in line


# ============================================================================ tune: infeasible constraints
def test_tune_infeasible_constraints_exit_1_with_the_closest_candidate(tmp_path, capsys):
    out = tmp_path / "t"
    code = main(["tune", "incerti2012", "--controller", "pid-tv", "--objective", "ise", "--margin", "pm>=179",
                 "--margin", "ms<=1.0", "--margin-mode", "constraint", "--margin-angles", "4", "--global", "4",
                 "--maxfev", "2", "--verify", "1", "--t-end", "0.1", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1, err
    line = [ln for ln in err.splitlines() if ln.startswith("mjbench: tune:")]
    assert len(line) == 1 and "no candidate meets the constraints" in line[0]
    assert "pm>=179: worst phase margin [deg] is" in line[0] and "short by" in line[0]
    assert "ms<=1: worst peak |S| is" in line[0] and "over by" in line[0]
    doc = json.loads((out / "tune.json").read_text())
    assert doc["feasible"] is False and len(doc["violated"]) == 2


# ============================================================================ sweeps: resume, Dask
def test_resumed_rows_are_byte_identical_to_fresh_ones(tmp_path, capsys):
    args = ["sweep", "incerti2012", "--mode", "pid", "--grid", "drive.R=1.8,2,2.2", "--t-end", "0.6", "--verify", "0",
            "--quiet"]
    assert main(args + ["--out", str(tmp_path / "fresh")]) == 0
    fresh = (tmp_path / "fresh" / "results.csv").read_text()
    assert ",n_cycles," in fresh.splitlines()[0]  # an integer column
    shutil.copytree(tmp_path / "fresh", tmp_path / "resumed")
    lines = fresh.splitlines(keepends=True)
    (tmp_path / "resumed" / "results.csv").write_text("".join(lines[:2]))  # as if stopped after one row
    assert main(args + ["--out", str(tmp_path / "resumed")]) == 0
    assert "2 run now, 1 resumed" in capsys.readouterr().out
    assert (tmp_path / "resumed" / "results.csv").read_text() == fresh  # byte for byte (n_cycles 2, not 2.0)


def test_dask_worker_killed_mid_sweep(tmp_path):
    """One worker under a nanny, killed after the first chunk: with the scenario scattered (the old
    way) its data is lost → the sweep stops cleanly, saying how many rows are saved and how to
    resume; shipped as a task (now) the scheduler recomputes it and the sweep completes.  Both
    tables, resumed or not, equal a fresh local run byte for byte."""
    distributed = pytest.importorskip("dask.distributed")
    import signal

    import mjbench.sweep as SW
    from mjbench.errors import MjbenchError

    spec = dict(scenario="incerti2012", grid={"drive.R": [1.8, 2.0, 2.2, 2.4, 2.6, 2.8]}, mode="pid", t_end=0.3,
                chunk_size=1, backend="reduced", verify=0)
    local = SW.run_sweep(SW.SweepSpec(**spec), tmp_path / "local", progress=False, plots=False)
    fresh = Path(local["table"]).read_text()

    def kill_after_first_chunk(client, table):
        pid = next(iter(client.run(os.getpid).values()))

        def go():
            t0 = time.time()
            while not table.exists() and time.time() - t0 < 60:
                time.sleep(0.005)
            os.kill(pid, signal.SIGKILL)
        th = threading.Thread(target=go)
        th.start()
        return th

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        old = tmp_path / "old"
        th = kill_after_first_chunk(client, old / "results.csv")
        orig = SW.cluster.ship_scenario, SW.cluster.DASK_RETRIES
        SW.cluster.ship_scenario, SW.cluster.DASK_RETRIES = SW.scatter_scenario, 0
        try:
            with pytest.raises(MjbenchError, match=r"the Dask cluster lost a chunk .* rows are saved in .* run the same "
                                                   r"command again to resume"):
                SW.run_sweep(SW.SweepSpec(**spec), old, client=client, progress=False, plots=False)
        finally:
            SW.cluster.ship_scenario, SW.cluster.DASK_RETRIES = orig
            th.join()
        client.wait_for_workers(1, timeout=60)
        new = tmp_path / "new"
        th = kill_after_first_chunk(client, new / "results.csv")
        SW.run_sweep(SW.SweepSpec(**spec), new, client=client, progress=False, plots=False)
        th.join()
    assert (new / "results.csv").read_text() == fresh
    SW.run_sweep(SW.SweepSpec(**spec), old, progress=False, plots=False)  # the resume the message asks for
    assert (old / "results.csv").read_text() == fresh


# ============================================================================ optimize-law never hangs
def test_optimize_law_case_that_hung_finishes_with_a_result(tmp_path, capsys):
    """Issue 26: this never returned (> 15 min): the exponents collapsed to (4.567, 4.554, 4.568)
    with coefficients ~1e6 and the ODE check of that law did not finish."""
    t0 = time.perf_counter()
    out = tmp_path / "ol"
    code = main(["optimize-law", "incerti-belt", "--set", "mechanism.J=5.0", "--set", "mechanism.k=7e4", "--set",
                 "mechanism.c=120", "--set", "law.gammas=[3.3,4.4,5.9]", "--set", "law.T=0.9", "--set",
                 "law.revolutions=12", "--no-plots", "--out", str(out)])
    assert code == 0 and time.perf_counter() - t0 < 120
    rep = json.loads((out / "optimize_law.json").read_text())
    from mjbench.motionlaws import PseudoPolynomialLaw
    from mjbench.vibration import degeneracy

    g = rep["laws"]["optimised"]["law"]["gammas"]
    assert not degeneracy(PseudoPolynomialLaw(12 * 2 * math.pi, 0.9, g))  # a healthy law
    assert rep["laws"]["optimised"]["E_T_J"] < rep["laws"]["initial"]["E_T_J"]
    assert rep["optimiser"]["degenerate_trials_refused"] > 0
    assert "optimiser held back" in capsys.readouterr().err


def test_ode_check_has_a_budget():
    from mjbench import vibration as V
    from mjbench.motionlaws import PseudoPolynomialLaw

    plat = S.make_mechanism(S.load("incerti-belt"))
    law = PseudoPolynomialLaw(30 * math.pi, 1.0, [3.0, 4.0, 5.0])
    with pytest.raises(V.ODEBudgetExceeded, match="more than 100 right-hand-side evaluations"):
        V.ode_response(law, plat.oscillator(), max_nfev=100)
    assert V.residual_energy_ode(law, plat.oscillator()) > 0  # within the default budget


# ============================================================================ the reduced model against MuJoCo
def _scaled(mech, eps):
    """``mech`` with a J(q) wrong by the factor (1 + eps) (J' too, consistently)."""
    class Wrong(type(mech)):
        def reduced(self, q):
            J, dJ, dEp = super().reduced(q)
            return J * (1 + eps), dJ * (1 + eps), dEp
    Wrong.__name__ = f"{type(mech).__name__}_J_times_{1 + eps!r}"  # (its own reduced-model table cache key)
    w = object.__new__(Wrong)
    w.__dict__.update(mech.__dict__)
    return w


@pytest.mark.parametrize("name", S.builtin_names())
def test_every_shipped_machine_passes_its_own_model_check(name):
    """The check every both-backends run makes (metrics.json "plausibility"/"model"), on every shipped
    scenario: the reduced model and MuJoCo's agree within the tolerance, or the check says why it
    does not apply (the elastic platforms' internal coordinates).  It caught the cam's check comparing
    the rigid model with MuJoCo's pose settled into its soft constraints (E_p' off by 1.8e-5)."""
    from mjbench import plausibility as P

    scn = S.load(name)
    r = P.reduced_vs_mujoco(S.make_mechanism(scn), scn.multibody_options())
    if not r["applicable"]:
        assert "internal (elastic) coordinates" in r["note"]
        return
    errs = {k: v for k, v in r.items() if k.endswith("_rel_err")}
    assert r["models_agree"] and errs and max(errs.values()) <= r["tolerance"], (r.get("note"), errs)


def test_model_check_flags_a_wrong_j_that_a_controller_hides():
    from mjbench import plausibility as P

    scn = S.load("incerti2012")
    mech = S.make_mechanism(scn)
    ok = P.reduced_vs_mujoco(mech, scn.multibody_options())
    assert ok["models_agree"] and ok["J_rel_err"] < 1e-12 and ok["closure_velocity_rel"] < 1e-12
    # sensitivity: a uniform J error of 2e-5 is flagged, 5e-6 is not (tolerance 1e-5 of the peak)
    assert P.reduced_vs_mujoco(_scaled(mech, 2e-5), scn.multibody_options())["models_agree"] is False
    assert P.reduced_vs_mujoco(_scaled(mech, 5e-6), scn.multibody_options())["models_agree"] is True
    bad = P.reduced_vs_mujoco(_scaled(mech, 0.02), scn.multibody_options())
    assert bad["J_rel_err"] == pytest.approx(0.02, rel=1e-6) and "J(q) by 0.02" in bad["note"]


def test_model_check_in_metrics_and_warnings(tmp_path, capsys, monkeypatch):
    """On every --backend both run: metrics.json "plausibility" has the model check; a wrong J(q)
    gives a warning even when the trajectories agree within the 1e-3 tolerance (closed loop)."""
    from mjbench import plausibility as P
    from mjbench import runner

    orig = S.make_mechanism
    out = tmp_path / "r"
    assert main(["run", "incerti2012", "--mode", "pid", "--t-end", "0.2", "--no-figure", "--quiet", "--out",
                 str(out)]) == 0
    p = json.loads((out / "metrics.json").read_text())["plausibility"]
    assert p["model"]["models_agree"] is True and p["model"]["tolerance"] == P.MODEL_TOLERANCE
    monkeypatch.setattr(runner.S, "make_mechanism", lambda scn: _scaled(orig(scn), 1e-3))
    assert main(["run", "incerti2012", "--mode", "pid", "--t-end", "0.2", "--no-figure", "--quiet", "--out",
                 str(tmp_path / "w")]) == 0
    err = capsys.readouterr().err
    assert "the reduced model differs from MuJoCo's model" in err and "J(q) by 0.001" in err


# ============================================================================ step size, stated pose
def test_too_coarse_step_is_flagged(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "incerti2012", "--mode", "open", "--backend", "reduced", "--t-end", "0.3", "--set",
                 "simulation.dt=2e-3", "--set", "simulation.record_dt=2e-3", "--set", "modes.open.voltage=48",
                 "--no-figure", "--quiet", "--out", str(out)]) == 0
    st = json.loads((out / "metrics.json").read_text())["plausibility"]["step"]["reduced"]
    assert st["step_ok"] is False and st["max_input_step_rad"] > st["limit_rad"] == 0.05
    assert "too coarse" in capsys.readouterr().err
    assert main(["run", "incerti2012", "--mode", "open", "--backend", "reduced", "--t-end", "0.3", "--no-figure",
                 "--quiet", "--out", str(tmp_path / "fine")]) == 0
    st = json.loads((tmp_path / "fine" / "metrics.json").read_text())["plausibility"]["step"]["reduced"]
    assert st["step_ok"] is True


def test_linkage_starts_in_its_stated_pose():
    raw, src = S.read_raw("press-slidercrank")
    raw.pop("initial")
    assert S.from_raw(raw, src).initial.q0 == pytest.approx(math.pi / 2)  # input_angle = "90 deg"
    raw["initial"] = {"q0": 0.0}
    assert S.from_raw(raw, src).initial.q0 == 0.0  # an explicit q0 is kept


def test_backend_tolerance_of_the_scenario_is_used(tmp_path):
    out = tmp_path / "r"
    assert main(["run", "incerti2012", "--mode", "pid", "--t-end", "0.1", "--set", "metrics.backend_tolerance=1e-9",
                 "--no-figure", "--quiet", "--out", str(out)]) == 0
    p = json.loads((out / "metrics.json").read_text())["plausibility"]
    assert p["tolerance"] == 1e-9 and p["backends_agree"] is False


# ============================================================================ disk full
def _enospc(*a, **k):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_disk_full_in_run_and_sweep(tmp_path, capsys, monkeypatch):
    from mjbench import trajectory

    monkeypatch.setattr(trajectory, "atomic_write", _enospc)
    code, err = run_cli(["run", "incerti2012", "--t-end", "0.05", "--backend", "reduced", "--out", tmp_path / "a/b"],
                        capsys)
    assert code == 2 and "No space left on device" in one_line(err) and "--out" in one_line(err)
    assert not (tmp_path / "a").exists()  # no folder left behind
    import mjbench.sweep as SW
    for part in (SW.folder, SW.table, SW.chunks):  # every writer of the sweep's folder
        monkeypatch.setattr(part, "atomic_write", _enospc)
    code, err = run_cli(["sweep", "incerti2012", "--grid", "drive.R=2,3", "--t-end", "0.05", "--out", tmp_path / "s"],
                        capsys)
    assert code == 2 and "No space left on device" in one_line(err) and "nothing was written" in one_line(err)
    assert not (tmp_path / "s").exists()


def test_incomplete_mp4_is_not_saved(tmp_path):
    from mjbench.render import RenderError
    from mjbench.render.video import _check_mp4

    p = tmp_path / "v.mp4"
    p.write_bytes(b"\x00\x00\x00\x10ftypisom\x00\x00\x00\x00" + b"\x00\x00\x10\x00mdat" + b"\x00" * 100)
    with pytest.raises((RenderError, OSError)):
        _check_mp4(str(p), str(p))


def test_ffmpeg_that_stops_reading_frames_is_one_line(tmp_path, monkeypatch):
    """ffmpeg exits at the MP4 header (a full disk): imageio-ffmpeg raises a broken pipe with its
    whole command line; the writer turns it into ENOSPC (disk full) or one line naming --out."""
    from collections import namedtuple

    import numpy as np

    from mjbench.render import RenderError
    from mjbench.render.video import VideoWriter

    class Dead:
        def send(self, frame):
            raise BrokenPipeError("[Errno 32] Broken pipe\n\nFFMPEG COMMAND:\nffmpeg -y -f rawvideo ...\n\nFFMPEG STDERR")

        def close(self):
            pass

    Usage = namedtuple("Usage", "total used free")
    frame = np.zeros((16, 16, 3), np.uint8)
    for free, want in ((4096, OSError), (10 ** 9, RenderError)):
        monkeypatch.setattr(shutil, "disk_usage", lambda p, free=free: Usage(10 ** 10, 10 ** 10 - free, free))
        w = VideoWriter.__new__(VideoWriter)
        w.path, w.ext, w.n, w._gen = str(tmp_path / "v.mp4"), ".mp4", 3, Dead()
        w.tmp = str(tmp_path / ".tmp-v.mp4")
        with pytest.raises(want) as ei:
            w.write(frame)
        msg = str(ei.value)
        assert "\n" not in msg and "FFMPEG COMMAND" not in msg
        if want is OSError:
            assert ei.value.errno == errno.ENOSPC
        else:
            assert "ffmpeg stopped writing the video after 3 frames ([Errno 32] Broken pipe)" in msg and "v.mp4" in msg
