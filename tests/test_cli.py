"""`mjbench run` / `mjbench list` end to end (short runs)."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mjbench.cli import main


def test_run_both_backends_writes_complete_results(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "incerti2012", "--mode", "pid", "--t-end", "0.5", "--out", str(out)]) == 0
    files = sorted(os.listdir(out))
    assert files == ["fig4.png", "manifest.json", "metrics.json", "trajectory_multibody.csv",
                     "trajectory_reduced.csv"]
    header = (out / "trajectory_multibody.csv").read_text().splitlines()[0].split(",")
    for col in ("t_s", "crank_angle_rad", "crank_speed_rad_s", "motor_speed_rad_s", "current_A",
                "voltage_V", "power_mech_W", "power_elec_W"):
        assert col in header
    data = np.loadtxt(out / "trajectory_reduced.csv", delimiter=",", skiprows=1)
    assert data[-1, 0] == pytest.approx(0.5)
    met = json.loads((out / "metrics.json").read_text())
    assert met["multibody_vs_reduced"]["max_rel_diff"] < 1e-3
    assert 0 < met["backends"]["multibody"]["chi_window"] < 1
    man = json.loads((out / "manifest.json").read_text())
    import mujoco

    assert man["scenario"]["drive"]["k_m"] == 0.48 and man["versions"]["mujoco"] == mujoco.__version__  # (pyproject pins it)
    assert (out / "fig4.png").stat().st_size > 10000


def test_single_backend_and_set(tmp_path):
    out = tmp_path / "r"
    assert main(["run", "incerti2012", "--mode", "open", "--backend", "reduced", "--t-end", "0.3",
                 "--set", "modes.open.voltage=20", "--out", str(out), "--quiet", "--no-figure"]) == 0
    assert sorted(os.listdir(out)) == ["manifest.json", "metrics.json", "trajectory.csv"]
    data = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    assert np.all(data[1:, 6] == 20.0)


def test_bad_input_is_a_clear_error_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "incerti2012", "--set", "mechanism.a=0.5", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "cannot make the full turn" in err or "cannot be assembled" in err
    assert not out.exists() or not any(out.iterdir())
    assert main(["run", "incerti2012", "--set", "drive.R=-1", "--out", str(out)]) == 2
    assert "drive.R" in capsys.readouterr().err


def test_console_script_list():
    exe = os.path.join(os.path.dirname(sys.executable), "mjbench")
    r = subprocess.run([exe, "list"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "incerti2012" in r.stdout
