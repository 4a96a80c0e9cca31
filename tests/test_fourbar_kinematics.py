"""Four-bar (seed 000): closed-form kinematics and reduced dynamics vs independent checks."""
import math
import re

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.errors import GeometryError, ParameterError
from mjbench.mechanisms.fourbar import CouplerPoint, FourBar


@pytest.fixture(scope="module")
def fb():
    return S.make_mechanism(S.load("incerti2012"))


ALPHA = np.linspace(0, 2 * np.pi, 73)


@pytest.mark.parametrize("k", [1, -1])
def test_loop_closes_for_both_assembly_modes(fb, k):
    m = FourBar(**{**fb.__dict__, "k": k})
    j = m.joints(ALPHA)
    BC = np.hypot(j["C"][0] - j["B"][0], j["C"][1] - j["B"][1])
    np.testing.assert_allclose(BC, m.b, rtol=0, atol=1e-12)  # |BC| = b for every α
    DC = np.hypot(j["C"][0] - m.h_x, j["C"][1] - m.h_y)
    np.testing.assert_allclose(DC, m.c, rtol=0, atol=1e-12)


def test_assembly_modes_differ(fb):
    b1, g1 = FourBar(**{**fb.__dict__, "k": 1}).angles(ALPHA)
    b2, g2 = FourBar(**{**fb.__dict__, "k": -1}).angles(ALPHA)
    assert np.min(np.abs(np.sin(g1 - g2))) > 1e-3  # the two branches are distinct configurations


def test_scalar_and_array_paths_agree(fb):
    for a in (0.0, 1.1, 3.0, 5.5):
        Js, dJs, dEs = fb.reduced(a)
        Ja, dJa, dEa = fb.reduced(np.array([a]))
        assert Js == pytest.approx(Ja[0], rel=1e-14) and dJs == pytest.approx(dJa[0], rel=1e-13)
        assert dEs == pytest.approx(dEa[0], rel=1e-13)


def _richardson(f, x, h=1e-3):
    """6th-order central difference (Richardson), error ~h^6."""
    d1 = (f(x + h) - f(x - h)) / (2 * h)
    d2 = (f(x + h / 2) - f(x - h / 2)) / h
    d4 = (f(x + h / 4) - f(x - h / 4)) / (h / 2)
    e1 = (4 * d2 - d1) / 3
    e2 = (4 * d4 - d2) / 3
    return (16 * e2 - e1) / 15


def test_velocity_ratios_are_derivatives_of_the_angles(fb):
    a = ALPHA[:-1] + 0.013
    beta, gamma, Q, R = fb.ratios(a)
    # derivative of angles (continuous across ±π: differentiate sin/cos pairs)
    db = _richardson(lambda x: np.sin(fb.angles(x)[0]), a) / np.cos(beta)
    dg = _richardson(lambda x: np.sin(fb.angles(x)[1]), a) / np.cos(gamma)
    ok_b, ok_g = np.abs(np.cos(beta)) > 0.2, np.abs(np.cos(gamma)) > 0.2
    np.testing.assert_allclose(db[ok_b], Q[ok_b], rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(dg[ok_g], R[ok_g], rtol=1e-8, atol=1e-10)


def test_reduced_derivatives_match_high_accuracy_numerics(fb):
    a = ALPHA[:-1] + 0.029
    J, dJ, dEp = fb.reduced(a)
    num_dJ = _richardson(lambda x: fb.reduced(x)[0], a)
    num_dEp = _richardson(fb.potential_energy, a)
    # relative to the scale of the derivative over the cycle: ≤ 1e-8 (issue requirement)
    assert np.max(np.abs(num_dJ - dJ)) / np.max(np.abs(dJ)) < 1e-8
    assert np.max(np.abs(num_dEp - dEp)) / np.max(np.abs(dEp)) < 1e-8


def test_J_matches_kinetic_energy_of_the_three_links(fb):
    """Appendix C J(α) against E_k summed link by link from point velocities (independent path)."""
    a = ALPHA[:-1] + 0.2
    ad = 1.7
    beta, gamma, Q, R = fb.ratios(a)
    bd, gd = Q * ad, R * ad
    f, th, m, JG = fb.f, fb.theta, fb.m, fb.J_G
    v1 = f[0] * ad
    vx2 = -fb.a * ad * np.sin(a) - f[1] * bd * np.sin(beta + th[1])
    vy2 = fb.a * ad * np.cos(a) + f[1] * bd * np.cos(beta + th[1])
    v3 = f[2] * gd
    Ek = 0.5 * (m[0] * v1**2 + JG[0] * ad**2 + m[1] * (vx2**2 + vy2**2) + JG[1] * bd**2
                + m[2] * v3**2 + JG[2] * gd**2)
    np.testing.assert_allclose(fb.kinetic_energy(a, ad), Ek, rtol=1e-12)


def test_coupler_point_velocity_is_derivative_of_position(fb):
    pt = CouplerPoint(0.12, 0.4)
    a = ALPHA[:-1] + 0.05
    vx, vy = fb.coupler_point_velocity(a, 1.0, pt)
    nx = _richardson(lambda x: fb.coupler_point_position(x, pt)[0], a)
    ny = _richardson(lambda x: fb.coupler_point_position(x, pt)[1], a)
    np.testing.assert_allclose(vx, nx, rtol=0, atol=1e-9)
    np.testing.assert_allclose(vy, ny, rtol=0, atol=1e-9)


def test_impossible_linkage_raises_with_parameters():
    with pytest.raises(GeometryError, match=r"cannot be assembled at any crank angle.*a=0.1, b=0.05, c=0.05"):
        FourBar(a=0.1, b=0.05, c=0.05, h_x=0.5, h_y=0.0)


def test_crank_that_cannot_turn_names_the_angle_range():
    # crank longer than the coupler allows: assembles only near α = 0
    with pytest.raises(GeometryError) as e:
        FourBar(a=0.3, b=0.25, c=0.3, h_x=0.35, h_y=0.0)
    msg = str(e.value)
    assert "cannot make the full turn" in msg and "a=0.3" in msg and "°.." in msg
    # the reported range really is where A²+B²−C² < 0
    lo, hi = (float(v) for v in re.search(r"for α in (-?[\d.]+)°\.\.(-?[\d.]+)°", msg).groups())
    mid = math.radians(0.5 * (lo + hi))
    m = FourBar.__new__(FourBar)
    m.__dict__.update(dict(a=0.3, b=0.25, c=0.3, h_x=0.35, h_y=0.0))
    assert FourBar._abcd2(m, mid)[3] < 0


@pytest.mark.parametrize("field,value,match", [
    ("a", -0.1, "fourbar.a"), ("b", 0.0, "fourbar.b"), ("c", float("nan"), "fourbar.c"),
    ("k", 2, "fourbar.k"), ("m", (1.0, -1.0, 1.0), "fourbar.m2"), ("J_G", (1.0, 1.0, -1e-3), "fourbar.J_G3")])
def test_non_physical_parameters_raise(fb, field, value, match):
    with pytest.raises(ParameterError, match=match):
        FourBar(**{**fb.__dict__, field: value})
