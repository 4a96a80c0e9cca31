"""Disc cams (mechanisms/cam.py, cam_profile.py; docs/higher_pairs.md §2), against independent paths:

* the program against the motion laws' closed forms written here (3-4-5, cycloidal, seed-001 Eq 16,
  seed-003 Bernstein curves through scipy's BPoly): ≤ 1e-12 of the lift (the requirement: 1e-9);
* the profile: the cam surface the code generates, rolled back by brute force (the follower placed
  where it touches the rotated, sampled surface) gives the program's displacement for all four
  followers (translating/oscillating × roller/flat-faced) to ≤ 1e-6 of the lift (sampling);
* the classic closed forms: pressure angle of an offset translating roller follower
  tan φ = (s' − e)/(d₀ + s); pitch-curve curvature of a radial roller follower; the flat face's
  ρ = R_b + s + s''; the jump speed against a brute-force scan of the contact force;
* the multibody run below the jump speed: both backends agree (follower speed ≤ 1e-4 of its peak),
  the follower stays on the cam (metrics.json: no separation), MuJoCo's follower follows the program
  to ≤ 1e-4 of the lift, the reduced backend's to ≤ 1e-9; above it MuJoCo shows the jump, within 2 %
  of the predicted speed (measured onset 1.0009× by scripts/cam_jump_onset.py; here ±1 % brackets);
* energy: the passive cam conserves MuJoCo's energy, equal to the reduced model's;
* bad input: one line naming the parameter, exit 2, before simulating.
"""
import json
import math

import mujoco
import numpy as np
import pytest
from scipy.interpolate import BPoly

from controllers.constant import ConstantCommand
from mjbench import runner
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.cli import main
from mjbench.drives.ideal import SpeedDrive, TorqueDrive
from mjbench.errors import GeometryError, ParameterError
from mjbench.machine import Machine
from mjbench.mechanisms import from_dict
from mjbench.mechanisms.cam_profile import CamProgram, Follower, FollowerLoad, contact_force, geometry, jump_speed
from mjbench.motionlaws import BezierLaw, coefficients_three

D = math.radians
RDRD = [dict(kind="rise", angle=D(120), law="345"), dict(kind="dwell", angle=D(60)),
        dict(kind="return", angle=D(120), law="cycloidal"), dict(kind="dwell", angle=D(60))]


def _cam(**kw):
    t = dict(type="cam", follower="translating", contact="roller", base_radius="40 mm", roller_radius="10 mm",
             lift="20 mm", cam_inertia=0.01, follower_mass=0.3, spring_rate=2000.0, spring_preload=20.0,
             program=[{k: (f"{math.degrees(v)} deg" if k == "angle" else v) for k, v in s.items()} for s in RDRD])
    t.update(kw)
    return from_dict(t)


# ============================================================================ the program
def test_program_against_the_laws_closed_forms():
    """3-4-5 rise h(10x³ − 15x⁴ + 6x⁵), cycloidal return h(1 − x + sin 2πx/2π), dwells; a
    pseudo-polynomial rise with γ = (3.5, 4.2, 6) against seed 001 Eq 16; a Bezier return against
    scipy's Bernstein polynomial: displacement and its derivatives to 1e-12 of the lift (per rad^k)."""
    h = 0.02
    b = D(120)
    prog = CamProgram(RDRD, h)
    th = np.linspace(0.0, 2 * math.pi, 4001)
    y, y1, y2, y3 = prog(th)
    x = np.clip(th / b, 0, 1)
    rise = h * (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5)
    rise1 = h / b * (30 * x ** 2 - 60 * x ** 3 + 30 * x ** 4)
    rise2 = h / b ** 2 * (60 * x - 180 * x ** 2 + 120 * x ** 3)
    u = np.clip((th - D(180)) / b, 0, 1)
    ret = h * (1 - u + np.sin(2 * math.pi * u) / (2 * math.pi))
    ret1 = -h / b * (1 - np.cos(2 * math.pi * u))
    ret2 = -h / b ** 2 * 2 * math.pi * np.sin(2 * math.pi * u)
    want = np.where(th <= b, rise, np.where(th <= D(180), h, np.where(th <= D(300), ret, 0.0)))
    want1 = np.where(th <= b, rise1, np.where(th <= D(180), 0, np.where(th <= D(300), ret1, 0.0)))
    want2 = np.where(th <= b, rise2, np.where(th <= D(180), 0, np.where(th <= D(300), ret2, 0.0)))
    assert np.max(np.abs(y - want)) < 1e-12 * h
    assert np.max(np.abs(y1 - want1)) < 1e-12 * h and np.max(np.abs(y2 - want2)) < 1e-11 * h
    # seed 001 Eq 16 (three exponents) and a Bezier law through scipy
    g = (3.5, 4.2, 6.0)
    prog2 = CamProgram([dict(kind="rise", angle=D(100), law="pseudopoly", gammas=list(g)),
                        dict(kind="dwell", angle=D(80)),
                        dict(kind="return", angle=D(150), law="bezier", m=2, p=3, interior_over_Phi=[0.3, 0.5, 0.8]),
                        dict(kind="dwell", angle=D(30))], h)
    C = coefficients_three(*g)
    t1 = np.linspace(0, D(100), 501)
    want = h * (1 - sum(c * (1 - t1 / D(100)) ** e for c, e in zip(C, g)))
    assert np.max(np.abs(prog2(t1)[0] - want)) < 1e-12 * h
    lw = BezierLaw(-h, D(150), 2, 3, -h * np.array([0.3, 0.5, 0.8]))
    bp = BPoly(lw.S[:, None], [0.0, D(150)])
    t2 = np.linspace(0, D(150), 501)
    assert np.max(np.abs(prog2(D(180) + t2)[0] - (h + bp(t2)))) < 1e-12 * h


