"""Periodic steady state of the speed-controlled machine by harmonic balance (no simulation).

The machine runs at the mean crank speed Ω under mjbench's speed PID (controllers/pid.py, constant
K_p, set-point ω₀ = zΩ, the integral written as the angle error):

    V = K_p·(ω₀ − φ̇) + K_i·(ω₀t − φ) − K_d·φ̈,      φ = z·q (motor angle).

In steady state q(τ) = Ωτ + δ(τ) with δ periodic (period T = 2π/Ω).  For a trial δ the
*inverse dynamics* of that motion gives the torque the crank needs (:class:`model.LoadModel`,
:class:`model.DriveModel`: J, J', E_p', loads, friction, rotor inertia, the gear efficiency), the
motor current I = T_m/k_m and the voltage the armature needs, V_req = R·I + L·İ + k_m·φ̇.  The
controller gives V_ctrl = −z·(K_p·δ̇ + K_i·δ + K_d·δ̈) + V₀ (V₀: the integral's mean, free).  The
residual V_req − V_ctrl is driven to zero harmonic by harmonic (spectral derivatives, N samples
per cycle) with the linear operator of the mean-inertia loop as the iteration matrix (a chord
Newton method):

    H(s) = (R + L·s)·(M̄s² + z²λ·s)/(k_m·z·η̄) + k_m·z·s + z·(K_p·s + K_i + K_d·s²).

At convergence the solution is the exact periodic orbit of the reduced model (up to the N-point
discretisation and the continuous-time reading of the sampled controller).  The integral's mean
fixes the phase: in steady state the crank lags the reference by c₀ = −V₀/(z·K_i).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MjbenchError

TWO_PI = 2.0 * math.pi


class NoSteadyState(MjbenchError):
    """The harmonic balance did not converge (a machine that cannot hold the speed)."""


@dataclass
class Gains:
    """Speed PID gains on the motor shaft (controllers/pid.py units)."""

    kp: float
    ki: float
    kd: float = 0.0

    def as_dict(self):
        return {"kp": self.kp, "ki": self.ki, "kd": self.kd}


def loop_operator(s, drive, M_mean, gains, eta_eff=None):
    """H(s) of the module doc (crank-side δ → voltage residual)."""
    eta = drive.eta if eta_eff is None else eta_eff
    z = drive.z
    return ((drive.R + drive.L * s) * (M_mean * s * s + drive.c_v * s) / (drive.k_m * z * eta)
            + drive.k_m * z * s + z * (gains.kp * s + gains.ki + gains.kd * s * s))


def effective_efficiency(drive, T_req, w_motor) -> float:
    """The chord operator's efficiency for an iterate: 1 / mean of the factor dT_m/dT_req, 1/η where
    the motor drives the gear (T_req·φ̇ ≥ 0) and η_back where the load drives it back."""
    X = np.asarray(T_req, float) / drive.z
    f = np.where(X * w_motor >= 0.0, 1.0 / drive.eta, drive.eta_back)
    return 1.0 / float(np.mean(f))


def steady_state(load, drive, gains: Gains, speed: float, n: int = 1024, tol: float = 1e-9, maxit: int = 400) -> dict:
    """The periodic steady state (module doc) → dict of arrays over one cycle (``tau`` [s], ``q``,
    ``qd``, ``qdd``, ``I``, ``dI``, ``V``, ``T_m`` = k_m·I, ``T_crank`` (needed at the crank),
    ``T_gear`` (gearbox output), ``w_motor``) and scalars (``c0``, ``V0``, ``iterations``,
    ``residual``).  Raises :class:`NoSteadyState` if it does not converge."""
    W = float(speed)
    T = TWO_PI / W
    tau = T * np.arange(n) / n
    w = TWO_PI / T * np.arange(n // 2 + 1)
    jw = 1j * w
    M_mean = load.J_mean + drive.J_eq
    dh = np.zeros(n // 2 + 1, complex)
    eta_eff = drive.eta
    H = loop_operator(jw, drive, M_mean, gains, eta_eff)
    H[0] = 1.0
    vscale = drive.k_m * drive.z * W + 1e-12
    res_prev, relax = math.inf, 1.0
    out = None
    for it in range(maxit):
        d = np.fft.irfft(dh, n)
        dd = np.fft.irfft(jw * dh, n)
        ddd = np.fft.irfft(-w * w * dh, n)
        q = W * tau + d
        qd = W + dd
        J, dJ, dEp, Qp, D = load(q)
        Treq = (J + drive.J_eq) * ddd + 0.5 * dJ * qd * qd + dEp - (Qp - D * qd) + drive.c_v * qd
        wm = drive.z * qd
        Tm = drive.motor_torque(Treq, wm)
        I = Tm / drive.k_m
        Ih = np.fft.rfft(I)
        dI = np.fft.irfft(jw * Ih, n)
        Vreq = drive.R * I + drive.L * dI + drive.k_m * wm
        Vctrl = -drive.z * (gains.kp * dd + gains.ki * d + gains.kd * ddd)
        r = Vreq - Vctrl
        rh = np.fft.rfft(r) / n
        rh[0] = 0.0
        res = float(np.sqrt(2.0 * np.sum(np.abs(rh[1:]) ** 2))) / vscale
        out = (d, dd, ddd, q, qd, Treq, wm, Tm, I, dI, Vreq, Vctrl, r)
        if res < tol:
            break
        if not math.isfinite(res) or np.max(np.abs(dd)) > 0.9 * W:
            raise NoSteadyState(f"the speed loop has no periodic steady state near {W:.4g} rad/s with these gains "
                                f"(harmonic balance diverged after {it} iterations: the speed would stop or reverse)")
        if res > res_prev:  # overshoot: smaller steps
            relax = max(0.05, 0.5 * relax)
        else:
            relax = min(1.0, relax * 1.2)
        res_prev = res
        eta_new = effective_efficiency(drive, Treq, wm)
        if abs(eta_new - eta_eff) > 1e-3 * eta_eff:
            eta_eff = eta_new
            H = loop_operator(jw, drive, M_mean, gains, eta_eff)
            H[0] = 1.0
        dh = dh - relax * (rh * n) / H
        dh[0] = 0.0
    else:
        raise NoSteadyState(f"harmonic balance did not converge in {maxit} iterations (residual {res:.3g} of the "
                            f"back-EMF): the steady state is too far from the mean-inertia loop")
    d, dd, ddd, q, qd, Treq, wm, Tm, I, dI, Vreq, Vctrl, r = out
    V0 = float(np.mean(r))
    c0 = -V0 / (drive.z * gains.ki) if gains.ki > 0 else 0.0
    return {"tau": tau, "T": T, "speed": W, "delta": d, "q": q, "qd": qd, "qdd": ddd, "I": I, "dI": dI, "V": Vreq,
            "T_m": drive.k_m * I, "T_crank": Treq, "T_gear": drive.gear_output(Treq, qd, ddd), "w_motor": wm,
            "c0": c0, "V0": V0, "iterations": it + 1, "residual": res, "dh": dh, "n": n,
            "M_mean": M_mean, "eta_eff": eta_eff}


def _at(x, tau, T):
    """Spectral (exact band-limited) interpolation of a periodic sample vector at time tau."""
    n = len(x)
    X = np.fft.rfft(x) / n
    k = np.arange(len(X))
    c = np.exp(1j * TWO_PI * k * (tau % T) / T)
    wts = np.full(len(X), 2.0)
    wts[0] = 1.0
    if n % 2 == 0:
        wts[-1] = 1.0
    return float(np.real(np.sum(wts * X * c)))


def initial_state(ss: dict) -> dict:
    """(q0 = 0, q̇0, I0): the point of the periodic orbit where the crank angle is a whole number of
    turns.  A simulation started there starts at speed with the orbit's current; the speed PID's
    angle reference starts at the first measurement (controllers/reference.py), so its integral
    term starts at zero and winds up to the orbit's mean voltage V₀ within the loop's slowest
    time constant (:func:`mjbench.design.control.settling_time`)."""
    T, W = ss["T"], ss["speed"]
    # q(τ) = Ωτ + δ(τ) ≡ 0 (mod 2π): Newton from τ = −δ(0)/Ω
    tau = -ss["delta"][0] / W
    for _ in range(20):
        f = W * tau + _at(ss["delta"], tau, T)
        df = W + _at(ss["qd"] - W, tau, T)
        step = f / df
        tau -= step
        if abs(step) < 1e-15 * T:
            break
    return {"q0": 0.0, "qd0": W + _at(ss["qd"] - W, tau, T), "I0": _at(ss["I"], tau, T), "tau": tau % T}


def summary(ss: dict, drive) -> dict:
    """Figures of one cycle: RMS/peak of current, motor torque, gearbox output, voltage; χ (motor
    speed, time mean) and the largest speed deviation; the gearbox output's work per cycle
    ∮T_gear·q̇ dt (in steady state: the loads' work and the mechanism's friction per cycle)."""
    I, Tm, Tg, V, wm = ss["I"], ss["T_m"], ss["T_gear"], ss["V"], ss["w_motor"]
    rms = lambda x: float(np.sqrt(np.mean(np.asarray(x) ** 2)))  # noqa: E731
    return {"current_rms_A": rms(I), "current_peak_A": float(np.max(np.abs(I))),
            "motor_torque_rms_Nm": rms(Tm), "motor_torque_peak_Nm": float(np.max(np.abs(Tm))),
            "gear_torque_rms_Nm": rms(Tg), "gear_torque_peak_Nm": float(np.max(np.abs(Tg))),
            "voltage_peak_V": float(np.max(np.abs(V))), "voltage_mean_V": float(np.mean(V)),
            "chi": float(np.ptp(wm) / np.mean(wm)),
            "speed_dev_max_rel": float(np.max(np.abs(ss["qd"] - ss["speed"])) / ss["speed"]),
            "motor_speed_max_rad_s": float(np.max(np.abs(wm))), "mean_power_W": float(np.mean(ss["T_crank"] * ss["qd"])),
            "gear_work_per_cycle_J": float(np.mean(Tg * ss["qd"])) * ss["T"],
            "copper_loss_W": float(np.mean(I * I)) * drive.R}
