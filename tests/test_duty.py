"""Duty figures (mjbench.metrics.duty): RMS and peak current, motor torque, gearbox output torque,
time at the current and voltage limits over the steady state — against hand computations on known
signals and against the closed forms of a motor driving a flywheel."""
import math

import numpy as np
import pytest

import mjbench as mjb
from mjbench import metrics as M
from mjbench.drive import DCMotorDrive
from mjbench import MjbenchWarning
from mjbench.trajectory import Trajectory


def _traj(t, **cols):
    tr = Trajectory(len(t), "test")
    tr.data[:] = 0.0
    tr.data[:, 0] = t
    for k, v in cols.items():
        tr.data[:, tr.index[k]] = v
    tr.n = len(t)
    return tr


def test_rms_peak_and_limits_against_hand_values():
    t = np.linspace(0.0, 2.0, 20001)  # 1000 samples per period: a fraction of time to ±2e-3
    current = 3.0 + 4.0 * np.sin(2 * np.pi * 5.0 * t)
    voltage = np.clip(60.0 * np.sin(2 * np.pi * 5.0 * t), -48.0, 48.0)
    tr = _traj(t, current_A=np.clip(current, -6.5, 6.5), voltage_V=voltage)
    drive = DCMotorDrive(R=1.0, L=1e-3, k_m=0.5, J_m=1e-4, J_a=0.0, J_b=0.0, z=10.0, lam=0.0, v_max=48.0, i_max=6.5)
    d = M.duty(tr, 1.0, drive)
    assert d["duty_window_s"] == [1.0, 2.0]
    # I = 3 + 4 sin, clipped at 6.5 A: the clipped RMS by quadrature of the same closed form
    tt = np.linspace(0, 0.2, 200001)
    ref = np.sqrt(np.mean(np.minimum(3 + 4 * np.sin(2 * np.pi * 5 * tt), 6.5) ** 2))
    assert d["current_rms_steady_A"] == pytest.approx(ref, rel=2e-3)
    assert d["current_peak_steady_A"] == 6.5
    assert d["torque_motor_rms_steady_Nm"] == pytest.approx(0.5 * ref, rel=2e-3)
    # |I| within 0.5 % of 6.5 A where 3 + 4 sin ≥ 6.5·(1 − 0.005): a fraction 1/2 − asin(s)/π of the time
    s = (6.5 * (1 - M.CURRENT_LIMIT_TOL) - 3.0) / 4.0
    assert d["current_limit_fraction_steady"] == pytest.approx(0.5 - math.asin(s) / math.pi, abs=2e-3)
    # |60 sin| ≥ 48 where |sin| ≥ 0.8: 1 − 2·asin(0.8)/π of the time
    assert d["voltage_limit_fraction_steady"] == pytest.approx(1 - 2 * math.asin(0.8) / math.pi, abs=2e-3)
    w = M.duty_warnings({"reduced": d})
    assert len(w) == 2 and "6.5 A" in w[0] and "48 V" in w[1] and "steady state t = 1–2 s" in w[0]
    # the controller's own clip, lower than v_max, is the voltage limit
    d2 = M.duty(tr, 1.0, drive, v_limit=30.0)
    assert d2["voltage_limit_V"] == 30.0 and d2["voltage_limit_fraction_steady"] > d["voltage_limit_fraction_steady"]
    # a continuous rating below the RMS current: a warning naming both
    rated = DCMotorDrive(R=1.0, L=1e-3, k_m=0.5, J_m=1e-4, J_a=0.0, J_b=0.0, z=10.0, lam=0.0, i_rated=4.0)
    d4 = M.duty(tr, 1.0, rated)
    assert d4["current_rated_A"] == 4.0
    assert any(f"RMS motor current {d4['current_rms_steady_A']:.3g} A (reduced)" in w and "i_rated = 4 A" in w
               for w in M.duty_warnings({"reduced": d4}))
    # no limits set: no fractions, no warnings
    free = DCMotorDrive(R=1.0, L=1e-3, k_m=0.5, J_m=1e-4, J_a=0.0, J_b=0.0, z=10.0, lam=0.0)
    d3 = M.duty(tr, 1.0, free)
    assert "current_limit_fraction_steady" not in d3 and not M.duty_warnings({"reduced": d3})


