"""The committed MJCF files are what the builders produce today, and every one compiles dense."""
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
def test_committed_mjcf_compiles_with_dense_jacobian(path):
    m = mujoco.MjModel.from_xml_path(str(path))
    assert m.opt.jacobian == mujoco.mjtJacobian.mjJAC_DENSE
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
