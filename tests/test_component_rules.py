"""The rules a component author must know, made impossible to break or checked (issue 27 item 4).

* a value a controller derives from its parameters is computed per run (``parameters(T, z)``):
  one controller object shared by a batch of machines with different gear ratios gives each run
  its own value (the batch equals the single runs with fresh objects), and the object's own state
  is untouched by the batch;
* the controller learns its sample period T (the co-step h when ``period`` = 0);
* angular-velocity fields take "Hz" as cycles per second (1 Hz = 2π rad/s), rpm and deg/s as
  angles per time; a frequency field takes rad/s and rpm as angles (2π rad/s = 1 Hz);
* the MJCF plane convention is declared once (``mechanisms/base.py``) and every built-in model
  follows it (hinge axes, plane positions);
* the registries: a second class under a taken name is refused; a plugin that cannot be loaded
  is named in the error and skipped (with a warning) in listings.

Independent checks: closed forms (the recorded voltage of the first sample, 2π factors), MuJoCo's
own joint axes and site positions.
"""
import math
from collections import namedtuple
from typing import Literal

import numpy as np
import pytest
from pydantic import Field

import controllers
from controllers.base import Controller
from mjbench import scenario as S
from mjbench import units as U
from mjbench.backends import simulate, simulate_many
from mjbench.compiled import law
from mjbench.errors import ScenarioError
from mjbench.fields import Q, Strict
from mjbench.mechanisms.base import HINGE_AXIS, mj_to_plane, plane_to_mj

# ----------------------------------------------------------------------------- a per-run derived value
DerivedP = namedtuple("DerivedP", "g T")


@law
def derived_law(t, q, qd, qdd, I, phi_r, om_r, acc_r, P, S):
    """u = g·(n + 1), n the number of samples so far (S[0]): g is derived per run, n is per-run state."""
    S[0] = S[0] + 1.0
    return P.g * S[0]


class DerivedParams(Strict):
    type: Literal["test-derived"] = "test-derived"
    k: Q("gain_v_per_rad_s") = Field(description="gain")
    period: Q("time", ge=0.0) = 0.0


@controllers.register
class Derived(Controller):
    """u_n = k·z·(n + 1) (g = k·z derived from the parameters and the machine's gear ratio)."""

    type_name = "test-derived"
    Params = DerivedParams
    STATE = ("n",)
    law = derived_law

    def __init__(self, k, period=0.0):
        self.k, self.period = float(k), float(period)
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        return cls(p.k, p.period)

    def parameters(self, T, z):
        return DerivedP(self.k * z, T)


def _machine(z, ctrl=None, dt=1e-4):
    scn = S.load("incerti2012", [f"drive.z={z}", f"simulation.dt={dt}", "drive.v_max=1e6"])
    m = S.make_machine(scn, "open")
    m.controller = ctrl if ctrl is not None else Derived(0.01)
    return m


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_a_batch_cannot_share_a_value_derived_from_parameters(backend):
    zs = (5.0, 10.0, 20.0)
    shared = Derived(0.01)  # ONE object in every machine of the batch
    batch = simulate_many([_machine(z, shared) for z in zs], backend, 0.01, record_dt=1e-4)
    for i, z in enumerate(zs):
        single = simulate(_machine(z), backend, 0.01, record_dt=1e-4, loop=batch.meta.get("loop"))
        np.testing.assert_array_equal(batch.trajectory(i).data, single.data)
        V = batch.trajectory(i).voltage
        assert V[0] == pytest.approx(0.01 * z) and V[9] == pytest.approx(0.01 * z * 10)  # g = k·z of this run
    assert shared.state() == {"n": 0.0}  # the object's own (Python-call) state: untouched by the runs


@pytest.mark.parametrize("dt,period,T", [(1e-4, 0.0, 1e-4), (2e-4, 0.0, 2e-4), (1e-4, 1e-3, 1e-3)])
def test_the_controller_learns_its_sample_period(dt, period, T):
    ctrl = Derived(1.0, period)
    m = _machine(1.0, ctrl, dt)
    from mjbench.control import controller_form
    from mjbench.kernel import control_every

    every = control_every(ctrl, dt)
    assert controller_form(ctrl, dt, every, m).P.T == pytest.approx(T, rel=1e-12)


