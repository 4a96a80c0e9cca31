"""A mode's controller per axis: ``[modes.NAME.axes.JOINT]`` keys over ``[modes.NAME]`` (gains,
set-point) on a machine with several motors (docs/linkages.md §8.2), and a run of such a machine
re-loaded from its manifest (the axes' drives and controllers included).

Independent paths: each PI loop's own purpose (its axis settles at its own set-point, whatever the
others do) and a re-run from the manifest, bit for bit."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench import validation
from mjbench.backends import simulate
from mjbench.errors import MjbenchError

ARM3R = str(Path(__file__).parent / "data" / "multi" / "arm3r.toml")
OWN = ["modes.pid.axes.B.omega_crank=0.0", 'modes.pid.axes.C={omega_crank = -2.0, kp = 0.5}']


def test_each_axis_runs_its_own_table_over_the_modes():
    scn = S.load(ARM3R, OWN)
    m = S.make_machine(scn, "pid")
    (a, _), (b, _), (c, _) = m.controllers
    assert (a.kp, b.kp, c.kp) == (1.0, 1.0, 0.5) and a.ki == b.ki == c.ki == 40.0
    tr = simulate(m, "reduced", 0.2, record_dt=1e-3, loop="python")
    for ax, want in (("A", 1.0), ("B", 0.0), ("C", -2.0)):  # each PI loop holds its own set-point
        w = tr[f"{ax}:crank_speed_rad_s"]
        assert abs(w[-1] - want) <= 0.02, (ax, w[-1])
    assert np.ptp(tr["C:crank_angle_rad"]) > 0.3


def test_a_run_reloads_from_its_resolved_scenario_with_its_axes():
    """The resolved scenario (what manifest.json keeps) loads back to the same axes' drives and
    controllers: the arm's smaller elbow motor and the per-axis set-points."""
    for name, sets in ((ARM3R, OWN), ("arm2r", [])):
        scn = S.load(name, sets)
        again = validation.validate(scn.resolved(), "resolved")
        assert again.resolved() == scn.resolved()
        assert {k: d.model_dump() for k, d in again.drives.items()} == {k: d.model_dump() for k, d in scn.drives.items()}
        assert again.mode_axes.keys() == scn.mode_axes.keys()
        a = simulate(S.make_machine(scn, "pid"), "reduced", 0.01, record_dt=1e-4, loop="python")
        b = simulate(S.make_machine(again, "pid"), "reduced", 0.01, record_dt=1e-4, loop="python")
        np.testing.assert_array_equal(a.data, b.data)
    assert "B" in S.load("arm2r").resolved()["drives"]  # (a table, not the Params' repr)


@pytest.mark.parametrize("sets,match", [
    (["modes.pid.axes.D.kp=1.0"], r"modes.pid.axes.D: not an input joint; the inputs are A, B, C"),
    (['modes.pid.axes.B.type="smc"'], r"modes.pid.axes.B.type: an axis runs its mode's controller"),
    (["modes.pid.axes.B.kp=true"], r"modes.pid.axes.B.kp"),
])
def test_a_wrong_axis_table_is_one_line(sets, match):
    with pytest.raises(MjbenchError, match=match):
        S.load(ARM3R, sets)


def test_one_controller_for_all_axes_and_one_input_take_no_axis_tables():
    with pytest.raises(MjbenchError, match=r"modes.ct.axes: 'computed_torque' is one controller for all axes"):
        S.load("fivebar", ["modes.ct.axes.A.wn=3.0"])
    with pytest.raises(MjbenchError, match=r"per-axis tables are for a mechanism with several inputs"):
        S.load("sixbar-watt2", ["modes.pi.axes.A.kp=1.0"])


def test_tune_keeps_an_axis_own_keys_but_searches_one_set_of_gains():
    from mjbench.tune import Problem

    with pytest.raises(MjbenchError, match=r"tune: modes.pid.axes.C sets kp: tune searches one set of kp, ki"):
        Problem(S.load(ARM3R, OWN), "pid", objective="ee_rms")


def test_a_sweep_row_sets_an_axis_key_or_the_modes_key_under_the_axes_own():
    """The sweep's rows (mjbench/sweep/rows.py): an axis's key, or the mode's key that every axis
    without its own value follows — the scenario the whole validation gives."""
    from mjbench.sweep.rows import RowScenarios

    scn = S.load(ARM3R, OWN)
    rows = RowScenarios(scn, ["modes.pid.axes.C.kp"])
    for v in (0.3, 0.7):
        r = rows({"modes.pid.axes.C.kp": v})
        assert r.mode_axes["pid"]["C"].kp == v and r.mode_axes["pid"]["C"].omega_crank == -2.0
        assert r.modes["pid"].kp == 1.0 and r.mode_axes["pid"]["B"].kp == 1.0
    rows = RowScenarios(scn, ["modes.pid.ki"])
    for v in (20.0, 30.0):
        r = rows({"modes.pid.ki": v})
        assert r.modes["pid"].ki == r.mode_axes["pid"]["B"].ki == r.mode_axes["pid"]["C"].ki == v
        assert r.mode_axes["pid"]["C"].kp == 0.5 and r.mode_axes["pid"]["B"].omega_crank == 0.0