# ============================================================================ the profile, independently
def _touch_y(fol, prof_c, theta, y_guess, lift, flat):
    """The follower value at which it touches the sampled cam surface rotated by θ (bisection):
    roller — the centre's distance to the nearest surface point equals R_r; flat face — the face's
    support equals the surface's largest extent along the face normal."""
    c, s = math.cos(theta), math.sin(theta)
    P = np.stack([c * prof_c[:, 0] - s * prof_c[:, 1], s * prof_c[:, 0] + c * prof_c[:, 1]], axis=1)

    def gap(y):
        if not flat:
            C = fol.roller_centre(np.array([y]))[0][0]
            return float(np.min(np.hypot(*(P - C).T))) - fol.Rr
        nu, _, _, h, _, _ = fol.face(np.array([y]))
        return float(h[0] - np.max(P @ nu[0]))

    lo, hi = y_guess - 0.05 * lift, y_guess + 0.05 * lift
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if gap(mid) > 0 else (mid, hi)
    return 0.5 * (lo + hi)


FOLLOWERS = {
    "translating roller, offset": (dict(motion="translating", contact="roller", Rb=0.04, Rr=0.01, u=(0.0, 1.0),
                                        e=0.008), 0.02),
    "translating flat": (dict(motion="translating", contact="flat", Rb=0.05, u=(0.0, 1.0)), 0.02),
    "oscillating roller": (dict(motion="oscillating", contact="roller", Rb=0.04, Rr=0.01, A=(0.11, 0.04),
                                arm=0.09, sense=1), D(20)),
    "oscillating flat": (dict(motion="oscillating", contact="flat", Rb=0.05, A=(0.12, 0.0), face_offset=0.0,
                              sense=-1), D(12)),
}


@pytest.mark.parametrize("kind", list(FOLLOWERS))
def test_profile_rolled_back_gives_the_program(kind):
    """The generated cam surface, sampled at 40 000 points and turned to 36 cam angles: the follower
    placed where it touches it (bisection on the distance / the support, no use of the program's
    derivatives) sits at the program's displacement to ≤ 1e-6 of the lift (chord sagitta of the
    sampling; measured 1e-8 .. 2e-7)."""
    kw, lift = FOLLOWERS[kind]
    fol = Follower(**kw)
    prog = CamProgram(RDRD, lift)
    n = 40000
    g = geometry(fol, prog, 2 * math.pi * np.arange(n) / n)
    prof = g["profile"]
    err = 0.0
    for th in np.linspace(0.0, 2 * math.pi, 36, endpoint=False) + 0.01:
        y = float(prog(float(th))[0])
        yt = _touch_y(fol, prof, th, y, lift, kw["contact"] == "flat")
        err = max(err, abs(yt - y))
    assert err < 1e-6 * lift, (kind, err / lift)


