"""A DC motor given by its datasheet ([drive.datasheet]): the converted drive, run, gives back the
datasheet's no-load speed and current and its stall torque and current (the motor's closed-form
steady states); the conversion is in the manifest; a value given two ways must agree."""
import json
import math

import pytest

import mjbench as mjb
from mjbench.errors import ScenarioError

RPM = 2 * math.pi / 60
#: a 24 V motor as a catalogue states it (no terminal resistance: it comes from the stall values)
SHEET = {"rated_voltage": "24 V", "no_load_speed": "4000 rpm", "no_load_current": "0.2 A", "stall_torque": "1.2 N*m",
         "inductance": "0.3 mH", "rotor_inertia": "1 kg*cm^2", "gear_ratio": 1}


def _run(sheet, J, t_end, **drive):
    machine = mjb.Machine(mjb.make_mechanism("rotor", J=J), mjb.make_drive(datasheet=sheet, **drive),
                          mjb.make_controller("open", voltage=24.0))
    return machine, mjb.simulate(machine, backend="reduced", t_end=t_end, record_dt="1 ms")["reduced"]


def test_no_load_speed_and_current_come_back_from_a_run():
    """At V_n without load the motor settles where k_m·I = λ·ω and V = R·I + k_m·ω: with
    k_m = (V_n − R·I_0)/ω_0 and λ = k_m·I_0/ω_0 that is ω_0 and I_0 exactly."""
    machine, run = _run(SHEET, J=1e-4, t_end=2.0)   # J_t = 2e-4 kg·m²: τ_mech = J_t·R/k_m² ≈ 0.08 s
    assert run["motor_speed_rad_s"][-1] == pytest.approx(4000 * RPM, rel=1e-6)
    assert run["current_A"][-1] == pytest.approx(0.2, rel=1e-5)


def test_stall_torque_and_current_come_back_from_a_run():
    """The rotor held (J = 1e4 kg·m²: 2.4e-6 rad/s after 20 ms): the torque at V_n is the stall
    torque, the current V_n/R — R and k_m both derived from the stall torque and no-load values."""
    machine, run = _run(SHEET, J=1e4, t_end=0.02)
    d = machine.drive
    assert run["crank_speed_rad_s"][-1] < 1e-5
    assert d.k_m * run["current_A"][-1] == pytest.approx(1.2, rel=1e-5)
    assert run["torque_crank_Nm"][-1] == pytest.approx(1.2, rel=1e-5)
    # the same motor stated by its terminal resistance and stall current instead of the stall torque
    R = d.R
    sheet = {**{k: v for k, v in SHEET.items() if k != "stall_torque"}, "terminal_resistance": R}
    _, run2 = _run(sheet, J=1e4, t_end=0.02)
    assert run2["current_A"][-1] == pytest.approx(24.0 / R, rel=1e-5)
    assert run2["torque_crank_Nm"][-1] == pytest.approx(1.2, rel=1e-4)


def test_conversion_formulas():
    V, w0, I0, Ts = 24.0, 4000 * RPM, 0.2, 1.2
    d = mjb.make_drive(datasheet=SHEET)
    km = V / (w0 + V * I0 / Ts)
    assert d.k_m == pytest.approx(km, rel=1e-12) and d.R == pytest.approx(km * V / Ts, rel=1e-12)
    assert d.lam == pytest.approx(km * I0 / w0, rel=1e-12) and d.z == 1.0 and d.J_m == pytest.approx(1e-4)
    # without the no-load current: k_m = V/ω_0, no friction
    d0 = mjb.make_drive(datasheet={**SHEET, "no_load_current": None, "gear_ratio": None, "gear_efficiency": 0.9}, z=20)
    with pytest.raises(ScenarioError, match=r"drive.z = 20 differs from the datasheet.s 1 \(gear_ratio\)"):
        mjb.make_drive(datasheet=SHEET, z=20)
    assert d0.k_m == pytest.approx(V / w0, rel=1e-12) and d0.lam == 0.0 and d0.train.gear.efficiency == 0.9
    with pytest.raises(ScenarioError, match=r"drive.R = 3 differs from the datasheet's .* \(k_m·rated_voltage / stall_torque\)"):
        mjb.make_drive(datasheet=SHEET, R=3)
    with pytest.raises(ScenarioError, match="needs terminal_resistance, stall_current or stall_torque"):
        mjb.make_drive(datasheet={k: v for k, v in SHEET.items() if k != "stall_torque"})
    # an explicit value equal to the derived one is accepted (a run's manifest holds both)
    assert mjb.make_drive(datasheet=SHEET, L="0.3 mH").L == pytest.approx(3e-4)


def test_scenario_manifest_states_the_conversion_and_reruns(tmp_path):
    raw = {"scenario": {"name": "sheet"}, "mechanism": {"type": "rotor", "J": 0.01},
           "drive": {"z": 10, "datasheet": {**SHEET, "stall_current": "10 A", "gear_ratio": None,
                                             "rated_current": "3 A"}},
           "simulation": {"t_end": 0.2, "mode": "open", "backend": "reduced"},
           "modes": {"open": {"type": "open", "voltage": 24.0}}}
    with pytest.warns(mjb.MjbenchWarning, match="stall_torque 1.2 N·m and k_m·stall_current = 0.5615 N·m"):
        scn = mjb.load(raw)
    # the stall torque and k_m·stall_current disagree (1.2 against 0.56 N·m): one warning naming both
    assert len(scn.warnings) == 1 and "differ by more than 10%" in scn.warnings[0]
    res = scn.simulate()
    out = res.save(tmp_path / "run")
    man = json.loads((out / "manifest.json").read_text())
    conv = man["drive_from_datasheet"]
    assert conv["R"].endswith("= rated_voltage / stall_current") and conv["R"].startswith("2.4 Ω")
    assert "(rated_voltage − R·no_load_current) / no_load_speed" in conv["k_m"] and conv["i_rated"].startswith("3 A")
    assert man["scenario"]["drive"]["R"] == pytest.approx(2.4) and man["scenario"]["drive"]["i_rated"] == 3.0
    with pytest.warns(mjb.MjbenchWarning):
        again = mjb.load(out / "manifest.json").simulate()
    assert (again["reduced"].data == res["reduced"].data).all()
