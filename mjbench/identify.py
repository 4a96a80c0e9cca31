"""DC-motor identification from a logged record (the seed-002 workflow, §3.2: "MATLAB Parameter
Estimation toolbox ... the voltage and speed of the motor are used to determine the motor
parameters").

Model (motor shaft, seed 000 Eqs 6-7 / seed 002 Eqs 18-20 with n = 1):

    L·dI/dt = V − R·I − K·ω                         (K: back-EMF constant [V·s/rad])
    J·dω/dt = K·I − b·ω − T_c·tanh(ω/ω_s)           (K: torque constant [N·m/A], the same in SI)

θ = (R [Ω], L [H], K [V·s/rad], J [kg·m²] rotor + whatever rides on the shaft, b [N·m·s/rad]
viscous, T_c [N·m] Coulomb friction).  The Coulomb term is smoothed over ω_s (default 0.05 rad/s)
so that the simulated record is a smooth function of θ; ω_s is a setting, not fitted.

Method: ``scipy.optimize.least_squares`` (trust-region reflective, bounds θ ≥ 0), *output error*:
the model is simulated from the measured initial state with the logged voltage held between
samples (exact zero-order-hold discretisation of the linear part, Coulomb term held over
sub-steps), and the residuals are the speed (and current) errors, each divided
by its noise level (estimated from the record: robust scale of its second differences).  Start:
an *equation-error* linear least-squares fit on Savitzky–Golay derivatives (needs the current).
Confidence intervals: 95 % from the Gauss–Newton covariance s²·(JᵀJ)⁻¹ at the optimum.

Why not ``mujoco.sysid``: it fits MjSpec parameters (masses, inertias, actuator gains) through
batched MuJoCo rollouts and needs the optional ``mujoco[sysid]`` extra; our electrical state (the
current, with R, L, K) lives in Python, not in the MuJoCo model, and a 2-state ODE needs no rigid-
body engine.  ``least_squares`` is already a dependency, is bounded, and its Jacobian gives the
confidence intervals directly.

Identifiability: with the current logged, all six are identifiable.  From voltage and speed only,
the record determines four combinations (LJ/K, (RJ + Lb)/K, Rb/K + K, R·T_c/K) — fix at least two
parameters (e.g. R and L measured with a meter: ``fixed={"R": .., "L": ..}``); a rank-deficient
fit is reported (infinite interval) instead of inventing numbers.
"""
from __future__ import annotations

import csv
import math

import numpy as np

from .errors import ParameterError
from .trajectory import atomic_write
from . import plots as P
from .plotstyle import new

PARAMS = ("R", "L", "K", "J", "b", "T_c")
UNITS = {"R": "Ω", "L": "H", "K": "V·s/rad", "J": "kg·m²", "b": "N·m·s/rad", "T_c": "N·m"}
#: mjbench scenario [drive] key of each parameter (motor side, z = 1 record)
DRIVE_KEYS = {"R": "R", "L": "L", "K": "k_m", "J": "J_m", "b": "lam", "T_c": "T_0"}
OMEGA_S = 0.05
COLUMNS = {"t": ("t_s", "t", "time", "time_s"),
           "V": ("voltage_V", "voltage", "V", "u", "v"),
           "omega": ("motor_speed_rad_s", "speed_rad_s", "omega", "speed", "omega_rad_s", "w"),
           "I": ("current_A", "current", "I", "i")}


