"""The n-input reduced model solved at every evaluation (``reduced_model = "solve"``,
mjbench/mechanisms/linkage/multi_solve.py): machines with three motors, and the five-bar without its
table.

Independent paths: the 3R arm's mass matrix and gravity as Σ m·J_vᵀJ_v + I·J_ωᵀJ_ω over its links
(the links' Jacobians written from the chain's geometry, not the product's projection V^T M V); the
NumPy exact solve the table is built from (another implementation of the same projection); MuJoCo's
own dynamics (the model check, and the other backend); the energy of a free arm; the five-bar's
table; the CPython loop for the compiled one."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mjbench import runner
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.errors import GeometryError, MjbenchError
from mjbench.mechanisms.linkage.multi_solve import scratch_size, solve_model

ARM3R = str(Path(__file__).parent / "data" / "multi" / "arm3r.toml")
# tests/data/multi/arm3r.toml: per link (mass, length to the next joint, centre, inertia about it)
LINKS = [(1.2, 0.30, 0.15, 9.0e-3), (0.8, 0.25, 0.125, 4.2e-3), (0.3, 0.10, 0.05, 1.0e-3)]
G = 9.81


def arm3_closed_form(q):
    """M(q) and g(q) of the planar 3R arm in relative joint angles: Σ_k m_k J_kᵀJ_k + I_k ω_kᵀω_k with
    J_k the Jacobian of link k's mass centre, ω_k = (1, …, 1, 0, …) its angular rate per joint rate."""
    phi = np.cumsum(q)
    n = len(q)
    M = np.zeros((n, n))
    g = np.zeros(n)
    for k, (m, _, c, inertia) in enumerate(LINKS):
        J = np.zeros((2, n))
        for j in range(k + 1):  # joint j moves every link from j on: ∂p_k/∂q_j
            for i in range(j, k):
                J[:, j] += LINKS[i][1] * np.array([-math.sin(phi[i]), math.cos(phi[i])])
            J[:, j] += c * np.array([-math.sin(phi[k]), math.cos(phi[k])])
        w = np.array([1.0 if j <= k else 0.0 for j in range(n)])
        M += m * J.T @ J + inertia * np.outer(w, w)
        g += m * G * J[1]
    return M, g


def law_model(mech, q, qd, W=None):
    """(M̄, bias) from the compiled law itself, run in CPython (a fresh work space: the first
    evaluation walks from the stated pose)."""
    P = mech.model_form().P
    n = P.n
    if W is None:
        W = np.zeros(n * n + n + scratch_size(n, P.nz))
    Sy = np.concatenate([q, qd])
    solve_model(Sy, 0, 0.0, P, W, 0)
    return W[:n * n].reshape(n, n).copy(), W[n * n:n * n + n].copy()


@pytest.fixture(scope="module")
def arm3():
    return S.make_mechanism(S.load(ARM3R))


def test_three_inputs_are_solved_each_step_and_say_so(arm3):
    assert arm3.n_inputs == 3
    form = arm3.model_form()
    assert form.flags["table"]["model"] == "solve" and arm3.c.table_n is None


