"""The compiled co-step (mjbench.backends.fused, issue 16): the same bits as the Python kernel.

Independent path: the Python kernel (`mjbench.kernel.run` with the PID, open-loop, drive and
tabulated reduced plant objects), run with the compiled loop switched off (MJBENCH_FUSED=0).  Every
variant exercises one branch of the compiled loop: the K_p·t ramp and its bound, the anti-windup,
the voltage limiter, the amplifier current limit, Coulomb friction, hinge friction (the viscous
table), a control period, a non-zero start, the open-loop ramp and another linkage (table size)."""
import numpy as np
import pytest

from mjbench import scenario
from mjbench.backends import _jit, fused, multibody, reduced, reduced_batch
from mjbench.errors import SimulationDiverged

pytestmark = pytest.mark.skipif(not _jit.AVAILABLE, reason="numba not installed (pip install mjbench[fast])")

T_END = 0.3
VARIANTS = [  # (mode, overrides)
    ("pid", ()),                                                          # K_p·t, anti-windup at ±48 V
    ("pid", ("modes.pid.kp_ramp=false", "modes.pid.kp=0.5")),             # constant K_p
    ("pid", ("modes.pid.t_ramp_max=0.1", "modes.pid.kp=300")),            # bounded ramp
    ("pid", ("modes.pid.v_limit=none", "drive.v_max=20")),                # plain clip, no anti-windup
    ("pid", ("modes.pid.v_limit=none", "drive.v_max=inf")),               # no limiter at all
    ("pid", ("drive.i_max=8",)),                                          # amplifier current limit
    ("pid", ("drive.T_0=0.05", "modes.pid.period=5e-4")),                 # Coulomb friction, 2 kHz PID
    ("pid", ("mechanism.joint_damping=0.01", "initial.q0=1.0", "initial.qd0=3.0", "initial.I0=1.0")),
    ("pid", ("mechanism.a=0.06", "mechanism.b=0.3", "drive.z=2.0", "modes.pid.omega0=50")),
    ("open", ()),
    ("open", ("modes.open.t_ramp=0.05", "drive.L=0.0")),
]


# one batch holds one controller law: the variants with the K_p·t ramp, the anti-windup and the
# 0.1 ms period (the Python batch's rule, which the compiled batch follows), and the open-loop ones
BATCHABLE = [o for m, o in VARIANTS if m == "open" or not any(
    k.startswith(("modes.pid.kp_ramp", "modes.pid.v_limit", "modes.pid.period")) for k in o)]


def _machine(mode, overrides, name="incerti2012"):
    return scenario.make_machine(scenario.load(name, overrides), mode)


@pytest.fixture
def python_kernel(monkeypatch):
    def run(fn):
        monkeypatch.setenv("MJBENCH_FUSED", "0")
        try:
            return fn()
        finally:
            monkeypatch.setenv("MJBENCH_FUSED", "1")
    monkeypatch.setenv("MJBENCH_JIT", "1")  # small runs: the compiled loop forced (default: from 2e5 run-steps)
    monkeypatch.setenv("MJBENCH_FUSED", "1")
    return run


@pytest.mark.parametrize("mode,overrides", VARIANTS)
def test_single_run_same_bits(python_kernel, mode, overrides):
    ref = python_kernel(lambda: reduced.simulate(_machine(mode, overrides), T_END, record_dt=2e-4))
    got = reduced.simulate(_machine(mode, overrides), T_END, record_dt=2e-4)
    assert "jit" not in ref.meta and got.meta.pop("jit") == "numba-fused"
    assert got.meta == ref.meta and got.columns == ref.columns and got.n == ref.n == round(T_END / 2e-4) + 1
    np.testing.assert_array_equal(got.data, ref.data)
    if ("drive.i_max=8",) == overrides:  # the limit is active, so the branch is tested
        assert np.max(np.abs(got["current_A"])) == 8.0
    if "drive.v_max=20" in overrides:
        assert np.max(np.abs(got["voltage_V"])) == 20.0


