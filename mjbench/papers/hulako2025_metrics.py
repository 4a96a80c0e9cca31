"""Metrics of a constant-coupler-speed run (seed 002 §4-§5.1, Table 3).  Definitions
(docs/coupler_speed.md):

* crank-speed error e(t) = q̇_trj(q(t)) − q̇(t) (Eq 22), with q̇_trj the Eq 17 reference at the
  *measured* angle, as the controller computes it;  ``crank_error_max_after`` = max |e| for
  t ≥ ``settle_time`` (§4: "under 0.1 rad/s after 1.5 s");
* coupler-point speed V_C(t) = S(q)·|q̇| (S = |dC/dq|, Eq 17), desired V_des(t) = V_C(s(q)) of
  the reference (× its ramp);  ``coupler_dev_max_after`` = max |V_C − V_des| for
  t ≥ ``settle_time`` — Table 3's "maximum deviation";
* rise time t_r: first instant at which V_C/V_des ≥ ``rise_fraction`` (0.9) starting from rest;
  ``rise_time_10_90``: the 10 % → 90 % interval;
* settling time t_s: the instant after which |V_C/V_des − 1| stays ≤ ``band_rel`` (10 %) until
  the end of the run (nan if it never does);  ``crank_settling_time``: the same with
  |e| ≤ ``crank_error_band`` (0.1 rad/s);
* ``coupler_dev_windows``: max |V_C − V_des| and max |e| over consecutive 1 s windows from
  ``settle_time`` to the end (does the deviation shrink with time after the transient?);
  ``coupler_dev_max_last_1s`` / ``crank_error_max_last_1s``: the same over the last second
  (close to the periodic steady state at 5 s).
"""
from __future__ import annotations

import math

import numpy as np

DEFAULTS = {"settle_time": 1.5, "band_rel": 0.10, "rise_fraction": 0.90, "crank_error_band": 0.1}


def coupler_speed(mechanism, q, qd):
    """Coupler-point speed V_C = |dC/dq|·|q̇| [m/s] (Eqs 15-17)."""
    return mechanism.coupler_speed_ratio(np.asarray(q, dtype=float)) * np.abs(np.asarray(qd, dtype=float))


def signals(traj, mechanism, reference) -> dict:
    """t, q̇, q̇_trj, e, V_C, V_des arrays of a trajectory."""
    t, q, qd = traj.t, traj.q, traj.qd
    vdes = np.asarray(reference.vc_at(q, t), dtype=float) + 0.0 * q
    S = mechanism.coupler_speed_ratio(q)
    qd_ref = np.minimum(vdes / S, reference.qd_max)
    return {"t": t, "q": q, "qd": qd, "qd_ref": qd_ref, "e": qd_ref - qd,
            "vc": S * np.abs(qd), "vdes": vdes}


def _last_exceed(t, bad):
    """Instant after which ``bad`` is False until the end (t[0] if never bad, nan if bad at the end)."""
    idx = np.flatnonzero(bad)
    if idx.size == 0:
        return float(t[0])
    if idx[-1] == len(t) - 1:
        return math.nan
    return float(t[idx[-1] + 1])


def compute(traj, mechanism, reference, settle_time=1.5, band_rel=0.10, rise_fraction=0.90,
            crank_error_band=0.1) -> dict:
    """Metrics dict (SI units in the keys) of one run; see the module docstring."""
    sg = signals(traj, mechanism, reference)
    t, e, vc, vdes = sg["t"], sg["e"], sg["vc"], sg["vdes"]
    after = t >= settle_time - 1e-12
    dev = vc - vdes
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(vdes > 0, vc / vdes, np.nan)
    out = {"settle_time_s": float(settle_time), "t_end_s": float(t[-1])}
    if after.any():
        out["crank_error_max_after_rad_s"] = float(np.max(np.abs(e[after])))
        out["crank_error_rms_after_rad_s"] = float(np.sqrt(np.mean(e[after] ** 2)))
        out["coupler_dev_max_after_m_s"] = float(np.max(np.abs(dev[after])))
        out["coupler_dev_rms_after_m_s"] = float(np.sqrt(np.mean(dev[after] ** 2)))
        out["coupler_speed_mean_after_m_s"] = float(np.mean(vc[after]))
    hit = np.flatnonzero(ratio >= rise_fraction)
    out["rise_time_s"] = float(t[hit[0]]) if hit.size else math.nan
    lo = np.flatnonzero(ratio >= 0.1)
    out["rise_time_10_90_s"] = float(t[hit[0]] - t[lo[0]]) if hit.size and lo.size else math.nan
    out["overshoot_rel"] = float(np.nanmax(ratio) - 1.0)
    out["settling_time_s"] = _last_exceed(t, ~(np.abs(ratio - 1.0) <= band_rel))
    out["crank_settling_time_s"] = _last_exceed(t, np.abs(e) > crank_error_band)
    edges = list(np.arange(settle_time, t[-1] - 1e-9, 1.0)) + [float(t[-1])]
    wins = []
    for a, b in zip(edges[:-1], edges[1:]):
        m = (t >= a) & (t <= b)
        if m.any():
            wins.append([float(a), float(b), float(np.max(np.abs(dev[m]))), float(np.max(np.abs(e[m])))])
    out["coupler_dev_windows"] = wins  # [t_start, t_end, max|V_C − V_des| (m/s), max|e| (rad/s)]
    last = t >= t[-1] - 1.0 - 1e-12
    out["coupler_dev_max_last_1s_m_s"] = float(np.max(np.abs(dev[last])))
    out["crank_error_max_last_1s_rad_s"] = float(np.max(np.abs(e[last])))
    out["voltage_max_V"] = float(np.max(np.abs(traj.voltage)))
    out["current_max_A"] = float(np.max(np.abs(traj.current)))
    return out


def from_run(scn, traj, machine) -> dict:
    """Metrics of a scenario run (settings from the scenario's [metrics] table)."""
    mt = scn.metrics
    cfg = {**DEFAULTS, **{k: getattr(mt, k) for k in DEFAULTS if getattr(mt, k, None) is not None}}
    ref = machine.controller.reference
    return compute(traj, machine.mechanism, ref, **cfg)


def compare_backends(ta, tb) -> dict:
    """Largest state differences between two trajectories on common samples (multibody vs reduced)."""
    n = min(ta.n, tb.n)
    return {"crank_angle_max_diff_rad": float(np.max(np.abs(ta.q[:n] - tb.q[:n]))),
            "crank_speed_max_diff_rad_s": float(np.max(np.abs(ta.qd[:n] - tb.qd[:n]))),
            "current_max_diff_A": float(np.max(np.abs(ta.current[:n] - tb.current[:n])))}
