"""Batched multibody backend: N simulations stepped together equal N single runs (issue 7)."""

import numpy as np
import pytest

from mjbench import scenario
from mjbench.backends import batch, multibody

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
    # a batch of one simulation is the same too
    one = batch.simulate(machines[2:], 0.05, record_dt=1e-3)
    np.testing.assert_allclose(one.trajectory(0).data[:, :10], single.data[:, :10], rtol=0, atol=1e-12)
    # higher voltage → faster start-up
    w = r1.column("motor_speed_rad_s")[:, -1]
    assert w[0] < w[1] < w[2]


def test_mixed_controller_flags_are_independent_runs():
    """Runs of a batch are independent compositions: a K_p·t PID next to a constant-gain one (the
    old stacked controller refused this) each equal their single run, bit for bit."""
    ms = [_machine(VARIANTS[0][0]), _machine(VARIANTS[5][0])]  # kp_ramp true vs false
    res = batch.simulate(ms, 0.02, record_dt=1e-3)
    for i in range(2):
        single = multibody.simulate(_machine(VARIANTS[(0, 5)[i]][0]), 0.02, record_dt=1e-3)
        np.testing.assert_array_equal(res.trajectory(i).data[:, :10], single.data[:, :10])
    assert not np.array_equal(res.trajectory(0).voltage, res.trajectory(1).voltage)


def test_divergence_isolated():
    """A diverging simulation is flagged and frozen; the others match their single runs."""
    good = _machine(mode="open")
    bad = _machine(("drive.v_max=1e9", "modes.open.voltage=1e7"), "open")  # runaway current
    res = batch.simulate([good, bad], 0.05, record_dt=1e-3)
    assert res.diverged.tolist() == [False, True]
    assert "diverged at t" in res.messages[1] and res.nrows[1] < res.nrows[0]
    single = multibody.simulate(_machine(mode="open"), 0.05, record_dt=1e-3)
    np.testing.assert_array_equal(res.trajectory(0).data[:, :10], single.data[:, :10])


def test_per_run_parameters_limits_and_drives():
    """Every run of a batch gets its own controller parameters and state (nothing shared): output
    limits 10 V and 48 V clip their own run (the anti-windup acting on each), a drive with L = 0
    (algebraic current) runs next to L = 9 mH; each run equals its single run."""
    from mjbench.kernel import Program, control_every
    from mjbench.backends.multibody import MultibodyPlant, build_model, DEFAULT_OPTIONS

    sets = [("modes.pid.v_limit=10",), ("modes.pid.v_limit=48",), ("modes.pid.v_limit=48", "drive.L=0")]
    ms = [_machine(o) for o in sets]
    res = batch.simulate(ms, 0.05, record_dt=1e-4)
    V = res.column("voltage_V")
    assert np.max(np.abs(V[0])) == pytest.approx(10.0) and 10.0 < np.max(np.abs(V[1])) <= 48.0
    for i, o in enumerate(sets):
        single = multibody.simulate(_machine(o), 0.05, record_dt=1e-4)
        np.testing.assert_array_equal(res.trajectory(i).data[:, :10], single.data[:, :10])
    tr = res.trajectory(2)  # L = 0: I₊ = (V − k_m·φ̇̄)/R, φ̇̄ the mean motor speed over the step
    w_mean = 0.5 * (tr.omega[:-1] + tr.omega[1:])
    np.testing.assert_allclose(tr.current[1:], (tr.voltage[:-1] - 0.48 * w_mean) / 2.0, rtol=1e-9, atol=1e-12)
    # the compositions: one P per run (its own v_limit), a fresh state array per run
    progs = []
    for mc in ms[:2]:
        h = DEFAULT_OPTIONS["timestep"]
        pl = MultibodyPlant(mc, DEFAULT_OPTIONS, build_model(mc, DEFAULT_OPTIONS)[1])
        pl.start()
        progs.append(Program.build(pl, mc, h, control_every(mc.controller, h)))
        pl.finish()
    assert progs[0].key == progs[1].key  # one compiled loop serves both
    (P0, S0), (P1, S1) = ((p.forms["ctrl_0"].P, p.forms["ctrl_0"].state()) for p in progs)
    assert (P0.v_limit, P1.v_limit) == (10.0, 48.0) and S0 is not S1
    assert progs[0].forms["ctrl_0"].state() is not progs[0].forms["ctrl_0"].state()


def test_model_based_smc_per_simulation_mechanisms():
    """Seed 004: the sliding-mode controller evaluates the reduced model of its own machine's
    mechanism (its ``model_form``); with a different mass per simulation each run's controller
    carries its own model parameters — and every run equals its single run."""
    pytest.importorskip("controllers.smc")
    m4 = scenario.get(scenario.load("yigit2023"), "mechanism.m4")
    sets = [("modes.smc.lam=80.0",), ("modes.smc.K=500.0", f"mechanism.m4={1.1 * m4}")]
    ms = [scenario.make_machine(scenario.load("yigit2023", s), "smc") for s in sets]
    res = batch.simulate(ms, 0.05, record_dt=1e-3)
    forms = [m.controller.form(1e-3, m) for m in ms]
    models = [f.fn_args[0] for f in forms]
    assert models[0].law is models[1].law  # one law (one compiled loop) ...
    J = [m.law(1.0, 5.0, 0.0, m.P)[0] for m in models]  # ... with each machine's own model: ℑ(q = 1)
    assert J[1] > J[0]
    for m, j in zip(ms, J):
        assert j == pytest.approx(float(m.mechanism.reduced(1.0)[0]), rel=1e-9)
    for i, s in enumerate(sets):
        single = multibody.simulate(scenario.make_machine(scenario.load("yigit2023", s), "smc"), 0.05, record_dt=1e-3)
        np.testing.assert_array_equal(res.trajectory(i).data[:, :10], single.data[:, :10])
