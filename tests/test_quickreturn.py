"""Seed 004: quick-return mechanism (mechanisms/quickreturn.py), SMC (controllers/smc.py),
optimum design (design.py), scenario yigit2023, metrics and plots.  Runtime ≈ 12 s."""
import math

import mujoco
import numpy as np
import pytest

from mjbench import scenario
from mjbench.papers import yigit2023_design as design
from mjbench.papers import yigit2023_metrics as mq
from mjbench.backends import simulate
from mjbench.errors import GeometryError, ParameterError, ScenarioError
from mjbench import mechanisms
from mjbench.mechanisms.quickreturn import QuickReturn


def from_params(d):
    return mechanisms.from_dict({"type": "quickreturn", **d})

Q = np.linspace(0.0, 2 * np.pi, 181)


@pytest.fixture(scope="module")
def mech():
    return QuickReturn()


# ------------------------------------------------------------------ kinematics
def test_influence_coefficients_vs_finite_differences(mech):
    h = 1e-6
    k, kp, km = mech.kin(Q), mech.kin(Q + h), mech.kin(Q - h)
    for pos, der in (("th3", "g1"), ("th4", "g2"), ("g1", "dg1"), ("g2", "dg2"), ("xC", "xd"),
                     ("xd", "xdd"), ("s21", "ds21")):
        fd = (kp[pos] - km[pos]) / (2 * h)
        assert np.max(np.abs(fd - k[der])) < 1e-7 * max(1.0, np.max(np.abs(k[der]))), (pos, der)
    # the loop equations (Eqs 5-6) hold exactly
    A = np.array([mech.r2 * np.cos(Q), mech.a + mech.r2 * np.sin(Q)])
    assert np.allclose(k["s21"] * np.cos(k["th3"]), A[0]) and np.allclose(k["s21"] * np.sin(k["th3"]), A[1])
    assert np.allclose(mech.r3 * np.sin(k["th3"]) + mech.r4 * np.sin(k["th4"]), mech.a + mech.b)


def test_paper_eq13_and_eq18_agree_with_derivation(mech):
    """Eq 13 (first order) and Eq 18 (g1') as printed agree with ours; Eqs 19-20 do not (errata)."""
    k = mech.kin(Q)
    q, p1, p2 = Q, k["th3"], k["th4"]
    r2, r3, r4, a = mech.r2, mech.r3, mech.r4, mech.a
    D = a * np.sin(p1) + r2 * np.cos(q - p1)
    g1 = r2 * np.cos(q - p1) / D
    g2 = -r2 * r3 * np.cos(q - p1) * np.cos(p1) / (r4 * np.cos(p2) * D)
    g3 = r2 * r3 * np.cos(q - p1) * np.sin(p1 - p2) / (np.cos(p2) * D)
    (G1, G2, G3), (dG1, _, _) = mech.influence(Q)
    assert np.allclose(g1, G1, atol=1e-12) and np.allclose(g2, G2, atol=1e-12) and np.allclose(g3, G3, atol=1e-12)
    dg1 = -a * r2 * (g1 * np.cos(q) + np.sin(q - p1) * np.sin(p1)) / D ** 2  # Eq 18
    assert np.allclose(dg1, dG1, atol=1e-12)


