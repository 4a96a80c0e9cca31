"""The committed MJCF files are what the builders produce today, and every one compiles with RK4 and
MuJoCo's default constraint Jacobian (no forced dense one: tests/test_mujoco_version.py)."""
import subprocess
import sys
from pathlib import Path

import mujoco
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
