"""Seed 002 (Hülako & Çakar): seed-002 notation, coupler curve, Eq 17 reference, both backends,
tracking metrics vs the paper, and the "what gain do I need" helper.  See docs/coupler_speed.md."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from controllers.base import Measurement
from controllers.references.coupler_speed import CouplerSpeed
from mjbench.papers import hulako2025_demand as gains
from mjbench.papers import hulako2025_metrics as metrics_coupler
from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from mjbench.errors import ParameterError
from mjbench import mechanisms
from mjbench.errors import ScenarioError
from mjbench.mechanisms.fourbar import to_seed002


def from_params(d):
    return mechanisms.from_dict({"type": "fourbar", **d})

M1, M2 = "hulako2025-model1", "hulako2025-model2"
Q = np.linspace(0.0, 2 * np.pi, 181)


@pytest.fixture(scope="module")
def fb1():
    return S.make_mechanism(S.load(M1))


def _paper_g1(r, q, phi1, phi2):
    """Eq 10 as corrected (errata: r3 in the denominator of g1) and Eq 11."""
    r1, r2, r3, r4 = r
    g1 = -r2 * np.sin(q - phi2) / (r3 * np.sin(phi1 - phi2))
    g2 = -r2 * np.sin(q - phi1) / (r4 * np.sin(phi1 - phi2))
    return g1, g2


# ----------------------------------------------------------------------------- notation
def test_seed002_table1_maps_onto_fourbar(fb1):
    assert (fb1.a, fb1.b, fb1.c, fb1.h_x, fb1.h_y) == (0.04226, 0.09644, 0.05878, 0.10891, 0.0)
    assert fb1.f == (0.02113, 0.04781, 0.02939) and fb1.theta == (0.0, 0.2268, 0.0)
    assert fb1.coupler_point.f == 0.05811 and fb1.coupler_point.theta == 0.8318
    assert fb1.joint_masses == {"A": 0.04, "B": 0.04, "C": 0.04, "D": 0.04}
    assert fb1.joint_damping == fb1.damping_A == fb1.damping_C == 0.000745
    # loop equations Eqs 3-4 hold for both branches
    for br in ("open", "crossed"):
        m = from_params({**to_seed002(fb1), "branch": br})
        phi1, phi2 = m.angles(Q)
        f1 = m.a * np.cos(Q) + m.b * np.cos(phi1) - m.h_x - m.c * np.cos(phi2)
        f2 = m.a * np.sin(Q) + m.b * np.sin(phi1) - m.c * np.sin(phi2)
        assert np.max(np.abs(f1)) < 1e-14 and np.max(np.abs(f2)) < 1e-14


def test_open_branch_has_B_above_ground(fb1):
    _, phi2 = fb1.angles(Q)  # open: B (rocker tip) above the ground line over the whole turn
    assert np.all(np.sin(phi2) > 0.2)  # φ2 ∈ 72°..165°
    crossed = from_params({**to_seed002(fb1), "branch": "crossed"})
    assert np.all(np.sin(crossed.angles(Q)[1]) < -0.2)
    assert crossed.k == -fb1.k


def test_seed002_and_seed000_notations_give_the_same_mechanism(fb1):
    p0 = dict(a=0.04226, b=0.09644, c=0.05878, h_x=0.10891, h_y=0.0, f1=0.02113, f2=0.04781, f3=0.02939,
              theta2=0.2268, m1=0.0461, m2=0.1438, m3=0.0546, J_G1=1.55e-5, J_G2=1.25e-4, J_G3=2.91e-5,
              k=fb1.k, coupler_f=0.05811, coupler_theta=0.8318, joint_mass_A=0.04, joint_mass_B=0.04,
              joint_mass_C=0.04, joint_mass_D=0.04, joint_damping=0.000745, damping_A=0.000745,
              damping_C=0.000745)
    fb0 = from_params(p0)
    for fn in ("angles", "reduced", "coupler_point_position", "coupler_speed_ratio", "hinge_damping_factor"):
        for x, y in zip(np.atleast_1d(getattr(fb0, fn)(Q)), np.atleast_1d(getattr(fb1, fn)(Q))):
            np.testing.assert_allclose(x, y, rtol=1e-13, atol=1e-15)
    # round trip, and a rotated ground line (beta1) only rotates the picture
    assert from_params({**to_seed002(fb1), "bearing_mass": 0.04, "bearing_damping": 0.000745}) == fb1
    rot = from_params({**to_seed002(fb1), "beta1": 0.3})
    np.testing.assert_allclose(rot.coupler_speed_ratio(Q + 0.3), fb1.coupler_speed_ratio(Q), rtol=1e-12)


def test_seed002_bad_input_is_named(fb1):
    with pytest.raises(ScenarioError, match="mechanism.r3: required value is missing"):
        from_params({"notation": "seed002", "r1": 0.1, "r2": 0.04, "r4": 0.05})
    base = to_seed002(fb1)
    with pytest.raises(ScenarioError, match="mechanism.branch"):
        from_params({**base, "branch": "up"})
    with pytest.raises(ParameterError, match="damping_joints"):
        from_params({**base, "damping_joints": ["A"]})
    with pytest.raises(ScenarioError, match="mechanism.c5: unknown key"):
        from_params({**base, "c5": 1.0})


# ----------------------------------------------------------------------------- Eq 17
def test_eq17_matches_paper_formula_and_numerical_derivative(fb1):
    r = (fb1.h_x, fb1.a, fb1.b, fb1.c)
    phi1, phi2 = fb1.angles(Q)
    g1, g2 = _paper_g1(r, Q, phi1, phi2)
    _, _, Qr, Rr = fb1.ratios(Q)
    np.testing.assert_allclose(g1, Qr, rtol=1e-12)
    np.testing.assert_allclose(g2, Rr, rtol=1e-12)
    rC, bC, r2 = fb1.coupler_point.f, fb1.coupler_point.theta, fb1.a
    S17 = np.sqrt(r2 ** 2 + rC ** 2 * g1 ** 2 + 2 * r2 * rC * g1 * np.cos(Q - phi1 - bC))  # Eq 17 denominator
    np.testing.assert_allclose(fb1.coupler_speed_ratio(Q), S17, rtol=1e-13)
    h = 1e-5  # |dC/dq| by central differences of the coupler-point position (Eq 13)
    xp, yp = fb1.coupler_point_position(Q + h)
    xm, ym = fb1.coupler_point_position(Q - h)
    num = np.hypot((xp - xm) / (2 * h), (yp - ym) / (2 * h))
    np.testing.assert_allclose(S17, num, rtol=1e-8)
    S, dS = fb1.coupler_speed_ratio_derivative(Q)
    num_dS = (fb1.coupler_speed_ratio(Q + h) - fb1.coupler_speed_ratio(Q - h)) / (2 * h)
    np.testing.assert_allclose(dS, num_dS, rtol=1e-6, atol=1e-9)


def test_following_eq17_moves_the_coupler_point_at_vc(fb1):
    """Integrate q̇ = q̇_trj(q) for one lap; the coupler point's speed from a numerical time
    derivative of its position is V_C, and the lap time is path_length / V_C."""
    vc = 0.2
    ref = CouplerSpeed(fb1, z=50.0, vc=vc)
    T = fb1.path_length() / vc
    t = np.linspace(0, T, 4001)
    sol = solve_ivp(lambda tt, y: [ref.crank_speed(float(y[0]))], (0, T), [0.0], t_eval=t,
                    rtol=1e-11, atol=1e-12, method="DOP853")
    q = sol.y[0]
    assert q[-1] == pytest.approx(2 * np.pi, abs=1e-6)
    x, y = fb1.coupler_point_position(q)
    speed = np.hypot(np.gradient(x, t, edge_order=2), np.gradient(y, t, edge_order=2))
    np.testing.assert_allclose(speed[2:-2], vc, rtol=2e-4)


def test_arc_length_and_coupler_curve(fb1):
    _, x, y = fb1.coupler_curve(200001)
    L_poly = np.sum(np.hypot(np.diff(x), np.diff(y)))
    assert fb1.path_length() == pytest.approx(L_poly, rel=1e-9)
    assert fb1.path_length() == pytest.approx(0.229431, abs=1e-6)
    s = fb1.arc_length(np.array([1.0, 1.0 + 2 * np.pi, 1.0 - 4 * np.pi]))
    L = fb1.path_length()
    np.testing.assert_allclose(s - s[0], [0, L, -2 * L], atol=1e-12)
    q = np.linspace(0, 2 * np.pi, 1001)  # ds/dq = |dC/dq|
    np.testing.assert_allclose(np.gradient(fb1.arc_length(q), q)[5:-5], fb1.coupler_speed_ratio(q)[5:-5], rtol=1e-4)


# ----------------------------------------------------------------------------- reference object
def test_reference_outputs_motor_side_and_integrates(fb1):
    z, vc, h = 50.0, 0.1, 1e-3
    ref = CouplerSpeed(fb1, z=z, vc=vc)
    y = Measurement(z=z)
    qs = 0.5 + 0.8 * np.arange(200) * h  # arbitrary measured motion
    phis, oms, accs = [], [], []
    for n, q in enumerate(qs):
        phi, om, acc = ref(n * h, y.set(n * h, float(q), 0.8, 0.0, 0.0))
        phis.append(phi); oms.append(om); accs.append(acc)
    # against the closed form of S(q) (the law reads its spline table: ≤ 1e-9 of the peak, measured 8e-11)
    qd_trj = vc / fb1.coupler_speed_ratio(qs)
    np.testing.assert_allclose(np.array(oms) / z, qd_trj, rtol=1e-9)            # ω_ref = z·q̇_trj (Eq 17)
    assert phis[0] == pytest.approx(z * qs[0])                                     # integral error 0 at t = 0
    trap = z * (qs[0] + np.concatenate(([0], np.cumsum(0.5 * h * (qd_trj[1:] + qd_trj[:-1])))))
    np.testing.assert_allclose(phis, trap, rtol=1e-9)
    np.testing.assert_allclose(np.array(accs[1:]) / z, np.diff(qd_trj) / h, rtol=1e-6)  # backward difference
    # the operators exactly, on the reference's own q̇_trj(q)
    own = ref.crank_speed(qs)
    np.testing.assert_allclose(np.array(oms) / z, own, rtol=1e-15)
    np.testing.assert_allclose(np.array(accs[1:]) / z, np.diff(own) / h, rtol=1e-10)
    ref.reset()
    phi, _, acc = ref(0.0, y.set(0.0, 2.0, 0.0, 0.0, 0.0))
    assert phi == pytest.approx(z * 2.0) and acc == 0.0


def test_kinematic_laws_equal_the_closed_forms(fb1):
    """The scalar laws the reference runs (fourbar_angles, fourbar_ratio_derivatives) against the
    four-bar's NumPy closed forms (Appendices A-B); a linkage that cannot be assembled gives NaN in
    the law and a GeometryError from the method."""
    from mjbench.errors import GeometryError
    from mjbench.mechanisms.fourbar import fourbar_angles, fourbar_ratio_derivatives

    P = fb1.kinematic_params()
    beta, gamma, Qr, Rr, dQ, dR = fb1.ratio_derivatives(Q)
    for i, q in enumerate(Q):
        b, g, Qv, Rv, dQv, dRv = fourbar_ratio_derivatives(float(q), P)
        assert (b, g) == fourbar_angles(float(q), P)
        np.testing.assert_allclose([b, g, Qv, Rv, dQv, dRv], [beta[i], gamma[i], Qr[i], Rr[i], dQ[i], dR[i]],
                                   rtol=1e-12, atol=1e-13)
    from mjbench.mechanisms.fourbar import _assembled

    bad = P._replace(a=0.2)  # a crank longer than the other links allow
    assert np.isnan(fourbar_angles(1.0, bad)[0])
    with pytest.raises(GeometryError, match="assembled"):  # the methods refuse such angles
        _assembled(np.array([fourbar_ratio_derivatives(1.0, bad)[2]]), np.array([1.0]))


def test_analytic_derivative_is_the_time_derivative_along_the_motion(fb1):
    """derivative = "analytic": ω̇_ref/z = dq̇_trj/dq·q̇ (measured) — against central differences of
    q̇_trj(q) (constant and table profiles)."""
    z, qd = 50.0, 4.0
    for kw in (dict(vc=0.1), dict(vc=0.1, profile="table", s=[0.0, 0.1], v_rel=[1.0, 2.0])):
        ref = CouplerSpeed(fb1, z=z, derivative="analytic", **kw)
        y = Measurement(z=z)
        for q in (0.7, 2.5, 5.0):
            ref.reset()
            ref(0.0, y.set(0.0, q, qd, 0.0, 0.0))
            _, _, acc = ref(1e-3, y.set(1e-3, q, qd, 0.0, 0.0))
            e = 1e-6
            fd = (ref.crank_speed(q + e) - ref.crank_speed(q - e)) / (2 * e) * qd
            assert acc / z == pytest.approx(fd, rel=1e-6, abs=1e-9)


def test_reference_profiles(fb1):
    L = fb1.path_length()
    pw = CouplerSpeed(fb1, z=50.0, profile="piecewise", s=[0.0, 0.5], v=[0.1, 0.3], s_unit="fraction")
    q = np.linspace(0, 2 * np.pi, 2001, endpoint=False)
    sl = fb1.arc_length(q)
    np.testing.assert_allclose(pw.vc_at(q), np.where(sl < 0.5 * L, 0.1, 0.3))
    bl = CouplerSpeed(fb1, z=50.0, profile="piecewise", s=[0.0, 0.5], v=[0.1, 0.3], s_unit="fraction", blend=0.02)
    vb = bl.vc_at(q)
    assert vb.min() >= 0.1 - 1e-12 and vb.max() <= 0.3 + 1e-12
    assert np.max(np.abs(np.diff(vb))) < 0.01  # continuous blends (no jumps)
    tb = CouplerSpeed(fb1, z=50.0, vc=0.2, profile="table", s=[0.0, 0.1], v_rel=[1.0, 2.0], s_unit="m")
    vt = tb.vc_at(q)
    np.testing.assert_allclose(vt, np.interp(sl, [0, 0.1, L], [0.2, 0.4, 0.2]), rtol=1e-12)
    fn = CouplerSpeed(fb1, z=50.0, profile=lambda s: 0.1 + 0.1 * (s > 0.05))
    assert fn.vc_at(0.0) == pytest.approx(0.1)
    with pytest.raises(ParameterError):
        CouplerSpeed(fb1, profile="piecewise", s=[0.1, 0.5], v=[0.1, 0.2])  # must start at s = 0


def test_pid_crank_side_is_motor_side_over_z():
    scn = S.load(M1)
    mach = S.make_machine(scn)
    pid = mach.controller
    assert pid.kp * 50 == pytest.approx(3.7) and pid.ki * 50 == pytest.approx(7.0) and pid.kd * 50 == pytest.approx(2.0)
    assert isinstance(pid.reference, CouplerSpeed) and pid.reference.vc == 0.1
    mach2 = S.make_machine(S.load(M2, ["vc=0.3"]))
    assert mach2.controller.reference.vc == 0.3 and mach2.mechanism.m[1] == 0.719
    assert mach2.controller.kp * 50 == pytest.approx(50.0)


# ----------------------------------------------------------------------------- backends
def test_mjcf_bearing_masses_match_reduced_energy():
    """Kinetic and potential energy of the compiled MJCF (bearing masses in all joints) equal
    the reduced model's (a regression: the bearing at C used to sit at 2c from D)."""
    import mujoco
    mach = S.make_machine(S.load(M2))
    fb = mach.mechanism
    _, model = multibody.build_model(mach)
    d = mujoco.MjData(model)
    for q in (0.3, 1.5, 4.0):
        d.qpos[:] = fb.initial_qpos(model, q)
        d.qvel[:] = fb.initial_qvel(model, q, 1.0)
        mujoco.mj_forward(model, d)
        J, _, _ = fb.reduced(q)
        assert d.energy[1] == pytest.approx(0.5 * (J + mach.drive.J_eq), rel=1e-6)
        assert d.energy[0] == pytest.approx(fb.potential_energy(q), rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("name", [M1, M2])
def test_multibody_matches_reduced(name):
    scn = S.load(name, ["vc=0.2"])
    runs = {}
    for be in (multibody, reduced):
        mach = S.make_machine(scn)
        runs[be.__name__] = be.simulate(mach, 0.6, dt=1e-4, record_dt=2e-3)
    a, b = runs["mjbench.backends.multibody"], runs["mjbench.backends.reduced"]
    d = metrics_coupler.compare_backends(a, b)
    assert d["crank_angle_max_diff_rad"] < 2e-6
    assert d["crank_speed_max_diff_rad_s"] < 2e-5   # measured 5e-6 (M1), 3e-6 (M2)
    assert d["current_max_diff_A"] < 5e-5
    assert np.max(a.closure) < 1e-7


def test_batched_backend_runs_the_coupler_reference_identically():
    """The batched MuJoCo backend (sweeps) calls the reference with (nsim,) arrays and the hinge
    friction through multibody_load on state columns: same trajectory as the single run."""
    from mjbench.backends import batch
    scn = S.load(M1, ["vc=0.2"])
    a = multibody.simulate(S.make_machine(scn), 0.3, dt=1e-4, record_dt=2e-3)
    res = batch.simulate([S.make_machine(scn), S.make_machine(S.load(M1, ["vc=0.3"]))], 0.3,
                         record_dt=2e-3, options={"timestep": 1e-4})
    b = res.trajectory(0)
    assert np.max(np.abs(a.qd - b.qd[: a.n])) < 1e-9
    assert res.trajectory(1).qd[-1] > b.qd[-1]  # the second simulation runs its own V_C


# ----------------------------------------------------------------------------- tracking vs paper
@pytest.fixture(scope="module")
def runs5s():
    """5 s runs (reduced backend, 0.1 ms) at V_C = 0.1 m/s: the paper's simulation settings."""
    out = {}
    for name in (M1, M2):
        scn = S.load(name, ["vc=0.1"])
        mach = S.make_machine(scn)
        tr = reduced.simulate(mach, 5.0, dt=1e-4, record_dt=2e-3)
        out[name] = metrics_coupler.from_run(scn, tr, mach)
    return out


def test_deviation_shrinks_after_transient(runs5s):
    for name, m in runs5s.items():
        w = m["coupler_dev_windows"]  # [1.5, 2.5], [2.5, 3.5], [3.5, 4.5], [4.5, 5]
        assert w[-1][2] < 0.75 * w[0][2], (name, w)   # measured 0.44 (M1), 0.51 (M2)
        assert w[-1][3] < 0.5 * w[0][3], (name, w)    # measured 0.23 (M1), 0.20 (M2)


def test_paper_figures_vs_stated_model(runs5s):
    """What our stated model gives (docs/coupler_speed.md, 'Gaps'): Model-2 meets Table 3's
    0.01 m/s; Model-1 does not, and neither meets the 0.07 s rise time nor (Model-1) the
    0.1 rad/s crank error after 1.5 s — the K_d·de/dt term is a virtual inertia K_d·z·k_m/R
    that slows the start-up from rest (closed-loop poles ≈ −1.0 ± 1.6j for Model-1)."""
    m1, m2 = runs5s[M1], runs5s[M2]
    assert m1["coupler_dev_max_after_m_s"] == pytest.approx(0.0167, rel=0.05)
    assert m1["crank_error_max_after_rad_s"] == pytest.approx(0.593, rel=0.05)
    assert m1["rise_time_s"] == pytest.approx(0.604, abs=0.01)
    assert m2["coupler_dev_max_after_m_s"] == pytest.approx(0.0041, rel=0.05)
    assert m2["crank_error_max_after_rad_s"] == pytest.approx(0.151, rel=0.05)
    assert m2["rise_time_s"] == pytest.approx(0.328, abs=0.01)
    assert m2["coupler_dev_max_after_m_s"] < 0.01 < m1["coupler_dev_max_after_m_s"]  # Table 3: 0.01
    assert m1["rise_time_s"] > 0.07 and m2["rise_time_s"] > 0.07                      # §5.1: 0.07 s


def test_run_writes_coupler_metrics_and_judges_the_paper(tmp_path, capsys):
    """`mjbench run` on a coupler-speed scenario: metrics.json holds the tracking metrics of each
    backend (engine: metrics.coupler_tracking) and the [[paper.figures]] with verdicts computed
    from them (§4 and Table 3 as upper bounds)."""
    from mjbench.cli import main
    from mjbench.outputs import read_json

    out = tmp_path / "run"
    assert main(["run", M2, "--set", "vc=0.2", "--backend", "reduced", "--t-end", "2", "--no-figure",
                 "--out", str(out)]) == 0
    m = read_json(out / "metrics.json")
    cs = m["backends"]["reduced"]["coupler_speed"]
    scn = S.load(M2, ["vc=0.2"])
    tr = reduced.simulate(S.make_machine(scn), 2.0, dt=1e-4, record_dt=scn.simulation.record_dt)
    ref = metrics_coupler.from_run(scn, tr, S.make_machine(scn))
    for k in ("coupler_dev_max_after_m_s", "crank_error_max_after_rad_s", "rise_time_s", "settling_time_s"):
        assert cs[k] == pytest.approx(ref[k], rel=1e-9), k
    rows = {r["metric"]: r for r in m["paper"]}
    dev = rows["coupler_speed.coupler_dev_max_after_m_s"]
    assert (dev["compare"], dev["paper"]) == ("max", 0.01)
    assert dev["verdict"]["ok"] == (cs["coupler_dev_max_after_m_s"] <= 0.01)
    err = rows["coupler_speed.crank_error_max_after_rad_s"]
    assert err["verdict"]["ok"] == (cs["crank_error_max_after_rad_s"] <= 0.1)
    assert rows["coupler_speed.rise_time_s"]["compare"] == "value"
    text = capsys.readouterr().out
    assert "max |V_C − V_des| after 1.5 s" in text and "verdict:" in text


def test_metrics_definitions_on_synthetic_run(fb1):
    """Rise/settling definitions on a hand-made trajectory."""
    from mjbench.trajectory import Trajectory
    ref = CouplerSpeed(fb1, z=50.0, vc=0.1)
    t = np.linspace(0, 3, 3001)
    q = np.full_like(t, 1.0)
    ratio = 1 - np.exp(-t / 0.1) + 0.2 * np.exp(-t / 0.5) * np.sin(10 * t)
    tr = Trajectory(len(t), "synthetic")
    tr.data[:, 0], tr.data[:, 1] = t, q
    tr.data[:, 2] = ratio * ref.crank_speed(1.0)
    tr.data[:, 5:7] = 0.0
    tr.n = len(t)
    m = metrics_coupler.compute(tr, fb1, ref, settle_time=1.5)
    i = np.flatnonzero(ratio >= 0.9)[0]
    assert m["rise_time_s"] == pytest.approx(t[i])
    bad = np.flatnonzero(np.abs(ratio - 1) > 0.1)
    assert m["settling_time_s"] == pytest.approx(t[bad[-1] + 1])
    assert m["coupler_dev_max_after_m_s"] == pytest.approx(0.1 * np.max(np.abs(ratio[t >= 1.5] - 1)), rel=1e-9)


# ----------------------------------------------------------------------------- demand helper
def test_demand_flags_voltage_saturation():
    r1 = gains.from_scenario(S.load(M1, ["vc=0.1"]))
    assert not r1["voltage_saturated"]
    assert r1["crank_speed_max_rad_s"] == pytest.approx(0.1 / 0.0192925, rel=1e-3)
    assert r1["lap_time_s"] == pytest.approx(0.229431 / 0.1, rel=1e-4)
    r4 = gains.from_scenario(S.load(M1, ["vc=0.4"]))
    assert r4["voltage_saturated"] and r4["voltage_max_V"] > 12.0
    # demand ≈ what a simulation that tracks well needs: voltage grows ~ with V_C
    assert r4["voltage_max_V"] > 4 * r1["voltage_max_V"]


def test_demand_inverse_dynamics_reproduces_open_loop_motion():
    """Drive the reduced model with the demanded feed-forward voltage (no feedback): starting on
    the ideal motion it follows q̇_trj closely for a lap (checks the inverse dynamics in gains.py)."""
    scn = S.load(M1, ["vc=0.1"])
    mach = S.make_machine(scn)
    d = gains.demand(mach.mechanism, mach.drive, mach.controller.reference)
    a = d["_arrays"]
    T = d["lap_time_s"]

    class FF:
        def reset(self):
            pass

        def __call__(self, t, y):
            return float(np.interp(t % T, a["t"], a["V"], period=T))

    mach.controller = FF()
    mach.q0, mach.qd0, mach.I0 = 0.0, float(a["qd"][0]), float(a["I"][0])
    tr = reduced.simulate(mach, 0.5 * T, dt=1e-4, record_dt=1e-3)
    qd_ideal = mach.mechanism.coupler_speed_ratio(tr.q)
    err = np.abs(tr.qd - 0.1 / qd_ideal)
    assert err.max() < 0.02  # rad/s, vs 1.6..5.2 rad/s speeds


def test_demand_cli(capsys):
    from mjbench.cli import main
    assert main(["demand", M1, "--set", "vc=0.3"]) == 0
    out = capsys.readouterr().out
    assert "voltage max" in out and "ok:" in out
    assert main(["demand", M2, "--set", "vc=0.4"]) == 1
    assert "WARNING: voltage saturation" in capsys.readouterr().out
