"""One source for the drive-train elements: each element is a law that the CPython loop and the
compiled (numba) loop run with the same bits, and that the Python objects call.

* the noise generator: the same words and deviates in CPython and numba; its statistics;
* every element alone and the combinations the shipped scenarios and docs use, on both backends:
  the CPython loop's record equals the compiled loop's, bit for bit;
* batches equal their single runs (both loops);
* the laws against independent computations from the record (encoder count, difference, PI).
"""
import math

import numpy as np
import pytest
from scipy import stats

from controllers import PID, ConstantVoltage
from mjbench import kernel
from mjbench import scenario as S
from mjbench.backends import simulate, simulate_many
from mjbench.drive import DCMotorDrive
from mjbench.drivetrain import Amplifier, CurrentLoop, DriveTrain, Gear, Sensor
from mjbench.drivetrain import noise as N
from mjbench.drivetrain.amplifier import pwm_averaged, pwm_switching
from mjbench.drivetrain.gear import gear_efficiency
from mjbench.machine import Machine
from mjbench.mechanisms.rotor import Rotor

numba = pytest.importorskip("numba")

BACKENDS = ("multibody", "reduced")
R, L, KM, JM = 2.0, 9e-3, 0.48, 1.3e-3


def _jit():
    from mjbench.compiled import jit

    jit.init()  # registers every law with numba
    return numba


# ================================================================ noise generator
def test_mul32_and_hash32_are_the_32_bit_arithmetic():
    rng = np.random.default_rng(0)
    xs = [int(v) for v in rng.integers(0, 2 ** 32, 2000, dtype=np.uint64)]
    for x in xs:
        for c in (0xED5AD4BB, 0xAC4C1B51, 0x31848BAB, 0xFFFFFFFF, 1):
            assert N.mul32(x, c) == (x * c) & 0xFFFFFFFF
    # triple32 is a bijection of 32-bit words: no collision among 2000 distinct inputs
    assert len({N.hash32(x) for x in set(xs)}) == len(set(xs))
    assert all(0 <= N.hash32(x) < 2 ** 32 for x in xs)


def test_noise_words_and_deviates_are_the_same_bits_in_cpython_and_numba():
    nb = _jit()

    @nb.njit
    def draw(key, n0, n):
        out = np.empty(n)
        words = np.empty(n, dtype=np.int64)
        for i in range(n):
            out[i] = N.gauss(key, n0 + i)
            words[i] = N.noise_word(key, n0 + i)
        return out, words

    for seed, stream, n0 in ((0, 1, 0), (123456789, 3, 10 ** 6), (2 ** 40 + 7, 4, 2 ** 31)):
        key = N.stream_key(seed, stream)
        z, w = draw(key, n0, 4000)
        np.testing.assert_array_equal(z, [N.gauss(key, n0 + i) for i in range(4000)])
        np.testing.assert_array_equal(w, [N.noise_word(key, n0 + i) for i in range(4000)])


def test_noise_is_standard_normal_and_independent_across_samples_streams_and_seeds():
    n = 100_000
    keys = [N.stream_key(1, N.STREAM_ANGLE), N.stream_key(1, N.STREAM_SPEED), N.stream_key(2, N.STREAM_ANGLE)]
    z = np.array([[N.gauss(k, i) for i in range(n)] for k in keys])
    se = 1.0 / math.sqrt(n)
    for x in z:
        assert abs(x.mean()) < 4 * se
        assert x.std() == pytest.approx(1.0, abs=4 / math.sqrt(2 * n))
        assert stats.kstest(x, "norm").pvalue > 1e-3
        assert abs(np.corrcoef(x[:-1], x[1:])[0, 1]) < 4 * se  # successive samples
        assert abs(stats.kurtosis(x)) < 0.1  # the tails are Gaussian too
    assert abs(np.corrcoef(z[0], z[1])[0, 1]) < 4 * se  # two streams of one seed
    assert abs(np.corrcoef(z[0], z[2])[0, 1]) < 4 * se  # one stream of two seeds


# ================================================================ python loop vs compiled loop
def both_loops(make, backend, t_end=0.05, record_dt=1e-4, **kw):
    """Run ``make()`` on ``backend`` with the CPython loop and the compiled loop; the records must be
    equal bit for bit (and the second run must really be compiled)."""
    tr = {}
    for loop in ("python", "compiled"):
        tr[loop] = simulate(make(), backend, t_end, record_dt=record_dt, loop=loop, **kw)
    assert tr["python"].meta["loop"] == "python"
    assert tr["compiled"].meta["loop"] == "compiled", tr["compiled"].meta["loop_reason"]
    assert tr["python"].columns == tr["compiled"].columns
    np.testing.assert_array_equal(tr["python"].data, tr["compiled"].data)
    return tr["python"]


