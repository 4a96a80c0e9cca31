"""Residual vibration of the elastic platforms (seeds 001, 003): E(T) closed form vs reduced ODE
vs MuJoCo, optimisation, paper optimum, shapers, ω_n sensitivity, models, CLI."""
import json
import math

import mujoco
import numpy as np
import pytest

from mjbench import scenario, vibration
from mjbench.errors import ParameterError, ScenarioError
from mjbench import mechanisms
from mjbench.mechanisms.platform import BeltPlatform, ElasticPlatform


def from_params(d):
    return mechanisms.from_dict({"type": "platform", **d})
from mjbench.motionlaws import BezierLaw, PseudoPolynomialLaw

PHI_001 = 2 * math.pi * 15  # 15 motor revolutions, T = 1 s (seed 001 §V)
PHI_003 = 2 * math.pi * 20  # 20 motor revolutions (seed 003 §V)


@pytest.fixture(scope="module")
def belt():
    return BeltPlatform()


@pytest.fixture(scope="module")
def elastic():
    return ElasticPlatform()


@pytest.fixture(scope="module")
def opt_belt(belt):
    return vibration.optimize(PseudoPolynomialLaw(PHI_001, 1.0, (3, 4, 5)), belt.oscillator())


@pytest.fixture(scope="module")
def opt_bezier(elastic):
    return vibration.optimize(BezierLaw(PHI_003, 1.0, 2, 3), elastic.oscillator())


def test_omega_n_and_xi_seed003(elastic):
    o = elastic.oscillator()
    assert o.omega_n == pytest.approx(53.36, abs=0.005)  # paper prints 53.3 (truncated)
    assert math.floor(o.omega_n * 10) / 10 == 53.3
    assert o.xi == pytest.approx(0.117, abs=5e-4)  # 11.7 %


def test_seed001_parameters(belt):
    o = belt.oscillator()
    assert o.ratio == pytest.approx(1 / 30)  # 15 motor turns → 180° of the platform
    assert o.k == pytest.approx(2 * 9e4 * 0.18 ** 2)  # k_t = 2kR²
    assert o.omega_n == pytest.approx(31.177, abs=1e-3)
    assert o.xi == pytest.approx(0.02598, abs=1e-5)


def test_parameter_errors():
    with pytest.raises(ParameterError, match="platform.k"):
        BeltPlatform(k=-1.0)
    with pytest.raises(ScenarioError, match="variant"):
        from_params({"variant": "chain"})
    with pytest.raises(ScenarioError, match="J9"):
        from_params({"variant": "elastic", "J9": 1.0})


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_closed_form_matches_adaptive_quadrature(belt, elastic):
    """The exact W (Gauss–Jacobi / by-parts series) against scipy.integrate.quad of Eq 30, to
    1e-12 of the integrand scale max|φ̈|·T (W itself is small after the cancellation)."""
    for law, osc in ((PseudoPolynomialLaw(PHI_001, 1.0, (3.024, 4.565, 5.874)), belt.oscillator()),
                     (BezierLaw(PHI_003, 1.0, 2, 3, PHI_003 * np.array([0.3, 0.55, 0.7])), elastic.oscillator())):
        W = vibration.convolution_W(law, osc)
        Wq = vibration._quad_W(law, osc, law.T)
        assert abs(W - Wq) < 1e-12 * law.peaks()["accel"] * law.T


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_closed_form_vs_ode(belt, elastic, opt_belt, opt_bezier):
    """E(T) closed form (Eq 31 / Eq 29) vs solve_ivp (DOP853, rtol 1e-12): |ΔE| < 1e-9·E0."""
    cases = [(opt_belt.law0, belt.oscillator(), opt_belt.E0), (opt_belt.law, belt.oscillator(), opt_belt.E0),
             (PseudoPolynomialLaw(PHI_001, 1.0, (3.024, 4.565, 5.874)), belt.oscillator(), opt_belt.E0),
             (opt_bezier.law0, elastic.oscillator(), opt_bezier.E0),
             (opt_bezier.law, elastic.oscillator(), opt_bezier.E0)]
    for law, osc, E0 in cases:
        Ec = vibration.residual_energy(law, osc)
        Eo = vibration.residual_energy_ode(law, osc)
        assert abs(Ec - Eo) < 1e-9 * E0 + 1e-9 * Ec, (law.describe(), Ec, Eo)


