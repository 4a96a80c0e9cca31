"""One module per mechanism, proven: a driven pendulum defined in this file alone runs on both
backends, batched, in a sweep and rendered — nothing else in mjbench knows about it.

The pendulum (mass m at distance l from the pivot, inertia J_G about its centre, gravity g) has
the closed-form reduced model J = J_G + m l², J' = 0, E_p = −m g l cos q (q from the downward
vertical), which the multibody model (MuJoCo hinge) must reproduce; with the motor unpowered and
no friction it is a conservative pendulum whose period for small swings is 2π √(J_tot/(m g l)).
"""
import math
from typing import Literal

import numpy as np
import pytest
from pydantic import Field

import mjbench.mechanisms as mechanisms
from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.backends import batch, multibody, reduced
from mjbench.mechanisms.base import Mechanism, new_spec
from mjbench.schema import Q, Strict


class PendulumParams(Strict):
    type: Literal["pendulum"] = "pendulum"
    m: Q("mass", gt=0.0) = Field(description="bob mass")
    l: Q("length", gt=0.0) = Field(description="pivot to mass centre")
    J_G: Q("inertia", ge=0.0) = Field(description="inertia about the mass centre")
    g: Q("acceleration") = 9.81


@mechanisms.register
class Pendulum(Mechanism):
    type_name = "pendulum"
    Params = PendulumParams

    def __init__(self, m, l, J_G, g=9.81):
        self.m, self.l, self.J_G, self.g = m, l, J_G, g

    @classmethod
    def from_params(cls, p):
        return cls(p.m, p.l, p.J_G, p.g)

    def reduced(self, q):
        J = self.J_G + self.m * self.l ** 2
        return J + 0.0 * q, 0.0 * q, self.m * self.g * self.l * np.sin(q)

    def potential_energy(self, q):
        return -self.m * self.g * self.l * np.cos(q)

    def build_spec(self, armature=0.0, options=None):
        import mujoco

        spec = new_spec("pendulum", options, gravity=(0.0, 0.0, -self.g))
        b = spec.worldbody.add_body(name="bob", pos=[0, 0, 0])
        j = b.add_joint(name=self.input_joint, type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, -1, 0])
        j.armature = float(armature)
        b.mass = self.m
        b.ipos = [0.0, 0.0, -self.l]  # q = 0: hanging down
        b.inertia = [self.J_G + 1e-9, self.J_G + 1e-9, self.J_G + 1e-9]
        b.explicitinertial = True
        b.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, 0, 0, -self.l], size=[0.01, 0, 0],
                   contype=0, conaffinity=0, mass=0)
        return spec

    def initial_qpos(self, model, q0, x0=None):
        return np.array([q0])

    def initial_qvel(self, model, q0, qd0, x0=None, xd0=None):
        return np.array([qd0])

    def points(self, q):
        # paper plane (x, y) with y up; q from the downward vertical
        return {"O": (0.0 * q, 0.0 * q), "G": (self.l * np.sin(q), -self.l * np.cos(q))}

    def trace_point(self, q):
        return self.points(q)["G"]


RAW = {
    "scenario": {"name": "toy-pendulum", "title": "driven pendulum (test)"},
    "mechanism": {"type": "pendulum", "m": "1.2 kg", "l": "250 mm", "J_G": 2e-3},
    "drive": {"R": 2.0, "L": "5 mH", "k_m": 0.3, "J_m": "10 kg*cm^2", "z": 4.0, "lam": 1e-3, "v_max": 24.0},
    "initial": {"q0": "20 deg"},
    "simulation": {"t_end": 1.0, "dt": 1e-4, "record_dt": 1e-3, "mode": "pid"},
    "modes": {"pid": {"type": "pid", "kp": 0.5, "ki": 2.0, "kd": 0.0, "omega0": "60 rpm", "v_limit": 24.0},
              "off": {"type": "open", "voltage": 0.0}},
}


@pytest.fixture(scope="module")
def scn():
    return S.from_raw(RAW, "test")


def test_units_and_closed_form(scn):
    p = scn.mechanism
    assert (p.l, scn.drive.L, scn.drive.J_m) == pytest.approx((0.25, 5e-3, 1e-3))
    assert scn.initial.q0 == pytest.approx(math.radians(20.0))
    assert scn.modes["pid"].omega0 == pytest.approx(2 * math.pi)


