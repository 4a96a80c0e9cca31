"""Tabulated and batched reduced model (issue 16): the table matches the closed forms, a batch of N
runs equals N single runs, and per-simulation mechanisms, drives and controllers are honoured."""
import numpy as np
import pytest

from mjbench import scenario
from mjbench.backends import reduced, reduced_batch, simulate_many
from mjbench.backends.table import ReducedTable, table_for

T_END = 0.15


def _machine(overrides=(), mode="pid", name="incerti2012"):
    return scenario.make_machine(scenario.load(name, overrides), mode)


# gains, drive constants, set-points, masses, geometry (another table size) and hinge friction
VARIANTS = [
    (),
    ("modes.pid.kp=55", "modes.pid.kd=0.03"),
    ("modes.pid.ki=50", "drive.R=2.5", "drive.k_m=0.45"),
    ("mechanism.m2=3.0", "mechanism.J_G3=0.025"),
    ("modes.pid.omega0=25", "drive.J_m=2e-3", "drive.lam=0.05"),
    ("mechanism.a=0.06", "mechanism.b=0.3"),
    ("mechanism.joint_damping=0.01",),
]


@pytest.mark.parametrize("name", ["incerti2012", "yigit2023", "hulako2025-model1"])
def test_table_matches_closed_forms(name):
    """Independent path: the mechanism's closed forms at random angles (not the table's nodes)."""
    mech = scenario.make_mechanism(scenario.load(name))
    tab = ReducedTable(mech)
    assert tab.max_rel_error <= 1e-9
    q = np.random.default_rng(1).uniform(-20.0, 20.0, 500)  # several turns, both signs
    J, dJ, dEp = mech.reduced(q)
    got = tab(q)
    for exact, approx in ((J, got[0]), (0.5 * dJ, got[1]), (dEp, got[2])):
        scale = np.max(np.abs(exact))
        assert np.max(np.abs(approx - exact)) <= 2e-9 * scale
    if tab.viscous:
        D = mech.reduced_viscous(q)
        assert np.max(np.abs(got[3] - D)) <= 2e-9 * np.max(np.abs(D))


def test_table_run_equals_closed_form_run():
    """The tabulated model's trajectory vs the closed forms' (seed 000 PID, 0.5 s)."""
    a = reduced.simulate(_machine(), 0.5, model="closed")
    b = reduced.simulate(_machine(), 0.5, model="table")
    assert a.meta["model"] == "closed" and b.meta["model"] == "table" and b.meta["table_max_rel_error"] <= 1e-9
    for col in ("crank_speed_rad_s", "current_A", "crank_angle_rad"):
        x, y = a[col], b[col]
        assert np.max(np.abs(x - y)) <= 1e-8 * np.max(np.abs(x))


def test_batch_equals_single_runs():
    """A batch is N independent runs: each equals its single run bit for bit, each with its own
    table (the short-crank linkage needs fewer nodes), gains, drive and mechanism."""
    machines = [_machine(o) for o in VARIANTS]
    res = reduced_batch.simulate(machines, T_END, record_dt=5e-4)
    assert not res.diverged.any() and res.meta["model"] == "table"
    nodes = []
    for i, o in enumerate(VARIANTS):
        single = reduced.simulate(_machine(o), T_END, record_dt=5e-4)
        nodes.append(single.meta["table_nodes"])
        tb = res.trajectory(i)
        assert tb.n == single.n
        np.testing.assert_array_equal(tb.data, single.data)
    assert sorted(set(nodes)) == [1024, 2048] and nodes[5] == 1024  # the short-crank linkage
    # the small-N route (single runs assembled) gives the same record
    few = simulate_many([_machine(o) for o in VARIANTS[:3]], "reduced", T_END, record_dt=5e-4)
    np.testing.assert_array_equal(few.data, res.data[:3])


def test_batch_compiled_equals_cpython_loop():
    """The batch on the compiled loop (threads) and on the CPython loop: the same bits."""
    machines = [_machine(o) for o in VARIANTS]
    res_jit = simulate_many(machines, "reduced", 0.05, loop="compiled")
    res_py = simulate_many([_machine(o) for o in VARIANTS], "reduced", 0.05, loop="python")
    assert res_jit.meta["loop"] == "compiled" and res_py.meta["loop"] == "python"
    np.testing.assert_array_equal(res_jit.data, res_py.data)


def test_batch_quickreturn_smc_and_platform():
    """Untabulated external torque (cutting force) per mechanism group; internal coordinates."""
    for name, mode, ovs in (("yigit2023", "smc", [(), ("mechanism.m4=0.5", "modes.smc.lam=80"), ("mechanism.r3=0.3",)]),
                            ("incerti-belt", "servo", [(), ("mechanism.k=2000",)])):
        res = reduced_batch.simulate([_machine(o, mode, name) for o in ovs], 0.2)
        assert not res.diverged.any()
        for i, o in enumerate(ovs):
            single = reduced.simulate(_machine(o, mode, name), 0.2)
            np.testing.assert_array_equal(res.trajectory(i).data, single.data)


def test_batch_divergence_isolated():
    good = _machine(mode="open")
    bad = _machine(("drive.v_max=1e9", "modes.open.voltage=1e7"), "open")
    res = reduced_batch.simulate([good, bad] * 8, 0.05, record_dt=1e-3)  # 16: the batched route
    assert res.diverged.tolist() == [False, True] * 8
    assert "reduced simulation diverged at t" in res.messages[1]
    single = reduced.simulate(_machine(mode="open"), 0.05, record_dt=1e-3)
    np.testing.assert_array_equal(res.trajectory(0).data[:, :10], single.data[:, :10])


def test_table_cache_and_errors():
    mech = scenario.make_mechanism(scenario.load("incerti2012"))
    assert table_for(mech) is table_for(scenario.make_mechanism(scenario.load("incerti2012")))
    plat = scenario.make_mechanism(scenario.load("incerti-belt"))
    from mjbench.errors import ParameterError
    with pytest.raises(ParameterError, match="cannot be tabulated"):
        ReducedTable(plat)
    with pytest.raises(ParameterError, match="RK4"):
        reduced_batch.simulate([_machine()] * 2, 0.01, options={"method": "solve_ivp"})