# ----------------------------------------------------------------------------- units
@pytest.mark.parametrize("text,kind,si", [
    ("1 Hz", "angular_velocity", 2 * math.pi), ("60 rpm", "angular_velocity", 2 * math.pi),
    ("360 deg/s", "angular_velocity", 2 * math.pi), ("1 revolution/s", "angular_velocity", 2 * math.pi),
    ("2 rad/s", "angular_velocity", 2.0), ("2 1/s", "angular_velocity", 2.0),
    ("1 kHz", "angular_velocity", 2000 * math.pi), ("1 Hz/s", "angular_acceleration", 2 * math.pi),
    ("1 V/Hz", "gain_v_per_rad_s", 1 / (2 * math.pi)), ("60 V/krpm", "gain_v_per_rad_s", 60 / (2000 * math.pi / 60)),
    ("20 kHz", "frequency", 2e4), ("2 rad/s", "frequency", 1 / math.pi), ("120 rpm", "frequency", 2.0),
    ("10 Hz", "gain_per_s", 10.0)])
def test_cycles_and_angles_convert_as_they_read(text, kind, si):
    assert U.to_si(text, kind) == pytest.approx(si, rel=1e-12)


def test_hz_in_a_scenario_is_cycles_per_second():
    scn = S.load("incerti2012", ['modes.pid.omega0="5 Hz"', 'initial.qd0="30 rpm"',
                                 'drive.sensor.speed="observer"', 'drive.sensor.bandwidth="628.3185307179587 rad/s"'])
    assert scn.modes["pid"].omega0 == pytest.approx(10 * math.pi)
    assert scn.initial.qd0 == pytest.approx(math.pi)
    assert scn.drive.sensor.bandwidth == pytest.approx(100.0)
    with pytest.raises(ScenarioError, match="wrong dimension"):
        S.load("incerti2012", ['initial.q0="1 Hz"'])


# ----------------------------------------------------------------------------- the plane convention
SIDE_VIEW = ["incerti2012", "yigit2023", "press-slidercrank", "sixbar-watt2", "toggle-press", "mjcf-fourbar"]


@pytest.mark.parametrize("name", SIDE_VIEW)
def test_every_model_follows_the_plane_convention(name):
    import mujoco

    mech = S.make_mechanism(S.load(name))
    model = mech.build_spec().compile()
    data = mujoco.MjData(model)
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert hinges and all(tuple(model.jnt_axis[j]) == HINGE_AXIS for j in hinges)
    q = 0.7
    data.qpos[:] = mech.initial_qpos(model, q)
    mujoco.mj_kinematics(model, data)
    tp = mech.trace_point(q)
    sites = [mj_to_plane(data.site_xpos[s]) for s in range(model.nsite)] + \
            [mj_to_plane(data.xpos[b]) for b in range(model.nbody)]
    assert min(math.hypot(x - tp[0], y - tp[1]) for x, y in sites) < 1e-6  # the traced point is where MuJoCo has it
    assert all(abs(data.site_xpos[s][1]) < 1e-12 for s in range(model.nsite))  # the plane is MuJoCo's y = 0
    assert plane_to_mj(*tp) == [tp[0], 0.0, tp[1]]


def test_positive_angles_turn_counter_clockwise():
    """A body turned by +q about HINGE_AXIS carries (1, 0, 0) to the plane point (cos q, sin q)."""
    import mujoco

    spec = mujoco.MjSpec()
    b = spec.worldbody.add_body(name="b")
    b.add_joint(name="j", type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(HINGE_AXIS))
    b.add_site(name="s", pos=plane_to_mj(1.0, 0.0))
    b.add_geom(size=[0.1, 0, 0], mass=1.0)
    m = spec.compile()
    d = mujoco.MjData(m)
    d.qpos[0] = 0.3
    mujoco.mj_kinematics(m, d)
    np.testing.assert_allclose(mj_to_plane(d.site_xpos[0]), (math.cos(0.3), math.sin(0.3)), atol=1e-15)


# ----------------------------------------------------------------------------- registries
def test_a_taken_type_name_is_refused():
    class Other(Derived):
        pass
    Other.__qualname__ = "Other"
    with pytest.raises(TypeError, match="already"):
        controllers.register(Other)
    assert controllers.get("test-derived") is Derived


