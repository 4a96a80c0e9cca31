"""Motion laws of seeds 001 (pseudo-polynomial) and 003 (Bezier): boundary conditions, Table II,
derivatives, polygons, errors."""
import math

import numpy as np
import pytest
from scipy.interpolate import BPoly

from mjbench.errors import ParameterError
from mjbench.motionlaws import (BezierLaw, PseudoPolynomialLaw, bernstein, bezier_integral,
                                boundary_matrix, coefficients_three, derivative_polygon,
                                integral_polygon, make_law, solve_coefficients)


def test_table_II_coefficients():
    # seed 001 Table II: 3-4-5 → 10, −15, 6; pseudo-polynomial 4.5, 6.2, 8.4 → 7.855, −10.107, 3.252
    np.testing.assert_allclose(solve_coefficients([3, 4, 5]), [10, -15, 6], rtol=1e-12)
    C = solve_coefficients([4.5, 6.2, 8.4])
    np.testing.assert_allclose(C, [7.855, -10.107, 3.252], atol=6e-4)
    np.testing.assert_allclose(C, coefficients_three(4.5, 6.2, 8.4), rtol=1e-12)  # Eq 16


def test_boundary_matrix_structure():
    Z = boundary_matrix([3.0, 4.0, 5.0])
    np.testing.assert_allclose(Z, [[1, 1, 1], [3, 4, 5], [6, 12, 20]])  # Eq 15


@pytest.mark.parametrize("gammas", [(3, 4, 5), (4.5, 6.2, 8.4), (3.024, 4.565, 5.874), (2.5, 3.7),
                                    (4, 5, 6, 7), (5.2, 6.1, 7.9, 9.3, 11.0), (6, 7, 8, 9, 10, 11)])
def test_pseudopolynomial_boundary_conditions(gammas):
    Phi, T = 3.7, 0.8
    law = PseudoPolynomialLaw(Phi, T, gammas)
    n = len(gammas) - 1
    # derivatives 0..n at t = 0 vanish; at T position = Φ, derivatives 1..n vanish (Eqs 11, 20)
    for k in range(0, min(n, 3) + 1):
        v0 = law.evaluate(np.array([0.0]), 3)[k][0]
        vT = law.evaluate(np.array([T]), 3)[k][0]
        scale = abs(Phi) / T ** k * 10 ** k
        assert abs(v0) < 1e-11 * scale, (k, v0)
        assert abs(vT - (Phi if k == 0 else 0.0)) < 1e-11 * scale, (k, vT)
    # higher BCs (k > 3) through Z̄ itself
    C = solve_coefficients(gammas)
    Z = boundary_matrix(gammas)
    np.testing.assert_allclose(Z @ C, np.eye(n + 1)[0], atol=1e-13 * np.max(np.abs(Z) @ np.abs(C)))


