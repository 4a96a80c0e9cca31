"""The engineer's first hour (issue 34): what a newcomer meets first says what it is — results in
python-control's shape, named linear signals, errors in the caller's language, a sweep that asks
what to rank by, a design report that explains its choice (flywheel size, failure lines)."""
import math

import numpy as np
import pytest

import mjbench as mjb
from mjbench.cli import main
from mjbench.design import report as DR
from mjbench.outputs import OutputError
from mjbench.trajectory import column_label


def test_runs_have_inputs_states_and_labels_like_python_control():
    res = mjb.load("incerti2012").simulate("open", "both", "20 ms")
    run = res["multibody"]
    n = len(run)
    assert run.input_labels == ["voltage_V"] and run.inputs.shape == (1, n)
    assert np.array_equal(run.inputs[0], run["voltage_V"])
    assert run.state_labels == ["crank_angle_rad", "crank_speed_rad_s", "current_A"]
    assert run.states.shape == (3, n) and np.array_equal(run.states[2], run["current_A"])
    assert res.state_labels == run.state_labels and res.inputs.shape == (1, n)   # the primary run's
    plat = mjb.load("incerti-belt").simulate(backend="reduced", t_end="20 ms")["reduced"]
    assert plat.state_labels == ["crank_angle_rad", "crank_speed_rad_s", "deflection_rad", "deflection_rate_rad_s",
                                 "current_A"]


def test_linear_loops_name_their_signals_and_states():
    lin = mjb.linearize("incerti2012", "pid", angles=0)
    L = lin.loop.L
    assert list(L.input_labels) == ["V"] and list(L.output_labels) == ["-u"]
    assert list(L.state_labels) == ["q", "qd", "I", "qd_prev"]          # the plant's; the PID has no state
    assert list(lin.loop.S.input_labels) == ["d"] and list(lin.loop.feedback.output_labels)[:2] == ["q", "qd"]
    assert not any(s.startswith(("x[", "u[", "y[")) for sys in (L, lin.loop.S, lin.loop.T, lin.loop.feedback)
                   for s in list(sys.state_labels) + list(sys.input_labels) + list(sys.output_labels))
    # the names change nothing: the margins are python-control's of the same matrices
    import control as ct

    with pytest.warns(UserWarning):  # python-control falls back to its frequency-response method here
        pm = ct.margin(L)[1]
    assert pm == pytest.approx(lin.margins.phase_margin_deg, abs=1e-3)


def test_api_errors_speak_python(tmp_path):
    res = mjb.load("incerti2012").simulate("open", "reduced", "5 ms")
    res.save(tmp_path / "run")
    with pytest.raises(OutputError, match="pass force=True to replace") as e:
        res.save(tmp_path / "run")
    assert "--force" not in str(e.value)
    assert main(["run", "incerti2012", "--mode", "open", "--backend", "reduced", "--t-end", "0.005", "--quiet",
                 "--out", str(tmp_path / "run")]) == 2                  # the CLI still says --force


def test_axis_labels_carry_quantity_and_unit():
    assert column_label("crank_speed_rad_s") == "crank speed α̇ [rad/s]"
    assert column_label("current_A") == "armature current I [A]"
    assert column_label("joint_guide_m") == "joint guide position [m]"
    assert column_label("deflection_rate_rad_s") == "deflection rate [rad/s]"
    fig = mjb.load("incerti2012").simulate("open", "reduced", "5 ms").plot()
    assert [a.get_ylabel() for a in fig.axes] == ["motor speed φ̇ [rad/s]", "armature voltage V_a [V]",
                                                  "armature current I [A]"]
    assert fig.axes[-1].get_xlabel() == "time t [s]" and fig._repr_png_().startswith(b"\x89PNG")


def test_sweep_asks_what_to_rank_by(tmp_path, capsys):
    """press-slidercrank has no χ window: ranking its rows by mean speed (the old default) would
    verify the slowest machines; the sweep refuses before running and says how to choose."""
    out = tmp_path / "sw"
    assert main(["sweep", "press-slidercrank", "--grid", "drive.J_b=1,2", "--t-end", "0.5", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--metric: scenario 'press-slidercrank' has no metrics.chi_window" in err and "--metric chi_last_cycle" in err
    assert not out.exists()


def test_flywheel_as_a_steel_disc():
    J = 0.0058013
    d = DR.flywheel_disc(J)
    r, t = d["diameter_m"] / 2, d["thickness_m"]
    assert 0.5 * d["mass_kg"] * r * r == pytest.approx(J, rel=1e-12)        # J = ½·m·r² back
    assert d["mass_kg"] == pytest.approx(7850 * math.pi * r * r * t, rel=1e-12) and t == pytest.approx(0.2 * 2 * r)
    txt = DR.flywheel_text({"flywheel_kgm2": J, "flywheel_location": "motor", "ratio": 50})
    assert txt.startswith("0.0058013 kg·m² on the motor shaft: a steel disc Ø130 × 26 mm, 2.73 kg")
    assert "14.503 kg·m² at the crank" in txt


def test_failure_lines_read_once():
    f = {"name": "voltage (hot winding) ≤ supply × (1 − headroom) = 21.6 V", "value": 23.161, "limit": 21.6,
         "compare": "max", "unit": "V"}
    assert DR.failure_text(f) == ("voltage (hot winding): 23.161 V, above the allowed 21.6 V "
                                  "(supply × (1 − headroom)) by 7.23 %")
    g = {"name": "the drive starts the machine from rest", "value": False, "compare": "true"}
    assert DR.failure_text(g) == "the drive starts the machine from rest: not met"


def test_runners_up_by_cost():
    cands = [{"label": f"M{i}", "ok": i != 2, "cost": 100.0 + i, "chi": 0.04, "current_rms_A": 2.0,
              "tightest": {"name": "RMS motor torque ≤ continuous rating", "margin": 0.1 * i}} for i in range(6)]
    head, body = DR.runners_up_rows({"sizing": {"candidates": cands[::-1]}})
    assert [b[1] for b in body] == ["M0", "M1", "M3", "M4"]                   # the chosen + three feasible
    assert body[0][0] == "chosen" and body[2][3] == "+3 (3 %)" and body[3][6] == "RMS motor torque: 40.0 %"
