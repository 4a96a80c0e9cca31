"""Yiğit & Şen 2023: quick-return mechanism, optimum design, sliding-mode control.

Three report cases:

* ``yigit2023-fig6-7`` (Figs 6-7): the open loop at 48 V judged against the paper's 6.1-6.4 rad/s
  band (steady min, mean, max) next to the no-load speed of the stated motor (Table II, Eqs
  29-30 — an upper limit of any open-loop speed); the SMC's steady error against §4's 0.2 %, and
  a study of the control period Ts the paper does not give (:data:`TS_STUDY`, multibody runs):
  which Ts gives 0.2 % (table + figure).
* ``yigit2023-design`` (Eqs 1-2, Table I): our optimum next to Table I, for the two readings of
  constraint c4 and two lower bounds of the (unstated) design bounds, and what the margin on the
  strict inequalities costs (:mod:`mjbench.papers.yigit2023_design`).
* ``yigit2023-realdrive``: the SMC on a realistic drive next to the ideal one
  (:mod:`mjbench.papers.drivetrain_study`), and the frequency response of the running machine — the
  SMC and the scenario's PID mode on both drives (:mod:`mjbench.papers.frest_study`).

Metrics: :mod:`mjbench.papers.yigit2023_metrics`, plots: :mod:`mjbench.papers.yigit2023_plots`.
"""
from __future__ import annotations

import math

import numpy as np

from mjbench import scenario as S
from mjbench.papers import Case
from mjbench.papers import drivetrain_study as DT
from mjbench.papers import frest_study as FR
from mjbench import runner
from . import yigit2023_metrics as MQ
from .. import papers

KEY = "yigit2023"
CITATION = "Yiğit & Şen 2023"
TITLE = "Optimum design and control of a quick-return mechanism used in a jewelry welding powder production machine"
SCENARIOS = ("yigit2023",)
CASES = [
    Case(name="yigit2023-fig6-7", scenario="yigit2023",
         title="Figs 6-7: open loop 48 V and sliding-mode control at ω_d = 5 rad/s; the control period Ts",
         modes=["open", "smc"], backend="both", video=True, video_mode="smc", video_t_end=4.0),
    Case(name="yigit2023-design", scenario="yigit2023", kind="study", video=False,
         title="Optimum design (Eqs 1-2): Table I against our optimum, two readings of constraint c4"),
    Case(name="yigit2023-realdrive", scenario="yigit2023", overrides=DT.case_overrides("yigit2023"),
         title="the SMC on a realistic drive: 20 kHz PWM, 2000-line encoder, 0.1 ms sampling (Ts), "
               "0.1° backlash, Coulomb friction (docs/drivetrain.md)",
         modes=["smc"], backend="both", t_end=3.0, video=False),
]

TS_STUDY = (1e-4, 2e-4, 3e-4, 5e-4, 1e-3, 2e-3)  #: control periods of the SMC study [s] (multiples of simulation.dt)
#: design configurations of the report: label → (lower bound [mm], c4 reading)
DESIGNS = {"bounds 10–500 mm, c4 max-abs": (10.0, "max-abs"), "bounds 10–500 mm, c4 signed": (10.0, "signed"),
           "bounds 54–500 mm, c4 max-abs": (54.0, "max-abs"), "bounds 54–500 mm, c4 signed": (54.0, "signed")}


# ============================================================================ Figs 6-7
def no_load_crank_speed(scn, voltage: float) -> float:
    """Steady crank speed of the stated motor with no mechanism and no load at ``voltage`` [rad/s]
    (Eqs 29-30 at rest of di/dt and dω/dt): V = R·I + z·k_m·ω, k_m·I = z·λ·ω + T_0, i.e.
    ω = (V − R·T_0/k_m) / (z·k_m + R·z·λ/k_m)."""
    d = scn.drive
    z, km, R, lam, T0 = float(d.z), float(d.k_m), float(d.R), float(d.lam), float(d.T_0 or 0.0)
    return (voltage - R * T0 / km) / (z * km + R * z * lam / km)


