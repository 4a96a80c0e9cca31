"""Metrics on trajectories: plain functions on NumPy arrays, results as plain dicts.

χ (Incerti 2012 Eq 22) = (φ̇_max − φ̇_min) / φ̇_av, the speed fluctuation over a crank cycle or
a time window divided by its average (a fraction here; the report prints it in percent).
``average="mean"`` takes the time mean (trapezoid), ``"midrange"`` takes (max + min)/2 (the paper
does not say which; see docs/errata.md).  "The last cycle" has two readings, both in
:func:`summary`: ``chi_last_cycle``, the last *complete* cycle counted from α(0) (it may end up to
one period before the end of the run), and ``chi_last_turn``, the last 2π of crank travel ending
at the end of the run.  χ is max − min of the *recorded* samples, so it depends on their interval:
every χ is labelled with it (``chi_sampling_s``, the record's step).  Measured on the Incerti 2012
PID run (2 s) against a record of every co-step (0.1 ms): χ of the last cycle 0.10 % low at
0.5 ms and 0.17 % at 1 ms, χ in the window 0.01 % / 0.03 % low.

Coupler-point speed tracking (:func:`coupler_tracking`, Hülako & Çakar 2025 §4-§5.1, Table 3):
computed by ``mjbench run`` whenever the controller tracks a ``coupler_speed`` reference.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import ParameterError


#: the numeric metrics of :func:`summary` (a sweep row's metrics, ``--metric`` names), by name
SUMMARY_METRICS = {
    "t_end_s": "end of the run [s]",
    "steady_from_s": "start of the steady-state window [s]",
    "mean_motor_speed_rad_s": "time-mean motor speed from steady_from_s [rad/s]",
    "mean_crank_speed_rad_s": "time-mean input (crank) speed from steady_from_s [rad/s]",
    "peak_voltage_V": "peak |voltage| [V]",
    "peak_current_A": "peak |current| [A]",
    "peak_power_elec_W": "peak electrical power [W]",
    "peak_power_mech_W": "peak mechanical power [W]",
    "energy_elec_J": "electrical energy over the run [J]",
    "energy_mech_J": "mechanical energy over the run [J]",
    "max_closure_error_m": "largest loop-closure error [m]",
    "chi_last_cycle": "χ of the last complete crank cycle counted from α(0)",
    "last_cycle_start_s": "start of that cycle [s]",
    "last_cycle_end_s": "end of that cycle [s]",
    "chi_steady_mean": "mean χ of the cycles from steady_from_s",
    "n_cycles": "complete crank cycles",
    "chi_last_turn": "χ of the last 2π of crank travel ending at t_end",
    "last_turn_start_s": "start of that turn [s]",
    "last_turn_end_s": "end of that turn [s]",
    "chi_window": "χ in the scenario's metrics.chi_window",
    "chi_sampling_s": "interval of the samples χ is computed from (the record's, simulation.record_dt) [s]",
    # the end state (transient runs that never reach a periodic steady state; :func:`end_state`)
    "final_crank_angle_rad": "input (crank) angle at t_end, unwrapped [rad]",
    "final_crank_speed_rad_s": "input (crank) speed at t_end [rad/s]",
    "final_crank_accel_rad_s2": "input (crank) acceleration at t_end (the record's backward difference) [rad/s²]",
    "final_current_A": "current at t_end [A] (NaN for an ideal drive)",
    "final_voltage_V": "applied voltage at t_end [V] (NaN for an ideal drive)",
    "final_torque_crank_Nm": "drive torque on the crank at t_end [N·m]",
    "final_power_mech_W": "mechanical power of the drive at t_end [W]",
    "speed_settling_band_rad_s": "half-width of the settling band: band_rel × |crank speed at t_end| [rad/s]",
    "speed_settling_time_s": "time from which the crank speed stays within the settling band around its value at "
                             "t_end until the end [s] (t_s[0] if always inside)",
}
#: the duty figures of :func:`duty` (numeric, over the steady-state window ``duty_window_s`` =
#: [steady_from_s, t_end_s]; "steady" in every name says so)
DUTY_METRICS = {
    "current_rms_steady_A": "RMS motor current over the steady-state window [A] (what a motor's continuous "
                            "rating is compared with)",
    "current_peak_steady_A": "peak |motor current| over the steady-state window [A]",
    "torque_motor_rms_steady_Nm": "RMS electromagnetic motor torque k_m·I on the motor shaft over the steady-state "
                                  "window [N·m]",
    "torque_output_rms_steady_Nm": "RMS torque at the gearbox output (crank shaft) over the steady-state window [N·m]: "
                                   "z·(k_m·I − T_0·sgn φ̇) through the gear efficiency, − z²·λ·α̇ − (J_m + J_a)·z²·α̈",
    "torque_output_peak_steady_Nm": "peak |torque at the gearbox output| over the steady-state window [N·m]",
    "current_rated_A": "the motor's continuous current rating drive.i_rated [A] (when stated)",
    "current_limit_A": "the current limit the run had: drive.i_max [A]",
    "current_limit_fraction_steady": "fraction of the steady-state window's samples with |I| at the current limit",
    "voltage_limit_V": "the voltage limit the run had: the smaller of drive.v_max and the controller's v_limit [V]",
    "voltage_limit_fraction_steady": "fraction of the steady-state window's samples with |V| at the voltage limit",
}
SUMMARY_METRICS.update(DUTY_METRICS)
#: a limit active over more than this fraction of the steady state is a warning (:func:`duty_warnings`)
LIMIT_FRACTION_WARN = 0.01
#: |V| ≥ v_limit·(1 − VOLTAGE_LIMIT_TOL) counts as "at the voltage limit" (the limiter clips the
#: command onto it, to rounding)
VOLTAGE_LIMIT_TOL = 1e-6
#: |I| ≥ i_max·(1 − CURRENT_LIMIT_TOL) counts as "at the current limit": the amplifier lowers the
#: voltage so that the current ends each step within ±i_max, and the recorded current of a
#: current-limited motor sits just below it (4.9977 A under a 5 A limit at h = 0.1 ms, L/R = 0.4 ms)
CURRENT_LIMIT_TOL = 5e-3
#: the numeric metrics of :func:`coupler_tracking` (``coupler_speed.<name>`` in a run's metrics)
COUPLER_METRICS = (
    "settle_time_s", "band_rel", "rise_fraction", "crank_error_band_rad_s", "t_end_s", "vc_desired_mean_m_s",
    "crank_error_max_after_rad_s", "crank_error_rms_after_rad_s", "coupler_dev_max_after_m_s",
    "coupler_dev_rms_after_m_s", "coupler_speed_mean_after_m_s", "rise_time_s", "rise_time_10_90_s",
    "overshoot_rel", "settling_time_s", "crank_settling_time_s", "coupler_dev_max_last_1s_m_s",
    "crank_error_max_last_1s_rad_s", "voltage_max_V", "current_max_A")


#: the metrics of :func:`mjbench.vibration.residual_from_trajectory` (``residual_vibration.<name>``
#: in a servo run's metrics.json, with ``max_tracking_error_rad`` added by the runner)
RESIDUAL_METRICS = ("E_T_J", "E_end_J", "residual_envelope_at_T_rad", "residual_peak_after_T_rad",
                    "residual_peak_window_s", "peak_current_A", "peak_voltage_V", "max_tracking_error_rad")


#: the metrics a cam's follower adds (:meth:`mjbench.mechanisms.cam.Cam.metrics`; ``_m``/``_m_s`` for a
#: translating follower, ``_rad``/``_rad_s`` for an oscillating one)
FOLLOWER_METRICS = ("follower_jump_speed_rad_s", "follower_separation_fraction", "follower_first_separation_s",
                    "follower_first_separation_cam_speed_rad_s", "follower_first_separation_cam_angle_deg",
                    "follower_max_gap_m", "follower_gap_tolerance_m", "follower_peak_speed_m_s",
                    "follower_peak_speed_rad_s", "follower_vs_program_max_m", "follower_vs_program_max_rad")


def known_metrics() -> list:
    """Every metric name a run's ``metrics.json`` can hold per backend (the names a scenario's
    ``[[paper.figures]] metric`` may use): :data:`SUMMARY_METRICS`, ``coupler_speed.<name>``
    (:data:`COUPLER_METRICS`), ``residual_vibration.<name>`` (:data:`RESIDUAL_METRICS`) and a cam's
    :data:`FOLLOWER_METRICS`."""
    return (list(SUMMARY_METRICS) + [f"coupler_speed.{k}" for k in COUPLER_METRICS]
            + [f"residual_vibration.{k}" for k in RESIDUAL_METRICS] + list(FOLLOWER_METRICS))


def unit_of(metric: str) -> str:
    """Unit of a metric key from its SI suffix (:func:`summary` naming), '1' for ratios such as χ."""
    if not metric:
        return ""
    for suf, unit in (("_rad_s2", "rad/s²"), ("_rad_s", "rad/s"), ("_m_s", "m/s"), ("_rad", "rad"),
                      ("_s", "s"), ("_V", "V"), ("_A", "A"), ("_W", "W"), ("_J", "J"), ("_m", "m"),
                      ("_Nm", "N·m")):
        if metric.endswith(suf):
            return unit
    return "1"


def _window(t, t0=None, t1=None):
    t0 = t[0] if t0 is None else t0
    t1 = t[-1] if t1 is None else t1
    # the samples with t0 − 1e-12 ≤ t ≤ t1 + 1e-12, as a slice (the times increase)
    sel = slice(int(np.searchsorted(t, t0 - 1e-12, "left")), int(np.searchsorted(t, t1 + 1e-12, "right")))
    if sel.stop - sel.start < 2:
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
    return _chi(float(w.max()), float(w.min()), average, lambda: time_mean(tt, w))


def _chi(wmax, wmin, average: str, mean):
    """(max − min)/average speed, the average ``mean()`` ("mean") or (max + min)/2 ("midrange");
    floats or arrays (one χ per window)."""
    if average == "mean":
        av = mean()
    elif average == "midrange":
        av = 0.5 * (wmax + wmin)
    else:
        raise ParameterError(f"metrics.chi_average = {average!r}: choose 'mean' or 'midrange'")
    if np.any(av == 0):
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


def last_turn(t, q):
    """(t_start, t_end) of the last crank turn of the record: the last 2π of crank travel, ending
    at the last sample (t_start interpolated; the latest instant at which the angle was 2π behind
    its final value).  None if the crank never travels 2π."""
    found = _last_turn_sample(q)
    if found is None:
        return None
    _, u, target, i = found
    f = (target - u[i]) / (u[i + 1] - u[i]) if u[i + 1] != u[i] else 0.0
    return float(t[i] + f * (t[i + 1] - t[i])), float(t[-1])


def _last_turn_sample(q):
    """(direction s = ±1, travel u = s·(q − q₀), u's value 2π before its end, the last sample i at
    or before it) of a recorded angle, or None when it never travels 2π."""
    q = np.asarray(q, dtype=float)
    s = 1.0 if q[-1] >= q[0] else -1.0
    u = s * (q - q[0])
    target = u[-1] - 2 * np.pi
    below = np.flatnonzero(u[:-1] <= target)
    if target < 0 or below.size == 0:
        return None
    return s, u, target, int(below[-1])


def chi_per_cycle(t, q, omega, average="mean"):
    """χ for every complete crank cycle: (array of (t_start, t_end), array of χ)."""
    cyc = cycles(t, q)
    vals = np.array([chi(t, omega, a, b, average) for a, b in cyc])
    return cyc, vals


# ============================================================================ from every co-step
# A run's trajectory carries interval statistics (mjbench.kernel.layout): per record row, the
# extremes of the motor speed, the current, the applied voltage and torque over every co-step since
# the previous row, and when they occurred.  The functions below compute extremes and crossings from
# them and from cubic interpolation of the recorded angle and speed (Hermite: the speed is the
# angle's exact derivative), so they do not depend on how densely the run was recorded.  A
# trajectory without statistics (read from a CSV) falls back to its samples.


def _hermite_cross(t, q, qd, i, target):
    """Time in [t_i, t_{i+1}] at which the cubic Hermite interpolant of the angle (values q, slopes
    q̇ at both ends) reaches ``target`` (Newton from the linear guess; q monotone there).  On Python
    floats: the same arithmetic as on NumPy's scalars, faster."""
    ti = float(t[i])
    h = float(t[i + 1]) - ti
    q0, q1, d0, d1, target = float(q[i]), float(q[i + 1]), float(qd[i]) * h, float(qd[i + 1]) * h, float(target)
    s = (target - q0) / (q1 - q0) if q1 != q0 else 0.0
    back = [None, None]  # the iterates one and two steps back (each a clipped iterate: never −0.0)
    for k in range(20):
        s2, s3 = s * s, s * s * s
        f = (2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * d0 + (-2 * s3 + 3 * s2) * q1 + (s3 - s2) * d1 - target
        df = (6 * s2 - 6 * s) * q0 + (3 * s2 - 4 * s + 1) * d0 + (-6 * s2 + 6 * s) * q1 + (3 * s2 - 2 * s) * d1
        if df == 0:
            break
        step = f / df
        s, back = min(1.0, max(0.0, s - step)), [s if k else None, back[0]]
        if abs(step) < 1e-15:
            break
        # rounding keeps the step above 1e-15 near the root: an iterate that repeats (a fixed point,
        # or two values in turn) gives the same iterates to the 20th, which is taken at once
        if s == back[0]:
            break
        if s == back[1]:
            s = s if (19 - k) % 2 == 0 else back[0]
            break
    return ti + s * h


def crossing_times(traj, targets_rel):
    """Times at which the unwrapped crank angle, measured from its first sample in the direction of
    net rotation, first reaches each of ``targets_rel`` [rad] (Hermite interpolation)."""
    t, q, qd = traj.t, np.asarray(traj.q, dtype=float), np.asarray(traj.qd, dtype=float)
    sgn = 1.0 if q[-1] >= q[0] else -1.0
    u, ud = sgn * (q - q[0]), sgn * qd
    umax = np.maximum.accumulate(u)
    out = []
    for tg, j in zip(targets_rel, np.searchsorted(umax, targets_rel, side="left").tolist()):
        if j == 0 or j >= len(u):
            out.append(float(t[min(j, len(t) - 1)]))
            continue
        out.append(_hermite_cross(t, u, ud, j - 1, tg))
    return np.array(out)


def cycles_of(traj):
    """:func:`cycles` of a run, the boundaries by Hermite interpolation of the angle (grid-free)."""
    q = np.asarray(traj.q, dtype=float)
    s = 1.0 if q[-1] >= q[0] else -1.0
    n = int(np.floor(s * (q[-1] - q[0]) / (2 * np.pi)))
    if n < 2:
        return np.empty((0, 2))
    times = crossing_times(traj, 2 * np.pi * np.arange(1, n + 1))
    return np.column_stack([times[:-1], times[1:]])


def last_turn_of(traj):
    """:func:`last_turn` of a run: the last 2π of crank travel to t_end, its start by Hermite
    interpolation (the latest instant the angle was 2π behind its final value)."""
    t, qd = traj.t, np.asarray(traj.qd, dtype=float)
    found = _last_turn_sample(traj.q)
    if found is None:
        return None
    s, u, target, i = found
    return _hermite_cross(t, u, s * qd, i, target), float(t[-1])


def _cubic(t, tts):
    """The cubic through the four samples nearest each time of ``tts`` (Lagrange's form): (rows
    (W, 4), weights (W, 4), whether the time is a sample, that sample's row)."""
    tts = np.asarray(tts, dtype=float)
    n = len(t)
    j = np.searchsorted(t, tts)
    jc = np.minimum(j, n - 1)
    on = (j < n) & (np.abs(t[jc] - tts) <= 1e-12 * np.maximum(1.0, np.abs(tts)))
    if on.all():
        return None, None, on, jc
    m = min(4, n)
    idx = np.maximum(0, np.minimum(j - 2, n - 4))[:, None] + np.arange(m)
    ts = t[idx]
    others = _OTHERS[m]  # node a's weight: the product over b ≠ a, in order, of (tt − t_b)/(t_a − t_b)
    r = (tts[:, None, None] - ts[:, others]) / (ts[:, :, None] - ts[:, others])
    if m == 1:
        return idx, np.ones((len(tts), 1)), on, jc
    w = r[:, :, 0]
    for b in range(1, m - 1):
        w = w * r[:, :, b]
    return idx, w, on, jc


#: for each node count m ≤ 4: the other nodes of each node, in order
_OTHERS = {m: np.array([[b for b in range(m) if b != a] for a in range(m)], dtype=int).reshape(m, m - 1)
           for m in range(1, 5)}


def values_at(t, x, tts, cubic=None) -> np.ndarray:
    """x at each time of ``tts`` by the cubic through the four nearest samples (a sample itself where
    the time is one); ``cubic``: :func:`_cubic` of these times, when already known."""
    idx, w, on, jc = _cubic(t, tts) if cubic is None else cubic
    if w is None:
        return x[jc]
    p = w * x[idx]
    v = 0.0
    for a in range(p.shape[1]):
        v = v + p[:, a]
    return np.where(on, x[jc], v)


def _range_reduce(op, x, lo, hi, fill):
    """op over x[lo[i]:hi[i]] for every i, its non-finite values left out → lists (values, whether
    any was taken); ``fill`` where none was.  (A few windows: one slice each.)"""
    fin = None if math.isfinite(float(np.sum(x))) else np.isfinite(x)  # (a finite sum: every value finite)
    if fin is not None:
        x = np.where(fin, x, fill)
    vals, took = [], []
    for a, b in zip(lo.tolist(), hi.tolist()):
        ok = b > a and (fin is None or bool(fin[a:b].any()))
        vals.append(float(op.reduce(x[a:b])) if ok else fill)
        took.append(ok)
    return vals, took


def _extrema(traj, column: str, t0s, t1s, cubic=None):
    """(max, min, empty) of a quantity over every window [t0s[i], t1s[i]] from its interval
    statistics, all windows at once; ``empty[i]``: the window holds no co-step and no edge value;
    ``cubic``: :func:`_cubic` of the edges (t0s, then t1s), when already known."""
    t = traj.t
    n = len(t)
    mx, tmx, mn, tmn = (traj.stat(f"{column}:{k}") for k in ("max", "t_max", "min", "t_min"))
    eps = 1e-12 * np.maximum(1.0, np.abs(t1s))
    a0, b1 = t0s - eps, t1s + eps
    i0, j1 = np.searchsorted(t, a0, "left"), np.searchsorted(t, b1, "right")
    # row r holds the statistics of the interval [t_{r-1}, t_r]: rows i0 + 1 … j1 − 1 lie inside
    # [t0 − eps, t1 + eps]
    wmax, tx = _range_reduce(np.maximum, mx, i0 + 1, j1, -np.inf)
    wmin, tn = _range_reduce(np.minimum, mn, i0 + 1, j1, np.inf)
    # rows i0 (≥ 1) and j1 (≤ n − 1) are cut by its edges: their extreme when it occurred inside
    for w, (lo, hi, r0, r1) in enumerate(zip(a0.tolist(), b1.tolist(), i0.tolist(), j1.tolist())):
        for r in (r0 if 1 <= r0 <= min(n - 1, r1) else 0, r1 if max(1, r0) <= r1 <= n - 1 else 0):
            if r == 0:
                continue
            x, tt = float(mx[r]), float(tmx[r])
            if math.isfinite(x) and lo <= tt <= hi:
                wmax[w], tx[w] = max(wmax[w], x), True
            x, tt = float(mn[r]), float(tmn[r])
            if math.isfinite(x) and lo <= tt <= hi:
                wmin[w], tn[w] = min(wmin[w], x), True
    wmax, wmin, found = np.array(wmax), np.array(wmin), np.array(tx) & np.array(tn)
    if traj.has(column):  # the windows' own edges (a sample, or the interpolated value)
        ends = values_at(t, traj[column], np.concatenate([t0s, t1s]), cubic)
        e0, e1 = ends[:len(t0s)], ends[len(t0s):]
        wmax = np.maximum(np.maximum(wmax, e0), e1)
        wmin = np.minimum(np.minimum(wmin, e0), e1)
        found[:] = True
    return wmax, wmin, ~found


def _no_costep(t, t0, t1) -> ParameterError:
    return ParameterError(f"window [{t0}, {t1}] s holds no co-step of the run (t = {t[0]:.4g} .. {t[-1]:.4g} s)")


def _edges(t, t0s, t1s):
    """The windows' edges as float arrays, a missing one (None) the record's start or end."""
    t0s = np.array([float(t[0]) if a is None else float(a) for a in t0s])
    t1s = np.array([float(t[-1]) if b is None else float(b) for b in t1s])
    return t0s, t1s


def window_extrema(traj, column: str, t0=None, t1=None):
    """(max, min) of a recorded quantity over [t0, t1] from every co-step (the interval statistics
    ``column:max`` … of :mod:`mjbench.kernel.layout`): rows inside the window contribute their
    interval's extremes; an interval cut by the window's edge its extreme when it occurred inside,
    and the value at the edge (interpolated) otherwise.  Without statistics: the samples."""
    t = traj.t
    (t0,), (t1,) = _edges(t, [t0], [t1])
    if traj.stat(f"{column}:max") is None:
        x = traj[column]
        sel = _window(t, t0, t1)
        return float(np.max(x[sel])), float(np.min(x[sel]))
    mx, mn, empty = _extrema(traj, column, np.array([t0]), np.array([t1]))
    if empty[0]:
        raise _no_costep(t, float(t0), float(t1))
    return float(mx[0]), float(mn[0])


def motor_angle(traj):
    """The motor-shaft angle φ [rad] of a run's samples: z·(q + δ) (δ the compliant gear's deflection,
    when recorded); None when the gear ratio is not in the run's meta."""
    z = traj.meta.get("z")
    if z is None:
        return None
    phi = float(z) * np.asarray(traj.q, dtype=float)
    if traj.has("gear_deflection_rad"):
        phi = phi + float(z) * traj["gear_deflection_rad"]
    return phi


def chis_of(traj, t0s, t1s, average="mean") -> np.ndarray:
    """χ of Eq 22 of a run over each window [t0s[i], t1s[i]] from every co-step, all windows at once:
    max − min of the motor speed from the interval statistics (:func:`window_extrema`), the time
    mean from the motor angle, Δφ/Δt (exact; the angle at a window edge by cubic interpolation);
    ``average = "midrange"``: (max + min)/2.  Without statistics: :func:`chi` of the samples.  A
    failing window raises as if the windows were taken one by one, in order."""
    t = traj.t
    t0s, t1s = _edges(t, t0s, t1s)
    if traj.stat("motor_speed_rad_s:max") is None:
        return np.array([chi(t, traj.omega, a, b, average) for a, b in zip(t0s, t1s)])
    cubic = _cubic(t, np.concatenate([t0s, t1s]))  # (the edges' interpolation: the speed's and the angle's)
    wmax, wmin, empty = _extrema(traj, "motor_speed_rad_s", t0s, t1s, cubic)
    n = int(np.argmax(empty)) if empty.any() else len(t0s)  # the windows before the first without a co-step
    a, b = t0s[:n], t1s[:n]

    def mean():
        phi = motor_angle(traj)
        if phi is None:
            return np.array([time_mean(t[s], traj.omega[s]) for s in (_window(t, a0, b0) for a0, b0 in zip(a, b))])
        ends = values_at(t, phi, None, cubic)
        return (ends[len(t0s):][:n] - ends[:n]) / (b - a)

    vals = _chi(wmax[:n], wmin[:n], average, mean) if n else np.empty(0)
    if n < len(t0s):
        raise _no_costep(t, float(t0s[n]), float(t1s[n]))
    return vals


def chi_of(traj, t0=None, t1=None, average="mean"):
    """χ of Eq 22 of a run over [t0, t1] (default: the whole record) from every co-step (:func:`chis_of`)."""
    return float(chis_of(traj, [t0], [t1], average)[0])


def peak_abs(traj, column: str, t0=None, t1=None) -> float:
    """max |x| of a recorded quantity over [t0, t1] from every co-step (:func:`window_extrema`)."""
    mx, mn = window_extrema(traj, column, t0, t1)
    return float(max(abs(mx), abs(mn)))


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


def summary(traj, chi_window=None, average="mean", steady_from=None, band_rel=0.10, drive=None, v_limit=None):
    """Standard metrics of a machine trajectory (dict of floats, SI units in the key names).

    chi_window: (t0, t1) for the windowed χ; steady_from: start of the 'steady state' [s]
    (default: half the run) for the mean speed, the per-cycle χ statistics and the duty figures
    (:func:`duty`: ``drive`` the run's drive object, ``v_limit`` its controller's output clip [V]);
    band_rel: the settling band of :func:`end_state` as a fraction of the final speed
    (``[metrics] band_rel``).
    Per-cycle metrics (χ) describe a periodic steady state; the ``final_*`` ones and the speed's
    settling time (:func:`end_state`) describe where a transient run ends.
    """
    t, om = traj.t, traj.omega
    if steady_from is None or steady_from >= t[-1] - 1e-12:  # default, or a run too short for it
        steady_from = t[-1] / 2
    after = slice(int(np.searchsorted(t, steady_from, "left")), None)  # t ≥ steady_from (the times increase)
    out = {
        "t_end_s": float(t[-1]),
        "steady_from_s": float(steady_from),
        "mean_motor_speed_rad_s": time_mean(t[after], om[after]),
        "mean_crank_speed_rad_s": time_mean(t[after], traj.qd[after]),
        "peak_voltage_V": _peak_voltage(traj),
        "peak_current_A": peak_abs(traj, "current_A") if np.any(np.isfinite(traj.current)) else float("nan"),
        "peak_power_elec_W": float(np.max(traj.p_elec)),
        "peak_power_mech_W": float(np.max(traj.p_mech)),
        "energy_elec_J": energy(t, traj.p_elec),
        "energy_mech_J": energy(t, traj.p_mech),
        "max_closure_error_m": float(np.max(traj.closure)),
    }
    out.update(end_state(traj, band_rel))
    out.update(duty(traj, steady_from, drive, v_limit))
    cyc = cycles_of(traj)
    turn = last_turn_of(traj)
    win = chi_window is not None and t[-1] >= chi_window[1] - 1e-9
    # every χ of the run at once, in this order: the cycles', the last turn's, the window's
    spans = [*cyc.tolist(), *([turn] if turn is not None else []), *([chi_window] if win else [])]
    chis = chis_of(traj, [a for a, _ in spans], [b for _, b in spans], average) if spans else np.empty(0)
    vals = chis[:len(cyc)]
    # two readings of "χ over the last cycle" (docs/validation.md): the last complete cycle
    # counted from α(0) (cycles() — it may end up to one period before t_end), and the last
    # 2π of crank travel ending at t_end
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
    if turn is not None:
        out["chi_last_turn"] = float(chis[len(cyc)])
        out["last_turn_start_s"], out["last_turn_end_s"] = turn
    if win:
        out["chi_window"] = float(chis[-1])
        out["chi_window_s"] = [float(chi_window[0]), float(chi_window[1])]
    if any(k.startswith("chi") for k in out) and traj.stat("motor_speed_rad_s:max") is None:
        # a run read back from a CSV has no interval statistics: its χ is max − min of the recorded
        # samples and depends on their interval, so it is labelled with it
        out["chi_sampling_s"] = sampling_interval(t)
    return out


def _peak_voltage(traj) -> float:
    """max |V| applied over any co-step (the statistics of the applied voltage; without them, the
    recorded samples of voltage_V)."""
    if traj.stat("voltage_applied_V:max") is None:
        return float(np.max(np.abs(traj.voltage)))
    return peak_abs(traj, "voltage_applied_V")


# ============================================================================ duty figures
def duty(traj, steady_from, drive=None, v_limit=None) -> dict:
    """The duty figures of a run over its steady-state window t ≥ ``steady_from`` (SI, keys of
    :data:`DUTY_METRICS`; ``duty_window_s`` = [steady_from, t_end]):

    * the motor current's RMS √(mean I²) and peak max|I|; the electromagnetic motor torque's RMS,
      k_m·RMS(I) — what a motor is sized by (its continuous rating);
    * the torque at the gearbox output (the crank shaft, which drives the flywheel J_b and the
      mechanism): T_out = z·η(k_m·I − T_0·sgn φ̇) − z²·λ·α̇ − (J_m + J_a)·z²·α̈, i.e. the recorded
      drive torque on the crank less what accelerates the motor-side inertias, the gear's
      efficiency η (``[drive.gear]``, by the power flow's direction) applied as the kernel applies
      it; RMS and peak — what a gearbox is sized by.  Not given behind a compliant gear (its mesh
      torque is not a recorded column);
    * the fraction of the window's samples at the current limit (|I| within 0.5 % of
      ``drive.i_max``: :data:`CURRENT_LIMIT_TOL`) and at the voltage limit (|V| at the smaller of
      ``drive.v_max`` and the controller's ``v_limit``; ``v_limit`` may be (v_limit, largest
      |command|) for a mode whose command is known — an open loop at or below the limit is never
      limited, 0); a limit that is not set (inf) is not listed.

    Means over the record's samples (uniform in time).  An ideal torque or speed source has no
    current: its output torque (the recorded drive torque less J·α̈) only.  The current's peak is
    taken over every co-step of the window (the kernel's interval statistics, :func:`peak_abs`); the
    output torque's over the recorded samples (:func:`duty_peaks`)."""
    t = traj.t
    t0 = float(steady_from if steady_from is not None else t[-1] / 2)
    sel = slice(int(np.searchsorted(t, t0 - 1e-12, "left")), None)  # t ≥ t0 − 1e-12 (the times increase)
    if sel.start >= len(t):
        return {}
    out = {"duty_window_s": [t0, float(t[-1])]}
    I = np.asarray(traj.current, dtype=float)[sel]
    qd, qdd = np.asarray(traj.qd, dtype=float)[sel], np.asarray(traj.qdd, dtype=float)[sel]
    electric = bool(np.all(np.isfinite(I)))
    out_torque = _output_torque(traj, sel, drive, I, qd, qdd) if drive is not None else None
    peaks = duty_peaks({"current": I if electric else None, "torque_output": out_torque})
    if electric:
        out["current_rms_steady_A"] = float(np.sqrt(np.mean(I * I)))
        # the peak over every co-step of the window (the interval statistics), not only the samples
        out["current_peak_steady_A"] = peak_abs(traj, "current_A", t0, float(t[-1])) \
            if traj.stat("current_A:max") is not None else peaks["current"]
        if drive is not None and hasattr(drive, "k_m"):
            out["torque_motor_rms_steady_Nm"] = float(drive.k_m) * out["current_rms_steady_A"]
    if out_torque is not None:
        out["torque_output_rms_steady_Nm"] = float(np.sqrt(np.mean(out_torque * out_torque)))
        out["torque_output_peak_steady_Nm"] = peaks["torque_output"]
    if electric and drive is not None:
        i_rated = float(getattr(drive, "i_rated", math.inf))
        if math.isfinite(i_rated):
            out["current_rated_A"] = i_rated
        i_max = float(getattr(drive, "i_max", math.inf))
        if math.isfinite(i_max):
            out["current_limit_A"] = i_max
            out["current_limit_fraction_steady"] = float(np.mean(np.abs(I) >= i_max * (1.0 - CURRENT_LIMIT_TOL)))
        v_limit, bound = v_limit if isinstance(v_limit, tuple) else (v_limit, math.inf)
        v_lim = min(float(getattr(drive, "v_max", math.inf)), math.inf if v_limit is None else float(v_limit))
        if math.isfinite(v_lim):
            V = np.asarray(traj.voltage, dtype=float)[sel]
            out["voltage_limit_V"] = v_lim
            if bound <= v_lim:  # the command never exceeds the limit (an open loop at or below it): never limited
                out["voltage_limit_fraction_steady"] = 0.0
            else:
                out["voltage_limit_fraction_steady"] = float(np.mean(np.abs(V) >= v_lim * (1.0 - VOLTAGE_LIMIT_TOL)))
    return out


def duty_peaks(signals: dict) -> dict:
    """max |x| of each signal {name: array or None} over the window's recorded samples (None stays
    None).  The one place the duty peaks are taken: the exact extrema over every co-step can replace
    the recorded samples' here."""
    return {k: (None if x is None or len(x) == 0 else float(np.max(np.abs(x)))) for k, x in signals.items()}


def _output_torque(traj, sel, drive, I, qd, qdd):
    """Torque at the gearbox output over the window (:func:`duty`), or None where it is not defined."""
    if not hasattr(drive, "k_m"):  # an ideal torque or speed source: its torque less its own inertia J
        T = np.asarray(traj["torque_crank_Nm"], dtype=float)[sel]
        return T - float(getattr(drive, "J", 0.0)) * qdd if np.all(np.isfinite(T)) else None
    train = getattr(drive, "train", None)
    gear = getattr(train, "gear", None)
    if gear is not None and gear.compliant:
        return None
    z, km, T0, lam = (float(getattr(drive, k)) for k in ("z", "k_m", "T_0", "lam"))
    w = z * qd
    Tm = km * I - T0 * np.sign(w)
    if gear is not None and gear.lossy:
        Tm = np.asarray(gear.transmitted_torque(Tm, w), dtype=float)
    return z * Tm - z * z * lam * qd - (float(drive.J_m) + float(drive.J_a)) * z * z * qdd


def duty_warnings(backend_metrics: dict, threshold: float = LIMIT_FRACTION_WARN) -> list:
    """Warning lines for a limit active over more than ``threshold`` of the steady state, one per
    limit (every backend's fraction on it), and for a steady-state RMS current above the drive's
    continuous rating ``i_rated`` when the run states it (``current_rated_A`` in the metrics)."""
    out = []
    for key, what, lim in (("current_limit_fraction_steady", "the current is at its limit", "current_limit_A"),
                           ("voltage_limit_fraction_steady", "the voltage is at its limit", "voltage_limit_V")):
        hits = {b: m for b, m in backend_metrics.items() if (m or {}).get(key, 0.0) > threshold}
        if not hits:
            continue
        m0 = next(iter(hits.values()))
        unit = "A" if key.startswith("current") else "V"
        frac = ", ".join(f"{100 * m[key]:.1f} % ({b})" for b, m in hits.items())
        t0, t1 = m0["duty_window_s"]
        out.append(f"{what} {m0[lim]:g} {unit} during {frac} of the steady state t = {t0:g}–{t1:g} s (more than "
                   f"{100 * threshold:g} %): the drive cannot give what the controller asks, so the speed and the "
                   f"other figures are the limited machine's (metrics.json \"{key}\")")
    over = {b: m for b, m in backend_metrics.items()
            if (m or {}).get("current_rated_A") is not None and m.get("current_rms_steady_A", 0.0) > m["current_rated_A"]}
    if over:
        m0 = next(iter(over.values()))
        rms = ", ".join(f"{m['current_rms_steady_A']:.3g} A ({b})" for b, m in over.items())
        t0, t1 = m0["duty_window_s"]
        out.append(f"the RMS motor current {rms} over the steady state t = {t0:g}–{t1:g} s exceeds the motor's continuous "
                   f"rating drive.i_rated = {m0['current_rated_A']:g} A: it would overheat in continuous duty")
    return out


# ============================================================================ process loads
def loads(mech, traj) -> dict:
    """Each process load of the mechanism (a linkage's ``[[mechanism.loads]]``, by name) along the
    recorded motion: ``peak_abs`` its largest |force| [N] (|torque| [N·m] for a torque load) and
    ``active_fraction`` the fraction of the samples where it is not zero, from the mechanism's own
    load law at the recorded angles (``load_forces``); {} for a mechanism without loads."""
    if not hasattr(mech, "load_forces") or not getattr(mech, "load_specs", None):
        return {}
    out = {}
    for name, ld, (s, _, F) in zip(mech.load_names(), mech.load_specs, mech.load_forces(traj.q, traj.qd)):
        F = np.asarray(F, dtype=float) + 0.0 * np.asarray(traj.q)
        entry = {"peak_abs": float(np.max(np.abs(F))), "active_fraction": float(np.mean(F != 0.0)),
                 "unit": "N" if ld.link is None else "N·m"}
        if ld.point is not None:
            s = np.asarray(s, dtype=float) + 0.0 * F
            entry.update(point=ld.point, direction=[float(x) for x in ld.direction], s_reached_m=[float(s.min()),
                                                                                                  float(s.max())])
            if ld.s is not None:
                entry["s_table_m"] = [float(ld.s[0]), float(ld.s[-1])]
        out[name] = entry
    return out


def change_points(mech, traj) -> list:
    """Each change point of the mechanism (:meth:`~mjbench.mechanisms.base.Mechanism.change_points`:
    input angles over one period where branches of the assembly meet) that the recorded motion
    passed, in time order: ``time_s`` (cubic Hermite interpolation of the recorded angle and
    speed), ``input_angle_rad`` (the recorded input angle there: the change point plus whole
    periods) and ``angle_deg`` (that angle reduced into [0°, 360°)); [] for a mechanism without.
    A passage is seen between two recorded samples (a run that diverged: up to its last finite one);
    a run that starts exactly on a change point passes it at its start, whichever way it moves."""
    qc = mech.change_points()
    if not qc:
        return []
    P = float(mech.reduced_period)
    t, q, qd = np.asarray(traj.t, dtype=float), np.asarray(traj.q, dtype=float), np.asarray(traj.qd, dtype=float)
    bad = np.flatnonzero(~(np.isfinite(t) & np.isfinite(q) & np.isfinite(qd)))
    if bad.size:
        t, q, qd = t[:bad[0]], q[:bad[0]], qd[:bad[0]]
    out = []
    for c in qc:
        k = np.floor((q - c) / P)
        if len(q) > 1 and k[0] == (q[0] - c) / P and q[1] > q[0]:
            k[0] -= 1.0  # a start exactly on a change point, moving up: passed at the start, as moving down
        for i in np.flatnonzero(k[1:] != k[:-1]):
            for j in range(int(min(k[i], k[i + 1])) + 1, int(max(k[i], k[i + 1])) + 1):
                level = c + j * P
                out.append({"time_s": _hermite_cross(t, q, qd, int(i), level), "input_angle_rad": float(level),
                            "angle_deg": float(math.degrees(level) % 360.0)})
    return sorted(out, key=lambda e: e["time_s"])


def load_warnings(backend_metrics: dict) -> list:
    """A load that never acts along the motion (zero at every recorded sample of every backend that
    ran): one warning naming it, where its table is and where its point went."""
    out, seen = [], set()
    for m in backend_metrics.values():
        for name, e in ((m or {}).get("loads") or {}).items():
            if name in seen or e["peak_abs"] > 0.0:
                continue
            if any(((x or {}).get("loads") or {}).get(name, {}).get("peak_abs", 0.0) > 0.0
                   for x in backend_metrics.values()):
                continue
            seen.add(name)
            where = ""
            if "s_table_m" in e:
                (a, b), (c, d) = e["s_table_m"], e["s_reached_m"]
                where = (f": its table spans s = {1e3 * a:.4g} … {1e3 * b:.4g} mm along {tuple(e['direction'])}, the "
                         f"point {e['point']} moved over s = {1e3 * c:.4g} … {1e3 * d:.4g} mm")
            out.append(f"load {name!r} never acts along the motion (zero at every recorded sample){where}; check the "
                       f"mechanism's assembly (a link angle's sign), the load's direction and active stroke, or give it "
                       f"over the stroke (profile: distance before the stroke's end)")
    return out


#: the trajectory columns whose last value is an end-state metric (``final_<column>``)
END_COLUMNS = ("crank_angle_rad", "crank_speed_rad_s", "crank_accel_rad_s2", "current_A", "voltage_V",
               "torque_crank_Nm", "power_mech_W")


def end_state(traj, band_rel=0.10) -> dict:
    """Where a run ends (the last recorded sample) and when its crank speed settled there.

    ``final_<column>``: the crank angle, speed and acceleration, current, voltage, drive torque and
    mechanical power at t_end (:data:`END_COLUMNS`; the energies over the run are ``energy_mech_J``
    and ``energy_elec_J``); ``speed_settling_time_s``: the time from
    which |α̇ − α̇(t_end)| ≤ ``speed_settling_band_rad_s`` = band_rel·|α̇(t_end)| holds at every later
    sample (a machine coming to rest: the band is 0 and the time is when it stopped)."""
    if not band_rel > 0:
        raise ParameterError(f"metrics.band_rel = {band_rel!r}: must be > 0")
    t, qd = traj.t, traj.qd
    out = {f"final_{c}": float(traj[c][-1]) for c in END_COLUMNS}
    band = float(band_rel) * abs(float(qd[-1]))
    out["speed_settling_band_rad_s"] = band
    out["speed_settling_time_s"] = _last_exceed(t, np.abs(qd - qd[-1]) > band)
    return out


def sampling_interval(t) -> float:
    """The record's sampling interval [s] (median step of the time column)."""
    return float(np.median(np.diff(t))) if len(t) > 1 else 0.0


def compare(traj_ref, traj_other, key="crank_speed_rad_s"):
    """Max and RMS relative difference of a column between two trajectories (see rel_difference)."""
    mx, rms = rel_difference(traj_ref.t, traj_ref[key], traj_other.t, traj_other[key])
    return {"max_rel_diff": mx, "rms_rel_diff": rms, "column": key,
            "normalisation": "peak |reference| over the run"}


# ============================================================================ coupler-speed tracking
def coupler_signals(traj, mechanism, reference) -> dict:
    """t, q, q̇, q̇_trj (reference at the measured angle, clamped at ``reference.qd_max``),
    e = q̇_trj − q̇, V_C = S(q)·|q̇| and the desired V_des of a coupler-speed run [SI]."""
    t, q, qd = traj.t, traj.q, traj.qd
    vdes = np.asarray(reference.vc_at(q, t), dtype=float) + 0.0 * q
    S = mechanism.coupler_speed_ratio(q)
    qd_ref = np.minimum(vdes / S, reference.qd_max)
    return {"t": t, "q": q, "qd": qd, "qd_ref": qd_ref, "e": qd_ref - qd, "vc": S * np.abs(qd), "vdes": vdes}


def _last_exceed(t, bad):
    """Instant after which ``bad`` is False until the end (t[0] if never bad, nan if bad at the end)."""
    idx = np.flatnonzero(bad)
    if idx.size == 0:
        return float(t[0])
    if idx[-1] == len(t) - 1:
        return float("nan")
    return float(t[idx[-1] + 1])


def coupler_tracking(traj, mechanism, reference, settle_time=None, band_rel=0.10, rise_fraction=0.90,
                     crank_error_band=None) -> dict:
    """Tracking metrics of a run whose controller follows a coupler-point speed V_C (SI units in
    the keys; docs/coupler_speed.md §4):

    * ``crank_error_max_after_rad_s``: max |e| for t ≥ ``settle_time``, e = q̇_trj(q) − q̇ the
      crank-speed error (Hülako & Çakar Eq 22) with the reference at the measured angle;
    * ``coupler_dev_max_after_m_s``: max |V_C − V_des| for t ≥ ``settle_time`` (their Table 3's
      "maximum deviation"); ``*_rms_after_*`` the RMS; ``coupler_speed_mean_after_m_s``;
    * ``rise_time_s``: first instant with V_C/V_des ≥ ``rise_fraction``; ``rise_time_10_90_s``;
    * ``settling_time_s``: instant after which |V_C/V_des − 1| ≤ ``band_rel`` to the end (nan if
      it never settles); ``crank_settling_time_s``: the same with |e| ≤ ``crank_error_band``;
    * ``coupler_dev_windows``: [t_start, t_end, max|V_C − V_des|, max|e|] over consecutive 1 s
      windows from ``settle_time``; ``coupler_dev_max_last_1s_m_s``,
      ``crank_error_max_last_1s_rad_s``: over the last second of the run.

    ``settle_time`` None: half the run; ``crank_error_band`` None: no crank settling time."""
    sg = coupler_signals(traj, mechanism, reference)
    t, e, vc, vdes = sg["t"], sg["e"], sg["vc"], sg["vdes"]
    if settle_time is None:
        settle_time = 0.5 * float(t[-1])
    after = t >= settle_time - 1e-12
    dev = vc - vdes
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(vdes > 0, vc / vdes, np.nan)
    out = {"settle_time_s": float(settle_time), "band_rel": float(band_rel), "rise_fraction": float(rise_fraction),
           "crank_error_band_rad_s": None if crank_error_band is None else float(crank_error_band),
           "t_end_s": float(t[-1]),
           "vc_desired_mean_m_s": float(np.mean(vdes))}
    if after.any():
        out["crank_error_max_after_rad_s"] = float(np.max(np.abs(e[after])))
        out["crank_error_rms_after_rad_s"] = float(np.sqrt(np.mean(e[after] ** 2)))
        out["coupler_dev_max_after_m_s"] = float(np.max(np.abs(dev[after])))
        out["coupler_dev_rms_after_m_s"] = float(np.sqrt(np.mean(dev[after] ** 2)))
        out["coupler_speed_mean_after_m_s"] = float(np.mean(vc[after]))
    hit = np.flatnonzero(ratio >= rise_fraction)
    out["rise_time_s"] = float(t[hit[0]]) if hit.size else float("nan")
    lo = np.flatnonzero(ratio >= 0.1)
    out["rise_time_10_90_s"] = float(t[hit[0]] - t[lo[0]]) if hit.size and lo.size else float("nan")
    out["overshoot_rel"] = float(np.nanmax(ratio) - 1.0) if np.isfinite(ratio).any() else float("nan")
    out["settling_time_s"] = _last_exceed(t, ~(np.abs(ratio - 1.0) <= band_rel))
    if crank_error_band is not None:
        out["crank_settling_time_s"] = _last_exceed(t, np.abs(e) > crank_error_band)
    edges = list(np.arange(settle_time, t[-1] - 1e-9, 1.0)) + [float(t[-1])]
    wins = []
    for a, b in zip(edges[:-1], edges[1:]):
        m = (t >= a) & (t <= b)
        if m.any():
            wins.append([float(a), float(b), float(np.max(np.abs(dev[m]))), float(np.max(np.abs(e[m])))])
    out["coupler_dev_windows"] = wins
    last = t >= t[-1] - 1.0 - 1e-12
    out["coupler_dev_max_last_1s_m_s"] = float(np.max(np.abs(dev[last])))
    out["crank_error_max_last_1s_rad_s"] = float(np.max(np.abs(e[last])))
    out["voltage_max_V"] = float(np.max(np.abs(traj.voltage)))
    out["current_max_A"] = float(np.max(np.abs(traj.current)))
    return out


def voltage_at_limit(traj, v_limit, t0=None, t1=None, rel_tol=1e-9) -> float:
    """Fraction of the samples in [t0, t1] at which |V| is at (or beyond) ``v_limit`` [V]."""
    sel = _window(traj.t, t0, t1)
    return float(np.mean(np.abs(traj.voltage[sel]) >= v_limit * (1.0 - rel_tol)))
