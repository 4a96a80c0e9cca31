"""The real-drive study (issue 15): seed 000's PID and seed 004's sliding-mode controller on a
realistic drive train, next to the ideal model of the papers.

Realistic drive (the same for both machines, docs/drivetrain.md): switching PWM H-bridge at
20 kHz on a 48 V bus (unipolar, 1 µs dead time), a 2000-line encoder (×4 quadrature) on the
motor shaft, a 0.1 ms control sample period, 0.1° backlash at the gear output (default mesh
stiffness: 1 kHz mesh resonance) and Coulomb friction on the motor shaft (0.05 N·m for seed 000's
motor, 0.1 N·m for seed 004's, ≈1 % of their running torque — our assumption, no paper gives
one).  The speed estimate is what varies: the plain ``difference`` of the counts, a tracking
``observer`` (PLL, bandwidth sample rate/20) or the ``mt`` (M/T) method.

Metrics over the steady window (seed 000: 1-2 s of the 2 s run, plus the paper's χ window
0.375-0.5 s; seed 004: 2-3 s):

* seed 000: χ (Eq 22) on the window, mean χ of the crank cycles in the steady window, χ of the
  last cycle, |mean motor speed − ω₀|/ω₀;
* seed 004: steady crank-speed error |mean(α̇ − ω_d)|/ω_d (§4: 0.2 %);
* chattering: the voltage switching frequency (crossings of the commanded voltage through its
  window mean, with a ±2 % v_max hysteresis, / 2 / duration) and the current ripple: the PWM
  ripple (mean peak-to-peak within a step) and the control-induced current chatter (RMS of I
  minus its 5 ms moving mean: everything above ≈ 200 Hz, the crank-frequency load variation
  excluded).  The PWM ripple is the per-step peak-to-peak less the step's net current change.

Used by scripts/drivetrain_study.py (table, figures, sweep) and by the report rows of the
``*-realdrive`` reproduce cases (:mod:`mjbench.papers.incerti2012`, :mod:`mjbench.papers.yigit2023`).
"""
from __future__ import annotations

import math

import numpy as np

from mjbench import metrics as M
from mjbench import scenario as S
from mjbench.errors import SimulationDiverged
from mjbench.backends import simulate as sim
from mjbench.papers import yigit2023_metrics as MQ
from mjbench import plotstyle as ps
from mjbench.plots import save

DT = 1e-4
PWM = ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48",
       'drive.pwm.scheme="unipolar"', 'drive.pwm.dead_time="1 us"']
GEAR = ['drive.gear.backlash="0.1 deg"']
FRICTION = {"incerti2012": ['drive.friction.coulomb="0.05 N*m"'], "yigit2023": ['drive.friction.coulomb="0.1 N*m"']}
#: scenario → (mode, run length [s], steady window [s], the mode's sample-period key)
MACHINES = {"incerti2012": ("pid", 2.0, (1.0, 2.0), "modes.pid.period"),
            "yigit2023": ("smc", 3.0, (2.0, 3.0), "modes.smc.Ts")}
ESTIMATORS = ("difference", "observer", "mt")
LABELS = {"ideal": "ideal drive", "difference": "real drive, speed by difference",
          "observer": "real drive, speed by observer", "mt": "real drive, speed by M/T"}


def ideal(name, period=DT) -> list:
    """Overrides of the ideal model at a control sample period."""
    return [f"{MACHINES[name][3]}={period!r}"]


def realistic(name, estimator="difference", lines=2000, period=DT) -> list:
    """Overrides of the realistic drive (``lines=None``: exact angle, the rest realistic)."""
    out = ideal(name, period) + PWM + GEAR + FRICTION[name]
    if lines is not None:
        out += [f"drive.encoder.lines={int(lines)}", 'drive.encoder.side="motor"']
    out += [f'drive.sensor.speed="{estimator}"']
    return out


def case_overrides(name, estimator="difference") -> list:
    """Overrides of a ``*-realdrive`` reproduce case: the realistic drive, recorded at every step
    (the chattering metrics need the 0.1 ms samples: a decimated record aliases the switching
    frequency and turns the PWM ripple into the control's own current change)."""
    return realistic(name, estimator) + [f"simulation.record_dt={DT!r}"]


def simulate(name, overrides, backend="reduced", t_end=None):
    """One run of the machine's studied mode: (Trajectory or None, divergence message or "")."""

    mode, T, _, _ = MACHINES[name]
    scn = S.load(name, overrides)
    opts = {"timestep": DT} if backend == "reduced" else {**scn.multibody_options(), "timestep": DT}
    try:
        return sim(S.make_machine(scn, mode), backend, float(t_end or T), record_dt=DT, options=opts), ""
    except SimulationDiverged as e:
        return None, str(e)


