"""Compliant gears (backlash, mesh stiffness) on a machine with several motors (docs/linkages.md
§8.2, mjbench/drivetrain/axes.py): each such motor a coordinate of its own in both models.

Independent paths: the energy of the free machine (the 2R arm's textbook M(q) and potential, the
motors' and the meshes' energies written here); the motor alone inside the play against scipy's
``solve_ivp`` of its own ODE (the arm does not move); the rigid gear as the stiff limit; the other
backend.  CPython loops over short runs (no compilation), one compiled run each."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.errors import MjbenchError

from arm2r_model import arm_energy  # (tests/arm2r_model.py: the textbook M(q) and potential)


def _cols(tr, fmt, labels=("A", "B")):
    return np.stack([tr[fmt.format(a)] for a in labels], axis=1)


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_a_free_arm_behind_elastic_gears_keeps_its_energy(backend):
    """No electrical coupling (k_m → 0), no viscous or contact damping, no play: the arm, both motors
    and both meshes exchange energy, ½q̇ᵀ(M(q) + diag J_b)q̇ + E_p(q) + Σ ½J_mo(q̇ + δ̇)² + Σ ½kδ² stays."""
    from controllers.constant import ConstantCommand
    from mjbench.drive import DCMotorDrive
    from mjbench.drivetrain import DriveTrain
    from mjbench.drivetrain.gear import Gear
    from mjbench.machine import Machine

    arm = S.make_mechanism(S.load("arm2r", ['mechanism.reduced_model="solve"']))
    K = (300.0, 120.0)
    drives = []
    for k in K:
        d = DCMotorDrive(R=0.4, L=5e-4, k_m=0.08, J_m=1e-5, J_a=0.0, J_b=2e-4, z=10.0, lam=0.0, T_0=0.0)
        d.train = DriveTrain(gear=Gear(stiffness=k, damping=0.0))
        d.k_m = 1e-12  # no back-EMF: nothing leaves through the motors' windings
        drives.append(d)
    m = Machine(arm, drives, [ConstantCommand(0.0), ConstantCommand(0.0)], q0=(0.3, 1.0), qd0=(2.0, -1.0))
    tr = simulate(m, backend, 0.3, record_dt=1e-3, loop="python")
    q, qd = _cols(tr, "{}:crank_angle_rad"), _cols(tr, "{}:crank_speed_rad_s")
    d, dd = _cols(tr, "{}:gear_deflection_rad"), _cols(tr, "{}:gear_deflection_rate_rad_s")
    Jb, Jmo, Kv = 2e-4, 1e-5 * 100.0, np.array(K)
    E = np.array([arm_energy(q[k], qd[k], Jb) + 0.5 * Jmo * np.sum((qd[k] + dd[k]) ** 2) + 0.5 * np.sum(Kv * d[k] ** 2)
                  for k in range(tr.n)])
    ke = arm_energy(q[0], qd[0], Jb) - arm_energy(q[0], 0.0 * qd[0])
    drift = np.max(np.abs(E - E[0])) / ke
    # the reduced model solved exactly (RK4 on it: ≈ 1e-12 measured); MuJoCo's RK4 on its own model
    assert drift <= (1e-9 if backend == "reduced" else 2e-6), drift
    assert np.max(np.abs(d)) > 1e-3 and np.ptp(q[:, 1]) > 0.3  # the meshes and the arm really moved


def _play(backend):
    sets = ['drive.gear={backlash="0.5 deg"}', "mechanism.gravity=[0.0, 0.0]", "drive.T_0=0.0",
            'modes.open={type="open", voltage=2.0}', "modes.open.axes.B.voltage=0.0"]
    m = S.make_machine(S.load("arm2r", sets), "open")
    return m, simulate(m, backend, 0.025, record_dt=1e-4, loop="python")


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_inside_the_play_the_motor_turns_alone_and_the_arm_stays(backend):
    """From the middle of the play (δ = 0) at rest, gravity off, 2 V on the shoulder's motor: until δ
    reaches β/2 the arm is not touched (both joints at rest) and the motor follows its own ODE
    L·İ = V − R·I − k_m·z·ω, J_mo·ω̇ = z·(k_m·I − λ·z·ω), δ̇ = ω (solve_ivp, DOP853)."""
    from scipy.integrate import solve_ivp

    m, tr = _play(backend)
    d = m.drives[0]
    z, jmo = float(d.z), float((d.J_m + d.J_a) * d.z ** 2)
    R, L, km, lam, V = float(d.R), float(d.L), float(d.k_m), float(d.lam), 2.0

    def f(t, y):
        i, w, _ = y
        return [(V - R * i - km * z * w) / L, z * (km * i - lam * z * w) / jmo, w]

    t = tr["t_s"]
    ref = solve_ivp(f, (0.0, t[-1]), [0.0, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t).y[2]
    delta = tr["A:gear_deflection_rad"]
    free = np.cumprod(delta < 0.5 * math.radians(0.5)).astype(bool)  # until the first contact
    assert 50 < free.sum() < len(t) - 20  # the play is crossed within the run
    for a in ("A", "B"):
        assert np.max(np.abs(tr[f"{a}:crank_speed_rad_s"][free])) <= 1e-12, a
    assert np.max(np.abs(tr["B:gear_deflection_rad"][free])) <= 1e-12
    # the co-step holds the torque over 0.1 ms while the current rises (L/R = 1.25 ms): ≈ 1e-4 of the play
    err = np.max(np.abs(delta[free] - ref[free]))
    assert err <= 2e-3 * 0.5 * math.radians(0.5), err
    # after the contact the arm is driven
    assert np.max(tr["A:crank_speed_rad_s"]) > 0.01


def test_a_stiff_gear_tends_to_the_rigid_one():
    """arm2r under its PID along the path, gravity off (a start at rest with the meshes unloaded, no
    ring): the mesh stiffness at 1e6 N·m/rad on both axes (≈ 400 Hz and 1 kHz against the motors)
    moves the joint speeds by less than 1e-4 of their peak from the rigid gear's."""
    flat = ["mechanism.gravity=[0.0, 0.0]"]
    rigid = simulate(S.make_machine(S.load("arm2r", flat), "pid"), "reduced", 0.3, record_dt=1e-3, loop="python")
    stiff = simulate(S.make_machine(S.load("arm2r", flat + ["drive.gear={stiffness=1e6}"]), "pid"), "reduced", 0.3,
                     record_dt=1e-3, loop="python")
    for a in ("A", "B"):
        w = rigid[f"{a}:crank_speed_rad_s"]
        assert np.max(np.abs(stiff[f"{a}:crank_speed_rad_s"] - w)) <= 1e-4 * np.max(np.abs(w)), a
        assert np.max(np.abs(stiff[f"{a}:gear_deflection_rad"])) > 0
        # each motor's recorded speed is its own shaft's, z·(q̇ + δ̇); the axis's view names δ as one axis does
        z = stiff.axis(a).meta["z"]
        np.testing.assert_allclose(stiff[f"{a}:motor_speed_rad_s"],
                                   z * (stiff[f"{a}:crank_speed_rad_s"] + stiff[f"{a}:gear_deflection_rate_rad_s"]),
                                   rtol=1e-12, atol=1e-12)
        assert np.array_equal(stiff.axis(a)["gear_deflection_rad"], stiff[f"{a}:gear_deflection_rad"])


