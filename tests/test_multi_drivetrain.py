"""Drive-train elements per axis on a machine with several motors (docs/linkages.md §8.2): each
axis's PWM bridge, encoder and current loop are its own, in the kernel's per-axis slots.

Independent paths: the encoder's closed form (each measured angle a whole number of counts
2π/(lines·edges) on the motor shaft), the other backend, and the current loop's own purpose (the
current follows its reference).  CPython loops over 0.05 s (no compilation)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.errors import MjbenchError

T_END = 0.05
SETS = ['drive.pwm={frequency="20 kHz", v_bus=24, model="switching"}',  # every axis
        'drives.A.encoder={lines=500}',  # the shoulder only
        'drives.E.current_loop={bandwidth="2 kHz"}']  # the other axis only


@pytest.fixture(scope="module")
def runs():
    scn = S.load("fivebar", SETS)
    return {b: simulate(S.make_machine(scn, "pid"), b, T_END, record_dt=1e-4, loop="python")
            for b in ("reduced", "multibody")}


def test_each_axis_records_its_own_elements(runs):
    tr = runs["reduced"]
    cols = set(tr.columns)
    for a in ("A", "E"):  # the switching bridge on both
        assert {f"{a}:voltage_bridge_V", f"{a}:current_min_A", f"{a}:current_max_A"} <= cols
    assert "A:angle_meas_rad" in cols and "E:angle_meas_rad" not in cols
    assert "E:current_ref_A" in cols and "A:current_ref_A" not in cols
    assert set(tr.meta["drivetrain"]) == {"A", "E"} and "current_loop" in tr.meta["drivetrain"]["E"]


def test_the_encoder_counts_whole_steps_on_its_own_axis(runs):
    tr = runs["reduced"]
    z = 10.0  # the five-bar's gearbox (scenario)
    counts = tr["A:angle_meas_rad"] * z / (2.0 * math.pi / (500 * 4))
    assert np.max(np.abs(counts - np.round(counts))) < 1e-6
    # and it measures that axis's angle, to one count
    err = np.abs(tr["A:angle_meas_rad"] - tr["A:crank_angle_rad"]) * z
    assert np.max(err) <= 2.0 * math.pi / 2000 * 0.5 + 1e-12


def test_the_current_loop_makes_its_axis_follow_the_reference(runs):
    tr = runs["reduced"]
    i, iref = tr["E:current_A"], tr["E:current_ref_A"]
    late = tr["t_s"] > 0.01
    assert np.max(np.abs(iref[late])) > 0.1  # it is asked for something
    assert np.sqrt(np.mean((i[late] - iref[late]) ** 2)) <= 0.1 * np.max(np.abs(iref[late]))


def test_both_backends_agree_with_the_elements_per_axis(runs):
    r, m = runs["reduced"], runs["multibody"]
    for a in ("A", "E"):
        w = r[f"{a}:crank_speed_rad_s"]
        assert np.max(np.abs(m[f"{a}:crank_speed_rad_s"] - w)) <= 1e-6 * np.max(np.abs(w))


# ---------------------------------------------------------------- the motors' Coulomb friction per axis
FC = 0.05  # [N·m] on each motor shaft
R_A, KM_A, Z_A, LAM_A = 0.4, 0.08, 50.0, 2e-5  # arm2r's [drive] (the shoulder A)


def _arm_open(frac):
    """arm2r in a horizontal plane, the shoulder's motor at frac × its breakaway voltage R·F_C/k_m, the
    elbow's at 0 V (a mode's table per axis)."""
    v = frac * FC * R_A / KM_A
    return S.load("arm2r", [f"drive.friction={{coulomb={FC}}}", "mechanism.gravity=[0.0, 0.0]",
                            f'modes.open={{type="open", voltage={v!r}}}', "modes.open.axes.B.voltage=0.0"])


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_an_axis_below_its_breakaway_voltage_sticks(backend):
    """k_m·V/R < F_C: the motor cannot break away.  MuJoCo's friction constraint holds it; the reduced
    model's regularised law −F_C·tanh(z·q̇/v_ε) lets it creep at ≈ (v_ε/z)·artanh(k_m·I/F_C)."""
    scn = _arm_open(0.8)
    m = S.make_machine(scn, "open")
    tr = simulate(m, backend, 0.3, record_dt=1e-3, loop="python")
    w = np.abs(tr["A:crank_speed_rad_s"][-1])
    if backend == "multibody":
        assert w <= 1e-4, w
    else:
        T = m.mechanism.model_form().P.T
        creep = T[0, 5] / T[0, 4] * math.atanh(KM_A * tr["A:current_A"][-1] / FC)
        assert w <= 1.05 * creep and creep < 5e-3, (w, creep)