def test_paper_eq19_as_printed_is_wrong(mech):
    """Errata (Yiğit & Şen 2023, docs/errata.md): Eq 19 (g2') as printed disagrees with finite differences; ours agrees."""
    k = mech.kin(Q)
    q, p1, p2 = Q, k["th3"], k["th4"]
    r2, r3, r4, a = mech.r2, mech.r3, mech.r4, mech.a
    D = a * np.sin(p1) + r2 * np.cos(q - p1)
    g1, g2 = k["g1"], k["g2"]
    eq19 = ((r2 * r3 * (a * np.cos(q - p1) - a * np.sin(q - p1) * np.sin(p1) * np.cos(p1))
             + r2 * np.cos(q - p1) ** 2 * np.sin(p1)) / (r4 * np.cos(p2) * D ** 2) * g1
            - r2 * r3 * np.cos(q - p1) * np.cos(p1) * np.sin(p2) / (r4 * np.cos(p2) ** 2 * D) * g2
            + a * r2 * r3 * np.sin(q - p1) * np.cos(p1) * np.sin(p1) / (r4 * np.cos(p2) * D ** 2))
    h = 1e-6
    fd = (mech.kin(Q + h)["g2"] - mech.kin(Q - h)["g2"]) / (2 * h)
    assert np.max(np.abs(fd - k["dg2"])) < 1e-7
    assert np.max(np.abs(fd - eq19)) > 0.1 * np.max(np.abs(fd))


def test_every_mode_runs_through_make_machine():
    scn = scenario.load("yigit2023")
    for mode in ("open", "smc", "pid"):
        for be in ("reduced", "multibody"):
            tr = simulate(scenario.make_machine(scn, mode), be, 0.05, dt=1e-4, record_dt=1e-3)
            assert tr.n == 51 and np.all(np.isfinite(tr.data))


def test_reduced_inertia_from_independent_kinetic_energy(mech):
    """J(q) of Eq 25 vs Σ m v² + I ω² with velocities from finite differences of positions."""
    m, h = mech, 1e-6

    def centres(q):
        k = m.kin(q)
        Ax, Ay = m.r2 * np.cos(q), m.a + m.r2 * np.sin(q)
        Bx, By = m.r3 * np.cos(k["th3"]), m.r3 * np.sin(k["th3"])
        return [(m.c2 * np.cos(q), m.a + m.c2 * np.sin(q)), (Ax, Ay),
                (m.c3 * np.cos(k["th3"]), m.c3 * np.sin(k["th3"])),
                (Bx + m.c4 * np.cos(k["th4"]), By + m.c4 * np.sin(k["th4"])), (k["xC"], 0 * q)], \
            (q, k["th3"], k["th3"], k["th4"], 0 * q)

    (cp, ap), (cm, am) = centres(Q + h), centres(Q - h)
    masses = (m.m2, m.m_block, m.m3, m.m4, m.m5)
    inert = (m.I_G2, m.I_block, m.I_G3, m.I_G4, 0.0)
    J = 0.0
    for i in range(5):
        vx, vy = (cp[i][0] - cm[i][0]) / (2 * h), (cp[i][1] - cm[i][1]) / (2 * h)
        w = (ap[i] - am[i]) / (2 * h)
        J = J + masses[i] * (vx * vx + vy * vy) + inert[i] * w * w
    Jr, dJ, dEp = m.reduced(Q)
    assert np.max(np.abs(J - Jr)) < 1e-8
    fd_dJ = (m.reduced(Q + h)[0] - m.reduced(Q - h)[0]) / (2 * h)
    fd_dEp = (m.potential_energy(Q + h) - m.potential_energy(Q - h)) / (2 * h)
    assert np.max(np.abs(fd_dJ - dJ)) < 1e-8 and np.max(np.abs(fd_dEp - dEp)) < 1e-7
    # scalar path = array path
    assert m.reduced(1.234)[0] == pytest.approx(float(m.reduced(np.array([1.234]))[0][0]), rel=1e-12)


