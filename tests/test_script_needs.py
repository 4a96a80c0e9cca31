"""What a script needs from a run (issue 27 item 7): torque loads on links, every joint coordinate
in the result, full-precision CSV, the acceleration at t = 0, end-state metrics, joints shared by
more than two bodies — checked against virtual work by hand, closed forms, the other backend and
the published reference solution of Andrews' squeezer (Hairer & Wanner)."""
from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjbench import compiled as C
from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.backends.multibody import build_model
from mjbench.drives.ideal import TorqueDrive
from mjbench.errors import ScenarioError
from mjbench.machine import Machine
from mjbench.mechanisms.linkage import Linkage, LinkageParams, linkage_load
from mjbench.runner import backend_options
from mjbench.trajectory import Trajectory

DATA = Path(__file__).parent / "data"
FOURBAR = tomllib.loads((DATA / "linkages" / "incerti2012.toml").read_text())


def _fourbar_linkage(loads, gravity=(0.0, 0.0)):
    raw = copy.deepcopy(FOURBAR)
    raw["loads"], raw["gravity"] = loads, list(gravity)
    return raw


def _scenario(mech_raw, drive=None, mode=None, t_end=0.3, joints=False, dt=1e-4):
    return S.from_raw({"scenario": {"name": "script-needs"}, "mechanism": mech_raw,
                       "drive": drive or {"type": "torque"},
                       "simulation": {"t_end": t_end, "dt": dt, "record_dt": 1e-3, "record_joints": joints},
                       "modes": {"m": mode or {"type": "constant", "torque": 3.0}}})


# ============================================================================ 2. torque loads on links
def _virtual_work_cases(q):
    """(loads, T·dθ/dq by hand) on the seed-000 four-bar: R = γ̇/α̇, Q = β̇/α̇ of its closed form."""
    fb = S.make_mechanism(S.load("incerti2012"))
    _, _, Qc, Rc = fb.ratios(q)
    xP = fb.a * np.cos(q) + 0.5 * fb.b * np.cos(fb.angles(q)[0])  # the coupler's mid-point P
    return {
        "constant on the rocker": ([{"link": "rocker", "torque": 2.0}], 2.0 * Rc),
        "angle table on the coupler": ([{"link": "coupler", "q": [0.0, math.pi, 2 * math.pi], "T": [1.0, -3.0, 1.0]}],
                                       np.interp(q % (2 * np.pi), [0, math.pi, 2 * math.pi], [1, -3, 1]) * Qc),
        "gated on the rocker": ([{"link": "rocker", "torque": -1.5, "active": "stroke_along"}],
                                np.where(Rc > 0, -1.5 * Rc, 0.0)),
        "stroke table on the rocker": ([{"link": "rocker", "point": "coupler.P", "direction": [1.0, 0.0],
                                         "s": [0.0, 0.3], "T": [0.0, 3.0]}], np.interp(xP, [0, 0.3], [0, 3.0]) * Rc),
    }


def test_torque_load_on_a_link_is_its_virtual_work_in_both_models():
    """A torque T on a link does the work T·δθ_link: on the input that is T·dθ/dq, written here from
    the four-bar's closed-form velocity ratios.  The reduced model's Q_ext (linkage_torque) and
    MuJoCo's generalised forces (linkage_load) projected on the velocity map both equal it."""
    q = np.linspace(0.0, 2 * np.pi, 721)
    for name, (loads, ref) in _virtual_work_cases(q).items():
        mech = Linkage(LinkageParams.model_validate(_fourbar_linkage(loads)))
        got = np.asarray(mech.external_torque(q, 0.0 * q, 0.0))
        assert np.max(np.abs(got - ref)) <= 1e-10 * np.max(np.abs(ref)), name
        assert np.max(np.abs(ref)) > 0.5, name
        _, m = build_model(Machine(mech, TorqueDrive(), None), {"timestep": 1e-4})
        d = mujoco.MjData(m)
        P = C.python_view(mech.load_form(m, d).P)
        for x in q[::24]:
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = mech.initial_qpos(m, float(x)), 0.0, 0.0
            linkage_load(0.0, P)
            Qm = float(d.qfrc_applied @ mech.initial_qvel(m, float(x), 1.0))
            assert Qm == pytest.approx(float(np.interp(x, q, ref)), abs=1e-9 * np.max(np.abs(ref))), (name, x)


