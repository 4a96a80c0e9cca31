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


@pytest.mark.parametrize("elem,match", [
    ("drive.friction.joints.B={coulomb=0.01}", r"drives.A: friction on the mechanism's joints .* is one-axis only"),
])
def test_what_stays_one_axis_in_the_drive_train_is_one_line(elem, match):
    with pytest.raises(MjbenchError, match=match):
        S.make_machine(S.load("fivebar", [elem]), "pid")


# ---------------------------------------------------------------- the motors' Coulomb friction per axis
FC = 0.05  # [N·m] on each motor shaft
R_A, KM_A, Z_A, LAM_A = 0.4, 0.08, 50.0, 2e-5  # arm2r's [drive] (the shoulder A)


def _arm_open(frac):
    """arm2r in a horizontal plane, the shoulder's motor at frac × its breakaway voltage R·F_C/k_m, the
    elbow's at 0 V (a mode's table per axis)."""
    v = frac * FC * R_A / KM_A
    return S.load("arm2r", [f"drive.friction={{coulomb={FC}}}", "mechanism.gravity=[0.0, 0.0]",
                            f'modes.open={{type="open", voltage={v!r}}}', "modes.open.axes.B.voltage=0.0"])


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_an_axis_below_its_breakaway_voltage_sticks(backend):
    """k_m·V/R < F_C: the motor cannot break away.  MuJoCo's friction constraint holds it; the reduced
    model's regularised law −F_C·tanh(z·q̇/v_ε) lets it creep at ≈ (v_ε/z)·artanh(k_m·I/F_C)."""
    scn = _arm_open(0.8)
    m = S.make_machine(scn, "open")
    tr = simulate(m, backend, 0.3, record_dt=1e-3, loop="python")
    w = np.abs(tr["A:crank_speed_rad_s"][-1])
    if backend == "multibody":
        assert w <= 1e-4, w
    else:
        T = m.mechanism.model_form().P.T
        creep = T[0, 5] / T[0, 4] * math.atanh(KM_A * tr["A:current_A"][-1] / FC)
        assert w <= 1.05 * creep and creep < 5e-3, (w, creep)


def test_above_it_the_axis_slides_at_the_closed_form_speed_on_both_backends():
    """k_m·V/R > F_C: the shoulder slides at the steady speed where k_m·I = F_C + λ·ω_m and
    V = R·I + k_m·ω_m, ω = ω_m/z (the elbow's motor, at 0 V, holds it)."""
    scn = _arm_open(1.5)
    v = 1.5 * FC * R_A / KM_A
    want = (v - R_A * FC / KM_A) / (KM_A + R_A * LAM_A / KM_A) / Z_A
    for b in ("reduced", "multibody"):
        tr = simulate(S.make_machine(scn, "open"), b, 0.3, record_dt=1e-3, loop="python")
        assert tr["A:crank_speed_rad_s"][-1] == pytest.approx(want, rel=1e-6), b
        assert np.max(np.abs(tr["B:crank_speed_rad_s"])) < 0.05 * want, b


def test_the_fivebar_with_motor_friction_agrees_between_the_backends():
    """Under PID along the path (rest between segments: the regularised stick against MuJoCo's
    constraint, measured 1.3e-3 of the peak speed over 1 s)."""
    pytest.importorskip("numba")
    scn = S.load("fivebar", ["drive.friction={coulomb=0.02}"])
    r, m = (simulate(S.make_machine(scn, "pid"), b, 0.6, record_dt=1e-3) for b in ("reduced", "multibody"))
    assert "friction" in S.make_machine(scn, "pid").mechanism.describe()["drivetrain"]["E"]
    for a in ("A", "E"):
        w = m[f"{a}:crank_speed_rad_s"]
        assert np.max(np.abs(r[f"{a}:crank_speed_rad_s"] - w)) <= 2e-3 * np.max(np.abs(w)), a


# ---------------------------------------------------------------- a Stribeck drop per axis
FS, VS = 0.08, 20.0  # breakaway [N·m] and Stribeck speed [rad/s] on the shoulder's motor (F_C = FC)


def _stribeck(frac, gear):
    v = frac * FS * R_A / KM_A
    sets = [f"drives.A.friction={{coulomb={FC}, breakaway={FS}, stribeck_speed={VS}}}", "mechanism.gravity=[0.0, 0.0]",
            f'modes.open={{type="open", voltage={v!r}}}', "modes.open.axes.B.voltage=0.0"]
    return S.load("arm2r", sets + (["drives.A.gear={stiffness=1e5}"] if gear else [])), v


@pytest.mark.parametrize("gear", [False, True], ids=["rigid", "compliant"])
def test_a_stribeck_axis_sticks_below_its_breakaway_and_slides_at_the_closed_form_speed(gear):
    """F_C < k_m·V/R < F_S: the motor cannot break away (it would slide with Coulomb friction alone);
    at 1.5 × the breakaway voltage it slides at the speed where k_m·I = F(ω_m) + λ·ω_m, V = R·I + k_m·ω_m,
    F(ω) = F_C + (F_S − F_C)·exp(−(ω/v_S)²) (brentq) — with a rigid gear (the friction on the input
    joint) and behind a compliant one (on the motor's own hinge / coordinate), both backends."""
    from scipy.optimize import brentq

    scn, _ = _stribeck(0.8, gear)
    assert FC * R_A / KM_A < 0.8 * FS * R_A / KM_A  # above the Coulomb level
    for b, tol in (("multibody", 5e-4), ("reduced", 1e-2)):  # (MuJoCo's soft constraint; the regularised law)
        tr = simulate(S.make_machine(scn, "open"), b, 0.3, record_dt=1e-3, loop="python")
        assert abs(tr["A:crank_speed_rad_s"][-1]) <= tol, b
    scn, v = _stribeck(1.5, gear)
    wm = brentq(lambda w: KM_A * (v - KM_A * w) / R_A - FC - (FS - FC) * math.exp(-(w / VS) ** 2) - LAM_A * w,
                1e-9, v / KM_A)
    for b in ("reduced", "multibody"):
        m = S.make_machine(scn, "open")
        tr = simulate(m, b, 0.3, record_dt=1e-3, loop="python")
        assert tr["A:crank_speed_rad_s"][-1] == pytest.approx(wm / Z_A, rel=1e-6), b
        assert m.mechanism.describe()["drivetrain"]["A"]["friction"]["breakaway_Nm"] == FS
