"""`mjbench design` with a cam requirement (mjbench/design/cam.py; docs/design.md §3c): the base circle is
the smallest that meets the pressure-angle limit (checked against the closed form of an offset
translating roller follower, tan φ = (s' − e)/(d₀ + s)), the spring holds the follower exactly up to
jump_margin × the speed and is the least peak force doing so, and the machine — catalogue drive, speed
PI with design-rule gains — is verified on MuJoCo: every prediction within its check's tolerance (2 % for
the sizing model's currents, torques, voltage and χ; measured ≤ 0.3 %), the follower on the cam."""
import math

import numpy as np
import pytest

from mjbench.cli import main
from mjbench.design import cam as DC
from mjbench.design import pipeline as DP
from mjbench.design.requirements import load as load_req
from mjbench.mechanisms.cam_profile import CamProgram, FollowerLoad, jump_speed


def _phi_max(req, Rb):
    """The largest pressure angle of the requirement's translating roller follower at base radius R_b,
    by the closed form (not the code's geometry)."""
    m = req.mechanism
    prog = CamProgram(m.segments(), m.lift)
    th = np.linspace(0, 2 * math.pi, 72001)
    s, s1, _, _ = prog(th)
    d0 = math.sqrt((Rb + m.roller_radius) ** 2 - m.offset ** 2)
    return math.degrees(float(np.max(np.arctan(np.abs(s1 - m.offset) / (d0 + s)))))


def test_base_circle_and_spring_of_the_shipped_requirement():
    req = load_req("cam")
    m = req.mechanism
    syn, table, _ = DC.synthesize(req)
    Rb = table["base_radius"]
    lim = math.degrees(m.max_pressure_angle)
    assert _phi_max(req, Rb) <= lim < _phi_max(req, Rb - DC.BASE_STEP)  # the smallest on the 0.1 mm grid
    assert Rb == pytest.approx(0.0125)
    W = m.jump_margin * req.duty.omega
    prog = CamProgram(m.segments(), m.lift)
    k, F0 = table["spring_rate"], table["spring_preload"]
    js = jump_speed(FollowerLoad(m.mass, k, F0, m.follower_load), prog)["speed_rad_s"]
    assert js == pytest.approx(W, rel=1e-5)
    assert F0 <= m.spring_precompression_max * k * m.lift * (1 + 1e-9)
    # the least peak force: any other rate needs a larger k·lift + F0 for the same jump speed
    th = np.linspace(0, 2 * math.pi, 4000, endpoint=False)
    y, _, y2, _ = prog(th)
    need = -(m.mass * y2 * W * W + m.follower_load)
    for kk in (0.8 * k, 1.2 * k, 2 * k):
        F = max(float(np.max(need - kk * y)), kk * 0.0)
        if F <= m.spring_precompression_max * kk * m.lift:
            assert kk * m.lift + F >= (k * m.lift + F0) * (1 - 1e-6)
    assert all(c["ok"] for c in syn.constraints)


def test_cam_design_verified_on_mujoco(tmp_path):
    """The whole command without tuning (design-rule gains): every prediction within its tolerance on
    the multibody run, the follower never leaves the cam, the machine.toml runs."""
    res = DP.design("cam", out=tmp_path / "d", tune=False, log=lambda *a: None)
    assert res["status"] == "ok", res["failures"]
    assert all(c["ok"] for c in res["checks"])
    rows = {r["name"]: r for r in res["requirements_table"]}
    assert rows["follower on the cam (separated fraction of the last cycle)"]["achieved"] == 0.0
    assert rows["pressure angle"]["achieved"] <= 30.0
    assert rows["jump speed (predicted)"]["ok"]
    assert res["verification"]["achieved"]["follower_first_separation_s"] is None
    assert main(["run", str(tmp_path / "d" / "machine.toml"), "--backend", "reduced", "--t-end", "0.2",
                 "--no-figure", "--quiet", "--out", str(tmp_path / "r")]) == 0


def test_bad_cam_requirements_exit_2(tmp_path, capsys):
    text = (DP.__file__.rsplit("/", 1)[0] + "/../scenarios/requirements/cam.toml")
    bad = open(text).read().replace('bottom_dwell = "30 deg"', 'bottom_dwell = "40 deg"')
    p = tmp_path / "bad.toml"
    p.write_text(bad)
    assert main(["design", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "not 360°" in err and "mechanism" in err