def test_pressure_angle_and_curvature_closed_forms():
    """Offset translating roller: tan φ = (s' − e)/(d₀ + s) (the relative velocity of the roller
    centre on the cam is ω·(d₀ + s, s' − e)); radial roller: ρ_p = ((R_p + s)² + s'²)^{3/2} /
    ((R_p + s)² + 2s'² − s''(R_p + s)); flat face: ρ = R_b + s + s''.  To 1e-10."""
    prog = CamProgram(RDRD, 0.02)
    th = np.linspace(0, 2 * math.pi, 721)
    s, s1, s2, _ = prog(th)
    e, Rb, Rr = 0.008, 0.04, 0.01
    fol = Follower("translating", "roller", Rb, Rr, (0.0, 1.0), e)
    d0 = math.sqrt((Rb + Rr) ** 2 - e * e)
    g = geometry(fol, prog, th)
    assert np.max(np.abs(np.abs(np.tan(g["pressure_angle"])) - np.abs(s1 - e) / (d0 + s))) < 1e-10
    rad = geometry(Follower("translating", "roller", Rb, Rr, (0.0, 1.0), 0.0), prog, th)
    Rp = Rb + Rr
    rho = ((Rp + s) ** 2 + s1 ** 2) ** 1.5 / ((Rp + s) ** 2 + 2 * s1 ** 2 - s2 * (Rp + s))
    assert np.max(np.abs(rad["rho_pitch"] - rho)) < 1e-10
    flat = geometry(Follower("translating", "flat", 0.05), prog, th)
    assert np.max(np.abs(flat["rho_cam"] - (0.05 + s + s2))) < 1e-10
    assert np.max(np.abs(flat["pressure_angle"])) < 1e-12


def test_jump_speed_against_a_brute_force_scan():
    """The jump speed (per-angle root of M·y''·ω² + c·y'·ω + K = 0, minimised and refined) equals
    the lowest speed of a brute-force scan of the contact force's sign (5000 angles × bisection on ω)
    to 1e-6; a load pressing the follower on raises it, damping (which opposes the return towards the
    cam) lowers it; no spring → error."""
    prog = CamProgram(RDRD, 0.02)
    load = FollowerLoad(0.3, 2000.0, 20.0, 5.0, 2.0)
    js = jump_speed(load, prog)
    th = 2 * math.pi * np.arange(5000) / 5000
    g = {k: v for k, v in zip(("y", "y1", "y2"), prog(th)[:3])}
    g["normal_share"] = np.ones_like(th)
    lo, hi = 1.0, 500.0
    for _ in range(60):
        w = 0.5 * (lo + hi)
        lo, hi = (w, hi) if contact_force(load, g, w).min() > 0 else (lo, w)
    assert js["speed_rad_s"] == pytest.approx(lo, rel=1e-6)
    bare = jump_speed(FollowerLoad(0.3, 2000.0, 20.0), prog)["speed_rad_s"]
    assert bare < jump_speed(FollowerLoad(0.3, 2000.0, 20.0, 5.0), prog)["speed_rad_s"]  # a load pressing it on
    assert bare > jump_speed(FollowerLoad(0.3, 2000.0, 20.0, 0.0, 2.0), prog)["speed_rad_s"]  # damping
    with pytest.raises(ParameterError, match="spring_preload"):
        jump_speed(FollowerLoad(0.3, 0.0, 0.0), prog)


# ============================================================================ the shipped scenario on both backends
@pytest.fixture(scope="module")
def below():
    scn = S.load("cam-follower")
    trajs, res = runner.simulate_mode(scn, "pi", "both", t_end=1.0)
    return scn, trajs, res