def test_torque_loads_run_alike_on_both_backends_with_the_same_bits():
    """The four-bar under a torque source with a gated torque on the rocker and an angle-table torque
    on the coupler: compiled = CPython on each backend, multibody ≈ reduced, and the loads act."""
    loads = [{"link": "rocker", "torque": -4.0, "active": "stroke_along"},
             {"link": "coupler", "q": [0.0, 3.0, 6.0], "T": [0.0, 2.0, -1.0]}]
    scn = _scenario(_fourbar_linkage(loads, (0.0, -9.81)))
    out = {}
    for b in ("reduced", "multibody"):
        py = simulate(S.make_machine(scn, "m"), b, 0.3, loop="python")
        cc = simulate(S.make_machine(scn, "m"), b, 0.3, loop="compiled")
        assert cc.meta["loop"] == "compiled", cc.meta["loop_reason"]
        np.testing.assert_array_equal(py.data, cc.data)
        out[b] = cc
    diff = M.compare(out["reduced"], out["multibody"])["max_rel_diff"]
    assert diff < 5e-6, diff  # measured 5.8e-7
    free = simulate(S.make_machine(_scenario(_fourbar_linkage([], (0.0, -9.81))), "m"), "reduced", 0.3)
    assert abs(free.q[-1] - out["reduced"].q[-1]) > 100 * diff * np.max(np.abs(free.qd))  # the loads act


def test_torque_load_description_errors():
    for load, msg in (({"link": "rocker"}, "give either torque or the table T"),
                      ({"link": "rocker", "T": [1.0, 2.0]}, "needs exactly one of q"),
                      ({"link": "rocker", "torque": 1.0, "point": "coupler.P"}, "would be ignored"),
                      ({"link": "rocker", "s": [0.0, 1.0], "T": [1.0, 2.0]}, "needs point and direction"),
                      ({"link": "rocker", "q": [0.0, 7.0], "T": [1.0, 2.0]}, "more than one turn"),
                      ({"link": "rocker", "force": 3.0}, "force, F and the profiles are a point load's"),
                      ({"link": "ground", "torque": 1.0}, "'ground' is not a moving link"),
                      ({"point": "coupler.P", "direction": [1, 0], "torque": 1.0}, "belong to a torque load")):
        with pytest.raises(ScenarioError) as e:
            _scenario(_fourbar_linkage([load]))
        assert msg in str(e.value), (load, str(e.value))


