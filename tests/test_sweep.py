"""Sweeps: grid and Monte Carlo rows, tidy CSV, resumption, Dask scale-out (issue 7)."""
import os

import numpy as np
import pytest

from mjbench import cli, scenario
from mjbench.backends import multibody, reduced
from mjbench.errors import ScenarioError
from mjbench.sweep import SweepSpec, auto_chunk, make_rows, parse_grid, parse_perturb, read_table, run_sweep

T_END = 0.06  # s: short runs, the point is the bookkeeping (metrics on the whole record)


def _spec(**kw):
    base = dict(scenario="incerti2012", grid={"modes.pid.kp": [60.0, 100.0], "drive.R": [1.8, 2.2]},
                t_end=T_END, chunk_size=3, backend="multibody")
    base.update(kw)
    return SweepSpec(**base)


def test_rows_grid_and_monte_carlo():
    scn = scenario.load("incerti2012")
    rows = make_rows(_spec(), scn)
    assert [(r["modes.pid.kp"], r["drive.R"]) for r in rows] == [(60.0, 1.8), (60.0, 2.2), (100.0, 1.8), (100.0, 2.2)]
    mc = _spec(grid={"modes.pid.kp": [60.0, 100.0]}, samples=50, perturb={"drive.R": 0.05, "mechanism.m2": 0.1})
    rows = make_rows(mc, scn)
    assert len(rows) == 100
    R = np.array([r["drive.R"] for r in rows])
    m2 = np.array([r["mechanism.m2"] for r in rows])
    assert np.all(np.abs(R / 2.0 - 1) <= 0.05) and np.all(np.abs(m2 / 2.27 - 1) <= 0.1)
    assert np.std(R) > 0.01  # really perturbed
    assert make_rows(mc, scn) == rows  # deterministic
    assert parse_grid(["a=1,2.5,true"]) == {"a": [1, 2.5, True]}
    assert parse_grid(["a=0:1:3"]) == {"a": [0.0, 0.5, 1.0]}
    assert parse_perturb(["x=5%", "y=0.1"]) == {"x": 0.05, "y": 0.1}
    with pytest.raises(ScenarioError, match="modes.pid.kpp"):
        make_rows(_spec(grid={"modes.pid.kpp": [1.0]}), scn)


def test_sweep_table_matches_single_runs_and_resumes(tmp_path):
    out = tmp_path / "sw"
    res = run_sweep(_spec(), out, progress=False)
    assert res["ran"] == 4
    assert res["plots"] and all(os.path.getsize(p) > 1000 for p in res["plots"])  # heat map (2 keys)
    rows = read_table(res["table"])
    assert [r["status"] for r in rows] == ["ok"] * 4
    # row 3 (kp = 100, R = 2.2) against a single multibody run
    scn = scenario.load("incerti2012", ["modes.pid.kp=100.0", "drive.R=2.2"])
    tr = multibody.simulate(scenario.make_machine(scn, "pid"), T_END, record_dt=scenario.get(scn, "simulation.record_dt"))
    assert rows[3]["peak_current_A"] == pytest.approx(float(np.max(np.abs(tr.current))), rel=1e-12)
    assert rows[3]["mean_motor_speed_rad_s"] > 0
    # resume: a deleted row is recomputed, the others are skipped
    text = open(res["table"]).read().splitlines()
    with open(res["table"], "w") as f:
        f.write("\n".join(text[:-1]) + "\n")
    res2 = run_sweep(_spec(), out, progress=False)
    assert res2["ran"] == 1
    assert read_table(res2["table"]) == rows
    with pytest.raises(ScenarioError, match="different sweep"):
        run_sweep(_spec(t_end=0.05), out, progress=False)