def test_the_3r_arm_mass_matrix_and_gravity_are_the_links_jacobian_sums(arm3):
    rng = np.random.default_rng(7)
    Q = rng.uniform(-2.5, 2.5, (12, 3))
    Qd = rng.normal(size=(12, 3))
    M, Gc, g, D = arm3.reduced_n(Q)  # the NumPy exact solve
    bias_np = arm3.bias_n(Q, Qd)
    for k in range(len(Q)):
        Mc, gc = arm3_closed_form(Q[k])
        scale = np.max(np.abs(Mc))
        Ml, bl = law_model(arm3, Q[k], Qd[k])
        np.testing.assert_allclose(Ml, Mc, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(M[k], Mc, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(g[k], gc, rtol=0, atol=1e-12 * np.max(np.abs(gc)))
        # the law's bias (velocity terms + gravity) against the NumPy path, and at rest against g(q)
        np.testing.assert_allclose(bl, bias_np[k], rtol=0, atol=1e-12 * max(np.max(np.abs(bias_np[k])), scale))
        _, b0 = law_model(arm3, Q[k], np.zeros(3))
        np.testing.assert_allclose(b0, gc, rtol=0, atol=1e-12 * np.max(np.abs(gc)))
    assert np.all(D == 0.0)


def test_the_law_warm_starts_from_its_last_configuration(arm3):
    """Evaluations along a motion, each from the previous one's z (the kernel's case): the same model
    as a fresh walk from the stated pose."""
    P = arm3.model_form().P
    W = np.zeros(12 + scratch_size(3, P.nz))
    q = np.array(arm3.stated_inputs)
    for step in range(50):
        q = q + np.array([0.02, -0.03, 0.05])
        Mw, bw = law_model(arm3, q, np.array([1.0, -2.0, 0.5]), W)
    Mf, bf = law_model(arm3, q, np.array([1.0, -2.0, 0.5]))
    np.testing.assert_allclose(Mw, Mf, rtol=0, atol=1e-13 * np.max(np.abs(Mf)))
    np.testing.assert_allclose(bw, bf, rtol=0, atol=1e-12 * np.max(np.abs(bf)))


def test_a_free_3r_arm_keeps_its_energy_and_both_backends_agree(arm3):
    """Torque sources commanding 0, no friction: ½q̇ᵀ(M̄ + J_eq)q̇ + E_p (the test's closed forms) is
    conserved by the reduced backend's RK4 on the solved model, and MuJoCo integrates the same motion."""
    pytest.importorskip("numba")
    from controllers.constant import ConstantCommand
    from mjbench.drives.ideal import TorqueDrive
    from mjbench.machine import Machine

    Ja = 2e-3

    def machine():
        return Machine(arm3, [TorqueDrive(J=Ja) for _ in range(3)], [ConstantCommand(0.0) for _ in range(3)],
                       q0=(0.3, 1.0, -0.5), qd0=(2.0, -1.0, 3.0))

    tr = simulate(machine(), "reduced", 0.5, record_dt=1e-3, loop="compiled")
    assert tr.meta["loop"] == "compiled" and tr.meta["model"] == "solve"
    q = np.stack([tr[f"{a}:crank_angle_rad"] for a in "ABC"], axis=1)
    qd = np.stack([tr[f"{a}:crank_speed_rad_s"] for a in "ABC"], axis=1)
    E = []
    for k in range(tr.n):
        Mc, _ = arm3_closed_form(q[k])
        phi = np.cumsum(q[k])
        y, Ep = 0.0, 0.0
        for i, (mass, length, c, _) in enumerate(LINKS):
            Ep += mass * G * (y + c * math.sin(phi[i]))
            y += length * math.sin(phi[i])
        E.append(0.5 * qd[k] @ (Mc + Ja * np.eye(3)) @ qd[k] + Ep)
    E = np.array(E)
    ke = 0.5 * qd[0] @ (arm3_closed_form(q[0])[0] + Ja * np.eye(3)) @ qd[0]
    assert np.max(np.abs(E - E[0])) / ke <= 1e-9, np.max(np.abs(E - E[0])) / ke
    assert np.ptp(q[:, 2]) > 0.5  # the wrist really turned
    # MuJoCo's RK4 on its own model of the same chain: the same motion to rounding
    mb = simulate(machine(), "multibody", 0.5, record_dt=1e-3, loop="python")
    for a in "ABC":
        w = tr[f"{a}:crank_speed_rad_s"]
        d = np.max(np.abs(mb[f"{a}:crank_speed_rad_s"] - w)) / np.max(np.abs(qd))
        assert d <= 1e-9, (a, d)


def test_three_motors_under_pid_per_axis_on_both_backends():
    """The scenario (tests/data/multi/arm3r.toml) through the runner's metrics: the backends agree, the
    model check passes, three axes (CPython loops over 0.05 s: no compilation)."""
    scn = S.load(ARM3R)
    m = S.make_machine(scn, "pid")
    trajs = {b: simulate(S.make_machine(scn, "pid"), b, 0.05, record_dt=1e-3, loop="python")
             for b in ("reduced", "multibody")}
    res = runner.run_metrics(m, trajs, scn.metrics, scn.multibody_options())
    # a serial chain: both integrate the same equations of motion with RK4 at 0.1 ms (the solved model
    # is exact), so they agree to rounding (measured 1.6e-14 of the peak speed over 1.5 s)
    assert res["multibody_vs_reduced"]["max_rel_diff"] <= 1e-9, res["multibody_vs_reduced"]
    mod = res["plausibility"]["model"]
    assert mod["models_agree"] and mod["M_rel_err"] <= 1e-9 and mod["bias_rel_err"] <= 1e-9, mod
    assert len(res["axes"]) == 3 and trajs["reduced"].meta["model"] == "solve"
    assert all(np.max(trajs["reduced"][f"{a}:crank_speed_rad_s"]) > 0.3 for a in "ABC")  # each axis driven


def test_the_fivebar_solved_each_step_is_its_table():
    """The five-bar with reduced_model = "solve" against its own table (the table's interpolation
    error, ≈ 1e-7 of M̄, is what separates them; CPython loop over 0.1 s)."""
    base = S.load("fivebar")
    solved = S.load("fivebar", ['mechanism.reduced_model="solve"'])
    a = simulate(S.make_machine(base, "pid"), "reduced", 0.1, record_dt=1e-3, loop="python")
    b = simulate(S.make_machine(solved, "pid"), "reduced", 0.1, record_dt=1e-3, loop="python")
    assert b.meta["model"] == "solve" and a.meta["model"] == "table"
    for ax in ("A", "E"):
        w = a[f"{ax}:crank_speed_rad_s"]
        d = np.max(np.abs(b[f"{ax}:crank_speed_rad_s"] - w)) / np.max(np.abs(w))
        assert d <= 1e-8, (ax, d)


def test_the_solved_model_compiles_to_the_cpython_bits():
    """Computed torque reads the solved model too (its own work space): both laws compiled = CPython."""
    pytest.importorskip("numba")
    scn = S.load("fivebar", ['mechanism.reduced_model="solve"'])
    py = simulate(S.make_machine(scn, "ct"), "reduced", 0.01, record_dt=1e-4, loop="python")
    cc = simulate(S.make_machine(scn, "ct"), "reduced", 0.01, record_dt=1e-4, loop="compiled")
    assert cc.meta["loop"] == "compiled", cc.meta["loop_reason"]
    np.testing.assert_array_equal(py.data, cc.data)


def test_what_the_solved_model_does_not_take_is_one_line():
    with pytest.raises(MjbenchError, match=r"reduced_model: a machine with several inputs"):
        S.load("sixbar-watt2", ['mechanism.reduced_model="solve"'])
    with pytest.raises(GeometryError, match=r"reduced_model = 'table' takes 1 or 2 inputs \(3 here\)"):
        S.make_mechanism(S.load(ARM3R, ['mechanism.reduced_model="table"']))
    spring = 'mechanism.springs=[{between = ["ground.A", "dist1.C"], stiffness = 10.0, length = 0.3}]'
    with pytest.raises(GeometryError, match=r"reduced_model = 'solve' takes no springs or gears"):
        S.make_mechanism(S.load("fivebar", ['mechanism.reduced_model="solve"', spring]))


@pytest.mark.parametrize("model,match", [
    ("table", r"Likely cause: axis A left its input_ranges\[0\] = \[95°, 160°\] \(the table of the reduced model "
              r"ends there; last recorded at t = 0\.04\d* s: A = 160\.\d°"),
    ("solve", r"Likely cause: the linkage reached inputs where its loops cannot be solved .* just after t = 0\.11\d* s"),
])
def test_a_reduced_run_that_leaves_the_model_says_where(model, match):
    """The five-bar driven open loop at full voltage leaves its table's ranges (the table) or turns
    until its loops cannot close (the solve): the divergence names the axis, the range and the time."""
    scn = S.load("fivebar", [f'mechanism.reduced_model="{model}"', 'modes.open={type="open", voltage=24.0}'])
    with pytest.raises(MjbenchError, match=match):
        simulate(S.make_machine(scn, "open"), "reduced", 0.2, record_dt=1e-3, loop="python")