def test_table_I_design_figures(mech):
    """Time ratio, stroke and transmission angle of Table I (constraints c3, c5, c6)."""
    d = math.asin(54 / 140)
    assert mech.time_ratio == pytest.approx((math.pi + 2 * d) / (math.pi - 2 * d), rel=1e-12)
    assert mech.time_ratio == pytest.approx(1.6741, abs=1e-4)  # 1.5 < TR < 2 holds
    # stroke 2·r3·r2/a = 249.94 mm: c3's "250 <" is missed by 0.06 mm (Table I is rounded to mm)
    assert mech.stroke == pytest.approx(2 * 0.324 * 54 / 140, rel=1e-9)
    # transmission angle at the slider (our reading of c5): 51.95° ∈ (45°, 55°)
    assert math.degrees(mech.min_transmission_angle()) == pytest.approx(51.953, abs=1e-2)
    # the lever-rod angle reading would give 29.3°, outside c5: not the paper's definition
    assert math.degrees(mech.min_transmission_angle(which="lever")) < 45
    assert mech.working_direction == -1.0  # slider moves to −x on the slow stroke for q̇ > 0


def test_cutting_force_profiles(mech):
    Qc = mech.external_torque(Q, 1.0, 0.0)
    assert np.all(Qc <= 1e-12)  # always resists forward rotation
    F = mech.cutting_force(Q)
    assert set(np.unique(np.round(np.abs(F), 9))) <= {0.0, 50.0}
    # mean cutting torque over a turn = F·stroke/(2π): work per cycle
    qq = np.linspace(0, 2 * np.pi, 20001)
    W = -np.trapezoid(mech.external_torque(qq, 1.0, 0.0), qq)
    assert W == pytest.approx(50.0 * mech.stroke, rel=1e-4)
    # scalar path matches array path
    for q in (0.3, 2.0, 4.0, 5.5):
        assert mech.external_torque(q, 1.0, 0.0) == pytest.approx(float(mech.external_torque(np.array([q]), 1.0, 0.0)[0]))
    win = QuickReturn(cut_profile="window", cut_start=0.1, cut_end=0.9)
    Ww = -np.trapezoid(win.external_torque(qq, 1.0, 0.0), qq)
    assert Ww == pytest.approx(50.0 * 0.8 * mech.stroke, rel=2e-3)
    sine = QuickReturn(cut_profile="sine")
    Ws = -np.trapezoid(sine.external_torque(qq, 1.0, 0.0), qq)
    assert Ws == pytest.approx(50.0 * 2 / np.pi * mech.stroke, rel=1e-4)
    assert sine.external_torque(2.0, 1.0, 0.0) == pytest.approx(float(sine.external_torque(np.array([2.0]), 1.0, 0.0)[0]))
    none = QuickReturn(cut_profile="none")
    assert np.all(none.external_torque(Q, 1.0, 0.0) == 0)


def test_bad_geometry_raises_with_parameter_names():
    with pytest.raises(GeometryError, match=r"r2 = 0\.15.*a = 0\.14"):
        QuickReturn(r2=0.15)
    with pytest.raises(GeometryError, match=r"r4 = 0\.02"):
        QuickReturn(r4=0.02)
    with pytest.raises(GeometryError, match=r"b = 0\.5"):
        QuickReturn(b=0.5)
    with pytest.raises(ParameterError, match=r"quickreturn\.r3"):
        QuickReturn(r3=-1.0)
    with pytest.raises(ScenarioError, match=r"mechanism\.rr: unknown key"):
        from_params({"r2": 0.05, "rr": 1})
    with pytest.raises(ParameterError, match=r"cut_profile"):
        QuickReturn(cut_profile="ramp")
    with pytest.raises(ScenarioError, match=r"mechanism\.cut_profile"):
        from_params({"r2": 0.05, "cut_profile": "ramp"})


