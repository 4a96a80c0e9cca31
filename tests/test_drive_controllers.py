"""DC motor drive (Eqs 6-9) and controllers (Eqs 14-16): the laws against the equations written out, errors."""
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


def _mean_current_by_hand(d, I, V, w, h):
    """Ī over a step h with V and φ̇ held, from the exact solution of L·İ = V − R·I − k_m·φ̇."""
    iss = (V - d.k_m * w) / d.R
    if d.L == 0.0:
        return iss
    x = h * d.R / d.L
    return iss + (I - iss) * (1.0 - math.exp(-x)) / x


@pytest.mark.parametrize("kw", [dict(), dict(T_0=0.05, z=3.0), dict(L=0.0, T_0=0.02)])
def test_kernel_drive_laws_are_eqs_7_and_9(kw):
    """The laws the kernel calls for the drive (step-mean current, motor torque, recorded crank
    torque) against Eqs 7 and 9 written out here, over a grid of states including stalled and
    reversing ones (L = 0: algebraic current)."""
    from mjbench.drive import current_mean, drive_torque, motor_torque

    h = 1e-4
    d = DCMotorDrive(R=2.0, **kw)
    P = d.step_params(h)
    z = d.z
    n = 0
    for I in (-7.0, 0.0, 0.3, 12.0):
        for V in (-48.0, 0.0, 5.0, 48.0):
            for qd in (-20.0, 0.0, 1e-9, 33.0):
                w = z * qd
                Ibar = current_mean(I, V, w, P)
                assert Ibar == pytest.approx(_mean_current_by_hand(d, I, V, w, h), rel=1e-12, abs=1e-12)
                sg = float(np.sign(w))
                # Eq 9 without J_eq·α̈: the plant adds the viscous −z²λ·α̇ (joint damping)
                assert z * motor_torque(Ibar, w, P) == pytest.approx(z * (d.k_m * Ibar - d.T_0 * sg), rel=1e-14,
                                                                     abs=1e-14)
                assert drive_torque(Ibar, w, P) == pytest.approx(z * (d.k_m * Ibar - d.T_0 * sg) - z * z * d.lam * qd,
                                                                 rel=1e-12, abs=1e-12)
                # the methods run the same laws
                assert d.crank_torque(Ibar, qd) == drive_torque(Ibar, w, P)
                assert d.crank_torque(Ibar, qd, viscous=False) == z * motor_torque(Ibar, w, P)
                n += 1
    assert n == 64


@pytest.mark.parametrize("kw", [dict(), dict(i_max=5.0, v_max=24.0, z=3.0, T_0=0.05),
                                dict(L=0.0, i_max=2.0, v_max=1.0, lam=0.0)])
def test_kernel_current_update_and_limits(kw):
    """The current update (law) is the exact exponential of Eq 7 clipped to ±i_max; the voltage
    limiter clips to ±v_max; L = 0: I₊ = (V − k_m·φ̇)/R."""
    from mjbench.drive import current_step

    h = 1e-4
    d = DCMotorDrive(R=2.0, **kw)
    P = d.step_params(h)
    imax = kw.get("i_max", math.inf)
    for I in (-7.0, 0.0, 0.3, 12.0):
        for V in (-48.0, -1.0, 0.0, 5.0, 48.0):
            for w in (-60.0, 0.0, 1e-9, 99.0):
                iss = (V - d.k_m * w) / d.R
                exact = iss if d.L == 0.0 else iss + (I - iss) * math.exp(-h * d.R / d.L)
                assert current_step(I, V, w, P) == pytest.approx(min(max(exact, -imax), imax), rel=1e-12, abs=1e-12)
                assert d.current_step(I, V, w, h) == current_step(I, V, w, P)
            assert d.limit(V) == min(max(V, -d.v_max), d.v_max)
    if "i_max" in kw:  # the limit was active somewhere in the grid
        assert current_step(12.0, 48.0, -60.0, P) == kw["i_max"]


