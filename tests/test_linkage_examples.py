"""The shipped generic-linkage examples: multibody vs reduced, loop closure, passive energy, and
their geometry against closed forms written here (circle intersections), not the product's code.

Measured (docs/linkages.md §4): multibody vs reduced crank speed 1.9e-7 (press), 1.5e-6 (six-bar),
5.9e-7 (toggle press) of the peak over 4/3/4 s PI runs.
"""
import copy
import math

import mujoco
import numpy as np
import pytest

from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.backends import multibody, reduced

EXAMPLES = ["press-slidercrank", "sixbar-watt2", "toggle-press"]


@pytest.fixture(scope="module", params=EXAMPLES)
def example(request):
    return request.param, S.load(request.param)


def test_multibody_vs_reduced_and_closure(example):
    name, scn = example
    a = multibody.simulate(S.make_machine(scn, "pi"), 1.5, dt=1e-4, record_dt=5e-4, options=scn.multibody_options())
    b = reduced.simulate(S.make_machine(scn, "pi"), 1.5, dt=1e-4, record_dt=5e-4)
    mx, rms = M.rel_difference(b.t, b.qd, a.t, a.qd)
    assert mx < 5e-6 and rms < 1e-6, (name, mx, rms)
    assert np.max(a.closure) < 1e-7


def _passive_params(scn):
    """The example's [mechanism] without dampers and loads (springs and gravity kept)."""
    raw = copy.deepcopy(scn.raw["mechanism"])
    for j in raw["joints"]:
        j["damping"] = 0.0
    for s in raw.get("springs", []):
        s["damping"] = 0.0
    raw["loads"] = []
    from mjbench.mechanisms import linkage as LK
    return LK.Linkage(LK.LinkageParams.model_validate(raw))


def test_passive_energy_conservation_and_reduced_energy(example):
    """No drive torque, no friction, the drive's reflected inertia J_eq on the input (as in every
    run): MuJoCo's energy (gravity + tendon springs + kinetic) is conserved, and equals the reduced
    model's ½·(J_eq + J(q))·q̇² + E_p(q) at MuJoCo's state.  Measured over 0.8 s from 3 rad/s:
    drift ≤ 4.1e-8, mismatch ≤ 1.9e-6 of the largest kinetic energy (six-bar)."""
    name, scn = example
    mech = _passive_params(scn)
    Ja = float(S.make_drive(scn).J_eq)
    m = mech.build_spec(armature=Ja, options={"timestep": 1e-4}).compile()
    d = mujoco.MjData(m)
    q0, qd0 = 0.4, 3.0
    d.qpos[:] = mech.initial_qpos(m, q0)
    d.qvel[:] = mech.initial_qvel(m, q0, qd0)
    mujoco.mj_forward(m, d)
    E0 = float(d.energy.sum())
    assert E0 == pytest.approx(0.5 * (Ja + mech.reduced(q0)[0]) * qd0 ** 2 + mech.potential_energy(q0), rel=1e-9)
    ja = m.joint(mech.input_joint)
    drift, mism, kmax = 0.0, 0.0, 0.0
    for i in range(8000):
        mujoco.mj_step(m, d)
        if i % 200 == 0:
            mujoco.mj_forward(m, d)
            E = float(d.energy.sum())
            drift = max(drift, abs(E - E0))
            kmax = max(kmax, float(d.energy[1]))
            q, qd = float(d.qpos[ja.qposadr[0]]), float(d.qvel[ja.dofadr[0]])
            mism = max(mism, abs(0.5 * (Ja + mech.reduced(q)[0]) * qd * qd + mech.potential_energy(q) - E))
    assert drift < 1e-6 * kmax, (name, drift / kmax)
    assert mism < 1e-5 * kmax, (name, mism / kmax)


def _circle(c1, r1, c2, r2, k):
    """Intersections of two circles (arrays of centres), branch k = ±1 (left of c1 → c2)."""
    dx, dy = c2[0] - c1[0], c2[1] - c1[1]
    d = np.hypot(dx, dy)
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h = np.sqrt(r1 * r1 - a * a)
    return (c1[0] + a * dx / d - k * h * dy / d, c1[1] + a * dy / d + k * h * dx / d)


