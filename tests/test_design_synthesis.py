"""Kinematic synthesis of mjbench design (mjbench/design/synthesis/): every routine against closed
forms (and round trips through known linkages) and against mjbench's own position solver
(mjbench.mechanisms.linkage, Newton on the loop-closure equations) to ≤ 1e-9.

Closed forms used (derived in the cited textbooks, re-derived in the synthesis package's docstring):
* time ratio Q = (180° + α)/(180° − α) — Norton, *Design of Machinery*, ch. 3 (quick return);
* offset slider-crank dead centres u = √((l ± r)² − e²), α = asin(e/(l − r)) − asin(e/(l + r)),
  μ_min = 90° − asin((r + e)/l) — Hartenberg & Denavit, *Kinematic Synthesis of Linkages* (1964);
* Freudenstein's equation K₁cos φ − K₂cos ψ + cos(φ − ψ) = K₃ — Freudenstein, Trans. ASME 77 (1955);
* Chebyshev spacing x_j = (x₀+x₁)/2 − (x₁−x₀)/2·cos((2j−1)π/2n) — the same paper;
* circle point / centre point of three coupler positions — Sandor & Erdman, *Advanced Mechanism
  Design* vol. 2 (inversion).
"""
import math

import numpy as np
import pytest

from mjbench.design import build as B
from mjbench.design import synthesis as S
from mjbench.design.pipeline import solver_check
from mjbench.design.requirements import MassModel, compile_function

SOLVER_TOL = 1e-9


def table_of(syn):
    g = syn.geometry
    if isinstance(g, S.SliderCrank):
        return B.slidercrank_table(g, MassModel(slider_mass=2.0))
    return B.fourbar_table(g, MassModel(), tool_at="coupler.P" if g.P is not None else "rocker.C")


def slider_closed_form(r, l, e):
    u1, u2 = math.sqrt((l + r) ** 2 - e * e), math.sqrt((l - r) ** 2 - e * e)
    alpha = math.asin(e / (l - r)) - math.asin(e / (l + r))
    return u1 - u2, (math.pi + alpha) / (math.pi - alpha), 90.0 - math.degrees(math.asin((r + e) / l))


# ============================================================================ helpers
def test_time_ratio_and_chebyshev_spacing():
    assert S.imbalance_angle(1.0) == 0.0
    assert math.degrees(S.imbalance_angle(1.2)) == pytest.approx(180 * 0.2 / 2.2, rel=1e-14)
    for Q in (1.0, 1.13, 1.5, 2.0):
        assert S.time_ratio(S.imbalance_angle(Q)) == pytest.approx(Q, rel=1e-14)
    x = S.chebyshev_points(1.0, 2.0, 3)
    np.testing.assert_allclose(x, [1.5 - 0.25 * math.sqrt(3), 1.5, 1.5 + 0.25 * math.sqrt(3)], rtol=1e-15)
    np.testing.assert_allclose(np.round(x, 3), [1.067, 1.5, 1.933])
    # circumcentre: equidistant from the three points
    P = np.array([[0.1, 0.2], [0.4, -0.1], [-0.3, 0.5]])
    c = S.circumcentre(*P)
    d = np.hypot(*(P - c).T)
    assert np.ptp(d) < 1e-15


# ============================================================================ slider-crank
@pytest.mark.parametrize("S_, Q", [(0.1, 1.2), (0.08, 1.05), (0.25, 1.5), (0.05, 1.0)])
def test_slider_crank_meets_stroke_and_time_ratio_closed_form_and_solver(S_, Q):
    syn = S.slider_crank(S_, Q, min_transmission=math.radians(20))
    g = syn.geometry
    stroke, Qcf, mu = slider_closed_form(g.r, g.l, g.e)
    assert stroke == pytest.approx(S_, rel=1e-12)
    assert Qcf == pytest.approx(Q, rel=1e-12)
    assert syn.achieved["min_transmission_deg"] == pytest.approx(mu, abs=1e-10)
    # μ_min sampled over a turn by the closed-form position analysis equals the formula
    q = np.linspace(0, 2 * np.pi, 20001)
    assert np.degrees(g.solve(q)["mu"].min()) == pytest.approx(mu, abs=1e-4)
    if Q > 1:  # the offset maximises μ_min: a neighbour on either side is worse
        alpha = S.imbalance_angle(Q)
        for de in (-1e-4, 1e-4):
            r2, l2 = S.slider_crank_from(S_, alpha, g.e * (1 + de))
            assert slider_closed_form(r2, l2, g.e * (1 + de))[2] < mu
    chk = solver_check(syn, table_of(syn))
    assert chk["residual"] <= SOLVER_TOL, chk
    assert chk["stroke_residual_m"] <= SOLVER_TOL and chk["branch_max_position_diff_m"] <= SOLVER_TOL