def test_closed_form_vs_multibody(belt, elastic, opt_belt, opt_bezier):
    """MuJoCo (RK4, 1 ms, driven joint imposed at every stage) vs closed form: |ΔE| < 1e-6·E0
    (measured 1.4e-7 for the 3-4-5 law, 2e-8 for the Bezier start; the error is O(h⁴))."""
    paper = PseudoPolynomialLaw(PHI_001, 1.0, (3.024, 4.565, 5.874))
    for plat, law, E0 in ((belt, opt_belt.law0, opt_belt.E0), (belt, paper, opt_belt.E0),
                          (belt, opt_belt.law, opt_belt.E0), (elastic, opt_bezier.law0, opt_bezier.E0),
                          (elastic, opt_bezier.law, opt_bezier.E0)):
        osc = plat.oscillator()
        Ec = vibration.residual_energy(law, osc)
        Em = vibration.residual_energy_multibody(plat, law, dt=1e-3)
        assert abs(Em - Ec) < 1e-6 * E0, (plat.variant, Ec, Em)
    # the multibody estimate resolves the optimised law: ≥ 6 orders below the start
    assert vibration.residual_energy_multibody(elastic, opt_bezier.law, dt=1e-3) < 1e-6 * opt_bezier.E0


def test_multibody_motor_follows_law_and_tracks_ode(elastic):
    law = BezierLaw(PHI_003, 1.0, 2, 3)
    r = vibration.simulate_multibody(elastic, law, t_end=1.3, dt=1e-3, record_dt=0.01)
    np.testing.assert_allclose(r["motor_angle"], law.position(r["t"]), atol=1e-9 * PHI_003)
    t, psi, psid, _ = vibration.ode_response(law, elastic.oscillator(), t_end=1.3, t_eval=r["t"])
    amp = np.max(np.abs(psi))
    np.testing.assert_allclose(r["psi"], psi, atol=1e-5 * amp)


def test_residual_amplitude_matches_free_vibration(belt):
    law = PseudoPolynomialLaw(PHI_001, 1.0)
    osc = belt.oscillator()
    psi, psid = vibration.residual_state(law, osc)
    A = vibration.residual_amplitude(psi, psid, osc)
    t_after = np.linspace(1.0, 1.0 + 2 * math.pi / osc.omega_d, 4001)
    t, p, _, _ = vibration.ode_response(law, osc, t_end=t_after[-1], t_eval=t_after)
    env = A * np.exp(-osc.xi * osc.omega_n * (t - 1.0))
    assert np.max(np.abs(p) - env) < 1e-9 * A  # never above the envelope
    assert np.max(np.abs(p) / env) > 0.999  # and touches it within one period


def test_residual_peak_is_the_actual_peak_of_the_ode(belt, elastic):
    """The named 'peak |ψ| over [T, T + 2 s]' (closed form on a grid) is the largest deflection the
    independent ODE integration reaches after the move, and lies below the envelope at T."""
    for plat, law in ((belt, PseudoPolynomialLaw(PHI_001, 1.0)), (elastic, BezierLaw(PHI_003, 1.0, 2, 3))):
        osc = plat.oscillator()
        t_after = np.linspace(1.0, 3.0, 40001)
        _, p, _, _ = vibration.ode_response(law, osc, t_end=3.0, t_eval=t_after)
        peak = vibration.residual_peak(law, osc, 2.0)
        assert peak == pytest.approx(np.max(np.abs(p)), rel=1e-5)
        s = vibration.summary(law, osc)
        assert s["residual_peak_after_T_rad"] == pytest.approx(peak)
        assert s["residual_peak_after_T_rad"] < s["residual_envelope_at_T_rad"]
        assert "residual_amplitude_rad" not in s  # named by definition (envelope), not "amplitude"


def test_degenerate_law_warnings(belt):
    """Healthy laws give no warning; collapsing exponents / huge coefficients, an exponent at
    its validity limit, a wild Bezier polygon and a reversing motor each give one."""
    assert vibration.law_warnings(PseudoPolynomialLaw(PHI_001, 1.0, (3, 4, 5))) == []
    assert vibration.law_warnings(BezierLaw(PHI_003, 1.0, 2, 3)) == []
    w = vibration.law_warnings(PseudoPolynomialLaw(PHI_001, 1.0, (3.4471, 3.3962, 7.6174)))
    assert any("collapsing" in x for x in w) and any("cancelling coefficients" in x for x in w)
    assert any("validity limit" in x for x in vibration.law_warnings(PseudoPolynomialLaw(PHI_001, 1.0, (2.01, 5, 9))))
    wild = BezierLaw(PHI_003, 1.0, 2, 3, np.array([-1.5, 0.5, 2.5]) * PHI_003)
    w = vibration.law_warnings(wild)
    assert any("polygon" in x for x in w) and any("reverses" in x for x in w)