# ------------------------------------------------------------------ multibody
def test_passive_energy_conservation_and_closure():
    """No drive, no cutting: MuJoCo (RK4, 0.1 ms) conserves E_k + E_p; energy = reduced model's."""
    m = QuickReturn(cut_profile="none")
    model = m.build_spec(options={"timestep": 1e-4}).compile()
    assert model.opt.jacobian == mujoco.MjModel.from_xml_string("<mujoco/>").opt.jacobian  # MuJoCo's default
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    d = mujoco.MjData(model)
    q0, qd0 = 0.3, 6.0
    d.qpos[:] = m.initial_qpos(model, q0)
    d.qvel[:] = m.initial_qvel(model, q0, qd0)
    mujoco.mj_forward(model, d)
    E0 = float(d.energy.sum())
    J = m.reduced(q0)[0]
    assert E0 == pytest.approx(0.5 * J * qd0 ** 2 + m.potential_energy(q0), rel=1e-10)
    drift = closure = closure_first = 0.0
    for i in range(50000):  # 5 s ≈ 5 crank turns
        mujoco.mj_step(model, d)
        if i % 50 == 0:
            mujoco.mj_forward(model, d)
            drift = max(drift, abs(float(d.energy.sum()) - E0) / E0)
            closure = max(closure, m.closure_error(model, d))
            if i < 10000:
                closure_first = closure
    assert drift < 5e-6      # measured 1.1e-6 (10 s: 1.1e-6)
    assert closure < 1e-7    # measured 3.2e-8 m (10 s: 3.1e-8 m): bounded, no drift
    assert closure < 5 * closure_first
    # the state stays on the reduced model's energy level
    ca, cv = model.joint("crank").qposadr[0], model.joint("crank").dofadr[0]
    q, qd = float(d.qpos[ca]), float(d.qvel[cv])
    assert 0.5 * m.reduced(q)[0] * qd ** 2 + m.potential_energy(q) == pytest.approx(E0, rel=1e-5)


def test_multibody_load_matches_external_torque():
    m = QuickReturn()
    model = m.build_spec().compile()
    d = mujoco.MjData(model)
    sv = model.joint("slider").dofadr[0]
    for q in (0.5, 1.5, 3.0, 4.5):
        d.qpos[:] = m.initial_qpos(model, q)
        m.multibody_load(model, d, 0.0)
        F = d.qfrc_applied[sv]
        assert F == pytest.approx(m.cutting_force(q))
        assert F * m.kin(q)["xd"] == pytest.approx(m.external_torque(q, 1.0, 0.0), rel=1e-12, abs=1e-12)


@pytest.fixture(scope="module")
def open_runs():
    scn = scenario.load("yigit2023")
    out = {}
    for be in ("reduced", "multibody"):
        out[be] = simulate(scenario.make_machine(scn, "open"), be, 4.0, dt=1e-4, record_dt=1e-3)
    return out


def test_multibody_vs_reduced_open_loop(open_runs):
    c = mq.compare(open_runs["reduced"], open_runs["multibody"])
    assert c["max_dqd"] < 1e-5     # measured 8e-7 rad/s
    assert c["max_dq"] < 1e-6
    assert c["max_dI"] < 1e-4
    assert open_runs["multibody"].closure.max() < 1e-7  # measured 1.6e-8 m (site gap)


@pytest.mark.parametrize("profile, tol", [("sine", 5e-6), ("window", 5e-5)])
def test_multibody_vs_reduced_cut_profiles(profile, tol):
    """Smooth profile: second-order agreement (force at the step mid-point); window: steps in the
    crank torque, both integrators lose an order (measured 8.5e-7 and 1.1e-5 rad/s over 3 s)."""
    scn = scenario.load("yigit2023", [f'profile="{profile}"', "mechanism.cut_start=0.1",
                                      "mechanism.cut_end=0.9"])
    a, b = (simulate(scenario.make_machine(scn, "open"), be, 2.0, dt=1e-4, record_dt=1e-3)
            for be in ("reduced", "multibody"))
    assert mq.compare(a, b)["max_dqd"] < tol


