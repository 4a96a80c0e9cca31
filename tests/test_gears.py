"""Gear pairs, belts, racks and planetary stages in the generic linkage (linkage/gears.py;
docs/higher_pairs.md §1), against independent paths:

* ratios from tooth counts, on the reduced model, to 1e-12: external −N1/N2, internal +N1/N2, belt
  +d1/d2 (crossed −), chain from teeth and pitch, rack ±r (the side of the pitch line);
* Willis' formula by hand for the shipped planetary stage: ω_s = (1 + N_r/N_s)·ω_a with the ring
  fixed, the planets' spin −N_s/N_p relative to the arm, the train's 12:1 = the scenario's drive z;
* MuJoCo: the same ratios from MuJoCo's joint rates, within the tendon equalities' compliance (the
  slip at the pitch point, ``closure_error_m``, measured ≤ 2e-9 m; ratio error ≤ 1e-6); the
  gear-train scenario's backends agree to ≤ 1e-5 of the peak speed (measured 2.4e-7);
* energy: the passive train conserves MuJoCo's energy and it equals the reduced model's;
* a non-integer ratio (24/36) turns the wheel 2/3 of a turn per input turn and stays periodic;
* bad input: tooth counts that do not mesh, a rack off its pinion, a gear not on its carrier — one
  line naming the element, exit 2.
"""
import copy
import math
import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjbench import runner
from mjbench import scenario as S
from mjbench.cli import main
from mjbench.errors import GeometryError
from mjbench.mechanisms import from_dict

SCN = Path(S.__file__).parent / "scenarios" / "gear-train.toml"


def _pair(kind="external", teeth=(20, 40), carrier_dist=0.06, **kw):
    g = {"name": "pair", "type": kind, "gears": ["g1", "g2"], **kw}
    if teeth is not None:
        g["teeth"] = list(teeth)
    return from_dict({"type": "linkage", "name": "pair", "input": "A", "gravity": [0.0, 0.0],
                      "ground": {"A": [0.0, 0.0], "B": [carrier_dist, 0.0]},
                      "links": {"g1": {"mass": 0.5, "inertia": 1e-3, "points": {"O": [0.0, 0.0]}},
                                "g2": {"mass": 1.0, "inertia": 4e-3, "points": {"O": [0.0, 0.0]}}},
                      "joints": [{"name": "A", "at": ["ground.A", "g1.O"]}, {"name": "B", "at": ["ground.B", "g2.O"]}],
                      "gears": [g]})


def _ratio(mech, a, b, q=np.linspace(0.0, 2 * math.pi, 13)):
    c = mech.c
    _, v, _ = c.exact(q)
    return v[:, 3 * c.index[a] + 2] / v[:, 3 * c.index[b] + 2]


@pytest.mark.parametrize("kind,kw,want", [
    ("external", dict(teeth=(20, 40), module="2 mm"), -0.5),
    ("external", dict(teeth=(17, 43)), -17 / 43),
    ("internal", dict(teeth=(20, 50), module="2 mm", carrier_dist=0.03), 0.4),
    ("belt", dict(teeth=None, diameters=["50 mm", "125 mm"], carrier_dist=0.3), 0.4),
    ("belt", dict(teeth=None, diameters=["50 mm", "125 mm"], crossed=True, carrier_dist=0.3), -0.4),
    ("chain", dict(teeth=(15, 45), pitch="12.7 mm", carrier_dist=0.4),
     math.sin(math.pi / 45) / math.sin(math.pi / 15)),
])
def test_ratio_from_tooth_counts_on_the_reduced_model(kind, kw, want):
    """θ̇₂/θ̇₁ from the solver's velocity coefficients equals the tooth (pitch-radius) ratio to 1e-12,
    J = I₁ + I₂·ratio² (the gears' masses on their axes)."""
    mech = _pair(kind, **kw)
    r = _ratio(mech, "g2", "g1")
    assert np.max(np.abs(r - want)) < 1e-12
    J = mech.reduced(np.linspace(0, 6, 7))[0]
    assert np.max(np.abs(J - (1e-3 + 4e-3 * want * want))) < 1e-15