def test_batch_same_bits_as_single_python_runs(python_kernel):
    """One compiled batch over the PID variants (several tables, drives, gains, limits, initial
    states) = the Python kernel's single runs; the open-loop variants likewise in their own batch."""
    assert len(BATCHABLE) >= 7
    for mode in ("pid", "open"):
        vs = [o for m, o in VARIANTS if m == mode and o in BATCHABLE]
        res = reduced_batch.simulate([_machine(mode, o) for o in vs], T_END, record_dt=5e-4)
        assert res.meta["jit"] == "numba-fused" and res.meta["nsim"] == len(vs) and not res.diverged.any()
        for i, o in enumerate(vs):
            single = python_kernel(lambda: reduced.simulate(_machine(mode, o), T_END, record_dt=5e-4))
            tr = res.trajectory(i)
            assert tr.n == single.n
            np.testing.assert_array_equal(tr.data, single.data)
    # and the Python kernel's batch (NumPy, numba plant step) gives the same record
    vs = [o for m, o in VARIANTS if m == "pid" and o in BATCHABLE]
    np_batch = python_kernel(lambda: reduced_batch.simulate([_machine("pid", o) for o in vs], T_END, record_dt=5e-4,
                                                            single_fast_path=False))
    res = reduced_batch.simulate([_machine("pid", o) for o in vs], T_END, record_dt=5e-4)
    np.testing.assert_array_equal(res.data, np_batch.data)


def test_divergence_same_time_and_message(python_kernel):
    """An unbounded K_p·t at a coarse step diverges: the single run raises the Python kernel's
    error (same text), the batch flags the run at the same time and keeps the same rows."""
    bad = ("modes.pid.kp=20000", "modes.pid.v_limit=none", "drive.v_max=1e6")
    with pytest.raises(SimulationDiverged) as ref:
        python_kernel(lambda: reduced.simulate(_machine("pid", bad), 1.0, dt=1e-3, record_dt=1e-3))
    with pytest.raises(SimulationDiverged) as got:
        reduced.simulate(_machine("pid", bad), 1.0, dt=1e-3, record_dt=1e-3)
    assert str(got.value) == str(ref.value) and "K_p·t" in str(got.value)
    good = ("modes.pid.v_limit=none",)
    machines = [_machine("pid", good), _machine("pid", bad)]
    res = reduced_batch.simulate(machines, 1.0, dt=1e-3, record_dt=1e-3)
    assert res.meta["jit"] == "numba-fused" and res.diverged.tolist() == [False, True]
    assert res.t_diverged[1] == ref.value.t and res.messages[1] == str(ref.value)
    np_res = python_kernel(lambda: reduced_batch.simulate([_machine("pid", good), _machine("pid", bad)], 1.0, dt=1e-3,
                                                          record_dt=1e-3, single_fast_path=False))
    assert np_res.nrows.tolist() == res.nrows.tolist() and np_res.t_diverged[1] == res.t_diverged[1]
    np.testing.assert_array_equal(res.data, np_res.data)


def test_what_runs_on_the_python_kernel(python_kernel):
    """Machines the compiled loop does not cover fall back to the Python kernel (no 'jit' key)."""
    h = 1e-4
    assert fused.supported(_machine("pid", ()), h)
    others = [_machine("smc", (), "yigit2023"),                # untabulated cutting force, SMC
              _machine("servo", (), "incerti-belt"),           # internal (elastic) coordinates
              _machine("pid", ("drive.pwm.frequency=20000", "drive.pwm.v_bus=48"))]  # drive train
    for mc in others:
        assert not fused.supported(mc, h)
        assert "jit" not in reduced.simulate(mc, 0.02).meta
    assert fused.usable([_machine("pid", ())], h, 0.02)
    assert not fused.usable([_machine("pid", ())], h, 0.02, progress=object())


# ---- the compiled loop around MuJoCo's own mj_step (a single multibody run)
MB_VARIANTS = [  # (scenario, mode, overrides)
    ("incerti2012", "pid", ()),                                            # K_p·t, anti-windup
    ("incerti2012", "open", ("modes.open.t_ramp=0.05",)),                   # open-loop ramp
    ("incerti2012", "pid", ("drive.T_0=0.05", "modes.pid.period=5e-4", "drive.i_max=8")),  # Coulomb, 2 kHz, I limit
    ("incerti2012", "pid", ("mechanism.joint_damping=0.01", "initial.q0=1.0", "initial.qd0=3.0", "initial.I0=1.0")),
    ("sixbar-watt2", "pi", ()),                                            # two loop closures
    ("mjcf-fourbar", "pid", ()),                                           # the user's own MJCF
]


