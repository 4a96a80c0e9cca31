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
