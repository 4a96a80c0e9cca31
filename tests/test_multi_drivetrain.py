"""Drive-train elements per axis on a machine with several motors (docs/linkages.md §8.2): each
axis's PWM bridge, encoder and current loop are its own, in the kernel's per-axis slots.

Independent paths: the encoder's closed form (each measured angle a whole number of counts
2π/(lines·edges) on the motor shaft), the other backend, and the current loop's own purpose (the
current follows its reference).  CPython loops over 0.05 s (no compilation)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.errors import MjbenchError

T_END = 0.05
SETS = ['drive.pwm={frequency="20 kHz", v_bus=24, model="switching"}',  # every axis
        'drives.A.encoder={lines=500}',  # the shoulder only
        'drives.E.current_loop={bandwidth="2 kHz"}']  # the other axis only


@pytest.fixture(scope="module")
def runs():
    scn = S.load("fivebar", SETS)
    return {b: simulate(S.make_machine(scn, "pid"), b, T_END, record_dt=1e-4, loop="python")
            for b in ("reduced", "multibody")}


def test_each_axis_records_its_own_elements(runs):
    tr = runs["reduced"]
    cols = set(tr.columns)
    for a in ("A", "E"):  # the switching bridge on both
        assert {f"{a}:voltage_bridge_V", f"{a}:current_min_A", f"{a}:current_max_A"} <= cols
    assert "A:angle_meas_rad" in cols and "E:angle_meas_rad" not in cols
    assert "E:current_ref_A" in cols and "A:current_ref_A" not in cols
    assert set(tr.meta["drivetrain"]) == {"A", "E"} and "current_loop" in tr.meta["drivetrain"]["E"]


def test_the_encoder_counts_whole_steps_on_its_own_axis(runs):
    tr = runs["reduced"]
    z = 10.0  # the five-bar's gearbox (scenario)
    counts = tr["A:angle_meas_rad"] * z / (2.0 * math.pi / (500 * 4))
    assert np.max(np.abs(counts - np.round(counts))) < 1e-6
    # and it measures that axis's angle, to one count
    err = np.abs(tr["A:angle_meas_rad"] - tr["A:crank_angle_rad"]) * z
    assert np.max(err) <= 2.0 * math.pi / 2000 * 0.5 + 1e-12


def test_the_current_loop_makes_its_axis_follow_the_reference(runs):
    tr = runs["reduced"]
    i, iref = tr["E:current_A"], tr["E:current_ref_A"]
    late = tr["t_s"] > 0.01
    assert np.max(np.abs(iref[late])) > 0.1  # it is asked for something
    assert np.sqrt(np.mean((i[late] - iref[late]) ** 2)) <= 0.1 * np.max(np.abs(iref[late]))


def test_both_backends_agree_with_the_elements_per_axis(runs):
    r, m = runs["reduced"], runs["multibody"]
    for a in ("A", "E"):
        w = r[f"{a}:crank_speed_rad_s"]
        assert np.max(np.abs(m[f"{a}:crank_speed_rad_s"] - w)) <= 1e-6 * np.max(np.abs(w))


@pytest.mark.parametrize("elem", ['drive.gear={backlash="0.1 deg"}', "drive.friction={coulomb=0.01}"])
def test_mechanical_elements_of_several_axes_are_one_line(elem):
    with pytest.raises(MjbenchError, match=r"drives.A: a compliant gear .* or dry friction .* is one-axis only"):
        S.make_machine(S.load("fivebar", [elem]), "pid")