def test_derivatives_match_finite_differences():
    law = PseudoPolynomialLaw(2.0, 1.3, (3.3, 4.1, 6.7, 8.0))
    t = np.linspace(0.1, 1.2, 7)
    h = 1e-5
    p0, v0, a0, j0 = law.evaluate(t)
    pp, vp, ap, _ = law.evaluate(t + h)
    pm, vm, am, _ = law.evaluate(t - h)
    np.testing.assert_allclose(v0, (pp - pm) / (2 * h), rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(a0, (vp - vm) / (2 * h), rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose(j0, (ap - am) / (2 * h), rtol=1e-6, atol=1e-6)


def test_outside_interval_and_scalar():
    law = PseudoPolynomialLaw(5.0, 1.0)
    p, v, a, j = law.evaluate(np.array([-0.5, 1.5]))
    np.testing.assert_array_equal(p, [0.0, 5.0])
    np.testing.assert_array_equal(v, [0.0, 0.0])
    p, v, a, j = law.evaluate(0.5)
    assert isinstance(p, float) and p == pytest.approx(2.5) and v == pytest.approx(1.875 * 5)


def test_pseudopolynomial_errors():
    with pytest.raises(ParameterError, match="distinct"):
        PseudoPolynomialLaw(1.0, 1.0, (3.0, 4.0, 4.0))
    with pytest.raises(ParameterError, match="γ_0 = 2"):
        PseudoPolynomialLaw(1.0, 1.0, (2.0, 4.0, 5.0))  # n = 2 needs γ > 2
    with pytest.raises(ParameterError, match="n = 3"):
        PseudoPolynomialLaw(1.0, 1.0, (3.0, 4.0, 5.0, 6.0))  # n = 3 needs γ > 3
    with pytest.raises(ParameterError, match="finite"):
        PseudoPolynomialLaw(1.0, 1.0, (3.0, np.nan, 5.0))
    with pytest.raises(ParameterError, match="law.T"):
        PseudoPolynomialLaw(1.0, 0.0)
    with pytest.raises(ParameterError, match="law.Phi"):
        PseudoPolynomialLaw(0.0, 1.0)


def test_bernstein_corrected_exponent():
    lam = np.linspace(0, 1, 11)
    n = 6
    total = sum(bernstein(n, i, lam) for i in range(n + 1))
    np.testing.assert_allclose(total, 1.0, atol=1e-14)  # partition of unity needs (1−λ)^(n−i)
    assert bernstein(4, 1, 0.5) == pytest.approx(4 * 0.5 * 0.5 ** 3)


@pytest.mark.parametrize("m,p", [(2, 3), (1, 0), (3, 2), (2, 5), (4, 1)])
def test_bezier_boundary_conditions(m, p):
    Phi, T = 40 * math.pi, 1.0
    rng = np.random.default_rng(m * 10 + p)
    law = BezierLaw(Phi, T, m, p, interior=Phi * rng.uniform(0.1, 0.9, p))
    assert law.n_s == 2 * m + p + 1 and law.S.size == 2 * (m + 1) + p
    for k in range(0, min(m, 3) + 1):  # Eq 16: derivatives 0..m vanish at 0, 1..m at T
        v0 = law.evaluate(np.array([0.0]), 3)[k][0]
        vT = law.evaluate(np.array([T]), 3)[k][0]
        scale = Phi * law.n_s ** k
        assert abs(v0) < 1e-12 * scale
        assert abs(vT - (Phi if k == 0 else 0.0)) < 1e-12 * scale
    if m < 3:  # derivative m+1 is not forced to zero in general
        assert abs(law.evaluate(np.array([0.0]), 3)[m + 1][0]) > 1e-6


def test_bezier_polygons_eqs_13_18_19():
    law = BezierLaw(10.0, 2.0, 2, 3, interior=[2.0, 5.0, 9.0])
    S, V, A, Jk = law.polygons()
    np.testing.assert_allclose(V, law.n_s / law.T * np.diff(S))  # Eq 18
    np.testing.assert_allclose(A, (law.n_s - 1) / law.T * np.diff(V))  # Eq 19
    t = np.linspace(0, 2.0, 9)
    # Eqs 20-21: the derivative curves are the Bezier curves of the derivative polygons
    lam = t / law.T
    v = sum(V[i] * bernstein(V.size - 1, i, lam) for i in range(V.size))
    a = sum(A[i] * bernstein(A.size - 1, i, lam) for i in range(A.size))
    _, v1, a1, _ = law.evaluate(t)
    np.testing.assert_allclose(v1, v, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(a1, a, rtol=1e-12, atol=1e-9)
    # Eq 17 with the corrected Bernstein polynomial
    pos = sum(S[i] * bernstein(law.n_s, i, lam) for i in range(S.size))
    np.testing.assert_allclose(law.position(t), pos, rtol=1e-13, atol=1e-12)


def test_integral_polygon_corrected_eq14_and_eq15():
    y = np.array([0.3, -1.0, 2.0, 0.5, 1.1])
    x0, xn = 0.5, 2.5
    yt = integral_polygon(y, x0, xn)
    ref = BPoly(y[:, None], [x0, xn]).antiderivative()
    np.testing.assert_allclose(yt, ref.c[:, 0], atol=1e-14)
    # derivative of the integral polygon returns the polygon (Eq 13 ∘ Eq 14 = id)
    np.testing.assert_allclose(derivative_polygon(yt, x0, xn), y, atol=1e-13)
    assert bezier_integral(y, x0, xn) == pytest.approx(float(ref(xn)), rel=1e-14)  # Eq 15


def test_bezier_errors_and_params():
    with pytest.raises(ParameterError, match="interior"):
        BezierLaw(1.0, 1.0, 2, 3, interior=[0.2, 0.5])
    with pytest.raises(ParameterError, match="law.m"):
        BezierLaw(1.0, 1.0, -1, 3)
    law = BezierLaw(4.0, 1.0, 2, 3)
    np.testing.assert_allclose(law.params, [0.25, 0.5, 0.75])  # linear polygon P_m → P_{m+p+1}
    law2 = law.with_params([0.1, 0.5, 0.9])
    np.testing.assert_allclose(law2.interior, [0.4, 2.0, 3.6])


def test_make_law():
    law = make_law({"kind": "pseudopoly", "revolutions": 15, "T": 1.0, "gammas": [3, 4, 5]})
    assert law.Phi == pytest.approx(30 * math.pi)
    law = make_law({"kind": "bezier", "revolutions": 20, "T": 1.0, "m": 2, "p": 3})
    assert law.n_s == 8
    with pytest.raises(ParameterError):
        make_law({"kind": "spline", "Phi": 1.0, "T": 1.0})


@pytest.mark.parametrize("m,p", [(2, 3), (1, 0), (3, 2), (4, 1)])
def test_bezier_law_matches_scipy_bpoly(m, p):
    """The scalar law (Horner in the Bernstein basis, derivative polygons of Eq 13) against
    scipy's BPoly and its derivatives, φ to φ⃛, over the move and at both ends."""
    Phi, T = 7.0, 0.6
    rng = np.random.default_rng(10 * m + p)
    law = BezierLaw(Phi, T, m, p, interior=Phi * rng.uniform(-0.2, 1.2, p))
    bp = [BPoly(law.S[:, None], [0.0, T])]
    for _ in range(3):
        bp.append(bp[-1].derivative())
    t = np.concatenate(([0.0, T], np.linspace(0.0, T, 97), [0.5 * T]))
    out = law.evaluate(t, 3)
    for k in range(4):
        ref = bp[k](t)
        np.testing.assert_allclose(out[k], ref, rtol=0, atol=1e-12 * Phi * (law.n_s / T) ** k * 10 ** k)


def test_pseudopolynomial_law_matches_eq17_written_out():
    """The scalar law against Eqs 17-18 written with NumPy (exponents γ, coefficients C)."""
    law = PseudoPolynomialLaw(2.5, 0.9, (4.5, 6.2, 8.4))
    t = np.linspace(0.0, 0.9, 61)
    u = 1.0 - t / 0.9
    g, C = law.gammas, law.C
    p = 2.5 * (1.0 - sum(C[i] * u ** g[i] for i in range(3)))
    v = 2.5 / 0.9 * sum(C[i] * g[i] * u ** (g[i] - 1) for i in range(3))
    a = -2.5 / 0.9 ** 2 * sum(C[i] * g[i] * (g[i] - 1) * u ** (g[i] - 2) for i in range(3))
    out = law.evaluate(t, 2)
    for x, ref, sc in zip(out, (p, v, a), (2.5, 2.5 / 0.9, 2.5 / 0.81)):
        np.testing.assert_allclose(x, ref, rtol=0, atol=1e-13 * sc * 100)


def test_law_reference_is_the_scaled_delayed_law():
    """LawReference (the servo's reference, a law) = scale·φ(t − t0) and derivatives, at rest
    before the start and after the end; its state-free law gives the same at any call order."""
    law = make_law({"kind": "bezier", "Phi": 3.0, "T": 0.5, "m": 2, "p": 3})
    ref = law.as_reference(scale=2.0, t0=0.1)
    for t in (0.0, 0.05, 0.1, 0.2, 0.37, 0.6, 0.65, 1.0, 0.3):
        phi, om, acc = ref(t, None)
        p, v, a = law.evaluate(t - 0.1, 2)
        assert (phi, om, acc) == (2.0 * p, 2.0 * v, 2.0 * a)
        if t < 0.1:
            assert (phi, om, acc) == (0.0, 0.0, 0.0)
        if t > 0.6:
            assert (phi, om, acc) == (6.0, 0.0, 0.0)
    with pytest.raises(ParameterError, match="law.T"):
        make_law({"kind": "bezier", "Phi": 3.0, "T": -1.0})
