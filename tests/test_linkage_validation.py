"""The generic linkage against what we trust: the hand-derived closed forms of the shipped four-bar
(seed-000 and seed-002 notations) and quick-return (seed 004), written by hand as generic
linkages in tests/data/linkages/*.toml, and their hand-coded multibody-vs-reduced agreement.

Measured (docs/linkages.md §3): exact solve vs closed form ≤ 7e-13 relative (J, J', E_p'), the
tabulated reduced model ≤ 7.2e-11; multibody vs reduced identical to the hand-coded mechanisms'.
"""
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from mjbench.mechanisms import linkage as LK

DATA = Path(__file__).parent / "data" / "linkages"
CASES = ["incerti2012", "hulako2025-model1", "yigit2023"]


def scenario(name, linkage=False, modes=None):
    """Built-in scenario ``name``, optionally with its [mechanism] replaced by the hand-written
    linkage and/or its modes replaced (aliases into the replaced tables dropped)."""
    raw, src = S.read_raw(name)
    drop = []
    if linkage:
        raw["mechanism"] = tomllib.loads((DATA / f"{name}.toml").read_text())
        drop.append("mechanism.")
    if modes is not None:
        raw["modes"], raw["simulation"]["mode"] = modes, next(iter(modes))
        drop.append("modes.")
        if isinstance(raw.get("paper"), dict):  # the paper's figures of the replaced modes go too
            raw["paper"]["figures"] = [f for f in raw["paper"].get("figures", []) if f.get("mode") in modes]
    raw["aliases"] = {k: v for k, v in raw.get("aliases", {}).items() if not v.startswith(tuple(drop or ["-"]))}
    return S.from_raw(raw, src)


def linkage_scenario(name, modes=None):
    return scenario(name, True, modes)


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(a)))


@pytest.fixture(scope="module", params=CASES)
def pair(request):
    name = request.param
    return name, S.make_mechanism(S.load(name)), S.make_mechanism(linkage_scenario(name))


def test_reduced_model_equals_closed_form_over_a_turn(pair):
    """J, J', E_p' of the generic linkage = FourBar.reduced / QuickReturn.reduced to ≤ 1e-9
    relative over a full turn: both the exact solve and the table the backends use."""
    name, ref, lk = pair
    q = np.linspace(0.0, 2 * np.pi, 2001)
    a = ref.reduced(q)
    for x, tol in ((lk.reduced_exact(q), 2e-12), (lk.reduced(q), 2e-10)):
        for i in range(3):
            assert _rel(a[i], x[i]) < tol, (name, i)
    assert np.max(np.abs(ref.potential_energy(q) - lk.potential_energy(q))) < 1e-10
    # hinge damping (seed 002) and the cutting force (seed 004) reduced to the crank, q̇ > 0
    assert np.allclose(lk.external_torque(q, 3.0, 0.0), ref.external_torque(q, 3.0, 0.0), rtol=0, atol=1e-10)
    # scalar hot path = array path
    assert lk.reduced(1.234) == pytest.approx(tuple(float(v[0]) for v in lk.reduced(np.array([1.234]))), rel=1e-14)
    assert lk.table_info["rel_error_dJ"] < 1e-10  # measured at the interval midpoints against the exact solve


def test_converters_give_the_same_linkage(pair):
    """linkage.equivalent (used by `analyze` for the hand-coded types) matches the hand-written files."""
    name, ref, lk = pair
    eq = LK.equivalent(ref)
    q = np.linspace(0.0, 2 * np.pi, 501)
    for i in range(3):
        assert _rel(lk.reduced(q)[i], eq.reduced(q)[i]) < 2e-10


def test_velocity_coefficient_derivative_by_finite_differences():
    """J'(q) = 2vᵀMa with a = dv/dq from the velocity-product terms: check against central
    differences of J itself on a linkage with a slider, a spring and an offset (press)."""
    lk = S.make_mechanism(S.load("press-slidercrank"))
    q = np.linspace(0.1, 6.2, 37)
    h = 1e-5
    J, dJ, dEp = lk.reduced_exact(q)
    fd = (lk.reduced_exact(q + h)[0] - lk.reduced_exact(q - h)[0]) / (2 * h)
    assert np.max(np.abs(fd - dJ)) < 1e-8 * np.max(np.abs(dJ))
    Ep = lambda x: lk.c.channels(*lk.c.exact(x))[:, 3]  # noqa: E731
    fdE = (Ep(q + h) - Ep(q - h)) / (2 * h)
    assert np.max(np.abs(fdE - dEp)) < 1e-7 * np.max(np.abs(dEp))


def _runs(scn, mode, t_end):
    a = multibody.simulate(S.make_machine(scn, mode), t_end, dt=1e-4, record_dt=5e-4,
                           options=scn.multibody_options())
    b = reduced.simulate(S.make_machine(scn, mode), t_end, dt=1e-4, record_dt=5e-4)
    return a, b


OPEN6 = {"open": {"type": "open", "voltage": 6.0}}


@pytest.mark.parametrize("name,mode,modes,t_end", [
    ("incerti2012", "pid", None, 2.0),
    ("hulako2025-model1", "open", OPEN6, 1.5),   # the coupler-speed reference needs a FourBar: open loop
    ("yigit2023", "open", None, 2.0),
])
def test_multibody_vs_reduced_as_tight_as_hand_coded(name, mode, modes, t_end):
    """Same runs with the hand-coded mechanism and its generic-linkage twin: the linkage's
    multibody-vs-reduced difference is no larger (measured: equal to 3 digits)."""
    hand, link = scenario(name, False, modes), scenario(name, True, modes)
    out = {}
    for lab, scn in (("hand", hand), ("linkage", link)):
        mb, red = _runs(scn, mode, t_end)
        out[lab] = M.rel_difference(red.t, red.qd, mb.t, mb.qd)
        assert np.max(mb.closure) < 1e-7
    assert out["linkage"][0] <= 1.05 * out["hand"][0] + 1e-9, out
    assert out["linkage"][1] <= 1.05 * out["hand"][1] + 1e-9, out


def test_mjcf_of_the_fourbar_linkage_is_the_hand_coded_one():
    """With the same spanning tree (ground pivots in the tree, closure at C) the generated MJCF
    gives the hand-coded four-bar's multibody run to round-off."""
    hand, link = S.load("incerti2012"), linkage_scenario("incerti2012")
    a = multibody.simulate(S.make_machine(hand, "open"), 0.5, dt=1e-4, record_dt=1e-3)
    b = multibody.simulate(S.make_machine(link, "open"), 0.5, dt=1e-4, record_dt=1e-3)
    assert np.max(np.abs(a.qd - b.qd)) < 1e-9 * np.max(np.abs(a.qd))