def _rotor_machine(i_max=math.inf, efficiency=None, load=-0.5, damping=0.02, voltage=12.0):
    flywheel = mjb.make_mechanism("rotor", J=0.05, load_torque=load, damping=damping)
    gear = {"gear": {"efficiency": efficiency}} if efficiency else {}
    drive = mjb.make_drive(R=0.5, L="0.2 mH", k_m=0.06, J_m="0.5 kg*cm^2", z=20, lam=1e-5, i_max=i_max, **gear)
    return flywheel, drive, mjb.Machine(flywheel, drive, mjb.make_controller("open", voltage=voltage))


@pytest.mark.parametrize("efficiency", [None, 0.8])
def test_gearbox_output_torque_is_what_the_flywheel_receives(efficiency):
    """The torque at the gearbox output (from the motor current) equals what the rotor's own
    equation says it receives, J·α̈ + c·α̇ − T_L, sample by sample; at the end of the run (steady
    speed) the load alone."""
    fly, drive, machine = _rotor_machine(efficiency=efficiency)
    res = mjb.simulate(machine, backend="reduced", t_end=1.0, record_dt="1 ms")
    run, m = res["reduced"], res.metrics["backends"]["reduced"]
    sel = run.time >= m["duty_window_s"][0]
    qd, qdd = run["crank_speed_rad_s"][sel], run["crank_accel_rad_s2"][sel]
    received = fly.J * qdd + fly.damping * qd - fly.load_torque
    assert m["torque_output_rms_steady_Nm"] == pytest.approx(np.sqrt(np.mean(received**2)), rel=2e-3)
    assert m["torque_output_peak_steady_Nm"] == pytest.approx(np.max(np.abs(received)), rel=2e-3)
    steady = fly.damping * qd[-1] - fly.load_torque
    assert m["torque_output_peak_steady_Nm"] == pytest.approx(steady, rel=5e-3)  # at rest speed by then
    assert m["current_rms_steady_A"] == pytest.approx(np.sqrt(np.mean(run["current_A"][sel] ** 2)), rel=1e-12)
    assert res.metrics["warnings"] == []


def test_time_at_the_current_limit_against_the_closed_form():
    """From rest, 24 V, i_max = 5 A, no load: the current sits at i_max (constant acceleration
    a = z·k_m·i_max / (J + J_m·z²)) until the back-EMF leaves less than R·i_max, at
    ω* = (V − R·i_max)/(k_m·z); the run is chosen so that t* = ω*/a is 3/4 of it: half of the
    steady-state window (its second half) is at the limit."""
    V, i_max = 24.0, 5.0
    fly, drive, _ = _rotor_machine(load=0.0, damping=0.0)
    a = drive.z * drive.k_m * i_max / (fly.J + drive.J_m * drive.z**2)
    t_star = (V - drive.R * i_max) / (drive.k_m * drive.z) / a
    fly, drive, machine = _rotor_machine(i_max=i_max, load=0.0, damping=0.0, voltage=V)
    drive.lam = 0.0
    with pytest.warns(MjbenchWarning, match="current is at its limit 5 A"):
        res = mjb.simulate(machine, backend="reduced", t_end=t_star / 0.75, record_dt="0.1 ms")
    m = res.metrics["backends"]["reduced"]
    assert m["current_limit_A"] == i_max
    assert m["current_limit_fraction_steady"] == pytest.approx(0.5, abs=0.02)
    assert any("current is at its limit 5 A" in w for w in res.warnings)


def test_scenario_runs_report_duty_in_metrics_and_summary():
    scn = mjb.load("press-slidercrank")
    res = scn.simulate(backend="reduced", t_end=2.5)
    m = res.metrics["backends"]["reduced"]
    assert m["duty_window_s"] == [2.0, 2.5]
    for k in set(M.DUTY_METRICS) - {"current_rated_A"}:   # (no rating stated)
        assert k in m, k
    assert m["current_limit_A"] == 40.0 and m["voltage_limit_V"] == 48.0
    text = res.summary()
    assert "duty over the steady state t = 2–2.5 s" in text and "RMS / peak gearbox output torque [N·m]" in text