def test_optimisation_six_orders_both_seeds(opt_belt, opt_bezier):
    assert opt_belt.E < 1e-6 * opt_belt.E0
    assert opt_bezier.E < 1e-6 * opt_bezier.E0
    # boundary conditions survive the optimisation (the laws stay rest-to-rest)
    for law in (opt_belt.law, opt_bezier.law):
        p, v, a, _ = law.evaluate(np.array([0.0, law.T]))
        assert abs(p[1] - law.Phi) < 1e-9 * law.Phi and np.max(np.abs(v)) < 1e-8 and np.max(np.abs(a)) < 1e-6


def test_paper_optimum_seed001(belt, opt_belt):
    """γ = 3.024, 4.565, 5.874 (seed 001 §V): E(T) is many orders below the 3-4-5 law."""
    osc = belt.oscillator()
    E_paper = vibration.residual_energy(PseudoPolynomialLaw(PHI_001, 1.0, (3.024, 4.565, 5.874)), osc)
    E_345 = vibration.residual_energy(PseudoPolynomialLaw(PHI_001, 1.0, (3, 4, 5)), osc)
    assert E_345 == pytest.approx(0.035822, rel=1e-4)
    assert E_paper < 1e-7 * E_345  # measured 1.8e-8 (the printed 3-decimal exponents limit it)
    # our optimum lies elsewhere on the zero-energy curve (errata 001: not unique)
    assert np.max(np.abs(opt_belt.law.params - [3.024, 4.565, 5.874])) > 0.05


def test_constrained_optimisation_respects_speed_limit(belt):
    osc = belt.oscillator()
    law0 = PseudoPolynomialLaw(PHI_001, 1.0)
    vmax = 1.01 * law0.peaks()["speed"]  # unconstrained optimum needs +2.2 %
    res = vibration.optimize(law0, osc, vibration.Constraints(max_speed=vmax))
    assert res.method == "SLSQP"
    assert res.law.peaks()["speed"] <= vmax * (1 + 1e-6)
    assert res.E < 1e-2 * res.E0


def test_shapers(belt, elastic):
    for plat, law in ((belt, PseudoPolynomialLaw(PHI_001, 1.0)), (elastic, BezierLaw(PHI_003, 1.0, 2, 3))):
        osc = plat.oscillator()
        E0 = vibration.residual_energy(law, osc)
        for kind in ("ZV", "ZVD"):
            for same in (False, True):
                sl = vibration.shape(law, osc, kind, same_total_time=same)
                assert sl.T == pytest.approx(law.T if same else law.T + (1 if kind == "ZV" else 2) * math.pi / osc.omega_d)
                assert vibration.residual_energy(sl, osc) < 1e-20 * E0  # exact at the nominal ω_n
                p, v, _, _ = sl.evaluate(np.array([sl.T]))
                assert p[0] == pytest.approx(law.Phi) and abs(v[0]) < 1e-9
        # shaped E(T) through the generic path (ODE) agrees with the closed form at +5 % ω_n
        sl = vibration.shape(law, osc, "ZV")
        o5 = osc.scaled(1.05)
        Ec = vibration.residual_energy(sl, o5)
        Eo = vibration.residual_energy_ode(sl, o5)
        assert Eo == pytest.approx(Ec, rel=1e-6)


def test_sensitivity_table(belt):
    osc = belt.oscillator()
    law = PseudoPolynomialLaw(PHI_001, 1.0)
    zv, zvd = vibration.shape(law, osc, "ZV"), vibration.shape(law, osc, "ZVD")
    tab = vibration.sensitivity({"345": law, "ZV": zv, "ZVD": zvd}, osc)
    for name in tab:
        assert [r[0] for r in tab[name]] == [-0.05, -0.025, 0.0, 0.025, 0.05]
    # ZVD is the robust one: at ±5 % it keeps less energy than ZV
    for i in (0, 4):
        assert tab["ZVD"][i][1] < tab["ZV"][i][1] < tab["345"][i][1]
    # the sensitivity uses the oscillator with ω_n scaled (ξ kept): check against the ODE
    o = osc.scaled(0.95)
    assert o.omega_n == pytest.approx(0.95 * osc.omega_n) and o.xi == pytest.approx(osc.xi)
    assert tab["345"][0][1] == pytest.approx(vibration.residual_energy_ode(law, o), rel=1e-8)