def test_constant_speed_reference_inside_the_pid_is_eq16():
    """PID + ConstantSpeed called from Python (the law the kernel runs) against Eq 16 written out,
    on a random measurement sequence; a reference subclass that only forwards gives the same bits;
    the reference starts at the first measured angle (φ_start = z·q − ω₀·t)."""
    from controllers.pid import PID
    from controllers.reference import ConstantSpeed

    class Forwarding(ConstantSpeed):
        pass

    z, kp, ki, kd, w0 = 2.0, 80.0, 32.0, 0.015, 30.0
    a = PID(kp, ki, kd, reference=ConstantSpeed(w0), kp_ramp=True)
    b = PID(kp, ki, kd, reference=Forwarding(w0), kp_ramp=True)
    y = Measurement(z=z)
    rng = np.random.default_rng(3)
    phi_start = None
    for n in range(200):
        t = n * 1e-3
        q, qd, qdd, I = (float(rng.normal() * s) for s in (3.0, 20.0, 500.0, 5.0))
        y.set(t, q, qd, qdd, I)
        ua = a(t, y)
        assert ua == b(t, y)
        if phi_start is None:
            phi_start = z * q - w0 * t
        eq16 = kp * t * (w0 - z * qd) + ki * (phi_start + w0 * t - z * q) + kd * (0.0 - z * qdd)
        assert ua == pytest.approx(eq16, rel=1e-12, abs=1e-9)
    assert a.offset == b.offset == 0.0  # no v_limit: no windup offset
    assert a.reference.phi_start == pytest.approx(phi_start)


def test_drive_methods_accept_arrays_of_states():
    """The drive's methods apply its scalar laws elementwise to arrays (post-processing): the same
    numbers as one call per element, in the array's shape."""
    d = DCMotorDrive(R=2.0)
    I = np.array([[0.0, 1.0], [-2.0, 3.0]])
    V = np.full((2, 2), 24.0)
    w = np.array([[0.0, 5.0], [10.0, -4.0]])
    out = d.current_step(I, V, w, 1e-4)
    assert out.shape == (2, 2)
    for k in np.ndindex(2, 2):
        assert out[k] == d.current_step(float(I[k]), 24.0, float(w[k]), 1e-4)
    tq = d.crank_torque(np.array([1.0, 2.0, 3.0]), np.array([1.0, -1.0, 0.0]))
    assert tq.shape == (3,) and tq[1] == d.crank_torque(2.0, -1.0)


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
    assert set(c.state()) == {"offset", "epos_prev", "started"}
    # the state: the last angle error φ_ref − φ (stalled motor: ω₀·t), the frozen increments in φ_w
    assert c.state()["epos_prev"] == pytest.approx(30.0 * 1999 * h, rel=1e-12)
    # saturated from the first sample (K_p·30 = 30 V > 12 V): every increment was frozen
    assert c.offset == pytest.approx(30.0 * 1999 * h, rel=1e-12)


def test_controller_objects_run_their_law_with_their_own_state():
    """A controller object is its law with P and S: the call equals the law called on
    ``parameters(T, z)`` and a fresh state, bit for bit, and two objects share nothing (the batch
    of the old array controllers is now independent runs: tests/test_compiled_controllers.py)."""
    from controllers.pid import pid_law
    from mjbench.control import call_law

    y = Measurement(z=1.5)
    a = PID(50.0, 32.0, 0.015, omega0=30.0, kp_ramp=True, v_limit=48.0)
    b = PID(80.0, 32.0, 0.015, omega0=30.0, kp_ramp=True, v_limit=5.0)
    P = a.parameters(0.0, 1.5)
    S = a.initial_state()
    Sref = a.reference.initial_state()
    for n in range(50):
        t = n * 1e-3
        y.set(t, 0.2 * n, 20.0 + n, 3.0, 0.0)
        sig = {**y.signals(), "t": t}
        ref = call_law(type(a.reference).law, sig, a.reference.parameters(0.0, 1.5), Sref)
        sig.update(zip(("phi_ref", "om_ref", "acc_ref"), ref))
        assert a(t, y) == call_law(pid_law, sig, P, S)
        b(t, y)
    np.testing.assert_array_equal(a._S, S)
    assert a.state() != b.state()  # saturated differently: each keeps its own windup offset
    assert ConstantVoltage(12.0, t_ramp=0.5)(0.1, y) == pytest.approx(12.0 * 0.1 / 0.5, rel=1e-15)
    with pytest.raises(TypeError):  # arrays are not a controller input any more
        a(0.0, Measurement(z=1.0).set(0.0, np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2)))


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