def test_above_it_the_axis_slides_at_the_closed_form_speed_on_both_backends():
    """k_m·V/R > F_C: the shoulder slides at the steady speed where k_m·I = F_C + λ·ω_m and
    V = R·I + k_m·ω_m, ω = ω_m/z (the elbow's motor, at 0 V, holds it)."""
    scn = _arm_open(1.5)
    v = 1.5 * FC * R_A / KM_A
    want = (v - R_A * FC / KM_A) / (KM_A + R_A * LAM_A / KM_A) / Z_A
    for b in ("reduced", "multibody"):
        tr = simulate(S.make_machine(scn, "open"), b, 0.3, record_dt=1e-3, loop="python")
        assert tr["A:crank_speed_rad_s"][-1] == pytest.approx(want, rel=1e-6), b
        assert np.max(np.abs(tr["B:crank_speed_rad_s"])) < 0.05 * want, b


def test_the_fivebar_with_motor_friction_agrees_between_the_backends():
    """Under PID along the path (rest between segments: the regularised stick against MuJoCo's
    constraint, measured 1.3e-3 of the peak speed over 1 s)."""
    pytest.importorskip("numba")
    scn = S.load("fivebar", ["drive.friction={coulomb=0.02}"])
    r, m = (simulate(S.make_machine(scn, "pid"), b, 0.6, record_dt=1e-3) for b in ("reduced", "multibody"))
    assert "friction" in S.make_machine(scn, "pid").mechanism.describe()["drivetrain"]["E"]
    for a in ("A", "E"):
        w = m[f"{a}:crank_speed_rad_s"]
        assert np.max(np.abs(r[f"{a}:crank_speed_rad_s"] - w)) <= 2e-3 * np.max(np.abs(w)), a


# ---------------------------------------------------------------- a Stribeck drop per axis
FS, VS = 0.08, 20.0  # breakaway [N·m] and Stribeck speed [rad/s] on the shoulder's motor (F_C = FC)


def _stribeck(frac, gear):
    v = frac * FS * R_A / KM_A
    sets = [f"drives.A.friction={{coulomb={FC}, breakaway={FS}, stribeck_speed={VS}}}", "mechanism.gravity=[0.0, 0.0]",
            f'modes.open={{type="open", voltage={v!r}}}', "modes.open.axes.B.voltage=0.0"]
    return S.load("arm2r", sets + (["drives.A.gear={stiffness=1e5}"] if gear else [])), v


