"""Incerti 2012: four-bar linkage + DC motor + PID with the time-varying gain K_p·t.

Report rows: the scenario's ``[[paper.figures]]`` (χ of Eq 22, open loop and PID) come from the
run itself (:func:`mjbench.runner.paper_rows`); this module adds the figures they depend on:

* χ of the open loop over the other reading of "the cycle" (the last 2π of crank travel ending
  at t_end, next to the last complete cycle counted from α(0));
* the closed-loop χ in the paper's window with our assumed ±48 V limiter removed, and with a
  plain clip instead of the clip + anti-windup (the paper gives neither: Fig. 3 draws a limiter
  without a value) — short runs to the end of the window on the multibody backend;
* how much of the PID run the voltage sits at the limit (Fig. 4 panel d shows it switching
  between the limits over the whole run; the paper prints no number);
* χ of the PID run over its last cycle, both readings (no paper figure);
* the linear analysis of the PID loop (:mod:`mjbench.linear`): worst frozen-angle margins, peak
  |S|, bandwidth and the frozen-angle validity number with K_p·t frozen at a few times, and the
  time at which the sampled K_p·t loop loses stability.

The realistic-drive case (``incerti2012-realdrive``): χ, speed error and chattering next to the ideal
drive (:mod:`mjbench.papers.drivetrain_study`) and the frequency response of the running machine on
the ideal and the realistic drive (:mod:`mjbench.papers.frest_study`: rows, a table, a Bode figure).

Figures: Fig. 4's layout (both columns, both backends) and the frozen-angle Bode family of the
loop.  The calibration of the illegible Table I values is
:mod:`mjbench.papers.incerti2012_calibration`.
"""
from __future__ import annotations

import math

from mjbench.papers import Case
from mjbench.papers import drivetrain_study as DT
from mjbench.papers import frest_study as FR
from mjbench import metrics as M
from mjbench import runner
from mjbench import scenario as S
from mjbench import linear
from mjbench import linear_plots
from mjbench.reproduce import default_figures

KEY = "incerti2012"
CITATION = "Incerti 2012"
TITLE = "On the dynamic behaviour of a four-bar linkage driven by a velocity controlled DC motor"
SCENARIOS = ("incerti2012", "incerti2012-calibrated")
CASES = [
    Case(name="incerti2012-fig4", scenario="incerti2012",
         title="Fig. 4: open loop 25 V (left) and PID K_p·t (right), χ of Eq 22",
         modes=["open", "pid"], backend="both", t_end=2.0, video=True, video_mode="pid", video_t_end=2.0),
    Case(name="incerti2012-calibrated-fig4", scenario="incerti2012-calibrated",
         title="Fig. 4 with the missing Table I values FITTED to the paper's χ (not a prediction)",
         modes=["open", "pid"], backend="both", t_end=2.0, video=True, video_mode="pid", video_t_end=2.0),
    Case(name="incerti2012-realdrive", scenario="incerti2012", overrides=DT.case_overrides("incerti2012"),
         title="the PID of Fig. 4 on a realistic drive: 20 kHz PWM, 2000-line encoder, 0.1 ms sampling, "
               "0.1° backlash, Coulomb friction (docs/drivetrain.md)",
         modes=["pid"], backend="both", t_end=2.0, video=False),
]

#: the limiter variants of the closed-loop χ: label → scenario values
LIMITER_VARIANTS = {
    "without the voltage limiter": {"drive.v_max": "inf", "modes.pid.v_limit": "none"},
    "with a plain clip at the limit (no anti-windup)": {"modes.pid.v_limit": "none"},
}


def _fig(scn, mode, metric):
    return next((f for f in scn.paper.get("figures", []) or []
                 if f.get("mode") == mode and f.get("metric") == metric), None)


def limiter_variants(scn, t_end: float, backend: str = "multibody") -> dict:
    """χ in the metrics window of the PID mode for each :data:`LIMITER_VARIANTS` entry (a run to
    ``t_end`` on ``backend``): {label: (χ as a fraction, the --set items)}."""

    out = {}
    mt = scn.metrics
    for label, values in LIMITER_VARIANTS.items():
        sv = S.with_values(scn, values)
        tr = runner.run_mode(sv, "pid", (backend,), t_end)[backend]
        out[label] = (M.chi(tr.t, tr.omega, *mt.chi_window, average=mt.chi_average),
                      " ".join(f"--set {k}={v}" for k, v in values.items()))
    return out


def _span(m, key):
    a, b = ("last_cycle_start_s", "last_cycle_end_s") if key == "chi_last_cycle" else \
        ("last_turn_start_s", "last_turn_end_s")
    return f"{m[a]:.3f}–{m[b]:.3f} s"


