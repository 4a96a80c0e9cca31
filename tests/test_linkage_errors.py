"""Bad linkage descriptions: one clear message naming the element, exit status 2 from the CLI."""
import copy
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.cli import main
from mjbench.errors import GeometryError, ScenarioError

DATA = Path(__file__).parent / "data" / "linkages"
BASE = tomllib.loads((DATA / "incerti2012.toml").read_text())


def build(mech):
    raw, src = S.read_raw("incerti2012")
    raw["mechanism"] = mech
    return S.make_mechanism(S.from_raw(raw, src))


def variant(**edits):
    m = copy.deepcopy(BASE)
    for path, value in edits.items():
        node = m
        keys = path.split("__")
        for k in keys[:-1]:
            node = node[int(k)] if k.isdigit() else node[k]
        last = keys[-1]
        node[int(last) if last.isdigit() else last] = value
    return m


def test_unknown_link_is_named():
    m = variant(joints__2__at=["coupler.C", "rokcer.C"])
    with pytest.raises(ScenarioError, match=r"joints\[2\] \('C'\): link 'rokcer' is not defined"):
        build(m)


def test_unknown_point_is_named():
    m = variant(joints__1__at=["crank.X", "coupler.B"])
    with pytest.raises(ScenarioError, match=r"link 'crank' has no point 'X'"):
        build(m)


def test_zero_length_link():
    m = variant(links__coupler__points={"B": [0.0, 0.0], "C": [0.0, 0.0]})
    with pytest.raises(ScenarioError, match=r"links\.coupler: zero length: its joint points B, C coincide"):
        build(m)


def test_negative_mass_names_the_path():
    m = variant(links__rocker__mass=-1.0)
    with pytest.raises(ScenarioError, match=r"mechanism\.links\.rocker\.mass: must be >= 0 kg"):
        build(m)


def test_two_degrees_of_freedom_names_the_joints():
    """A five-bar (two rockers in series instead of one) has 2 DOF: the joints that still move
    with the input held are named."""
    m = copy.deepcopy(BASE)
    m["links"]["r2"] = {"mass": 1.0, "inertia": 0.01, "points": {"D": [0, 0], "E": [0.3, 0]}, "angle": "-96 deg"}
    m["links"]["rocker"]["angle"] = "90 deg"
    m["joints"][3]["at"] = ["ground.D", "r2.D"]
    m["joints"].append({"name": "E", "at": ["rocker.D", "r2.E"]})
    with pytest.raises(GeometryError, match=r"has 2 degrees of freedom .*joints B, C, D, E can still move"):
        build(m)


def test_zero_degrees_of_freedom_names_the_joints():
    """A strut from the frame to the coupler point makes the four-bar a rigid structure."""
    fb = S.make_mechanism(S.load("incerti2012"))
    P = np.array(fb.coupler_point_position(0.5))
    G = np.array([0.15, -0.1])
    m = copy.deepcopy(BASE)
    m["ground"]["G"] = list(G)
    m["links"]["strut"] = {"mass": 1.0, "inertia": 0.01, "points": {"G": [0, 0], "P": [float(np.hypot(*(P - G))), 0]},
                           "angle": float(np.arctan2(*(P - G)[::-1]))}
    m["joints"] += [{"name": "G", "at": ["ground.G", "strut.G"]}, {"name": "P", "at": ["strut.P", "coupler.P"]}]
    with pytest.raises(GeometryError, match=r"has 0 degrees of freedom .*rigid structure .*joints A, B, C, D, G, P"):
        build(m)


def test_loop_that_cannot_close_over_part_of_the_turn_gives_the_range():
    """Crank 0.3 m: not a Grashof crank: the range where the loop cannot close is given (checked
    against the closed form A²+B²−C² < 0 of seed 000, Appendix A)."""
    m = variant(links__crank__points={"A": [0.0, 0.0], "B": [0.3, 0.0]})
    with pytest.raises(GeometryError) as ei:
        build(m)
    msg = str(ei.value)
    assert "loop A, B, C, D cannot close for input angles" in msg
    lo, hi = (float(x) for x in msg.split("input angles ")[1].split(" ")[0].rstrip("°").split("°.."))
    a, b, c, hx, hy = 0.3, 0.3, 0.3, 0.3, 0.05
    al = np.radians(np.arange(0, 360, 0.1))
    A = 2 * c * (hy - a * np.sin(al))
    B = 2 * c * (hx - a * np.cos(al))
    C = a * a - b * b + c * c + hx * hx + hy * hy - 2 * a * (hx * np.cos(al) + hy * np.sin(al))
    bad = np.degrees(al[A * A + B * B - C * C < 0])
    assert lo == pytest.approx(bad.min(), abs=0.2) and hi == pytest.approx(bad.max(), abs=0.2)