# ------------------------------------------------------------------ metrics
def switching_frequency(t, v, band):
    """Crossings of v through its mean with hysteresis ±band, per second / 2 [Hz]."""
    x = v - np.mean(v)
    state, n = 0, 0
    for s in np.where(x > band, 1, np.where(x < -band, -1, 0)):
        if s and s != state:
            n += state != 0
            state = s
    return n / 2.0 / max(t[-1] - t[0], 1e-300)


def chatter(tr, t0, t1, v_max=48.0) -> dict:
    """Chattering metrics of a trajectory over [t0, t1] (see the module docstring)."""
    k = (tr.t >= t0 - 1e-12) & (tr.t <= t1 + 1e-12)
    t, v, i = tr.t[k], tr.voltage[k], tr.current[k]
    spacing = float(np.median(np.diff(t))) if len(t) > 1 else DT
    if abs(spacing - DT) > 1e-9 * DT:
        raise ValueError(f"chattering metrics need a trajectory recorded every {DT:g} s (one co-step); this one is "
                         f"recorded every {spacing:g} s: set simulation.record_dt = {DT:g}")
    n = max(1, int(round(5e-3 / DT)))
    mov = np.convolve(i, np.ones(n) / n, mode="same")
    core = slice(n, len(i) - n) if len(i) > 3 * n else slice(None)
    rip = 0.0
    if tr.has("current_max_A"):
        # row r holds the extremes of the step ending at t_r: minus that step's net change (the
        # control's own current slope), what remains is the PWM ripple
        pp = np.maximum((tr["current_max_A"] - tr["current_min_A"])[1:] - np.abs(np.diff(tr.current)), 0.0)
        rip = float(np.mean(pp[k[1:]]))
    return {"switch_freq_Hz": switching_frequency(t, v, 0.02 * v_max),
            "current_ripple_A": rip,
            "current_chatter_A": float(np.sqrt(np.mean((i - mov)[core] ** 2)))}


def evaluate(name, tr) -> dict:
    """The study's metrics of one run (NaN if it diverged)."""
    mode, T, (t0, t1), _ = MACHINES[name]
    if tr is None:
        keys = ("chi_window", "chi_steady", "chi_last_cycle", "speed_error") if name == "incerti2012" \
            else ("steady_error",)
        return {**{k: math.nan for k in keys}, "switch_freq_Hz": math.nan, "current_ripple_A": math.nan,
                "current_chatter_A": math.nan, "diverged": True}
    out = {"diverged": False}
    if name == "incerti2012":
        s = M.summary(tr, chi_window=(0.375, 0.5), steady_from=t0)
        out["chi_window"] = s["chi_window"]
        out["chi_steady"] = s.get("chi_steady_mean", math.nan)
        out["chi_last_cycle"] = s.get("chi_last_cycle", math.nan)
        out["speed_error"] = abs(s["mean_motor_speed_rad_s"] - 30.0) / 30.0
    else:

        out["steady_error"] = MQ.steady_error(tr, 5.0, t0)["error_abs_mean"]
    out.update(chatter(tr, t0, t1))
    return out


def main_metric(name) -> str:
    return "chi_steady" if name == "incerti2012" else "steady_error"


# ------------------------------------------------------------------ the table
def table(names=("incerti2012", "yigit2023"), backends=("multibody", "reduced"), progress=print) -> dict:
    """{scenario: {variant: {backend: metrics}}} for the ideal drive and the three estimators."""
    res = {}
    for name in names:
        res[name] = {}
        variants = {"ideal": ideal(name), **{e: realistic(name, e) for e in ESTIMATORS}}
        for var, ov in variants.items():
            res[name][var] = {}
            for b in backends:
                tr, msg = simulate(name, ov, b)
                res[name][var][b] = evaluate(name, tr)
                if progress:
                    progress(f"  {name} {var:10s} {b:9s} {main_metric(name)} = {res[name][var][b][main_metric(name)]:.4g}"
                             + (f"  DIVERGED: {msg[:80]}" if msg else ""))
    return res


# ------------------------------------------------------------------ each element alone
def elements(name) -> dict:
    """Each realistic element alone on the ideal model (0.1 ms sampling): {label: overrides}."""
    base = ideal(name)
    return {"ideal drive": base,
            "20 kHz switching PWM": base + PWM,
            "2000-line encoder, speed by difference": base + ["drive.encoder.lines=2000"],
            "2000-line encoder, speed by M/T": base + ["drive.encoder.lines=2000", 'drive.sensor.speed="mt"'],
            "one-sample computation delay": base + ['drive.sensor.speed="true"', "drive.sensor.delay=true"],
            "0.1° backlash, exact output-side sensor": base + GEAR,
            "0.1° backlash, exact motor-side sensor": base + GEAR + ['drive.sensor.speed="true"'],
            "Coulomb friction": base + FRICTION[name],
            "all, speed by M/T": realistic(name, "mt")}


