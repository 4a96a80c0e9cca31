"""Metrics on synthetic signals with known answers; scenario loading and overrides."""
import numpy as np
import pytest

from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.errors import ParameterError, ScenarioError


def test_chi_of_a_sine():
    t = np.linspace(0, 2, 20001)
    w = 30 + 5 * np.sin(2 * np.pi * 2 * t)
    assert M.chi(t, w, 0.5, 1.0) == pytest.approx(10 / 30, rel=1e-6)  # whole periods: mean = 30
    assert M.chi(t, w, 0.5, 1.0, average="midrange") == pytest.approx(10 / 30, rel=1e-6)
    with pytest.raises(ParameterError, match="chi_average"):
        M.chi(t, w, average="median")


def test_cycles_of_constant_speed():
    t = np.linspace(0, 1, 10001)
    q = 2 * np.pi * 3.0 * t  # 3 rev/s
    cyc = M.cycles(t, q)
    assert len(cyc) == 2
    np.testing.assert_allclose(np.diff(cyc, axis=1), 1 / 3, rtol=1e-6)


def test_two_readings_of_the_last_cycle():
    """chi_last_cycle: the last complete cycle counted from α(0); chi_last_turn: the last 2π of
    travel ending at t_end.  On q(t) = ω·t + a·sin(ν t) (exact phase known) both windows span
    exactly 2π of travel, the first ends at the last multiple of 2π from q(0), the second at
    t_end, and χ over each equals a direct evaluation on its window."""
    from scipy.optimize import brentq

    from mjbench.trajectory import Trajectory

    w, a, nu, t_end = 10.0, 0.05, 37.0, 2.0
    t = np.linspace(0.0, t_end, 40001)

    def q(x):
        return w * x + a * np.sin(nu * x)

    qd = w + a * nu * np.cos(nu * t)
    tr = Trajectory(len(t), "synthetic")
    tr.data[:, 0], tr.data[:, 1], tr.data[:, 2], tr.data[:, 4] = t, q(t), qd, qd
    tr.data[:, 5:11] = 0.0
    tr.n = len(t)
    s = M.summary(tr)
    k = int(q(t_end) // (2 * np.pi))
    t_k = brentq(lambda x: q(x) - 2 * np.pi * k, 0, t_end)
    t_k1 = brentq(lambda x: q(x) - 2 * np.pi * (k - 1), 0, t_end)
    assert (s["last_cycle_start_s"], s["last_cycle_end_s"]) == pytest.approx((t_k1, t_k), abs=2e-5)
    t_turn = brentq(lambda x: q(x) - (q(t_end) - 2 * np.pi), 0, t_end)
    assert (s["last_turn_start_s"], s["last_turn_end_s"]) == pytest.approx((t_turn, t_end), abs=2e-5)
    assert s["chi_last_turn"] == pytest.approx(M.chi(t, qd, t_turn, t_end), rel=1e-3)
    assert s["last_cycle_end_s"] < t_end - 0.05  # here the complete cycle ends well before t_end
    assert M.last_turn(t[:100], q(t[:100])) is None  # less than 2π of travel


def test_relative_difference_is_peak_normalised():
    t = np.linspace(0, 1, 101)
    a = np.sin(2 * np.pi * t) * 10
    mx, rms = M.rel_difference(t, a, t, a + 0.1)
    assert mx == pytest.approx(0.01) and rms == pytest.approx(0.01)


def test_overrides_aliases_and_errors():
    scn = S.load("incerti2012", ["drive.R=2.5", "modes.pid.kp_ramp=false", "mechanism.a=0.09"])
    assert scn.drive.R == 2.5 and scn.modes["pid"].kp_ramp is False
    assert S.make_mechanism(scn).a == 0.09
    with pytest.raises(ScenarioError, match="drive.Rr: unknown key"):
        S.load("incerti2012", ["drive.Rr=2"])
    with pytest.raises(ScenarioError, match="expected key=value"):
        S.load("incerti2012", ["drive.R"])
    with pytest.raises(ScenarioError, match="unknown scenario 'nope'"):
        S.load("nope")
    with pytest.raises(ScenarioError, match="mode 'smc' is not defined"):
        S.make_machine(S.load("incerti2012"), "smc")


def test_every_builtin_scenario_loads():
    for name in S.builtin_names():
        scn = S.load(name)
        assert scn.name == name
