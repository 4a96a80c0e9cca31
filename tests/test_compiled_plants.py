"""Everything mechanical compiles: every shipped scenario and mode, on both backends, runs the
kernel's compiled loop and gives the same bits as the CPython loop (the reference: the same laws
executed by Python); so do the drive train's mechanical elements (compliant gear with backlash,
mesh stiffness, dry friction with a Stribeck drop, friction on joints away from the crank) on
rigid and elastic mechanisms, and batches equal their single runs.

Independent paths besides the CPython execution: the laws against the closed forms they encode
(the platforms' equations of motion, the periodic and range tables against their NumPy/SciPy
splines, the gear's mesh law), and a reduced-vs-multibody comparison of a user MJCF with a slide
input (now compiled through its own table law).  The physics of the shipped machines is validated
in their own test files (test_fourbar_multibody, test_quickreturn, test_vibration, test_linkage_*,
test_mjcf_mechanism, test_drivetrain).
"""
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from controllers import PID, ConstantVoltage
from mjbench import kernel
from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.backends import multibody, reduced, simulate, simulate_many
from mjbench.drivetrain import Friction, Gear
from mjbench.drivetrain.gear import DrivenMechanism, friction_level, mesh_torque_law
from mjbench.errors import SimulationDiverged
from mjbench.machine import Machine

DATA = Path(__file__).parent / "data"
BACKENDS = ("reduced", "multibody")
T_END = 0.1

#: machines with several motors are checked compiled = CPython in tests/test_multi_axis.py (their loops
#: take ≈ 30 s each to compile)
MULTI_AXIS = {"fivebar", "arm2r"}
SHIPPED = [(name, mode) for name in S.builtin_names() if name not in MULTI_AXIS for mode in S.modes(S.load(name))]


def _plant(backend, mc):
    return multibody.MultibodyPlant(mc) if backend == "multibody" else reduced.ReducedPlant(mc)


def _both_loops(make, backend, t_end=T_END, **kw):
    """(python, compiled) trajectories of fresh machines from ``make()``."""
    py = simulate(make(), backend, t_end, loop="python", **kw)
    cc = simulate(make(), backend, t_end, loop="compiled", **kw)
    assert py.meta["loop"] == "python", py.meta
    assert cc.meta["loop"] == "compiled", cc.meta["loop_reason"]  # a silent fallback fails here
    return py, cc


def _same_bits(make, backend, t_end=T_END, **kw):
    py, cc = _both_loops(make, backend, t_end, **kw)
    assert py.columns == cc.columns and py.n == cc.n == int(round(t_end / 1e-3)) + 1
    elec = [cc.columns.index(c) for c in ("current_A", "voltage_V", "power_elec_W")]
    mech = [i for i in range(10) if i not in elec]
    assert np.all(np.isfinite(cc.data[:, mech]))
    # the electrics: a DC motor's, finite; an ideal drive has none (NaN, trajectory.COLUMNS)
    assert np.all(np.isfinite(cc.data[:, elec])) or np.all(np.isnan(cc.data[:, elec]))
    np.testing.assert_array_equal(py.data, cc.data)
    return cc


# ================================================================ every shipped scenario and mode
def test_the_list_covers_every_shipped_scenario():
    """Every TOML file shipped in mjbench/scenarios, every mode of each."""
    files = {p.stem for p in (Path(S.__file__).parent / "scenarios").glob("*.toml")}
    names = {n for n, _ in SHIPPED} | MULTI_AXIS
    assert names == files and len(names) >= 11
    assert len(SHIPPED) == sum(len(S.modes(S.load(n))) for n in files - MULTI_AXIS)


def test_every_shipped_composition_is_all_laws():
    """Every slot of every shipped scenario's composition is a law (the compiled loop takes it all);
    that the compiled loop gives the CPython loop's bits on each is tests/test_digests.py's (both
    loops against one recorded digest per scenario, mode and backend)."""
    for name, mode in SHIPPED:
        scn = S.load(name)
        for backend in BACKENDS:
            mc = S.make_machine(scn, mode)
            pl = _plant(backend, mc)
            pl.start()
            pr = kernel.Program.build(pl, mc, pl.h, kernel.control_every(mc.controller, pl.h))
            getattr(pl, "finish", lambda: None)()
            assert pr.compiled, (name, mode, backend, pr.reasons)