def elements_table(names=("incerti2012", "yigit2023"), backend="reduced", progress=print) -> dict:
    """{scenario: {label: metrics}} of :func:`elements`."""
    out = {}
    for name in names:
        out[name] = {}
        for lab, ov in elements(name).items():
            tr, msg = simulate(name, ov, backend)
            out[name][lab] = evaluate(name, tr)
            if progress:
                progress(f"  {name} {lab}: {main_metric(name)} = {out[name][lab][main_metric(name)]:.4g}")
    return out


# ------------------------------------------------------------------ the sweep
def sweep(name, lines_list, periods, estimator="difference", backend="reduced", progress=print) -> dict:
    """Encoder resolution × sample period, the rest of the drive realistic; plus the ideal drive
    at each period.  Returns {"lines": [...], "periods": [...], "grid": [[metrics]], "ideal": [metrics]}."""
    grid = []
    ideal_row = []
    for p in periods:
        tr, _ = simulate(name, ideal(name, p), backend)
        ideal_row.append(evaluate(name, tr))
    for n in lines_list:
        row = []
        for p in periods:
            tr, msg = simulate(name, realistic(name, estimator, n, p), backend)
            row.append(evaluate(name, tr))
            if progress:
                progress(f"  {name} {estimator} lines={n} T={1e3 * p:g} ms: {main_metric(name)} = "
                         f"{row[-1][main_metric(name)]:.4g}" + (" DIVERGED" if msg else ""))
        grid.append(row)
    return {"scenario": name, "estimator": estimator, "backend": backend, "lines": list(lines_list),
            "periods": list(periods), "grid": grid, "ideal": ideal_row}


def breakdown(name, m, ideal_m) -> bool:
    """Whether a realistic run has broken down: diverged, seed 004's error above 1 % (5× the paper's
    0.2 %), seed 000's mean χ over the steady cycles 25 % above the ideal drive's at the same period."""
    if m.get("diverged"):
        return True
    if name == "yigit2023":
        return not (m["steady_error"] <= 0.01)
    return not (m["chi_steady"] <= 1.25 * ideal_m["chi_steady"])


# ------------------------------------------------------------------ figures
def figure_compare(name, trajs: dict, path, title=""):
    """Speed, voltage and current of the ideal and realistic runs: whole run and a 20 ms zoom."""

    mode, T, (t0, t1), _ = MACHINES[name]
    fig, ax = ps.new(3, 2, figsize=(12, 8.5), sharex="col")
    zoom = (t1 - 0.02, t1)
    colors = {"ideal": "k", "difference": "tab:red", "observer": "tab:orange", "mt": "tab:blue"}
    crank = name == "yigit2023"
    for var, tr in trajs.items():
        if tr is None:
            continue
        lab = LABELS.get(var, var)
        sp = tr.qd if crank else tr.omega
        for c, (a, b) in enumerate(((0.0, T), zoom)):
            k = (tr.t >= a) & (tr.t <= b)
            lw = 0.8 if c == 0 else 1.0
            ax[0, c].plot(tr.t[k], sp[k], color=colors.get(var), lw=lw, label=lab)
            ax[1, c].plot(tr.t[k], tr.voltage[k], color=colors.get(var), lw=lw, label=lab)
            if c == 1 and tr.has("current_max_A"):
                ax[2, c].fill_between(tr.t[k], tr["current_min_A"][k], tr["current_max_A"][k],
                                      color=colors.get(var), alpha=0.25, lw=0)
            ax[2, c].plot(tr.t[k], tr.current[k], color=colors.get(var), lw=lw, label=lab)
    ax[0, 0].set_ylabel(ps.label("crank speed α̇" if crank else "motor speed φ̇", "rad/s"))
    ax[1, 0].set_ylabel(ps.label("commanded voltage", "V"))
    ax[2, 0].set_ylabel(ps.label("current I (band: PWM min–max)", "A"))
    for c in range(2):
        ax[2, c].set_xlabel(ps.label("time t", "s"))
    ax[0, 0].legend(loc="lower right", fontsize=8)
    ax[0, 1].set_title("zoom: last 20 ms", fontsize=9)
    ps.finish(fig, title)
    return save(fig, path)


