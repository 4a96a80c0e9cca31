"""The CPython twins (``Form.python``): the same bits as the laws they stand for.

The CPython loop calls a form's twin instead of its law (a function specialised to the form's
parameters); the compiled loop runs the law.  Here each twin and its law are evaluated from the same
states — random ones, every kind of load the linkage's MuJoCo law handles — and must write the same
floats; whole runs of both loops are compared by tests/test_compiled_plants.py, tests/test_digests.py."""
import copy
import math
import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjbench import compiled as C
from mjbench import scenario as S
from mjbench.backends import multibody
from mjbench.backends.multibody import build_model
from mjbench.drives.ideal import TorqueDrive
from mjbench.machine import Machine
from mjbench.mechanisms.linkage import Linkage, LinkageParams, linkage_load
from mjbench.mechanisms.linkage.multibody_loads import python_twin

DATA = Path(__file__).parent / "data"
FOURBAR = tomllib.loads((DATA / "linkages" / "incerti2012.toml").read_text())

#: every group of the load law: point loads through hinges (constant, gated table), torques on links
#: (constant gated, angle table), a damped loop-closing hinge, a spring
LOADS = {
    "point on the coupler, table, gated": {"loads": [{"point": "coupler.P", "direction": [0.3, -1.0],
                                                      "s": [-0.2, 0.0, 0.15], "F": [40.0, -10.0, 25.0],
                                                      "active": "stroke_along"}]},
    "point, constant, and torques": {"loads": [{"point": "rocker.C", "direction": [1.0, 0.0], "force": 12.5},
                                               {"link": "rocker", "torque": -4.0, "active": "stroke_against"},
                                               {"link": "coupler", "q": [0.0, 3.0, 6.0], "T": [0.0, 2.0, -1.0]}]},
    "damped closing hinge": {"damping": {"C": 0.35, "D": 0.02}},
}


def _fourbar(case):
    raw = copy.deepcopy(FOURBAR)
    spec = LOADS[case]
    raw["loads"] = spec.get("loads", [])
    for j in raw["joints"]:
        j["damping"] = spec.get("damping", {}).get(j["name"], 0.0)
    return Linkage(LinkageParams.model_validate(raw))


def _compare(mech, model, data, rng, n=200):
    form = mech.load_form(model, data)
    assert form is not None and form.python is not None
    P = C.python_view(form.P)
    twin = form.python
    for _ in range(n):
        q = float(rng.uniform(-10.0, 10.0))
        data.qpos[:] = mech.initial_qpos(model, q)
        data.qvel[:] = rng.normal(0.0, 5.0, model.nv)
        data.qfrc_applied[:] = rng.normal(0.0, 1.0, model.nv)  # the drive torque on the input is added to
        start = data.qfrc_applied.copy()
        linkage_load(0.0, P)
        law = data.qfrc_applied.copy()
        data.qfrc_applied[:] = start
        twin(0.0, P)
        assert law.tobytes() == data.qfrc_applied.tobytes(), (q, law, data.qfrc_applied)
    return form


@pytest.mark.parametrize("case", sorted(LOADS))
def test_the_load_twin_writes_the_laws_bits(case):
    mech = _fourbar(case)
    _, m = build_model(Machine(mech, TorqueDrive(), None), {"timestep": 1e-4})
    d = mujoco.MjData(m)
    form = _compare(mech, m, d, np.random.default_rng(7))
    P = form.P
    groups = (P.ga, P.gc - P.ga, P.gt - P.gc, P.ge - P.gt)  # damped closures, slide loads, chain loads, torques
    assert groups == {"point on the coupler, table, gated": (0, 0, 1, 0), "point, constant, and torques": (0, 0, 1, 2),
                      "damped closing hinge": (1, 0, 0, 0)}[case]


@pytest.mark.parametrize("name", ["press-slidercrank", "toggle-press"])
def test_the_load_twin_of_the_shipped_presses(name):
    scn = S.load(name)
    mech = S.make_mechanism(scn)
    _, m = build_model(S.make_machine(scn), scn.multibody_options())
    d = mujoco.MjData(m)
    form = _compare(mech, m, d, np.random.default_rng(11))
    assert form.P.gc - form.P.ga == 1  # the ram: a load on a slide
    # near the stroke's end, where the forming force acts
    src = form.python.source
    assert "math.floor" in src and "qfrc[" in src


def test_the_load_twin_reads_the_live_arrays():
    """The twin holds memoryviews of MuJoCo's own qpos/qvel/qfrc_applied, so a state written in place
    is what it reads (nothing is copied when it is built)."""
    mech = _fourbar("point, constant, and torques")
    _, m = build_model(Machine(mech, TorqueDrive(), None), {"timestep": 1e-4})
    d = mujoco.MjData(m)
    twin = python_twin(mech.load_form(m, d).P)
    d.qpos[:] = mech.initial_qpos(m, 1.0)
    d.qfrc_applied[:] = 0.0
    twin(0.0, None)
    first = d.qfrc_applied.copy()
    d.qpos[:] = mech.initial_qpos(m, 2.5)
    twin(0.0, None)
    assert not np.array_equal(first, d.qfrc_applied) and np.all(np.isfinite(d.qfrc_applied))


@pytest.mark.parametrize("name", ["press-slidercrank", "incerti2012", "incerti-belt"])
def test_the_mujoco_step_twin_is_the_law(name):
    """One step by the plant's twin and one by its law from the same state: the same qpos, qvel and
    the same state read back into QO."""
    scn = S.load(name)
    mach = S.make_machine(scn)
    runs = []
    for use_twin in (True, False):
        pl = multibody.MultibodyPlant(mach, scn.multibody_options(), None)
        pl.start()
        f = pl.form()
        assert f.python is not None
        P = C.python_view(f.P)
        fn = f.python if use_twin else C.Form(f.law, f.P, fn_args=f.fn_args).bound()
        tau = memoryview(np.array([0.7]))
        qo = np.zeros(4)
        out = []
        for k in range(50):
            fn(tau, k * pl.h, P, memoryview(f.state()), memoryview(qo))
            out.append(np.concatenate([pl.data.qpos, pl.data.qvel, qo]))
        runs.append(np.array(out))
        pl.finish()
    assert runs[0].tobytes() == runs[1].tobytes()
    assert math.isfinite(float(runs[0][-1, 0]))
