"""Drive types (mjbench/drives/, docs/engine.md "Drive types"): an ideal torque source and a stiff
speed source beside the DC motor — closed forms on a flywheel, both backends, the same bits compiled
and in CPython, the scenario checks, the DC motor's record unchanged."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mjbench import drives
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.errors import ParameterError, ScenarioError, SimulationDiverged

BACKENDS = ("reduced", "multibody")
ELEC = ("current_A", "voltage_V", "power_elec_W")


def _rotor(drive, mode, J=0.01, load=0.0, damping=0.0, t_end=0.2, dt=1e-4):
    return S.from_raw({"scenario": {"name": "rotor-bench"},
                       "mechanism": {"type": "rotor", "J": J, "load_torque": load, "damping": damping},
                       "drive": drive, "simulation": {"t_end": t_end, "dt": dt, "record_dt": 1e-3},
                       "modes": {"m": mode}})


def _both_loops(scn, backend, t_end):
    py = simulate(S.make_machine(scn, "m"), backend, t_end, options={"timestep": scn.simulation.dt}, loop="python")
    cc = simulate(S.make_machine(scn, "m"), backend, t_end, options={"timestep": scn.simulation.dt},
                  loop="compiled")
    assert py.meta["loop"] == "python" and cc.meta["loop"] == "compiled", cc.meta["loop_reason"]
    assert py.columns == cc.columns
    np.testing.assert_array_equal(py.data, cc.data)  # NaN in the same places, every other bit equal
    return cc


@pytest.mark.parametrize("backend", BACKENDS)
def test_torque_source_accelerates_a_flywheel_as_newton_says(backend):
    """T on J: q̈ = T/J exactly (RK4 on a constant acceleration is exact; MuJoCo's too); the torque
    column is the command, the delivered power T·q̇, the electrics NaN; a ramp t_ramp ramps it."""
    T, J = 0.5, 0.01
    tr = _both_loops(_rotor({"type": "torque"}, {"type": "constant", "torque": "0.5 N*m"}, J=J), backend, 0.2)
    t = tr.t
    np.testing.assert_allclose(tr.qd, T / J * t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(tr.q, 0.5 * T / J * t ** 2, rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(tr.qdd, T / J, rtol=1e-9)  # row 0 too: the forward difference of step 1
    assert np.all(tr["torque_crank_Nm"] == T)
    np.testing.assert_array_equal(tr.p_mech, T * tr.qd)
    np.testing.assert_array_equal(tr.omega, tr.qd)  # z = 1
    for c in ELEC:
        assert np.all(np.isnan(tr[c])), c
    # the drive's own inertia and damping sit on the input joint: (J + J_s)·q̈ = T − c·q̇
    Js, c = 0.03, 0.2
    tr = simulate(S.make_machine(_rotor({"type": "torque", "J": Js, "damping": c},
                                        {"type": "constant", "torque": T, "t_ramp": 0.05}, J=J), "m"), backend, 0.3)
    tau = (J + Js) / c
    te = tr.t[tr.t >= 0.05] - 0.05
    w0 = float(tr.qd[tr.t >= 0.05][0])
    expect = T / c + (w0 - T / c) * np.exp(-te / tau)
    np.testing.assert_allclose(tr.qd[tr.t >= 0.05], expect, rtol=1e-8)
    np.testing.assert_allclose(tr["torque_crank_Nm"], np.minimum(tr.t / 0.05, 1.0) * T - c * tr.qd, rtol=1e-12,
                               atol=1e-15)


@pytest.mark.parametrize("backend", BACKENDS)
def test_speed_source_follows_its_command_under_a_load(backend):
    """A PI speed loop holds the commanded speed against a load torque (final error ~0, torque =
    the load); a proportional loop is a first-order lag to ω* + T_L/k_v with time constant J/k_v."""
    w = 100 * 2 * math.pi / 60
    scn = _rotor({"type": "speed", "k_v": 20.0, "k_i": 2000.0}, {"type": "constant", "speed": "100 rpm"},
                 load=-0.5, t_end=0.5)
    tr = _both_loops(scn, backend, 0.5)
    assert tr.qd[-1] == pytest.approx(w, rel=1e-12)
    assert tr["torque_crank_Nm"][-1] == pytest.approx(0.5, rel=1e-9)
    for c in ELEC:
        assert np.all(np.isnan(tr[c])), c
    kv, J, TL = 5.0, 0.01, -0.5
    tr = simulate(S.make_machine(_rotor({"type": "speed", "k_v": kv}, {"type": "constant", "speed": w},
                                        J=J, load=TL, t_end=0.1), "m"), backend, 0.1)
    ws = w + TL / kv
    # −k_v·q̇ is integrated inside the step (RK4: error (h·k_v/J)⁵/120 = 2.6e-9 per step here; a torque
    # held over the step would be off by h·k_v/J = 5 % per step)
    np.testing.assert_allclose(tr.qd, ws * (1 - np.exp(-tr.t * kv / J)), rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(tr["torque_crank_Nm"], kv * (w - tr.qd), rtol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_ideal_drives_on_a_linkage_compile_with_the_same_bits(backend):
    """The seed-000 four-bar (gravity, a closed loop) under each ideal drive: compiled = CPython."""
    raw = S.load("incerti2012").raw
    for drive, mode in (({"type": "torque", "T_max": 4.0}, {"type": "constant", "torque": 6.0}),
                        ({"type": "speed", "k_v": 2.0, "k_i": 20.0, "J": 0.01}, {"type": "constant", "speed": 20.0})):
        scn = S.from_raw({**{k: v for k, v in raw.items() if k not in ("drive", "modes", "paper", "aliases")},
                          "drive": drive, "modes": {"m": mode}, "simulation": {"t_end": 0.2}})
        tr = _both_loops(scn, backend, 0.2)
        assert tr.qd.max() > 1.0
        if drive["type"] == "torque":  # the command is clipped at ±T_max
            assert np.all(tr["torque_crank_Nm"] == 4.0)


def test_pid_on_a_torque_source():
    """A PID's output is the input torque on a torque source (its gains in N·m per unit error)."""
    scn = _rotor({"type": "torque"}, {"type": "pid", "kp": 0.2, "ki": 2.0, "kd": 0.0, "omega0": 30.0}, load=-0.3,
                 t_end=1.0)
    tr = simulate(S.make_machine(scn, "m"), "reduced", 1.0)
    assert tr.qd[-1] == pytest.approx(30.0, rel=1e-3)
    assert tr["torque_crank_Nm"][-1] == pytest.approx(0.3, rel=1e-2)


def test_scenario_checks_of_the_drive_types():
    base = _rotor({"type": "torque"}, {"type": "constant", "torque": 1.0}).raw
    cases = [
        ({"modes": {"m": {"type": "open", "voltage": 12.0}}}, 'type = "open" gives an armature voltage'),
        ({"modes": {"m": {"type": "constant", "speed": 3.0}}}, 'needs [drive] type = "speed"'),
        ({"modes": {"m": {"type": "constant", "torque": 1.0, "speed": 3.0}}}, "exactly one of torque"),
        ({"initial": {"I0": 2.0}}, "has no current"),
        ({"drive": {"type": "hydraulic"}}, "'hydraulic' is not a known drive type; choose one of dcmotor, speed, torque"),
        ({"drive": {"type": "torque", "R": 1.0}}, "drive.R: unknown key"),
        ({"drive": {"type": "speed"}}, "drive.k_v: required value is missing"),
        ({"drive": {"type": "torque", "T_max": -1.0}}, "drive.T_max: must be > 0"),
    ]
    for change, msg in cases:
        with pytest.raises(ScenarioError, match=None) as e:
            S.from_raw({**base, **change})
        assert msg in str(e.value), (change, str(e.value))
    dc = S.load("incerti2012").raw
    with pytest.raises(ScenarioError) as e:
        S.from_raw({**dc, "modes": {**dc["modes"], "x": {"type": "constant", "torque": 1.0}}})
    assert 'modes.x: type = "constant" with torque = … needs [drive] type = "torque"' in str(e.value)
    assert drives.names() == ["dcmotor", "speed", "torque"]


def test_a_dc_motor_quantity_of_an_ideal_drive_is_a_named_error():
    d = S.make_machine(_rotor({"type": "torque"}, {"type": "constant", "torque": 1.0}), "m").drive
    with pytest.raises(ParameterError, match=r'drive\.R: \[drive\] type = "torque" is an ideal torque source'):
        d.R
    assert getattr(d, "v_max", "fallback") == "fallback"  # also an AttributeError
    assert d.J_eq == 0.0 and d.z == 1.0 and d.train is None


def test_too_stiff_a_speed_loop_diverges_with_its_cause():
    scn = _rotor({"type": "speed", "k_v": 400.0}, {"type": "constant", "speed": 10.0}, J=0.01)
    with pytest.raises(SimulationDiverged, match=r"speed loop is too stiff for the step: h·k_v/\(J_eq \+ J\(q\)\) = 4"):
        simulate(S.make_machine(scn, "m"), "reduced", 0.2)


def test_the_dc_motor_records_what_it_did():
    """The DC motor's record law writes the same columns as before the drive types: k_m·I·φ̇ and
    V·I to the bit, the crank torque Eq 9, the applied voltage."""
    scn = S.load("incerti2012")
    mc = S.make_machine(scn, "pid")
    tr = simulate(mc, "reduced", 0.3)
    d = mc.drive
    I, V, w = tr.current, tr.voltage, tr.omega
    np.testing.assert_array_equal(tr.p_mech, d.k_m * I * w)
    np.testing.assert_array_equal(tr.p_elec, V * I)
    np.testing.assert_array_equal(tr["torque_crank_Nm"], d.crank_torque(I, tr.qd))
    assert np.all(np.isfinite(tr.data[:, :11]))
