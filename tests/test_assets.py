"""The committed MJCF files are what the builders produce today, and every one compiles with RK4 and
MuJoCo's default constraint Jacobian (no forced dense one: tests/test_mujoco_version.py)."""
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_committed_mjcf_is_up_to_date():
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "export_mjcf.py"), "--check"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.parametrize("path", sorted((ROOT / "assets" / "mjcf").glob("*.xml")), ids=lambda p: p.name)
def test_committed_mjcf_compiles_with_mujocos_default_jacobian(path):
    m = mujoco.MjModel.from_xml_path(str(path))
    assert 'jacobian=' not in path.read_text()
    assert m.opt.jacobian == mujoco.MjModel.from_xml_string("<mujoco/>").opt.jacobian
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4


# ============================================================================ issue 35: stand-alone files
#: run by a fresh interpreter that imports MuJoCo and NumPy only: each committed file loaded as a user
#: would, its closure at qpos0 and at the keyframe, then 1 s of passive motion from the keyframe
PLAIN_MUJOCO = r'''
import json, sys
from pathlib import Path
import mujoco, numpy as np
out = {}
for path in sorted(Path(sys.argv[1]).glob("*.xml")):
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)                      # what MjModel / the viewer start from: qpos0
    mujoco.mj_forward(m, d)
    res = lambda: float(np.max(np.abs(d.efc_pos[:d.ne]))) if d.ne else 0.0
    at0 = res()
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    atkey, worst = res(), 0.0
    for _ in range(int(round(1.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
        worst = max(worst, res())
    out[path.name] = {"nkey": int(m.nkey), "key": m.key(0).name if m.nkey else None, "at_qpos0": at0,
                      "at_key": atkey, "passive_1s_max": worst, "finite": bool(np.all(np.isfinite(d.qpos))),
                      "qpos": m.key_qpos[0].tolist() if m.nkey else None,
                      "qvel": m.key_qvel[0].tolist() if m.nkey else None,
                      "input_qpos": {m.joint(j).name: int(m.jnt_qposadr[j]) for j in range(m.njnt)}}
assert "mjbench" not in sys.modules and "controllers" not in sys.modules
print(json.dumps(out))
'''


def test_committed_mjcf_stands_alone_in_plain_mujoco():
    """Issue 35: every shipped MJCF loads assembled in MuJoCo alone — at qpos0 (the viewer) and at its
    keyframe, which is the scenario's initial state — and stays closed over 1 s of passive motion
    (before: fourbar.xml and quickreturn.xml had no keyframe and started 0.2 m / 0.4 m off)."""
    import json
    import os

    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import export_mjcf
    finally:
        sys.path.pop(0)
    from mjbench import scenario as S

    env = {**os.environ, "MUJOCO_GL": "disable"}
    r = subprocess.run([sys.executable, "-c", PLAIN_MUJOCO, str(ROOT / "assets" / "mjcf")], capture_output=True,
                       text=True, timeout=300, env=env, cwd=str(ROOT / "assets"))
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert set(got) == set(export_mjcf.TARGETS)
    for fname, f in got.items():
        assert f["nkey"] == 1 and f["key"] == "initial", fname
        assert f["at_qpos0"] <= 1e-6 and f["at_key"] <= 1e-6, (fname, f)  # measured ≤ 1e-16 m
        assert f["passive_1s_max"] <= 1e-6 and f["finite"], (fname, f)  # measured ≤ 1.5e-9 m
        scenario, mode = export_mjcf.TARGETS[fname]
        mach = S.make_machine(S.load(scenario), mode)
        a = f["input_qpos"][mach.mechanism.input_joint]
        assert f["qpos"][a] == pytest.approx(mach.q0, abs=1e-12), fname  # the scenario's initial state
        assert f["qvel"][a] == pytest.approx(mach.qd0, abs=1e-12), fname


def test_every_builtin_machine_exports_assembled():
    """The exporter (mjbench/mjcf_export.py) on every built-in scenario's machine — linkages, a user's
    MJCF, the seven-body squeezer, the platforms: qpos0 and the keyframe on the written model's loop
    closure, and the keyframe at the machine's initial state."""
    from mjbench import scenario as S
    from mjbench.mjcf_export import closure_of, machine_xml

    for name in S.builtin_names():
        mach = S.make_machine(S.load(name))
        m = mujoco.MjModel.from_xml_string(machine_xml(mach))
        assert m.nkey == 1 and closure_of(m, m.qpos0) <= 1e-10 and closure_of(m, m.key_qpos[0]) <= 1e-10, name
        for j, q0 in zip(mach.mechanism.input_joints, np.atleast_1d(mach.q0)):  # (several axes: every input)
            a = int(m.joint(j).qposadr[0])
            assert m.key_qpos[0][a] == pytest.approx(q0, abs=1e-12) and m.qpos0[a] == pytest.approx(q0, abs=1e-12), \
                (name, j)