def test_open_loop_48V_vs_paper(open_runs):
    """§4: 48 V → crank speed 6.1-6.4 rad/s.  The stated motor cannot reach 6.1 rad/s even unloaded:
    ω_noload = V/(n·K_g + R·n·B_m/K_m) = 5.916 rad/s.  We assert our model's band and the gap."""
    scn = scenario.load("yigit2023")
    dr = scenario.make_drive(scn)
    w_noload = 48.0 / (dr.z * dr.k_m + dr.R * dr.z * dr.lam / dr.k_m)
    assert w_noload == pytest.approx(5.916, abs=1e-3)
    assert w_noload < scn.paper["open_speed_min"]
    m = QuickReturn()
    T_cut = 50.0 * m.stroke / (2 * math.pi)  # mean cutting torque [N·m]
    w_cut = (48.0 - dr.R * T_cut / (dr.z * dr.k_m)) / (dr.z * dr.k_m + dr.R * dr.z * dr.lam / dr.k_m)
    st = mq.speed_stats(open_runs["reduced"], t_start=2.0)
    assert st["speed_mean"] == pytest.approx(w_cut, abs=2e-3)   # 5.901 rad/s
    assert 5.86 < st["speed_min"] < 5.88 and 5.93 < st["speed_max"] < 5.945  # band 5.871-5.936 rad/s
    assert st["fluctuation"] < 0.02


# ------------------------------------------------------------------ SMC
def _smc(Ts, t_end=3.5, **over):
    sets = [f"Ts={Ts}"] + [f"{k}={v}" for k, v in over.items()]
    scn = scenario.load("yigit2023", sets)
    tr = simulate(scenario.make_machine(scn, "smc"), "reduced", t_end, dt=1e-4, record_dt=1e-4)
    return tr, mq.summary(tr, omega_d=5.0, t_start=2.0)


def test_smc_steady_error_depends_on_sampling():
    """Paper: 0.2 % steady-state error, sampling period not given.  Ours (bias of the mean speed):
    0.036 % at Ts = 0.1 ms, 0.40 % at 1 ms, 2.4 % at 5 ms — the bang-bang limit cycle."""
    errs = {}
    for Ts in (1e-4, 1e-3, 5e-3):
        tr, s = _smc(Ts)
        errs[Ts] = s["error_abs_mean"]
        assert np.all(np.abs(tr.voltage) <= 48.0 + 1e-9)
    assert errs[1e-4] < 1e-3 and 2e-3 < errs[1e-3] < 6e-3 and errs[5e-3] > 1e-2
    assert errs[1e-4] < errs[1e-3] < errs[5e-3]


def test_smc_boundary_layer_removes_chattering():
    _, s_sign = _smc(1e-3)
    _, s_bl = _smc(1e-3, boundary=20.0)
    assert s_sign["switches"] > 100          # bang-bang: ≈ 150 switches/s
    assert s_bl["switches"] == 0
    assert s_bl["error_abs_max"] < 1e-4


def _eq37_by_hand(drive, mech, lam, K, phi, w_d, t, q, w, wdot, model=True):
    """Our reading of seed 004 Eq 37 (controllers/smc.py) written out with the CLOSED forms of the
    mechanism (the controller evaluates its tabulated model law), boundary layer φ > 0."""
    n = drive.z
    e1 = w - w_d
    s = lam * e1 + wdot
    torque = drive.J_eq * (-lam * e1) + n * n * drive.lam * w + n * drive.T_0 * np.sign(w)
    if model:
        J, dJ, dEp = mech.reduced(q)
        Q0 = -dEp + mech.external_torque(q, w, t)
        torque += J * (-lam * e1) + 0.5 * dJ * w * w - Q0
    u = drive.R * torque / (n * drive.k_m) + n * drive.k_m * w - K * np.clip(s / phi, -1.0, 1.0)
    return float(np.clip(u, -48.0, 48.0))


