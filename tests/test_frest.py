"""Frequency response of the nonlinear machine (`mjbench frest`, mjbench/frest.py, docs/bridges.md §3)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mjbench import frest
from mjbench import scenario as S


@pytest.mark.parametrize("name, backend", [("incerti-bezier", "reduced"), ("incerti-belt", "reduced"),
                                           ("incerti-bezier", "multibody")])
def test_ideal_drive_equals_linearisation_on_the_elastic_platforms(name, backend):
    """Constant inertia: the frozen-angle model holds over the whole band; measured = linear within
    1 % in magnitude and 1° in phase, plant and loop; margins agree; coherence 1."""
    res = frest.measure(S.load(name), backend=backend)
    js = res["json"]
    assert js["inertia_rate_1_s"] == 0.0
    assert js["band_rad_s"][0] == pytest.approx(js["lines_rad_s"][0])  # the whole excited band
    assert len(js["lines_rad_s"]) >= 25 and js["lines_rad_s"][-1] > 2000.0
    for k in ("plant", "loop"):
        c = js["comparison"][k]
        assert c["max_mag_diff"] <= 0.01 and c["max_phase_diff_deg"] <= 1.0, (k, c)
    assert js["max_rel_diff_vs_linear"] <= 0.02
    assert min(js["plant"]["coherence"]) > 0.99
    m, ml = js["loop"]["margins"], js["loop"]["margins_linear"]
    assert m["gain_margin_dB"] == pytest.approx(ml["gain_margin_dB"], abs=0.2)
    assert m["phase_margin_deg"] == pytest.approx(ml["phase_margin_deg"], abs=1.0)
    assert m["peak_sensitivity"] <= ml["peak_sensitivity"] * 1.01  # measured on the lines: a lower bound
    # the FRD objects are python-control's
    import control

    assert isinstance(res["frd"]["loop"], control.FrequencyResponseData)
    np.testing.assert_allclose(res["frd"]["plant"].omega, res["omega"])


def test_the_estimate_sees_a_wrong_model():
    """Not a tautology: the same measurement against the linearisation of a different machine
    (drive.R × 1.2) differs by more than the 1 % the test above allows."""
    from mjbench import linear as LN

    res = frest.measure(S.load("incerti-bezier"), backend="reduced")
    op = res["json"]["operating_point"]
    other = S.make_machine(S.load("incerti-bezier", ["drive.R=1.2"]), None)
    opo = LN.operating_point(other, op["q_rad"], op["qd_rad_s"])
    held = frest.hold_machine(other, opo, 1e-4)
    P = LN.sample(LN.reduced_plant(held, opo, 1e-4, angle="frozen"), 1)
    Gl = LN.response(P, res["omega"], "qd", "V")
    assert frest.compare(res["P"], Gl, np.ones(len(Gl), bool))["max_mag_diff"] > 0.05


def test_stepped_sine_agrees_with_multisine():
    scn = S.load("incerti-bezier")
    kw = dict(backend="reduced", band=(50.0, 800.0), n_lines=3, settle=1.5, periods=2)
    a = frest.measure(scn, signal="multisine", **kw)
    b = frest.measure(scn, signal="sine", **kw)
    np.testing.assert_allclose(a["omega"], b["omega"])
    assert np.max(np.abs(a["P"] - b["P"]) / np.abs(a["P"])) < 2e-3
    assert b["json"]["n_runs"] == 4


def test_margins_from_frd_on_a_known_loop():
    """Crossings of L = k·e^{−jωτ}/(jω) read from sampled lines: PM = 90° − ω_c·τ, GM at ω·τ = π/2."""
    k, tau = 10.0, 0.01
    w = np.logspace(0, 3, 400)
    L = k * np.exp(-1j * w * tau) / (1j * w)
    m = frest.margins_from_frd(w, L)
    assert m["w_gain_crossover_rad_s"] == pytest.approx(k, rel=1e-3)
    assert m["phase_margin_deg"] == pytest.approx(90.0 - math.degrees(k * tau), abs=0.05)
    w180 = math.pi / 2 / tau
    assert m["gain_margin_dB"] == pytest.approx(-20 * math.log10(k / w180), abs=0.05)


def test_seed000_pid_on_the_limiter_departs_from_the_linear_loop():
    """Seed 000's PID (K_p·t frozen at 2 s) sits on its ±48 V limiter at 30 rad/s: the measured loop
    is not the linear one (low coherence, distortion), and frest.json says how much of the time the
    limiter is on."""
    js = frest.measure(S.load("incerti2012"), "pid", backend="reduced", periods=2, n_lines=12)["json"]
    assert js["limiter_active_fraction"] > 0.05
    assert js["max_rel_diff_vs_linear"] > 0.5
    assert js["band_rad_s"][0] > 500.0  # the frozen band of a running four-bar: above 10 × max|J'·q̇|/J
    assert js["frozen_family"]["n_angles"] == 12


SCENARIOS = S.builtin_names()


@pytest.mark.parametrize("name", SCENARIOS)
def test_frest_runs_on_every_shipped_scenario(name, tmp_path):
    """The CLI on every built-in scenario with its default mode (short settings: smoke test)."""
    from mjbench.cli import main

    out = tmp_path / "fr"
    rc = main(["frest", name, "--lines", "6", "--periods", "2", "--settle", "0.1", "--period", "0.2",
               "--band", "30,2000", "--out", str(out)])
    assert rc == 0
    js = json.loads((out / "frest.json").read_text())
    assert {"max_rel_diff_vs_linear", "band_rad_s", "lines_rad_s", "plant", "comparison"} <= set(js)
    assert len(js["lines_rad_s"]) >= 3 and (out / "bode.png").stat().st_size > 10_000
