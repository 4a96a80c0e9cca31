"""Autotuning (issue 7): for seed 000 the tuned PID beats the paper's gains on χ in the paper's
window 0.375–0.5 s without exceeding the paper run's voltage and current peaks."""
import numpy as np
import pytest

from mjbench import cli, scenario
from mjbench.errors import ParameterError
from mjbench.outputs import read_json
from mjbench.tune import Problem, tune


def test_tuned_pid_beats_paper_gains_on_chi():
    scn = scenario.load("incerti2012")
    res = tune(scn, "pid-tv", "chi", n_global=24, maxfev=24, log=lambda *a: None)
    base, tuned = res.validation["baseline"], res.validation["tuned"]
    assert base["chi"] == pytest.approx(0.07235, abs=2e-4)  # paper gains, our stated model
    assert tuned["chi"] < 0.8 * base["chi"]
    # allowed peaks: those of the paper's gains (defaults of --limit)
    assert tuned["peak_voltage_V"] <= res.limits["voltage"] + 1e-9
    assert tuned["peak_current_A"] <= res.limits["current"] * (1 + 1e-9)
    assert res.improvement > 0.2
    # the batch and the single-run validation agree on the winner's χ
    prob = Problem(scn, "pid-tv", "chi", res.limits)
    x = np.array([res.best[p] for p in prob.params])
    _, mets = prob.evaluate(np.vstack([x, x]))  # 2 rows: the batched path
    assert mets[0]["chi"] == pytest.approx(tuned["chi"], rel=1e-9)


def test_tune_cli_limits_and_errors(tmp_path, capsys):
    rc = cli.main(["tune", "incerti2012", "--controller", "pid", "--objective", "ise", "--global", "4",
                   "--maxfev", "4", "--t-end", "0.2", "--limit", "voltage=40,current=25", "--out", str(tmp_path)])
    assert rc == 0
    out = capsys.readouterr().out
    assert "improvement of ise" in out and read_json(tmp_path / "tune.json")["objective"] == "ise"  # strict JSON
    assert (tmp_path / "tune_speed.png").stat().st_size > 1000
    with pytest.raises(ParameterError, match="objective"):
        Problem(scenario.load("incerti2012"), "pid", "nope")


def test_reduced_search_finds_the_multibody_optimum():
    """Search on the reduced model, verify on MuJoCo: same winner as a search on MuJoCo itself."""
    scn = scenario.load("incerti2012")
    kw = dict(n_global=8, maxfev=10, t_end=0.5, log=lambda *a: None)
    red = tune(scn, "pid-tv", "chi", backend="reduced", verify=2, **kw)
    mb = tune(scn, "pid-tv", "chi", backend="multibody", **kw)
    assert red.backend == "reduced" and len(red.verified) == 2
    for p in red.params:
        assert red.best[p] == pytest.approx(mb.best[p], rel=1e-3)
    chi_r, chi_m = red.validation["tuned"]["chi"], mb.validation["tuned"]["chi"]
    assert chi_r == pytest.approx(chi_m, rel=1e-2)
    # both figures of the winner are stated and agree to the models' accuracy (≈ 1e-5)
    assert red.search["tuned"]["chi"] == pytest.approx(chi_r, rel=1e-3)
    assert red.verified[0]["score_multibody"] == pytest.approx(red.verified[0]["score_search"], rel=1e-3)