def test_mjcf_defaults_compile_and_match():
    for fname, plat in (("belt_platform.xml", BeltPlatform()), ("elastic_platform.xml", ElasticPlatform())):
        m = mujoco.MjModel.from_xml_path(f"assets/mjcf/{fname}")
        m2 = plat.build_spec().compile()
        assert m.nv == m2.nv == 2
        np.testing.assert_allclose(m.body_inertia, m2.body_inertia)
        np.testing.assert_allclose(m.body_ipos, 0.0)
    m = mujoco.MjModel.from_xml_path("assets/mjcf/belt_platform.xml")
    assert m.ntendon == 2 and np.all(m.tendon_stiffness == 9e4) and np.all(m.tendon_damping == 150)
    # static check: the two branches give k_t·(λφ_m − ϑ) on the platform (seed 001 Eq 1)
    d = mujoco.MjData(m)
    d.qpos[m.joint("motor").qposadr[0]] = 1.0
    mujoco.mj_forward(m, d)
    assert d.qfrc_passive[m.joint("platform").dofadr[0]] == pytest.approx(2 * 9e4 * 0.18 ** 2 / 30)


def test_study_and_cli(tmp_path, capsys):
    from mjbench.cli import main

    rc = main(["optimize-law", "incerti-bezier", "--out", str(tmp_path), "--no-multibody", "--no-plots"])
    assert rc == 0
    out = capsys.readouterr().out
    assert "ω_n = 53.3571 rad/s" in out and "ξ = 11.672 %" in out
    rep = json.loads((tmp_path / "optimize_law.json").read_text())
    assert rep["reduction_orders"] > 6
    assert rep["laws"]["optimised"]["E_T_J"] < 1e-6 * rep["laws"]["initial"]["E_T_J"]
    # the real servo ([servo] table) degrades the optimised law but keeps most of the gain
    sv = rep["servo"]["laws"]
    assert rep["laws"]["optimised"]["E_T_J"] < 1e-12 * sv["optimised"]["E_T_J"]
    assert sv["optimised"]["E_T_J"] < 1e-3 * sv["initial"]["E_T_J"]  # measured 3e-5
    assert sv["initial"]["max_tracking_error_rad"] < 0.01
    scn = scenario.load("incerti-belt", ["law.gammas=[3.0, 4.0, 6.0]"])
    assert scn.law.gammas == [3.0, 4.0, 6.0]


def test_paper_check_rounding_and_truncation(elastic):
    from mjbench.commands.optimize_law import paper_check

    osc = elastic.oscillator()
    chk = paper_check(osc, {"omega_n": 53.3, "xi": 0.117})
    assert chk["omega_n"]["match"] and chk["omega_n"]["how"] == "truncated"  # 53.357 printed 53.3
    assert chk["xi"]["match"] and chk["xi"]["how"] == "rounded"  # 11.672 % printed 11.7 %
    assert not paper_check(osc, {"omega_n": 50.0})["omega_n"]["match"]


def test_servo_reduces_to_ideal_for_a_heavy_motor(belt):
    """DC motor + cascade servo (controllers.servo): with a rotor 1500× the reflected load
    inertia and stiff loops the motor is not disturbed by the belt, and E(T) tends to the
    ideal-servo value (measured 1.3e-5 relative); the assumed real drive degrades it."""
    from controllers.servo import CascadeServo, ServoParams
    from mjbench.backends import reduced
    from mjbench.drive import DCMotorDrive
    from mjbench.machine import Machine

    law = PseudoPolynomialLaw(PHI_001, 1.0)
    osc = belt.oscillator()
    E_ideal = vibration.residual_energy(law, osc)
    drive = DCMotorDrive(R=1.0, L=1e-4, k_m=0.5, J_m=10.0, J_a=0.0, J_b=0.0, z=1.0, T_0=0.0, lam=0.0,
                         v_max=math.inf)
    ctrl = CascadeServo.from_params(ServoParams(kpp=200.0, kvp=2e4, kvi=2e6), drive=drive, mechanism=belt,
                                    reference=law.as_reference())
    tr = reduced.simulate(Machine(belt, drive, ctrl), law.T + 0.1, dt=1e-4, record_dt=1e-4)
    s = vibration.residual_from_trajectory(tr, osc, law.T, 0.1)
    assert s["E_T_J"] == pytest.approx(E_ideal, rel=1e-4)
    assert np.max(np.abs(law.position(tr.t) - tr.q)) < 1e-5
