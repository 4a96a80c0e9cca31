"""Machines with several motors: the n-input linkage, its n×n reduced model, the kernel's n-axis
plants, per-axis drives and controllers, task-space paths and computed torque.

Independent paths: the 2R arm's mass matrix, velocity terms and gravity in closed form (a textbook
formula, not the product's projection V^T M V); MuJoCo's own mass matrix, bias forces and inverse
dynamics (``mj_fullM``, ``qfrc_bias``, ``mj_inverse``) projected through the loop constraints; the
energy of a free arm (kinetic + potential, conserved); the other backend; the CPython loop for
the compiled one; the planned path for the end effector."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mjbench import plausibility as P
from mjbench import runner
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.errors import GeometryError, MjbenchError, ParameterError
from mjbench.mechanisms.linkage import LinkageParams, Linkage, cbar

from arm2r_model import C1, C2, G, L1, M1, M2, arm_closed_form  # (tests/arm2r_model.py)


@pytest.fixture(scope="module")
def arm():
    return S.make_mechanism(S.load("arm2r"))


@pytest.fixture(scope="module")
def fivebar():
    return S.make_mechanism(S.load("fivebar"))


def test_the_2r_arm_reduced_model_is_the_closed_form(arm):
    rng = np.random.default_rng(1)
    Q = rng.uniform(-np.pi, np.pi, (40, 2))
    Qd = rng.normal(size=(40, 2))
    M, Gc, g, D = arm.reduced_n(Q)
    c = cbar(Gc, Qd)
    for k in range(40):
        Mc, cc, gc = arm_closed_form(*Q[k], *Qd[k])
        np.testing.assert_allclose(M[k], Mc, rtol=0, atol=1e-12 * np.max(np.abs(Mc)))
        np.testing.assert_allclose(c[k], cc, rtol=0, atol=1e-12 * max(np.max(np.abs(Mc)), 1.0))
        np.testing.assert_allclose(g[k], gc, rtol=0, atol=1e-12 * np.max(np.abs(gc)))
    assert np.all(D == 0.0)
    # the table the simulation reads: within its stated error
    Mt = arm.reduced_table(Q)[0]
    assert np.max(np.abs(Mt - M)) / np.max(np.abs(M)) <= max(arm.table_info["rel_error_M"], 1e-12) * 1.01
    assert arm.table_info["rel_error_M"] <= 1e-6 and arm.table_info["rel_error_c"] <= 1e-6


@pytest.mark.parametrize("name", ["arm2r", "fivebar"])
def test_the_reduced_model_equals_mujoco_through_the_loop_constraints(name, arm, fivebar):
    mech = arm if name == "arm2r" else fivebar
    r = P.reduced_vs_mujoco(mech, S.load(name).multibody_options())
    assert r["models_agree"], r
    for k in ("M_rel_err", "bias_rel_err", "inverse_dynamics_rel_err"):
        assert r[k] <= 1e-9, (k, r[k])
    assert r["closure_position_m"] <= 1e-10


def test_a_free_arm_keeps_its_energy_on_both_backends(arm):
    """Torque sources commanding 0, no friction: ½q̇ᵀ(M̄ + J_eq)q̇ + E_p is conserved (RK4 at 0.1 ms;
    MuJoCo's RK4; the reduced model read from the table)."""
    from controllers.constant import ConstantCommand
    from mjbench.drives.ideal import TorqueDrive
    from mjbench.machine import Machine

    Ja = 2e-3
    for backend in ("reduced", "multibody"):
        m = Machine(arm, [TorqueDrive(J=Ja), TorqueDrive(J=Ja)], [ConstantCommand(0.0), ConstantCommand(0.0)],
                    q0=(0.3, 1.0), qd0=(2.0, -1.0))
        tr = simulate(m, backend, 0.5, record_dt=1e-3, loop="python")
        q = np.stack([tr["A:crank_angle_rad"], tr["B:crank_angle_rad"]], axis=1)
        qd = np.stack([tr["A:crank_speed_rad_s"], tr["B:crank_speed_rad_s"]], axis=1)
        E = []
        for k in range(tr.n):
            Mc, _, _ = arm_closed_form(*q[k], *qd[k])
            Ep = G * ((M1 * C1 + M2 * L1) * math.sin(q[k, 0]) + M2 * C2 * math.sin(q[k, 0] + q[k, 1]))
            E.append(0.5 * qd[k] @ (Mc + Ja * np.eye(2)) @ qd[k] + Ep)
        E = np.array(E)
        ke = 0.5 * qd[0] @ (arm_closed_form(*q[0], *qd[0])[0] + Ja * np.eye(2)) @ qd[0]
        # MuJoCo's RK4 on its exact model; the reduced RK4 on the table (c̄, ḡ interpolated to ≈ 3e-7,
        # table_info): their small inconsistency with dM̄/dq shows as a drift of that order over the run
        tol = 2e-6 if backend == "multibody" else 2e-5
        assert np.max(np.abs(E - E[0])) / ke <= tol, (backend, np.max(np.abs(E - E[0])) / ke)
        assert np.ptp(q[:, 1]) > 0.5  # it really moved


@pytest.mark.parametrize("name,mode", [("fivebar", "pid"), ("arm2r", "ct")])
def test_both_backends_agree_and_the_end_effector_follows_its_path(name, mode):
    scn = S.load(name)
    m = S.make_machine(scn, mode)
    trajs = {b: simulate(S.make_machine(scn, mode), b, 0.5, record_dt=1e-3, loop="python")
             for b in ("reduced", "multibody")}
    res = runner.run_metrics(m, trajs, scn.metrics, scn.multibody_options())
    assert res["multibody_vs_reduced"]["max_rel_diff"] <= 1e-5, res["multibody_vs_reduced"]
    assert res["plausibility"]["model"]["models_agree"]
    ee = res["backends"]["multibody"]["end_effector"]
    assert ee["max_error_m"] <= (2e-3 if mode == "pid" else 2e-4), ee
    assert set(res["axes"]) == set(m.axis_labels) and len(res["axes"]) == 2


def test_computed_torque_and_pid_compile_to_the_cpython_bits():
    pytest.importorskip("numba")
    scn = S.load("fivebar")
    for mode in ("pid",):
        for b in ("reduced", "multibody"):
            py = simulate(S.make_machine(scn, mode), b, 0.05, record_dt=1e-4, loop="python")
            cc = simulate(S.make_machine(scn, mode), b, 0.05, record_dt=1e-4, loop="compiled")
            assert cc.meta["loop"] == "compiled", cc.meta["loop_reason"]
            np.testing.assert_array_equal(py.data, cc.data)


def test_a_run_that_evaluates_the_tabulated_model_compiles_from_its_first_co_step(monkeypatch):
    """A component's form (or a model it evaluates) may declare the co-steps from which compiling pays
    (``flags["min_steps"]``); the composition takes the least.  The five-bar's 2-input model table costs
    ≈ 85 µs a call in CPython: the computed-torque controller that evaluates it makes even a short
    MuJoCo run compile, where the PID's MuJoCo run keeps the plant's threshold."""
    from mjbench import kernel
    from mjbench.backends import multibody
    from mjbench.compiled import jit

    pytest.importorskip("numba")
    monkeypatch.setattr(jit, "loaded", lambda: False)  # as in a fresh process
    scn = S.load("fivebar")
    for mode, want in (("ct", 0), ("pid", multibody.MIN_COMPILED_STEPS)):
        mc = S.make_machine(scn, mode)
        plant = multibody.MultibodyPlant(mc, scn.multibody_options())
        plant.start()
        h = float(plant.h)
        pr = kernel.Program.build(plant, mc, h, kernel.control_every(mc.controller, h))
        assert pr.min_steps == want
        mode_, why = kernel.choose_loop(pr, 10_000)
        assert (mode_ == "compiled") == (want == 0), why


def _desc(**kw):
    d = dict(type="linkage", name="arm", ground={"O": (0.0, 0.0)},
             links={"upper": dict(mass=1.0, inertia=0.01, points={"O": (0, 0), "B": (0.3, 0)}),
                    "fore": dict(mass=0.5, inertia=0.005, points={"B": (0, 0), "T": (0.25, 0)}, angle=1.0)},
             joints=[dict(name="A", at=("ground.O", "upper.O")), dict(name="B", at=("upper.B", "fore.B"))],
             inputs=["A", "B"], input_angles=[0.0, 1.0])
    d.update(kw)
    return d


def test_the_number_of_inputs_must_be_the_mobility():
    with pytest.raises(GeometryError, match=r"has 2 degrees of freedom .* but 1 inputs \(A\): it needs exactly 2"):
        Linkage.from_params(LinkageParams.model_validate(_desc(inputs=["A"], input_angles=[0.0])))
    sets = ['mechanism.inputs=["A", "E", "B"]', "mechanism.input_angles=[2.2625, 0.879, 0.0]",
            'mechanism.input_ranges=[[1.7, 2.8], [0.35, 1.5], [-1, 1]]']
    with pytest.raises((GeometryError, MjbenchError), match=r"2 degrees of freedom .* but 3 inputs"):
        S.make_mechanism(S.load("fivebar", sets))


def test_a_path_through_a_singular_configuration_is_refused_before_simulating():
    """The arm stretched straight (the tip at 0.55 m) cannot move radially: the path is refused,
    naming where."""
    sets = ['path.segments=[{line = [0.55, 0.0], T = "0.5 s"}]', "path.repeat=false",
            "path.start=[0.2598076, 0.4]"]
    with pytest.raises(GeometryError, match=r"singular configuration of the inverse kinematics at t = [\d.]+ s"):
        S.make_machine(S.load("arm2r", sets), "pid")


def test_a_path_that_does_not_start_at_the_machine_is_one_line():
    with pytest.raises(ParameterError, match=r"path.start = \(0.1, 0.4\) m: the stated pose puts fore.T at"):
        S.make_machine(S.load("arm2r", ["path.start=[0.1, 0.4]", "path.repeat=false"]), "pid")


def test_one_axis_only_quantities_say_so():
    m = S.make_machine(S.load("fivebar"), "pid")
    with pytest.raises(ParameterError, match=r"drives.R: the machine has 2 axes"):
        m.drive.R
    with pytest.raises(ParameterError, match="reduced model is the n×n"):
        m.mechanism.reduced(0.0)