PWM_SW = ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48",
          'drive.pwm.dead_time="1 us"']
#: the elements alone and the compositions of the study (mjbench/papers/drivetrain_study.py), the
#: benchmark (scripts/bench_parts/drivetrain.py) and docs/drivetrain.md, on the seed-000 four-bar
ELEMENTS = {
    "pwm_averaged": ['drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48", 'drive.pwm.dead_time="1 us"',
                     "drive.i_max=6"],
    "pwm_switching": PWM_SW,
    "pwm_switching_bipolar": PWM_SW + ['drive.pwm.scheme="bipolar"', "drive.i_max=6"],
    "encoder_difference": ["drive.encoder.lines=2000"],
    "encoder_observer_output": ["drive.encoder.lines=2000", 'drive.encoder.side="output"',
                                'drive.sensor.speed="observer"'],
    "encoder_mt": ["drive.encoder.lines=500", 'drive.sensor.speed="mt"', "modes.pid.period=5e-4"],
    "noise_delay": ['drive.sensor.noise_angle="0.01 deg"', "drive.sensor.noise_speed=0.1",
                    'drive.sensor.noise_current="20 mA"', "drive.sensor.seed=1", "drive.sensor.delay=true"],
    "delay": ['drive.sensor.speed="true"', "drive.sensor.delay=true"],
    "efficiency": ["drive.gear.efficiency=0.9", "drive.gear.efficiency_back=0.7"],
    "current_loop": ['drive.current_loop.bandwidth="1 kHz"', "drive.i_max=20", 'drive.sensor.noise_current="20 mA"'],
    "realistic_electrical": PWM_SW + ["drive.encoder.lines=2000", 'drive.sensor.speed="mt"', "drive.sensor.delay=true",
                                      "drive.gear.efficiency=0.9", 'drive.current_loop.bandwidth="1 kHz"',
                                      'drive.current_loop.period="2e-4 s"', "drive.i_max=20"],
}


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("element", list(ELEMENTS))
def test_each_element_gives_the_same_bits_in_both_loops(element, backend):
    sets = ELEMENTS[element]
    mode = "pid"
    tr = both_loops(lambda: S.make_machine(S.load("incerti2012", sets), mode), backend)
    assert np.all(np.isfinite(tr.data))
    assert tr.meta["drivetrain"]  # the run used the drive train
    if "pwm" in element:
        assert "voltage_bridge_V" in tr.columns
    if "current_loop" in element or "realistic" in element:
        assert tr.has("current_ref_A")


@pytest.mark.parametrize("backend", BACKENDS)
def test_open_loop_and_current_reference_modes_give_the_same_bits(backend):
    """The open-loop mode (the benchmark's) through a switching bridge and, with a current loop, as a
    current reference."""
    for sets in (PWM_SW + ["drive.gear.efficiency=0.8"],
                 ['drive.current_loop.bandwidth="500 Hz"', "modes.open.voltage=5"] + PWM_SW):
        both_loops(lambda: S.make_machine(S.load("incerti2012", sets), "open"), backend)


def test_rotor_bench_elements_give_the_same_bits_on_mujoco():
    """The flywheel bench of tests/test_drivetrain.py (its MuJoCo model compiles; its reduced model
    is a Python adapter): every element under a sampled PID."""
    def drive(**train):
        d = DCMotorDrive(R=R, L=L, k_m=KM, J_m=JM, J_a=0.0, J_b=0.0, z=2.0, lam=0.01, v_max=48.0)
        d.train = DriveTrain(**train)
        return d

    for train in (dict(pwm=Amplifier("switching", 25e3, 48.0, "unipolar", 1e-6)),
                  dict(sensor=Sensor(lines=500, speed="mt", noise_current=0.05, seed=4, delay=True)),
                  dict(sensor=Sensor(lines=1000, speed="observer", noise_angle=1e-4)),
                  dict(current_loop=CurrentLoop.from_bandwidth(500.0, L, R), gear=Gear(efficiency=0.8))):
        both_loops(lambda: Machine(Rotor(1e-2, damping=0.01), drive(**train),
                                   PID(0.5, 5.0, 1e-4, omega0=30.0, v_limit=48.0, period=2e-4)), "multibody", 0.1)