def _rack(side):
    """A slider-crank (crank 25 mm, rod 120 mm) whose slider is a rack meshing with a 30-tooth m = 1 mm
    pinion whose centre is 15 mm above (side +1) or below (−1) the rack's pitch line."""
    return from_dict({"type": "linkage", "name": "rack", "input": "C", "gravity": [0.0, 0.0],
                      "ground": {"C": [0.0, 0.0], "G": [0.1, 0.0], "E": [0.18, side * 0.015]},
                      "links": {"crank": {"mass": 0.5, "inertia": 1e-3, "points": {"C": [0.0, 0.0], "B": [0.025, 0.0]}},
                                "rod": {"mass": 0.2, "com": [0.06, 0.0], "inertia": 2e-4,
                                        "points": {"B": [0.0, 0.0], "P": [0.12, 0.0]}},
                                "rack": {"mass": 0.5, "inertia": 0.0, "points": {"P": [0.0, 0.0]}},
                                "pinion": {"mass": 0.2, "inertia": 1e-4, "points": {"E": [0.0, 0.0]}}},
                      "joints": [{"name": "C", "at": ["ground.C", "crank.C"]}, {"name": "B", "at": ["crank.B", "rod.B"]},
                                 {"name": "R", "at": ["rod.P", "rack.P"]},
                                 {"name": "slide", "type": "prismatic", "at": ["ground.G", "rack.P"], "axis": [1.0, 0.0]},
                                 {"name": "E", "at": ["ground.E", "pinion.E"]}],
                      "gears": [{"type": "rack", "gears": ["pinion", "rack"], "teeth": [30], "module": "1 mm"}]})


def test_rack_and_pinion_both_sides():
    """A rack driven to and fro by a crank and rod turns its pinion by ṡ/r, r = m·N/2 = 15 mm, the
    sense from the side: a pinion above the rack turns counter-clockwise as the rack moves forwards
    (its lowest point moves with the rack), below it clockwise; to 1e-12 over the turn.  A rack on a
    full-turn pinion input does not repeat every turn: refused, saying so."""
    q = np.linspace(0.1, 6.2, 25)
    for side in (1.0, -1.0):
        mech = _rack(side)
        c = mech.c
        z, v, _ = c.exact(q)
        ds = c.joint_rates(z, v)[:, 3]
        wp = v[:, 3 * c.index["pinion"] + 2]
        assert np.max(np.abs(wp * 0.015 * side - ds)) < 1e-12, side
    with pytest.raises(GeometryError, match="rack"):
        from_dict({"type": "linkage", "name": "rack", "input": "A", "gravity": [0.0, 0.0],
                   "ground": {"A": [0.0, 0.0], "G": [0.0, -0.015]},
                   "links": {"pinion": {"mass": 0.2, "inertia": 1e-4, "points": {"O": [0.0, 0.0]}},
                             "rack": {"mass": 0.5, "inertia": 0.0, "points": {"P": [0.0, 0.0]}}},
                   "joints": [{"name": "A", "at": ["ground.A", "pinion.O"]},
                              {"name": "slide", "type": "prismatic", "at": ["ground.G", "rack.P"], "axis": [1.0, 0.0]}],
                   "gears": [{"type": "rack", "gears": ["pinion", "rack"], "teeth": [30], "module": "1 mm"}]})