# ============================================================================ 3. every joint coordinate
def test_joint_columns_on_both_backends():
    """[simulation] record_joints: one coordinate and one rate per MuJoCo joint; MuJoCo's own on the
    multibody backend, the four-bar's closed forms on the reduced one; compiled = CPython; the two
    agree as the crank does; the input joint is the crank angle."""
    scn = S.load("incerti2012", ["simulation.record_joints=true"])
    names = ("joint_crank_rad", "joint_crank_rate_rad_s", "joint_coupler_joint_rad", "joint_coupler_joint_rate_rad_s",
             "joint_rocker_joint_rad", "joint_rocker_joint_rate_rad_s")
    out = {}
    for b in ("multibody", "reduced"):
        o = backend_options(scn, b)
        py = simulate(S.make_machine(scn, "open"), b, 0.3, options=o, loop="python")
        cc = simulate(S.make_machine(scn, "open"), b, 0.3, options=o, loop="compiled")
        assert cc.meta["loop"] == "compiled", cc.meta["loop_reason"]
        np.testing.assert_array_equal(py.data, cc.data)
        assert cc.columns[11:] == names
        out[b] = cc
    mb, rd = out["multibody"], out["reduced"]
    np.testing.assert_array_equal(mb["joint_crank_rad"], mb.q)
    np.testing.assert_allclose(rd["joint_crank_rad"], rd.q, atol=1e-12)
    assert rd.meta["joint_columns"]["max_rel_error"] <= 1e-9
    fb = S.make_mechanism(scn)
    beta, gamma, Qr, Rr = fb.ratios(rd.q)  # the closed forms at the reduced run's own angles
    np.testing.assert_allclose(np.mod(rd["joint_rocker_joint_rad"] - gamma + np.pi, 2 * np.pi) - np.pi, 0.0, atol=1e-9)
    np.testing.assert_allclose(rd["joint_rocker_joint_rate_rad_s"], Rr * rd.qd, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(rd["joint_coupler_joint_rate_rad_s"], (Qr - 1.0) * rd.qd, rtol=1e-8, atol=1e-8)
    peak = np.max(np.abs(rd.qd))
    for c in names:
        scale = peak if c.endswith("_s") else 1.0
        assert np.max(np.abs(mb[c] - rd[c])) <= 2e-5 * scale, c


def test_joint_columns_where_the_reduced_model_has_none():
    """A platform (internal coordinates): MuJoCo's joints on the multibody backend; the reduced
    backend says why it has none."""
    scn = S.load("incerti-belt", ["simulation.record_joints=true"])
    mode = scn.mode()
    rd = simulate(S.make_machine(scn, mode), "reduced", 0.05, options=backend_options(scn, "reduced"))
    assert "not provided" in rd.meta["joint_columns"] and not any(c.startswith("joint_") for c in rd.columns)
    mb = simulate(S.make_machine(scn, mode), "multibody", 0.05, options=backend_options(scn, "multibody"))
    assert {c for c in mb.columns if c.startswith("joint_")} >= {"joint_motor_rad", "joint_motor_rate_rad_s"}


# ============================================================================ 4. CSV at full precision
def test_csv_round_trips_every_float(tmp_path):
    scn = _scenario(_fourbar_linkage([{"link": "rocker", "torque": -1.0}]), joints=True)
    tr = simulate(S.make_machine(scn, "m"), "reduced", 0.2, options=backend_options(scn, "reduced"))
    assert np.isnan(tr.current).all()  # NaN columns too
    path = tmp_path / "trajectory.csv"
    tr.write_csv(path)
    back = Trajectory.read_csv(path)
    assert back.columns == tr.columns
    assert back.data.tobytes() == np.ascontiguousarray(tr.data).tobytes()  # every bit, NaNs included
    short = np.array([[float("%.10g" % v) for v in row] for row in tr.data])
    assert not np.array_equal(short, tr.data, equal_nan=True)  # the old format lost digits here
    assert sorted(p.name for p in tmp_path.iterdir()) == ["trajectory.csv"]  # written whole, no temp file left


# ============================================================================ 5. the acceleration at t = 0
@pytest.mark.parametrize("backend", ("reduced", "multibody"))
def test_acceleration_row_0_is_the_forward_difference_of_the_first_step(backend):
    """Recording every step: row 0 = (q̇_1 − q̇_0)/h (no longer 0), row n ≥ 1 the backward difference,
    bit for bit, compiled = CPython (the controller still sees 0 at t = 0)."""
    scn = S.load("incerti2012")
    h = scn.simulation.dt
    rows = []
    for loop in ("python", "compiled"):
        tr = simulate(S.make_machine(scn, "pid"), backend, 0.02, record_dt=h, loop=loop)
        rows.append(tr.data)
        qd = tr.qd
        assert tr.qdd[0] == (qd[1] - qd[0]) * (1.0 / h) and abs(tr.qdd[0]) > 10.0  # K_p·t = 0: gravity
        np.testing.assert_array_equal(tr.qdd[1:], (qd[1:] - qd[:-1]) * (1.0 / h))
    np.testing.assert_array_equal(rows[0], rows[1])


# ============================================================================ 6. end-state metrics
def test_end_state_metrics_and_the_settling_time():
    """final_* are the last samples; the settling time of a first-order speed lag (a proportional speed
    source on a flywheel) is the closed form's within one record step; the names are known metrics."""
    J, kv, w = 0.01, 0.2, 30.0
    scn = S.from_raw({"scenario": {"name": "lag"}, "mechanism": {"type": "rotor", "J": J},
                      "drive": {"type": "speed", "k_v": kv}, "simulation": {"t_end": 0.3, "record_dt": 1e-3},
                      "modes": {"m": {"type": "constant", "speed": w}}})
    tr = simulate(S.make_machine(scn, "m"), "reduced", 0.3)
    m = M.summary(tr, band_rel=0.02)
    for key, col in (("final_crank_angle_rad", "crank_angle_rad"), ("final_crank_speed_rad_s", "crank_speed_rad_s"),
                     ("final_torque_crank_Nm", "torque_crank_Nm"), ("final_power_mech_W", "power_mech_W")):
        assert m[key] == tr[col][-1]
    assert math.isnan(m["final_current_A"]) and math.isnan(m["final_voltage_V"])
    tau, T = J / kv, float(tr.t[-1])
    wend = w * (1 - math.exp(-T / tau))
    assert m["speed_settling_band_rad_s"] == pytest.approx(0.02 * wend, rel=1e-6)
    t_star = -tau * math.log(math.exp(-T / tau) + 0.02 * wend / w)
    assert t_star <= m["speed_settling_time_s"] < t_star + 1e-3 + 1e-12
    numeric = {k for k, v in m.items() if isinstance(v, (int, float))}
    assert numeric <= set(M.SUMMARY_METRICS) and {k for k in M.SUMMARY_METRICS if k.startswith("final_")} <= numeric
    assert {"final_crank_angle_rad", "speed_settling_time_s"} <= set(M.known_metrics())


# ============================================================================ 7. joints shared by > 2 bodies
REFERENCE_T = 0.03  #: the IVP test set's reference solution of the squeezer at t = 0.03 s
REFERENCE = {  # angle [rad], rate [rad/s]: β, Θ, γ, φ, δ, Ω, ε
    "O": (0.1581077119629904e+2, 0.1139920302151208e+4), "P": (-0.1575637105984298e+2, -0.1424379294994111e+4),
    "B": (0.4082224013073101e-1, 0.1103291221937134e+2), "Q": (-0.5347301163226948, 0.1929337464421385e+2),
    "A5": (0.5244099658805304, 0.5735699284790808), "R": (0.5347301163226948, -0.1929337464421385e+2),
    "A7": (0.1048080741042263e+1, 0.3231791658026955)}
BETA_DDOT_0 = 14222.4439199541138705911625887  #: β̈(0) of the benchmark's consistent initial values


@pytest.fixture(scope="module")
def squeezer():
    scn = S.load("squeezer")
    return scn, {b: simulate(S.make_machine(scn, "constant"), b, REFERENCE_T, record_dt=scn.simulation.record_dt,
                             options=backend_options(scn, b), loop="python") for b in ("reduced", "multibody")}


def test_the_squeezer_has_a_quaternary_joint_closed_by_connects(squeezer):
    """Point E joins four bodies (three joints), the frame pivot A two: our solver counts one degree of
    freedom, the MJCF's tree holds the benchmark's seven coordinates and E3, E4, E6 are connects."""
    scn, _ = squeezer
    mech = S.make_mechanism(scn)
    _, m = build_model(S.make_machine(scn, "constant"), {"timestep": 1e-5})
    assert m.njnt == 7 and m.neq == 3
    assert {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(7)} == set(REFERENCE)
    assert {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) for e in range(3)} == {
        "closure_E3", "closure_E4", "closure_E6"}
    assert mech.table_info["rel_error_dJ"] < 1e-10
    # a cycle among the shared joints (b3.E–b4.E besides b2–b3, b2–b4) is redundant: accepted, the
    # same motion (docs/linkages.md §1.1)
    red = copy.deepcopy(scn.raw)
    red["mechanism"]["joints"].append({"name": "E34", "at": ["b3.E", "b4.E"]})
    red = S.from_raw(red)
    assert S.make_mechanism(red).c.closures == [7, 8, 9, 10]
    a = simulate(S.make_machine(red, "constant"), "reduced", 0.01, options=backend_options(red, "reduced"),
                 loop="python")
    b = simulate(S.make_machine(scn, "constant"), "reduced", 0.01, options=backend_options(scn, "reduced"),
                 loop="python")
    assert np.max(np.abs(a.q - b.q)) <= 1e-10