def ts_study(ctx, backend: str = "multibody") -> dict:
    """The SMC's steady error for each control period of :data:`TS_STUDY` (the scenario's own Ts
    is taken from the case's run): {"rows": [(Ts, |mean e| %, max |e| %)],
    "matched": Ts at which |mean e| equals the paper's figure (log-log interpolation) or None}."""


    scn = ctx.scn
    t_start = float(S.get(scn, "metrics.steady_start", 2.0))
    wd = float(S.get(scn, "metrics.omega_d", 5.0))
    Ts0 = float(scn.modes["smc"].Ts)
    rows = []
    for Ts in sorted(set(TS_STUDY) | {Ts0}):
        if math.isclose(Ts, Ts0) and backend in ctx.runs.get("smc", {}):
            tr = ctx.runs["smc"][backend]
        else:
            tr = runner.run_mode(S.with_values(scn, {"modes.smc.Ts": Ts}), "smc", (backend,), ctx.case.t_end)[backend]
        e = MQ.steady_error(tr, wd, t_start)
        rows.append((Ts, 100 * e["error_abs_mean"], 100 * e["error_abs_max"]))
    paper = 100 * float(scn.paper.get("smc_steady_error", float("nan")))
    matched = None
    for (t0, e0, *_), (t1, e1, *_) in zip(rows[:-1], rows[1:]):
        if min(e0, e1) <= paper <= max(e0, e1) and e0 > 0 and e1 > 0 and e0 != e1:
            f = (math.log(paper) - math.log(e0)) / (math.log(e1) - math.log(e0))
            matched = math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
            break
    return {"rows": rows, "matched": matched, "paper_pct": paper, "Ts_default": Ts0, "backend": backend}


def _fig6_rows(ctx) -> list:

    scn = ctx.scn
    pap = scn.paper
    out = []
    t_start = float(S.get(scn, "metrics.steady_start", 2.0))
    band = [pap["open_speed_min"], pap["open_speed_max"]] if "open_speed_min" in pap else None
    if "open" in ctx.runs and band is not None:
        V = float(scn.modes["open"].voltage)
        for key in ("min", "max"):
            vals = {b: MQ.speed_stats(tr, t_start)[f"speed_{key}"] for b, tr in ctx.runs["open"].items()}
            out.append({"name": f"open loop {V:g} V: crank speed {key} in steady state (Fig. 6 band)", "unit": "rad/s",
                        "paper": band, "ours": vals,
                        "reason": "the speed the stated motor can reach is capped: see the no-load row"})
        d = scn.drive
        out.append({"name": f"no-load crank speed of the stated motor at {V:g} V (Table II, Eqs 29-30, no mechanism)",
                    "unit": "rad/s", "paper": band, "ours": {"Table II": no_load_crank_speed(scn, V)},
                    "reason": f"V/(z·K_m + R·z·B_m/K_m) with z = {float(d.z):g}, K_m = {float(d.k_m):g} V·s/rad, "
                              f"R = {float(d.R):g} Ω, B_m = {float(d.lam):g} N·m·s/rad: any load only lowers it, "
                              "so no mechanism model reaches a band above it"})
    if "smc" in ctx.runs and "smc_steady_error" in pap:
        wd = float(S.get(scn, "metrics.omega_d", 5.0))
        st = ts_study(ctx)
        ctx.extra["ts_study"] = st
        Ts0 = st["Ts_default"]
        errs = {b: 100 * MQ.steady_error(tr, wd, t_start)["error_abs_mean"] for b, tr in ctx.runs["smc"].items()}
        closest = min(st["rows"], key=lambda r: abs(math.log(r[1] / st["paper_pct"])) if r[1] > 0 else math.inf)
        match = (f"the Ts study gives the paper's figure at Ts ≈ {1e3 * st['matched']:.2g} ms"
                 if st["matched"] is not None else "no period of the Ts study gives the paper's figure")
        out.append({"name": f"SMC steady crank-speed error |mean e|/ω_d (§4), scenario Ts = {1e3 * Ts0:g} ms",
                    "unit": "%", "paper": st["paper_pct"], "ours": errs, "headline": True,
                    "reason": f"bang-bang switching (K ≫ the 48 V bound): the residual error is set by the control "
                              f"period Ts, which the paper does not give; {match}"})
        for Ts, e_mean, _ in st["rows"]:
            if math.isclose(Ts, Ts0):
                continue
            out.append({"name": f"SMC steady error |mean e|/ω_d with Ts = {1e3 * Ts:g} ms", "unit": "%",
                        "paper": st["paper_pct"], "ours": {st["backend"]: e_mean},
                        "reason": "Ts study (`--set Ts=...`)" + ("; the closest period of the study"
                                                                  if Ts == closest[0] else "")})
        if st["matched"] is not None:
            out.append({"name": "control period Ts that gives the paper's 0.2 % (log-log interpolation of the study)",
                        "unit": "ms", "paper": None, "ours": {st["backend"]: 1e3 * st["matched"]},
                        "reason": "the paper states no Ts; the scenario keeps its own (not tuned to the paper)"})
        ctx.tables.append({
            "title": f"SMC steady error against the control period Ts ({st['backend']} backend, t ≥ {t_start:g} s, "
                     "whole crank turns)",
            "head": ["Ts [ms]", "|mean e|/ω_d [%]", "max |e|/ω_d [%]"],
            "rows": [[f"{1e3 * Ts:g}" + (" (scenario)" if math.isclose(Ts, Ts0) else ""), e1, e2]
                     for Ts, e1, e2 in st["rows"]],
            "note": f"Paper (§4): {st['paper_pct']:g} %. " + (match[0].upper() + match[1:] + ".")})
    return out