@pytest.mark.parametrize("gear", [False, True], ids=["rigid", "compliant"])
def test_a_stribeck_axis_sticks_below_its_breakaway_and_slides_at_the_closed_form_speed(gear):
    """F_C < k_m·V/R < F_S: the motor cannot break away (it would slide with Coulomb friction alone);
    at 1.5 × the breakaway voltage it slides at the speed where k_m·I = F(ω_m) + λ·ω_m, V = R·I + k_m·ω_m,
    F(ω) = F_C + (F_S − F_C)·exp(−(ω/v_S)²) (brentq) — with a rigid gear (the friction on the input
    joint) and behind a compliant one (on the motor's own hinge / coordinate), both backends."""
    from scipy.optimize import brentq

    scn, _ = _stribeck(0.8, gear)
    assert FC * R_A / KM_A < 0.8 * FS * R_A / KM_A  # above the Coulomb level
    for b, tol in (("multibody", 5e-4), ("reduced", 1e-2)):  # (MuJoCo's soft constraint; the regularised law)
        tr = simulate(S.make_machine(scn, "open"), b, 0.3, record_dt=1e-3, loop="python")
        assert abs(tr["A:crank_speed_rad_s"][-1]) <= tol, b
    scn, v = _stribeck(1.5, gear)
    wm = brentq(lambda w: KM_A * (v - KM_A * w) / R_A - FC - (FS - FC) * math.exp(-(w / VS) ** 2) - LAM_A * w,
                1e-9, v / KM_A)
    for b in ("reduced", "multibody"):
        m = S.make_machine(scn, "open")
        tr = simulate(m, b, 0.3, record_dt=1e-3, loop="python")
        assert tr["A:crank_speed_rad_s"][-1] == pytest.approx(wm / Z_A, rel=1e-6), b
        assert m.mechanism.describe()["drivetrain"]["A"]["friction"]["breakaway_Nm"] == FS


# ---------------------------------------------------------------- friction on the mechanism's joints
def _free_drives(n, joint, F):
    """n DC motors without back-EMF or viscous friction (nothing leaves through them), Coulomb friction
    F on the mechanism's ``joint`` in their drive trains."""
    from mjbench.drive import DCMotorDrive
    from mjbench.drivetrain import DriveTrain
    from mjbench.drivetrain.gear import Friction

    drives = []
    for _ in range(n):
        d = DCMotorDrive(R=1.0, L=1e-3, k_m=0.05, J_m=1e-5, J_a=0.0, J_b=0.0, z=10.0, lam=0.0, T_0=0.0)
        d.train = DriveTrain(friction=Friction(joints={joint: {"coulomb": F}}))
        d.k_m = 1e-12
        drives.append(d)
    return drives


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_friction_on_a_passive_joint_takes_the_energy_it_dissipates(backend):
    """A free five-bar (no back-EMF, no viscous friction) with Coulomb friction F on the passive joint
    B (proximal → distal link): E = ½q̇ᵀ(M̄ + J_eq)q̇ + E_p falls by ∫F·|ω_B|dt, ω_B = θ̇_dist1 − θ̇_prox1
    from the position solve's V = ∂z/∂q (the reduced model's regularised law: ∫ω_B·F·tanh(ω_B/v_ε)dt)."""
    from controllers.constant import ConstantCommand
    from mjbench.machine import Machine

    F = 0.02
    mech = S.make_mechanism(S.load("fivebar"))
    drives = _free_drives(2, "B", F)
    q0 = tuple(mech.stated_inputs)
    m = Machine(mech, drives, [ConstantCommand(0.0), ConstantCommand(0.0)], q0=q0, qd0=(3.0, -2.0))
    tr = simulate(m, backend, 0.1, record_dt=1e-4, loop="python")
    Q = np.stack([tr["A:crank_angle_rad"], tr["E:crank_angle_rad"]], axis=1)
    Qd = np.stack([tr["A:crank_speed_rad_s"], tr["E:crank_speed_rad_s"]], axis=1)
    Mb = mech.reduced_n(Q)[0] + drives[0].J_eq * np.eye(2)
    E = 0.5 * np.einsum("bi,bij,bj->b", Qd, Mb, Qd) + mech.potential_energy(Q)
    _, V = mech.jacobian_inputs(Q)
    c = mech.c
    ib, ia = c.index["dist1"], c.index["prox1"]
    wB = np.einsum("bk,bk->b", V[:, 3 * ib + 2, :] - V[:, 3 * ia + 2, :], Qd)
    if backend == "reduced":
        veps = m.mechanism.model_form().P.T[0, 3]
        P = wB * F * np.tanh(wB / veps)
    else:
        P = F * np.abs(wB)
    lost = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(tr["t_s"]))])
    assert lost[-1] > 0.05 * (E[0] - np.min(E))  # the friction takes a good part of it
    err = np.max(np.abs((E[0] - E) - lost)) / lost[-1]
    assert err <= 1e-5, err  # (measured 3.5e-8 reduced, 4.7e-7 MuJoCo)


