"""Machines with several motors, the analyses (issue 32 items 7-9): inverse dynamics along the path,
workspace and singularities, the MIMO linear model and loop, and every command on ``fivebar``.

Independent paths: MuJoCo's ``mj_inverse`` through the loop constraints (the analysis's own check,
here with its tolerance), the 2R arm's textbook M(q), c(q, q̇), g(q) (``test_multi_axis.arm_closed_form``)
for the inverse dynamics and the plant's Jacobian, det J_x = l1·l2·sin q2 of the 2R arm, the
five-bar's circle geometry for its singular configurations, MuJoCo's ``mjd_transitionFD`` for the
MIMO plant, the kernel's own co-step (one step of the reduced backend from perturbed states) for
the discrete plant, the loop-at-a-time formula L_k = −[G_kk + G_ko(I − G_oo)⁻¹G_ok] from the
frequency response of G = C·P, and computed torque's law differentiated by hand."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mjbench import analyze_multi as AM
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.cli import main
from mjbench.linear import multi as LM
from mjbench.machine import Machine
from test_multi_axis import L1, arm_closed_form


@pytest.fixture(scope="module")
def fivebar():
    scn = S.load("fivebar")
    return scn, S.make_machine(scn, "pid")


@pytest.fixture(scope="module")
def arm():
    scn = S.load("arm2r")
    return scn, S.make_machine(scn, "pid")


# ============================================================================ inverse dynamics
@pytest.mark.parametrize("name", ["fivebar", "arm2r"])
def test_inverse_dynamics_along_the_path_equals_mj_inverse(name, fivebar, arm):
    scn, m = fivebar if name == "fivebar" else arm
    info, arr = AM.inverse_dynamics(m.mechanism, m.drives, m.axis_labels, scn.path)
    chk = AM.inverse_dynamics_vs_mujoco(m.mechanism, m.drives, scn.multibody_options(), arr["Q"], arr["Qd"],
                                        arr["Qdd"], arr["tau_drive"], n=40)
    assert chk["agree"] and chk["max_rel_diff"] <= 1e-9, chk  # tolerance of the analysis: 1e-6
    assert chk["n_points"] == 40
    # RMS and peak are those of the curves
    for k, lab in enumerate(m.axis_labels):
        I = arr["curves"][f"I:{lab}"]
        assert info["axes"][lab]["current_A"]["rms"] == pytest.approx(math.sqrt(np.mean(I * I)), rel=1e-12)
        assert info["axes"][lab]["current_A"]["peak"] == pytest.approx(np.max(np.abs(I)), rel=1e-12)


def test_the_arms_inverse_dynamics_is_the_closed_form_and_its_motor_the_dc_motor_equations(arm):
    scn, m = arm
    info, arr = AM.inverse_dynamics(m.mechanism, m.drives, m.axis_labels, scn.path)
    t, Q, Qd, Qdd = arr["curves"]["t"], arr["Q"], arr["Qd"], arr["Qdd"]
    Ja = np.array([d.J_eq for d in m.drives])
    c = np.array([d.crank_damping for d in m.drives])
    for k in range(0, len(t), 37):
        Mc, cc, gc = arm_closed_form(*Q[k], *Qd[k])
        tau = Mc @ Qdd[k] + cc + gc + Ja * Qdd[k] + c * Qd[k]
        np.testing.assert_allclose(arr["tau_drive"][k], tau, rtol=0, atol=1e-11 * max(1.0, np.max(np.abs(tau))))
    for k, (lab, d) in enumerate(zip(m.axis_labels, m.drives)):
        I = arr["tau_drive"][:, k] / (d.z * d.k_m)  # T_0 = 0
        np.testing.assert_allclose(arr["curves"][f"I:{lab}"], I, rtol=1e-13, atol=1e-13)
        V = arr["curves"][f"V:{lab}"]
        dIdt = np.gradient(I, t)
        inner = slice(2, -2)  # (the ends: one-sided differences against the cycle's seam)
        np.testing.assert_allclose(V[inner], (d.R * I + d.L * dIdt + d.k_m * d.z * Qd[:, k])[inner], rtol=0,
                                   atol=1e-4 * np.max(np.abs(V)))


# ============================================================================ workspace, singularities
def test_the_arms_workspace_determinant_and_its_singular_elbow(arm):
    scn, m = arm
    W = AM.workspace_grid(m.mechanism, scn.path.point, grid=61)
    assert W["reached"].all()  # a serial arm: no direct singularity, every pose reached
    q2 = W["axes"][1][None, :] + 0 * W["axes"][0][:, None]
    np.testing.assert_allclose(W["detJ"], L1 * 0.25 * np.sin(q2), rtol=0, atol=1e-12)  # tip 0.25 m from the elbow
    nodes = AM._sign_change_nodes(W["detJ"], W["reached"])
    step = W["step"]
    d = np.abs(((q2[nodes] + math.pi / 2) % math.pi) - math.pi / 2)  # distance to 0 or π
    assert nodes.any() and np.all(d <= step + 1e-12)
    res = AM.workspace_numbers(m.mechanism, W, None)
    assert res["singularities"]["inverse_kinematic"]["meets_workspace"]  # full turns: the elbow straightens
    assert not res["singularities"]["direct"]["meets_workspace"]
    assert res["workspace"]["x_range_m"][1] == pytest.approx(L1 + 0.25, rel=2e-3)


def test_the_fivebars_workspace_and_singular_configurations_are_its_geometry(fivebar):
    scn, m = fivebar
    res, maps = AM.analyze_multi("fivebar", m.mechanism, m.drives, m.axis_labels, scn.path, scn.multibody_options(),
                                 grid=91, check=False)
    W = maps["workspace"]
    ws, sg = res["workspace"], res["singularities"]
    assert ws["reached_fraction_in_ranges"] == 1.0 and ws["path_inside_workspace"]
    assert not sg["inverse_kinematic"]["meets_workspace"] and not sg["direct"]["meets_workspace"]
    assert res["conditioning"]["max"] < 10 and res["conditioning"]["along_path"]["kappa_max"] < 2
    # the proximal links' ends B = A + 0.2(cos θ1, sin θ1), D = E + 0.2(cos θ2, sin θ2)
    th1, th2 = np.meshgrid(*W["axes"], indexing="ij")
    B = np.stack([-0.05 + 0.2 * np.cos(th1), 0.2 * np.sin(th1)], -1)
    D = np.stack([0.05 + 0.2 * np.cos(th2), 0.2 * np.sin(th2)], -1)
    BD = np.linalg.norm(D - B, axis=-1)
    # not reached: the direct singularity (distal links folded, B = D, or stretched, |BD| = 0.5 m)
    miss = ~W["reached"]
    assert miss.any() and np.all((BD[miss] < 0.06) | (BD[miss] > 0.5 - 1e-3))
    # the inverse-kinematic locus: a leg straight (A-B-C or E-D-C collinear).  With the legs' cross
    # products b1 = (B − A)×(C − B), b2 = (D − E)×(C − D), the velocity equations give det J_x = b1·b2/det K
    # (K: the distal links' directions, not singular on the branch), so det J_x and b1·b2 have one sign ratio
    C = W["X"]
    A0, E0 = np.array([-0.05, 0.0]), np.array([0.05, 0.0])

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    b = cross(B - A0, C - B) * cross(D - E0, C - D)
    r = W["reached"] & (np.abs(b) > 1e-6 * np.nanmax(np.abs(b)))
    ratio = np.sign(W["detJ"][r]) * np.sign(b[r])
    assert np.all(ratio == ratio[0])
    assert AM._sign_change_nodes(W["detJ"], W["reached"]).sum() > 50  # the locus crosses the grid


def test_analyze_writes_the_numbers_and_figures(tmp_path, fivebar):
    import json

    import mjbench as mjb

    an = mjb.analyze_mechanism("fivebar", grid=31)
    d = an.data
    assert an.multi_axis and d["inverse_dynamics_max_rel_diff_vs_mujoco"] <= 1e-6
    assert d["plausibility"]["model"]["models_agree"]
    for lab in ("A", "E"):
        row = d["inverse_dynamics"]["axes"][lab]
        assert row["current_A"]["peak"] > row["current_A"]["rms"] > 0 and row["voltage_V"]["peak"] < 24
    an.save(tmp_path / "an")
    names = sorted(p.name for p in (tmp_path / "an").iterdir())
    assert names == ["analysis.json", "inverse_dynamics.png", "singularities.png", "workspace.png"]
    assert json.loads((tmp_path / "an" / "analysis.json").read_text())["inverse_dynamics_max_rel_diff_vs_mujoco"] <= 1e-6
    assert "--speed has no effect" in _err(main, ["analyze", "fivebar", "--speed", "3"])


def _err(fn, argv):
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stderr(buf):
        rc = fn(argv)
    assert rc == 2
    return buf.getvalue()


# ============================================================================ linear
def test_the_mimo_plant_is_the_arms_closed_form_linearised(arm):
    scn, m = arm
    op = LM.path_operating_point(m, 0.3)
    A, B = LM.reduced_mechanics_n(m, op)
    Ja = np.array([d.J_eq for d in m.drives])
    c = np.array([d.crank_damping for d in m.drives])

    def acc(x):
        Mc, cc, gc = arm_closed_form(*x[:2], *x[2:])
        return np.linalg.solve(Mc + np.diag(Ja), op.tau - cc - gc - c * x[2:])

    x0 = np.concatenate([op.q, op.qd])
    Ac = np.zeros((2, 4))
    for j in range(4):
        e = 1e-6
        xp, xm = x0.copy(), x0.copy()
        xp[j] += e
        xm[j] -= e
        Ac[:, j] = (acc(xp) - acc(xm)) / (2 * e)
    np.testing.assert_allclose(A[2:], Ac, rtol=0, atol=1e-5 * np.max(np.abs(Ac)))  # the table: ≈ 1e-7 of M̄, c̄, ḡ
    Mc = arm_closed_form(*op.q, *op.qd)[0] + np.diag(Ja)
    np.testing.assert_allclose(B[2:], np.linalg.inv(Mc), rtol=1e-6)
    assert np.allclose(acc(x0), op.qdd, atol=1e-6 * max(1, np.max(np.abs(op.qdd))))  # the point's q̈


@pytest.mark.parametrize("name,tol", [("fivebar", 1e-3), ("arm2r", 3e-5)])
def test_the_mimo_plant_equals_mujocos_linearisation(name, tol, fivebar, arm):
    scn, m = fivebar if name == "fivebar" else arm
    op = LM.path_operating_point(m, 0.5)
    red = LM.plant_n(*LM.reduced_mechanics_n(m, op), m.drives, m.axis_labels)
    mb = LM.plant_n(*LM.multibody_mechanics_n(m, op, scn.multibody_options()), m.drives, m.axis_labels)
    assert list(red.input_labels) == [f"V_{x}" for x in m.axis_labels]
    assert list(red.output_labels) == [f"{s}_{x}" for s in ("q", "qd", "I") for x in m.axis_labels]
    d = LM.mimo_difference(red, mb)
    assert d["max_rel"] <= tol, d  # MuJoCo's soft loop closure (five-bar); the embedding's differences


def test_the_discrete_plant_is_the_kernels_co_step(fivebar):
    from controllers.openloop import ConstantVoltage

    scn, m = fivebar
    h = float(scn.simulation.dt)
    op = LM.path_operating_point(m, 0.3)
    P = LM.plant_n(*LM.reduced_mechanics_n(m, op), m.drives, m.axis_labels, h=h)
    cols = [f"{lab}:{c}" for c in ("crank_angle_rad", "crank_speed_rad_s", "current_A") for lab in m.axis_labels]

    def step(x, V):
        mc = Machine(m.mechanism, m.drives, [ConstantVoltage(v) for v in V], q0=tuple(x[:2]), qd0=tuple(x[2:4]),
                     I0=tuple(x[4:]))
        tr = simulate(mc, "reduced", h, record_dt=h, loop="python")
        return np.array([tr[c][-1] for c in cols])

    x0, V0 = np.concatenate([op.q, op.qd, op.I]), op.V
    Ad, Bd = np.zeros((6, 6)), np.zeros((6, 2))
    for j in range(6):
        e = 1e-6 * max(1.0, abs(x0[j]))
        xp, xm = x0.copy(), x0.copy()
        xp[j] += e
        xm[j] -= e
        Ad[:, j] = (step(xp, V0) - step(xm, V0)) / (2 * e)
    for j in range(2):
        Vp, Vm = V0.copy(), V0.copy()
        Vp[j] += 1e-4
        Vm[j] -= 1e-4
        Bd[:, j] = (step(x0, Vp) - step(x0, Vm)) / 2e-4
    assert np.max(np.abs(Ad - np.asarray(P.A))) <= 1e-8
    assert np.max(np.abs(Bd - np.asarray(P.B))) <= 1e-9 * np.max(np.abs(Bd))


def _loop(scn, m, t=None):
    h = float(scn.simulation.dt)
    op = LM.path_operating_point(m, t)
    A, B = LM.reduced_mechanics_n(m, op)
    P_T = LM.sample_n(LM.plant_n(A, B, m.drives, m.axis_labels, h=h), 1, m.axis_labels)
    return op, LM.loop_n(P_T, LM.controller_n(m, op, h), m.axis_labels)


def test_loop_at_a_time_and_the_sensitivity_peak_from_the_frequency_response(fivebar):
    scn, m = fivebar
    op, lp = _loop(scn, m)
    mg = LM.margins_n(lp)
    assert mg["stable"]
    L = lp.L
    for w in (3.0, 300.0, 2000.0):
        Gw = -LM._freq_response(L, [w])[0]  # G = C·P (u = G·V)
        S = LM._freq_response(lp.S, [w])[0]
        np.testing.assert_allclose(S, np.linalg.inv(np.eye(2) + (-Gw)), rtol=1e-9, atol=1e-12)
        for k, lab in enumerate(m.axis_labels):
            o = 1 - k
            Lk = -(Gw[k, k] + Gw[k, o] * Gw[o, k] / (1.0 - Gw[o, o]))
            np.testing.assert_allclose(LM._freq_response(lp.at_a_time[lab], [w])[0, 0, 0], Lk, rtol=1e-9)
    # ‖S‖∞ is the largest singular value over the grid, found to better than the grid does
    w = np.logspace(-2, math.log10(0.999 * math.pi / float(lp.S.dt)), 4000)
    top = LM.sigma_curves(lp.S, w)[:, 0].max()
    assert top <= mg["mimo_sensitivity_peak"] * (1 + 1e-9) and mg["mimo_sensitivity_peak"] <= top * 1.001
    for lab, a in mg["loop_at_a_time"].items():
        assert a["phase_margin_deg"] > 60 and a["gain_margin_dB"] > 20 and a["peak_sensitivity"] < 1.5


def test_the_controllers_counterparts(fivebar):
    from controllers.pid import pid_counterpart

    scn, m = fivebar
    h = float(scn.simulation.dt)
    op = LM.path_operating_point(m)
    Cn = LM.controller_n(m, op, h)
    for k, (lab, d) in enumerate(zip(m.axis_labels, m.drives)):  # PID per axis: Eq 16 with that axis's ratio
        c = m.controllers[k][0]
        one = pid_counterpart(c.kp, c.ki, c.kd, d.z, h, h)
        ins = [f"{s}_{lab}" for s in one.input_labels]
        np.testing.assert_allclose(np.asarray(Cn[f"V_{lab}", ins].D), np.asarray(one.D), rtol=1e-12)
    # computed torque: ∂V_k/∂q_ref_j = R_k/(z_k·k_m,k)·(M̄ + J_eq)_kj·ω_n² (the law differentiated by hand)
    mct = S.make_machine(scn, "ct")
    Cct = LM.controller_n(mct, op, h)
    Mt = LM._model(mct.mechanism, mct.drives, op.q, op.qd)[0]
    wn = mct.controller.wn
    for k, (lab, d) in enumerate(zip(mct.axis_labels, mct.drives)):
        for j, lj in enumerate(mct.axis_labels):
            got = float(np.asarray(Cct[f"V_{lab}", f"q_ref_{lj}"].D)[0, 0])
            assert got == pytest.approx(d.R / (d.z * d.k_m) * Mt[k, j] * wn ** 2, rel=1e-6)


def test_linearize_and_the_api(tmp_path):
    import mjbench as mjb

    lin = mjb.linearize("fivebar", "ct", t=0.5, multibody=False)
    assert lin.data["multi_axis"] and list(lin.plant.input_labels) == ["V_A", "V_E"]
    lp = lin.data["loop"]
    assert lp["stable"] and 1.0 < lp["mimo_sensitivity_peak"] < 1.5
    assert set(lp["loop_at_a_time"]) == {"A", "E"}
    assert lin.loop.L.ninputs == 2 and lin.loop.S.noutputs == 2
    assert "‖S‖∞" in lin.summary()
    lin.save(tmp_path / "lin")
    assert sorted(p.name for p in (tmp_path / "lin").iterdir()) == ["bode.png", "linear.json", "poles.png",
                                                                     "sigma.png"]
    with pytest.raises(mjb.ParameterError, match="linearised at its path's point"):
        mjb.linearize("fivebar", q=1.0)


# ============================================================================ every command
ONE_AXIS_ONLY = {
    "frest": ["frest", "fivebar", "--out", "{tmp}/frest"],
    "export-fmu": ["export-fmu", "fivebar", "--out", "{tmp}/f.fmu"],
    "calibrate": ["calibrate", "fivebar", "--out", "{tmp}/cal"],
    "identify": ["identify", "--data", "{tmp}/run/trajectory_multibody.csv"],
    "design": ["design", "fivebar", "--out", "{tmp}/design"],
    "optimize-law": ["optimize-law", "fivebar", "--out", "{tmp}/law"],
}
WORKS = {
    "run": ["run", "fivebar", "--t-end", "0.02", "--out", "{tmp}/run"],
    "render": ["render", "fivebar", "--t-end", "0.05", "--width", "160", "--height", "96", "--out", "{tmp}/v.mp4",
               "--no-progress"],
    "sweep": ["sweep", "fivebar", "--grid", "modes.pid.kp=1,2", "--t-end", "0.02", "--verify", "1", "--out",
              "{tmp}/sweep"],
    "tune": ["tune", "fivebar", "--controller", "pid", "--bounds", "kd=1e-4:1e-2", "--global", "2", "--starts", "0",
             "--verify", "1", "--t-end", "0.02", "--out", "{tmp}/tune"],
    "linearize": ["linearize", "fivebar", "--mode", "ct", "--no-multibody", "--out", "{tmp}/lin"],
    "analyze": ["analyze", "fivebar", "--grid", "21", "--out", "{tmp}/an"],
    "check": ["check", "fivebar", "--mode", "pid", "--backend", "reduced", "--t-end", "0.005"],
}


def test_every_command_works_on_fivebar_or_says_in_one_line_it_is_one_axis_only(tmp_path, capsys, monkeypatch):
    """Each command of the CLI on the two-motor five-bar, short settings: it works (exit 0), or it
    prints exactly one line naming the one-axis-only capability (exit 2); then the API."""
    import mjbench as mjb

    monkeypatch.setenv("MJBENCH_JIT", "0")  # runs of a few ms: the CPython loop (check compiles its own)
    fmt = {"tmp": str(tmp_path)}
    for name, argv in WORKS.items():  # run first: identify reads its record
        rc = main([a.format(**fmt) for a in argv])
        out, err = capsys.readouterr()
        assert rc == 0, (name, err[-2000:])
    for name, argv in ONE_AXIS_ONLY.items():
        rc = main([a.format(**fmt) for a in argv])
        out, err = capsys.readouterr()
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert rc == 2 and len(lines) == 1, (name, err)
        assert lines[0].startswith(f"mjbench: error: {name}: the machine has 2 axes (A, E); {name} is one-axis only"), \
            lines[0]
    # the API: simulate, Result.plot (every axis's column), to_pandas
    res = mjb.load("fivebar").simulate(mode="pid", backend="reduced", t_end=0.02)
    fig = res.plot()
    assert len(fig.axes) == 3 and len(fig.axes[0].lines) == 2  # A and E
    df = res.to_pandas()
    assert {"A:current_A", "E:voltage_V"} <= set(df.columns)
    for fn in (mjb.hold_point, mjb.step_check):  # the API's one-axis studies: one line each
        with pytest.raises(mjb.ParameterError, match=rf"^{fn.__name__}: the machine has 2 axes \(A, E\); "
                                                     rf"{fn.__name__} is one-axis only"):
            fn("fivebar", **({"dq": 0.01} if fn is mjb.step_check else {}))
    run = mjb.simulate(mjb.load("fivebar").machine("ct"), backend="reduced", t_end=0.01)
    assert "2 axes (A: DC motor (z = 10" in run.describe() and "computed_torque controller" in run.describe()