# ================================================================ the drive train's mechanical elements
def _driven(name, mode=None, gear=None, friction=None, sets=(), ctrl=None):
    scn = S.load(name, list(sets))
    mc = S.make_machine(scn, mode or sorted(scn.modes)[0])
    mech = DrivenMechanism(mc.mechanism, mc.drive, gear, friction)
    return Machine(mech, mc.drive, ctrl() if ctrl else mc.controller, mc.q0, mc.qd0, mc.I0)


STRIBECK = dict(coulomb=0.02, breakaway=0.03, stribeck_speed=2.0)
ROCKER = {"rocker_joint": {"coulomb": 0.1, "breakaway": 0.15, "stribeck_speed": 0.5, "viscous": 0.01}}
VARIANTS = {
    # compliant gear: backlash (contact damping toggled on the MuJoCo tendon every step) / stiff mesh
    "fourbar-backlash": lambda: _driven("incerti2012", "pid", Gear(backlash=math.radians(0.2))),
    "fourbar-stiff-mesh-friction": lambda: _driven("incerti2012", "pid", Gear(stiffness=2000.0, damping=0.05),
                                                   Friction(**STRIBECK, joints=ROCKER)),
    # rigid gear with friction: motor (Stribeck: dof_frictionloss edited every step) and a joint away from the crank
    "fourbar-friction": lambda: _driven("incerti2012", "open", None, Friction(**STRIBECK, joints=ROCKER)),
    # elastic platform behind a compliant gear: two internal coordinates (ψ, then δ)
    "belt-backlash": lambda: _driven("incerti-belt", None, Gear(backlash=math.radians(0.2)), Friction(0.01),
                                     sets=("mechanism.J_motor=1e-3",)),
    "bezier-friction": lambda: _driven("incerti-bezier", None, None, Friction(**STRIBECK)),
    # untabulated external torques under friction and backlash: cutting force, point load
    "quickreturn-backlash": lambda: _driven("yigit2023", "pid", Gear(backlash=math.radians(0.3)), Friction(0.05)),
    "press-friction": lambda: _driven("press-slidercrank", "pi", None, Friction(0.05, 0.08, 1.0)),
}


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("variant", list(VARIANTS))
def test_drive_train_mechanics_compiled_equals_cpython(variant, backend):
    tr = _same_bits(VARIANTS[variant], backend)
    mech = VARIANTS[variant]().mechanism
    for name in mech.internal:  # the plant records every internal coordinate and its rate
        assert f"{name}_rad" in tr.columns and f"{name}_rate_rad_s" in tr.columns
    if mech.compliant:
        d = tr["gear_deflection_rad"]
        assert np.max(np.abs(d)) > 0.0
        # the motor column is the motor's own speed: crank speed + deflection rate (× z)
        np.testing.assert_allclose(tr.omega, mech.z * (tr.qd + tr["gear_deflection_rate_rad_s"]), rtol=1e-12)


def test_compliant_gear_plant_returns_the_deflection_on_both_backends():
    """The kernel's (q, q̇, δ, δ̇): δ is the gear's deflection on both plants (reduced: its last
    internal coordinate; MuJoCo: motor hinge − crank), the two backends agree on it."""
    make = VARIANTS["fourbar-backlash"]
    red = simulate(make(), "reduced", 0.2, loop="compiled")
    mb = simulate(make(), "multibody", 0.2, loop="compiled")
    beta = math.radians(0.2)
    for tr in (red, mb):
        d = tr["gear_deflection_rad"]
        assert np.max(np.abs(d)) > 0.5 * beta  # the mesh takes up the play
    scale = np.max(np.abs(red["gear_deflection_rad"]))
    diff = np.abs(red["gear_deflection_rad"] - mb["gear_deflection_rad"])
    # in contact the backends agree closely (measured median 1.9e-6 of the peak); the impacts while
    # crossing the play are discontinuities both RK4s pass a step apart (measured RMS 1.7 % of the peak)
    assert np.median(diff) < 1e-5 * scale and np.sqrt(np.mean(diff ** 2)) < 0.05 * scale
    mx, _ = M.rel_difference(red.t, red.qd, mb.t, mb.qd)
    assert mx < 5e-3, mx  # measured 1.6e-3 of the peak speed (the impacts)


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_of_drive_train_variants_equals_single_runs(backend):
    """N machines with different backlash and friction in one batch (threads): each equals its
    single CPython run bit for bit; the MuJoCo models are per simulation (per-step model edits)."""
    def make(i):
        return _driven("incerti2012", "pid", Gear(backlash=math.radians(0.1 * (i + 1))),
                       Friction(0.01 * (i + 1), 0.015 * (i + 1), 2.0))
    res = simulate_many([make(i) for i in range(3)], backend, T_END, loop="compiled")
    assert res.meta["loop"] == "compiled" and not res.diverged.any()
    for i in range(3):
        single = simulate(make(i), backend, T_END, loop="python")
        np.testing.assert_array_equal(res.trajectory(i).data, single.data)
    assert not np.array_equal(res.trajectory(0).data, res.trajectory(2).data)


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_of_shipped_machines_equals_single_runs(backend):
    """A batch of elastic platforms (internal coordinates, different belts) and one of generic
    linkages with point loads: each run equals its single run."""
    for name, sets in (("incerti-bezier", [(), ("mechanism.k=6000",), ("mechanism.c=20",)]),
                       ("toggle-press", [(), ("drive.R=1.2",)])):
        res = simulate_many([S.make_machine(S.load(name, list(o))) for o in sets], backend, T_END, loop="compiled")
        assert res.meta["loop"] == "compiled" and not res.diverged.any()
        for i, o in enumerate(sets):
            single = simulate(S.make_machine(S.load(name, list(o))), backend, T_END, loop="python")
            np.testing.assert_array_equal(res.trajectory(i).data, single.data)