# ============================================================================ design
def study(ctx):
    """``yigit2023-design``: :func:`yigit2023_design.optimise` for every :data:`DESIGNS` entry and,
    for the first, with no margin on the strict inequalities (eps = 0)."""
    D = papers.yigit2023_design  # (scipy.optimize: loaded on first use)

    res = {}
    for label, (lo, c4) in DESIGNS.items():
        res[label] = D.optimise(bounds=((lo, 500.0),) * 5, c4=c4)
    first = next(iter(DESIGNS))
    lo, c4 = DESIGNS[first]
    res["eps = 0"] = D.optimise(bounds=((lo, 500.0),) * 5, c4=c4, eps=0.0)
    ctx.extra["design"] = res


def _design_rows(ctx) -> list:
    D = papers.yigit2023_design  # (scipy.optimize: loaded on first use)

    res = ctx.extra["design"]
    paper_sum = float(ctx.scn.paper.get("design_sum_mm", float(np.sum(D.TABLE_I))))
    out = []
    for label in DESIGNS:
        b = res[label].get("best")
        out.append({"name": f"r₂ + r₃ + r₄ + a + b of the optimum (Eq 1), {label}", "unit": "mm", "paper": paper_sum,
                    "ours": {"ours": b["sum_mm"] if b else None},
                    "reason": "the paper's fmincon result (Table I) is not the minimum of Eq 1 under our reading of "
                              "Eq 2: the bounds are unstated and the stroke constraint is cheapest at the largest "
                              "swing TR < 2 allows (docs/quickreturn.md)"})
    tab = res[next(iter(DESIGNS))]["table_I"]
    out.append({"name": "constraints of Eq 2 violated by Table I (our reading, no margin)", "unit": "",
                "paper": None, "ours": {"ours": ", ".join(tab["violated"]) or "none"},
                "reason": f"Table I's stroke is {tab['stroke_mm']:.2f} mm against c3's 250 mm: rounding"})
    first = next(iter(DESIGNS))
    a, z = res[first]["best"], res["eps = 0"]["best"]
    out.append({"name": f"cost of the 1e-3 margin on the strict inequalities, {first}", "unit": "mm", "paper": None,
                "ours": {"ours": a["sum_mm"] - z["sum_mm"]},
                "reason": f"TR < 2 − 1e-3 lengthens r₃ by {a['r3'] - z['r3']:.3g} mm and the slider line follows "
                          f"(b +{a['b'] - z['b']:.3g} mm); `mjbench design --eps 0` removes it"})
    for label in DESIGNS:
        r = res[label]
        if "from_table_I" in r and r["best"]["sum_mm"] < r["from_table_I"]["sum_mm"] - 0.01:
            out.append({"name": f"local optimum from Table I (SLSQP), {label}", "unit": "mm", "paper": paper_sum,
                        "ours": {"ours": r["from_table_I"]["sum_mm"]},
                        "reason": "a local optimiser started at Table I stays on the branch with the slider line "
                                  "above the lever tip at the swing ends; the global optimum "
                                  f"({r['best']['sum_mm']:.1f} mm) lies on the other branch"})
    rows_t = [["Table I (paper)", *D.TABLE_I.tolist(), tab["sum_mm"], tab["TR"], tab["stroke_mm"], tab["mu_min_deg"],
               tab["c4_mm"], tab["c4_signed_mm"], "—"]]
    for label in list(DESIGNS) + ["eps = 0"]:
        b = res[label].get("best")
        if b is None:
            continue
        name = label if label != "eps = 0" else f"{first}, eps = 0"
        rows_t.append([name, *b["x"], b["sum_mm"], b["TR"], b["stroke_mm"], b["mu_min_deg"], b["c4_mm"],
                       b["c4_signed_mm"], b["start"]])
        if label == "bounds 54–500 mm, c4 signed" and "from_table_I" in res[label]:
            f = res[label]["from_table_I"]
            rows_t.append([f"{label}: local, SLSQP from Table I", *f["x"], f["sum_mm"], f["TR"], f["stroke_mm"],
                           f["mu_min_deg"], f["c4_mm"], f["c4_signed_mm"], "Table I start"])
    ctx.tables.append({
        "title": "Designs (lengths in mm; μ_min = smallest transmission angle at the slider [°]; c4 = stroke + rod "
                 "term in the two readings)",
        "head": ["design", "r₂", "r₃", "r₄", "a", "b", "sum", "TR", "stroke", "μ_min", "c4 max-abs", "c4 signed",
                 "found by"],
        "rows": rows_t,
        "note": "c4 'max-abs': stroke + r₄·sin φ_max, φ_max the largest |rod angle| to the slider path over the "
                "swing (our default); 'signed': stroke + r₄·sin φ at the lever extremes, φ signed (negative when the "
                "slider line lies below the lever tip). Choose with `mjbench design quickreturn --c4 max-abs|signed`; "
                "bounds with `--bounds LO HI` (the paper gives none)."})
    return out