def test_below_the_jump_speed_backends_agree_and_the_follower_stays(below):
    """The PI holds 25 rad/s (0.744 of the jump speed): no separation in metrics.json; the follower's
    speed on both backends agrees to ≤ 1e-4 of its peak (measured 3.5e-5); MuJoCo's follower
    displacement vs the program at MuJoCo's own cam angle ≤ 1e-4 of the lift (measured 3.1e-5), the
    reduced backend's ≤ 1e-9 (the program itself); the cam speeds agree to 1e-6 of the peak."""
    scn, trajs, res = below
    mech = S.make_mechanism(scn)
    mb, rd = res["backends"]["multibody"], res["backends"]["reduced"]
    assert mb["follower_separation_fraction"] == 0.0 and mb["follower_first_separation_s"] is None
    assert res["multibody_vs_reduced"]["max_rel_diff"] < 1e-6
    lift = mech.program.lift
    out = {}
    for b, tr in trajs.items():
        c = tr.columns
        col = lambda n: tr.data[:tr.n, c.index(n)]  # noqa: E731
        y_abs = col("joint_cam_lift_rad") + col("joint_follower_gap_rad")
        v_abs = col("joint_cam_lift_rate_rad_s") + col("joint_follower_gap_rate_rad_s")
        # the closed forms at the backend's own cam angle (3-4-5 rise, dwell, cycloidal return, dwell)
        th = np.mod(tr.q, 2 * math.pi)
        x, u = np.clip(th / D(120), 0, 1), np.clip((th - D(180)) / D(120), 0, 1)
        want = np.where(th <= D(180), lift * (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5),
                        np.where(th <= D(300), lift * (1 - u + np.sin(2 * math.pi * u) / (2 * math.pi)), 0.0))
        out[b] = (np.max(np.abs(y_abs - want)) / lift, tr.t, v_abs)
    assert out["reduced"][0] < 1e-9
    assert out["multibody"][0] < 1e-4
    t, v_mb = out["multibody"][1], out["multibody"][2]
    v_rd = np.interp(t, out["reduced"][1], out["reduced"][2])
    assert np.max(np.abs(v_mb - v_rd)) < 1e-4 * np.max(np.abs(v_rd))


def test_above_the_jump_speed_mujoco_separates_near_the_prediction():
    """At constant speeds (a stiff speed source): 1 % below the predicted jump speed the follower stays
    on the cam, 1 % above it leaves it, at the predicted cam angle (±5°); the scenario's pi-over mode
    (1.13× the jump speed) reports the separation in its metrics."""
    scn = S.load("cam-follower")
    mech = S.make_mechanism(scn)
    wj = mech.jump["speed_rad_s"]
    assert wj == pytest.approx(33.595, rel=1e-4)
    got = {}
    for r in (0.99, 1.01):
        w = r * wj
        drive = SpeedDrive(k_v=200.0, k_i=2e4)
        ctrl = ConstantCommand.from_params(ConstantCommand.Params(type="constant", speed=w), drive=drive,
                                           mechanism=mech)
        tr = simulate(Machine(mech, drive, ctrl, 0.0, w, 0.0), "multibody", 0.45, record_dt=1e-4,
                      options={"timestep": 1e-4, "record_joints": True})
        got[r] = mech.metrics(tr, None, None)
    assert got[0.99]["follower_first_separation_s"] is None
    assert got[1.01]["follower_first_separation_s"] is not None
    assert abs(got[1.01]["follower_first_separation_cam_angle_deg"] - mech.jump["theta_deg"]) < 5.0
    trajs, res = runner.simulate_mode(scn, "pi-over", "both", t_end=1.0)
    mb = res["backends"]["multibody"]
    assert mb["follower_separation_fraction"] > 0.05 and mb["follower_first_separation_s"] > 0.0
    assert res["backends"]["reduced"]["follower_separation_fraction"] == 0.0
    assert res["plausibility"].get("expected") and "left the cam" in res["plausibility"]["note"]