def test_slider_crank_round_trip_of_the_press_example():
    """press-slidercrank (docs/linkages.md §5: r = 40 mm, l = 200 mm, offset 10 mm; stroke 80.10 mm,
    time ratio 181.2°/178.8° = 1.013): its stroke and time ratio, synthesised with its offset, give
    back its crank and rod."""
    r, l, e = 0.040, 0.200, 0.010
    stroke, Q, _ = slider_closed_form(r, l, e)
    assert round(1e3 * stroke, 2) == 80.10
    alpha = math.degrees(S.imbalance_angle(Q))
    assert (round(180 + alpha, 1), round(180 - alpha, 1)) == (181.2, 178.8)
    syn = S.slider_crank(stroke, Q, offset=e)
    assert syn.geometry.r == pytest.approx(r, rel=1e-12) and syn.geometry.l == pytest.approx(l, rel=1e-12)
    # the slow stroke is along the working direction (down) with the crank turning counter-clockwise
    dc = syn.geometry.dead_centres()
    assert dc["arc_along_w"] > dc["arc_against_w"]
    assert solver_check(syn, table_of(syn))["residual"] <= SOLVER_TOL


def test_slider_crank_constraints_are_reported():
    syn = S.slider_crank(0.1, 1.3, min_transmission=math.radians(45), max_link_ratio=2.0, envelope=(0.05, 0.5))
    fails = {c["name"] for c in syn.failures()}
    assert "minimum transmission angle" in fails  # 39.0° at best for Q = 1.3 (one-parameter family)
    assert "link-length ratio (rod / crank)" in fails and "envelope width" in fails
    assert not syn.ok
    with pytest.raises(Exception, match="offset"):
        S.slider_crank(0.1, 1.2, offset=1.0)


# ============================================================================ crank-rocker
@pytest.mark.parametrize("swing, Q, slow", [(60, 1.25, "ccw"), (45, 1.1, "cw"), (90, 1.0, "ccw"), (30, 1.5, "ccw")])
def test_crank_rocker_swing_time_ratio_closed_form_and_solver(swing, Q, slow):
    syn = S.crank_rocker(math.radians(swing), Q, rocker_length=0.2, slow_swing=slow)
    fb = syn.geometry
    assert fb.full_rotation() and fb.grashof()["kind"] == "crank-rocker"
    dc = fb.dead_centres()
    assert math.degrees(dc["swing"]) == pytest.approx(swing, abs=1e-9)
    slow_arc = max(dc["arc_ext_to_fold"], dc["arc_fold_to_ext"])
    assert slow_arc / (2 * math.pi - slow_arc) == pytest.approx(Q, rel=1e-9)
    if Q > 1:  # the rocker turns the asked way on the slow stroke
        d = dc["direction_ext_to_fold"] if dc["arc_ext_to_fold"] > math.pi else -dc["direction_ext_to_fold"]
        assert d == (1 if slow == "ccw" else -1)
    # the rocker's range over a turn (closed-form analysis) is the swing; μ_min at |BD| = d ± a
    q = np.linspace(0, 2 * np.pi, 40001)
    s = fb.solve(q)
    assert np.degrees(np.ptp(np.unwrap(s["theta4"]))) == pytest.approx(swing, abs=1e-5)
    assert np.degrees(S.fold(s["mu"]).min()) == pytest.approx(math.degrees(fb.mu_min()), abs=1e-5)
    chk = solver_check(syn, table_of(syn))
    assert chk["residual"] <= SOLVER_TOL and chk["branch_max_position_diff_m"] <= SOLVER_TOL, chk
    assert chk["swing_solver_deg"] == pytest.approx(swing, abs=1e-8)


