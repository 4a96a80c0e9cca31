"""A user's own MJCF ([mechanism] type = "mjcf"): the MuJoCo-derived reduced model against closed
forms (hinge input: the seed-000 four-bar; slide input: an elliptic trammel), against our generic
linkage on an exported MJCF with a slide, a tendon spring and damping, the labels in every output,
and bad input.

Measured: J 2.3e-10, J' 9.5e-10, E_p' 1.1e-10 relative to the seed-000 closed form.
"""
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.cli import main
from mjbench.errors import GeometryError, ParameterError

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data"


def mjcf_scenario(table, base="incerti2012"):
    raw, src = S.read_raw(base)
    raw["mechanism"] = table
    raw["aliases"] = {}
    return S.from_raw(raw, src)


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(a)))


def test_hinge_input_against_the_seed000_closed_form():
    mech = S.make_mechanism(S.load("mjcf-fourbar"))
    ref = S.make_mechanism(S.load("incerti2012"))
    q = np.linspace(0.0, 2 * np.pi, 1441)
    a, b = ref.reduced(q), mech.reduced(q)
    assert _rel(a[0], b[0]) < 2e-9
    assert _rel(a[1], b[1]) < 1e-8
    assert _rel(a[2], b[2]) < 2e-9
    assert np.max(np.abs(ref.potential_energy(q) - mech.potential_energy(q))) < 1e-9
    assert mech.reduced_source.startswith("MuJoCo-derived")
    assert mech.table_info["dJ_rel_error_estimate"] < 1e-8


def test_slide_input_against_the_trammel_closed_form():
    mech = S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": str(DATA / "trammel.xml"), "input_joint": "x",
                                           "keyframe": "up", "table_nodes": 512}))
    x = np.linspace(-0.079, 0.079, 101)
    L, mA, mB, mr, I, g = 0.1, 0.5, 0.8, 0.3, 2.5e-4, 9.81
    z = np.sqrt(L * L - x * x)
    dz = -x / z
    ddz = -L * L / z ** 3
    J = mA + mB * dz ** 2 + mr * (0.25 + 0.25 * dz ** 2) + I / z ** 2
    dJ = 2 * mB * dz * ddz + 0.5 * mr * dz * ddz - 2 * I * dz / z ** 3
    dEp = g * dz * (mB + 0.5 * mr)
    Jm, dJm, dEpm = mech.reduced(x)
    assert _rel(J, Jm) < 1e-7 and _rel(dEp, dEpm) < 1e-7
    assert _rel(dJ, dJm) < 1e-6  # 4th-order differences on the manifold + spline (512 nodes)
    with pytest.raises(GeometryError, match="outside the slide range"):
        mech.reduced(np.array([0.09]))


def test_exported_press_mjcf_against_the_generic_linkage(tmp_path):
    """assets/mjcf/press_slidercrank.xml (our builder's export: slide, tendon spring, joint
    damping, the drive's armature J_eq and damping z²λ on the input) as a user's MJCF: the
    MuJoCo-derived J − J_eq, E_p' and damping equal our linkage's own model."""
    lk = S.make_mechanism(S.load("press-slidercrank"))
    drive = S.make_drive(S.load("press-slidercrank"))
    mech = S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": str(ROOT / "assets" / "mjcf" / "press_slidercrank.xml"),
                                           "input_joint": "O"}))
    q = np.linspace(0.0, 2 * np.pi, 721)
    a, b = lk.reduced(q), mech.reduced(q)
    assert _rel(a[0] + drive.J_eq, b[0]) < 1e-8
    assert _rel(a[1], b[1]) < 2e-7
    assert _rel(a[2], b[2]) < 1e-8
    D = -mech.external_torque(q, 1.0, 0.0) - drive.crank_damping
    assert np.max(np.abs(D - lk.damping_factor(q))) < 1e-8 * np.max(lk.damping_factor(q))


def test_labels_in_every_output(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "mjcf-fourbar", "--mode", "open", "--t-end", "0.2", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "MuJoCo-derived" in text and "not an independent check" in text
    met = json.loads((out / "metrics.json").read_text())
    assert met["reduced_model"].startswith("MuJoCo-derived")
    assert "not an independent check" in met["multibody_vs_reduced"]["note"]
    assert met["multibody_vs_reduced"]["max_rel_diff"] < 1e-3
    man = json.loads((out / "manifest.json").read_text())
    assert man["reduced_model"].startswith("MuJoCo-derived")
    assert Path(man["scenario"]["mechanism"]["file"]).is_absolute()  # re-runnable from anywhere
    assert main(["analyze", "mjcf-fourbar", "--out", str(tmp_path / "a")]) == 0
    res = json.loads((tmp_path / "a" / "analysis.json").read_text())
    assert res["reduced_model"].startswith("MuJoCo-derived") and res["velocity_ratios"]
    assert "MuJoCo-derived" in capsys.readouterr().out


def test_relative_file_path_is_relative_to_the_scenario(tmp_path):
    shutil.copy(ROOT / "mjbench" / "scenarios" / "models" / "fourbar_user.xml", tmp_path / "my.xml")
    text = (ROOT / "mjbench" / "scenarios" / "mjcf-fourbar.toml").read_text().replace("models/fourbar_user.xml", "my.xml")
    (tmp_path / "s.toml").write_text(text)
    scn = S.load(str(tmp_path / "s.toml"))
    assert scn.mechanism.file == str(tmp_path / "my.xml")


def _xml(tmp_path, body, name="m.xml"):
    p = tmp_path / name
    p.write_text(body)
    return str(p)


def test_bad_input(tmp_path):
    with pytest.raises(ParameterError, match="no such file"):
        S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": str(tmp_path / "none.xml"), "input_joint": "a"}))
    with pytest.raises(ParameterError, match="input_joint = 'nope': no joint of that name"):
        S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": str(DATA / "trammel.xml"), "input_joint": "nope"}))
    src = (DATA / "trammel.xml").read_text()
    act = src.replace("</mujoco>", '<actuator><motor joint="z"/></actuator></mujoco>')
    with pytest.raises(ParameterError, match="acts on 'z'"):
        S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": _xml(tmp_path, act), "input_joint": "x"}))
    free = src.replace('<equality><connect site1="rod_end" site2="B"/></equality>', "")
    with pytest.raises(GeometryError, match="no equality constraint"):
        S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": _xml(tmp_path, free, "f.xml"), "input_joint": "x"}))
    two = src.replace('<joint name="z" type="slide" axis="0 0 1"/>',
                      '<joint name="z" type="slide" axis="0 0 1"/><joint name="zx" type="slide" axis="1 0 0"/>')
    two = two.replace('qpos="0 1.5708 0.1"', 'qpos="0 1.5708 0.1 0"')
    with pytest.raises(GeometryError, match=r"2 degrees of freedom .*joints .*can still move"):
        S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": _xml(tmp_path, two, "t.xml"), "input_joint": "x",
                                        "keyframe": "up"}))
    nolim = src.replace(' range="-0.08 0.08"', "")
    with pytest.raises(ParameterError, match="a slide input needs a range"):
        S.make_mechanism(mjcf_scenario({"type": "mjcf", "file": _xml(tmp_path, nolim, "n.xml"), "input_joint": "x",
                                        "keyframe": "up"}))
    assert math.isfinite(1.0)