def figure_sweep(sweeps: list, path, title=""):
    """Heat maps of the main metric over encoder lines × sample period, broken-down cells hatched."""
    from matplotlib.colors import LogNorm


    fig, axes = ps.new(1, len(sweeps), figsize=(6.2 * len(sweeps), 4.6))
    axes = np.atleast_1d(axes)
    for ax, sw in zip(axes, sweeps):
        name = sw["scenario"]
        key = main_metric(name)
        Z = np.array([[m[key] if not m.get("diverged") else np.nan for m in row] for row in sw["grid"]])
        pos = Z[np.isfinite(Z) & (Z > 0)]
        norm = LogNorm(vmin=max(pos.min(), 1e-5), vmax=max(pos.max(), 1e-4)) if pos.size else None
        im = ax.imshow(Z, origin="lower", aspect="auto", cmap="viridis", norm=norm)
        ax.set_xticks(range(len(sw["periods"])), [f"{1e3 * p:g}" for p in sw["periods"]])
        ax.set_yticks(range(len(sw["lines"])), [str(n) for n in sw["lines"]])
        ax.set_xlabel(ps.label("control sample period", "ms"))
        ax.set_ylabel("encoder lines per revolution (×4)")
        from matplotlib.patches import Rectangle

        for i, row in enumerate(sw["grid"]):
            for j, m in enumerate(row):
                bad = breakdown(name, m, sw["ideal"][j])
                txt = "div." if m.get("diverged") else f"{m[key]:.2g}"
                light = bool(np.isfinite(Z[i, j]) and norm is not None and norm(Z[i, j]) > 0.6)
                ax.text(j, i, txt, ha="center", va="center", fontsize=8, color="k" if light else "w",
                        fontweight="bold" if bad else "normal")
                if bad:
                    ax.add_patch(Rectangle((j - 0.46, i - 0.46), 0.92, 0.92, fill=False, ec="red", lw=2.0))
        ax.set_title(f"{name} ({'PID: mean χ of the steady cycles' if name == 'incerti2012' else 'SMC: steady error'}), "
                     f"speed by {sw['estimator']}\nred frame: broken down", fontsize=9)
        fig.colorbar(im, ax=ax, shrink=0.85)
    ps.finish(fig, title)
    return save(fig, path)


# ------------------------------------------------------------------ report rows (reproduce)
def report_rows(ctx, name) -> list:
    """Rows of a ``*-realdrive`` reproduce case: the ideal drive and the realistic one (this case's
    runs: speed by difference, both backends) and the realistic one with the M/T speed (reduced)."""
    mode = MACHINES[name][0]
    if mode not in ctx.runs:
        return []
    cols = {}
    tr_i, _ = simulate(name, ideal(name), "reduced")
    cols["ideal (reduced)"] = evaluate(name, tr_i)
    for b, tr in ctx.runs[mode].items():  # this case's runs: the real drive (speed by difference)
        cols[b] = evaluate(name, tr)
    tr_m, _ = simulate(name, realistic(name, "mt"), "reduced")
    cols["real drive, M/T speed (reduced)"] = evaluate(name, tr_m)
    ctx.extra["drivetrain_trajs"] = {"ideal": tr_i, "difference": next(iter(ctx.runs[mode].values())), "mt": tr_m}
    order = ["multibody", "reduced", "ideal (reduced)", "real drive, M/T speed (reduced)"]
    cols = {k: cols[k] for k in order if k in cols}
    # (metric, label, unit, paper value, scale to the unit)
    spec = ([("chi_window", "χ, window 0.375–0.5 s (Eq 22)", "%", 2.6, 100.0),
             ("chi_steady", "χ, mean of the crank cycles in 1–2 s (Eq 22)", "%", None, 100.0),
             ("chi_last_cycle", "χ, last crank cycle (Eq 22)", "%", None, 100.0),
             ("speed_error", "|mean motor speed − ω₀|/ω₀, 1–2 s", "%", None, 100.0)] if name == "incerti2012" else
            [("steady_error", "steady crank-speed error |mean e|/ω_d, 2–3 s (§4)", "%", 0.2, 100.0)])
    spec += [("switch_freq_Hz", "voltage switching frequency (crossings of the mean, ±2 % v_max)", "Hz", None, 1.0),
             ("current_ripple_A", "PWM current ripple, mean peak-to-peak per step less its net change", "A", None, 1.0),
             ("current_chatter_A", "current chatter, RMS of I − 5 ms moving mean (> ≈200 Hz)", "A", None, 1.0)]
    why = ("multibody/reduced: this case's realistic drive (20 kHz switching PWM, 2000-line encoder on the motor, "
           "speed by difference, 0.1 ms sampling, 0.1° backlash, Coulomb friction); next to the ideal drive and the "
           "realistic one with the M/T speed (docs/drivetrain.md)")
    return [{"name": f"[real drive] {label}", "unit": unit, "paper": paper,
             "ours": {k: scale * m[key] for k, m in cols.items()}, "reason": why}
            for key, label, unit, paper, scale in spec]


def report_figures(ctx, name) -> list:
    trajs = ctx.extra.get("drivetrain_trajs")
    if not trajs:
        return []
    p = figure_compare(name, trajs, ctx.out / "drivetrain_compare.png",
                       title=f"{name}: ideal drive vs realistic drive (speed by difference / by M/T)")
    return [p]