def test_crank_rocker_round_trip_of_the_seed000_fourbar():
    """The seed-000 four-bar (incerti2012: a = 0.1, b = c = 0.3, D = (0.3, 0.05) m): its swing and
    time ratio, synthesised with its own free parameter β, give back its link lengths."""
    seed = S.FourBar([0.0, 0.0], [0.3, 0.05], 0.1, 0.3, 0.3, 1)
    dc = seed.dead_centres()
    psi, arc = dc["swing"], max(dc["arc_ext_to_fold"], dc["arc_fold_to_ext"])
    Q = arc / (2 * math.pi - arc)
    lo = min((dc["extended"]["psi"], dc["folded"]["psi"]), key=lambda p: (p - dc["folded"]["psi"]) % (2 * np.pi)
             if p == dc["extended"]["psi"] else (p - dc["extended"]["psi"]) % (2 * np.pi))
    C = {k: seed.D + 0.3 * np.array([math.cos(dc[k]["psi"]), math.sin(dc[k]["psi"])]) for k in ("extended", "folded")}
    # C1 = the clockwise end of the swing (the construction's convention)
    k1 = "extended" if S.wrap(dc["folded"]["psi"] - dc["extended"]["psi"]) > 0 else "folded"
    k2 = "folded" if k1 == "extended" else "extended"
    C1, C2 = C[k1], C[k2]
    u, v = C2 - C1, seed.A - C1
    beta = math.acos(np.dot(u, v) / np.hypot(*u) / np.hypot(*v))
    slow = dc["direction_ext_to_fold"] if dc["arc_ext_to_fold"] > math.pi else -dc["direction_ext_to_fold"]
    syn = S.crank_rocker(psi, Q, rocker_length=0.3, beta=beta, slow_swing="ccw" if slow > 0 else "cw")
    g = syn.geometry
    assert (g.a, g.b, g.c, g.d) == pytest.approx((0.1, 0.3, 0.3, math.hypot(0.3, 0.05)), rel=1e-9)
    assert lo is not None
    assert solver_check(syn, table_of(syn))["residual"] <= SOLVER_TOL


def test_grashof_and_full_rotation():
    non = S.FourBar([0, 0], [0.2, 0], 0.15, 0.1, 0.12, 1)  # s + l > p + q
    assert not non.grashof()["grashof"] and not non.full_rotation() and non.mu_min() == 0.0
    drag = S.FourBar([0, 0], [0.05, 0], 0.2, 0.25, 0.2, 1)
    assert drag.grashof()["kind"].startswith("double-crank") and drag.full_rotation()
    # a change-point linkage (s + l = p + q, a parallelogram) passes a singular position: not a crank
    par = S.FourBar([0, 0], [0.15, 0], 0.15, 0.2, 0.2, 1)
    assert par.grashof()["grashof"] and not par.full_rotation()
    # mjbench's solver refuses the non-Grashof linkage as an input crank (it cannot turn fully)
    from mjbench.errors import GeometryError
    from mjbench.mechanisms import linkage as LK

    t = B.fourbar_table(non, MassModel(), q_stated=0.0)
    with pytest.raises(GeometryError):
        LK.compiled(LK.LinkageParams.model_validate(t))


# ============================================================================ Freudenstein
def _aligned_seed():
    d = math.hypot(0.3, 0.05)
    return S.FourBar([0.0, 0.0], [d, 0.0], 0.1, 0.3, 0.3, 1), d


def test_freudenstein_recovers_a_known_fourbar():
    """Three (and then 12) exact input/output pairs of a known four-bar → Freudenstein's K → its
    lengths, to round-off (three points: exact solve; more: least squares with zero residual)."""
    fb, d = _aligned_seed()
    for phi in (np.array([0.3, 1.4, 2.9]), np.linspace(0.1, 6.0, 12)):
        psi = fb.solve(phi)["theta4"]
        K = S.freudenstein_solve(phi, psi)
        a, b2, c = S.lengths_from_K(K, d)
        assert (a, math.sqrt(b2), c) == pytest.approx((0.1, 0.3, 0.3), rel=1e-12)