def test_willis_formula_and_the_train_of_the_shipped_gear_train():
    """Planetary stage (sun 24, planets 24, ring 72 fixed, arm the carrier) by hand: Willis
    (ω_s − ω_a)/(ω_r − ω_a) = −N_r/N_s with ω_r = 0 gives ω_s = 4·ω_a; each planet spins
    −N_s/N_p = −1 relative to the arm; the spur pair 20/60: ω_crank = −ω_a/3; so ω_s/ω_crank = −12,
    the scenario's drive z (12, a positive ratio of speeds); the output pinion ṡ/r of the rack.
    All to 1e-12 over a turn (the stage's three planets make two rows redundant: least squares)."""
    scn = S.load("gear-train")
    mech = S.make_mechanism(scn)
    raw = tomllib.loads(SCN.read_text())["mechanism"]
    teeth = {g["name"]: g["teeth"] for g in raw["gears"]}
    Ns, Np = teeth["sun-planet1"]
    Nr = teeth["planet1-ring"][1]
    n1, n2 = teeth["spur"]
    q = np.linspace(0.0, 2 * math.pi, 25)
    c = mech.c
    z, v, _ = c.exact(q)
    w = {ln: v[:, 3 * c.index[ln] + 2] for ln in c.links}
    willis = (w["sun"] - w["arm"]) / (0.0 - w["arm"])
    assert np.max(np.abs(willis - (-Nr / Ns))) < 1e-12
    assert np.max(np.abs(w["sun"] / w["arm"] - (1 + Nr / Ns))) < 1e-12
    for k in (1, 2, 3):
        assert np.max(np.abs((w[f"planet{k}"] - w["arm"]) / (w["sun"] - w["arm"]) + Ns / Np)) < 1e-12
    assert np.max(np.abs(w["arm"] / w["crank"] + n2 / n1)) < 1e-12
    total = (1 + Nr / Ns) * n2 / n1
    assert np.max(np.abs(w["sun"] / w["crank"] + total)) < 1e-12
    assert S.make_drive(scn).z == total == 12.0
    slide = c.joint_rates(z, v)[:, [j.name for j in scn.mechanism.joints].index("guide")]
    assert np.max(np.abs(w["pinion"] * 0.015 - slide)) < 1e-12  # the pinion above the rack: ṡ = +r·ω


@pytest.fixture(scope="module")
def run():
    scn = S.load("gear-train", ["simulation.record_joints=true"])
    trajs, res = runner.simulate_mode(scn, "pi", "both", t_end=0.5)
    return scn, trajs, res


def test_backends_agree_and_mujoco_keeps_the_ratios(run):
    """Multibody vs reduced crank speed ≤ 1e-5 of the peak (measured 2.4e-7 over 2 s); MuJoCo's joint
    rates keep the train's ratios: sun/crank = −12 to 1e-6 of the sun's peak speed; the gears' slip at
    their pitch points (the tendon equalities' residual, ``closure_error_m``) ≤ 1e-8 m; the reduced
    backend's joint columns give the ratios exactly (1e-9 of the peak)."""
    scn, trajs, res = run
    assert res["multibody_vs_reduced"]["max_rel_diff"] < 1e-5
    mb = trajs["multibody"]
    assert res["backends"]["multibody"]["max_closure_error_m"] < 1e-8
    for b, tr in trajs.items():
        col = lambda n: tr.data[:tr.n, tr.columns.index(n)]  # noqa: E731
        sun, crank = col("joint_S_rate_rad_s"), col("joint_C_rate_rad_s")
        peak = np.max(np.abs(sun))
        err = np.max(np.abs(sun + 12.0 * crank)) / peak
        assert err < (1e-6 if b == "multibody" else 1e-9), (b, err)
    del mb


def test_passive_energy_of_the_train():
    """No drive torque, no loads or damping, gravity on: MuJoCo's energy is conserved (≤ 1e-6 of the
    kinetic energy over 0.4 s from 6 rad/s at the crank) and equals ½(J_eq + J)q̇² + E_p of the reduced
    model (≤ 1e-5; gravity's zero levels are the same, y = 0)."""
    raw = tomllib.loads(SCN.read_text())["mechanism"]
    raw = copy.deepcopy(raw)
    raw["loads"] = []
    for j in raw["joints"]:
        j.pop("damping", None)
    mech = from_dict(raw)
    Ja = 0.02
    m = mech.build_spec(armature=Ja, options={"timestep": 1e-4}).compile()
    d = mujoco.MjData(m)
    q0, qd0 = 0.5, 6.0
    d.qpos[:] = mech.initial_qpos(m, q0)
    d.qvel[:] = mech.initial_qvel(m, q0, qd0)
    mujoco.mj_forward(m, d)
    E0 = float(d.energy.sum())
    assert E0 == pytest.approx(0.5 * (Ja + mech.reduced(q0)[0]) * qd0 ** 2 + mech.potential_energy(q0), rel=1e-9)
    ja = m.joint("C")
    drift = mism = 0.0
    kmax = float(d.energy[1])
    for i in range(4000):
        mujoco.mj_step(m, d)
        if i % 100 == 0:
            mujoco.mj_forward(m, d)
            E = float(d.energy.sum())
            drift, kmax = max(drift, abs(E - E0)), max(kmax, float(d.energy[1]))
            q, qd = float(d.qpos[ja.qposadr[0]]), float(d.qvel[ja.dofadr[0]])
            mism = max(mism, abs(0.5 * (Ja + mech.reduced(q)[0]) * qd * qd + mech.potential_energy(q) - E))
    assert drift < 1e-6 * kmax and mism < 1e-5 * kmax, (drift / kmax, mism / kmax)