@pytest.mark.parametrize("name,sets,mode,tol", [
    # play without contact damping, gravity off: the motors cross the play, hit and drive the arm; each
    # impact of the stiff mesh amplifies the models' small differences (measured 7.5e-5 and 1.8e-4 after the second)
    ("arm2r", ['drive.gear={backlash="0.5 deg", damping_ratio=0.0}', "mechanism.gravity=[0.0, 0.0]",
               'modes.open={type="open", voltage=2.0}', "modes.open.axes.B.voltage=1.0"], "open", 5e-4),
    # a damped stiff mesh on both motors of the five-bar under PID along its path
    ("fivebar", ["drive.gear={stiffness=2e4}"], "pid", 1e-5),
    # three motors (the model solved at every evaluation), each behind a damped mesh (measured 1.8e-9)
    (str(Path(__file__).parent / "data" / "multi" / "arm3r.toml"), ["drive.gear={stiffness=5e4}"], "pid", 1e-6),
], ids=["arm2r-play", "fivebar-mesh", "arm3r-mesh"])
def test_both_backends_agree_with_compliant_gears(name, sets, mode, tol):
    scn = S.load(name, sets)
    m = S.make_machine(scn, mode)
    r, mb = (simulate(S.make_machine(scn, mode), b, 0.2, record_dt=1e-3, loop="python") for b in ("reduced", "multibody"))
    for a in m.axis_labels:
        w = mb[f"{a}:crank_speed_rad_s"]
        assert np.max(np.abs(r[f"{a}:crank_speed_rad_s"] - w)) <= tol * np.max(np.abs(w)), a
        dm = mb[f"{a}:gear_deflection_rad"]
        assert np.max(np.abs(r[f"{a}:gear_deflection_rad"] - dm)) <= 1e-3 * np.max(np.abs(dm)), a
    assert set(m.mechanism.describe()["drivetrain"]) == set(m.axis_labels)