# ======================================================================== model
def simulate(theta, t, V, omega0, I0, omega_s=OMEGA_S, nsub=None):
    """ω(t), I(t) of the model for parameter rows ``theta`` (n, 6) — vectorised over n — with V
    held over each sample interval.  Returns (omega, I), each (n, len(t)).

    Discretisation: the linear part (R, L, K, J, b) exactly (zero-order hold, matrix exponential
    per parameter row); the Coulomb term held over a sub-step (explicit), with ``nsub`` sub-steps
    per sample so that h·T_c/(ω_s·J) ≤ 0.25 (default).  The record's own sampling need not be
    uniform: the exponential is recomputed where the interval changes."""
    from scipy.linalg import expm

    th = np.atleast_2d(np.asarray(theta, dtype=float))
    n = len(th)
    R, L, K, J, b, Tc = (th[:, k] for k in range(6))
    dts = np.diff(t)
    if nsub is None:
        stiff = float(np.max(Tc / (omega_s * J)))
        nsub = max(1, int(math.ceil(float(np.max(dts)) * stiff / 0.25)))

    def discretise(h):
        M = np.zeros((n, 4, 4))  # [ω, I | V, T_f]
        M[:, 0, 0], M[:, 0, 1], M[:, 0, 3] = -b / J, K / J, -1.0 / J
        M[:, 1, 0], M[:, 1, 1], M[:, 1, 2] = -K / L, -R / L, 1.0 / L
        E = expm(M * h)
        return E[:, :2, :2], E[:, :2, 2], E[:, :2, 3]

    w = np.empty((n, len(t)))
    cur = np.empty_like(w)
    xw = np.full(n, float(omega0))
    xi = np.full(n, float(I0))
    w[:, 0], cur[:, 0] = xw, xi
    h_cached = None
    for k in range(len(dts)):
        h = dts[k] / nsub
        if h_cached is None or abs(h - h_cached) > 1e-12 * h:
            (Ad, Bv, Bf), h_cached = discretise(h), h
            a00, a01, a10, a11 = Ad[:, 0, 0], Ad[:, 0, 1], Ad[:, 1, 0], Ad[:, 1, 1]
            bv0, bv1, bf0, bf1 = Bv[:, 0], Bv[:, 1], Bf[:, 0], Bf[:, 1]
        v = V[k]
        for _ in range(nsub):
            tf = Tc * np.tanh(xw / omega_s)
            xw, xi = (a00 * xw + a01 * xi + bv0 * v + bf0 * tf,
                      a10 * xw + a11 * xi + bv1 * v + bf1 * tf)
        w[:, k + 1], cur[:, k + 1] = xw, xi
    return w, cur


def synthetic_record(theta: dict, t_end=2.0, dt=1e-3, noise_speed=0.05, noise_current=0.05, seed=0,
                     levels=(-24.0, -12.0, 0.0, 12.0, 24.0), hold=0.1, omega_s=OMEGA_S):
    """A test record: random voltage steps every ``hold`` s, the model integrated by
    ``scipy.integrate.solve_ivp`` (DOP853, tight tolerances — not the fit's RK4), Gaussian noise
    on speed and current.  Returns dict of arrays t, V, omega, I (and the noise-free ones)."""
    from scipy.integrate import solve_ivp

    rng = np.random.default_rng(seed)
    t = np.arange(0.0, t_end + 0.5 * dt, dt)
    nseg = int(math.ceil(t_end / hold)) + 1
    seg = rng.choice(levels, size=nseg)
    V = seg[np.minimum((t / hold).astype(int), nseg - 1)]
    R, L, K, J, b, Tc = (float(theta[p]) for p in PARAMS)
    w, cur = [0.0], [0.0]
    x = np.array([0.0, 0.0])
    for k in range(len(t) - 1):
        v = V[k]
        sol = solve_ivp(lambda tt, y: [(K * y[1] - b * y[0] - Tc * np.tanh(y[0] / omega_s)) / J,
                                       (v - R * y[1] - K * y[0]) / L],
                        (t[k], t[k + 1]), x, method="DOP853", rtol=1e-10, atol=1e-12)
        x = sol.y[:, -1]
        w.append(x[0])
        cur.append(x[1])
    w, cur = np.array(w), np.array(cur)
    return {"t": t, "V": V, "omega": w + noise_speed * rng.standard_normal(len(t)),
            "I": cur + noise_current * rng.standard_normal(len(t)), "omega_true": w, "I_true": cur}