def test_the_fivebar_with_joint_friction_agrees_between_the_backends():
    """Under PID along the path, Coulomb, Stribeck and viscous friction on both passive tree joints
    (measured 1.3e-3 of the peak speed over 0.6 s: the regularised stick against MuJoCo's constraint)."""
    pytest.importorskip("numba")
    scn = S.load("fivebar", ["drive.friction.joints.B={coulomb=0.05, breakaway=0.08, stribeck_speed=0.5, viscous=0.01}",
                             "drive.friction.joints.D={coulomb=0.03}"])
    r, m = (simulate(S.make_machine(scn, "pid"), b, 0.6, record_dt=1e-3) for b in ("reduced", "multibody"))
    rigid = simulate(S.make_machine(S.load("fivebar"), "pid"), "reduced", 0.6, record_dt=1e-3)
    for a in ("A", "E"):
        w = m[f"{a}:crank_speed_rad_s"]
        assert np.max(np.abs(r[f"{a}:crank_speed_rad_s"] - w)) <= 3e-3 * np.max(np.abs(w)), a
        # it matters: the current differs from the frictionless machine's by ≈ 0.2 A
        assert np.max(np.abs(r[f"{a}:current_A"] - rigid[f"{a}:current_A"])) > 0.05, a
    d = S.make_machine(scn, "pid").mechanism.describe()["drivetrain"]["joints"]
    assert d["B"]["breakaway_Nm"] == 0.08 and d["D"]["coulomb_Nm"] == 0.03


@pytest.mark.parametrize("sets,match", [
    (["drives.E.friction.joints.B={coulomb=0.01}", "drives.A.friction.joints.B={coulomb=0.02}"],
     r"drives.E.friction.joints.B: differs from another axis's"),
    (["drive.friction.joints.C={coulomb=0.01}"], r"drive.friction.joints.C: .*no joint 'C'"),
])
def test_joint_friction_it_cannot_model_is_one_line(sets, match):
    with pytest.raises(MjbenchError, match=match):
        simulate(S.make_machine(S.load("fivebar", sets), "pid"), "reduced", 0.01, loop="python")


def test_a_motor_and_a_joint_law_on_one_input_joint_add_up_in_mujoco():
    """Axis A's motor (Stribeck, rigid gear: on the input joint, × z) and joint A's own friction: MuJoCo's
    friction level on that dof, edited every step, is z·F_m(|z·v|) + F_j(|v|) — at rest z·F_S,m + F_S,j,
    and at speed the sum of the two laws' levels."""
    from mjbench.backends.multibody import MultibodyPlant
    from mjbench import compiled as C

    scn = S.load("fivebar", ["drives.A.friction={coulomb=0.01, breakaway=0.02, stribeck_speed=5.0}",
                             "drives.A.friction.joints.A={coulomb=0.1, breakaway=0.3, stribeck_speed=0.2}"])
    m = S.make_machine(scn, "pid")
    plant = MultibodyPlant(m)
    plant.start()
    model, data = plant.model, plant.data
    dof = int(model.joint("A").dofadr[0])
    z = 10.0
    assert model.dof_frictionloss[dof] == pytest.approx(z * 0.02 + 0.3, rel=1e-12)
    f = m.mechanism.load_form(model, data)
    data.qvel[dof] = 0.3
    f.bound()(0.0, C.python_view(f.P))
    want = z * (0.01 + 0.01 * math.exp(-(z * 0.3 / 5.0) ** 2)) + 0.1 + 0.2 * math.exp(-(0.3 / 0.2) ** 2)
    assert model.dof_frictionloss[dof] == pytest.approx(want, rel=1e-12)


