"""The example scripts of scripts/examples/ run as a user runs them (a fresh interpreter, in an
empty folder), and what they write holds against computations made here by other means: the
record re-read from the CSV files, the closed form of a DC motor and a flywheel (matrix
exponential), a single run against the sweep's batched one."""
import csv
import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import mjbench as mjb

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "scripts" / "examples"
NAMES = ["acceptance.py", "machine_in_code.py", "sweep.py"]


def run(script: str, cwd: Path, *args: str) -> str:
    """Run an example in ``cwd``; its standard output (a failure shows its stderr)."""
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    p = subprocess.run([sys.executable, str(EXAMPLES / script), *args], cwd=cwd, env=env, capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, f"{script} failed:\n{p.stderr[-4000:]}"
    return p.stdout


def columns(path: Path) -> dict:
    """A CSV file as {column: array}; numeric columns as floats."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = {}
    for k in rows[0]:
        vals = [r[k] for r in rows]
        try:
            out[k] = np.array([float(v) for v in vals])
        except ValueError:
            out[k] = np.array(vals)
    return out


def test_examples_are_listed():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == NAMES
    api, readme = (ROOT / "docs" / "api.md").read_text(), (ROOT / "README.md").read_text()
    for name in NAMES:
        assert f"scripts/examples/{name}" in api and f"scripts/examples/{name}" in readme, name


def test_acceptance_script(tmp_path):
    printed = float(run("acceptance.py", tmp_path).strip().splitlines()[-1])
    out = tmp_path / "out_api"
    assert sorted(os.listdir(out)) == ["fig4.png", "manifest.json", "metrics.json", "trajectory_multibody.csv",
                                       "trajectory_reduced.csv"]
    metrics = json.loads((out / "metrics.json").read_text())
    mb = metrics["backends"]["multibody"]
    assert printed == mb["mean_crank_speed_rad_s"] and 25.0 < printed < 30.0   # 27.14 rad/s
    # the printed mean, recomputed from the CSV (full precision): time mean over the second half
    tr_mb, tr_red = columns(out / "trajectory_multibody.csv"), columns(out / "trajectory_reduced.csv")
    t, w = tr_mb["t_s"], tr_mb["crank_speed_rad_s"]
    half = t >= mb["steady_from_s"]
    assert np.trapezoid(w[half], t[half]) / (t[half][-1] - t[half][0]) == pytest.approx(printed, rel=1e-12)
    # both backends, from their CSV files
    diff = np.max(np.abs(w - tr_red["crank_speed_rad_s"])) / np.max(np.abs(tr_red["crank_speed_rad_s"]))
    assert diff == pytest.approx(metrics["multibody_vs_reduced"]["max_rel_diff"], rel=1e-9) and diff < 1e-5
    man = json.loads((out / "manifest.json").read_text())
    assert man["overrides"] == ["drive.R=2.2 ohm"] and man["scenario"]["drive"]["R"] == 2.2


def test_machine_in_code_against_the_closed_form(tmp_path):
    run("machine_in_code.py", tmp_path, "out")
    # the script's machine: flywheel 0.05 kg·m², R 0.5 Ω, L 1 mH, k_m 0.06, J_m 5e-5, z 20, λ 1e-5, 12 V step
    J, R, L, km, Jm, z, lam, V = 0.05, 0.5, 1e-3, 0.06, 5e-5, 20.0, 1e-5, 12.0
    Jt, zk = J + Jm * z**2, z * km
    M = np.zeros((3, 3))
    M[:2, :2] = [[-lam * z**2 / Jt, zk / Jt], [-zk / L, -R / L]]
    M[1, 2] = V / L
    for b in ("multibody", "reduced"):
        tr = columns(tmp_path / "out" / "run" / f"trajectory_{b}.csv")
        idx = np.arange(0, len(tr["t_s"]), 10)
        exact = np.array([expm(M * t)[:2, 2] for t in tr["t_s"][idx]])   # (ω, I) from rest
        w_err = np.max(np.abs(tr["crank_speed_rad_s"][idx] - exact[:, 0])) / np.max(exact[:, 0])
        i_err = np.max(np.abs(tr["current_A"][idx] - exact[:, 1])) / np.max(np.abs(exact[:, 1]))
        assert w_err < 1e-4 and i_err < 1e-4, (b, w_err, i_err)          # 2.0e-5, 1.7e-5: the co-step scheme
    metrics = json.loads((tmp_path / "out" / "run" / "metrics.json").read_text())
    assert metrics["multibody_vs_reduced"]["max_rel_diff"] < 1e-9         # one hinge: the same equation (9e-17)
    steady = columns(tmp_path / "out" / "steady_speeds.csv")
    assert list(steady["voltage_V"]) == [6.0, 12.0, 24.0]
    w_inf = zk * steady["voltage_V"] / (zk**2 + R * lam * z**2)
    assert np.allclose(steady["final_crank_speed_rad_s"], w_inf, rtol=1e-9, atol=0)
    assert np.array_equal(steady["closed_form_rad_s"], w_inf)


def test_sweep_rows_verified_and_equal_to_single_runs(tmp_path):
    run("sweep.py", tmp_path, "sw")
    rows = columns(tmp_path / "sw" / "results.csv")
    kps, Rs = [40, 80, 160], ["1.5 ohm", "2 ohm", "2.5 ohm"]
    assert sorted(zip(rows["modes.pid.kp"], rows["drive.R"])) == sorted(itertools.product(map(float, kps), Rs))
    assert set(rows["status"]) == {"ok"}
    ver = columns(tmp_path / "sw" / "verify.csv")
    best = np.argsort(rows["chi_window"])[:2]                              # the two smallest χ, re-run on MuJoCo
    assert list(ver["row"]) == list(rows["row"][best])
    assert np.all(np.abs(ver["multibody"] - ver["reduced"]) < 1e-5 * np.abs(ver["reduced"]))   # 2e-7
    # one row of the batch against a single run of the same values
    i = int(np.flatnonzero((rows["modes.pid.kp"] == 80) & (rows["drive.R"] == "2 ohm"))[0])
    one = mjb.load("incerti2012", **{"modes.pid.kp": 80, "drive.R": "2 ohm"}).simulate("pid", "reduced", 0.5)
    m = one.metrics["backends"]["reduced"]
    for key in ("chi_window", "peak_current_A", "mean_crank_speed_rad_s", "energy_elec_J"):
        assert rows[key][i] == pytest.approx(m[key], rel=1e-12), key