def test_press_geometry_stroke_and_forming_work():
    """Offset slider-crank: stroke √((l+r)²−e²) − √((l−r)²−e²); ram height closed form; forming
    work per stroke = ∫F ds of the load table."""
    scn = S.load("press-slidercrank")
    mech = S.make_mechanism(scn)
    r, l, e = 0.040, 0.200, -0.010
    q = np.linspace(0, 2 * np.pi, 721)
    y = -np.sqrt(l * l - (e - r * np.cos(q)) ** 2) + r * np.sin(q)
    assert np.max(np.abs(mech.points(q)["ram.C"][1] - y)) < 1e-10
    from mjbench.analyze import analyze

    res = analyze(scn, n=720)
    stroke = math.sqrt((l + r) ** 2 - e * e) - math.sqrt((l - r) ** 2 - e * e)
    assert res["strokes_m"]["guide"] == pytest.approx(stroke, abs=1e-9)
    # time ratio: the down stroke lasts π + 2·asin(e/(l+r))... from the dead-centre crank angles
    d1 = math.asin(-e / (l + r))
    d2 = math.asin(-e / (l - r))
    down = math.pi + d2 - d1  # crank arc from the extended to the folded dead centre... measured
    arcs = res["stroke_arcs_deg"]["guide"]
    assert arcs["decreasing"] + arcs["increasing"] == pytest.approx(360.0, abs=1e-6)
    assert math.radians(arcs["decreasing"]) == pytest.approx(down, abs=1e-3)
    # ∫F ds over the down stroke: 8 kN over [BDC, BDC + 2 mm], linear to 0 over the next 8 mm
    y_bdc = -math.sqrt((l + r) ** 2 - e * e)
    W = 8000.0 * (-0.2378 - y_bdc) + 0.5 * 8000.0 * 0.008
    qq = np.linspace(0, 2 * np.pi, 40001)
    Q = mech.external_torque(qq, 1e-12, 0.0)  # q̇ → 0: no viscous part
    assert -np.trapezoid(Q, qq) == pytest.approx(W, rel=2e-4)


def test_sixbar_geometry_against_two_fourbars():
    """Watt II = loop 1 (FourBar closed form) driving loop 2 (circle intersection)."""
    from mjbench.mechanisms.fourbar import FourBar

    mech = S.make_mechanism(S.load("sixbar-watt2"))
    q = np.linspace(0, 2 * np.pi, 361)
    fb = FourBar(a=0.05, b=0.19, c=0.13, h_x=0.18, h_y=0.0, k=1)
    _, g = fb.angles(q)
    cx, cy = -0.036235, 0.135230  # C in the bell crank's frame (the scenario file: 140 mm at 105°)
    C = (0.18 + cx * np.cos(g) - cy * np.sin(g), cx * np.sin(g) + cy * np.cos(g))
    D = _circle(C, 0.12, (0.42 + 0 * q, 0.06 + 0 * q), 0.07, 1)
    P = mech.points(q)
    assert np.max(np.hypot(P["rocker2.D"][0] - D[0], P["rocker2.D"][1] - D[1])) < 1e-9
    th = np.unwrap(np.arctan2(D[1] - 0.06, D[0] - 0.42))
    from mjbench.analyze import analyze

    res = analyze(S.load("sixbar-watt2"), n=720)
    assert res["swings_deg"]["O6"] == pytest.approx(math.degrees(np.ptp(th)), abs=0.05)  # 1° grid vs exact extremes
    mu1 = res["transmission_angles_deg"]["B (coupler1 on rocker1)"]["min"]
    assert mu1 == pytest.approx(math.degrees(np.min(fb.transmission_angle(np.linspace(0, 2 * np.pi, 720, endpoint=False)))), abs=1e-6)


def test_toggle_press_geometry_and_bottom_dead_centre():
    """Knuckle K = circle(F, 120 mm) ∩ circle(E, 264 mm); ram P = K − (0, √(w² − x_K²))."""
    mech = S.make_mechanism(S.load("toggle-press"))
    q = np.linspace(0, 2 * np.pi, 361)
    E = (0.3043 + 0.04 * np.cos(q), 0.19 + 0.04 * np.sin(q))
    K = _circle((0.0 + 0 * q, 0.30 + 0 * q), 0.12, E, 0.264, -1)
    yP = K[1] - np.sqrt(0.12 ** 2 - K[0] ** 2)
    P = mech.points(q)
    assert np.max(np.abs(P["ram.P"][1] - yP)) < 1e-10
    from mjbench.analyze import analyze

    res = analyze(S.load("toggle-press"), n=720)
    assert res["strokes_m"]["guide"] == pytest.approx(np.ptp(yP), abs=2e-5)  # 1° grid here vs exact extremes
    # the crank-rod toggle (extended) is the ram's bottom dead centre: ram speed ratio ≈ 0 there
    tg = [t["q"] for t in res["toggles"]["E"] if t["kind"] == "extended"]
    assert len(tg) == 1
    z, v, _ = mech.state(np.array(tg))
    assert abs(mech.c.joint_rates(z, v)[0, mech.c.jindex["guide"]]) < 1e-9