# ============================================================================ hooks
def rows(ctx) -> list:
    if ctx.case.kind == "study":
        return _design_rows(ctx)
    if ctx.case.name.endswith("-realdrive"):  # the SMC on a realistic drive, next to the ideal one; frequency response
        ctx.tables.append(FR.report_table(ctx, "yigit2023"))
        return DT.report_rows(ctx, "yigit2023") + FR.report_rows(ctx, "yigit2023")
    return _fig6_rows(ctx)


def figures(ctx) -> list:
    """Figs 6 (crank speed, all modes) and 7 (voltage of the closed loop), the Ts study; or the
    design comparison."""
    PQ = papers.yigit2023_plots  # (matplotlib: loaded on first use)

    if ctx.case.kind == "study":
        D = papers.yigit2023_design  # (scipy.optimize: loaded on first use)

        res = ctx.extra["design"]
        designs = {"Table I (paper)": D.TABLE_I}
        for label in ("bounds 10–500 mm, c4 max-abs", "bounds 54–500 mm, c4 max-abs", "bounds 54–500 mm, c4 signed"):
            if res[label].get("best"):
                designs[label.replace(", ", "\n")] = res[label]["best"]["x"]
        return [PQ.design_comparison(designs, str(ctx.out / "designs.png"),
                                     title=f"{ctx.case.name}: Table I and our optimum designs at one scale "
                                           "(swing ends solid, mid-swing dotted)")]
    if ctx.case.name.endswith("-realdrive"):
        return DT.report_figures(ctx, "yigit2023") + [FR.report_figure(ctx, "yigit2023")]
    pap = ctx.scn.paper
    runs = {f"{mode} ({b})": tr for mode, trs in ctx.runs.items() for b, tr in trs.items()}
    band = (pap["open_speed_min"], pap["open_speed_max"]) if "open_speed_min" in pap else None
    t_end = min(float(tr.t[-1]) for tr in runs.values())
    zoom = (max(0.0, t_end - 2.0), max(0.5, t_end - 1.0))
    window = (zoom[0], zoom[0] + 0.05)
    figs = PQ.figures(runs, ctx.out, omega_d=float(S.get(ctx.scn, "metrics.omega_d", pap.get("omega_d", 5.0))),
                      zoom=zoom, window=window, band=band, v_limit=float(S.get(ctx.scn, "drive.v_max", 48.0)))
    st = ctx.extra.get("ts_study")
    if st is not None:
        figs.append(PQ.ts_study(st["rows"], str(ctx.out / "smc_ts_study.png"),
                                paper_pct=st["paper_pct"], default_Ts=st["Ts_default"], matched=st["matched"],
                                title=f"{ctx.case.name}: SMC steady error vs control period ({st['backend']})"))
    return figs