def test_the_compiled_loops_run_the_gears_as_the_cpython_loop():
    """Both plants' laws (the reduced RK4 with the motors' coordinates, MuJoCo's per-step contact
    damping and Stribeck friction levels, the joint friction's speed-ratio table) compiled: the same
    bits as in CPython."""
    pytest.importorskip("numba")
    scn = S.load("arm2r", ['drive.gear={backlash="0.2 deg"}',
                           "drives.B.friction={coulomb=0.02, breakaway=0.03, stribeck_speed=10.0}",
                           "drives.B.friction.joints.B={coulomb=0.01, breakaway=0.015, stribeck_speed=1.0, viscous=0.001}"])
    for b in ("reduced", "multibody"):
        c = simulate(S.make_machine(scn, "pid"), b, 0.05, record_dt=1e-3, loop="compiled")
        p = simulate(S.make_machine(scn, "pid"), b, 0.05, record_dt=1e-3, loop="python")
        assert c.meta["loop"] == "compiled"
        np.testing.assert_array_equal(c.data, p.data)


def test_a_run_records_each_axis_gear_and_checks_the_mechanism_model(tmp_path):
    from mjbench import runner

    scn = S.load("arm2r", ['drive.gear={stiffness=1e5}', "simulation.t_end=0.1"])
    res = runner.run(scn, tmp_path, mode="pid", backend="both", progress=False)
    model = res["plausibility"]["model"]
    assert model["models_agree"] and model["M_rel_err"] < 1e-9
    assert res["plausibility"]["max_rel_diff"] < 1e-5  # (measured 1.2e-7)
    cols = (tmp_path / "trajectory_multibody.csv").read_text().splitlines()[0]
    assert "A:gear_deflection_rad" in cols and "B:gear_deflection_rate_rad_s" in cols
    man = json.loads((tmp_path / "manifest.json").read_text())
    assert "drivetrain" in json.dumps(man)


def test_a_compliant_gear_needs_the_motor_inertia():
    with pytest.raises(MjbenchError, match=r"drives.B: a compliant gear .* needs a motor inertia"):
        S.make_machine(S.load("arm2r", ['drives.B.gear={backlash="0.1 deg"}', "drives.B.J_m=0.0",
                                        "drives.B.J_a=0.0"]), "pid")


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_a_mesh_too_stiff_for_the_step_is_one_line_before_simulating(backend):
    """The elbow's mesh at 1e7 N·m/rad resonates at ≈ 5 kHz against its motor: beyond RK4's reach at
    0.1 ms (it diverged within 4 ms before this check)."""
    m = S.make_machine(S.load("arm2r", ["drives.B.gear={stiffness=1e7}"]), "pid")
    with pytest.raises(MjbenchError, match=r"drives.B: the gear's mesh .* resonates at 5\d\d\d Hz .* "
                                           r"simulation.dt <= 7.8e-05 s"):
        simulate(m, backend, 0.01, loop="python")
