"""Open loop from a time series ([modes.NAME] type = "signal"): a voltage step against the motor's
closed form, a linear ramp equal (bit for bit) to the open-loop ramp, a CSV file equal to the same
arrays, NumPy arrays from Python, the compiled loop equal to the CPython one, bad tables refused."""
import numpy as np
import pytest

import controllers
import mjbench as mjb
from mjbench.backends import simulate
from mjbench.errors import ParameterError, ScenarioError

DRIVE = dict(R="0.5 ohm", L="1 mH", k_m=0.06, J_m="0.5 kg*cm^2", z=20, lam=1e-5, v_max="24 V")
J = 0.05


def _machine(ctrl):
    return mjb.Machine(mjb.make_mechanism("rotor", J=J), mjb.make_drive(**DRIVE), ctrl)


def closed_form(t, V, drive):
    """Crank speed [rad/s] of the linear motor + flywheel after a step V at t = 0 (matrix exponential)."""
    Jt = J + drive.J_m * drive.z**2
    zk = drive.z * drive.k_m
    A = np.array([[-drive.lam * drive.z**2 / Jt, zk / Jt], [-zk / drive.L, -drive.R / drive.L]])
    B = np.array([0.0, 1.0 / drive.L]) * V
    lam, vec = np.linalg.eig(A)
    x = ((np.expm1(np.outer(t, lam)) / lam) * np.linalg.solve(vec, B)) @ vec.T
    return x[:, 0].real


def test_step_against_the_closed_form():
    """12 V from t = 0.05 s (hold): the speed is the closed-form step response shifted by 0.05 s."""
    sig = mjb.make_controller("signal", t=[0.0, 0.05], voltage=[0.0, 12.0], interpolation="hold")
    m = _machine(sig)
    res = mjb.simulate(m, backend="both", t_end=0.3, record_dt="1 ms")
    for run in res.runs.values():
        t = run.time
        assert np.all(run["voltage_V"][t < 0.05 - 1e-9] == 0.0) and np.all(run["voltage_V"][t >= 0.05 - 1e-12] == 12.0)
        ref = closed_form(np.maximum(t - 0.05, 0.0), 12.0, m.drive)
        assert np.max(np.abs(run["crank_speed_rad_s"] - ref)) < 1e-4 * np.max(ref)


def test_linear_ramp_equals_the_open_loop_ramp():
    ramp = mjb.make_controller("signal", t=np.array([0.0, 0.1]), voltage=np.array([0.0, 20.0]), interpolation="linear")
    open_ = mjb.make_controller("open", voltage=20.0, t_ramp=0.1)
    a = mjb.simulate(_machine(ramp), backend="reduced", t_end=0.2)["reduced"].data
    b = mjb.simulate(_machine(open_), backend="reduced", t_end=0.2)["reduced"].data
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_compiled_equals_cpython(backend):
    pytest.importorskip("numba")
    t = np.linspace(0.0, 0.08, 9)
    sig = controllers.from_dict({"type": "signal", "t": t, "voltage": 24.0 * np.sin(40 * t), "interpolation": "linear"})
    out = [simulate(_machine(sig), backend, 0.1, record_dt=1e-4, loop=loop) for loop in ("python", "compiled")]
    assert out[1].meta["loop"] == "compiled"
    np.testing.assert_array_equal(out[0].data, out[1].data)


def test_csv_file_equals_the_arrays(tmp_path):
    (tmp_path / "v.csv").write_text("t_s,voltage_V\n0,0\n0.05,6\n0.1,24\n")
    base = {"scenario": {"name": "sig"}, "mechanism": {"type": "rotor", "J": J}, "drive": DRIVE,
            "simulation": {"t_end": 0.15, "mode": "s", "backend": "reduced"}}
    scn_file = tmp_path / "s.toml"
    scn_file.write_text(mjb.load({**base, "modes": {"s": {"type": "signal", "t": [0.0, 0.05, 0.1],
                                                          "voltage": [0.0, 6.0, 24.0], "interpolation": "linear"}}})
                        .to_toml().replace('t = [0.0, 0.05, 0.1]\nvoltage = [0.0, 6.0, 24.0]', 'file = "v.csv"'))
    from_file = mjb.load(scn_file)
    assert from_file.get("modes.s.source_file") == str(tmp_path / "v.csv")
    arrays = mjb.load({**base, "modes": {"s": {"type": "signal", "t": [0.0, 0.05, 0.1], "voltage": [0.0, 6.0, 24.0],
                                               "interpolation": "linear"}}})
    np.testing.assert_array_equal(from_file.simulate()["reduced"].data, arrays.simulate()["reduced"].data)


def test_bad_tables_are_refused():
    with pytest.raises(ScenarioError, match="t must increase strictly: t\\[2\\] = 0.1 s after t\\[1\\] = 0.2 s"):
        mjb.make_controller("signal", t=[0, 0.2, 0.1], voltage=[0, 1, 2], interpolation="hold")
    with pytest.raises(ScenarioError, match="interpolation: required value is missing"):
        mjb.make_controller("signal", t=[0, 0.2], voltage=[0, 1])
    with pytest.raises(ScenarioError, match="same length"):
        mjb.make_controller("signal", t=[0, 0.2], voltage=[0, 1, 2], interpolation="linear")
    with pytest.raises(ParameterError, match='needs \\[drive\\] type = "torque"'):
        mjb.Machine(mjb.make_mechanism("rotor", J=J), mjb.make_drive(**DRIVE),
                    mjb.make_controller("signal", t=[0, 1], torque=[0, 1], interpolation="hold",
                                        drive=mjb.make_drive(**DRIVE)))
    with pytest.raises(ScenarioError, match='type = "signal" with t'):
        mjb.load("incerti2012", **{"modes.open.voltage": [0, 24]})
