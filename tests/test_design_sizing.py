"""Drive sizing of mjbench design (mjbench/design/sizing.py, periodic.py, thermal.py, catalogue.py):
closed forms and the sizing model against simulation, cheaply."""
import math

import numpy as np
import pytest

from mjbench.design import catalogue as CAT
from mjbench.design import control as CT
from mjbench.design import periodic as P
from mjbench.design import sizing as SZ
from mjbench.design import thermal as TH
from mjbench.design.model import DriveModel, LoadModel
from mjbench.errors import ScenarioError


def motor(**kw):
    d = dict(name="m", voltage=48.0, R=0.5, L=2e-4, k_m=0.1, J_rotor=1e-4, T_cont=1.0, T_peak=10.0, speed_max=1e4,
             R_th_wh=1.0, R_th_ha=3.0, tau_w=30.0, tau_h=900.0, T_max=125.0)
    d.update(kw)
    return CAT.Motor(**d)


def law_345(T=0.5, n=2001, Phi=2 * math.pi):
    """A rest-to-rest 3-4-5 polynomial motion of one crank turn in T seconds: (t, q, q̇, q̈)."""
    t = np.linspace(0.0, T, n)
    u = t / T
    q = Phi * (10 * u ** 3 - 15 * u ** 4 + 6 * u ** 5)
    qd = Phi / T * (30 * u ** 2 - 60 * u ** 3 + 30 * u ** 4)
    qdd = Phi / T ** 2 * (60 * u - 180 * u ** 2 + 120 * u ** 3)
    return t, q, qd, qdd


# ============================================================================ gear ratio
def test_inertia_matching_closed_form_on_a_pure_inertia():
    """A pure inertia J_L moved by a motion law: the RMS motor torque is least at z* = √(J_L/J_r)
    (inertia matching); the brute-force sweep finds it, the closed form gives it exactly."""
    J_L, m = 0.8, motor(J_rotor=2e-4)
    t, q, qd, qdd = law_345()
    z_star = math.sqrt(J_L / m.J_rotor)
    sw = SZ.ratio_sweep(J_L * qdd, qd, qdd, m, z=np.geomspace(10, 200, 4001))
    assert sw["z_closed_form"] == pytest.approx(z_star, rel=1e-12)
    assert sw["z_best"] == pytest.approx(z_star, rel=2e-3)
    # the RMS there is 2·√(J_L·J_r)·RMS(q̈), the matched-inertia minimum
    assert sw["rms_best_Nm"] == pytest.approx(2 * math.sqrt(J_L * m.J_rotor) * np.sqrt(np.mean(qdd ** 2)), rel=1e-5)


def _press_load(speed=2 * math.pi):
    from mjbench import scenario as S

    scn = S.load("press-slidercrank")
    return scn, LoadModel(S.make_mechanism(scn), speed)


def test_optimal_ratio_on_the_real_load_closed_form_vs_brute_force():
    """The press (linkage, forming load, gravity, friction) under a motion law: z*⁴ = ⟨h²⟩/⟨g²⟩
    (lossless) matches the brute-force sweep; at constant speed g = λΩ: z*⁴ = ⟨T_L²⟩/(λΩ)²."""
    scn, load = _press_load()
    t, q, qd, qdd = law_345(T=0.6)
    T_L = SZ.motion_torque(load, q, qd, qdd)
    m = motor(viscous=2e-4)
    sw = SZ.ratio_sweep(T_L, qd, qdd, m, z=np.geomspace(2, 400, 6001))
    h, g = T_L, m.J_rotor * qdd + m.viscous * qd
    assert sw["z_closed_form"] == pytest.approx((np.mean(h * h) / np.mean(g * g)) ** 0.25, rel=1e-12)
    assert sw["z_best"] == pytest.approx(sw["z_closed_form"], rel=2e-3)
    # constant speed: the sweep's optimum is the viscous one
    W = 2 * math.pi
    qc, TLc = SZ.constant_speed_torque(load, W)
    swc = SZ.ratio_sweep(TLc, W + 0 * qc, 0 * qc, m, z=np.geomspace(2, 2000, 6001))
    z_v = (np.mean(TLc ** 2) / (m.viscous * W) ** 2) ** 0.25
    assert swc["z_closed_form"] == pytest.approx(z_v, rel=1e-12) and swc["z_best"] == pytest.approx(z_v, rel=2e-3)
    # with a gearbox efficiency the brute force is the reference (no closed form): never worse than z*
    swe = SZ.ratio_sweep(T_L, qd, qdd, m, eta=0.8, eta_back=0.7, z=np.geomspace(2, 400, 6001))
    k = int(np.argmin(np.abs(swe["z"] - swe["z_closed_form"])))
    assert swe["rms_best_Nm"] <= swe["rms_Nm"][k]
    # the supply voltage bounds the ratio: the sweep's best is then at the envelope
    swv = SZ.ratio_sweep(TLc, W + 0 * qc, 0 * qc, m, z=np.geomspace(2, 2000, 2001), supply=48.0,
                         dt=(2 * math.pi / W) / len(qc))
    ok = swv["allowed"]
    assert swv["at_limit"] and swv["z_best"] == pytest.approx(swv["z"][ok].max()) and swv["z_best"] < z_v
    assert swv["voltage_peak_V"][ok].max() <= 48.0 and swv["peak_Nm"][ok].max() <= m.T_peak