def write_record(path, rec, current=True):

    cols = ["t_s", "voltage_V", "motor_speed_rad_s"] + (["current_A"] if current else [])
    arr = np.column_stack([rec["t"], rec["V"], rec["omega"]] + ([rec["I"]] if current else []))
    atomic_write(path, lambda f: np.savetxt(f, arr, delimiter=",", header=",".join(cols), comments="",
                                            fmt="%.10g"))
    return path


MIN_SAMPLES = 20


def read_record(path, option="--data"):
    """CSV with a header → dict t, V, omega[, I] (column names: see ``COLUMNS``; an mjbench
    trajectory CSV works as is).  Every problem is ONE :class:`ParameterError` naming the file,
    and the row (line number in the file) and column where it is: a missing file, a folder, an
    empty or header-only file, another separator, a ragged row, text, NaN or inf in a number
    column, times that do not increase, too few samples."""
    import os

    where = f"{option} {path}"
    if not os.path.exists(path):
        raise ParameterError(f"{where}: no such file")
    if os.path.isdir(path):
        raise ParameterError(f"{where} is a folder: give the CSV file of the record")
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            lines = f.read().splitlines()
    except UnicodeDecodeError:
        raise ParameterError(f"{where}: not a UTF-8 text file (a CSV record is expected)") from None
    except OSError as e:
        raise ParameterError(f"{where}: cannot read it ({e.strerror})") from None
    numbered = [(i + 1, ln) for i, ln in enumerate(lines) if ln.strip()]
    if not numbered:
        raise ParameterError(f"{where} is empty: expected a header row ({', '.join(c[0] for c in COLUMNS.values())}) "
                             f"and at least {MIN_SAMPLES} samples")
    hline, head = numbered[0]
    if "," not in head:
        for sep, name in ((";", "semicolons"), ("\t", "tabs")):
            if sep in head:
                raise ParameterError(f"{where} row {hline}: the columns are separated by {name}; mjbench reads "
                                     f"comma-separated values with a '.' decimal point (e.g. 0.5,12,3.1)")
    names = [h.strip() for h in next(csv.reader([head]))]
    cols = {}
    for key, cands in COLUMNS.items():
        for c in cands:
            if c in names:
                cols[key] = (names.index(c), c)
                break
    missing = [k for k in ("t", "V", "omega") if k not in cols]
    if missing:
        raise ParameterError(f"{where} row {hline}: no column for {', '.join(missing)} (accepted names: "
                             + "; ".join(f"{k}: {', '.join(COLUMNS[k])}" for k in missing) + f"); the header has "
                             f"{', '.join(map(repr, names))}")
    body = numbered[1:]
    if not body:
        raise ParameterError(f"{where} holds a header but no samples: need at least {MIN_SAMPLES} rows of numbers")
    data = {k: np.empty(len(body)) for k in cols}
    for j, row in enumerate(csv.reader([ln for _, ln in body])):
        line = body[j][0]
        if len(row) != len(names):
            raise ParameterError(f"{where} row {line}: {len(row)} field{'s' if len(row) != 1 else ''}, the header has "
                                 f"{len(names)} (a ragged row)")
        for k, (ci, cname) in cols.items():
            text = row[ci].strip()
            try:
                v = float(text)
            except ValueError:
                what = "an empty cell" if not text else f"{text!r}"
                raise ParameterError(f"{where} row {line}, column {cname}: {what} is not a number") from None
            if not math.isfinite(v):
                raise ParameterError(f"{where} row {line}, column {cname}: {text} is not a finite number (remove or "
                                     f"interpolate the sample)")
            data[k][j] = v
    t = data["t"]
    if len(t) < MIN_SAMPLES:
        raise ParameterError(f"{where}: {len(t)} samples; the fit needs at least {MIN_SAMPLES}")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        j = int(bad[0]) + 1
        raise ParameterError(f"{where} row {body[j][0]}, column {cols['t'][1]}: time {t[j]:g} s is not after the "
                             f"previous sample's {t[j - 1]:g} s (times must increase)")
    return data


