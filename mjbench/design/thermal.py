"""Two-node thermal model of a DC motor (winding + housing), copper resistance rising with temperature.

    C_w·dT_w/dt = I²·R(T_w) − (T_w − T_h)/R_wh,     C_h·dT_h/dt = (T_w − T_h)/R_wh − (T_h − T_a)/R_ha
    R(T) = R₂₅·(1 + α_Cu·(T − 25 °C)),  α_Cu = 0.00393 /K,  C_w = τ_w/R_wh,  C_h = τ_h/R_ha

For a duty whose cycle is much shorter than τ_w the winding sees the cycle's mean I² (the RMS
current); the steady state is then closed form:

    ΔT = T_w − T_a = ⟨I²⟩·R₂₅·R_th·(1 + α(T_a − 25)) / (1 − ⟨I²⟩·R₂₅·R_th·α),   R_th = R_wh + R_ha

(no steady state — thermal runaway — when the denominator is ≤ 0).  The catalogue's continuous
torque is rated at 25 °C ambient; at T_a it is derated by √((T_max − T_a)/(T_max − 25)) (the copper
loss the winding limit allows scales with the temperature rise).
"""
from __future__ import annotations

import math

import numpy as np

ALPHA_CU = 0.00393  #: 1/K, copper near room temperature


def steady(i2_mean: float, motor, T_amb: float = 25.0) -> dict:
    """Steady winding and housing temperatures [°C] for the mean square current [A²]."""
    Rth = motor.R_th_wh + motor.R_th_ha
    k = i2_mean * motor.R * Rth
    den = 1.0 - k * ALPHA_CU
    if den <= 0:
        return {"T_winding_C": math.inf, "T_housing_C": math.inf, "loss_W": math.inf, "runaway": True}
    dT = k * (1.0 + ALPHA_CU * (T_amb - 25.0)) / den
    Tw = T_amb + dT
    P = i2_mean * motor.R * (1.0 + ALPHA_CU * (Tw - 25.0))
    return {"T_winding_C": Tw, "T_housing_C": T_amb + P * motor.R_th_ha, "loss_W": P,
            "R_hot_ohm": motor.R * (1.0 + ALPHA_CU * (Tw - 25.0)), "runaway": False}


def transient(i2_mean: float, motor, T_amb: float = 25.0, t_end: float = None, n: int = 2000) -> dict:
    """Winding and housing temperatures from cold (both at T_a) under a constant mean I², by the
    exact solution of the linear two-node system with R frozen over each of n steps (R(T) updated
    step by step): (t, T_w, T_h) and the time to 95 % of the steady rise."""
    if t_end is None:
        t_end = 5.0 * motor.tau_h
    Cw, Ch = motor.tau_w / motor.R_th_wh, motor.tau_h / motor.R_th_ha
    A = np.array([[-1.0 / (motor.R_th_wh * Cw), 1.0 / (motor.R_th_wh * Cw)],
                  [1.0 / (motor.R_th_wh * Ch), -(1.0 / motor.R_th_wh + 1.0 / motor.R_th_ha) / Ch]])
    from scipy.linalg import expm

    h = t_end / n
    E = expm(A * h)
    Ainv = np.linalg.inv(A)
    x = np.zeros(2)
    t = np.linspace(0.0, t_end, n + 1)
    X = np.zeros((n + 1, 2))
    for k in range(n):
        P = i2_mean * motor.R * (1.0 + ALPHA_CU * (T_amb + x[0] - 25.0))
        b = np.array([P / Cw, 0.0])
        x = E @ x + Ainv @ (E - np.eye(2)) @ b
        X[k + 1] = x
    st = steady(i2_mean, motor, T_amb)
    rise = st["T_winding_C"] - T_amb
    k95 = np.flatnonzero(X[:, 0] >= 0.95 * rise) if math.isfinite(rise) else []
    return {"t": t, "T_winding_C": T_amb + X[:, 0], "T_housing_C": T_amb + X[:, 1],
            "t95_s": float(t[k95[0]]) if len(k95) else math.inf}


def derated_continuous_torque(motor, T_amb: float) -> float:
    """Catalogue continuous torque (25 °C ambient) derated to the ambient T_a."""
    if T_amb >= motor.T_max:
        return 0.0
    return motor.T_cont * math.sqrt((motor.T_max - T_amb) / (motor.T_max - 25.0))