def test_loop_that_cannot_be_assembled_at_all():
    m = variant(ground__D=[1.0, 0.05])
    with pytest.raises(GeometryError, match=r"cannot be assembled at any input angle.*joint"):
        build(m)


def test_input_joint_not_in_a_loop():
    """An input joint in no loop is an open chain (a pendulum is valid: tests/test_change_points.py);
    here it leaves the four-bar undriven: 2 degrees of freedom, the undriven joints and the open input named."""
    m = copy.deepcopy(BASE)
    m["ground"]["O"] = [0.5, 0.5]
    m["links"]["wheel"] = {"mass": 1.0, "inertia": 0.01, "points": {"O": [0, 0]}}
    m["joints"].append({"name": "O", "at": ["ground.O", "wheel.O"]})
    m["input"] = "O"
    with pytest.raises(GeometryError, match=r"has 2 degrees of freedom .*joints A, B, C, D can still move \(the input "
                                            r"joint 'O' is in no closed loop"):
        build(m)


def test_input_joint_must_be_on_the_frame_and_revolute():
    with pytest.raises(ScenarioError, match=r"input = 'B': the input joint must connect the ground"):
        build(variant(input="B"))
    with pytest.raises(ScenarioError, match=r"input = 'Z': no joint of that name"):
        build(variant(input="Z"))


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return '"' + v.replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f'"{k}" = {_toml_value(x)}' for k, x in v.items()) + " }"
    raise TypeError(v)


def _write_scenario(path, mech):
    """incerti2012 with [mechanism] = mech, as a TOML file (inline tables are enough here)."""
    lines = ['[scenario]', 'name = "bad-linkage"', '[mechanism]']
    for k, v in mech.items():
        lines.append(f'"{k}" = {_toml_value(v)}')
    text = (Path(S.__file__).parent / "scenarios" / "incerti2012.toml").read_text()
    rest = text[text.index("[drive]"):]
    rest = rest[:rest.index("[paper]")]
    path.write_text("\n".join(lines) + "\n" + rest)
    return path


@pytest.mark.parametrize("edit,needle", [
    ({"joints__2__at": ["coupler.C", "rokcer.C"]}, "link 'rokcer' is not defined"),
    ({"links__crank__points": {"A": [0.0, 0.0], "B": [0.3, 0.0]}}, "cannot close for input angles"),
])
def test_cli_exit_status_2(tmp_path, capsys, edit, needle):
    f = _write_scenario(tmp_path / "bad.toml", variant(**edit))
    out = tmp_path / "out"
    assert main(["run", str(f), "--out", str(out), "--t-end", "0.1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("mjbench: error:") and needle in err and "Traceback" not in err
    assert not out.exists() or not any(out.iterdir())
    assert main(["analyze", str(f)]) == 2
    assert needle in capsys.readouterr().err


def test_cli_accepts_the_good_file(tmp_path):
    f = _write_scenario(tmp_path / "good.toml", BASE)
    assert main(["run", str(f), "--out", str(tmp_path / "o"), "--t-end", "0.05", "--quiet", "--no-figure"]) == 0
    assert math.isfinite(float((tmp_path / "o" / "trajectory_reduced.csv").read_text().splitlines()[-1].split(",")[2]))


def test_an_input_that_locks_gives_the_angle():
    """The seed-000 crank-rocker driven at its rocker (joint D): the rocker cannot turn past its limit
    positions, where the crank and the coupler are collinear (a lock-up: no branch continues): one
    line naming where the input locks, before simulating.  Checked against the limit positions by
    the cosine rule: |DB| = coupler ± crank."""
    m = variant(input="D", input_angle="-96 deg")
    with pytest.raises(GeometryError) as ei:
        build(m)
    msg = str(ei.value)
    assert "cannot close for input angles" in msg and "the input locks at" in msg, msg
    lo, hi = (float(x) for x in msg.split("input angles ")[1].split(" ")[0].rstrip("°").split("°.."))
    d = math.hypot(0.30, 0.05)
    phi_d = math.atan2(-0.05, -0.30)  # direction D → A
    limits = []
    for r in (0.3 + 0.1, 0.3 - 0.1):  # |DB| at the two limit positions
        beta = math.acos((0.3 ** 2 + d * d - r * r) / (2 * 0.3 * d))  # angle at D between DA and DC
        limits += [math.degrees(phi_d + beta) % 360, math.degrees(phi_d - beta) % 360]
    assert min(abs((lo - x + 180) % 360 - 180) for x in limits) < 0.5, (lo, limits)
    assert min(abs((hi - x + 180) % 360 - 180) for x in limits) < 0.5, (hi, limits)