# ======================================================================== fit
def _noise(x):
    """Noise level of a densely sampled signal: robust (MAD) scale of its second differences,
    σ = 1.4826·MAD(Δ²x)/√6 (white noise; the smooth part's Δ² is negligible, steps are outliers)."""
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    sigma = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / math.sqrt(6.0)
    return sigma if sigma > 0 else 1e-6 * (float(np.max(np.abs(x))) or 1.0)


def equation_error(t, V, omega, I, omega_s=OMEGA_S):
    """Linear least-squares start from derivatives (Savitzky–Golay): V = R·I + L·İ + K·ω and
    K·I = J·ω̇ + b·ω + T_c·tanh(ω/ω_s)."""
    from scipy.signal import savgol_filter

    dt = float(np.median(np.diff(t)))
    win = min(15, len(t) - (1 - len(t) % 2))
    dI = savgol_filter(I, win, 3, deriv=1, delta=dt)
    dw = savgol_filter(omega, win, 3, deriv=1, delta=dt)
    Is = savgol_filter(I, win, 3)
    ws = savgol_filter(omega, win, 3)
    A = np.column_stack([Is, dI, ws])
    (R, L, K), *_ = np.linalg.lstsq(A, V, rcond=None)
    B = np.column_stack([dw, ws, np.tanh(ws / omega_s)])
    (J, b, Tc), *_ = np.linalg.lstsq(B, K * Is, rcond=None)
    return {"R": R, "L": L, "K": K, "J": J, "b": b, "T_c": Tc}


DEFAULT_GUESS = {"R": 2.0, "L": 5e-3, "K": 0.1, "J": 1e-4, "b": 1e-4, "T_c": 1e-3}


def fit(t, V, omega, I=None, fixed=None, guess=None, omega_s=OMEGA_S, max_nfev=200):
    """Fit θ to the record; returns a dict with ``params`` {name: {value, std, ci95, fixed}},
    ``rms`` residuals, ``sigma`` noise levels, ``cost``, ``nfev``, ``method`` and the fitted
    simulation (``omega_fit``, ``I_fit``)."""
    from scipy.optimize import least_squares

    t, V, omega = (np.asarray(a, dtype=float) for a in (t, V, omega))
    I = None if I is None else np.asarray(I, dtype=float)
    fixed = _fixed(fixed, I)
    start, method = _start(t, V, omega, I, fixed, guess, omega_s)
    free = [p for p in PARAMS if p not in fixed]
    scale = np.array([max(abs(start[p]), 1e-9) for p in free])
    sig_w = _noise(omega)
    sig_i = _noise(I) if I is not None else None
    theta_rows = _theta_rows(free, scale, fixed)
    fun, jac = _residuals(theta_rows, t, V, omega, I, sig_w, sig_i, omega_s)
    z0 = np.array([start[p] for p in free]) / scale
    lb = np.zeros(len(free))
    sol = least_squares(fun, z0, jac=jac, bounds=(lb, np.inf), method="trf", x_scale="jac",
                        max_nfev=max_nfev, xtol=1e-12, ftol=1e-12, gtol=1e-12)
    std, cond = _uncertainty(sol, len(free), scale)
    th = theta_rows(sol.x)[0]
    w_fit, i_fit = simulate(th[None, :], t, V, omega[0], I[0] if I is not None else 0.0, omega_s)
    out = {"params": _param_rows(th, std, free, fixed), "method": method,
           "solver": "scipy.optimize.least_squares (trf)",
           "nfev": int(sol.nfev), "cost": float(sol.cost), "status": int(sol.status),
           "sigma": {"speed_rad_s": sig_w, "current_A": sig_i},
           "rms": {"speed_rad_s": float(np.sqrt(np.mean((w_fit[0] - omega) ** 2)))},
           "condition": cond, "omega_s": omega_s, "n_samples": len(t),
           "omega_fit": w_fit[0], "I_fit": i_fit[0]}
    if I is not None:
        out["rms"]["current_A"] = float(np.sqrt(np.mean((i_fit[0] - I) ** 2)))
    return out