def test_servo_is_the_cascade_with_conditional_integration():
    """CascadeServo called from Python (its law) against the cascade written out here: P position
    loop, PI velocity loop with the rectangle rule over the measured sample interval, feed-forward,
    output clip with the integral frozen while clipped."""
    from controllers.reference import ConstantSpeed
    from controllers.servo import CascadeServo

    z, kpp, kvp, kvi, kffv, vl = 2.0, 50.0, 0.4, 20.0, 0.5, 12.0
    c = CascadeServo(ConstantSpeed(10.0, phi0=0.0), kpp=kpp, kvp=kvp, kvi=kvi, kffv=kffv, v_limit=vl)
    y = Measurement(z=z)
    integ, t_prev, clipped = 0.0, None, 0
    for n in range(300):
        t = n * 1e-3
        q, qd = 0.4 * t + 0.02 * math.sin(40 * t), 4.0 + (3.0 if n > 150 else 0.0)
        u = c(t, y.set(t, q, qd, 0.0, 0.0))
        e_v = 10.0 + kpp * (10.0 * t - z * q) - z * qd
        dt = 0.0 if t_prev is None else t - t_prev
        t_prev = t
        inc = kvi * e_v * dt
        raw = kffv * 10.0 + kvp * e_v + integ + inc
        if (raw > vl and inc > 0) or (raw < -vl and inc < 0):
            raw -= inc
            clipped += 1
        else:
            integ += inc
        assert u == pytest.approx(min(max(raw, -vl), vl), rel=1e-12, abs=1e-12)
    assert clipped > 0 and c.integ == pytest.approx(integ, rel=1e-12)
    assert set(c.state()) == {"integ", "t_prev"} and c.state()["t_prev"] == t_prev


def test_current_limit_applies_in_every_integrator_option():
    """The amplifier limit is the kernel's (one current update for every backend and method): the
    applied voltage is limited so that the current stays within ±i_max over the step (it reaches the
    limit to within the step's speed change, never beyond it)."""
    from mjbench import scenario as S
    from mjbench.backends import multibody, reduced

    scn = S.load("incerti2012", ["drive.i_max=10", "drive.v_max=inf", "modes.pid.v_limit=none"])
    runs = [reduced.simulate(S.make_machine(scn, "pid"), 0.05, record_dt=1e-4, method=m) for m in ("rk4", "solve_ivp")]
    runs.append(multibody.simulate(S.make_machine(scn, "pid"), 0.05, record_dt=1e-4))
    for tr in runs:
        assert 10.0 - 1e-4 < np.max(np.abs(tr.current)) <= 10.0 + 1e-12
    assert np.max(np.abs(runs[0].qd - runs[1].qd)) < 1e-8 * np.max(np.abs(runs[0].qd))


def test_controller_errors_are_product_errors():
    import controllers
    from mjbench.errors import ParameterError, ScenarioError

    with pytest.raises(ScenarioError, match="modes.pid.kpp: unknown key"):
        controllers.from_dict({"type": "pid", "kp": 1.0, "ki": 1.0, "kd": 0.0, "omega0": 1.0, "kpp": 2})
    with pytest.raises(ScenarioError, match="needs a set-point: omega0"):
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


def test_current_limited_run_converges_with_the_step():
    """A flywheel press spinning up on its amplifier's 40 A limit (seconds on the limit): the step-mean
    current that drives the mechanics is limited together with the end current, so the run converges
    with the step (second order here); clipping only the end current made the mean current exceed the
    limit by O(h) and the crank speed moved by 1.3 % of its peak when h was halved."""
    from mjbench import scenario as S
    from mjbench.backends import reduced

    qd = {}
    for h in (1e-4, 5e-5, 2.5e-5):
        scn = S.load("press-slidercrank", [f"simulation.dt={h}"])
        tr = reduced.simulate(S.make_machine(scn, "open"), 0.3, dt=h, record_dt=1e-3)
        assert np.max(np.abs(tr.current)) > 39.9  # on the limit
        qd[h] = tr.qd
    peak = np.max(np.abs(qd[1e-4]))
    e1 = np.max(np.abs(qd[1e-4] - qd[5e-5])) / peak
    e2 = np.max(np.abs(qd[5e-5] - qd[2.5e-5])) / peak
    assert e1 < 2e-4 and e1 / e2 > 2.5, (e1, e2)  # small, and better than first order