def test_tune_with_margin_constraints(tmp_path, capsys):
    """--margin on the linear model: the tuned gains meet pm >= 60°, peak |S| <= 1.5 at every
    frozen angle (the scenario's gains do not: worst PM ≈ 42°, peak |S| ≈ 1.57), checked again on
    the linear model independently of the tuner's bookkeeping."""
    from mjbench import linear

    scn = scenario.load("incerti2012")
    res = tune(scn, "pid", "ise", n_global=8, maxfev=8, t_end=0.3, margins=["pm>=60", "ms<=1.5"],
               margin_angles=8, log=lambda *a: None)
    base, tuned = res.validation["baseline"]["margins"], res.validation["tuned"]["margins"]
    assert base["violation"] > 0 and tuned["violation"] == 0
    prob = Problem(scn, "pid", "ise", res.limits, t_end=0.3)
    m = prob.machine(np.array([res.best[p] for p in prob.params]))
    w = linear.family_margins(m, linear.plant_family(m, 1e-4, 8), 1e-4)
    assert w["phase_margin_deg"] >= 60 and w["peak_sensitivity"] <= 1.5
    rc = cli.main(["tune", "incerti2012", "--controller", "pid", "--objective", "ise", "--global", "2",
                   "--maxfev", "2", "--t-end", "0.1", "--margin", "pm>=45", "--margin-mode", "constraint",
                   "--margin-angles", "4", "--out", str(tmp_path / "t")])
    assert rc == 0 and "worst pm >= 45" in capsys.readouterr().out
    assert cli.main(["tune", "incerti2012", "--controller", "pid", "--margin", "pm<=45"]) == 2
    assert "lower bound" in capsys.readouterr().err
    assert cli.main(["tune", "yigit2023", "--controller", "smc", "--objective", "ise", "--margin", "pm>=45"]) == 2
    assert "boundary" in capsys.readouterr().err


# ============================================================================ what a controller declares
def test_tunable_gains_are_the_controller_classes_declarations():
    """``tune --controller`` reads Controller.TUNABLE / TUNE_VARIANTS: the shipped families as they
    were hard-coded before (pid, pid-tv, smc, servo), any other class by its own declaration."""
    from mjbench.tune import tunable_controllers, tune_spec

    got = {k: (s.ctype, s.params, s.fixed) for k, s in tunable_controllers().items()}
    assert got == {"pid": ("pid", ("kp", "ki", "kd"), {"kp_ramp": False}),
                   "pid-tv": ("pid", ("kp", "ki", "kd"), {"kp_ramp": True}),
                   "smc": ("smc", ("lam", "K"), {}), "servo": ("servo", ("kpp", "kvp", "kvi"), {}),
                   "computed_torque": ("computed_torque", ("wn",), {})}
    assert tune_spec("pid-tv").fixed == {"kp_ramp": True}
    with pytest.raises(ParameterError, match="'open': its class declares no tunable gains.*pid, pid-tv"):
        tune_spec("open")
    with pytest.raises(ParameterError, match="'nope': no controller type or tuning variant"):
        tune_spec("nope")


def test_a_bad_declaration_is_refused():
    from controllers.pid import PID

    from mjbench.tune import declared_specs

    class Typo(PID):
        TUNABLE = {"kpp": (0.0, 1.0)}  # not a field of PIDParams

    class Empty(PID):
        TUNABLE = {"kp": (2.0, 1.0)}  # lo >= hi

    for cls in (Typo, Empty):
        with pytest.raises(ParameterError, match="TUNABLE"):
            declared_specs(cls)


def test_search_box_within_the_declared_intervals():
    """The box ×/÷ span around the scenario's gains, clipped to each gain's admissible interval;
    a zero gain with a finite interval searches that interval; --bounds outside it are refused."""
    from mjbench.tune import search_box

    iv = {"a": (0.0, np.inf), "b": (1.0, 30.0), "c": (0.5, 8.0)}
    lo, hi = search_box(("a", "b", "c"), np.array([2.0, 10.0, 0.0]), 10.0, None, iv)
    np.testing.assert_allclose(np.exp(lo), [0.2, 1.0, 0.5], rtol=1e-15)
    np.testing.assert_allclose(np.exp(hi), [20.0, 30.0, 8.0], rtol=1e-15)
    # without a declaration (intervals None: 0 ... inf) the box is x0 ×/÷ span, as before
    lo, hi = search_box(("a",), np.array([2.0]), 10.0, None)
    assert (lo[0], hi[0]) == (np.log(0.2), np.log(20.0))
    with pytest.raises(ParameterError, match="--bounds b=0.5:20: outside the interval 1 ... 30"):
        search_box(("a", "b", "c"), np.array([2.0, 10.0, 1.0]), 10.0, {"b": (0.5, 20.0)}, iv)
    with pytest.raises(ParameterError, match="c = 100 in the scenario.*outside the interval 0.5 ... 8"):
        search_box(("c",), np.array([100.0]), 10.0, None, iv)
    with pytest.raises(ParameterError, match="a = 0 in the scenario, so ×/÷ --span gives no interval"):
        search_box(("a",), np.array([0.0]), 10.0, None, iv)