def test_passive_energy_on_both_models():
    """No drive torque, no damping or load, the cam started at 20 rad/s: MuJoCo's energy (kinetic +
    the spring tendon) is conserved to 1e-6 of the kinetic energy and equals the reduced model's
    ½(J_eq + J)θ̇² + E_p to 1e-5 (the cam-lift device rides with the cam: in contact the two bodies
    move the follower's M; MuJoCo's spring energy counts ½k·y₀² more at the base position); the reduced
    backend's energy drifts ≤ 1e-8."""
    mech = S.make_mechanism(S.load("cam-follower"))
    Ja = 0.05
    m = mech.build_spec(armature=Ja, options={"timestep": 1e-4}).compile()
    d = mujoco.MjData(m)
    d.qpos[:] = mech.initial_qpos(m, 0.3)
    d.qvel[:] = mech.initial_qvel(m, 0.3, 20.0)
    mech.model_at_pose(m, d)
    mujoco.mj_forward(m, d)
    E0 = float(d.energy.sum())
    off = 0.5 * (Ja + mech.reduced(0.3)[0]) * 400.0 + mech.potential_energy(0.3) - E0  # ½k·y₀² (E_p's zero)
    assert abs(off + 0.5 * 2.0 * 0.25 ** 2) < 1e-5  # (and the start's settled penetration, 2.4e-6 J)
    drift = mism = 0.0
    kmax = float(d.energy[1])
    for i in range(4000):
        mech.multibody_load(m, d, d.time)
        mujoco.mj_step(m, d)
        if i % 100 == 0:
            mujoco.mj_forward(m, d)
            E = float(d.energy.sum())
            drift, kmax = max(drift, abs(E - E0)), max(kmax, float(d.energy[1]))
            q, qd = float(d.qpos[0]), float(d.qvel[0])
            mism = max(mism, abs(0.5 * (Ja + mech.reduced(q)[0]) * qd * qd + mech.potential_energy(q) - E - off))
    assert drift < 1e-6 * kmax and mism < 1e-5 * kmax, (drift / kmax, mism / kmax)
    drive = TorqueDrive(J=Ja)
    ctrl = ConstantCommand.from_params(ConstantCommand.Params(type="constant", torque=0.0), drive=drive,
                                       mechanism=mech)
    tr = simulate(Machine(mech, drive, ctrl, 0.3, 20.0, 0.0), "reduced", 0.4, record_dt=1e-3)
    E = 0.5 * (Ja + mech.reduced(tr.q)[0]) * tr.qd ** 2 + mech.potential_energy(tr.q)
    assert np.ptp(E) < 1e-8 * E.max()


# ============================================================================ bad input and analyze
STEEP = [{"kind": "rise", "angle": "45 deg", "law": "cycloidal"}, {"kind": "dwell", "angle": "135 deg"},
         {"kind": "return", "angle": "120 deg", "law": "cycloidal"}, {"kind": "dwell", "angle": "60 deg"}]


@pytest.mark.parametrize("change,match", [
    ({"base_radius": "20 mm", "roller_radius": "15 mm", "lift": "30 mm", "program": STEEP}, "base_radius: the cam is undercut"),
    ({"base_radius": "20 mm", "roller_radius": "15 mm", "lift": "30 mm", "max_pressure_angle": "45 deg",
      "program": [dict(STEEP[0], angle="60 deg"), dict(STEEP[1], angle="120 deg")] + STEEP[2:]}, "max_pressure_angle"),
    ({"spring_preload": 0.0, "follower_load": -5.0}, "follower_load"),
    ({"spring_preload": -1.0}, "spring_preload"),
    ({"program": [{"kind": "rise", "angle": "120 deg", "law": "345"}, {"kind": "return", "angle": "120 deg",
                                                                       "law": "cycloidal"}]}, "360"),
    ({"program": [{"kind": "rise", "angle": "180 deg", "law": "pseudopoly", "gammas": [3, 4]},
                  {"kind": "return", "angle": "180 deg", "law": "cycloidal"}]}, "zero speed and acceleration"),
    ({"contact": "flat", "roller_radius": 0.0, "base_radius": "8 mm"}, "convex"),
    ({"lift": "20 deg"}, "lift"),
])
def test_bad_cams_are_refused_naming_the_parameter(change, match):
    with pytest.raises((ParameterError, GeometryError, Exception), match=match):
        _cam(**change)


def test_bad_cam_on_the_cli_is_one_line_exit_2(tmp_path, capsys):
    assert main(["run", "cam-follower", "--set", 'mechanism.max_pressure_angle="30 deg"', "--t-end", "0.01",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "max_pressure_angle" in err[0] and "33.17°" in err[0] and not (tmp_path / "o").exists()


def test_analyze_writes_the_jump_speed_and_the_cam_figures(tmp_path):
    out = tmp_path / "an"
    assert main(["analyze", "cam-follower", "--points", "360", "--out", str(out)]) == 0
    js = json.loads((out / "analysis.json").read_text())
    assert js["jump_speed_rad_s"] == pytest.approx(33.595, rel=1e-4)
    cam = js["cam"]
    assert cam["checks"]["max_pressure_angle_deg"] == pytest.approx(33.17, abs=0.01)
    rows = {r["cam_speed_rad_s"]: r for r in cam["speeds"]}
    assert not rows[25.0]["follower_leaves_cam"] and rows[38.0]["follower_leaves_cam"]
    assert any(f["kind"] == "jump" for f in js["flags"])
    for f in ("cam_svaj.png", "cam_pressure_curvature.png", "cam_contact_force.png", "cam_profile.png"):
        assert (out / f).stat().st_size > 20_000, f
