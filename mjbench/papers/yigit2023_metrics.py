"""Metrics of the Yiğit & Şen scenario (quick-return + SMC), computed on Trajectory objects.

Steady state = samples with t ≥ ``t_start`` cut to a whole number of crank revolutions (so that the
mean is a cycle mean, not biased by a partial cycle); if less than one revolution is available
the whole window is used.  All speeds are crank speeds [rad/s].
"""
from __future__ import annotations

import math

import numpy as np


def steady_mask(tr, t_start: float):
    """Boolean mask of the steady window: t ≥ t_start, trimmed to whole crank revolutions."""
    t, q = tr.t, tr.q
    m = t >= t_start
    if not m.any():
        raise ValueError(f"steady window t >= {t_start} s is empty (run ends at {t[-1]:.6g} s)")
    i0 = int(np.argmax(m))
    turns = (q[i0:] - q[i0]) / (2 * math.pi)
    nrev = math.floor(abs(turns[-1]))
    if nrev >= 1:
        i1 = i0 + int(np.argmax(np.abs(turns) >= nrev))
        m = np.zeros_like(m)
        m[i0:i1 + 1] = True
    return m


def speed_stats(tr, t_start: float = 2.0) -> dict:
    """Crank speed min / max / mean [rad/s] and fluctuation (max − min)/mean in steady state."""
    m = steady_mask(tr, t_start)
    w = tr.qd[m]
    mean = float(np.mean(w))
    return {"speed_min": float(w.min()), "speed_max": float(w.max()), "speed_mean": mean,
            "fluctuation": float((w.max() - w.min()) / mean) if mean != 0 else math.nan,
            "window_s": (float(tr.t[m][0]), float(tr.t[m][-1]))}


def steady_error(tr, omega_d: float, t_start: float = 2.0) -> dict:
    """Relative crank-speed error e = (ω − ω_d)/ω_d in steady state: mean (bias), max |e|, rms."""
    m = steady_mask(tr, t_start)
    e = (tr.qd[m] - omega_d) / omega_d
    return {"error_mean": float(np.mean(e)), "error_abs_max": float(np.max(np.abs(e))),
            "error_rms": float(np.sqrt(np.mean(e * e))),
            "error_abs_mean": float(abs(np.mean(e)))}


def switching(tr, t_start: float = 2.0, deadband: float = 0.0) -> dict:
    """Chattering: number of sign changes of the armature voltage (|V| > deadband) in the steady
    window, and the rate [1/s]."""
    m = steady_mask(tr, t_start)
    v = tr.voltage[m]
    s = np.sign(np.where(np.abs(v) > deadband, v, 0.0))
    s = s[s != 0]
    n = int(np.count_nonzero(np.diff(s))) if len(s) > 1 else 0
    dur = float(tr.t[m][-1] - tr.t[m][0])
    return {"switches": n, "switch_rate_hz": n / dur if dur > 0 else math.nan}


def current_stats(tr, t_start: float = 2.0) -> dict:
    """Peak |current| over the whole run and in steady state [A]; steady rms current."""
    m = steady_mask(tr, t_start)
    i = tr.current
    return {"current_peak": float(np.max(np.abs(i))), "current_peak_steady": float(np.max(np.abs(i[m]))),
            "current_rms_steady": float(np.sqrt(np.mean(i[m] ** 2)))}


def summary(tr, omega_d: float | None = None, t_start: float = 2.0) -> dict:
    """All scenario metrics in one flat dict."""
    out = {}
    out.update(speed_stats(tr, t_start))
    if omega_d:
        out.update(steady_error(tr, omega_d, t_start))
    out.update(switching(tr, t_start))
    out.update(current_stats(tr, t_start))
    return out


def compare(tr_a, tr_b) -> dict:
    """Largest differences between two runs on the same time grid (e.g. multibody vs reduced)."""
    n = min(tr_a.n, tr_b.n)
    return {"max_dq": float(np.max(np.abs(tr_a.q[:n] - tr_b.q[:n]))),
            "max_dqd": float(np.max(np.abs(tr_a.qd[:n] - tr_b.qd[:n]))),
            "max_dI": float(np.max(np.abs(tr_a.current[:n] - tr_b.current[:n])))}