def test_non_integer_ratio_stays_periodic_on_both_backends():
    """24/36: the wheel turns −2/3 of a turn per input turn (its angle's winding is fractional, the
    reduced model still periodic: both gears symmetric); a short run agrees on both backends."""
    from controllers.constant import ConstantCommand
    from mjbench.backends import simulate
    from mjbench.drives.ideal import TorqueDrive
    from mjbench.machine import Machine

    mech = _pair("external", teeth=(24, 36), module="2 mm")
    assert mech.c.w[mech.c.index["g2"]] == pytest.approx(-24 / 36, abs=1e-12)
    J = mech.reduced(np.linspace(0, 2 * math.pi, 50))[0]
    assert np.ptp(J) < 1e-15
    drive = TorqueDrive(J=0.0)
    trs = {b: simulate(Machine(mech, drive, ConstantCommand.from_params(
        ConstantCommand.Params(type="constant", torque=0.05), drive=drive, mechanism=mech), 0.0, 0.0, 0.0), b, 0.3,
        record_dt=1e-3) for b in ("reduced", "multibody")}
    assert np.max(np.abs(trs["reduced"].qd - trs["multibody"].qd)) < 1e-6 * np.max(trs["reduced"].qd)


# ============================================================================ bad input
def _gear_train_with(tmp_path, edit):
    raw = tomllib.loads(SCN.read_text())
    edit(raw["mechanism"])
    import json

    path = tmp_path / "bad.toml"
    lines = []

    def dump(d, prefix=""):
        simple = {k: v for k, v in d.items() if not isinstance(v, (dict, list)) or
                  (isinstance(v, list) and not (v and isinstance(v[0], dict)))}
        if prefix:
            lines.append(f"[{prefix}]")
        for k, v in simple.items():
            lines.append(f"{json.dumps(k)} = {json.dumps(v)}")
        for k, v in d.items():
            if isinstance(v, dict):
                dump(v, f"{prefix}.{json.dumps(k)}" if prefix else json.dumps(k))
            elif isinstance(v, list) and v and isinstance(v[0], dict):
                for item in v:
                    lines.append(f"[[{prefix}.{k}]]" if prefix else f"[[{k}]]")
                    for kk, vv in item.items():
                        lines.append(f"{json.dumps(kk)} = {json.dumps(vv)}")
    dump(raw)
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("edit,match", [
    (lambda m: m["gears"][6].update(module="1.4 mm"), "do not mesh at their centres"),
    (lambda m: m["gears"][3].update(teeth=[24, 20]), "do not mesh"),
    (lambda m: m["ground"].update(E=[0.18, 0.02]), "do not mesh"),
    (lambda m: m["gears"][0].update(carrier="crank"), "does not turn about a pivot of its carrier"),
    (lambda m: m["gears"][0].update(gears=["sun", "wheel"]), "link 'wheel' is not defined"),
])
def test_bad_gears_are_one_line_exit_2(tmp_path, capsys, edit, match):
    path = _gear_train_with(tmp_path, edit)
    assert main(["run", str(path), "--t-end", "0.01", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and match in err[0] and "gears" in err[0], err
    assert not (tmp_path / "o").exists()


def test_geometry_error_names_the_rack():
    """A rack whose pitch line misses the pinion's pitch circle by 5 mm."""
    import mjbench.mechanisms.linkage.model as LM

    good = _rack(1.0).params.model_dump()
    good["ground"]["E"] = [0.18, 0.02]
    with pytest.raises(GeometryError, match="rack's pitch line .* 20 mm from the pinion's centre"):
        from_dict(good)
    del LM