@pytest.mark.parametrize("backend", BACKENDS)
def test_linkage_with_a_damped_closing_hinge_compiles(backend):
    """Seed 002's four-bar (bearing friction in every hinge) as a generic linkage: the loop-closing
    hinge C carries viscous friction, a torque pair from the relative rate in MuJoCo (the load law
    linkage_load) and a tabulated D(q) in the reduced model; both loops give the same bits."""
    from mjbench.mechanisms.linkage import table_from_fourbar

    raw, src = S.read_raw("hulako2025-model1")
    fb = S.make_mechanism(S.load("hulako2025-model1"))
    assert fb.damping_C > 0
    raw["mechanism"] = table_from_fourbar(fb)
    raw["aliases"] = {}
    raw["modes"] = {"open": {"type": "open", "voltage": 12.0}}
    raw["simulation"]["mode"] = "open"
    raw.get("paper", {}).pop("figures", None)
    scn = S.from_raw(raw, src)
    mech = S.make_mechanism(scn)
    assert mech.has_multibody_load() and not mech.params.loads
    _same_bits(lambda: S.make_machine(scn, "open"), backend)


def test_divergence_is_the_same_in_both_loops():
    """A compliant gear on the belt platform without motor-side inertia (J_motor = 0): the mesh is
    far too stiff for RK4 at 0.1 ms and the reduced run diverges — at the same step, with the same
    message, in both loops (the laws turn a non-finite angle into NaN; nothing raises inside)."""
    def make():
        return _driven("incerti-belt", None, Gear(backlash=math.radians(0.2)), ctrl=lambda: ConstantVoltage(20.0))
    msgs = []
    for loop in ("python", "compiled"):
        with pytest.raises(SimulationDiverged) as e:
            simulate(make(), "reduced", T_END, loop=loop)
        msgs.append(str(e.value))
    assert msgs[0] == msgs[1] and "diverged at t = " in msgs[0]


# ================================================================ the laws against their closed forms
def test_platform_law_is_the_equations_of_motion():
    """platform_xdd / reduced_accel against the module's equations written out here:
    (J_a + J_in)·φ̈ = τ − c_a·φ̇ + ρ(kψ + cψ̇), ψ̈ = −(kψ + cψ̇)/J − ρφ̈ (both variants)."""
    rng = np.random.default_rng(3)
    for name in ("incerti-belt", "incerti-bezier"):
        mech = S.make_mechanism(S.load(name))
        o = mech.oscillator()
        for _ in range(20):
            qd, psi, psid, tau, Ja, ca = rng.normal(size=6) * (10.0, 1e-3, 0.1, 5.0, 1e-4, 1e-3)
            Ja = abs(Ja) + 1e-4
            T = o.k * psi + o.c * psid
            qdd = (tau - ca * qd + o.ratio * T) / (Ja + mech.J_input)
            got = mech.reduced_accel(0.0, 0.3, qd, (psi,), (psid,), tau, Ja, ca)
            assert got[0] == pytest.approx(qdd, rel=1e-13, abs=1e-13)
            assert got[1][0] == pytest.approx(-T / o.J - o.ratio * qdd, rel=1e-12, abs=1e-12)


