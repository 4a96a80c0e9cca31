"""Yiğit & Şen 2023 (seed 004): quick-return mechanism, optimum design, sliding-mode control.

Report rows: the SMC's steady crank-speed error (§4: 0.2 %) and the open-loop speed band (Fig. 6);
figures: Figs 6 (crank speed) and 7 (SMC voltage).  Metrics:
:mod:`mjbench.papers.yigit2023_metrics`, plots: :mod:`mjbench.papers.yigit2023_plots`, the
optimum design of §3: :mod:`mjbench.papers.yigit2023_design`.
"""
from __future__ import annotations

from mjbench.papers import Case

from mjbench import scenario as S

KEY = "yigit2023"
CITATION = "Yiğit & Şen 2023"
TITLE = "Optimum design and control of a quick-return mechanism used in a jewelry welding powder production machine"
SCENARIOS = ("yigit2023",)
CASES = [
    Case(name="yigit2023-fig6-7", scenario="yigit2023",
         title="Figs 6-7: open loop 48 V and sliding-mode control at ω_d = 5 rad/s",
         modes=["open", "smc"], backend="both", video=True, video_mode="smc", video_t_end=4.0),
]


def figures(ctx) -> list:
    """Seed 004 Figs 6 (crank speed, all modes) and 7 (voltage of the closed loop)."""
    from . import yigit2023_plots as PQ

    pap = ctx.scn.get("paper", {})
    runs = {f"{mode} ({b})": tr for mode, trs in ctx.runs.items() for b, tr in trs.items()}
    band = (pap["open_speed_min"], pap["open_speed_max"]) if "open_speed_min" in pap else None
    t_end = min(float(tr.t[-1]) for tr in runs.values())
    zoom = (max(0.0, t_end - 2.0), max(0.5, t_end - 1.0))
    window = (zoom[0], zoom[0] + 0.05)
    return PQ.figures(runs, ctx.out, omega_d=float(S.get(ctx.scn, "metrics.omega_d", pap.get("omega_d", 5.0))),
                      zoom=zoom, window=window, band=band,
                      v_limit=float(S.get(ctx.scn, "drive.v_max", 48.0)))


def rows(ctx) -> list:
    """Seed 004: steady crank-speed error of the SMC (§4: 0.2 %) and the open-loop speed band."""
    from . import yigit2023_metrics as MQ

    pap = ctx.scn.get("paper", {})
    rows = []
    t_start = float(S.get(ctx.scn, "metrics.steady_start", 2.0))
    if "smc" in ctx.runs and "smc_steady_error" in pap:
        wd = float(S.get(ctx.scn, "metrics.omega_d", 5.0))
        errs = {b: MQ.steady_error(tr, wd, t_start)["error_abs_mean"] for b, tr in ctx.runs["smc"].items()}
        rows.append({"name": "SMC steady-state crank-speed error |mean e| (§4)", "unit": "1",
                     "paper": pap["smc_steady_error"], "ours": errs,
                     "reason": "bang-bang switching: the residual error depends on the control sampling period "
                               "Ts, not given in the paper (docs/quickreturn.md)"})
    if "open" in ctx.runs and "open_speed_min" in pap:
        for key, lab in (("min", "open_speed_min"), ("max", "open_speed_max")):
            vals = {b: MQ.speed_stats(tr, t_start)[f"speed_{key}"] for b, tr in ctx.runs["open"].items()}
            rows.append({"name": f"open loop 48 V: crank speed {key} in steady state (Fig. 6)", "unit": "rad/s",
                         "paper": pap[lab], "ours": vals,
                         "reason": "the stated motor constants cap the unloaded speed at 5.916 rad/s at 48 V "
                                   "(docs/quickreturn.md)"})
    return rows