MECHANICAL = {
    "study_mt": None,  # mjbench/papers/drivetrain_study.py: realistic("incerti2012", "mt")
    "backlash_exact_motor": ['drive.gear.backlash="0.1 deg"', 'drive.sensor.speed="true"'],
    "backlash_encoder_observer_noise": ['drive.gear.backlash="0.1 deg"', "drive.encoder.lines=2000",
                                        'drive.sensor.speed="observer"', "drive.sensor.noise_speed=0.05"],
}


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("combo", list(MECHANICAL))
def test_drive_trains_with_a_compliant_gear_give_the_same_bits(combo, backend):
    """With the mechanical elements (backlash, Coulomb friction: the plant's model,
    :class:`~mjbench.drivetrain.gear.DrivenMechanism`) the sensor measures the motor's own shaft
    through the plant's deflection and rate."""
    from mjbench.backends.multibody import MultibodyPlant
    from mjbench.backends.reduced import ReducedPlant
    from mjbench.papers import drivetrain_study as DT

    sets = MECHANICAL[combo] or DT.realistic("incerti2012", "mt")
    m = S.make_machine(S.load("incerti2012", sets), "pid")
    plant = MultibodyPlant(m) if backend == "multibody" else ReducedPlant(m)
    plant.start()
    pr = kernel.Program.build(plant, m, 1e-4, kernel.control_every(m.controller, 1e-4))
    getattr(plant, "finish", lambda: None)()
    if not pr.compiled:
        pytest.skip("the plant has no compiled form yet: " + "; ".join(pr.reasons))
    tr = both_loops(lambda: S.make_machine(S.load("incerti2012", sets), "pid"), backend)
    if combo == "backlash_exact_motor":  # the exact motor speed (crank side) is the recorded motor speed / z
        z = float(m.drive.z)
        np.testing.assert_allclose(tr["speed_est_rad_s"] * z, tr.omega, rtol=1e-13, atol=1e-12)
        assert np.max(np.abs(tr.omega / z - tr.qd)) > 1e-3  # and it is not the crank's


# ================================================================ batches
@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_of_drive_trains_equals_single_runs_in_both_loops(backend):
    """Runs differing in encoder lines, noise seed and PWM frequency: each batch run equals its single
    run, with the CPython loop and with the compiled loop (threads)."""
    variants = [["drive.encoder.lines=500", "drive.sensor.seed=1", 'drive.pwm.frequency="20 kHz"'],
                ["drive.encoder.lines=2000", "drive.sensor.seed=2", 'drive.pwm.frequency="25 kHz"']]
    common = ['drive.pwm.model="switching"', "drive.pwm.v_bus=48", 'drive.sensor.speed="observer"',
              "drive.sensor.noise_speed=0.05", 'drive.current_loop.bandwidth="1 kHz"', "drive.i_max=20"]
    scns = [S.load("incerti2012", common + v) for v in variants]
    for loop in ("python", "compiled"):
        res = simulate_many([S.make_machine(s, "pid") for s in scns], backend, 0.03, record_dt=1e-4, loop=loop)
        assert res.meta["loop"] == loop
        for i, s in enumerate(scns):
            single = simulate(S.make_machine(s, "pid"), backend, 0.03, record_dt=1e-4, loop=loop)
            np.testing.assert_array_equal(res.trajectory(i).data, single.data)
    # and the two seeds/line counts give different runs
    assert not np.array_equal(res.trajectory(0).data, res.trajectory(1).data)


# ================================================================ the laws against independent computations
def _drive(**train):
    d = DCMotorDrive(R=R, L=L, k_m=KM, J_m=JM, J_a=0.0, J_b=0.0, z=3.0, lam=0.01, v_max=48.0)
    d.train = DriveTrain(**train)
    return d


def test_recorded_encoder_count_and_difference_match_a_numpy_recomputation():
    """angle_meas = Δ·round(z·q/Δ)/z, speed_est = its difference over T, accel_est the difference of
    that: recomputed with NumPy from the recorded exact angle (the control sample = the record)."""
    T = 1e-4
    sen = Sensor(lines=500, side="motor")
    m = Machine(Rotor(1e-2, damping=0.01), _drive(sensor=sen), ConstantVoltage(12.0))
    m.controller.period = T
    tr = simulate(m, "multibody", 0.1, record_dt=T, loop="compiled")
    z, D = 3.0, 2 * math.pi / 2000
    th = D * np.round(z * tr.q * (1.0 / D))
    np.testing.assert_allclose(tr["angle_meas_rad"], th / z, rtol=1e-15, atol=1e-15)
    w = np.concatenate([[0.0], np.diff(th) / T])
    np.testing.assert_allclose(tr["speed_est_rad_s"], w / z, rtol=1e-12, atol=1e-9)
    a = np.concatenate([[0.0, 0.0], np.diff(w[1:]) / T])
    np.testing.assert_allclose(tr["accel_est_rad_s2"], a / z, rtol=1e-9, atol=1e-4)
    assert np.ptp(tr["speed_est_rad_s"][100:]) > 0  # it moved through several counts