def test_energy_swing_and_load_model():
    q = 2 * np.pi * np.arange(4096) / 4096
    A, Tm = 3.0, 1.5
    es = SZ.energy_swing(q, Tm + A * np.sin(q) + 0.5 * A * np.sin(2 * q))
    # E(q) = −A cos q − A/4 cos 2q + const: its range over a turn
    E = -A * np.cos(q) - 0.25 * A * np.cos(2 * q)
    assert es["dE_J"] == pytest.approx(np.ptp(E), rel=1e-5)
    assert es["T_mean_Nm"] == pytest.approx(Tm, rel=1e-12) and es["work_per_cycle_J"] == pytest.approx(2 * np.pi * Tm)
    scn, load = _press_load()
    assert load.affine_error < 1e-12  # the press's external torque is position part − D(q)·q̇
    from mjbench import scenario as S
    mech = S.make_mechanism(scn)
    qq = np.linspace(0.1, 6.0, 37)
    J, dJ, dEp = mech.reduced(qq)
    T_ref = 0.5 * dJ * 4.0 + dEp - mech.external_torque(qq, 2.0 + 0 * qq, 0.0)
    # linear interpolation on 8192 nodes: ≤ 1e-5 of the peak (the largest error sits at the kinks of the forming
    # force table)
    assert np.max(np.abs(load.load_torque(qq, 2.0 + 0 * qq, 0.0) - T_ref)) < 1e-5 * np.max(np.abs(T_ref))


class _Inertia:
    """A test mechanism: constant inertia J and a position-dependent load torque (no MuJoCo)."""

    def __init__(self, J, load):
        self.J, self.load = J, load

    def reduced(self, q):
        return self.J + 0 * q, 0 * q, 0 * q

    def external_torque(self, q, qd, t):
        return -self.load(q)


def test_flywheel_energy_method_against_the_periodic_steady_state():
    """A constant inertia driven against T(q) = T̄ + A sin q through a slow speed loop: the energy
    method's χ_E = ΔE/(JΩ²) = 2A/(JΩ²) agrees with the exact periodic steady state within its
    stated error bound (loop share + inertia variation + second order)."""
    A, W = 20.0, 2 * math.pi
    for J in (2.0, 8.0):
        load = LoadModel(_Inertia(J, lambda q: 5.0 + A * np.sin(q)), W)
        dm = DriveModel(z=20.0, k_m=0.1, R=0.5, L=2e-4, J_m=1e-4)
        M = load.J_mean + dm.J_eq
        g = CT.design_gains(dm, M, 0.3 * W)
        ss = P.steady_state(load, dm, g, W)
        chi_hb = P.summary(ss, dm)["chi"]
        c = SZ.Candidate(motor(), None, dm, 0.0, g)
        q, TL = SZ.constant_speed_torque(load, W)
        st = SZ.chi_energy_statement(c, load, SZ.energy_swing(q, TL)["dE_J"], W, TL)
        assert st["chi_energy"] == pytest.approx(2 * A / (M * W * W), rel=1e-5)
        assert abs(chi_hb / st["chi_energy"] - 1) <= st["tolerance"]
        # the linear loop's χ (no inertia variation here) is within second order of the exact one
        assert st["chi_loop_linear"] == pytest.approx(chi_hb, rel=3 * st["chi_energy"])
    # the flywheel of the energy method gives χ_max by construction
    fw = SZ.flywheel(2 * A, W, 0.04, 1.0)
    assert SZ.chi_energy(2 * A, fw["J_have"] + fw["J_flywheel"], W) == pytest.approx(0.04, rel=1e-12)