def test_a_broken_plugin_is_named(tmp_path, monkeypatch):
    info = tmp_path / "broken_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[mjbench.controllers]\nbroken = no_such_module:Broken\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ScenarioError, match="broken-plugin.*cannot be loaded.*no_such_module"):
        controllers.get("broken")
    with pytest.warns(UserWarning, match="broken"):
        assert "broken" not in controllers.names() and "pid" in controllers.names()
    with pytest.raises(ScenarioError, match="entry point mjbench.controllers broken"):
        S.load("incerti2012", ['modes.x.type="broken"'])


# ----------------------------------------------------------------------------- the documented example
def test_the_contributing_toy_controller_runs():
    """The toy PI of docs/CONTRIBUTING.md, executed as written: a scenario mode of its type runs in
    the CPython and the compiled loop with the same bits; unsaturated, its voltages are the PI's
    difference equation on the recorded speed error (u_k = K_p·e_k + T·K_i·Σ_{j≤k} e_j, the anti-windup
    term zero while the drive applies what it is told); with an amplifier current limit the integral
    is corrected by the voltage actually applied (it stays below the plain PI's); and its margins
    come from its law (no linear() written)."""
    from pathlib import Path

    from mjbench import linear as LN

    text = (Path(__file__).resolve().parents[1] / "docs" / "CONTRIBUTING.md").read_text()
    block = text.split("### A controller", 1)[1].split("```python\n", 1)[1].split("```", 1)[0]
    exec(compile(block, "docs/CONTRIBUTING.md", "exec"), {"__name__": "contributing_toy"})
    sets = ['modes.p.type="toy-pi"', "modes.p.kp_crank=20.0", "modes.p.ki_crank=200.0", 'modes.p.omega0="300 rpm"',
            "modes.p.period=1e-3"]
    scn = S.load("incerti2012", sets + ["drive.v_max=1e3"])
    runs = {loop: simulate(S.make_machine(scn, "p"), "reduced", 0.05, record_dt=1e-3, loop=loop)
            for loop in ("python", "compiled")}
    assert runs["compiled"].meta["loop"] == "compiled", runs["compiled"].meta["loop_reason"]
    np.testing.assert_array_equal(runs["python"].data, runs["compiled"].data)
    tr = runs["compiled"]
    z = float(scn.drive.z)
    e = 10 * math.pi - tr.omega
    want = 20.0 / z * e + 1e-3 * 200.0 / z * np.cumsum(e)
    np.testing.assert_allclose(tr.voltage, want, rtol=1e-9, atol=1e-9)
    # with an amplifier current limit the law reads the voltage applied over the last co-step (the
    # record's voltage_V of the row before each sample, every co-step recorded): replayed here, the
    # law's commands through the drive's own limit law give the recorded voltages exactly
    from mjbench.drive import drive_voltage

    scl = S.load("incerti2012", sets + ["drive.i_max=2", "modes.p.kaw=50"])
    mc = S.make_machine(scl, "p")
    lim = simulate(mc, "reduced", 0.1, record_dt=1e-4, loop="python")
    Pd = mc.drive.step_params(1e-4)
    integ, u_prev, limited = 0.0, 0.0, 0
    for k in range(0, lim.n, 10):
        e_k = 10 * math.pi - lim.omega[k]
        V_last = lim.voltage[k - 1] if k else 0.0
        integ += 1e-3 * (200.0 / z * e_k + 50.0 * (V_last - u_prev))
        u_prev = 20.0 / z * e_k + integ
        cmd = min(max(u_prev, -float(mc.drive.v_max)), float(mc.drive.v_max))
        assert lim.voltage[k] == drive_voltage(lim.current[k], cmd, lim.omega[k], Pd), k
        limited += lim.voltage[k] < cmd - 1e-9
    assert limited > 20 and np.max(np.abs(lim.current)) <= 2.0 + 1e-9
    m = S.make_machine(scn, "p")
    _, mg = LN.analyse(m, LN.operating_point(m, 0.0, 10 * math.pi / z), 1e-4, "reduced")
    assert mg.stable and math.isfinite(mg.phase_margin_deg) and mg.Ms >= 1.0