@pytest.mark.parametrize("name,mode,overrides", MB_VARIANTS)
def test_multibody_single_run_same_bits(python_kernel, name, mode, overrides):
    """The compiled loop calls the same mj_step on the same MjData as the Python kernel's plant:
    the record (state, drive, closure residual read from the connect sites) is the same bits."""
    ref = python_kernel(lambda: multibody.simulate(_machine(mode, overrides, name), T_END, record_dt=2e-4))
    got = multibody.simulate(_machine(mode, overrides, name), T_END, record_dt=2e-4)
    assert "jit" not in ref.meta and got.meta.pop("jit") == "numba-fused"
    assert got.meta == ref.meta and got.columns == ref.columns and got.n == ref.n == round(T_END / 2e-4) + 1
    np.testing.assert_array_equal(got.data, ref.data)
    assert 0 < np.max(got["closure_error_m"]) < 1e-6  # the residual is read (RK4: ≈ 1e-8 m), not a zero column
    if "drive.i_max=8" in overrides:
        assert np.max(np.abs(got["current_A"])) == 8.0


def test_multibody_divergence_same_message(python_kernel):
    """A diverging multibody run raises the Python kernel's error, same time and text."""
    bad = ("modes.pid.kp=20000", "modes.pid.v_limit=none", "drive.v_max=1e6")
    with pytest.raises(SimulationDiverged) as ref:
        python_kernel(lambda: multibody.simulate(_machine("pid", bad), 1.0, dt=1e-3, record_dt=1e-3))
    with pytest.raises(SimulationDiverged) as got:
        multibody.simulate(_machine("pid", bad), 1.0, dt=1e-3, record_dt=1e-3)
    assert str(got.value) == str(ref.value) and got.value.t == ref.value.t and got.value.t > 0
    assert str(got.value).startswith("multibody simulation diverged at t =")


def test_multibody_what_runs_on_the_python_kernel(python_kernel):
    """Multibody plants the compiled loop does not cover: the Python kernel (no 'jit' key)."""
    def plant(name, mode, overrides=()):
        return multibody.MultibodyPlant(_machine(mode, overrides, name))

    assert fused.supported_multibody(plant("incerti2012", "pid"))
    for name, mode, overrides in [("press-slidercrank", "pi", ()),   # a process load (multibody_load)
                                  ("yigit2023", "smc", ()),          # SMC, cutting force, own closure residual
                                  ("incerti-belt", "servo", ()),     # internal (elastic) coordinates
                                  ("incerti2012", "pid", ("drive.pwm.frequency=20000", "drive.pwm.v_bus=48"))]:
        p = plant(name, mode, overrides)
        assert not fused.supported_multibody(p), name
    mc = _machine("pid", ("drive.pwm.frequency=20000", "drive.pwm.v_bus=48"))
    assert "jit" not in multibody.simulate(mc, 0.02).meta
    # hinge C's viscous friction is a MuJoCo load on a four-bar: only then is the load hook called
    fb = _machine("pid", ()).mechanism
    assert not fb.has_multibody_load()
    fb.damping_C = 1e-3
    assert fb.has_multibody_load()
    p = plant("incerti2012", "pid")
    assert fused.usable_multibody(p, 0.02) and not fused.usable_multibody(p, 0.02, progress=object())


def test_batch_of_one_multibody_run_on_the_compiled_loop(python_kernel):
    """``batch.simulate`` of one machine (its single-run path) takes the compiled loop too: the same
    record, and a diverging run flagged with the Python kernel's time and message."""
    from mjbench.backends import batch

    ref = python_kernel(lambda: batch.simulate([_machine("pid", ())], T_END, record_dt=5e-4))
    got = batch.simulate([_machine("pid", ())], T_END, record_dt=5e-4)
    assert got.meta.pop("jit") == "numba-fused" and "jit" not in ref.meta and got.meta == ref.meta
    np.testing.assert_array_equal(got.data, ref.data)
    bad = ("modes.pid.kp=20000", "modes.pid.v_limit=none", "drive.v_max=1e6")
    ref = python_kernel(lambda: batch.simulate([_machine("pid", bad)], 1.0, dt=1e-3, record_dt=1e-3))
    got = batch.simulate([_machine("pid", bad)], 1.0, dt=1e-3, record_dt=1e-3)
    assert got.diverged.tolist() == ref.diverged.tolist() == [True]
    assert got.t_diverged[0] == ref.t_diverged[0] > 0 and got.messages == ref.messages
