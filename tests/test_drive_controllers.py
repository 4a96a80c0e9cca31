"""DC motor drive (Eqs 6-9) and controllers (Eqs 14-16): exactness, vectorisation, errors."""
import math

import numpy as np
import pytest

from controllers import PID, ConstantVoltage, Measurement
from mjbench.drive import DCMotorDrive
from mjbench.errors import ParameterError


def test_current_step_is_exact_for_constant_speed():
    d = DCMotorDrive(R=2.0, L=9e-3, k_m=0.48)
    V, w, h = 25.0, 12.0, 1e-4
    I = 0.0
    for _ in range(100):
        I = d.current_step(I, V, w, h)
    t = 100 * h
    iss = (V - d.k_m * w) / d.R
    assert I == pytest.approx(iss * (1 - math.exp(-t * d.R / d.L)), rel=1e-12)
    # mean current over one step equals the integral of the exact solution / h
    Ibar = d.current_mean(0.0, V, w, h)
    tau = d.L / d.R
    assert Ibar == pytest.approx(iss * (1 - tau / h * (1 - math.exp(-h / tau))), rel=1e-12)


@pytest.mark.parametrize("kw", [dict(), dict(T_0=0.05, z=3.0), dict(L=0.0, T_0=0.02)])
def test_kernel_step_torque_equals_the_drive_methods(kw):
    """The kernel's bound per-step torque (a scalar closure for a single run) gives the same
    bits as the documented methods it stands for (which the batch uses), over a grid of states
    including stalled and reversing ones."""
    h = 1e-4
    d = DCMotorDrive(R=2.0, **kw)
    torque, generic = d.step_torque(h, scalar=True), d.step_torque(h, scalar=False)
    n = 0
    for I in (-7.0, 0.0, 0.3, 12.0):
        for V in (-48.0, 0.0, 5.0, 48.0):
            for qd in (-20.0, 0.0, 1e-9, 33.0):
                ref = d.crank_torque(d.current_mean(I, V, d.z * qd, h), qd, False)
                assert torque(I, V, qd) == ref == generic(I, V, qd)
                n += 1
    assert n == 64


@pytest.mark.parametrize("kw", [dict(), dict(i_max=5.0, v_max=24.0, z=3.0, T_0=0.05),
                                dict(L=0.0, i_max=2.0, v_max=1.0, lam=0.0)])
def test_kernel_current_and_limit_closures_equal_the_drive_methods(kw):
    """The kernel's bound current update, voltage limiter and recorded torque (closures for a
    single run) give the same bits as current_step / limit / crank_torque, limits active or not
    (L = 0: algebraic current; T_0 > 0: Coulomb friction, stalled and reversing speeds)."""
    h = 1e-4
    d = DCMotorDrive(R=2.0, **kw)
    cur, generic = d.step_current(h, scalar=True), d.step_current(h, scalar=False)
    lim = d.step_limit(scalar=True)
    tq = d.torque_function(scalar=True)  # the recorded torque column
    assert (lim is None) == (d.v_max == math.inf)
    for I in (-7.0, 0.0, 0.3, 12.0):
        for V in (-48.0, -1.0, 0.0, 5.0, 48.0):
            for w in (-60.0, 0.0, 1e-9, 99.0):
                assert cur(I, V, w) == d.current_step(I, V, w, h) == generic(I, V, w)
                assert tq(I, w) == d.crank_torque(I, w)
            if lim is not None:
                assert lim(V) == d.limit(V)
    if "i_max" in kw:  # the limit was active somewhere in the grid
        assert cur(12.0, 48.0, -60.0) == kw["i_max"]


def test_pid_inlined_constant_speed_reference_equals_the_reference_call():
    """PID inlines ConstantSpeed (hot path); any other reference goes through its __call__ — a
    subclass that only forwards must give the same bits, scalar and (nsim,) arrays."""
    from controllers.base import Measurement
    from controllers.pid import PID
    from controllers.reference import ConstantSpeed

    class Forwarding(ConstantSpeed):
        pass

    for kp in (80.0, np.array([80.0, 5.0, 300.0])):
        a = PID(kp, 32.0, 0.015, reference=ConstantSpeed(30.0), kp_ramp=True, v_limit=48.0)
        b = PID(kp, 32.0, 0.015, reference=Forwarding(30.0), kp_ramp=True, v_limit=48.0)
        assert a._const_ref and not b._const_ref
        y = Measurement(z=2.0)
        rng = np.random.default_rng(3)
        for n in range(200):
            t = n * 1e-3
            q, qd, qdd, I = (rng.normal(size=np.shape(kp)) * s + 0.0 for s in (3.0, 20.0, 500.0, 5.0))
            y.set(t, q, qd, qdd, I)
            np.testing.assert_array_equal(a(t, y), b(t, y))
        np.testing.assert_array_equal(a.offset, b.offset)
        assert a.reference.phi_start is not None