def test_current_loop_voltage_matches_a_numpy_pi_with_its_own_noise_stream():
    """V_k = K_p·e_k + x_{k+1}, e_k = i*_k − (I_k + σ·n_k), n_k the current loop's own stream
    (not the sensor's: the controller's current sample and the loop's are different draws)."""
    h, sc, seed = 1e-4, 0.05, 7
    cl = CurrentLoop(3.0, 400.0)
    m = Machine(Rotor(1e-2, damping=0.01), _drive(current_loop=cl, sensor=Sensor(speed="true", noise_current=sc,
                                                                                   seed=seed)),
                PID(0.2, 2.0, 0.0, omega0=20.0))
    tr = simulate(m, "multibody", 0.05, record_dt=h, loop="compiled")
    n = len(tr.t) - 1
    key = N.stream_key(seed, N.STREAM_CURRENT_LOOP)
    noise = sc * np.array([N.gauss(key, k) for k in range(n)])
    e = tr["current_ref_A"][:n] - (tr.current[:n] + noise)
    x = np.cumsum(400.0 * h * e)
    V = 3.0 * e + x
    assert np.max(np.abs(V)) < 48.0  # unclipped
    np.testing.assert_allclose(tr.voltage[1:], V, rtol=1e-10, atol=1e-10)  # row k+1 holds step k's voltage
    other = sc * np.array([N.gauss(N.stream_key(seed, N.STREAM_CURRENT), k) for k in range(n)])
    assert abs(np.corrcoef(noise, other)[0, 1]) < 0.1


def test_python_objects_call_the_laws():
    """Amplifier, Gear and Sensor methods give the laws' values (one implementation): checked against
    the closed forms they stand for."""
    d = _drive()
    h = 1e-4
    amp = Amplifier("averaged", 20e3, 48.0, "bipolar", 1e-6)
    # bipolar dead time: −2·V_bus·t_d·f·sgn I; the bus clips
    np.testing.assert_allclose(amp.bridge_voltage(np.array([1.0, -1.0, 1.0]), np.array([12.0, 12.0, 60.0]), 0.0, d, h),
                               [12.0 - 1.92, 12.0 + 1.92, 48.0], rtol=1e-12)
    P = amp.params(d, h)
    assert amp.bridge_voltage(1.0, 12.0, 0.0, d, h) == pwm_averaged(0.0, 1.0, 12.0, 0.0, P, None)
    # switching at 0 V unipolar: no edges, the exact RL decay over h
    sw = Amplifier("switching", 20e3, 48.0)
    Ibar, Iend, Vb, lo, hi = sw.switching_step(0.0, 2.0, 0.0, 0.0, d, h)
    assert Iend == pytest.approx(2.0 * math.exp(-h * R / L), rel=1e-14) and Vb == 0.0 and (lo, hi) == (Iend, 2.0)
    assert Ibar == pytest.approx(2.0 * (L / R) * (1 - math.exp(-h * R / L)) / h, rel=1e-12)
    assert (Ibar, Iend, Vb, lo, hi) == pwm_switching(0.0, 2.0, 0.0, 0.0, sw.params(d, h), None)
    g = Gear(efficiency=0.8, efficiency_back=0.5)
    np.testing.assert_allclose(g.transmitted_torque(np.array([1.0, 1.0, -1.0]), np.array([2.0, -2.0, -2.0])),
                               [0.8, 2.0, -0.8])
    assert g.transmitted_torque(1.0, -2.0) == gear_efficiency(1.0, -2.0, g.efficiency_params())
    s = Sensor(lines=100, speed="difference").start(z=1.0, T=1e-3)
    D = 2 * math.pi / 400
    assert s.measure(0.0, 0.6 * D, 0.0, 0.0, 1.0) == (D, 0.0, 0.0, 1.0)
    q, w, a, i = s.measure(1e-3, 2.4 * D, 0.0, 0.0, 1.0)
    assert (q, i) == (2 * D, 1.0) and w == pytest.approx(D / 1e-3, rel=1e-12)
    assert s.state()["n"] == 2.0