def test_smc_multibody_agrees_and_is_eq37():
    import controllers
    from controllers.base import Measurement

    scn = scenario.load("yigit2023")
    trs = [simulate(scenario.make_machine(scn, "smc"), be, 1.0, dt=1e-4, record_dt=1e-3)
           for be in ("reduced", "multibody")]
    assert mq.compare(*trs)["max_dqd"] < 1e-4
    # the object (its law, with the mechanism's tabulated model) against Eq 37 from the closed
    # forms: inside the boundary layer the difference is the table's (≤ 1e-9 relative)
    mech, drive = scenario.make_mechanism(scn), scenario.make_drive(scn)
    for model in (True, False):
        for q, w, wdot in ((0.1, 4.99, 0.3), (2.0, 5.01, -0.2), (4.4, 5.0, 0.05)):  # cutting stroke at 4.4
            ctrl = controllers.from_dict({"type": "smc", "omega_d": 5.0, "boundary": 200.0, "Ts": 0.0,
                                          "model": model}, drive, mech)
            u = ctrl(0.0, Measurement(z=drive.z).set(0.0, q, w, wdot, 1.0))
            ref = _eq37_by_hand(drive, mech, 50.0, 1000.0, 200.0, 5.0, 0.0, q, w, wdot, model)
            assert abs(ref) < 48.0  # not clipped: the comparison sees every term
            assert u == pytest.approx(ref, rel=1e-8, abs=1e-9), (model, q)
            assert ctrl.state()["s_last"] == pytest.approx(50.0 * (w - 5.0) + wdot, rel=1e-14)


def test_smc_holds_output_between_samples():
    """Ts = 1 ms is the controller's period: the kernel calls it every 10 co-simulation steps of
    0.1 ms and holds the voltage in between (every backend)."""
    scn = scenario.load("yigit2023")
    mc = scenario.make_machine(scn, "smc")
    assert mc.controller.period == pytest.approx(1e-3)
    tr = simulate(mc, "reduced", 1.0, dt=1e-4, record_dt=1e-4)
    V = tr.voltage
    changes = np.flatnonzero(np.diff(V) != 0) + 1
    assert len(changes) > 20 and np.all(changes % 10 == 0)
    with pytest.raises(ParameterError, match="whole multiple"):
        simulate(scenario.make_machine(scenario.load("yigit2023", ["Ts=1.5e-4"]), "smc"), "reduced", 0.01,
                 dt=1e-4)


# ------------------------------------------------------------------ design, scenario, plots
def test_design_optimum_is_feasible_and_below_table_I():
    res = design.optimise(starts=4, seed=1)
    best = res["best"]
    assert design.feasible(best["x"])
    assert best["sum_mm"] == pytest.approx(517.24, abs=0.1)   # with the default 10-500 mm bounds
    assert best["sum_mm"] < 803.0
    chk = design.check_with_mechanism(best["x"])
    assert chk["TR"] == pytest.approx(best["TR"], rel=1e-9)
    assert chk["mu_min_deg"] == pytest.approx(best["mu_min_deg"], abs=1e-3)
    assert res["table_I"]["violated"] == ["c3 stroke>250"]   # by 0.06 mm (rounding)


def test_design_c4_readings_against_the_closed_form_optimum():
    """At a 54 mm lower bound the optimum has r₂ = r₄ = 54 mm (bounds), TR = 2 (δ = 30°, a = 2r₂),
    stroke = 250 mm (r₃ = 250 mm), and the smallest slider-line height H = a + b allowed by c4/c5:
    max-abs reading: μ_min = 45° at mid-swing, H = r₃ − r₄·sin 45°  → sum 569.82 mm;
    signed reading:  c4 ≥ 250 needs H ≥ r₃·cos δ (slider line not below the lever tip at the
    swing ends) → sum 574.51 mm.  A local optimiser from Table I stops on the other branch (605.5)."""
    r2 = r4 = 54.0
    a, r3 = 2 * r2, 250.0
    H_abs, H_signed = r3 - r4 * np.sin(np.pi / 4), r3 * np.cos(np.pi / 6)
    expect = {"max-abs": r2 + r3 + r4 + H_abs, "signed": r2 + r3 + r4 + H_signed}
    for c4, want in expect.items():
        res = design.optimise(starts=2, seed=0, bounds=((54.0, 500.0),) * 5, c4=c4, eps=0.0)
        assert res["best"]["sum_mm"] == pytest.approx(want, abs=0.02), c4
        assert res["from_table_I"]["sum_mm"] == pytest.approx(605.48, abs=0.05)  # the upper branch
        assert design.feasible(res["best"]["x"], c4=c4)
    # the max-abs optimum violates the signed reading of c4 (its rod points down at the swing ends)
    best_abs = design.optimise(starts=1, bounds=((54.0, 500.0),) * 5, eps=0.0)["best"]
    assert not design.feasible(best_abs["x"], c4="signed") and best_abs["c4_signed_mm"] < 250.0
    with pytest.raises(ValueError, match="c4"):
        design.optimise(starts=1, c4="largest")


