"""MuJoCo version (issue 25): the installed MuJoCo satisfies pyproject's requirement, is recorded in
manifests, and the closed chains give the same motion with MuJoCo's default constraint Jacobian
(``auto``, what every model uses) as with a forced sparse and a forced dense one.

History: on MuJoCo 4.0.0 every model forced ``jacobian="dense"`` (sparse-Cholesky bug on closed
chains, upstream issue 3767).  On 4.0.1 this test measured sparse and auto against dense at ≤ 2e-12 of
the peak crank speed (auto = dense on these nv ≤ 5 models: the same bits), so the workaround was
dropped.  Should a MuJoCo release break the sparse path on closed chains again, this test fails."""
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


JAC = {"dense": mujoco.mjtJacobian.mjJAC_DENSE, "sparse": mujoco.mjtJacobian.mjJAC_SPARSE}
DEFAULT_JACOBIAN = mujoco.MjModel.from_xml_string("<mujoco/>").opt.jacobian  # MuJoCo's default: auto


def test_mujocos_default_jacobian_is_auto():
    assert DEFAULT_JACOBIAN == mujoco.mjtJacobian.mjJAC_AUTO


@pytest.mark.parametrize("name, mode, overrides", [
    ("incerti2012", "pid", []),                       # four-bar, one connect
    ("yigit2023", "smc", []),                         # quick-return, two loops, slider
    ("sixbar-watt2", None, []),                       # Watt II six-bar, two loops
    ("toggle-press", None, []),                       # knuckle press: two loops, slider, 20 kN load
    ("mjcf-fourbar", "pid", []),                      # a user's MJCF
    ("incerti2012", "pid", ['drive.gear.backlash="0.1 deg"', 'drive.friction.coulomb="0.05 N*m"',
                            'drive.friction.joints.rocker_joint.coulomb="0.01 N*m"']),  # tendon + frictionloss rows
])
def test_closed_chains_default_jacobian_equals_sparse_and_dense(name, mode, overrides):
    """The models keep MuJoCo's default Jacobian (auto; dense at these sizes), and a 0.3 s closed-loop
    run gives the same crank speed with the Jacobian forced sparse (≤ 1e-9 of the peak; measured
    ≤ 2e-12) or dense (the same bits)."""
    scn = S.load(name, overrides)
    o = backend_options(scn, "multibody")
    runs = {}
    for jac in ("default", "dense", "sparse"):
        mach = S.make_machine(scn, mode)
        spec, m = build_model(mach, o)
        assert m.opt.jacobian == DEFAULT_JACOBIAN  # no forced Jacobian
        if jac != "default":
            m = spec.compile()
            m.opt.jacobian = JAC[jac]
        runs[jac] = (simulate(mach, 0.3, record_dt=1e-3, options=o, model=m).qd, bool(mujoco.mj_isSparse(m)))
    assert runs["sparse"][1] and not runs["dense"][1]
    ref = runs["default"][0]
    peak = np.max(np.abs(ref))
    assert peak > 0.0 and np.all(np.isfinite(ref))
    if not runs["default"][1]:  # auto chose dense at this size: the same computation, the same bits
        np.testing.assert_array_equal(runs["dense"][0], ref)
    assert np.max(np.abs(runs["dense"][0] - ref)) <= 1e-9 * peak
    assert np.max(np.abs(runs["sparse"][0] - ref)) <= 1e-9 * peak
