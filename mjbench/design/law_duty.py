"""A motion-law duty: the crank follows a rest-to-rest motion law once round per cycle.

``[duty.law]`` (docs/design.md §3b): the input crank turns 2π in ``move_fraction`` of the cycle
along the law (a 3-4-5 polynomial by default, any pseudo-polynomial or Bezier law of
mjbench/motionlaws.py) and dwells for the rest; the cycle repeats.  The machine is a motor +
gearbox under the **cascade servo** (controllers/servo.py) tracking that law repeated per cycle
(controllers/references/periodic.py).  The stages:

1. **Inverse dynamics of the law** (:func:`sizing.motion_torque`): the crank torque over the cycle,
   J q̈ + ½J'q̇² + E_p' − Q_ext; the gear-ratio study (:func:`sizing.ratio_sweep`: RMS motor
   torque over the ratios, the closed form z*⁴ = ⟨h²⟩/⟨g²⟩).  No flywheel: every cycle the motor
   would have to accelerate it.
2. **Servo gains, design rule** (:func:`design_gains`, stated basis): the velocity PI crosses over at
   ω_v = ``tracking_bandwidth_ratio`` × 2π/T_move on the mean-inertia plant with its zero at
   ω_v/4, the position loop K_pp = ω_v/4 (the usual cascade rule: position-loop bandwidth a few
   times below the velocity loop's; phase margin ≈ 90° − 2·atan ¼ ≈ 62° on the rigid plant, less
   the electrical lag); feed-forward K_ffv = k_m + R·λ/k_m (back-EMF and viscous drop), K_ffa =
   R·M̄/(η·z²·k_m) (the mean inertia through the gearbox).
3. **Periodic steady state of the tracking loop by harmonic balance** (:func:`steady_state`):
   q(τ) = q_ref(τ) + δ(τ), δ periodic with zero mean (the servo's integral makes it so); the
   inverse dynamics of q gives the current and the voltage the armature needs; the servo gives
   V = z·(K_ffv·q̇_ref + K_ffa·q̈_ref) − z·C(s)·δ + s₀ with C(s) = (K_vp + K_vi/s)(s + K_pp) and s₀
   its integral's mean; the residual is driven to zero harmonic by harmonic with the mean-inertia
   operator (chord Newton), as :mod:`periodic` does for the speed loop.  It predicts the current,
   torques, voltage and the tracking error δ — every candidate of the catalogue is checked on it
   (ratings, thermal model, supply, tracking error ≤ ``tracking_error_max``).
4. **Tuning** (:func:`mjbench.tune.tune`, controller ``servo``, objective ``tracking_rms`` or
   ``tracking_peak``) within ×/÷ 3 of the design rule's gains, the tuned gains re-checked by the
   harmonic balance.
5. **Verification**: the machine from rest on the multibody backend until two cycles agree; the
   last cycle against the prediction (``checks``).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from . import sizing as SZ
from . import thermal as TH
from . import finish as PL
from .checks import check_row, drive_checks, sizing_common
from .law_figure import _cycle, figure  # noqa: F401 - the figure of a motion-law design
from .model import DriveModel, LoadModel
from .periodic import NoSteadyState, effective_efficiency
from .synthesis import constraint
from .. import metrics as M
from .. import scenario as SC
from .. import mechanisms as MR
from ..errors import ParameterError
from .. import tune as T
from ..backends import simulate
from ..runner import backend_options

TWO_PI = 2.0 * math.pi
#: the design rule: velocity-PI zero and position-loop gain as fractions of the velocity crossover
ZERO_RATIO = 0.25
POSITION_RATIO = 0.25
#: tuning box: each servo gain within ×/÷ this factor of the design rule's
BOX = 3.0
#: longest verification run [cycles]; at most this many runs, each twice as long as the last
MAX_CYCLES = 60
ATTEMPTS = 6


# ============================================================================ the law
def law_of(req):
    """(the crank's motion law over one cycle, the cycle time T_c [s])."""
    T_c = req.duty.cycle_time
    return req.duty.law.build(T_c), T_c


def reference(law, T_c: float, n: int):
    """(τ, q_ref, q̇_ref, q̈_ref) over one cycle at n samples: the law, then the dwell at 2π."""
    tau = T_c * np.arange(n) / n
    p, v, a = law.evaluate(tau, 2)[:3]
    return tau, np.asarray(p, float), np.asarray(v, float), np.asarray(a, float)


def describe(req, law, T_c) -> dict:
    d = req.duty.law
    out = {"kind": d.kind, "law": law.describe(), "cycle_s": T_c, "move_time_s": float(law.T),
           "dwell_s": T_c - float(law.T), "move_fraction": d.move_fraction,
           "tracking_error_max_rad": req.duty.tracking_error_max}
    pk = law.peaks()
    out.update(peak_speed_rad_s=pk["speed"], peak_accel_rad_s2=pk["accel"])
    return out


# ============================================================================ the servo
@dataclass
class ServoGains:
    """Cascade servo gains on the motor shaft (controllers/servo.py units)."""

    kpp: float
    kvp: float
    kvi: float
    kffv: float = 0.0
    kffa: float = 0.0

    def as_dict(self):
        return {"kpp": self.kpp, "kvp": self.kvp, "kvi": self.kvi, "kffv": self.kffv, "kffa": self.kffa}


def feedback(s, g: ServoGains):
    """C(s) = (K_vp + K_vi/s)(s + K_pp): the servo's voltage per motor-side angle error."""
    return (g.kvp + g.kvi / s) * (s + g.kpp)


def velocity_plant(s, drive: DriveModel, M_mean: float, eta=None):
    """φ̇/V of the mean-inertia drive, motor side."""
    eta = drive.eta if eta is None else eta
    Jm = M_mean / drive.z ** 2
    return eta * drive.k_m / ((drive.R + drive.L * s) * (Jm * s + drive.lam) + eta * drive.k_m ** 2)


def design_gains(drive: DriveModel, M_mean: float, w_v: float) -> ServoGains:
    """The design rule (module doc) for the velocity-loop crossover w_v [rad/s]."""
    G = velocity_plant(1j * w_v, drive, M_mean)
    kvp = 1.0 / (abs(G) * abs(1.0 - 1j * ZERO_RATIO))
    return ServoGains(kpp=float(POSITION_RATIO * w_v), kvp=float(kvp), kvi=float(kvp * ZERO_RATIO * w_v),
                      kffv=float(drive.k_m + drive.R * drive.lam / drive.k_m),
                      kffa=float(drive.R * M_mean / (drive.eta * drive.z ** 2 * drive.k_m)))


def loop_operator(s, drive: DriveModel, M_mean: float, g: ServoGains, eta_eff=None):
    """H(s): crank-side δ → voltage residual of the tracking loop (mean inertia)."""
    eta = drive.eta if eta_eff is None else eta_eff
    z = drive.z
    return ((drive.R + drive.L * s) * (M_mean * s * s + drive.c_v * s) / (drive.k_m * z * eta)
            + drive.k_m * z * s + z * feedback(s, g))


def closed_loop_poles(drive: DriveModel, M_mean: float, g: ServoGains) -> np.ndarray:
    """Poles of the linear tracking loop: s²(R + Ls)(M̄s + c_v) + η k_m² z² s² + η k_m z²
    (K_vp s + K_vi)(s + K_pp) = 0."""
    z, k, eta = drive.z, drive.k_m, drive.eta
    p = np.polymul([1.0, 0.0, 0.0], np.polymul([drive.L, drive.R], [M_mean, drive.c_v]))
    p = np.polyadd(p, [eta * k * k * z * z, 0.0, 0.0])
    p = np.polyadd(p, eta * k * z * z * np.polymul([g.kvp, g.kvi], [1.0, g.kpp]))
    return np.roots(p)


def settling_time(drive, M_mean, g: ServoGains, decades: float = 3.5) -> float:
    p = closed_loop_poles(drive, M_mean, g)
    sig = -max(float(x.real) for x in p)
    return math.inf if sig <= 0 else math.log(10.0) * decades / sig


# ============================================================================ harmonic balance
#: speed [rad/s, motor side] below which the harmonic balance rounds the sign of the motor speed
#: (Coulomb friction, the gear efficiency's direction): × the law's peak motor speed
SIGN_SPEED = 1e-3


def motor_torque(drive: DriveModel, T_crank, w_motor, w_eps: float):
    """:meth:`DriveModel.motor_torque` with sgn φ̇ rounded to tanh(φ̇/w_eps): where the law stops
    (the ends of the move, a dwell) the motor speed passes zero, and sgn has no periodic orbit there
    (the simulation chatters about it: friction and the efficiency take a mean value — what the
    rounding gives).  |difference| ≤ T_0 and the efficiency's only within |φ̇| ≲ 3·w_eps."""
    X = np.asarray(T_crank, float) / drive.z
    sw = np.tanh(np.asarray(w_motor, float) / w_eps)
    a, b = 0.5 * (1.0 / drive.eta + drive.eta_back), 0.5 * (1.0 / drive.eta - drive.eta_back)
    return X * a + np.abs(X) * b * sw + drive.T0 * sw


def steady_state(load: LoadModel, drive: DriveModel, g: ServoGains, law, T_c: float, n: int = 1024,
                 tol: float = 1e-9, maxit: int = 400) -> dict:
    """The periodic steady state of the servo tracking ``law`` repeated every T_c (module doc, step
    3) → arrays over one cycle (``tau``, ``q``, ``qd``, ``qdd``, ``q_ref``, ``delta`` (= q − q_ref),
    ``I``, ``V``, ``T_m``, ``T_crank``, ``T_gear``, ``w_motor``) and ``s0`` (the integral's mean
    [V]), ``iterations``, ``residual``.  Raises :class:`NoSteadyState` if it does not converge."""
    tau, qr, qdr, qddr = reference(law, T_c, n)
    W = TWO_PI / T_c
    w = W * np.arange(n // 2 + 1)
    jw = 1j * w
    M_mean = load.J_mean + drive.J_eq
    eta_eff = drive.eta
    H = np.ones(len(w), complex)
    H[1:] = loop_operator(jw[1:], drive, M_mean, g, eta_eff)
    Cz = np.zeros(len(w), complex)
    Cz[1:] = drive.z * feedback(jw[1:], g)
    w_eps = SIGN_SPEED * drive.z * float(np.max(np.abs(qdr)))
    Vff = drive.z * (g.kffv * qdr + g.kffa * qddr)
    vscale = drive.k_m * drive.z * W + 1e-12
    dh = np.zeros(n // 2 + 1, complex)
    res_prev, relax, out, res = math.inf, 1.0, None, math.inf
    for it in range(maxit):
        d = np.fft.irfft(dh, n)
        dd = np.fft.irfft(jw * dh, n)
        ddd = np.fft.irfft(-w * w * dh, n)
        q, qd, qdd = qr + d, qdr + dd, qddr + ddd
        J, dJ, dEp, Qp, D = load(q)
        Treq = (J + drive.J_eq) * qdd + 0.5 * dJ * qd * qd + dEp - (Qp - D * qd) + drive.c_v * qd
        wm = drive.z * qd
        I = motor_torque(drive, Treq, wm, w_eps) / drive.k_m
        dI = np.fft.irfft(jw * np.fft.rfft(I), n)
        Vreq = drive.R * I + drive.L * dI + drive.k_m * wm
        Vfb = -np.fft.irfft(Cz * dh, n)
        r = Vreq - Vff - Vfb
        rh = np.fft.rfft(r) / n
        rh[0] = 0.0
        res = float(np.sqrt(2.0 * np.sum(np.abs(rh[1:]) ** 2))) / vscale
        out = (d, dd, ddd, q, qd, qdd, Treq, wm, I, dI, Vreq, r)
        if res < tol:
            break
        if not math.isfinite(res) or np.max(np.abs(d)) > math.pi:
            raise NoSteadyState(f"the servo has no periodic steady state tracking the law with these gains (harmonic "
                                f"balance diverged after {it} iterations)")
        relax = max(0.05, 0.5 * relax) if res > res_prev else min(1.0, relax * 1.2)
        res_prev = res
        eta_new = effective_efficiency(drive, Treq, wm)
        if abs(eta_new - eta_eff) > 1e-3 * eta_eff:
            eta_eff = eta_new
            H[1:] = loop_operator(jw[1:], drive, M_mean, g, eta_eff)
        dh = dh - relax * (rh * n) / H
        dh[0] = 0.0
    else:
        raise NoSteadyState(f"harmonic balance did not converge in {maxit} iterations (residual {res:.3g} of the "
                            f"back-EMF at the mean speed)")
    d, dd, ddd, q, qd, qdd, Treq, wm, I, dI, Vreq, r = out
    return {"tau": tau, "T": T_c, "speed": W, "q_ref": qr, "qd_ref": qdr, "qdd_ref": qddr, "delta": d, "q": q,
            "qd": qd, "qdd": qdd, "I": I, "dI": dI, "V": Vreq, "T_m": drive.k_m * I, "T_crank": Treq,
            "T_gear": drive.gear_output(Treq, qd, qdd), "w_motor": wm, "s0": float(np.mean(r)), "iterations": it + 1,
            "residual": res, "n": n, "M_mean": M_mean, "eta_eff": eta_eff, "sign_speed": w_eps}


def summary(ss: dict, drive: DriveModel) -> dict:
    """Figures of one cycle: RMS/peak current, motor and gearbox torque, voltage, tracking error."""
    I, Tm, Tg, V, wm, d = ss["I"], ss["T_m"], ss["T_gear"], ss["V"], ss["w_motor"], ss["delta"]
    rms = lambda x: float(np.sqrt(np.mean(np.asarray(x) ** 2)))  # noqa: E731
    return {"current_rms_A": rms(I), "current_peak_A": float(np.max(np.abs(I))),
            "motor_torque_rms_Nm": rms(Tm), "motor_torque_peak_Nm": float(np.max(np.abs(Tm))),
            "gear_torque_rms_Nm": rms(Tg), "gear_torque_peak_Nm": float(np.max(np.abs(Tg))),
            "voltage_peak_V": float(np.max(np.abs(V))), "voltage_mean_V": float(np.mean(V)),
            "tracking_rms_rad": rms(d), "tracking_peak_rad": float(np.max(np.abs(d))),
            "motor_speed_max_rad_s": float(np.max(np.abs(wm))), "mean_power_W": float(np.mean(ss["T_crank"] * ss["qd"])),
            "gear_work_per_cycle_J": float(np.mean(Tg * ss["qd"])) * ss["T"],
            "copper_loss_W": float(np.mean(I * I)) * drive.R, "chi": None}


# ============================================================================ candidates
def evaluate(c: SZ.Candidate, load, req, law, T_c, n=256, tol=1e-7) -> SZ.Candidate:
    """Harmonic balance, thermal state and checks of a candidate (in place)."""
    try:
        c.ss = steady_state(load, c.drive, c.gains, law, T_c, n=n, tol=tol)
    except NoSteadyState as e:
        c.note = str(e)
        c.checks = [constraint("periodic steady state exists (harmonic balance)", False, compare="true", note=str(e))]
        return c
    s = summary(c.ss, c.drive)
    th = TH.steady(float(np.mean(c.ss["I"] ** 2)), c.motor, req.duty.ambient_temperature)
    Rh = th.get("R_hot_ohm", math.inf)
    s["voltage_peak_hot_V"] = float(np.max(np.abs(c.ss["V"] + (Rh - c.drive.R) * c.ss["I"]))) if math.isfinite(Rh) \
        else math.inf
    c.summary, c.thermal = s, th
    c.checks = SZ.candidate_checks(c, req, req.duty.omega)
    lim = req.duty.tracking_error_max
    if lim is not None:
        c.checks.append(constraint("peak tracking error |q_ref − q| ≤ tracking_error_max", s["tracking_peak_rad"],
                                   float(lim), "max", "rad"))
    return c


@dataclass
class LawSizing:
    law: object
    T_c: float
    q: np.ndarray                    #: the reference angle over the cycle (inverse dynamics)
    T_L: np.ndarray                  #: the crank torque of the law (mechanism alone)
    torque: dict
    candidates: list
    chosen: SZ.Candidate | None
    closest: SZ.Candidate | None
    sweep: dict
    timing: dict


def size(load: LoadModel, req, cat, law, T_c: float, log=None) -> LawSizing:
    """Every motor × gearbox (and direct drive if allowed): necessary conditions on mean values,
    then the design-rule servo and the harmonic balance of its tracking loop; the cheapest
    feasible candidate (module doc)."""
    t_cpu = time.process_time()
    log = log or (lambda *_: None)
    tau, qr, qdr, qddr = reference(law, T_c, 2048)
    T_L = SZ.motion_torque(load, qr, qdr, qddr)
    Tm_mean = float(np.mean(T_L))  # time mean over the cycle (perfect tracking): |mean| ≤ RMS
    W = req.duty.omega
    torque = {"T_mean_Nm": Tm_mean, "T_rms_Nm": float(np.sqrt(np.mean(T_L ** 2))),
              "T_peak_Nm": float(np.max(np.abs(T_L))), "work_per_cycle_J": float(np.mean(T_L * qdr) * T_c)}
    d = req.drive
    V_av = (1.0 - d.voltage_headroom) * d.supply_voltage
    T_amb = req.duty.ambient_temperature
    w_v = req.control.tracking_bandwidth_ratio * TWO_PI / float(law.T)
    gbs = list(cat.gearboxes) + ([None] if d.direct_drive else [])
    cands = []
    for m in cat.motors:
        for g in gbs:
            z = 1.0 if g is None else g.ratio
            eta = 1.0 if g is None else g.efficiency
            c = SZ.Candidate(m, g, SZ.drive_model(m, g, 0.0), 0.0, cost=SZ._cost(m, g, 0.0))
            wm = z * W  # the mean speed: the peak is higher
            Tmot = Tm_mean / (z * eta) + m.friction + m.viscous * wm
            nec = [constraint("mean motor speed ≤ maximum", wm, m.speed_max, "max", "rad/s"),
                   constraint("mean motor torque ≤ continuous rating", Tmot, TH.derated_continuous_torque(m, T_amb),
                              "max", "N·m"),
                   constraint("mean voltage ≤ supply × (1 − headroom)", m.R * Tmot / m.k_m + m.k_m * wm, V_av, "max", "V")]
            if g is not None:
                nec += [constraint("mean gearbox input speed ≤ maximum", wm, g.speed_max_in, "max", "rad/s"),
                        constraint("mean gearbox output torque ≤ T_cont_out", abs(Tm_mean), g.T_cont_out, "max", "N·m")]
            if not all(x["ok"] for x in nec):
                c.checks, c.screened_out = nec, True
                c.note = "fails on mean values (no steady-state analysis)"
                cands.append(c)
                continue
            c.gains = design_gains(c.drive, load.J_mean + c.drive.J_eq, w_v)
            cands.append(evaluate(c, load, req, law, T_c))
    feas = [c for c in cands if c.ok]
    chosen = min(feas, key=lambda c: (c.cost, c.summary.get("motor_torque_rms_Nm", 0.0))) if feas else None
    pool = [c for c in cands if not c.screened_out] or cands
    # the closest: a candidate whose steady state was found (its figures say by how much it fails) before
    # one without (whose failure says nothing about the requirement the others miss)
    closest = chosen or min(pool, key=lambda c: (c.ss is None, c.violation, c.cost))
    log(f"sizing (motion law): {len(cands)} candidates, {sum(not c.screened_out for c in cands)} analysed, "
        f"{len(feas)} feasible")
    best = chosen or closest
    g = best.gearbox
    sw = SZ.ratio_sweep(T_L, qdr, qddr, best.motor, eta=g.efficiency if g else 1.0, eta_back=g.eta_back if g else 1.0,
                        J_a=g.J_input if g else 0.0, supply=d.supply_voltage, headroom=d.voltage_headroom,
                        dt=T_c / len(qr))
    return LawSizing(law, T_c, qr, T_L, torque, cands, chosen, closest, sw, {"cpu_s": time.process_time() - t_cpu})


def finalize(c: SZ.Candidate, load, req, law, T_c, n=1024):
    """The full-resolution harmonic balance of a candidate."""
    return evaluate(c, load, req, law, T_c, n=n, tol=1e-9)


def sizing_json(sz: LawSizing, load) -> dict:
    return {"duty": "motion law", "cycle_s": sz.T_c, "torque_of_the_law": sz.torque,
            "flywheel": {"J_flywheel": 0.0, "note": "none for a motion-law duty: the motor would accelerate it "
                                                    "every cycle"},
            **sizing_common(sz, load, "tracking_peak_rad")}


# ============================================================================ the machine
def machine_scenario(req, table, cand, law, T_c: float, t_end: float) -> dict:
    """The machine's scenario tables (machine.toml): the servo tracking the law repeated per cycle."""
    dm, m, g = cand.drive, cand.motor, cand.gains
    i_max = min(x for x in (req.drive.current_limit, m.T_peak / m.k_m) if x is not None)
    d = req.duty.law
    lawt = {"kind": d.kind, "Phi": float(TWO_PI * dm.z), "T": float(law.T)}
    if d.kind == "pseudopoly":
        lawt["gammas"] = [float(x) for x in law.gammas]
    else:
        lawt.update(m=int(law.m), p=int(law.p), interior_over_Phi=[float(x) for x in law.params])
    return {
        "scenario": {"name": req.name, "title": req.design.title or f"designed machine {req.name}",
                     "description": (req.design.description + " " if req.design.description else "")
                     + "Written by `mjbench design`: catalogue motor and gearbox, cascade servo tracking the crank's "
                       "motion law once round per cycle; starts from rest, its last cycle is the verified steady state."},
        "mechanism": table,
        "drive": dm.as_drive_table(v_max=float(req.drive.supply_voltage), i_max=float(i_max)),
        "initial": {"q0": 0.0, "qd0": 0.0, "I0": 0.0},
        "simulation": {"t_end": float(t_end), "dt": float(req.verify.dt), "record_dt": _record_dt(req.verify.dt, T_c),
                       "mode": "servo", "backend": "both"},
        "law": lawt,
        "modes": {"servo": {"type": "servo", "kpp": float(g.kpp), "kvp": float(g.kvp), "kvi": float(g.kvi),
                            "kffv": float(g.kffv), "kffa": float(g.kffa), "v_limit": float(req.drive.supply_voltage),
                            "reference": {"type": "law", "period": float(T_c)}}},
        "metrics": {"chi_window": [float(t_end - T_c), float(t_end)], "steady_start": float(max(0.0, t_end - T_c))},
    }


def _record_dt(dt, T):
    k = max(1, int(round(T / 2000.0 / dt)))
    return float(k * dt)


def on_grid(t, req, T_c):
    """t rounded up to the recording grid (the last sample falls on t_end)."""
    rdt = _record_dt(req.verify.dt, T_c)
    return math.ceil(t / rdt - 1e-9) * rdt


# ============================================================================ verification


def measure(tr, dm: DriveModel, ref_angle, T_c: float, motor, T_amb) -> dict:
    """Figures of the last complete cycle [t_end − T_c, t_end] of a run (the prediction's
    counterparts); ``ref_angle(t)``: the crank's reference angle [rad]."""

    b = float(tr.t[-1])
    a = b - T_c
    if a < tr.t[0] - 1e-9:
        raise NoSteadyState("the verification run is shorter than one cycle")
    sel = _cycle(tr, a, b)
    tt, I, V, wm, q, qd = tr.t[sel], tr.current[sel], tr.voltage[sel], tr.omega[sel], tr.q[sel], tr.qd[sel]

    def rms(x):
        return float(np.sqrt(np.trapezoid(np.asarray(x) ** 2, tt) / (tt[-1] - tt[0])))

    e = q - ref_angle(tt)
    Tg = dm.gear_output_of_run(I, wm, tr.qdd[sel])
    out = {"cycle_s": [a, b], "current_rms_A": rms(I), "current_peak_A": float(np.max(np.abs(I))),
           "motor_torque_rms_Nm": dm.k_m * rms(I), "motor_torque_peak_Nm": dm.k_m * float(np.max(np.abs(I))),
           "gear_torque_rms_Nm": rms(Tg), "gear_torque_peak_Nm": float(np.max(np.abs(Tg))),
           "gear_work_per_cycle_J": float(np.trapezoid(Tg * qd, tt)),
           "voltage_peak_V": float(np.max(np.abs(V))), "tracking_rms_rad": rms(e),
           "tracking_peak_rad": float(np.max(np.abs(e))), "mean_speed_rad_s": float((q[-1] - q[0]) / (tt[-1] - tt[0])),
           "motor_speed_max_rad_s": float(np.max(np.abs(wm))), "chi": float(M.chi(tr.t, tr.omega, a, b)),
           "closure_max_m": float(np.max(np.abs(tr.closure[sel]))) if tr.has("closure_error_m") else 0.0}
    out["T_winding_C"] = TH.steady(rms(I) ** 2, motor, T_amb)["T_winding_C"]
    return out


def periodicity(tr, ref_angle, T_c: float) -> float:
    """Relative difference of the RMS current and of the RMS tracking error between the last two
    cycles (0: periodic)."""
    b = float(tr.t[-1])
    if b - 2 * T_c < tr.t[0] - 1e-9:
        return math.inf
    v = []
    for a in (b - 2 * T_c, b - T_c):
        sel = _cycle(tr, a, a + T_c)
        e = tr.q[sel] - ref_angle(tr.t[sel])
        v.append((math.sqrt(float(np.mean(tr.current[sel] ** 2))), math.sqrt(float(np.mean(e * e)))))
    return max(abs(v[1][0] - v[0][0]) / max(v[1][0], 1e-12), abs(v[1][1] - v[0][1]) / max(v[1][1], 1e-12))


#: tolerance of the tracking-error checks, × the requirement's tolerance: the error is the small
#: difference of the reference and the motion (here 1e-4 of a turn), its prediction the continuous-time
#: reading of a servo sampled every co-step — as the temperature rise, twice the current's tolerance
TRACKING_FACTOR = 2.0


def checks_of(pred: dict, ach: dict, pred_th: dict, T_amb: float, tol: float) -> list:
    """{name, predicted, achieved, rel_diff, tolerance, ok} for every verified prediction."""

    hb = "harmonic balance of the reduced model's tracking loop vs the multibody run"
    out, temp = drive_checks(pred, ach, pred_th, T_amb, tol, hb)
    note = hb + "; a small difference of two large signals: twice the current tolerance"
    for key, name in (("tracking_rms_rad", "tracking error |q_ref − q| RMS [rad]"),
                      ("tracking_peak_rad", "tracking error |q_ref − q| peak [rad]")):
        out.append(check_row(name, pred[key], ach[key], TRACKING_FACTOR * tol, note))
    return out + [temp]


# ============================================================================ the command's law branch
def design(req, res: dict, syn, table, cat, clock, t0c, t0w, out, force, log, verify=True, tune=None) -> dict:
    """Sizing, control, verification and outputs of a motion-law duty (after the synthesis of
    :func:`mjbench.design.pipeline.design`, whose ``res`` this continues): the stages of the module
    doc, one function each below."""

    law, T_c = law_of(req)
    res["duty"].update(law=describe(req, law, T_c), tracking_error_max_rad=req.duty.tracking_error_max)
    load, sz, failures, stop = _sizing_stage(req, cat, table, law, T_c, res, clock, log)
    if stop:
        return PL._finish(res, req, failures, None, clock, t0c, t0w, out, force, log)
    cand = sz.chosen
    log(f"chosen: {cand.label}; RMS motor torque {cand.summary['motor_torque_rms_Nm']:.4g} N·m, peak tracking error "
        f"{cand.summary['tracking_peak_rad']:.4g} rad")
    M_mean = load.J_mean + cand.drive.J_eq
    do_tune = req.control.tune if tune is None else tune
    final, ctl = _control_stage(req, table, cand, load, law, T_c, M_mean, do_tune, clock)
    t_end = _prediction(res, ctl, final, req, law, T_c, M_mean)
    scn_doc = machine_scenario(req, table, final, law, T_c, t_end)
    scn = SC.from_raw(scn_doc, f"design:{req.name}")
    res["machine"] = scn_doc
    ach, trs = None, {}
    if verify:
        scn_doc, scn, ach, trs = _verification(req, res, table, final, law, T_c, t_end, scn_doc, scn, clock)
        failures += _checks(res, req, final, ach)
    failures += _analysis_stage(req, res, syn, scn, final, ach, clock)
    res["_trajectories"] = trs
    return PL._finish(res, req, failures, scn_doc, clock, t0c, t0w, out, force, log)


def _sizing_stage(req, cat, table, law, T_c, res, clock, log):
    """Stage "sizing" (stage 1, the catalogue search) → (load model, LawSizing, failures, stop):
    ``stop`` when no candidate is chosen or the chosen one fails at full resolution
    (``res["closest"]``: the best one, its failing checks in ``failures``); ``res`` gets ``sizing``
    and ``_sizing``."""

    failures = []
    with clock("sizing"):
        mech = MR.from_dict(table)
        if mech.internal or getattr(getattr(mech, "_tab", None), "lo", None) is not None:
            raise ParameterError(f"mechanism {table.get('type')!r}: the design sizes rigid machines whose input turns "
                                 f"fully (internal elastic coordinates or a slide input are not supported)")
        load = LoadModel(mech, req.duty.omega)
        sz = size(load, req, cat, law, T_c, log=log)
        best = sz.chosen or sz.closest
        if best.gains is not None and not best.screened_out:
            if sz.chosen is None:
                SZ.refine_closest(best, lambda: finalize(best, load, req, law, T_c))
            else:
                finalize(best, load, req, law, T_c)
    res["sizing"] = sizing_json(sz, load)
    res["_sizing"] = sz
    if sz.chosen is None or not sz.chosen.ok:
        lim = req.duty.tracking_error_max
        peaks = [c.summary["tracking_peak_rad"] for c in sz.candidates if c.ss is not None and c.summary]
        if lim is not None and peaks and min(peaks) > lim:  # the bound itself: no candidate comes near it
            failures.append(dict(constraint(
                "peak tracking error ≤ tracking_error_max, best of every analysed candidate", min(peaks), float(lim),
                "max", "rad", note=f"no candidate of the catalogue ({len(peaks)} with a periodic steady state) tracks "
                                   f"the law this closely with the design-rule servo"), stage="sizing",
                                 candidate="all"))
        failures += [dict(c, stage="sizing", candidate=best.label) for c in best.checks if not c["ok"]]
        res["closest"] = best.describe()
        return load, sz, failures, True
    return load, sz, failures, False


def _run_length(drive, M_mean, g: ServoGains, req, T_c):
    """(verification run length [s]: the cycles asked plus the loop's settling, at most MAX_CYCLES,
    on the recording grid; the settling time [s])."""
    ts = settling_time(drive, M_mean, g)
    n = req.verify.cycles + math.ceil((ts if math.isfinite(ts) else 0.0) / T_c)
    return on_grid(min(n, MAX_CYCLES) * T_c, req, T_c), ts


def _control_stage(req, table, cand, load, law, T_c, M_mean, do_tune, clock):
    """Stage "tuning" → (the final candidate, the ``control`` entry so far): the design rule's gains
    (stage 2), the box ×/÷ BOX around them, then ``mjbench.tune`` within it when ``do_tune``
    (stage 4); the tuned gains kept only if the harmonic balance accepts them."""
    g0 = cand.gains
    ctl = {"controller": "servo (cascade: P position, PI velocity, feed-forward)",
           "design_rule": {"gains": g0.as_dict(), "velocity_crossover_rad_s": req.control.tracking_bandwidth_ratio
                           * TWO_PI / float(law.T), "zero_ratio": ZERO_RATIO, "position_ratio": POSITION_RATIO,
                           "basis": "velocity PI crossover ω_v on the mean-inertia plant, its zero at ω_v/4; position "
                                    "loop K_pp = ω_v/4; feed-forward K_ffv = k_m + R·λ/k_m, K_ffa = R·M̄/(η·z²·k_m)"}}
    final = cand
    with clock("tuning"):
        box = {k: (getattr(g0, k) / BOX, getattr(g0, k) * BOX) for k in ("kpp", "kvp", "kvi")}
        ctl["box"] = {k: list(v) for k, v in box.items()}
        if do_tune:
            final = _tuned(req, table, cand, load, law, T_c, M_mean, box, ctl)
        else:
            ctl["source"] = "design rule ([control] tune = false)"
    return final, ctl


def _tuned(req, table, cand, load, law, T_c, M_mean, box, ctl):
    """``mjbench.tune`` (controller ``servo``) from the candidate's gains within ``box`` on the
    reduced backend (``ctl``: ``tune``, ``source``) → the tuned candidate if the harmonic balance
    accepts it, else ``cand``."""

    g0 = cand.gains
    t_end, _ = _run_length(cand.drive, M_mean, g0, req, T_c)
    scn0 = SC.from_raw(machine_scenario(req, table, cand, law, T_c, t_end), f"design:{req.name}")
    c = req.control
    try:
        tr = T.tune(scn0, controller="servo", objective=c.objective,
                    limits={"voltage": float(req.drive.supply_voltage), "current": float(scn0.drive.i_max)},
                    n_global=c.n_global, starts=1, maxfev=c.maxfev, bounds=box, seed=0, t_end=t_end,
                    backend="reduced", verify=1, margins=list(c.margins), margin_mode="penalty",
                    margin_angles=c.margin_angles, log=lambda *_: None)
        gt = ServoGains(tr.best["kpp"], tr.best["kvp"], tr.best["kvi"], g0.kffv, g0.kffa)
        ctl["tune"] = {"best": tr.best, "baseline": tr.baseline, "objective": tr.objective,
                       "search": PL._clean_metrics(tr.search), "validation": PL._clean_metrics(tr.validation),
                       "evaluations": tr.history.get("evaluations"), "at_bound": tr.history.get("at_bound"),
                       "seconds": tr.history.get("seconds"), "margins": [list(m) for m in tr.margins]}
        tuned = SZ.Candidate(cand.motor, cand.gearbox, cand.drive, 0.0, gt, cost=cand.cost)
        finalize(tuned, load, req, law, T_c)
        return PL.accept_tuned(ctl, tuned, cand, "mjbench.tune, servo, " + c.objective)
    except Exception as e:  # noqa: BLE001 - tuning trouble keeps the design rule, reported
        ctl["source"] = f"design rule: tuning failed ({type(e).__name__}: {e})"
    return cand


def _prediction(res, ctl, final, req, law, T_c, M_mean):
    """The final gains' loop figures into ``ctl`` (then ``res["control"]``), the predicted figures
    (``res["prediction"]``, ``res["chosen"]``, ``res["_final"]``) → the verification run's length [s]."""
    gains = final.gains
    ctl["final"] = gains.as_dict()
    poles = closed_loop_poles(final.drive, M_mean, gains)
    ctl["closed_loop_poles"] = [[float(p.real), float(p.imag)] for p in poles]
    ctl["slowest_decay_1_s"] = float(-max(p.real for p in poles))
    t_end, t_settle = _run_length(final.drive, M_mean, gains, req, T_c)
    ctl["settling_time_s"] = t_settle
    res["control"] = ctl
    res["prediction"] = {**final.summary, "thermal": final.thermal,
                         "harmonic_balance": {"samples": final.ss["n"], "iterations": final.ss["iterations"],
                                              "residual": final.ss["residual"], "integral_mean_V": final.ss["s0"]}}
    if T_c - float(law.T) > 1e-9 * T_c:
        res["prediction"]["note"] = (
            "the crank dwells: at rest the motor speed chatters about zero in the simulation, and the gear efficiency's "
            "direction and the Coulomb friction take a mean value the harmonic balance rounds (sgn → tanh); against a "
            "static load in the dwell the RMS figures agree less closely (docs/design.md §7: 1-3 % measured)")
    res["chosen"] = final.describe()
    res["_final"] = final
    return t_end


def _verification(req, res, table, final, law, T_c, t_end, scn_doc, scn, clock):
    """Stage "verification" (stage 5): the machine (``scn_doc``, ``scn``: run length ``t_end``) on the
    multibody backend from rest, longer runs (up to MAX_CYCLES) until its last two cycles agree →
    (scenario doc, scenario, achieved figures of the last cycle, {"multibody": trajectory});
    ``res``: ``machine`` (a longer run), ``verification``."""

    with clock("verification"):

        z = float(final.drive.z)
        for attempt in range(ATTEMPTS):
            mach = SC.make_machine(scn)
            ref = mach.controller.reference

            def ref_angle(t, ref=ref):
                return ref.reference_angle(t) / z

            tr = simulate(mach, "multibody", t_end, record_dt=scn.simulation.record_dt,
                          options=backend_options(scn, "multibody"))
            drift = periodicity(tr, ref_angle, T_c)
            if drift <= 0.05 * req.verify.tolerance or t_end >= MAX_CYCLES * T_c - 1e-9 or attempt == ATTEMPTS - 1:
                break  # (the last attempt's run is the one reported: t_end, machine.toml describe it)
            t_end = on_grid(min(MAX_CYCLES, 2 * round(t_end / T_c)) * T_c, req, T_c)
            scn_doc = machine_scenario(req, table, final, law, T_c, t_end)
            scn = SC.from_raw(scn_doc, f"design:{req.name}")
            res["machine"] = scn_doc
        ach = measure(tr, final.drive, ref_angle, T_c, final.motor, req.duty.ambient_temperature)
    res["verification"] = {"backend": "multibody", "t_end_s": t_end, "achieved": ach,
                           "last_two_cycles_rel_diff": drift, "loop": tr.meta.get("loop", "")}
    return scn_doc, scn, ach, {"multibody": tr}


def _checks(res, req, final, ach) -> list:
    """``res["checks"]``: the prediction against the multibody run (:func:`checks_of`) → the failing
    ones as failures of stage "verification"."""
    res["checks"] = checks_of(final.summary, ach, final.thermal, req.duty.ambient_temperature, req.verify.tolerance)
    return [dict(constraint(f"check: {c['name']}", c["achieved"], compare="true", ok=False,
                            note=f"predicted {c['predicted']:.6g}, rel. diff {c['rel_diff']:+.3g} > "
                                 f"{c['tolerance']:.3g}"), stage="verification")
            for c in res["checks"] if not c["ok"]]


def _analysis_stage(req, res, syn, scn, final, ach, clock) -> list:
    """Stage "analysis": ``res["requirements_table"]`` (the pipeline's rows, plus the tracking error's
    when verified) → its failing rows as failures of stage "requirements"."""

    with clock("analysis"):
        rows = PL.requirements_table(req, syn, scn, final, ach, res.get("synthesis", {}))
        if ach is not None:
            src = "multibody run, last cycle"
            lim = req.duty.tracking_error_max
            rows.append(PL._row("peak tracking error |q_ref − q|", None if lim is None else float(lim),
                                ach["tracking_peak_rad"], "max" if lim is not None else "info", "rad", src,
                                ok=None if lim is not None else True))
            rows.append(PL._row("RMS tracking error", None, ach["tracking_rms_rad"], "info", "rad", src, ok=True))
        res["requirements_table"] = rows
    return [dict(r, stage="requirements") for r in res["requirements_table"] if r["ok"] is False]
