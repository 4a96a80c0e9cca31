"""The speed loop: the design rule for the PID gains, its linear model, and tuning with mjbench.tune.

Plant on the motor shaft with the machine's mean inertia M̄ (crank side, J̄ + J_eq + flywheel):
G(s) = φ̇/V = η·k_m / ((R + L·s)(J_mot·s + λ) + η·k_m²), J_mot = M̄/z².  Controller (controllers/pid.py,
angle-integral form): C(s) = K_p + K_i/s + K_d·s.

Design rule: crossover ω_c = ``bandwidth_ratio`` × Ω (below the cycle frequency by default, so that
the inertia — flywheel — carries the cycle's torque peaks and the motor the mean), PI zero at
ω_c/2 (K_i = K_p·ω_c/2, phase margin ≈ 60°), |C(jω_c)·G(jω_c)| = 1, K_d = 0.

Tuning (:func:`tune_gains`): :func:`mjbench.tune.tune` on the machine's scenario, within a box of
gains the sizing model accepts (every corner's periodic steady state, :mod:`periodic`, keeps the
current, torque, temperature, voltage and χ within the requirements), with the requirement's
margin constraints and objective.
"""
from __future__ import annotations

import math

import numpy as np

from .periodic import Gains
from .. import tune as T

ZERO_RATIO = 0.5  #: PI zero / crossover of the design rule (phase margin ≈ 60°)


def plant(s, drive, M_mean, eta=None):
    eta = drive.eta if eta is None else eta
    Jm = M_mean / drive.z ** 2
    return eta * drive.k_m / ((drive.R + drive.L * s) * (Jm * s + drive.lam) + eta * drive.k_m ** 2)


def design_gains(drive, M_mean, w_c, zero_ratio=ZERO_RATIO) -> Gains:
    """PI gains of the design rule (module doc) for crossover w_c [rad/s]."""
    G = plant(1j * w_c, drive, M_mean)
    kp = 1.0 / (abs(G) * abs(1.0 - 1j * zero_ratio))
    return Gains(float(kp), float(kp * zero_ratio * w_c), 0.0)


def closed_loop_poles(drive, M_mean, gains: Gains, eta=None) -> np.ndarray:
    """Poles of the linear speed loop: s·den(s) + η·k_m·(K_d s² + K_p s + K_i) = 0."""
    eta = drive.eta if eta is None else eta
    Jm = M_mean / drive.z ** 2
    R, L, lam, k = drive.R, drive.L, drive.lam, drive.k_m
    den = np.polymul([L, R], [Jm, lam])
    den = np.polyadd(den, [eta * k * k])
    char = np.polyadd(np.polymul(den, [1.0, 0.0]), eta * k * np.array([gains.kd, gains.kp, gains.ki]))
    return np.roots(char)


def settling_time(drive, M_mean, gains: Gains, decades: float = 3.5) -> float:
    """Time for the slowest closed-loop mode to decay by 10^-decades [s] (ln(10)·decades/σ_min)."""
    p = closed_loop_poles(drive, M_mean, gains)
    sig = -max(float(x.real) for x in p)
    return math.inf if sig <= 0 else math.log(10.0) * decades / sig


def ripple_transfer(drive, M_mean, gains: Gains, w):
    """Speed ripple with the drive and its loop / speed ripple of the inertia alone, for a load
    torque at frequency w (array): J s / (J s + λ + η k_m (k_m + C(s))/(R + L s)), motor side."""
    s = 1j * np.asarray(w, float)
    Jm = M_mean / drive.z ** 2
    C = gains.kp + gains.ki / s + gains.kd * s
    return Jm * s / (Jm * s + drive.lam + drive.eta * drive.k_m * (drive.k_m + C) / (drive.R + drive.L * s))


def ripple_ratio(drive, M_mean, gains: Gains, w: float) -> float:
    """|ripple_transfer| at one frequency."""
    return float(abs(ripple_transfer(drive, M_mean, gains, w)))


def crossover(drive, M_mean, gains: Gains) -> float:
    """Gain crossover of C·G [rad/s] (bisection on a log grid), NaN if none."""
    w = np.geomspace(1e-3, 1e5, 2000)
    s = 1j * w
    Lg = np.abs((gains.kp + gains.ki / s + gains.kd * s) * plant(s, drive, M_mean))
    k = np.flatnonzero((Lg[:-1] >= 1) & (Lg[1:] < 1))
    return float(w[k[-1]]) if len(k) else math.nan


def tune_gains(scn, req, x0: Gains, box: dict, t_end: float, limits: dict, log=None):
    """mjbench.tune.tune on the machine scenario (mode ``pi``, controller ``pid``), within ``box``
    = {gain: (lo, hi)}, objective and margins of ``req.control``; returns the TuneResult."""

    c = req.control
    return T.tune(scn, controller="pid", objective=c.objective, limits=limits, n_global=c.n_global, starts=1,
                  maxfev=c.maxfev, bounds=box, seed=0, t_end=t_end, backend="reduced", verify=1,
                  margins=list(c.margins), margin_mode="penalty", margin_angles=c.margin_angles,
                  log=log or (lambda *_: None))