def test_drive_accepts_arrays_like_scalars():
    R = np.array([1.0, 2.0, 3.0])
    da = DCMotorDrive(R=R)
    I = np.zeros(3)
    out = da.current_step(I, np.full(3, 24.0), np.array([0.0, 5.0, 10.0]), 1e-4)
    for k in range(3):
        ds = DCMotorDrive(R=float(R[k]))
        assert out[k] == pytest.approx(ds.current_step(0.0, 24.0, [0.0, 5.0, 10.0][k], 1e-4), rel=1e-14)
    tq = da.crank_torque(out, np.array([1.0, -1.0, 0.0]))
    assert tq.shape == (3,)


def test_torque_and_inertia_follow_eq9():
    d = DCMotorDrive(z=3.0, k_m=0.5, T_0=0.1, lam=0.02, J_m=1e-3, J_a=2e-4, J_b=5e-4)
    assert d.J_eq == pytest.approx(5e-4 + (1e-3 + 2e-4) * 9)
    # T_c + J_eq α̈ = z k_m I − z T_0 − z² λ α̇  (α̇ > 0)
    assert d.crank_torque(2.0, 4.0) == pytest.approx(3 * 0.5 * 2 - 3 * 0.1 - 9 * 0.02 * 4)
    assert d.crank_torque(2.0, 4.0, viscous=False) == pytest.approx(3 * 0.5 * 2 - 3 * 0.1)


@pytest.mark.parametrize("kw,name", [({"R": 0.0}, "drive.R"), ({"L": -1e-3}, "drive.L"),
                                     ({"k_m": float("nan")}, "drive.k_m"), ({"z": -2}, "drive.z"),
                                     ({"v_max": 0.0}, "drive.v_max")])
def test_non_physical_drive_parameters_raise(kw, name):
    with pytest.raises(ParameterError, match=name):
        DCMotorDrive(**kw)


def _y(t, q, qd, qdd, z=1.0):
    return Measurement(z=z).set(t, q, qd, qdd, 0.0)


def test_pid_is_eq16_with_time_varying_gain():
    c = PID(80.0, 32.0, 0.015, omega0=30.0, kp_ramp=True)
    c.reset()
    c(0.0, _y(0.0, 0.0, 0.0, 0.0))  # first sample at rest at φ = 0: φ_ref = ω₀·t
    t, q, qd, qdd = 0.4, 10.0, 28.0, 5.0
    V = c(t, _y(t, q, qd, qdd))
    assert V == pytest.approx(80 * t * (30 - qd) + 32 * (30 * t - q) + 0.015 * (0 - qdd))
    c2 = PID(80.0, 32.0, 0.015, omega0=30.0, kp_ramp=True, t_ramp_max=0.2)
    assert c2.gain_p(0.4) == pytest.approx(16.0)


def test_pid_anti_windup_freezes_the_integral_while_saturated():
    c = PID(1.0, 10.0, 0.0, omega0=30.0, v_limit=12.0)
    c.reset()
    h = 1e-3
    # motor stalled: error grows, output saturated → integral frozen
    outs = [c(n * h, _y(n * h, 0.0, 0.0, 0.0)) for n in range(2000)]
    assert max(outs) == 12.0
    # after release the integral term is what accumulated before saturation, not 2 s of windup
    assert c.ki * (30.0 * 2000 * h - c.offset) < 12.0 + 30.0
    assert set(c.state()) == {"offset", "epos_prev"}


def test_controllers_accept_arrays():
    kp = np.array([50.0, 80.0])
    c = PID(kp, 32.0, 0.015, omega0=30.0, kp_ramp=True, v_limit=48.0)
    c.reset()
    y = Measurement(z=1.0).set(0.3, np.array([5.0, 6.0]), np.array([20.0, 25.0]), np.zeros(2), np.zeros(2))
    V = c(0.3, y)
    for k in range(2):
        cs = PID(float(kp[k]), 32.0, 0.015, omega0=30.0, kp_ramp=True, v_limit=48.0)
        cs.reset()
        assert V[k] == pytest.approx(cs(0.3, _y(0.3, [5.0, 6.0][k], [20.0, 25.0][k], 0.0)), rel=1e-14)
    assert ConstantVoltage(np.array([1.0, 2.0]))(0.1, y).shape == (2,)