def rows(ctx) -> list:
    """χ rows (the other last-cycle reading, the limiter what-ifs, time at the limit), then the
    linear loop rows; the realistic-drive case: χ, speed error and chattering next to the ideal
    drive (:mod:`mjbench.papers.drivetrain_study`)."""
    if ctx.case.name.endswith("-realdrive"):  # + the frequency response on the ideal and the realistic drive
        ctx.tables.append(FR.report_table(ctx, "incerti2012"))
        return DT.report_rows(ctx, "incerti2012") + FR.report_rows(ctx, "incerti2012")
    return _chi_rows(ctx) + linear_rows(ctx)


def _chi_rows(ctx) -> list:
    """χ over the last 2π (open loop), the limiter variants and the time at the limit (PID)."""

    scn, out = ctx.scn, []
    if "open" in ctx.metrics:
        fig = _fig(scn, "open", "chi_last_cycle")
        ms = ctx.metrics["open"]["backends"]
        m0 = next(iter(ms.values()))
        if "chi_last_turn" in m0:
            out.append({"name": f"χ, open loop 25 V (Eq 22), last 2π of travel ending at t_end ({_span(m0, 'chi_last_turn')})",
                        "unit": "%", "paper": fig.get("value") if fig else None, "compare": "value",
                        "fitted": bool(fig and fig.get("fitted")),
                        "ours": {b: 100 * m["chi_last_turn"] for b, m in ms.items() if "chi_last_turn" in m},
                        "reason": "the other reading of the paper's 'steady cycle' (the last complete cycle "
                                  f"counted from α(0) spans {_span(m0, 'chi_last_cycle')})"
                                  if "chi_last_cycle" in m0 else "the paper's 'steady cycle', read as the last 2π"})
    if "pid" not in ctx.runs:
        return out
    ms = ctx.metrics["pid"]["backends"]
    m0 = next(iter(ms.values()))
    fig = _fig(scn, "pid", "chi_window")
    v_max = float(scn.drive.v_max) if scn.drive.v_max is not None else math.inf
    if scn.metrics.chi_window is not None:
        t0, t1 = scn.metrics.chi_window
        for label, (chi, sets) in limiter_variants(scn, t1).items():
            out.append({"name": f"χ, PID K_p·t, window {t0:g}–{t1:g} s, {label}", "unit": "%",
                        "paper": fig.get("value") if fig else None, "compare": "value",
                        "ours": {"multibody": 100 * chi},
                        "reason": f"what-if on our limiter assumption (`{sets}`; ours keeps ±{v_max:g} V with the "
                                  "anti-windup); the paper states no limiter value"})
    out.append({"name": "peak |armature voltage|, PID", "unit": "V", "paper": None,
                "ours": {bk: float(abs(tr.voltage).max()) for bk, tr in ctx.runs["pid"].items()},
                "reason": f"our limiter: ±{v_max:g} V (Fig. 3 draws one without a value)"})
    if math.isfinite(v_max):
        windows = [("over the whole run", None, None)]
        t_run = min(float(tr.t[-1]) for tr in ctx.runs["pid"].values())
        if scn.metrics.chi_window is not None and t_run >= scn.metrics.chi_window[1] - 1e-9:
            t0, t1 = scn.metrics.chi_window
            windows.append((f"in the window {t0:g}–{t1:g} s", t0, t1))
        for what, a, b in windows:
            out.append({"name": f"time at the ±{v_max:g} V limit, PID, {what}", "unit": "%", "paper": None,
                        "ours": {bk: 100 * M.voltage_at_limit(tr, v_max, a, b) for bk, tr in ctx.runs["pid"].items()},
                        "reason": "Fig. 4 panel d shows the voltage switching between the limits over the whole run; "
                                  "the paper prints no number"})
    for key, what in (("chi_last_cycle", "last complete cycle from α(0)"),
                      ("chi_last_turn", "last 2π of travel ending at t_end")):
        if key in m0:
            out.append({"name": f"χ, PID K_p·t, {what} ({_span(m0, key)})", "unit": "%", "paper": None,
                        "ours": {b: 100 * m[key] for b, m in ms.items() if key in m},
                        "reason": "the paper quotes the closed-loop χ on its window only"})
    return out


#: K_p·t frozen at these times [s] for the loop rows (0.375-0.5 s: the paper's χ window)
LOOP_TIMES = (0.1, 0.5, 2.0)
N_ANGLES = 24


