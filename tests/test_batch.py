"""Batched multibody backend: N simulations stepped together equal N single runs (issue 7)."""

import numpy as np
import pytest

import controllers
from mjbench import scenario
from mjbench.backends import batch, multibody
from mjbench.drive import DCMotorDrive
from mjbench.errors import ParameterError

T_END = 0.12  # s: 1200 co-steps, enough for the PID start-up, limiter and anti-windup to act


def _machine(overrides=(), mode="pid"):
    scn = scenario.load("incerti2012", overrides)
    return scenario.make_machine(scn, mode)


# per-simulation gains, voltages, masses/inertias, geometry-free drive constants and set-points
VARIANTS = [
    ((), "pid"),
    (("modes.pid.kp=55", "modes.pid.kd=0.03"), "pid"),
    (("modes.pid.ki=50", "drive.R=2.5", "drive.k_m=0.45"), "pid"),
    (("mechanism.m2=3.0", "mechanism.J_G3=0.025"), "pid"),
    (("modes.pid.omega0=25", "drive.J_m=2e-3", "drive.lam=0.05"), "pid"),
    (("modes.pid.kp_ramp=false", "modes.pid.kp=2.0"), "pid"),
]


def test_batch_equals_single_runs():
    machines = [_machine(o, m) for o, m in VARIANTS[:5]]
    res = batch.simulate(machines, T_END, record_dt=5e-4, nthread=2)
    assert not res.diverged.any()
    for i, (o, m) in enumerate(VARIANTS[:5]):
        single = multibody.simulate(_machine(o, m), T_END, record_dt=5e-4)
        tb = res.trajectory(i)
        assert tb.n == single.n
        # q, q̇, q̈, φ̇, I, V, torque, powers: same operations on the same numbers
        diff = np.max(np.abs(tb.data[:, :10] - single.data[:, :10]))
        assert diff <= 1e-12 * max(1.0, np.max(np.abs(single.data[:, :10])))
        # closure column from site positions vs efc_pos: same quantity
        assert np.max(np.abs(tb.closure - single.closure)) < 1e-12


def test_open_loop_per_sim_voltage_and_threads():
    machines = [_machine((f"modes.open.voltage={v}",), "open") for v in (10.0, 25.0, 40.0)]
    r1 = batch.simulate(machines, 0.05, record_dt=1e-3, nthread=1)
    r2 = batch.simulate(machines, 0.05, record_dt=1e-3, nthread=2)
    np.testing.assert_array_equal(r1.data, r2.data)  # bit-identical at any thread count
    single = multibody.simulate(machines[2], 0.05, record_dt=1e-3)
    np.testing.assert_allclose(r1.trajectory(2).data[:, :10], single.data[:, :10], rtol=0, atol=1e-12)
    # one simulation through mujoco.batch (no single-run fast path) is the same too
    one = batch.simulate(machines[2:], 0.05, record_dt=1e-3, single_fast_path=False)
    np.testing.assert_allclose(one.trajectory(0).data[:, :10], single.data[:, :10], rtol=0, atol=1e-12)
    # higher voltage → faster start-up
    w = r1.column("motor_speed_rad_s")[:, -1]
    assert w[0] < w[1] < w[2]


def test_mixed_controller_flags_rejected():
    ms = [_machine(VARIANTS[0][0]), _machine(VARIANTS[5][0])]  # kp_ramp true vs false
    with pytest.raises(ParameterError, match="kp_ramp"):
        batch.simulate(ms, 0.01)


def test_divergence_isolated():
    """A diverging simulation is flagged and frozen; the others match their single runs."""
    good = _machine(mode="open")
    bad = _machine(("drive.v_max=1e9", "modes.open.voltage=1e7"), "open")  # runaway current
    res = batch.simulate([good, bad], 0.05, record_dt=1e-3)
    assert res.diverged.tolist() == [False, True]
    assert "diverged at t" in res.messages[1] and res.nrows[1] < res.nrows[0]
    single = multibody.simulate(_machine(mode="open"), 0.05, record_dt=1e-3)
    np.testing.assert_array_equal(res.trajectory(0).data[:, :10], single.data[:, :10])


def test_stack_objects_vectorises_pid_and_drive():
    pids = [controllers.PID(kp, 32.0, 0.015, omega0=30.0, kp_ramp=True, v_limit=48.0) for kp in (60.0, 80.0)]
    st = batch.stack_objects(pids)
    assert isinstance(st.kp, np.ndarray) and st.kp.tolist() == [60.0, 80.0] and st.ki == 32.0
    ramp = batch.stack_objects([controllers.PID(80.0, 32.0, 0.015, omega0=30.0, kp_ramp=True, t_ramp_max=tm)
                                for tm in (0.2, 1.0)])
    ramp.reset()
    np.testing.assert_array_equal(ramp.gain_p(0.5), [80.0 * 0.2, 80.0 * 0.5])
    # per-simulation output limits: clipped (and frozen) row by row
    # (a diverged, NaN row must not keep the others from being clipped)
    vl = batch.stack_objects([controllers.PID(100.0, 0.0, 0.0, omega0=30.0, v_limit=v) for v in (10.0, 48.0, 48.0)])
    vl.reset()
    y = controllers.Measurement()
    y.set(0.0, np.zeros(3), np.array([0.0, 0.0, np.nan]), np.zeros(3), np.zeros(3))
    np.testing.assert_array_equal(vl(0.0, y), [10.0, 48.0, np.nan])
    drv = batch.stack_drives([DCMotorDrive(R=2.0, L=9e-3), DCMotorDrive(R=2.0, L=0.0)])
    assert drv.R == 2.0 and drv.L.tolist() == [9e-3, 0.0]
    drv.prepare(1e-4)
    # L = 0 row: algebraic current; L > 0 row: exact exponential decay
    I = drv.current_step(np.zeros(2), np.array([10.0, 10.0]), np.zeros(2), 1e-4)
    assert I[1] == pytest.approx(5.0) and 0 < I[0] < 5.0 * (1 - np.exp(-1e-4 * 2 / 9e-3)) + 1e-12


def test_model_based_smc_per_simulation_mechanisms():
    """Seed 004: the sliding-mode controller evaluates the reduced model of its mechanism; with a
    different mass per simulation it gets a PerSimulation stand-in — still equal to single runs."""
    pytest.importorskip("controllers.smc")
    m4 = scenario.get(scenario.load("yigit2023"), "mechanism.m4")
    sets = [("modes.smc.lam=80.0",), ("modes.smc.K=500.0", f"mechanism.m4={1.1 * m4}")]
    ms = [scenario.make_machine(scenario.load("yigit2023", s), "smc") for s in sets]
    res = batch.simulate(ms, 0.05, record_dt=1e-3)
    assert isinstance(batch.stack_objects([m.controller for m in ms]).mechanism, batch.PerSimulation)
    for i, s in enumerate(sets):
        single = multibody.simulate(scenario.make_machine(scenario.load("yigit2023", s), "smc"), 0.05, record_dt=1e-3)
        np.testing.assert_allclose(res.trajectory(i).data[:, :10], single.data[:, :10], rtol=1e-12, atol=1e-12)