def test_zero_inductance_algebraic_current():
    """L = 0: both backends use the algebraic current I = (V − k_m φ̇)/R (the current update is
    the kernel's, shared), and they agree."""
    from mjbench import scenario as S
    from mjbench.backends import multibody, reduced
    scn = S.load("incerti2012", ["drive.L=0"])
    tr = multibody.simulate(S.make_machine(scn, "open"), 0.05)
    # I = (V − k_m φ̇)/R at every sample after the first step
    np.testing.assert_allclose(tr.current[1:], (25.0 - 0.48 * tr.omega[1:]) / 2.0, rtol=0, atol=0.05)
    tr2 = reduced.simulate(S.make_machine(scn, "open"), 0.05)
    np.testing.assert_allclose(tr2.current[1:], (25.0 - 0.48 * tr2.omega[1:]) / 2.0, rtol=0, atol=0.05)
    np.testing.assert_allclose(tr2.qd, tr.qd, rtol=0, atol=1e-4 * np.max(np.abs(tr.qd)))


def test_servo_accepts_arrays_and_matches_single_runs():
    """A batch runs one servo with (nsim,) gains (issue: CascadeServo cast gains to float)."""
    from controllers.reference import ConstantSpeed
    from controllers.servo import CascadeServo

    kvp = np.array([1.0, 2.0, 4.0])
    c = CascadeServo(ConstantSpeed(10.0), kpp=50.0, kvp=kvp, kvi=20.0, kffv=0.5, v_limit=12.0)
    c.reset()
    y = Measurement(z=1.0)
    outs = [c(t, y.set(t, np.full(3, 0.5 * t), np.full(3, 4.0), np.zeros(3), np.zeros(3))) for t in (0.0, 1e-3, 2e-3)]
    for k in range(3):
        s = CascadeServo(ConstantSpeed(10.0), kpp=50.0, kvp=float(kvp[k]), kvi=20.0, kffv=0.5, v_limit=12.0)
        s.reset()
        ref = [s(t, _y(t, 0.5 * t, 4.0, 0.0)) for t in (0.0, 1e-3, 2e-3)]
        assert [o[k] for o in outs] == pytest.approx(ref, rel=1e-15)
    assert set(c.state()) == {"integ", "t_prev"}


def test_current_limit_applies_in_every_integrator_option():
    """The amplifier limit is the kernel's (one current update for every backend and method)."""
    from mjbench import scenario as S
    from mjbench.backends import multibody, reduced

    scn = S.load("incerti2012", ["drive.i_max=10", "drive.v_max=inf", "modes.pid.v_limit=none"])
    runs = [reduced.simulate(S.make_machine(scn, "pid"), 0.05, record_dt=1e-4, method=m) for m in ("rk4", "solve_ivp")]
    runs.append(multibody.simulate(S.make_machine(scn, "pid"), 0.05, record_dt=1e-4))
    for tr in runs:
        assert np.max(np.abs(tr.current)) == pytest.approx(10.0, abs=1e-12)
    assert np.max(np.abs(runs[0].qd - runs[1].qd)) < 1e-8 * np.max(np.abs(runs[0].qd))


def test_controller_errors_are_product_errors():
    import controllers
    from mjbench.errors import ParameterError, ScenarioError

    with pytest.raises(ScenarioError, match="modes.pid.kpp: unknown key"):
        controllers.from_dict({"type": "pid", "kp": 1.0, "ki": 1.0, "kd": 0.0, "omega0": 1.0, "kpp": 2})
    with pytest.raises(ScenarioError, match="needs omega0"):
        controllers.from_dict({"type": "pid", "kp": 1.0, "ki": 1.0, "kd": 0.0})
    with pytest.raises(ParameterError, match="kp"):
        PID(float("nan"), 1.0, 0.0, omega0=1.0)
    with pytest.raises(ScenarioError, match="type = 'pidd'"):
        controllers.from_dict({"type": "pidd"})


def test_pid_reference_starts_at_the_initial_angle():
    """A machine started at q0 ≠ 0 gets no initial position error (no start-up kick)."""
    from mjbench import scenario as S
    from mjbench.backends import reduced

    tr0 = reduced.simulate(S.make_machine(S.load("incerti2012"), "pid"), 0.05, record_dt=1e-4)
    tr1 = reduced.simulate(S.make_machine(S.load("incerti2012", ["initial.q0=0.0"]), "pid"), 0.05, record_dt=1e-4)
    np.testing.assert_array_equal(tr0.voltage, tr1.voltage)
    tr2 = reduced.simulate(S.make_machine(S.load("incerti2012", ["initial.q0=1.0"]), "pid"), 0.05, record_dt=1e-4)
    assert abs(tr2.voltage[0]) < 1e-12  # at rest, on the reference: no kick