def _families(ctx):
    """Frozen-angle families of the PID loop at LOOP_TIMES (computed once per case)."""

    if "linear" not in ctx.extra:
        mach = ctx.machines.get("pid")
        if mach is None:
            ctx.extra["linear"] = None
        else:
            h = float(ctx.scn.simulation.dt)
            fams = {t: linear.frozen_angle_family(mach, h, N_ANGLES, t=t) for t in LOOP_TIMES}
            lim = linear.kp_ramp_limit(mach, h, N_ANGLES) if getattr(mach.controller, "kp_ramp", False) else None
            ctx.extra["linear"] = {"families": fams, "limit": lim, "machine": mach}
    return ctx.extra["linear"]


def linear_rows(ctx) -> list:
    """The PID loop of Eq 16 (linear, sampled at the co-simulation step, K_p·t frozen at t):
    worst frozen-angle margins, bandwidth, validity of the frozen picture, K_p·t stability limit.
    The paper gives none of these (no number to compare): every value is computed here."""
    lin = _families(ctx)
    if lin is None:
        return []
    mach = lin["machine"]
    out = []
    why = ("not in the paper; linear loop at the plant input, worst over 24 frozen crank angles at the "
           "30 rad/s set-point (docs/linear.md)")
    for t, fam in lin["families"].items():
        kp = float(mach.controller.gain_p(t))
        w, v = fam.worst, fam.validity
        tag = f"PID, K_p·t = {kp:.4g} V·s/rad (t = {t:g} s)"
        out += [
            {"name": f"{tag}: worst phase margin (at q = {w['phase_margin_deg']['at_q_rad']:.2f} rad)", "unit": "deg",
             "paper": None, "ours": {"linear": w["phase_margin_deg"]["value"]}, "reason": why},
            {"name": f"{tag}: worst gain margin (at q = {w['gain_margin_dB']['at_q_rad']:.2f} rad)", "unit": "dB",
             "paper": None, "ours": {"linear": w["gain_margin_dB"]["value"]}, "reason": why},
            {"name": f"{tag}: max peak |S| (at q = {w['peak_sensitivity']['at_q_rad']:.2f} rad)", "unit": "1",
             "paper": None, "ours": {"linear": w["peak_sensitivity"]["value"]}, "reason": why},
            {"name": f"{tag}: slowest closed-loop bandwidth", "unit": "rad/s", "paper": None,
             "ours": {"linear": w["bandwidth_rad_s"]["value"]},
             "reason": ("every frozen loop stable" if w["all_stable"] else
                        "some frozen loops are UNSTABLE at this gain (negative J'·q̇ damping; see ν)")},
            {"name": f"{tag}: frozen-angle validity ν = max|J'q̇/J| / bandwidth", "unit": "1", "paper": None,
             "ours": {"linear": v["ratio"]},
             "reason": f"{v['verdict']} (< 0.1 valid, > 1 fails): the inertia changes at up to "
                       f"{v['inertia_rate_max_1_s']:.3g} 1/s"},
        ]
    lim = lin["limit"]
    if lim is not None and lim.get("t_s") is not None:
        out += [
            {"name": "K_p·t ramp: the sampled loop loses stability at t", "unit": "s", "paper": None,
             "ours": {"linear": lim["t_s"]},
             "reason": f"K_p·t = {lim['kp_eff']:.4g} V·s/rad at q = {lim['at_q_rad']:.2f} rad, h = "
                       f"{float(ctx.scn.simulation.dt):g} s: Eq 15's unbounded gain (the paper runs 2 s)"},
            {"name": "K_p·t ramp: every frozen loop stable from t", "unit": "s", "paper": None,
             "ours": {"linear": lim["t_stable_from_s"]},
             "reason": "before, K_p·t is too small to stabilise the angles where J'·q̇ < 0 (frozen picture)"},
        ]
    return out


def figures(ctx) -> list:
    """Incerti 2012 Fig. 4 layout (one column per mode, every backend, set-point dashed) and the
    frozen-angle Bode family of the PID loop at the end of the paper's χ window."""

    figs = default_figures(ctx, "fig4.png")  # the paper's own figure name
    if ctx.case.name.endswith("-realdrive"):
        return figs + DT.report_figures(ctx, "incerti2012") + [FR.report_figure(ctx, "incerti2012")]
    lin = _families(ctx)
    if lin is not None:
        t = 0.5
        fam = lin["families"][t]
        kp = float(lin["machine"].controller.gain_p(t))
        i = int(min(range(len(fam.margins)), key=lambda k: fam.margins[k].phase_margin_deg))
        figs.append(linear_plots.bode([lp.L for lp in fam.loops], ctx.out / "linear_bode_pid.png", fam.angles,
                                      fam.loops[i].L, margins=fam.margins[i],
                                      title=f"{ctx.case.name}: PID loop L at frozen crank angles, K_p·t = {kp:g} V·s/rad "
                                            f"(t = {t:g} s); black: worst phase margin, q = {fam.angles[i]:.2f} rad"))
    return figs
