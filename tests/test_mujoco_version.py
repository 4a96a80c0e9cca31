"""MuJoCo version (issue 25): the installed MuJoCo satisfies pyproject's requirement, is recorded in
manifests, and the closed chains give the same motion with the sparse or automatic constraint
Jacobian as with the dense one that every model forces (the 4.0.0 workaround, upstream issue 3767):
the test that decides whether the workaround is still needed."""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.backends.multibody import build_model, simulate
from mjbench.runner import backend_options

ROOT = Path(__file__).resolve().parents[1]


def _version(v: str) -> tuple:
    return tuple(int(x) for x in re.findall(r"\d+", v)[:3])


def test_installed_mujoco_satisfies_pyproject():
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    spec = next(d for d in deps if d.replace("_", "-").startswith(("mujoco-core", "mujoco")))
    m = re.match(r"(mujoco(?:-core)?)\s*(==|>=)\s*([\d.]+)", spec)
    assert m, spec
    have, want = _version(mujoco.__version__), _version(m.group(3))
    assert have == want if m.group(2) == "==" else have >= want, (mujoco.__version__, spec)


def test_manifest_records_the_mujoco_version():
    from mjbench.manifest import versions

    assert versions()["mujoco"] == mujoco.__version__


JAC = {"sparse": mujoco.mjtJacobian.mjJAC_SPARSE, "auto": mujoco.mjtJacobian.mjJAC_AUTO}


@pytest.mark.parametrize("name, mode, overrides", [
    ("incerti2012", "pid", []),                       # four-bar, one connect
    ("yigit2023", "smc", []),                         # quick-return, two loops, slider
    ("sixbar-watt2", None, []),                       # Watt II six-bar, two loops
    ("mjcf-fourbar", "pid", []),                      # a user's MJCF
    ("incerti2012", "pid", ['drive.gear.backlash="0.1 deg"', 'drive.friction.coulomb="0.05 N*m"',
                            'drive.friction.joints.rocker_joint.coulomb="0.01 N*m"']),  # tendon + frictionloss rows
])
def test_closed_chains_sparse_and_auto_jacobian_equal_dense(name, mode, overrides):
    scn = S.load(name, overrides)
    o = backend_options(scn, "multibody")
    runs = {}
    for jac in ("dense", "sparse", "auto"):
        mach = S.make_machine(scn, mode)
        spec, m = build_model(mach, o)
        assert m.opt.jacobian == mujoco.mjtJacobian.mjJAC_DENSE  # what the models force today
        if jac != "dense":
            m = spec.compile()
            m.opt.jacobian = JAC[jac]
        runs[jac] = (simulate(mach, 0.3, record_dt=1e-3, options=o, model=m).qd, bool(mujoco.mj_isSparse(m)))
    ref = runs["dense"][0]
    assert runs["sparse"][1] and not runs["dense"][1]
    for jac in ("sparse", "auto"):
        assert np.max(np.abs(runs[jac][0] - ref)) <= 1e-9 * np.max(np.abs(ref)), jac
