"""A plain Python function as the controller (issue 34 item 6)."""
from __future__ import annotations

import numpy as np
import pytest

import mjbench as mjb
from mjbench.errors import ParameterError


def test_function_controller_equals_the_builtin_law():
    """A P controller written by hand as f(t, y) gives the run of the built-in PID with the same gain
    (K_i = K_d = 0, no ramp) to 1e-9; it is called every co-step; the run says it used the CPython
    loop and why."""
    scn = mjb.load("incerti2012", ["modes.pid.ki=0", "modes.pid.kd=0", "modes.pid.kp_ramp=false",
                                   "modes.pid.kp=0.05"])
    z = float(scn.spec.drive.z)
    w0 = float(scn.spec.modes["pid"].omega0)
    vmax = scn.spec.modes["pid"].v_limit
    calls = []

    def p_law(t, y):
        calls.append(t)
        v = 0.05 * z * (w0 / z - y["crank_speed_rad_s"])  # motor-side error φ̇_ref − φ̇ = z·(α̇_ref − α̇)
        return float(np.clip(v, -vmax, vmax)) if vmax is not None else v

    ref = scn.simulate("pid", backend="reduced", t_end=0.3)
    mine = scn.simulate("pid", backend="reduced", t_end=0.3, controller=p_law)
    a, b = ref["reduced"], mine["reduced"]
    assert np.max(np.abs(a["crank_speed_rad_s"] - b["crank_speed_rad_s"])) <= 1e-9 * np.max(np.abs(a["crank_speed_rad_s"]))
    assert np.max(np.abs(a["current_A"] - b["current_A"])) <= 1e-9 * np.max(np.abs(a["current_A"]))
    assert len(calls) >= 0.3 / float(scn.spec.simulation.dt) - 1  # called every co-step
    meta = b.meta
    assert meta["loop"] == "python" and "CPython" in meta["loop_reason"] and "FunctionController" in meta["loop_reason"]
    assert mine.metrics["controller"][0]["type"] == "function"


def test_function_controller_open_loop_is_the_open_mode(tmp_path):
    """A constant function is an open loop: the same run as the scenario's open-loop mode with that
    voltage, sample for sample (bit for bit); the saved manifest records the function."""
    scn = mjb.load("incerti2012")
    if "open" not in scn.spec.modes:
        pytest.skip("no open-loop mode")
    V = float(scn.spec.modes["open"].voltage)
    ref = scn.simulate("open", backend="reduced", t_end=0.2)
    mine = scn.simulate("open", backend="reduced", t_end=0.2, controller=lambda t, y: V)
    assert np.array_equal(ref["reduced"]["crank_speed_rad_s"], mine["reduced"]["crank_speed_rad_s"])
    mine.save(tmp_path / "out")
    import json

    man = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert man["controller_replaced_by"][0]["type"] == "function"


def test_function_controller_bad_input_is_one_line():
    scn = mjb.load("incerti2012")
    with pytest.raises(ParameterError, match="controller function .*must return a number"):
        scn.simulate(backend="reduced", t_end=0.01, controller=lambda t, y: "x")
    with pytest.raises(ParameterError, match="not finite"):
        scn.simulate(backend="reduced", t_end=0.01, controller=lambda t, y: float("nan"))
    with pytest.raises(ParameterError, match="give a function"):
        scn.simulate(backend="reduced", t_end=0.01, controller=3.0)