def test_least_squares_is_the_least_squares_solution():
    rng = np.random.default_rng(1)
    phi = np.linspace(0, 2, 15)
    psi = 1.0 + 0.4 * phi + 0.02 * rng.standard_normal(15)
    K = S.freudenstein_solve(phi, psi)
    M = np.stack([np.cos(phi), -np.cos(psi), -np.ones_like(phi)], axis=-1)
    ref = np.linalg.lstsq(M, -np.cos(phi - psi), rcond=None)[0]
    np.testing.assert_allclose(K, ref, rtol=1e-10)


def _log_spec():
    return S.FunctionSpec(compile_function("log10(x)"), 1.0, 2.0, math.radians(90), math.radians(60), "log10(x)")


def test_function_generator_chebyshev_points_exact_closed_form_and_solver():
    spec = _log_spec()
    syn = S.function_generator(spec, ground_length=0.15, min_transmission=math.radians(35), max_link_ratio=6)
    assert syn.ok, syn.failures()
    assert syn.achieved["precision_point_error_rad"] <= 1e-12
    fb = syn.geometry
    assert fb.a < min(fb.b, fb.c, fb.d) and fb.full_rotation()  # crank-rocker: the output oscillates
    # structural error: zero at the three Chebyshev points, not between them
    phi0, psi0 = math.radians(syn.achieved["phi0_deg"]), math.radians(syn.achieved["psi0_deg"])
    x, err, ok = S.structural_error(fb, spec, phi0, psi0, 2001)
    assert ok and np.max(np.abs(err)) == pytest.approx(math.radians(syn.achieved["structural_error_max_deg"]), rel=1e-2)
    for xp in S.chebyshev_points(spec.x0, spec.x1, 3):
        assert abs(np.interp(xp, x, err)) < 2e-5
    assert np.max(np.abs(err)) > 1e-4
    chk = solver_check(syn, table_of(syn))
    assert chk["angle_residual_rad"] <= SOLVER_TOL and chk["branch_max_position_diff_m"] <= SOLVER_TOL, chk
    assert chk["structural_error_max_deg_solver"] == pytest.approx(syn.achieved["structural_error_max_deg"], rel=2e-2)


def test_function_generator_least_squares_and_structural_error():
    spec = _log_spec()
    cheb = S.function_generator(spec, ground_length=0.15, min_transmission=math.radians(35), max_link_ratio=6)
    ls = S.function_generator(spec, ground_length=0.15, method="least-squares", n_points=21, max_link_ratio=6,
                              min_transmission=math.radians(20))
    assert ls.geometry.full_rotation()
    p0, s0 = math.radians(ls.achieved["phi0_deg"]), math.radians(ls.achieved["psi0_deg"])
    # the least-squares linkage: its K solve the normal equations of the 21 points
    xs = np.linspace(spec.x0, spec.x1, 21)
    ph, ps = spec.phi(xs, p0), spec.psi(xs, s0)
    M = np.stack([np.cos(ph), -np.cos(ps), -np.ones_like(ph)], axis=-1)
    np.testing.assert_allclose(ls.achieved["K"], np.linalg.lstsq(M, -np.cos(ph - ps), rcond=None)[0], rtol=1e-9)
    # its structural error is reported and of the same order as Chebyshev's (no exact points)
    assert 0 < ls.achieved["structural_error_max_deg"] < 10 * cheb.achieved["structural_error_max_deg"]
    chk = solver_check(ls, table_of(ls))
    assert chk["structural_error_max_deg_solver"] == pytest.approx(ls.achieved["structural_error_max_deg"], rel=2e-2)


def test_function_generator_branch_defect_is_reported():
    """Start angles whose precision points fall on different assembly branches: reported, and the
    linkage really misses a precision point (its one branch cannot reach it)."""
    spec = _log_spec()
    found = None
    for p0 in np.radians(np.arange(0, 360, 15)):
        for s0 in np.radians(np.arange(0, 360, 15)):
            ph, ps = spec.phi(S.chebyshev_points(1, 2, 3), p0), spec.psi(S.chebyshev_points(1, 2, 3), s0)
            fb, sig = S._fg_linkage(S.freudenstein_solve(ph, ps), 0.15, ph, ps)
            if fb is not None and np.any(sig != sig[0]) and fb.full_rotation():
                found = (p0, s0)
                break
        if found:
            break
    assert found is not None
    syn = S.function_generator(spec, ground_length=0.15, phi0=found[0], psi0=found[1])
    bad = {c["name"] for c in syn.failures()}
    assert "no branch defect (precision points on one assembly branch)" in bad
    assert syn.achieved["precision_point_error_rad"] > 1e-3


