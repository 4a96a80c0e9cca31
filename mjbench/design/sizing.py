"""Drive sizing: inverse dynamics over the duty, gear ratio, flywheel, motor and gearbox selection.

1. **Inverse dynamics at the duty** (:func:`constant_speed_torque`): the torque the crank needs
   to turn the mechanism at constant speed, T_L(q) = ½J'Ω² + E_p' − Q_ext(q, Ω) (inertial,
   gravity/springs, process loads, friction); its mean (work per cycle), RMS, peak and the
   **energy swing** ΔE = max − min of ∫(T_L − T̄)dq.  Any prescribed motion (a motion law over
   a cycle) goes through :func:`motion_torque` the same way, with J(q)q̈.
2. **Gear ratio** (:func:`ratio_sweep`): for a motor, the motor torque over the cycle for each
   ratio, T_m(z) = z·g(t) + h(t)/(zη) with g = J_r·q̈ + λ·q̇ (rotor, motor friction) and h the
   crank-side torque; brute-force minimum of the RMS over the ratios the speed and voltage
   envelope allows, and the closed form of the unconstrained, lossless optimum
   z*⁴ = ⟨h²⟩/⟨g²⟩ (:func:`optimal_ratio`; a pure inertia J_L gives the inertia-matching
   z* = √(J_L/J_r)).  At constant speed g = λΩ: the RMS falls as 1/z until the viscous term, so
   the best ratio is usually the largest the envelope allows.
3. **Flywheel** (:func:`flywheel`): the classical energy method, J_total = ΔE/(χ_max·Ω²), minus
   what the mechanism (mean J) and the reflected drive (J_b + (J_m + J_a)z²) already give.  Its
   χ estimate χ_E = ΔE/(J_total·Ω²) assumes a constant drive torque and a constant inertia; the
   stated error bound (before any simulation) adds the loop's share of the ripple
   1 − |ripple ratio(Ω)| (:func:`control.ripple_ratio`), ΔJ/(2J_total) and χ_E/2.
4. **Selection** (:func:`size`): every motor × gearbox of the catalogue (and direct drive if
   allowed), after necessary checks on the mean values, gets its flywheel, the design-rule
   gains and the **periodic steady state** of the speed loop (:mod:`periodic`: harmonic
   balance of the reduced model) → RMS and peak current, motor torque, gearbox torque, voltage
   (hot winding), speeds, χ, and the two-node thermal model (:mod:`thermal`).  Checked against
   the speed–torque envelope at the supply voltage (voltage and peak torque), the continuous
   rating (RMS torque, derated for the ambient), the winding temperature limit, the gearbox's
   ratings and χ_max.  The feasible candidate of lowest cost (catalogue ``cost``; else motor
   size) wins; if none is feasible, the one with the smallest total relative violation is the
   closest, with what fails.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import control as CT
from . import periodic as P
from . import thermal as TH
from .model import DriveModel, LoadModel
from .synthesis import constraint

TWO_PI = 2.0 * math.pi


# ============================================================================ inverse dynamics
def constant_speed_torque(load: LoadModel, speed: float, n: int = 4096):
    """(q, T_L): the crank torque of the mechanism alone at constant speed over one turn."""
    q = load.q0 + TWO_PI * np.arange(n) / n
    return q, load.load_torque(q, speed + 0.0 * q, 0.0)


def motion_torque(load: LoadModel, q, qd, qdd):
    """T_L of a prescribed motion (any arrays): J q̈ + ½J'q̇² + E_p' − Q_ext."""
    return load.load_torque(q, qd, qdd)


def energy_swing(q, T_L) -> dict:
    """ΔE [J] of the torque over a turn (uniform q grid): the largest excursion of the
    cumulative work of T_L − T̄ (trapezoid, periodic)."""
    dq = TWO_PI / len(q)
    Tm = float(np.mean(T_L))
    f = T_L - Tm
    E = np.concatenate([[0.0], np.cumsum(0.5 * (f + np.roll(f, -1)) * dq)])[:-1]
    return {"dE_J": float(np.ptp(E)), "T_mean_Nm": Tm, "T_rms_Nm": float(np.sqrt(np.mean(T_L ** 2))),
            "T_peak_Nm": float(np.max(np.abs(T_L))), "work_per_cycle_J": Tm * TWO_PI,
            "q_Emax": float(q[int(np.argmax(E))]), "q_Emin": float(q[int(np.argmin(E))])}


# ============================================================================ gear ratio
def optimal_ratio(h, g) -> float:
    """Closed-form minimum of RMS(z·g + h/z) (lossless): z*⁴ = ⟨h²⟩/⟨g²⟩ (Pasch & Seering 1984,
    "On the drive systems for high-performance machines", J. Mech. Trans. Autom. Des. 106:102;
    for a pure inertia, h = J_L·q̈ and g = J_r·q̈: the inertia match z* = √(J_L/J_r))."""
    h, g = np.asarray(h, float), np.asarray(g, float)
    return float((np.mean(h * h) / np.mean(g * g)) ** 0.25)


def ratio_sweep(T_crank, qd, qdd, motor, z=None, eta=1.0, eta_back=1.0, J_a=0.0, J_b=0.0, supply=None,
                headroom=0.0, dt=None) -> dict:
    """RMS and peak motor torque over the cycle for each ratio z (array), for the prescribed
    motion (q̇, q̈ over the cycle; ``T_crank`` the mechanism's torque T_L), with the motor's rotor
    and friction, the gearbox (η, J_a) and J_b on the crank; the ratios the speed and voltage
    envelope allows (``supply``: back-EMF + R·I + L·İ ≤ (1 − headroom)·supply; ``dt``: the time
    step of the samples for İ).  Brute-force optimum over the allowed ratios, and the closed
    form :func:`optimal_ratio` (lossless, no Coulomb friction, no limits)."""
    z = np.geomspace(1.0, 300.0, 600) if z is None else np.asarray(z, float)
    T_crank, qd, qdd = (np.asarray(x, float) * np.ones_like(np.asarray(qd, float)) for x in (T_crank, qd, qdd))
    Jr = motor.J_rotor + J_a
    rms, peak, ok, vpk = np.empty(len(z)), np.empty(len(z)), np.ones(len(z), bool), np.empty(len(z))
    for k, zk in enumerate(z):
        dm = DriveModel(z=zk, k_m=motor.k_m, R=motor.R, L=motor.L, J_m=motor.J_rotor, J_a=J_a, J_b=J_b,
                        lam=motor.viscous, T0=motor.friction, eta=eta, eta_back=eta_back)
        Tc = T_crank + dm.J_eq * qdd + dm.c_v * qd
        Tm = dm.motor_torque(Tc, zk * qd)
        rms[k] = np.sqrt(np.mean(Tm ** 2))
        peak[k] = np.max(np.abs(Tm))
        I = Tm / motor.k_m
        dI = np.gradient(I, dt) if dt else 0.0
        V = motor.R * I + motor.L * dI + motor.k_m * zk * qd
        vpk[k] = np.max(np.abs(V))
        ok[k] = np.max(np.abs(zk * qd)) <= motor.speed_max
        if supply is not None:
            ok[k] &= vpk[k] <= (1 - headroom) * supply
        ok[k] &= peak[k] <= motor.T_peak
    h = T_crank + J_b * qdd
    g = Jr * qdd + motor.viscous * qd
    out = {"z": z, "rms_Nm": rms, "peak_Nm": peak, "voltage_peak_V": vpk, "allowed": ok,
           "z_closed_form": optimal_ratio(h, g) if np.any(g) else math.inf}
    if np.any(ok):
        k = int(np.argmin(np.where(ok, rms, np.inf)))
        out.update(z_best=float(z[k]), rms_best_Nm=float(rms[k]), at_limit=bool(k == len(z) - 1 or not ok[min(k + 1, len(z) - 1)]))
    else:
        out.update(z_best=math.nan, rms_best_Nm=math.nan, at_limit=False)
    return out


# ============================================================================ flywheel
def flywheel(dE, speed, chi_max, J_have) -> dict:
    """Energy method: the total inertia for χ_max and the flywheel that adds it (≥ 0)."""
    J_need = dE / (chi_max * speed ** 2)
    return {"J_total_needed": J_need, "J_have": J_have, "J_flywheel": max(0.0, J_need - J_have)}


def chi_energy(dE, J_total, speed) -> float:
    return dE / (J_total * speed ** 2)


# ============================================================================ candidates
@dataclass
class Candidate:
    motor: object
    gearbox: object | None
    drive: DriveModel
    J_f: float                       #: flywheel inertia at its location [kg·m²]
    gains: P.Gains | None = None
    location: str = "motor"          #: flywheel on the motor shaft or on the crank
    ss: dict | None = None
    summary: dict = field(default_factory=dict)
    thermal: dict = field(default_factory=dict)
    checks: list = field(default_factory=list)
    screened_out: bool = False
    cost: float = 0.0
    note: str = ""

    @property
    def ok(self) -> bool:
        return bool(self.checks) and all(c["ok"] for c in self.checks)

    @property
    def violation(self) -> float:
        v = 0.0
        for c in self.checks:
            if c["ok"]:
                continue
            if c["compare"] == "max" and c["limit"]:
                v += max(0.0, c["value"] / c["limit"] - 1.0) if math.isfinite(c["value"]) else 1e3
            elif c["compare"] == "min" and c["limit"]:
                v += max(0.0, 1.0 - c["value"] / c["limit"])
            else:
                v += 1.0
        return v

    @property
    def label(self) -> str:
        return f"{self.motor.name} + {self.gearbox.name if self.gearbox else 'direct drive'}" + \
            (f" + flywheel {self.J_f:.4g} kg·m² on the {self.location} shaft" if self.J_f > 0 else "")

    def describe(self) -> dict:
        m, g = self.motor, self.gearbox
        return {"motor": m.name, "gearbox": g.name if g else None, "ratio": self.drive.z,
                "flywheel_kgm2": self.J_f, "flywheel_location": self.location, "gains": self.gains.as_dict() if self.gains else None,
                "cost": self.cost, "predicted": dict(self.summary), "thermal": {k: v for k, v in self.thermal.items()},
                "checks": list(self.checks), "ok": self.ok, "violation": self.violation,
                "screened_out": self.screened_out, "note": self.note}


def drive_model(motor, gearbox, J_f, location="motor") -> DriveModel:
    """The drive of a candidate; the flywheel J_f on the motor shaft (J_a) or on the crank (J_b)."""
    Jfa, Jfb = (J_f, 0.0) if location == "motor" else (0.0, J_f)
    if gearbox is None:
        return DriveModel(z=1.0, k_m=motor.k_m, R=motor.R, L=motor.L, J_m=motor.J_rotor, J_a=Jfa, J_b=Jfb,
                          lam=motor.viscous, T0=motor.friction)
    return DriveModel(z=gearbox.ratio, k_m=motor.k_m, R=motor.R, L=motor.L, J_m=motor.J_rotor,
                      J_a=gearbox.J_input + Jfa, J_b=Jfb, lam=motor.viscous, T0=motor.friction,
                      eta=gearbox.efficiency, eta_back=gearbox.eta_back)


def candidate_checks(c: Candidate, req, speed) -> list:
    """The constraints of a candidate from its periodic steady state (see the module doc)."""
    m, g, dm, s = c.motor, c.gearbox, c.drive, c.summary
    d = req.drive
    T_amb = req.duty.ambient_temperature
    V_av = (1.0 - d.voltage_headroom) * d.supply_voltage
    i_lim = d.current_limit
    th = c.thermal
    out = [constraint("motor speed ≤ maximum", s["motor_speed_max_rad_s"], m.speed_max, "max", "rad/s")]
    if g is not None:
        out.append(constraint("gearbox input speed ≤ maximum", s["motor_speed_max_rad_s"], g.speed_max_in, "max", "rad/s"))
    out += [
        constraint(f"voltage (hot winding) ≤ supply × (1 − headroom) = {V_av:.4g} V", s["voltage_peak_hot_V"], V_av, "max", "V"),
        constraint("peak motor torque ≤ T_peak", s["motor_torque_peak_Nm"], m.T_peak, "max", "N·m"),
        constraint(f"RMS motor torque ≤ continuous rating (derated to {T_amb:g} °C)", s["motor_torque_rms_Nm"],
                   TH.derated_continuous_torque(m, T_amb), "max", "N·m"),
        constraint("winding temperature ≤ T_max (two-node model, steady)", th["T_winding_C"], m.T_max, "max", "°C")]
    if i_lim is not None:
        out.append(constraint("peak current ≤ amplifier limit", s["current_peak_A"], i_lim, "max", "A"))
    if g is not None:
        out += [constraint("gearbox output torque RMS ≤ T_cont_out", s["gear_torque_rms_Nm"], g.T_cont_out, "max", "N·m"),
                constraint("gearbox output torque peak ≤ T_peak_out", s["gear_torque_peak_Nm"], g.T_peak_out, "max", "N·m")]
    if req.duty.chi_max is not None:
        out.append(constraint("speed fluctuation χ ≤ χ_max", s["chi"], req.duty.chi_max, "max", "1"))
    if c.J_f > 0:
        if not d.flywheel:
            out.append(constraint("flywheel allowed", False, compare="true"))
        elif d.flywheel_max is not None:
            out.append(constraint("flywheel ≤ flywheel_max", c.J_f, d.flywheel_max, "max", "kg·m²"))
    return out


def evaluate(c: Candidate, load: LoadModel, req, speed, n=256, tol=1e-7) -> Candidate:
    """Periodic steady state, thermal state and checks of a candidate (in place)."""
    try:
        c.ss = P.steady_state(load, c.drive, c.gains, speed, n=n, tol=tol)
    except P.NoSteadyState as e:
        c.note = str(e)
        c.checks = [constraint("periodic steady state exists (harmonic balance)", False, compare="true", note=str(e))]
        return c
    s = P.summary(c.ss, c.drive)
    th = TH.steady(float(np.mean(c.ss["I"] ** 2)), c.motor, req.duty.ambient_temperature)
    Rh = th.get("R_hot_ohm", math.inf)
    s["voltage_peak_hot_V"] = float(np.max(np.abs(c.ss["V"] + (Rh - c.drive.R) * c.ss["I"]))) if math.isfinite(Rh) else math.inf
    c.summary, c.thermal = s, th
    c.checks = candidate_checks(c, req, speed)
    return c


#: ranking figure of a flywheel per kg·m² at its location, plus a fixed part (its hub, guard)
FLYWHEEL_COST = (20.0, 100.0)


def _cost(motor, gearbox, J_f):
    fw = (FLYWHEEL_COST[0] + FLYWHEEL_COST[1] * J_f) if J_f > 0 else 0.0
    if motor.cost is not None:
        return float(motor.cost) + float(getattr(gearbox, "cost", 0.0) or 0.0) + fw
    return motor.T_cont * motor.speed_max + (gearbox.T_cont_out if gearbox is not None else 0.0) + fw


@dataclass
class Sizing:
    speed: float
    torque: dict          #: energy swing etc. of the constant-speed inverse dynamics
    candidates: list
    chosen: Candidate | None
    closest: Candidate | None
    flywheel: dict
    sweep: dict
    timing: dict
    q: np.ndarray = None
    T_L: np.ndarray = None


def size(load: LoadModel, req, cat, speed: float, log=None) -> Sizing:
    """Select motor, gearbox, flywheel and design-rule gains (module doc)."""
    t_cpu = time.process_time()
    log = log or (lambda *_: None)
    q, T_L = constant_speed_torque(load, speed)
    tq = energy_swing(q, T_L)
    d = req.drive
    chi_max = req.duty.chi_max
    V_av = (1.0 - d.voltage_headroom) * d.supply_voltage
    T_amb = req.duty.ambient_temperature
    gbs = list(cat.gearboxes) + ([None] if d.direct_drive else [])
    cands = []
    for m in cat.motors:
        for g in gbs:
            z = 1.0 if g is None else g.ratio
            eta = 1.0 if g is None else g.efficiency
            dm0 = drive_model(m, g, 0.0)
            J_have = load.J_mean + dm0.J_eq
            fw = flywheel(tq["dE_J"], speed, chi_max, J_have) if chi_max is not None else {"J_flywheel": 0.0}
            loc = d.flywheel_location
            J_f = (fw["J_flywheel"] / (z * z if loc == "motor" else 1.0)) if d.flywheel else 0.0
            c = Candidate(m, g, drive_model(m, g, J_f, loc), J_f, location=loc, cost=_cost(m, g, J_f))
            # necessary conditions from the mean values (RMS ≥ mean): screen before the harmonic balance
            wm = z * speed
            Tm_mean = tq["T_mean_Nm"] / (z * eta) + m.friction + m.viscous * wm
            I_mean = Tm_mean / m.k_m
            nec = [constraint("motor speed ≤ maximum", wm, m.speed_max, "max", "rad/s"),
                   constraint("mean motor torque ≤ continuous rating", Tm_mean,
                              TH.derated_continuous_torque(m, T_amb), "max", "N·m"),
                   constraint("mean voltage ≤ supply × (1 − headroom)", m.R * I_mean + m.k_m * wm, V_av, "max", "V")]
            if g is not None:
                nec += [constraint("gearbox input speed ≤ maximum", wm, g.speed_max_in, "max", "rad/s"),
                        constraint("mean gearbox output torque ≤ T_cont_out", abs(tq["T_mean_Nm"]), g.T_cont_out, "max", "N·m")]
            if not all(x["ok"] for x in nec):
                c.checks, c.screened_out = nec, True
                c.note = "fails on mean values (no steady-state analysis)"
                cands.append(c)
                continue
            M_mean = load.J_mean + c.drive.J_eq
            c.gains = CT.design_gains(c.drive, M_mean, req.control.bandwidth_ratio * speed)
            cands.append(evaluate(c, load, req, speed))
    feas = [c for c in cands if c.ok]
    chosen = min(feas, key=lambda c: (c.cost, c.summary.get("motor_torque_rms_Nm", 0.0))) if feas else None
    pool = [c for c in cands if not c.screened_out] or cands
    # the closest: a candidate whose steady state was found (its figures say by how much it fails) before
    # one without (whose failure says nothing about the requirement the others miss)
    closest = chosen or min(pool, key=lambda c: (c.ss is None, c.violation, c.cost))
    log(f"sizing: {len(cands)} candidates, {sum(not c.screened_out for c in cands)} analysed, {len(feas)} feasible")
    # gear-ratio study for the chosen (or closest) motor with its gearbox's efficiency
    best = chosen or closest
    g = best.gearbox
    zb = best.drive.z
    Jf_crank = best.J_f * (zb * zb if best.location == "motor" else 1.0)
    sw = ratio_sweep(T_L, speed + 0.0 * q, 0.0 * q, best.motor, eta=g.efficiency if g else 1.0,
                     eta_back=g.eta_back if g else 1.0, J_a=g.J_input if g else 0.0,
                     J_b=Jf_crank if best.location == "crank" else 0.0,
                     supply=d.supply_voltage, headroom=d.voltage_headroom, dt=(TWO_PI / speed) / len(q))
    zb = best.drive.z
    Jf_crank = best.J_f * (zb * zb if best.location == "motor" else 1.0)
    fw = {"dE_J": tq["dE_J"], "chi_max": chi_max, "J_mechanism_mean": load.J_mean,
          "J_reflected_drive": best.drive.J_eq - Jf_crank, "J_flywheel": best.J_f, "location": best.location,
          "J_flywheel_at_crank": Jf_crank, "J_total": load.J_mean + best.drive.J_eq}
    if chi_max is not None:
        fw["J_total_needed"] = tq["dE_J"] / (chi_max * speed ** 2)
    return Sizing(speed, tq, cands, chosen, closest, fw, sw,
                  {"cpu_s": time.process_time() - t_cpu}, q, T_L)


def finalize(c: Candidate, load, req, speed, n=1024):
    """The full-resolution periodic steady state of a candidate (n samples per cycle)."""
    return evaluate(c, load, req, speed, n=n, tol=1e-9)


def refine_closest(c: Candidate, run) -> None:
    """``run()`` (the full-resolution harmonic balance of ``c``, in place) for the closest of no
    feasible candidates: if that one does not converge where the screening's did, ``c`` keeps the
    screening's figures and checks — they say which requirement it misses and by how much (an
    impossible tracking bound is not "harmonic balance did not converge") — with a note."""
    keep = (c.ss, c.summary, c.thermal, list(c.checks), c.note)
    run()
    lost = any(x["name"].startswith("periodic steady state") and not x["ok"] for x in c.checks)
    if lost and keep[0] is not None:
        c.ss, c.summary, c.thermal, c.checks = keep[:4]
        c.note = ((keep[4] + "; ") if keep[4] else "") + ("figures of the screening harmonic balance (256 samples per "
                                                          "cycle): the full-resolution one did not converge")


def chi_energy_statement(c: Candidate, load, dE, speed, T_L=None) -> dict:
    """χ of the energy method for a candidate and its a-priori error estimate (module doc, step 3):
    the loop's share, |χ_E/χ_lin − 1| with χ_lin the ripple of the mean-inertia linear loop driven
    by the harmonics of the constant-speed load torque T_L (each scaled by
    :func:`control.ripple_transfer`); the variation of the inertia ΔJ/J_total; the second-order
    terms (the speed ripple in ½J'q̇²) ≈ χ_E."""
    M = load.J_mean + c.drive.J_eq
    chi_E = chi_energy(dE, M, speed)
    out = {"chi_energy": chi_E}
    if T_L is not None:
        n = len(T_L)
        Th = np.fft.rfft(T_L - np.mean(T_L))
        k = np.arange(len(Th))
        k[0] = 1
        w = k * speed
        W0 = -Th / (M * 1j * w)
        W0[0] = 0.0
        r = CT.ripple_transfer(c.drive, M, c.gains, w)
        W1 = W0 * r
        chi_open = float(np.ptp(np.fft.irfft(W0, n)) / speed)
        chi_lin = float(np.ptp(np.fft.irfft(W1, n)) / speed)
        out.update(chi_inertia_alone_linear=chi_open, chi_loop_linear=chi_lin)
        e_loop = abs(chi_E / chi_lin - 1.0) if chi_lin > 0 else math.inf
    else:
        e_loop = abs(1.0 - CT.ripple_ratio(c.drive, M, c.gains, speed))
    e_J = load.J_ptp / M
    e_chi = chi_E
    out.update(ripple_ratio_at_cycle_frequency=CT.ripple_ratio(c.drive, M, c.gains, speed), error_loop=e_loop,
               error_J=e_J, error_second_order=e_chi, tolerance=e_loop + e_J + e_chi)
    return out