def test_gear_laws_against_their_definitions():
    """Mesh torque: a dead band of ±β/2 with stiffness k and damping c in contact; friction level
    F_C + (F_S − F_C)·exp(−(v/v_S)²)."""
    k, c, hb = 2000.0, 0.05, 0.01
    for d, dd in ((0.005, 1.0), (-0.009, -3.0), (0.02, 0.5), (-0.03, 2.0)):
        ref = 0.0 if abs(d) <= hb else k * (d - math.copysign(hb, d)) + c * dd
        assert mesh_torque_law(d, dd, k, c, hb) == pytest.approx(ref, rel=1e-14, abs=1e-15)
    assert mesh_torque_law(0.003, 2.0, k, c, 0.0) == pytest.approx(k * 0.003 + c * 2.0)
    for v in (0.0, 0.5, 2.0, 7.0):
        assert friction_level(v, 0.02, 0.03, 2.0) == pytest.approx(0.02 + 0.01 * math.exp(-(v / 2.0) ** 2), rel=1e-15)
    assert friction_level(3.0, 0.02, 0.02, math.inf) == 0.02


def test_compliant_gear_accelerations_are_the_two_inertia_equations():
    """DrivenMechanism.reduced_accel (the compliant_accel law around the rotor's model law) against
    the two-inertia equations written out: J_b·α̈ = T_g + Q_load(α̇) over the crank, (J_eq − J_b)·θ̈_m =
    τ − c·θ̇_m − T_g on the motor, T_g = k(δ − β/2) + c_g·δ̇ in contact."""
    from mjbench.drive import DCMotorDrive
    from mjbench.mechanisms.rotor import Rotor

    drv = DCMotorDrive(R=2.0, L=9e-3, k_m=0.48, J_m=1.3e-3, J_a=0.0, J_b=2e-4, z=3.0, lam=1e-3)
    rot = Rotor(1e-2, load_torque=0.3, damping=0.02)
    mech = DrivenMechanism(rot, drv, Gear(backlash=0.02, stiffness=500.0, damping=0.1))
    mech.set_step(1e-4)
    Ja, ca = float(drv.J_eq), float(drv.crank_damping)
    for d, dd in ((0.015, 0.4), (-0.004, 1.0), (-0.03, -0.2)):
        qd, tau = 2.0, 1.5
        Tg = 0.0 if abs(d) <= 0.01 else 500.0 * (d - math.copysign(0.01, d)) + 0.1 * dd
        add = (tau - ca * (qd + dd) - Tg) / (Ja - drv.J_b)
        qdd = (Tg + 0.3 - 0.02 * qd) / (drv.J_b + 1e-2)
        a, (x,) = mech.reduced_accel(0.0, 0.7, qd, (d,), (dd,), tau, Ja, ca)
        assert a == pytest.approx(qdd, rel=1e-13) and x == pytest.approx(add - qdd, rel=1e-12, abs=1e-12)


def test_periodic_table_law_equals_its_numpy_evaluation():
    """ptable_channel (the law the linkage's loads and Python scalars use) against the table's own
    NumPy evaluation of the same spline, at random angles over several turns."""
    from mjbench.mechanisms.linkage_kin import ptable_channel

    mech = S.make_mechanism(S.load("press-slidercrank"))
    tab = mech.c.table
    q = np.random.default_rng(5).uniform(-15.0, 15.0, 300)
    ref = tab(q)
    for ch in range(tab.k):
        got = np.array([ptable_channel(float(x), ch, tab.P) for x in q])
        scale = max(np.max(np.abs(ref[:, ch])), 1e-300)
        assert np.max(np.abs(got - ref[:, ch])) <= 1e-14 * scale, ch
    assert math.isnan(ptable_channel(math.inf, 0, tab.P)) and math.isnan(ptable_channel(math.nan, 0, tab.P))


