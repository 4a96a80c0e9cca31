"""Process loads given over the stroke (profile: distance before the end of the active stroke;
profile_fraction: fraction of the stroke) on a linkage, and a load that never acts along the motion
is a warning naming it (the press assembled upside down)."""
import math

import numpy as np
import pytest

import mjbench as mjb
from mjbench.errors import ScenarioError

R, L, E = 0.040, 0.200, 0.010           # press-slidercrank: crank, rod, offset [m]
BDC = -math.sqrt((L + R) ** 2 - E**2)   # the ram pin's lowest height (closed form)
TDC = -math.sqrt((L - R) ** 2 - E**2)
FORMING = {"name": "forming", "point": "ram.C", "direction": [0.0, 1.0], "active": "stroke_against"}


def _press(load, **values):
    return mjb.load("press-slidercrank", **{"mechanism.loads": [load], **values})


def test_profile_becomes_the_table_at_the_stroke_end():
    scn = _press({**FORMING, "profile": [["10 mm", "0 N"], ["2 mm", "8 kN"], ["0 mm", "8 kN"]]})
    ld = scn.machine().mechanism.load_specs[0]
    np.testing.assert_allclose(ld.s, [BDC, BDC + 0.002, BDC + 0.010], atol=1e-6)   # BDC found on a 2048-point turn
    assert ld.F == [8000.0, 8000.0, 0.0]
    frac = _press({**FORMING, "profile_fraction": [[0.125, 0.0], [0.025, 8000.0], [0.0, 8000.0]]})
    stroke = TDC - BDC                                                                # 80.0 mm
    np.testing.assert_allclose(frac.machine().mechanism.load_specs[0].s,
                               [BDC, BDC + 0.025 * stroke, BDC + 0.125 * stroke], atol=1e-6)
    # the same press as with the scenario's absolute table (BDC written by hand to 0.1 mm)
    a = scn.simulate(backend="reduced", t_end=2.5).metrics["backends"]["reduced"]
    b = mjb.load("press-slidercrank").simulate(backend="reduced", t_end=2.5).metrics["backends"]["reduced"]
    assert a["loads"]["forming"]["peak_abs"] == 8000.0 and b["loads"]["forming"]["peak_abs"] == 8000.0
    assert a["mean_crank_speed_rad_s"] == pytest.approx(b["mean_crank_speed_rad_s"], rel=1e-4)
    assert a["energy_mech_J"] == pytest.approx(b["energy_mech_J"], rel=1e-3)


def test_a_load_never_reached_is_a_warning_naming_it():
    """The rod's angle with the wrong sign assembles the press upside down: the ram never comes
    down to the table's heights, and the run says so."""
    scn = mjb.load("press-slidercrank", **{"mechanism.links.rod.angle": "93 deg"})
    with pytest.warns(mjb.MjbenchWarning, match="load 'forming' never acts along the motion"):
        res = scn.simulate(backend="reduced", t_end=0.5)
    m = res.metrics["backends"]["reduced"]["loads"]["forming"]
    assert m["peak_abs"] == 0.0 and m["s_reached_m"][0] > 0.15          # the ram above the crank
    assert any("its table spans s = -239.8 … -229.8 mm along (0.0, 1.0), the point ram.C moved over s = " in w
               for w in res.metrics["warnings"])
    # given over the stroke it follows the (wrong) assembly's stroke end and acts
    res2 = _press({**FORMING, "profile": [["10 mm", "0 N"], ["0 mm", "8 kN"]]},
                  **{"mechanism.links.rod.angle": "93 deg"}).simulate(backend="reduced", t_end=1.5)
    assert res2.metrics["backends"]["reduced"]["loads"]["forming"]["peak_abs"] > 0 and not res2.metrics["warnings"]


@pytest.mark.parametrize("load, msg", [
    ({**FORMING, "active": "always", "profile": [[0.01, 0.0], [0.0, 100.0]]}, "measured from the end of a stroke"),
    ({**FORMING, "profile_fraction": [[1.5, 0.0], [0.0, 100.0]]}, "distinct and in \\[0, 1\\]"),
    ({**FORMING, "profile": [[0.01, 0.0], [0.0, 100.0]], "force": 5.0}, "give one of force, the table s, F"),
])
def test_bad_profiles_are_refused(load, msg):
    with pytest.raises(ScenarioError, match=msg):
        _press(load)