def _fixed(fixed, I) -> dict:
    """The fixed parameters, checked: known names; at least two without a current record."""
    fixed = {k: float(v) for k, v in (fixed or {}).items()}
    for k in fixed:
        if k not in PARAMS:
            raise ParameterError(f"identify: unknown parameter {k!r}; choose from {PARAMS}")
    if I is None and len(fixed) < 2:
        raise ParameterError("identify: without a current column only four combinations of (R, L, K, J, b, T_c) "
                             "are identifiable from voltage and speed; fix at least two parameters "
                             "(e.g. --fix R=... --fix L=... measured with a meter)")
    return fixed


def _start(t, V, omega, I, fixed, guess, omega_s):
    """The starting point (defaults, the equation-error estimate with a current record, the
    user's guess, the fixed values) → (θ0 dict, method text)."""
    start = dict(DEFAULT_GUESS)
    method = "output error, start from defaults"
    if I is not None:
        ee = equation_error(t, V, omega, I, omega_s)
        for k, v in ee.items():
            if np.isfinite(v) and v > 0:
                start[k] = float(v)
        method = "output error, start from equation error"
    start.update(guess or {})
    start.update(fixed)
    return start, method


def _theta_rows(free, scale, fixed):
    """theta_rows(Z): full parameter rows (PARAMS order) from scaled free parameters Z (rows)."""
    def theta_rows(Z):
        Z = np.atleast_2d(Z)
        rows = np.empty((len(Z), 6))
        for k, p in enumerate(PARAMS):
            rows[:, k] = Z[:, free.index(p)] * scale[free.index(p)] if p in free else fixed[p]
        return rows
    return theta_rows


def _residuals(theta_rows, t, V, omega, I, sig_w, sig_i, omega_s):
    """(fun, jac) of the output error: simulated speed (and current) minus the record, over the
    noise levels; the Jacobian by forward differences in one vectorised simulation."""
    def resid_rows(Z):
        th = theta_rows(Z)
        th[:, [0, 1, 2, 3]] = np.maximum(th[:, [0, 1, 2, 3]], 1e-12)  # R, L, K, J > 0
        w, cur = simulate(th, t, V, omega[0], I[0] if I is not None else 0.0, omega_s)
        r = (w - omega) / sig_w
        if I is not None:
            r = np.concatenate([r, (cur - I) / sig_i], axis=1)
        return r

    def fun(z):
        return resid_rows(z)[0]

    def jac(z):  # forward differences, all columns in one vectorised simulation
        hstep = 1e-6 * np.maximum(np.abs(z), 1e-3)
        Z = np.vstack([z] + [z + np.eye(len(z))[k] * hstep[k] for k in range(len(z))])
        r = resid_rows(Z)
        return ((r[1:] - r[0]) / hstep[:, None]).T
    return fun, jac


def _uncertainty(sol, p, scale):
    """Standard deviations of the free parameters and the condition number of the normalised
    normal matrix (covariance in column-normalised coordinates: the condition number then measures
    identifiability, not the units); ill-conditioned (> 1e12): infinite deviations."""
    m = len(sol.fun)
    s2 = 2 * sol.cost / max(1, m - p)
    Jm = sol.jac
    cn = np.linalg.norm(Jm, axis=0)
    cn[cn == 0] = 1.0
    Jn = Jm / cn
    try:
        JtJ = Jn.T @ Jn
        cond = float(np.linalg.cond(JtJ))
        cov = np.linalg.inv(JtJ) / np.outer(cn, cn) * s2
        std = np.sqrt(np.maximum(np.diag(cov), 0)) * scale
    except np.linalg.LinAlgError:
        std, cond = np.full(p, np.inf), float("inf")
    if not np.isfinite(cond) or cond > 1e12:
        std = np.full(p, np.inf)
    return std, cond