def test_linkage_loads_law_matches_the_load_description():
    """The point-load law (constant and table kinds, stroke gates) against LoadSpec's definition
    evaluated here with NumPy: the toggle press's coining load F(s) piecewise linear in s, on its
    working stroke only."""
    from mjbench.mechanisms.linkage import load_force

    mech = S.make_mechanism(S.load("toggle-press"))
    ld = mech.params.loads[0]
    q = np.linspace(0.0, 2 * np.pi, 721)
    vals = mech.c.table(q)
    for k, (ks, kd, _) in enumerate(mech._loads):
        s, ds = vals[:, ks], vals[:, kd]
        if ld.force is not None:
            mag = np.full_like(s, float(ld.force))
        else:
            mag = np.interp(s, np.array(ld.s, float), np.array(ld.F, float))
        gate = {"always": np.ones_like(ds, bool), "stroke_along": ds > 0, "stroke_against": ds < 0}[ld.active]
        ref = np.where(gate, mag, 0.0)
        got = np.array([load_force(k, float(a), float(b), mech.loads_P) for a, b in zip(s, ds)])
        np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-9 * np.max(np.abs(ref)))
        assert np.max(np.abs(ref)) > 0.0


def test_mjcf_slide_input_runs_compiled_and_agrees_with_mujoco():
    """A user MJCF with a slide input (elliptic trammel): its reduced model is its own spline over
    the slide range (range_table_model); the law equals SciPy's spline, the run compiles, and the
    reduced run follows the MuJoCo run."""
    from mjbench.mechanisms.mjcf import range_channel

    raw, src = S.read_raw("incerti2012")
    raw["mechanism"] = {"type": "mjcf", "file": str(DATA / "trammel.xml"), "input_joint": "x", "keyframe": "up",
                        "table_nodes": 512}
    raw["aliases"] = {}
    raw["initial"] = {"q0": 0.0, "qd0": 0.0}
    raw["drive"].update({"v_max": 5.0})
    scn = S.from_raw(raw, src)
    mech = S.make_mechanism(scn)
    tab = mech._tab
    x = np.random.default_rng(2).uniform(tab.lo, tab.hi, 200)
    ref = tab(x)
    for ch in range(5):
        got = np.array([range_channel(float(v), ch, tab.P) for v in x])
        assert np.max(np.abs(got - ref[:, ch])) <= 1e-12 * max(np.max(np.abs(ref[:, ch])), 1e-300)
    assert math.isnan(range_channel(tab.hi + 1e-3, 0, tab.P))

    def make():
        return dataclasses.replace(S.make_machine(scn, "open"), controller=ConstantVoltage(0.5))
    red = _same_bits(make, "reduced", 0.05)
    assert red.meta["model"] == "table"
    mb = simulate(make(), "multibody", 0.05, loop="compiled")
    assert mb.meta["loop"] == "compiled"
    mx, _ = M.rel_difference(red.t, red.qd, mb.t, mb.qd)
    assert np.max(np.abs(red.qd)) > 1e-3 and mx < 1e-7, mx  # measured 4.7e-10 (a MuJoCo-derived model)


def test_reduced_model_choice_and_reasons():
    """``model = "closed"`` and ``solve_ivp`` run the CPython loop and say why; the default table
    model is compiled and recorded in the meta."""
    scn = S.load("yigit2023")
    for kw, why in (({"model": "closed"}, "closed forms"), ({"method": "solve_ivp"}, "solve_ivp")):
        pl = reduced.ReducedPlant(S.make_machine(scn, "open"), **kw)
        pl.start()
        f = pl.form()
        assert not f.compiled and why in f.reason
    tr = simulate(S.make_machine(scn, "open"), "reduced", 0.01, loop="compiled")
    assert tr.meta["loop"] == "compiled" and tr.meta["model"] == "table" and tr.meta["table_max_rel_error"] <= 1e-9
    # the closed forms and the table: the same machine within the table's accuracy
    a = simulate(S.make_machine(scn, "open"), "reduced", 0.3, model="closed")
    b = simulate(S.make_machine(scn, "open"), "reduced", 0.3)
    assert np.max(np.abs(a.qd - b.qd)) <= 1e-9 * np.max(np.abs(a.qd))  # measured 2.5e-16 (table error ≤ 2e-10)


def test_open_loop_pid_override_on_platforms_compiles():
    """The platforms with a speed PID built here (the shipped mode is the cascade servo): the
    rigid-part reference speed is reached on both backends, compiled and CPython alike."""
    for name in ("incerti-belt", "incerti-bezier"):
        def make(name=name):
            mc = S.make_machine(S.load(name))
            return dataclasses.replace(mc, controller=PID(kp=0.5, ki=5.0, kd=0.0, omega0=20.0))
        for backend in BACKENDS:
            tr = _same_bits(make, backend, 0.1)
            assert tr.qd[-1] > 0.0