def test_the_squeezer_matches_the_published_reference_solution(squeezer):
    """All seven coordinates and rates at t = 0.03 s against the reference (joint columns), on our
    solver (reduced) and on MuJoCo; β̈(0) (the record's row 0) against the benchmark's; multibody vs
    reduced over the run."""
    _, tr = squeezer
    rd, mb = tr["reduced"], tr["multibody"]
    assert rd.t[-1] == pytest.approx(REFERENCE_T, abs=1e-12)
    tol = {"reduced": (3e-9, 1e-7), "multibody": (3e-6, 5e-4)}  # angle [rad], rate (relative)
    for b, t in tr.items():
        ang, rate = tol[b]
        for j, (a_ref, w_ref) in REFERENCE.items():
            assert abs(t[f"joint_{j}_rad"][-1] - a_ref) <= ang, (b, j, t[f"joint_{j}_rad"][-1] - a_ref)
            assert abs(t[f"joint_{j}_rate_rad_s"][-1] - w_ref) <= rate * abs(w_ref), (b, j)
    assert abs(rd.q[-1] - REFERENCE["O"][0]) <= 2e-9 and abs(rd.qd[-1] / REFERENCE["O"][1] - 1) <= 3e-10
    assert abs(rd.qdd[0] / BETA_DDOT_0 - 1) <= 5e-6 and abs(mb.qdd[0] / BETA_DDOT_0 - 1) <= 3e-5
    assert M.compare(rd, mb)["max_rel_diff"] <= 3e-6
    assert mb.closure.max() <= 1e-8
    assert np.all(rd["torque_crank_Nm"] == 0.033)
    # no losses: the torque's work T·Δβ is the kinetic + spring energy gained (the linkage's J, E_p)
    mech = S.make_mechanism(S.load("squeezer"))
    for t in tr.values():
        q, qd = np.array([t.q[0], t.q[-1]]), np.array([t.qd[0], t.qd[-1]])
        E = 0.5 * mech.reduced(q)[0] * qd ** 2 + mech.potential_energy(q)
        assert E[1] - E[0] == pytest.approx(0.033 * (q[1] - q[0]), rel=5e-6 if t is mb else 1e-9)  # MuJoCo: its soft closure
