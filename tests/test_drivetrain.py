"""The real drive train (issue 15): every element against an analytic or limit case, both backends.

Most cases drive a flywheel (``rotor`` mechanism: constant inertia, optional viscous load), whose
dynamics have closed forms; the scenario tests use the seed-000 four-bar.
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from controllers import PID, ConstantVoltage
from controllers.base import Controller
from mjbench import scenario as S
from mjbench.backends import batch, multibody, reduced
from mjbench.drive import DCMotorDrive
from mjbench.drivetrain import Amplifier, CurrentLoop, DriveTrain, Friction, Gear, Sensor
from mjbench.drivetrain.amplifier import ripple_formula
from mjbench.errors import MjbenchError, ScenarioError
from mjbench.machine import Machine
from mjbench.mechanisms.rotor import Rotor

BACKENDS = {"reduced": reduced, "multibody": multibody}
R, L, KM, JM = 2.0, 9e-3, 0.48, 1.3e-3


class Fn(Controller):
    """Open loop u = f(t), logging what it is given (t, q, q̇, q̈)."""

    type_name = "test_fn"

    def __init__(self, f, period=0.0):
        self.f, self.period = f, period
        self.log = []

    @classmethod
    def from_params(cls, *a, **k):  # pragma: no cover
        raise NotImplementedError

    def reset(self):
        self.log = []

    def __call__(self, t, y):
        self.log.append((t, y.q, y.qd, y.qdd, y.current))
        return self.f(t)


def drive(z=1.0, lam=0.0, **train):
    d = DCMotorDrive(R=R, L=L, k_m=KM, J_m=JM, J_a=0.0, J_b=0.0, z=z, lam=lam, v_max=train.pop("v_max", math.inf))
    d.train = DriveTrain(**train)
    return d


# ================================================================ off by default, schema
def test_elements_are_off_by_default_and_fill_only_their_kernel_slots():
    scn = S.load("incerti2012")
    assert scn.drive.build().train is None
    assert "pwm" not in scn.resolved()["drive"]  # manifests unchanged
    h = 1e-4

    def forms(every=1, i_max=math.inf, **train):
        d = drive(**train)
        d.i_max = i_max
        m = Machine(Rotor(1e-2), d, ConstantVoltage(1.0))
        return d.forms(h, every, reduced.ReducedPlant(m, h))

    assert drive().forms(h, 1, None) == {}
    f = forms(sensor=Sensor(lines=1000))  # an encoder alone: only the sensor's slot
    assert set(f) == {"sense"} and f["sense"].law.__name__ == "sensor_law" and f["sense"].compiled
    assert forms(sensor=Sensor(speed="true", delay=True)) == {"sense_cols": True, "delay": True}  # exact + delay
    assert set(forms(pwm=Amplifier("averaged", 20e3, 48.0))) == {"amp"}
    sw = forms(pwm=Amplifier("switching", 20e3, 48.0))["amp"]
    assert sw.flags == {"switching": True} and sw.laws["end"].__name__ == "pwm_end_current"
    assert set(forms(gear=Gear(efficiency=0.9))) == {"eff"} and forms(gear=Gear(efficiency=1.0)) == {}
    f = forms(i_max=7.0, v_max=30.0, current_loop=CurrentLoop(2.0, 100.0, period=2e-4),
              pwm=Amplifier("averaged", 20e3, 24.0))
    assert f["limit"] == (-7.0, 7.0)  # the controller's output is a current reference
    P = f["cloop"].P
    assert (P.every, P.kp, P.kiT, P.vmax) == (2, 2.0, 100.0 * 2e-4, 24.0)  # bounded by the bus
    # the sensor's sample period is the controller's
    assert forms(every=5, sensor=Sensor(lines=100))["sense"].P.T == pytest.approx(5e-4)


def test_set_accepts_every_element_with_units():
    scn = S.load("incerti2012", ['drive.pwm.frequency="20 kHz"', 'drive.pwm.v_bus="48 V"',
                                 'drive.pwm.dead_time="0.5 us"', 'drive.encoder.lines=2000',
                                 'drive.sensor.speed="observer"', 'drive.sensor.bandwidth="200 Hz"',
                                 'drive.gear.backlash="0.1 deg"', 'drive.gear.efficiency=0.9',
                                 'drive.friction.coulomb="20 mN*m"', 'drive.current_loop.bandwidth="1 kHz"',
                                 'drive.friction.joints.rocker_joint.coulomb="0.01 N*m"'])
    d = scn.drive
    assert d.pwm.frequency == 20e3 and d.pwm.dead_time == pytest.approx(5e-7)
    assert d.gear.backlash == pytest.approx(math.radians(0.1)) and d.friction.coulomb == pytest.approx(0.02)
    assert d.sensor.bandwidth == 200.0 and d.encoder.lines == 2000
    tr = S.make_machine(scn, "pid").drive.train
    assert tr.current_loop.kp == pytest.approx(9e-3 * 2 * math.pi * 1e3)
    # the speed estimate defaults to the difference with an encoder, to the exact speed without
    assert S.load("incerti2012", ["drive.sensor.delay=true"]).drive.build().train.sensor.speed == "true"
    assert S.load("incerti2012", ["drive.encoder.lines=100"]).drive.build().train.sensor.speed == "difference"


@pytest.mark.parametrize("sets,path", [
    (['drive.gear.backlash="-0.1 deg"'], "drive.gear.backlash: must be >= 0"),
    (['drive.gear.efficiency=1.2'], "drive.gear.efficiency: must be less than or equal to 1"),
    (['drive.gear.efficiency_back=0'], "drive.gear.efficiency_back: must be greater than 0"),
    (['drive.pwm.frequency="5 kHz"', 'drive.pwm.v_bus=48'], "drive.pwm.frequency: 5000 Hz is below the control rate"),
    (['drive.pwm.frequency="20 kHz"'], "drive.pwm.v_bus: required value is missing"),
    (['drive.pwm.frequency="20 kHz"', 'drive.pwm.v_bus=48', 'drive.pwm.dead_time="30 us"'], "drive.pwm.dead_time: must be shorter"),
    (['drive.encoder.lines=0'], "drive.encoder.lines"),
    (['drive.sensor.speed="mt"'], "drive.sensor.speed: 'mt'"),
    (['drive.friction.coulomb=0.02', 'drive.friction.breakaway=0.01'], "drive.friction.breakaway: must be >= coulomb"),
    (['drive.friction.breakaway=0.03'], "drive.friction.stribeck_speed: required"),
    (['drive.friction.joints.nope.coulomb=1'], "drive.friction.joints.nope: the mechanism's model has no joint"),
    (['drive.current_loop.kp=3'], "drive.current_loop: give both kp and ki"),
    (['drive.gear.backlash="1 m"'], "drive.gear.backlash: '1 m' has the wrong dimension"),
    (['drive.sensor.speed="observer"', 'drive.sensor.bandwidth="2 kHz"'], "drive.sensor.bandwidth: 2000 Hz is too high"),
])
def test_bad_drive_train_values_are_clear_errors_with_their_path(sets, path):
    with pytest.raises(ScenarioError, match=path.replace("(", r"\(")):
        S.load("incerti2012", sets)


# ================================================================ amplifier
@pytest.mark.parametrize("scheme,V", [("unipolar", 24.0), ("bipolar", 0.0)])
def test_switching_ripple_at_half_duty_matches_the_analytic_value(scheme, V):
    f = 20e3
    m = Machine(Rotor(1e3), drive(pwm=Amplifier("switching", f, 48.0, scheme)), ConstantVoltage(V))
    tr = reduced.simulate(m, 0.1, dt=1e-4, record_dt=1e-4)  # one step = two PWM periods
    rip = (tr["current_max_A"] - tr["current_min_A"])[-100:]
    # ΔI ≈ V_bus/(4 L f) (unipolar) or V_bus/(2 L f) (bipolar) for T ≪ L/R; exact: ×tanh(T/4τ)·4τ/T
    approx = ripple_formula(48.0, L, f, scheme)
    x = (1 / f) / (4 * L / R)
    assert rip.mean() == pytest.approx(approx * math.tanh(x) / x, rel=2e-4)
    assert rip.mean() == pytest.approx(approx, rel=3e-3)
    assert np.ptp(rip) < 1e-3 * approx  # periodic steady state
    # samples at the carrier's valley (centre-aligned) are the period-mean current
    assert tr.current[-1] == pytest.approx((V - KM * tr.qd[-1]) / R, abs=1e-3 * approx)


def test_switching_mean_current_converges_to_the_averaged_model():
    """Max |Ī_switching − Ī_averaged| over a closed-loop start-up falls as 1/f² with the PWM frequency."""
    errs = []
    freqs = (10e3, 20e3, 40e3, 80e3)
    for f in freqs:
        out = {}
        for model in ("averaged", "switching"):
            m = Machine(Rotor(2e-3, damping=0.01), drive(lam=0.08, pwm=Amplifier(model, f, 48.0)),
                        PID(0.5, 5.0, 0.0, omega0=30.0, v_limit=48.0, period=1e-4))
            out[model] = reduced.simulate(m, 0.06, dt=1e-4, record_dt=1e-4)
        errs.append(np.max(np.abs(out["switching"]["current_mean_A"][1:] - out["averaged"]["current_mean_A"][1:])))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.0) & (ratios < 5.0)), (errs, ratios)
    assert errs[-1] < 1e-5


def test_mechanics_held_over_the_step_costs_less_than_1e5_of_the_speed():
    """Switching PWM at the 0.1 ms co-step vs the same model fully resolved (h = T/20)."""
    scn = S.load("incerti2012", ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"', 'drive.pwm.v_bus=48'])
    a = reduced.simulate(S.make_machine(scn, "open"), 0.04, dt=1e-4, record_dt=1e-4)
    b = reduced.simulate(S.make_machine(scn, "open"), 0.04, dt=2.5e-6, record_dt=1e-4)
    assert np.max(np.abs(a.qd - b.qd)) < 1e-5 * np.max(np.abs(b.qd))
    assert np.max(np.abs(a.current - b.current)) < 1e-4


@pytest.mark.parametrize("scheme,factor", [("unipolar", 1.0), ("bipolar", 2.0)])
def test_dead_time_shifts_the_mean_voltage_by_the_classic_error(scheme, factor):
    f, td, V = 20e3, 1e-6, 12.0
    out = {}
    for model in ("averaged", "switching"):
        m = Machine(Rotor(1e3), drive(pwm=Amplifier(model, f, 48.0, scheme, td)), ConstantVoltage(V))
        out[model] = reduced.simulate(m, 0.03, dt=1e-4, record_dt=1e-4)
    # I > 0: every edge towards the on-level waits t_d → ΔV = −factor·V_bus·t_d·f
    for tr in out.values():
        assert tr["voltage_bridge_V"][-1] == pytest.approx(V - factor * 48.0 * td * f, abs=1e-9)
    # the step-mean current (the torque's) agrees; the sampled one is offset by the shifted pulse centre
    assert out["switching"]["current_mean_A"][-1] == pytest.approx(out["averaged"]["current_mean_A"][-1], rel=1e-5)


def test_batch_switching_equals_single_runs():
    ms, singles = [], []
    for V in (6.0, 18.0, -30.0):
        mk = lambda: Machine(Rotor(2e-3, damping=0.01),  # noqa: E731
                             drive(lam=0.05, pwm=Amplifier("switching", 25e3, 48.0, "unipolar", 1e-6)),
                             ConstantVoltage(V))
        ms.append(mk())
        singles.append(multibody.simulate(mk(), 0.02, record_dt=1e-4))
    res = batch.simulate(ms, 0.02, record_dt=1e-4)
    for i, s in enumerate(singles):  # independent runs: the same bits
        np.testing.assert_array_equal(res.trajectory(i).data, s.data)


# ================================================================ sensor
@pytest.mark.parametrize("side,zz", [("motor", 3.0), ("output", 1.0)])
def test_encoder_quantisation_error_is_within_half_a_count(side, zz):
    c = Fn(lambda t: 12.0, period=1e-4)
    m = Machine(Rotor(1e-2, damping=0.01), drive(z=3.0, sensor=Sensor(lines=500, side=side)), c)
    tr = reduced.simulate(m, 0.2, dt=1e-4, record_dt=1e-4)
    log = np.array(c.log)
    half = 0.5 * 2 * math.pi / 2000
    err = (log[:, 1] - tr.q[: len(log)]) * zz  # on the encoder's shaft
    assert np.max(np.abs(err)) <= half * (1 + 1e-9)
    assert np.max(np.abs(err)) > 0.9 * half  # and the bound is reached
    assert tr.q[-1] > 200 * half


def test_observer_tracks_a_constant_speed_ramp_with_zero_steady_error():
    for lines, tol in ((0, 1e-9), (2000, 2e-4)):
        c = Fn(lambda t: 0.0, period=1e-4)
        d = drive(sensor=Sensor(lines=lines, speed="observer", bandwidth=100.0))
        d.k_m = 1e-12  # no torque: the shaft turns at its initial speed (a constant-speed angle ramp)
        tr = reduced.simulate(Machine(Rotor(1e-2), d, c, qd0=20.0), 0.5, dt=1e-4, record_dt=1e-4)
        w = np.array(c.log)[-2000:, 2]
        assert abs(w.mean() - 20.0) < tol * 20.0, lines
        assert abs(tr.qd[-1] - 20.0) < 1e-9
    # and the plain difference has the ±Δ/T quantisation jitter
    c = Fn(lambda t: 0.0, period=1e-4)
    d = drive(sensor=Sensor(lines=2000, speed="difference"))
    d.k_m = 1e-12
    reduced.simulate(Machine(Rotor(1e-2), d, c, qd0=20.0), 0.1, dt=1e-4)
    w = np.array(c.log)[-500:, 2]
    assert np.ptp(w) == pytest.approx(2 * math.pi / 8000 / 1e-4, rel=1e-6)


def test_mt_method_measures_low_speed_where_the_difference_cannot():
    out = {}
    for method in ("difference", "mt"):
        c = Fn(lambda t: 0.0, period=1e-3)
        d = drive(sensor=Sensor(lines=500, speed=method))
        d.k_m = 1e-12
        reduced.simulate(Machine(Rotor(1e-2), d, c, qd0=0.5), 1.0, dt=1e-4)
        out[method] = np.array(c.log)[200:, 2]
    # 0.5 rad/s with 2000 counts/rev at 1 kHz: 0.16 count per sample → the difference reads 0 or 3.14 rad/s
    assert set(np.round(out["difference"], 6)) <= {0.0, round(2 * math.pi / 2000 / 1e-3, 6)}
    assert np.max(np.abs(out["mt"] - 0.5)) < 1e-3 * 0.5


def test_noise_is_seeded_and_has_the_given_deviation():
    logs = []
    for seed in (1, 1, 2):
        c = Fn(lambda t: 0.0, period=1e-4)
        d = drive(sensor=Sensor(speed="true", noise_speed=0.5, noise_current=0.1, seed=seed))
        reduced.simulate(Machine(Rotor(1e-2), d, c), 0.5, dt=1e-4)
        logs.append(np.array(c.log))
    assert np.array_equal(logs[0], logs[1]) and not np.array_equal(logs[0], logs[2])
    assert np.std(logs[0][:, 2]) == pytest.approx(0.5, rel=0.05)
    assert np.std(logs[0][:, 4]) == pytest.approx(0.1, rel=0.05)


def test_one_sample_delay_applies_each_output_one_sample_later():
    T = 1e-3
    f = lambda t: 1.0 + 10.0 * t  # noqa: E731
    trs = {}
    for delay in (False, True):
        m = Machine(Rotor(1e-2), drive(sensor=Sensor(speed="true", delay=delay)), Fn(f, period=T))
        trs[delay] = reduced.simulate(m, 0.05, dt=1e-4, record_dt=T)
    t = trs[True].t
    np.testing.assert_allclose(trs[False].voltage, f(t), rtol=1e-12)
    np.testing.assert_allclose(trs[True].voltage[1:], f(t[:-1]), rtol=1e-12)
    assert trs[True].voltage[0] == 0.0


# ================================================================ gear
@pytest.mark.parametrize("backend", list(BACKENDS))
def test_backlash_output_lags_by_half_the_play_on_a_slow_reversal(backend):
    beta = math.radians(1.0)
    c_load = 0.01
    m = Machine(Rotor(1e-4, damping=c_load), drive(gear=Gear(backlash=beta)),
                Fn(lambda t: 2.0 * math.sin(2 * math.pi * 0.5 * t)))
    tr = BACKENDS[backend].simulate(m, 2.2, dt=1e-4, record_dt=1e-3)
    k = m.mechanism.k
    moving = np.abs(tr.qd) > 2.0  # away from the reversals' impacts (speed amplitude ≈ 4 rad/s)
    lag = tr["gear_deflection_rad"] * np.sign(tr.qd) - c_load * np.abs(tr.qd) / k  # minus the mesh's elastic T/k
    assert moving.sum() > 800 and (tr.qd > 2).any() and (tr.qd < -2).any()
    np.testing.assert_allclose(lag[moving], beta / 2, rtol=1e-4)
    # the motor column is the motor's own speed: it differs from the crank's while crossing the play
    assert np.max(np.abs(tr.omega - tr.qd)) > 0.01


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_gear_stiffness_gives_the_two_inertia_mesh_frequency(backend):
    Jl, k = 2e-3, 500.0
    m = Machine(Rotor(Jl), drive(gear=Gear(stiffness=k, damping=0.0)), ConstantVoltage(0.0),
                x0=(0.01,))
    d = m.drive
    d.k_m = 1e-12  # no electrical damping: a free two-inertia oscillation
    tr = BACKENDS[backend].simulate(m, 0.2, dt=1e-5, record_dt=1e-5)
    x = tr["gear_deflection_rad"]
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    tz = tr.t[up] - x[up] / (x[up + 1] - x[up]) * 1e-5
    f_sim = (len(tz) - 1) / (tz[-1] - tz[0])
    f_th = math.sqrt(k * (1 / JM + 1 / Jl)) / (2 * math.pi)
    assert f_sim == pytest.approx(f_th, rel=1e-4)


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_efficiency_power_balance_forward_and_back_driven(backend):
    z, eta, eta_b, cL, V = 2.0, 0.8, 0.6, 0.02, 12.0
    # forward, steady state: z·η·k_m·I = c_L·α̇ with I = (V − k_m·z·α̇)/R
    m = Machine(Rotor(1e-3, damping=cL), drive(z=z, gear=Gear(efficiency=eta, efficiency_back=eta_b)),
                ConstantVoltage(V))
    tr = BACKENDS[backend].simulate(m, 1.5, dt=1e-4, record_dt=1e-3)
    w = z * eta * KM * V / (R * cL + eta * z * z * KM * KM)
    assert tr.qd[-1] == pytest.approx(w, rel=1e-6)
    p_load, p_motor = cL * tr.qd[-1] ** 2, KM * tr.current[-1] * z * tr.qd[-1]
    assert p_load / p_motor == pytest.approx(eta, rel=1e-6)
    # back-driven: a spinning load brakes on the short-circuited motor; the motor receives η_b of the
    # power the load gives: J_tot·ω̇ = z·k_m·I/η_b, L·İ = −R·I − k_m·z·ω (exact linear solution)
    J = 1e-3 + z * z * JM
    m = Machine(Rotor(1e-3), drive(z=z, gear=Gear(efficiency=eta, efficiency_back=eta_b)), ConstantVoltage(0.0),
                qd0=50.0)
    tr = BACKENDS[backend].simulate(m, 0.05, dt=1e-4, record_dt=1e-4)
    A = np.array([[0.0, z * KM / (eta_b * J)], [-KM * z / L, -R / L]])
    from scipy.linalg import expm

    ref = np.array([expm(A * t) @ [50.0, 0.0] for t in tr.t])
    back = ref[:, 0] > 1.0  # until the load stops (then the power flows the other way)
    np.testing.assert_allclose(tr.qd[back], ref[back, 0], atol=1e-4 * 50.0)
    np.testing.assert_allclose(tr.current[back], ref[back, 1], atol=1e-4 * 50.0 * KM * z / R)
    k = slice(30, int(np.argmax(~back)))  # after the electrical transient: received / given = η_b
    given = -J * tr.qd[k] * np.gradient(tr.qd, tr.t)[k]
    got = -KM * tr.current[k] * z * tr.qd[k]
    assert np.median(got / given) == pytest.approx(eta_b, rel=1e-3)


# ================================================================ friction
def _breakaway_reference(a, fc, fs, vs, J):
    """Stick until k_m·I(t) = F_S (I of the RL ramp response), then J·ω̇ = k_m·I − F(ω), L·İ = a·t − R·I − k_m·ω."""
    tau = L / R
    tb = brentq(lambda t: KM * (a / R) * (t - tau * (1 - math.exp(-t / tau))) - fs, 1e-3, 10.0)
    Ib = (a / R) * (tb - tau * (1 - math.exp(-tb / tau)))

    def rhs(t, y):
        w, i = y
        return [(KM * i - (fc + (fs - fc) * math.exp(-(w / vs) ** 2))) / J, (a * t - R * i - KM * w) / L]

    return tb, solve_ivp(rhs, (tb, tb + 1.0), [0.0, Ib], rtol=1e-10, atol=1e-12, dense_output=True)


@pytest.mark.parametrize("where", ["motor", "joint"])
def test_friction_breakaway_and_stick_on_a_slow_ramp_in_both_backends(where):
    a, fc, fs, vs, Jr = 1.0, 0.05, 0.08, 1.0, 1e-2
    tb, ref = _breakaway_reference(a, fc, fs, vs, Jr + JM)
    res = {}
    for b, mod in BACKENDS.items():
        fr = Friction(fc, fs, vs) if where == "motor" else \
            Friction(joints={"crank": {"coulomb": fc, "breakaway": fs, "stribeck_speed": vs}})
        m = Machine(Rotor(Jr), drive(friction=fr), Fn(lambda t: a * t))
        tr = res[b] = mod.simulate(m, tb + 0.35, dt=1e-4, record_dt=1e-4)
        stick = tr.t < tb - 0.01
        assert np.max(np.abs(tr.q[stick])) < 5e-4, b   # stuck while k_m·I < F_S
        slip = tr.t > tb + 0.05
        np.testing.assert_allclose(tr.qd[slip], ref.sol(tr.t[slip])[0], rtol=0.02, atol=0.02)
        t_move = tr.t[np.argmax(tr.qd > 0.3)]
        t_ref = brentq(lambda t: ref.sol(t)[0] - 0.3, tb + 1e-6, tb + 0.5)
        assert abs(t_move - t_ref) < 2e-3, b
    assert np.max(np.abs(res["reduced"].qd - res["multibody"].qd)) < 0.03


def test_joint_friction_away_from_the_crank_agrees_between_backends():
    scn = S.load("incerti2012", ["drive.friction.joints.rocker_joint.coulomb=0.3",
                                 "drive.friction.joints.rocker_joint.viscous=0.01", "mechanism.g=0"])
    trs = {b: BACKENDS[b].simulate(S.make_machine(scn, "open"), 0.6, dt=1e-4) for b in BACKENDS}
    ideal = reduced.simulate(S.make_machine(S.load("incerti2012", ["mechanism.g=0"]), "open"), 0.6, dt=1e-4)
    d = np.max(np.abs(trs["reduced"].qd - trs["multibody"].qd))
    assert d < 0.01 * np.max(trs["reduced"].qd)
    assert np.max(np.abs(ideal.qd - trs["reduced"].qd)) > 10 * d  # the friction matters


# ================================================================ current loop
def test_current_loop_step_is_the_designed_first_order_lag():
    wc = 2 * math.pi * 500.0
    errs = []
    for h in (1e-5, 1e-4):
        m = Machine(Rotor(1e4), drive(v_max=48.0, current_loop=CurrentLoop.from_bandwidth(500.0, L, R)),
                    ConstantVoltage(1.0))  # the mode's output is now a current reference [A]
        tr = reduced.simulate(m, 0.005, dt=h, record_dt=h)
        errs.append(np.max(np.abs(tr.current - (1 - np.exp(-wc * tr.t)))))
        assert tr["current_ref_A"][-1] == 1.0
    assert errs[0] < 0.01 and 6 < errs[1] / errs[0] < 15  # converges (first order in h)


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_cascade_speed_pi_over_the_current_loop_has_no_steady_error(backend):
    m = Machine(Rotor(1e-2, damping=0.02), drive(lam=0.01, v_max=48.0, current_loop=CurrentLoop.from_bandwidth(500.0, L, R)),
                PID(0.5, 5.0, 0.0, omega0=30.0))
    tr = BACKENDS[backend].simulate(m, 2.0, dt=1e-4, record_dt=1e-3)
    assert tr.omega[-1] == pytest.approx(30.0, rel=1e-8)
    assert tr.current[-1] == pytest.approx((0.02 + 0.01) * 30.0 / KM, rel=1e-8)


# ================================================================ everything, both backends, batch
def test_realistic_drive_runs_on_both_backends_and_in_batch():
    sets = ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"', 'drive.pwm.v_bus=48',
            'drive.pwm.dead_time="1 us"', 'drive.encoder.lines=2000', 'drive.sensor.speed="observer"',
            'drive.gear.backlash="0.1 deg"', 'drive.friction.coulomb="0.05 N*m"']
    scn = S.load("incerti2012", sets)
    trs = {b: BACKENDS[b].simulate(S.make_machine(scn, "open"), 0.3, dt=1e-4) for b in BACKENDS}
    assert np.max(np.abs(trs["reduced"].qd - trs["multibody"].qd)) < 1e-3 * np.max(trs["reduced"].qd)
    machines = [S.make_machine(S.load("incerti2012", sets + [f"drive.encoder.lines={n}"]), "pid") for n in (500, 2000)]
    res = batch.simulate(machines, 0.1, record_dt=1e-3)
    for i, n in enumerate((500, 2000)):
        single = multibody.simulate(S.make_machine(S.load("incerti2012", sets + [f"drive.encoder.lines={n}"]), "pid"), 0.1)
        np.testing.assert_array_equal(res.trajectory(i).data, single.data)  # independent runs: the same bits


def test_study_chattering_metrics_on_known_signals():
    from mjbench.papers import drivetrain_study as DT

    t = np.arange(0, 1.0, 1e-4)
    square = 48.0 * np.sign(np.sin(2 * math.pi * 50.0 * t + 0.1))
    assert DT.switching_frequency(t, square, 0.96) == pytest.approx(50.0, rel=0.01)
    jitter = 25.0 + 0.5 * np.sign(np.sin(2 * math.pi * 800.0 * t))  # below the ±2 % v_max band
    assert DT.switching_frequency(t, jitter, 0.96) == 0.0
    assert DT.breakdown("yigit2023", {"steady_error": 0.02}, {}) and not DT.breakdown("yigit2023", {"steady_error": 0.002}, {})
    assert DT.breakdown("incerti2012", {"diverged": True}, {})


def test_realdrive_cases_record_every_step_and_decimated_records_are_refused():
    """The chattering metrics of the report's *-realdrive cases come from the case's own runs:
    those must be recorded every co-step (a 1 ms record aliased the switching frequency, 277 Hz
    instead of 2.1 kHz, and read the control's current change as PWM ripple)."""
    from mjbench.papers import drivetrain_study as DT

    for name in ("incerti2012", "yigit2023"):
        assert S.load(name, DT.case_overrides(name)).simulation.record_dt == DT.DT
    m = S.make_machine(S.load("incerti2012", DT.realistic("incerti2012")), "pid")
    fine = reduced.simulate(m, 0.03, dt=DT.DT, record_dt=DT.DT)
    coarse = reduced.simulate(S.make_machine(S.load("incerti2012", DT.realistic("incerti2012")), "pid"), 0.03,
                              dt=DT.DT, record_dt=1e-3)
    c = DT.chatter(fine, 0.01, 0.03)
    # the PWM ripple cannot exceed the 50 %-duty ripple V_bus/(4 L f) of the unipolar bridge
    assert 0.0 < c["current_ripple_A"] <= ripple_formula(48.0, float(m.drive.L), 20e3) * (1 + 1e-6), c
    with pytest.raises(ValueError, match="record_dt"):
        DT.chatter(coarse, 0.01, 0.03)


@pytest.mark.parametrize("model", ["averaged", "switching"])
def test_amplifier_current_limit_holds_the_current_at_i_max(model):
    d = drive(pwm=Amplifier(model, 20e3, 48.0))
    d.i_max = 5.0
    d._flags()
    m = Machine(Rotor(1e3), d, ConstantVoltage(48.0))  # stalled: 24 A without the limit
    tr = reduced.simulate(m, 0.05, dt=1e-4, record_dt=1e-4)
    assert np.max(tr.current) <= 5.0 + 1e-9
    assert tr.current[-1] == pytest.approx(5.0, rel=1e-3)
    assert tr["voltage_bridge_V"][-1] == pytest.approx(R * 5.0 + KM * tr.qd[-1], rel=2e-3)  # the bridge's mean


def test_every_element_in_a_batch_equals_its_single_runs():
    """Observer, M/T, current loop, averaged PWM, efficiency, Stribeck friction with per-simulation
    model edits, delay: each run of a batch has its own objects, parameters and state."""
    common = ['drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48", 'drive.pwm.dead_time="1 us"',
              "drive.gear.efficiency=0.9", "drive.gear.efficiency_back=0.7", 'drive.friction.coulomb="0.03 N*m"',
              'drive.friction.breakaway="0.05 N*m"', 'drive.friction.stribeck_speed="2 rad/s"',
              "drive.sensor.delay=true", 'drive.current_loop.bandwidth="500 Hz"', "modes.open.voltage=4"]
    # one batch = one estimator and one encoder side (strings must agree); lines differ per simulation
    for extra in (['drive.sensor.speed="observer"'], ['drive.sensor.speed="mt"', 'drive.encoder.side="output"',
                                                      'drive.gear.backlash="0.2 deg"']):
        scns = [S.load("incerti2012", common + extra + [f"drive.encoder.lines={n}"]) for n in (1000, 3000)]
        res = batch.simulate([S.make_machine(s, "open") for s in scns], 0.05, record_dt=1e-3)
        for i, s in enumerate(scns):
            single = multibody.simulate(S.make_machine(s, "open"), 0.05)
            np.testing.assert_array_equal(res.trajectory(i).data, single.data)


@pytest.mark.parametrize("model", ["table", "closed"])
def test_reduced_batch_runs_the_drive_train_like_single_runs(model):
    """The batched reduced backend (tabulated or closed rigid model, and the compliant gear's extra
    coordinate) through the same kernel: each simulation equals its single reduced run, bit for bit."""
    from mjbench.backends import reduced_batch

    common = ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48",
              "drive.gear.efficiency=0.9", 'drive.friction.coulomb="0.03 N*m"', 'drive.sensor.speed="mt"']
    for extra in ([], ['drive.gear.backlash="0.2 deg"']):
        scns = [S.load("incerti2012", common + extra + [f"drive.encoder.lines={n}"]) for n in (500, 1000, 3000)]
        res = reduced_batch.simulate([S.make_machine(s, "pid") for s in scns], 0.05, dt=1e-4,
                                     options={"model": model})
        for i, s in enumerate(scns):
            single = reduced.simulate(S.make_machine(s, "pid"), 0.05, dt=1e-4, options={"model": model})
            np.testing.assert_array_equal(res.trajectory(i).data, single.data)


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_a_mesh_too_stiff_for_the_step_is_one_line_before_simulating(backend):
    """1e9 N·m/rad on seed 000's gear resonates at ≈ 145 kHz against the motor: RK4 at 0.1 ms cannot
    follow it (the run would diverge); the largest step that can is named."""
    m = S.make_machine(S.load("incerti2012", ["drive.gear={stiffness=1e9}"]), "pid")
    with pytest.raises(MjbenchError, match=r"drive.gear: the gear's mesh .* resonates at 1.45e\+05 Hz .* "
                                           r"simulation.dt <= 2.7e-06 s"):
        BACKENDS[backend].simulate(m, 0.01, dt=1e-4)
