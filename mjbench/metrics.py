"""Metrics on trajectories: plain functions on NumPy arrays, results as plain dicts.

χ (seed 000 Eq 22) = (φ̇_max − φ̇_min) / φ̇_av, the speed fluctuation over a crank cycle or a time
window divided by its average.  ``average="mean"`` takes the time mean (trapezoid), ``"midrange"``
takes (max + min)/2 (the paper does not say which; see docs/errata.md).
"""
from __future__ import annotations

import numpy as np

from .errors import ParameterError


def _window(t, t0=None, t1=None):
    t0 = t[0] if t0 is None else t0
    t1 = t[-1] if t1 is None else t1
    sel = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
    if sel.sum() < 2:
        raise ParameterError(f"window [{t0}, {t1}] s holds fewer than 2 samples of the trajectory "
                             f"(t = {t[0]:.4g} .. {t[-1]:.4g} s)")
    return sel


def time_mean(t, x):
    """Time average of x over the samples (trapezoid) — the mean of a non-uniformly sampled signal."""
    if len(t) < 2:
        return float(x[0])
    return float(np.trapezoid(x, t) / (t[-1] - t[0]))


def chi(t, omega, t0=None, t1=None, average="mean"):
    """χ of Eq 22 over the window [t0, t1] (defaults: whole record)."""
    sel = _window(t, t0, t1)
    w, tt = omega[sel], t[sel]
    wmax, wmin = float(w.max()), float(w.min())
    if average == "mean":
        av = time_mean(tt, w)
    elif average == "midrange":
        av = 0.5 * (wmax + wmin)
    else:
        raise ParameterError(f"metrics.chi_average = {average!r}: choose 'mean' or 'midrange'")
    if av == 0:
        raise ParameterError("χ undefined: zero average speed in the window")
    return (wmax - wmin) / av


def cycles(t, q):
    """(t_start, t_end) of every complete crank cycle: the unwrapped crank angle advances by 2π
    (measured from its first sample, in the direction of net rotation)."""
    q = np.asarray(q, dtype=float)
    s = 1.0 if q[-1] >= q[0] else -1.0
    u = s * (q - q[0])
    k = np.floor(u / (2 * np.pi))
    kmax = np.maximum.accumulate(k)
    edges = np.flatnonzero(np.diff(kmax) > 0) + 1  # first sample past a new multiple of 2π
    if len(edges) < 2:
        return np.empty((0, 2))
    target = 2 * np.pi * kmax[edges]
    f = (target - u[edges - 1]) / (u[edges] - u[edges - 1])
    times = t[edges - 1] + f * (t[edges] - t[edges - 1])
    return np.column_stack([times[:-1], times[1:]])


def chi_per_cycle(t, q, omega, average="mean"):
    """χ for every complete crank cycle: (array of (t_start, t_end), array of χ)."""
    cyc = cycles(t, q)
    vals = np.array([chi(t, omega, a, b, average) for a, b in cyc])
    return cyc, vals


def rel_difference(t_ref, x_ref, t_other, x_other, t0=None, t1=None):
    """Max and RMS of |x_other − x_ref| / max|x_ref| on the reference samples (x_other linearly
    interpolated).  Normalised by the peak of the reference: a relative error that stays meaningful
    when the signal crosses zero (start-up from rest)."""
    sel = _window(t_ref, t0, t1)
    xr = x_ref[sel]
    xo = np.interp(t_ref[sel], t_other, x_other)
    scale = float(np.max(np.abs(xr)))
    if scale == 0:
        raise ParameterError("relative difference undefined: the reference signal is identically zero")
    d = np.abs(xo - xr) / scale
    return float(d.max()), float(np.sqrt(np.mean(d * d)))


def energy(t, p, t0=None, t1=None):
    """∫ p dt over the window [J]."""
    sel = _window(t, t0, t1)
    return float(np.trapezoid(p[sel], t[sel]))


def summary(traj, chi_window=None, average="mean", steady_from=None):
    """Standard metrics of a machine trajectory (dict of floats, SI units in the key names).

    chi_window: (t0, t1) for the windowed χ; steady_from: start of the 'steady state' [s]
    (default: half the run) for the mean speed and the per-cycle χ statistics.
    """
    t, om = traj.t, traj.omega
    if steady_from is None or steady_from >= t[-1] - 1e-12:  # default, or a run too short for it
        steady_from = t[-1] / 2
    out = {
        "t_end_s": float(t[-1]),
        "steady_from_s": float(steady_from),
        "mean_motor_speed_rad_s": time_mean(t[t >= steady_from], om[t >= steady_from]),
        "mean_crank_speed_rad_s": time_mean(t[t >= steady_from], traj.qd[t >= steady_from]),
        "peak_voltage_V": float(np.max(np.abs(traj.voltage))),
        "peak_current_A": float(np.max(np.abs(traj.current))),
        "peak_power_elec_W": float(np.max(traj.p_elec)),
        "peak_power_mech_W": float(np.max(traj.p_mech)),
        "energy_elec_J": energy(t, traj.p_elec),
        "energy_mech_J": energy(t, traj.p_mech),
        "max_closure_error_m": float(np.max(traj.closure)),
    }
    cyc, vals = chi_per_cycle(t, traj.q, om, average)
    if len(vals):
        out["chi_last_cycle"] = float(vals[-1])
        out["last_cycle_start_s"] = float(cyc[-1, 0])
        out["last_cycle_end_s"] = float(cyc[-1, 1])
        steady = vals[cyc[:, 0] >= steady_from]
        if len(steady):
            out["chi_steady_mean"] = float(np.mean(steady))
        out["n_cycles"] = int(len(vals))
        out["chi_cycles"] = [{"t_start_s": float(a), "t_end_s": float(b), "chi": float(v)}
                             for (a, b), v in zip(cyc, vals)]
    if chi_window is not None:
        t0, t1 = chi_window
        if t[-1] >= t1 - 1e-9:
            out["chi_window"] = chi(t, om, t0, t1, average)
            out["chi_window_s"] = [float(t0), float(t1)]
    return out


def compare(traj_ref, traj_other, key="crank_speed_rad_s"):
    """Max and RMS relative difference of a column between two trajectories (see rel_difference)."""
    mx, rms = rel_difference(traj_ref.t, traj_ref[key], traj_other.t, traj_other[key])
    return {"max_rel_diff": mx, "rms_rel_diff": rms, "column": key,
            "normalisation": "peak |reference| over the run"}