def test_both_backends_agree(scn):
    a = multibody.simulate(S.make_machine(scn), 1.0, record_dt=1e-3)
    b = reduced.simulate(S.make_machine(scn), 1.0, record_dt=1e-3)
    mx, rms = M.rel_difference(b.t, b.qd, a.t, a.qd)
    assert mx < 1e-6, mx  # no constraints: the same ODE, both RK4 at 0.1 ms


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_compiled_loop_equals_cpython_loop(scn, backend):
    """The pendulum needs no law of its own: its reduced model is the default spline table
    (``Mechanism.model_form``), its MuJoCo model has no loads; on both backends the kernel's
    compiled loop gives the CPython loop's bits."""
    from mjbench.backends import simulate

    py = simulate(S.make_machine(scn), backend, 0.2, loop="python")
    cc = simulate(S.make_machine(scn), backend, 0.2, loop="compiled")
    assert py.meta["loop"] == "python" and cc.meta["loop"] == "compiled", cc.meta["loop_reason"]
    np.testing.assert_array_equal(py.data, cc.data)
    assert np.max(np.abs(cc.qd)) > 0.1


def test_passive_swing_period_and_energy(scn):
    """Motor unpowered, no friction: small swing of period 2π√(J_tot/(mgl)), energy conserved."""
    s = S.with_values(scn, {"initial.q0": 0.05, "drive.lam": 0.0, "drive.R": 1e9})  # open circuit
    mc = S.make_machine(s, "off")
    tr = reduced.simulate(mc, 3.0, record_dt=1e-4)
    mech, d = mc.mechanism, mc.drive
    J_tot = mech.reduced(0.0)[0] + d.J_eq
    T = 2 * math.pi * math.sqrt(J_tot / (mech.m * mech.g * mech.l))
    up = np.flatnonzero((tr.qd[:-1] < 0) & (tr.qd[1:] >= 0))  # speed zero crossings (q at its minimum)
    assert np.mean(np.diff(tr.t[up])) == pytest.approx(T * (1 + 0.05 ** 2 / 16), rel=1e-4)
    E = 0.5 * J_tot * tr.qd ** 2 + mech.potential_energy(tr.q)
    assert np.ptp(E) < 1e-9 * mech.m * mech.g * mech.l


def test_batched_and_swept(scn, tmp_path):
    machines = [S.make_machine(S.with_values(scn, {"modes.pid.kp": kp})) for kp in (0.3, 0.5, 0.8)]
    res = batch.simulate(machines, 0.3, record_dt=1e-3, nthread=1)
    for i, kp in enumerate((0.3, 0.5, 0.8)):
        single = multibody.simulate(S.make_machine(S.with_values(scn, {"modes.pid.kp": kp})), 0.3, record_dt=1e-3)
        np.testing.assert_array_equal(res.trajectory(i).qd, single.qd)
    # a sweep of the scenario file (the TOML a user would write)
    from mjbench.sweep import SweepSpec, read_table, run_sweep

    path = tmp_path / "toy.toml"
    path.write_text(_toml(RAW))
    out = run_sweep(SweepSpec(scenario=str(path), grid={"modes.pid.kp": [0.3, 0.8]}, t_end=0.3, backend="multibody"),
                    tmp_path / "sw", progress=False, plots=False)
    rows = read_table(out["table"])
    assert [r["status"] for r in rows] == ["ok", "ok"]
    single = M.summary(res.trajectory(2))
    assert rows[1]["peak_current_A"] == single["peak_current_A"]


def test_rendered(scn, tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    from mjbench import render

    info = render.render_scenario(scn, tmp_path / "toy.mp4", fps=10, width=160, height=90, t_end=0.5,
                                  progress=False)
    assert info["frames"] == 6 and (tmp_path / "toy.mp4").stat().st_size > 0


def _toml(raw):
    """Minimal TOML writer for the nested dict above (strings, numbers, tables)."""
    lines = []

    def val(v):
        return f'"{v}"' if isinstance(v, str) else repr(v)

    def table(prefix, d):
        scal = {k: v for k, v in d.items() if not isinstance(v, dict)}
        if prefix:
            lines.append(f"[{prefix}]")
        for k, v in scal.items():
            lines.append(f"{k} = {val(v)}")
        for k, v in d.items():
            if isinstance(v, dict):
                table(f"{prefix}.{k}" if prefix else k, v)

    table("", raw)
    return "\n".join(lines) + "\n"