# ============================================================================ periodic steady state
def test_harmonic_balance_matches_a_simulation_of_the_press():
    """The press scenario's own PI at 60 SPM: the periodic steady state by harmonic balance against
    the last cycle of a reduced-backend run from rest (independent: time stepping, the kernel's
    sampled PID, drive and current integration)."""
    from mjbench import metrics as M
    from mjbench import scenario as S
    from mjbench.backends import simulate

    scn, load = _press_load()
    d = scn.drive
    dm = DriveModel(z=d.z, k_m=d.k_m, R=d.R, L=d.L, J_m=d.J_m, J_a=d.J_a, J_b=d.J_b, lam=d.lam, T0=d.T_0)
    mp = scn.modes["pi"]
    W = mp.omega0 / d.z
    ss = P.steady_state(load, dm, P.Gains(mp.kp, mp.ki, mp.kd), W)
    pred = P.summary(ss, dm)
    tr = simulate(S.make_machine(scn), "reduced", 8.0)
    a, b = M.cycles(tr.t, tr.q)[-1]
    sel = (tr.t >= a) & (tr.t <= b)
    assert pred["current_rms_A"] == pytest.approx(np.sqrt(np.mean(tr.current[sel] ** 2)), rel=5e-3)
    assert pred["current_peak_A"] == pytest.approx(np.max(np.abs(tr.current[sel])), rel=5e-3)
    assert pred["chi"] == pytest.approx(M.chi(tr.t, tr.omega, a, b), rel=5e-3)
    init = P.initial_state(ss)
    assert init["q0"] == 0.0 and init["qd0"] == pytest.approx(W, rel=0.05)


# ============================================================================ thermal
def test_two_node_thermal_model():
    m = motor(R=0.6, R_th_wh=1.4, R_th_ha=4.0, tau_w=30.0, tau_h=1100.0)
    st = TH.steady(9.0, m, 40.0)
    # the closed form satisfies the balance ΔT = I²R(T)(R_wh + R_ha)
    assert st["T_winding_C"] - 40.0 == pytest.approx(9.0 * st["R_hot_ohm"] * 5.4, rel=1e-12)
    assert st["T_housing_C"] - 40.0 == pytest.approx(st["loss_W"] * 4.0, rel=1e-12)
    tr = TH.transient(9.0, m, 40.0, t_end=12 * m.tau_h, n=3000)
    assert tr["T_winding_C"][-1] == pytest.approx(st["T_winding_C"], rel=1e-4)
    assert 0 < tr["t95_s"] < 12 * m.tau_h
    assert TH.steady(1e4, m, 40.0)["runaway"]
    assert TH.derated_continuous_torque(m, 25.0) == m.T_cont
    assert TH.derated_continuous_torque(m, 75.0) == pytest.approx(m.T_cont * math.sqrt(50 / 100))


# ============================================================================ catalogue
def test_example_catalogue_is_illustrative_and_csv_equals_toml(tmp_path):
    cat = CAT.load("example")
    assert cat.illustrative and "illustrative" in cat.title and len(cat.motors) >= 5 and len(cat.gearboxes) >= 20
    with open(CAT.example_path(), encoding="utf-8") as f:
        assert "ILLUSTRATIVE VALUES" in f.readline()
    for m in cat.motors:  # self-consistent figures: stall torque ≥ peak, no-load speed ≥ maximum
        assert m.k_m * m.voltage / m.R >= m.T_peak * 0.99 and m.voltage / m.k_m >= 0.9 * m.speed_max
    rows = ["kind,name,voltage,R,L,k_m,J_rotor,T_cont,T_peak,speed_max,R_th_wh,R_th_ha,tau_w,tau_h,ratio,efficiency,"
            "J_input,T_cont_out,T_peak_out,speed_max_in",
            "motor,A,48 V,0.6 ohm,0.3 mH,0.11,1.4 kg*cm^2,0.45,4.5,3800 rpm,1.4 K/W,4,30 s,1100,,,,,,",
            "gearbox,G,,,,,,,,,,,,,50,0.85,2 kg*cm^2,120,300,4000 rpm"]
    (tmp_path / "c.csv").write_text("\n".join(rows) + "\n")
    c = CAT.load(str(tmp_path / "c.csv"))
    ref = next(m for m in cat.motors if m.name == "PMDC-48-150")
    for k in ("voltage", "R", "L", "k_m", "J_rotor", "T_cont", "T_peak", "speed_max", "R_th_wh", "R_th_ha", "tau_w",
              "tau_h"):
        assert getattr(c.motors[0], k) == pytest.approx(getattr(ref, k), rel=1e-12), k
    assert c.gearboxes[0].ratio == 50 and c.gearboxes[0].J_input == pytest.approx(2e-4)


def test_catalogue_errors_name_every_problem(tmp_path):
    (tmp_path / "bad.toml").write_text('[[motors]]\nname = "x"\nvoltage = "48 kg"\nR = -1\n'
                                       '[[gearboxes]]\nname = "g"\nratio = 0.5\n')
    with pytest.raises(ScenarioError) as e:
        CAT.load(str(tmp_path / "bad.toml"))
    msg = str(e.value)
    for part in ("motors.0.voltage", "motors.0.R", "motors.0.k_m", "gearboxes.0.ratio", "gearboxes.0.T_cont_out"):
        assert part in msg, msg
    with pytest.raises(ScenarioError, match="kind"):
        (tmp_path / "k.csv").write_text("kind,name\nengine,x\n")
        CAT.load(str(tmp_path / "k.csv"))
    with pytest.raises(ScenarioError, match="no such file"):
        CAT.load("nope.toml")