def test_design_margin_cost():
    """eps = 1e-3 on TR < 2 lengthens r₃ by 250·(1/sin δ(TR = 2 − 1e-3) − 2)/2 ≈ 0.15 mm."""
    a, z = (design.optimise(starts=1, eps=e)["best"] for e in (1e-3, 0.0))
    d = np.pi / 2 * (2 - 1e-3 - 1) / (2 - 1e-3 + 1)  # δ from TR = (π + 2δ)/(π − 2δ)
    assert a["r3"] - z["r3"] == pytest.approx(125 / np.sin(d) - 250, abs=2e-3)
    assert 0.29 < a["sum_mm"] - z["sum_mm"] < 0.31


def test_design_cli(tmp_path, capsys):
    from mjbench.cli import main

    assert main(["design", "quickreturn", "--starts", "2", "--c4", "signed", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "design.json").is_file()
    out = capsys.readouterr().out
    assert "Table I" in out and "c4 read as signed" in out


def test_metrics_and_plots(open_runs, tmp_path):
    from mjbench.papers import yigit2023_plots as pq

    s = mq.summary(open_runs["multibody"], omega_d=5.0, t_start=2.0)
    for k in ("speed_min", "speed_max", "speed_mean", "fluctuation", "error_mean", "switches", "current_peak"):
        assert k in s and np.isfinite(s[k])
    paths = pq.figures({"open 48 V": open_runs["reduced"], "open 48 V (multibody)": open_runs["multibody"]},
                       tmp_path, zoom=(2.0, 3.0), window=(2.0, 2.05))
    for p in paths:
        assert (tmp_path / p.split("/")[-1]).stat().st_size > 10000


def test_asset_mjcf_loads():
    import pathlib

    p = pathlib.Path(__file__).resolve().parents[1] / "assets" / "mjcf" / "quickreturn.xml"
    model = mujoco.MjModel.from_xml_path(str(p))
    assert model.nv == 5 and model.neq == 2
    assert model.opt.jacobian == mujoco.MjModel.from_xml_string("<mujoco/>").opt.jacobian  # MuJoCo's default


def test_design_closed_loop_check_reduced_then_multibody(capsys):
    """mjbench design: the designs' SMC runs on the reduced batch, Table I and the optimum re-run on
    MuJoCo, both figures printed; the two models agree on them."""
    from mjbench import cli

    rc = cli.main(["design", "quickreturn", "--starts", "2", "--t-end", "0.6"])
    out = capsys.readouterr().out
    assert rc == 0 and "reduced backend → multibody (verification)" in out
    from mjbench.papers import yigit2023_design as D

    res = D.optimise(starts=2)
    dyn = D.dynamic_check(res, verify=1, t_end=0.6)
    assert [r["label"] for r in dyn["rows"]] == ["Table I", "optimum"]
    for r in dyn["rows"]:
        for key, _, _ in D.DYN_FIGURES:
            assert r["multibody"][key] == pytest.approx(r["reduced"][key], rel=1e-3, abs=1e-6)