def test_reduced_sweep_verifies_best_rows_on_multibody(tmp_path, capsys):
    """Default backend: the batched reduced model; the best rows re-run on MuJoCo (verify.csv)."""
    rc = cli.main(["sweep", "incerti2012", "--grid", "modes.pid.kp=60.0,100.0", "--grid", "drive.R=1.8,2.2",
                   "--t-end", str(T_END), "--out", str(tmp_path), "--quiet", "--metric", "peak_current_A",
                   "--verify", "2"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "reduced → multibody (verify.csv)" in out
    rows = read_table(tmp_path / "results.csv")
    scn = scenario.load("incerti2012", ["modes.pid.kp=100.0", "drive.R=2.2"])
    tr = reduced.simulate(scenario.make_machine(scn, "pid"), T_END, record_dt=scenario.get(scn, "simulation.record_dt"))
    assert rows[3]["peak_current_A"] == pytest.approx(float(np.max(np.abs(tr.current))), rel=1e-12)
    ver = read_table(tmp_path / "verify.csv")
    best = sorted(rows, key=lambda r: r["peak_current_A"])[:2]
    assert [v["row"] for v in ver] == [r["row"] for r in best]
    for v, r in zip(ver, best):
        s = scenario.load("incerti2012", [f"modes.pid.kp={r['modes.pid.kp']}", f"drive.R={r['drive.R']}"])
        mb = multibody.simulate(scenario.make_machine(s, "pid"), T_END, record_dt=scenario.get(s, "simulation.record_dt"))
        assert v["multibody"] == pytest.approx(float(np.max(np.abs(mb.current))), rel=1e-12)
        assert abs(v["relative"]) < 1e-3  # the two models agree (stated accuracy ≈ 1e-5)
    assert auto_chunk(256, "multibody") == 64 and auto_chunk(5000, "multibody") == 64
    assert auto_chunk(5000, "reduced") == 256 and auto_chunk(100, "reduced", workers=2) == 25


def test_monte_carlo_cli_and_plot(tmp_path):
    out = tmp_path / "mc"
    rc = cli.main(["sweep", "incerti2012", "--samples", "6", "--perturb", "drive.R=5%", "--perturb",
                   "mechanism.m2=10%", "--t-end", str(T_END), "--out", str(out), "--quiet",
                   "--metric", "peak_current_A"])
    assert rc == 0
    rows = read_table(out / "results.csv")
    assert len(rows) == 6 and all(r["status"] == "ok" for r in rows)
    assert os.path.getsize(out / "distribution_peak_current_A.png") > 1000


def test_dask_local_cluster_identical(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    local = run_sweep(_spec(), tmp_path / "local", progress=False, plots=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = run_sweep(_spec(), tmp_path / "dask", client=client, progress=False, plots=False)
        # the CLI route: a scheduler address (the sweep opens and closes its own Client)
        rc = cli.main(["sweep", "incerti2012", "--grid", "modes.pid.kp=60.0,100.0", "--grid", "drive.R=1.8,2.2",
                       "--t-end", str(T_END), "--chunk", "3", "--out", str(tmp_path / "addr"), "--quiet",
                       "--scheduler", cluster.scheduler_address, "--backend", "multibody"])
        assert rc == 0
    assert read_table(tmp_path / "addr" / "results.csv") == read_table(local["table"])
    assert read_table(local["table"]) == read_table(remote["table"])
    assert open(local["table"]).read() == open(remote["table"]).read()


def test_dask_reduced_batch_chunks_identical(tmp_path):
    """The reduced batch on Dask: chunks of 20 scenarios per task (the batched route), per-row
    geometry and drive; the table equals the local one byte for byte."""
    distributed = pytest.importorskip("dask.distributed")
    spec = dict(scenario="incerti2012", grid={}, samples=40, perturb={"mechanism.a": 0.05, "drive.R": 0.05},
                t_end=T_END, chunk_size=20, backend="reduced", verify=0)
    local = run_sweep(SweepSpec(**spec), tmp_path / "local", progress=False, plots=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = run_sweep(SweepSpec(**spec), tmp_path / "dask", client=client, progress=False, plots=False)
    rows = read_table(local["table"])
    assert len(rows) == 40 and all(r["status"] == "ok" for r in rows)
    assert open(local["table"]).read() == open(remote["table"]).read()
@pytest.mark.parametrize("backend", ["multibody", "reduced"])
def test_dask_two_clients_two_sweeps_at_once(tmp_path, backend):
    """Two different sweeps (incerti2012 and incerti2012-calibrated) submitted at the same time by
    two clients of one scheduler: each table equals its own local run (the scenarios are scattered
    under keys of their own, never one future per top-level key that the other client replaces)."""
    import threading

    distributed = pytest.importorskip("dask.distributed")
    grid = {"modes.pid.kp": [60.0, 100.0], "modes.pid.ki": [16.0, 32.0]}
    specs = {name: SweepSpec(scenario=name, grid=grid, t_end=T_END, chunk_size=1, backend=backend, verify=0)
             for name in ("incerti2012", "incerti2012-calibrated")}
    local = {name: read_table(run_sweep(sp, tmp_path / f"local-{name}", progress=False, plots=False)["table"])
             for name, sp in specs.items()}
    speeds = {name: [r["mean_motor_speed_rad_s"] for r in rows] for name, rows in local.items()}
    assert all(a != b for a, b in zip(*speeds.values()))  # the two machines really differ
    remote, errors = {}, []
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        barrier = threading.Barrier(len(specs))

        def one(name):
            try:
                with distributed.Client(cluster.scheduler_address) as client:
                    barrier.wait(timeout=60)
                    res = run_sweep(specs[name], tmp_path / f"dask-{name}", client=client, progress=False,
                                    plots=False)
                remote[name] = read_table(res["table"])
            except BaseException as e:  # noqa: BLE001 - reported by the main thread
                errors.append((name, e))

        threads = [threading.Thread(target=one, args=(name,)) for name in specs]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=300)
    assert not errors, errors
    for name in specs:
        assert [r["status"] for r in remote[name]] == ["ok"] * 4, name
        assert remote[name] == local[name], name


def test_row_scenarios_substitute_what_whole_validation_gives():
    """The sweep validates each swept value once and substitutes it (RowScenarios): every row's
    scenario dumps equal to the scenario validated whole, units converted; a key that takes part
    in cross-field checks (simulation.*) validates every row whole; an invalid value is an error."""
    from mjbench.sweep import RowScenarios, row_scenario

    scn = scenario.load("incerti2012")
    keys = ["modes.pid.kp", "drive.R", "drive.L"]
    rows = [{"row": i, "modes.pid.kp": kp, "drive.R": R, "drive.L": "9 mH"}
            for i, (kp, R) in enumerate([(40.0, 1.5), (80.0, 2.0), (40.0, 2.0), (160.0, 3.0)])]
    rs = RowScenarios(scn, keys)
    got = [rs(r) for r in rows]
    assert rs.fast is True
    for r, g in zip(rows, got):
        assert g.model_dump() == row_scenario(scn, r, keys).model_dump()
    assert got[1].drive.L == pytest.approx(9e-3) and got[3].modes["pid"].kp == 160.0
    assert RowScenarios(scn, ["simulation.dt"]).fast is False
    with pytest.raises(Exception, match="drive.R"):
        rs({"row": 9, "modes.pid.kp": 40.0, "drive.R": -1.0, "drive.L": "9 mH"})