# ============================================================================ motion generation
def _known_fourbar_poses():
    fb = S.FourBar([0.0, 0.0], [0.12, 0.02], 0.04, 0.11, 0.09, 1, P=(0.05, 0.03))
    q = np.array([0.4, 1.7, 3.0])
    s = fb.solve(q)
    th_frame = 0.25  # the pose frame: coupler line rotated by a fixed angle
    poses = np.column_stack([s["P"], s["theta3"] - th_frame])
    mA = S._rotT(poses[:, 2][0], s["B"][0] - poses[0, :2])
    mB = S._rotT(poses[:, 2][0], s["C"][0] - poses[0, :2])
    return fb, poses, mA, mB


def test_motion_generator_round_trips():
    """Three poses of a known four-bar's coupler: given its ground pivots, the circle points are its
    moving pivots; given its moving pivots, the centre points are its ground pivots (round-off)."""
    fb, poses, mA, mB = _known_fourbar_poses()
    syn = S.motion_generator(poses, ground_pivots=[fb.A, fb.D])
    a = syn.achieved
    np.testing.assert_allclose(a["moving_pivot_A"], mA, atol=1e-12)
    np.testing.assert_allclose(a["moving_pivot_B"], mB, atol=1e-12)
    assert (syn.geometry.a, syn.geometry.b, syn.geometry.c) == pytest.approx((0.04, 0.11, 0.09), rel=1e-10)
    syn2 = S.motion_generator(poses, moving_pivots=[mA, mB])
    np.testing.assert_allclose(syn2.achieved["A"], fb.A, atol=1e-12)
    np.testing.assert_allclose(syn2.achieved["D"], fb.D, atol=1e-12)
    for s in (syn, syn2):
        assert s.ok, s.failures()
        chk = solver_check(s, table_of(s))
        assert chk["residual"] <= SOLVER_TOL and chk["branch_max_position_diff_m"] <= SOLVER_TOL, chk


def test_motion_generator_order_defect_is_reported():
    fb, poses, mA, mB = _known_fourbar_poses()
    syn = S.motion_generator(poses[[0, 2, 1]], ground_pivots=[fb.A, fb.D])
    bad = {c["name"] for c in syn.failures()}
    assert "no order defect (poses reached 1 → 2 → 3 turning the crank forward)" in bad


def test_motion_generator_search_meets_constraints_and_solver():
    poses = [[0.0, 0.0, 0.0], [0.06, 0.04, math.radians(-20)], [0.12, 0.02, math.radians(-45)]]
    syn = S.motion_generator(poses, min_transmission=math.radians(35), max_link_ratio=5.0, envelope=(0.5, 0.5),
                             search_box=[[-0.15, -0.25], [0.15, 0.05]], n_candidates=256)
    assert syn.ok, syn.failures()
    chk = solver_check(syn, table_of(syn))
    assert chk["position_residual_m"] <= SOLVER_TOL and chk["angle_residual_rad"] <= SOLVER_TOL, chk
    # tighter than the linkage can be: the constraint fails and is named
    tight = S.motion_generator(poses, moving_pivots=[syn.achieved["moving_pivot_A"], syn.achieved["moving_pivot_B"]],
                               min_transmission=math.radians(89), max_link_ratio=1.5)
    bad = {c["name"] for c in tight.failures()}
    assert {"minimum transmission angle", "link-length ratio (longest / shortest)"} <= bad


def test_function_expressions_are_safe():
    f = compile_function("log10(x) + x^2 - sin(pi*x)")
    assert f(np.array([2.0]))[0] == pytest.approx(math.log10(2) + 4 - math.sin(2 * math.pi))
    for bad in ("__import__('os')", "x.real", "open('f')", "[x for x in ()]", "lambda: 1"):
        with pytest.raises(ValueError):
            compile_function(bad)