def _param_rows(th, std, free, fixed) -> dict:
    params = {}
    for k, name in enumerate(PARAMS):
        if name in fixed:
            params[name] = {"value": fixed[name], "std": 0.0, "ci95": [fixed[name], fixed[name]], "fixed": True}
        else:
            j = free.index(name)
            v, sd = float(th[k]), float(std[j])
            params[name] = {"value": v, "std": sd, "ci95": [v - 1.96 * sd, v + 1.96 * sd], "fixed": False}
    return params


def drive_table(res) -> dict:
    """Fitted values as the scenario's [drive] keys (J_m = the whole shaft inertia; set J_a = 0)."""
    return {DRIVE_KEYS[k]: v["value"] for k, v in res["params"].items()}


def report(res, truth=None) -> str:
    lines = [f"{res['solver']}, {res['method']}; {res['nfev']} evaluations, {res['n_samples']} samples",
             f"  {'param':<6s} {'value':>12s} {'± 95 % CI':>12s} {'unit':<10s}" + ("   truth     error" if truth else "")]
    for k, v in res["params"].items():
        ci = "fixed" if v["fixed"] else (f"{1.96 * v['std']:.3g}" if np.isfinite(v["std"]) else "unident.")
        row = f"  {k:<6s} {v['value']:>12.5g} {ci:>12s} {UNITS[k]:<10s}"
        if truth and k in truth:
            tv = truth[k]
            row += f"   {tv:<9.4g} {100 * (v['value'] - tv) / tv:+.2f} %" if tv else f"   {tv:<9.4g}"
        lines.append(row)
    rms = ", ".join(f"{k} {v:.3g}" for k, v in res["rms"].items())
    sig = ", ".join(f"{k} {v:.3g}" for k, v in res["sigma"].items() if v is not None)
    lines.append(f"  RMS fit residual: {rms}   (noise estimated from the record: {sig})")
    lines.append("  scenario [drive]: " + ", ".join(f"{k} = {v:.6g}" for k, v in drive_table(res).items()))
    return "\n".join(lines)


def plot(rec, res, path):

    has_i = rec.get("I") is not None
    nrow = 3 if has_i else 2
    fig, axes = new(nrow + 1, 1, figsize=(8, 2.6 * (nrow + 1)), sharex=True)
    t = rec["t"]
    axes[0].plot(t, rec["V"], color="k", lw=1)
    axes[0].set_ylabel("voltage [V]")
    axes[1].plot(t, rec["omega"], color="0.6", lw=0.8, label="measured")
    axes[1].plot(t, res["omega_fit"], color="tab:blue", lw=1.2, label="fitted model")
    axes[1].set_ylabel("speed [rad/s]")
    axes[1].legend(loc="upper right")
    if has_i:
        axes[2].plot(t, rec["I"], color="0.6", lw=0.8, label="measured")
        axes[2].plot(t, res["I_fit"], color="tab:red", lw=1.2, label="fitted model")
        axes[2].set_ylabel("current [A]")
        axes[2].legend(loc="upper right")
    axes[-1].plot(t, rec["omega"] - res["omega_fit"], color="tab:blue", lw=0.6, label="speed residual [rad/s]")
    if has_i:
        axes[-1].plot(t, rec["I"] - res["I_fit"], color="tab:red", lw=0.6, alpha=0.7, label="current residual [A]")
    axes[-1].set_ylabel("residual")
    axes[-1].set_xlabel("time t [s]")
    axes[-1].legend(loc="upper right")
    p = res["params"]
    axes[0].set_title("  ".join(f"{k}={v['value']:.4g}" for k, v in p.items()), fontsize=8)
    return P.save(fig, path)