def test_viscous_friction_on_a_passive_joint_is_the_same_through_the_table_and_the_solve():
    """The five-bar under PID with 0.02 N·m·s/rad on the passive joint B: its speed ratio r_B = ∂θ_B/∂q
    read from the tabulated grid (bicubic) and from each evaluation's solve give the same run (measured
    4e-12 of the peak speed), and MuJoCo's joint damping the same motion (measured 2e-8)."""
    jf = "drive.friction.joints.B={viscous=0.02}"
    r = {k: simulate(S.make_machine(S.load("fivebar", [jf, f'mechanism.reduced_model="{k}"']), "pid"), "reduced",
                     0.3, record_dt=1e-3, loop="python") for k in ("table", "solve")}
    mb = simulate(S.make_machine(S.load("fivebar", [jf]), "pid"), "multibody", 0.3, record_dt=1e-3, loop="python")
    free = simulate(S.make_machine(S.load("fivebar"), "pid"), "reduced", 0.3, record_dt=1e-3, loop="python")
    for a in ("A", "E"):
        w = mb[f"{a}:crank_speed_rad_s"]
        pk = np.max(np.abs(w))
        assert np.max(np.abs(r["solve"][f"{a}:crank_speed_rad_s"] - r["table"][f"{a}:crank_speed_rad_s"])) <= 1e-9 * pk
        assert np.max(np.abs(r["solve"][f"{a}:crank_speed_rad_s"] - w)) <= 1e-6 * pk
        assert np.max(np.abs(free[f"{a}:current_A"] - r["solve"][f"{a}:current_A"])) > 0.02  # it matters


def test_joint_friction_on_three_motors_takes_the_energy_it_dissipates():
    """The 3R arm (three inputs: the model solved at every evaluation), free (no back-EMF), Coulomb
    friction F on its elbow B: E = ½q̇ᵀ(M̄ + J_eq)q̇ + E_p falls by ∫ω_B·F·tanh(ω_B/v_ε)dt, ω_B = q̇_B
    (B is an input: r_B = e_B); compiled = CPython bit for bit."""
    from pathlib import Path

    from controllers.constant import ConstantCommand
    from mjbench.machine import Machine

    F = 0.05
    mech = S.make_mechanism(S.load(str(Path(__file__).parent / "data" / "multi" / "arm3r.toml")))
    drives = _free_drives(3, "B", F)

    def machine():
        return Machine(mech, drives, [ConstantCommand(0.0)] * 3, q0=(0.3, 1.0, -0.5), qd0=(2.0, -1.0, 3.0))

    tr = simulate(machine(), "reduced", 0.2, record_dt=1e-4, loop="python")
    Q = np.stack([tr[f"{a}:crank_angle_rad"] for a in "ABC"], axis=1)
    Qd = np.stack([tr[f"{a}:crank_speed_rad_s"] for a in "ABC"], axis=1)
    E = 0.5 * np.einsum("bi,bij,bj->b", Qd, mech.reduced_n(Q)[0] + drives[0].J_eq * np.eye(3), Qd) \
        + mech.potential_energy(Q)
    m = machine()
    m.mechanism.set_step(1e-4)
    veps = m.mechanism.model_form().P.T[0, 3]
    wB = Qd[:, 1]
    P = wB * F * np.tanh(wB / veps)
    lost = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(tr["t_s"]))])
    assert lost[-1] > 0.1 * np.ptp(E)
    assert np.max(np.abs((E[0] - E) - lost)) <= 1e-5 * lost[-1]  # (measured 1.3e-7)
    pytest.importorskip("numba")
    c = simulate(machine(), "reduced", 0.05, record_dt=1e-3, loop="compiled")
    p = simulate(machine(), "reduced", 0.05, record_dt=1e-3, loop="python")
    np.testing.assert_array_equal(c.data, p.data)
