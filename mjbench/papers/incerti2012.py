"""Incerti 2012 (seed 000): four-bar linkage + DC motor + PID with the time-varying gain K_p·t.

Report rows: the scenario's ``[[paper.figures]]`` (χ of Eq 22 open loop and PID) come from the
run itself (:func:`mjbench.runner.paper_rows`); then the linear analysis of the PID loop
(:mod:`mjbench.linear`): worst frozen-angle margins, peak |S|, bandwidth and the frozen-angle
validity number with K_p·t frozen at a few times, and the time at which the sampled K_p·t loop
loses stability.  Figures: Fig. 4's layout (both columns, both backends) and the frozen-angle
Bode family of the loop.  The calibration of the illegible Table I values is
:mod:`mjbench.papers.incerti2012_calibration`.
"""
from __future__ import annotations

from mjbench.papers import Case

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
]


#: K_p·t frozen at these times [s] for the loop rows (0.375-0.5 s: the paper's χ window)
LOOP_TIMES = (0.1, 0.5, 2.0)
N_ANGLES = 24


def _families(ctx):
    """Frozen-angle families of the PID loop at LOOP_TIMES (computed once per case)."""
    from mjbench import linear

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


def rows(ctx) -> list:
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
    """Seed 000 Fig. 4 layout (one column per mode, every backend, set-point dashed) and the
    frozen-angle Bode family of the PID loop at the end of the paper's χ window."""
    from mjbench import linear_plots
    from mjbench.reproduce import default_figures

    figs = default_figures(ctx)
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
