"""Frequency response of the real-drive machines (issue 25, ``mjbench frest``): seed 000's PID and
seed 004's sliding-mode controller measured on the ideal and on the realistic drive of
:mod:`mjbench.papers.drivetrain_study` (M/T speed), next to the linearisation at the operating point
and the frozen-angle family followed along the turn (:mod:`mjbench.frest`, docs/bridges.md §3).

Report rows, a table and a Bode figure of the ``*-realdrive`` reproduce cases
(:mod:`mjbench.papers.incerti2012`, :mod:`mjbench.papers.yigit2023`).  Variants per machine
(:data:`VARIANTS`): seed 000's PID held at the scenario's point (q = 0, 30 rad/s, K_p·t frozen at
2 s) on the ideal drive, on the ideal drive without the ±48 V limiter (the linear loop the ideal
drive would have) and on the realistic drive; seed 004's SMC on both drives, and its PID mode (the
machine's linear loop) on both drives.

Settings (:data:`SETTINGS`, cheap enough for ``make demo``): reduced backend, 12 lines, 2 measured
periods, 1 s of settling instead of the default 7 time constants of the slowest closed-loop pole
(seed 000's slowest pole, −0.19 rad/s, is almost cancelled by the PID's zero: the frozen-band
estimate moves by 5e-4 between 3 s and 13 s of settling; docs/bridges.md).
"""
from __future__ import annotations

import math

import numpy as np

from mjbench.papers import drivetrain_study as DT
from mjbench import frest
from mjbench import scenario as S
from mjbench import plotstyle as ps
from mjbench.plots import save

SETTINGS = {"backend": "reduced", "n_lines": 12, "periods": 2, "settle": 1.0}
NO_LIMIT = ["drive.v_max=inf", "modes.pid.v_limit=none"]
#: scenario → [(label, mode, overrides)]
VARIANTS = {
    "incerti2012": [("ideal drive", "pid", DT.ideal("incerti2012")),
                    ("ideal drive, no ±48 V limit", "pid", DT.ideal("incerti2012") + NO_LIMIT),
                    ("realistic drive (M/T)", "pid", DT.realistic("incerti2012", "mt"))],
    "yigit2023": [("SMC, ideal drive", "smc", DT.ideal("yigit2023")),
                  ("SMC, realistic drive (M/T)", "smc", DT.realistic("yigit2023", "mt")),
                  ("PID, ideal drive", "pid", DT.ideal("yigit2023")),
                  ("PID, realistic drive (M/T)", "pid", DT.realistic("yigit2023", "mt"))],
}


def measure(name) -> dict:
    """{label: frest.measure result} for every variant of ``name`` (:data:`SETTINGS`)."""

    return {label: frest.measure(S.load(name, ov), mode, **SETTINGS) for label, mode, ov in VARIANTS[name]}


def _results(ctx, name) -> dict:
    if "frest" not in ctx.extra:
        ctx.extra["frest"] = measure(name)
    return ctx.extra["frest"]


def _finite(x):
    return x is not None and isinstance(x, (int, float)) and math.isfinite(x)


def _pick(res, fn, coherent_only=False) -> dict:
    """{label: fn(json)} over the variants (``coherent_only``: the linear ones), finite values only."""
    out = {}
    for label, r in res.items():
        if coherent_only and not _coherent(r["json"]):
            continue
        v = fn(r["json"])
        if _finite(v):
            out[label] = float(v)
    return out


def _cmp(key, field="max_rel_diff", scale=100.0):
    def f(js):
        c = js["comparison"].get(key) or {}
        return None if c.get(field) is None else scale * c[field]
    return f


def _margin(key, which="margins"):
    def f(js):
        lp = js.get("loop") or {}
        return (lp.get(which) or {}).get(key)
    return f


def _fmt(v, f="{:.3g}"):
    return "∞" if v is not None and v == math.inf else ("—" if not _finite(v) else f.format(v))


def _linear_margins(js) -> str:
    """The linearisation's margins of a variant's mode: exact, and read on the measured lines."""
    lp = js.get("loop") or {}
    m, mo = lp.get("margins_linear") or {}, lp.get("margins_linear_on_lines") or {}
    if not m:
        return ""
    return (f"{js['controller'].upper()} linear: PM {_fmt(m.get('phase_margin_deg'))}°, GM {_fmt(m.get('gain_margin_dB'))} dB, "
            f"peak |S| {_fmt(m.get('peak_sensitivity'))} (read on the same lines: {_fmt(mo.get('phase_margin_deg'))}°, "
            f"{_fmt(mo.get('gain_margin_dB'))} dB, {_fmt(mo.get('peak_sensitivity'))})")


COHERENT = 0.9  #: min γ² of a response read as linear


def _coherent(js) -> bool:
    return js["limiter_active_fraction"] <= 0.05 and min(js["plant"]["coherence"]) >= COHERENT


def reading(js) -> str:
    """One sentence on what a variant's measurement shows, from its numbers."""
    lim, coh = js["limiter_active_fraction"], min(js["plant"]["coherence"])
    lp = js.get("loop") or {}
    coh_loop = min(lp["coherence"]) if lp.get("coherence") else None
    c = js["comparison"]
    if lim > 0.05:
        return (f"saturated: at the ±{js['voltage_limit_V']:g} V limit {100 * lim:.0f} % of the time, γ² ≥ {coh:.2f} — "
                "no linear response (a describing function)")
    m, mo = lp.get("margins") or {}, lp.get("margins_linear_on_lines") or {}
    loop_txt = (f"measured loop GM {_fmt(m.get('gain_margin_dB'))} dB, PM {_fmt(m.get('phase_margin_deg'))}° (linearisation "
                f"read on the same lines: {_fmt(mo.get('gain_margin_dB'))} dB, {_fmt(mo.get('phase_margin_deg'))}°)" if m else "")
    if coh < COHERENT:
        if coh_loop is not None and coh_loop >= COHERENT:
            return (f"the loop is linear (γ² of ΔV ≥ {coh_loop:.2f}; {loop_txt}, {100 * c['loop']['max_rel_diff']:.3g} % "
                    f"from the linearisation), the crank speed is not (γ² ≥ {coh:.2f}, distortion "
                    f"{js['distortion_ratio']:.2g}): behind the gear it is not driven by the excitation alone")
        return (f"not coherent (γ² ≥ {coh:.2f}, distortion {js['distortion_ratio']:.2g}): part of the response is not "
                "driven by the excitation (switching, quantisation, backlash impacts)")
    txt = f"linear (γ² ≥ {coh:.3f})"
    if c.get("plant_vs_family_along_turn"):
        txt += (f": plant {100 * c['plant_vs_family_along_turn']['max_rel_diff']:.2g} % from the frozen family along the "
                f"turn, {100 * c['plant']['max_rel_diff']:.3g} % from the linearisation at q*")
    elif c.get("plant"):
        txt += f": plant {100 * c['plant']['max_rel_diff']:.2g} % from the linearisation"
    return txt + (f"; {loop_txt}" if loop_txt else "")


def report_rows(ctx, name) -> list:
    """Rows of a ``*-realdrive`` case: what the frequency-response measurement of the running machine
    shows on each variant, and why it departs from the linearisation."""
    res = _results(ctx, name)
    js0 = next(iter(res.values()))["json"]
    op = js0["operating_point"]
    where = (f"held at q* = {op['q_rad']:.3g} rad, {op['qd_rad_s']:.3g} rad/s" +
             (f", K_p·t frozen at t = {op['t_s']:g} s" if name == "incerti2012" else ""))
    lin_txt = "; ".join(dict.fromkeys(_linear_margins(r["json"]) for r in res.values() if _linear_margins(r["json"])))
    band = {lab: r["json"]["band_rad_s"] for lab, r in res.items()}
    band_txt = "; ".join(sorted({f"{b[0]:.3g}–{b[1]:.3g} rad/s" for b in band.values()}))
    side_pred = _pick(res, lambda js: 100 * ((js.get("frozen_family") or {}).get("sidebands") or {}).get(
        "speed_frozen_max_rel", math.nan), coherent_only=True)
    pre = "[FRF] "
    rows = [
        (pre + "time on the ±48 V limit while measured", "%", _pick(res, lambda js: 100 * js["limiter_active_fraction"]),
         "the controller's output clipped at ±48 V (the anti-windup limiter; on the realistic drive also the 48 V PWM "
         "bus): a clipped loop has no linear response, what is measured is a describing function"),
        (pre + "min coherence γ² of the response with the excitation", "1", _pick(res, lambda js: min(js["plant"]["coherence"])),
         "γ² = 1: the same response in every period (a linear, time-invariant or periodically time-varying machine); "
         "< 1: part of the response is not driven by the excitation (limiter, sliding-mode switching, encoder "
         "quantisation, PWM ripple, backlash impacts)"),
        (pre + "plant q̇/V: max |measured − linearisation at q*| / |linearisation| over the frozen band", "%",
         _pick(res, _cmp("plant")),
         f"linearisation of the ideal drive {where} (mjbench linearize); frozen band {band_txt} (above 10 × the inertia "
         "variation rate); a running linkage is periodically time-varying, so its response is the frozen-angle family "
         "averaged along the turn, not the operating angle's"),
        (pre + "plant q̇/V: max |measured − frozen-angle family along the turn| / |…| over the frozen band", "%",
         _pick(res, _cmp("plant_vs_family_along_turn"), coherent_only=True),
         "the frozen-angle loops followed along the machine's own turn, ⟨P·S⟩/⟨S⟩ over one period: what a coherent "
         f"measurement of the running linkage equals where the frozen picture holds (variants with γ² ≥ {COHERENT:g} "
         "and off the limit; no linear family for the SMC)"),
        (pre + "loop L at the plant input: max |measured − linearisation| / |linearisation| over the frozen band", "%",
         _pick(res, _cmp("loop")), "L = 1/S − 1 with S = ΔV/d measured (d added to the controller output)"),
        (pre + "speed response at ω ± Ω (Ω the turn frequency), relative to the line's own, max over the band", "%",
         _pick(res, lambda js: 100 * ((js.get("frozen_family") or {}).get("sidebands") or {}).get(
             "speed_measured_max_rel", math.nan), coherent_only=True),
         "the rotation sidebands that make the running linkage periodically time-varying; the frozen family along the "
         "turn predicts " + ("; ".join(f"{k}: {v:.3g} %" for k, v in side_pred.items()) or "—")),
        (pre + "measured loop: phase margin", "deg", _pick(res, _margin("phase_margin_deg")),
         f"read from the measured loop (crossings interpolated between lines); linearisation: {lin_txt or '—'}"),
        (pre + "measured loop: gain margin", "dB", _pick(res, _margin("gain_margin_dB")),
         "read from the measured loop; a variant without a −180° crossing inside the band has none (∞, not shown); "
         "what each element of the realistic drive does alone: docs/bridges.md §3"),
        (pre + "measured loop: peak |S| on the lines", "1", _pick(res, _margin("peak_sensitivity")),
         "max |ΔV/d| over the excited lines (a lower bound of the true peak)"),
    ]
    return [{"name": n, "unit": u, "paper": None, "ours": ours, "reason": why} for n, u, ours, why in rows if ours]


def report_table(ctx, name) -> dict:
    """One row per variant: lines, band, settings and the headline figures (ctx.tables)."""
    res = _results(ctx, name)
    rows = []
    for lab, r in res.items():
        js = r["json"]
        lp = js.get("loop") or {}
        m, ml = lp.get("margins") or {}, lp.get("margins_linear") or {}
        c = js["comparison"]
        rows.append([lab, js["mode"], len(js["lines_rad_s"]), f"{js['band_rad_s'][0]:.3g}–{js['band_rad_s'][1]:.3g}",
                     f"{js['period_s']:.3g} s × {js['periods']}", 100 * js["limiter_active_fraction"],
                     min(js["plant"]["coherence"]), _fmt(100 * c["plant"]["max_rel_diff"] if c.get("plant") else None),
                     _fmt(100 * c["plant_vs_family_along_turn"]["max_rel_diff"]
                          if c.get("plant_vs_family_along_turn") else None),
                     f"{_fmt(m.get('phase_margin_deg'))}° / {_fmt(m.get('gain_margin_dB'))} dB",
                     f"{_fmt(ml.get('phase_margin_deg'))}° / {_fmt(ml.get('gain_margin_dB'))} dB" if ml else "—"])
    return {"title": f"{name}: frequency response of the running machine (mjbench frest, reduced backend, "
                     f"{SETTINGS['n_lines']} lines requested, {SETTINGS['periods']} periods)",
            "head": ["variant", "mode", "lines", "frozen band [rad/s]", "period", "on the limit [%]", "min γ²",
                     "plant vs linear [%]", "plant vs family along the turn [%]", "PM / GM measured", "linear"],
            "rows": rows,
            "note": "Reading: " + "; ".join(f"{lab}: {reading(r['json'])}" for lab, r in res.items()) + ". "
                    "The lines avoid each other's rotation sidebands (docs/bridges.md §3). Frozen band: where the "
                    "frozen-angle picture holds (above 10 × max|J'·q̇|/J_tot)."}


def report_figure(ctx, name):
    """Bode magnitude of the measured plant and loop of every variant, with the linearisation (line)
    and the frozen-angle family along the turn (dashed)."""

    res = _results(ctx, name)
    fig, ax = ps.new(1, 2, figsize=(12, 4.6))
    for i, (lab, r) in enumerate(res.items()):
        col = f"C{i}"
        w = r["omega"]
        ax[0].loglog(w, np.abs(r["P"]), "o", ms=3.5, color=col, label=f"{lab} (γ² ≥ {min(r['coherence']):.2f})")
        if r["L"] is not None:
            ax[1].loglog(w, np.abs(r["L"]), "o", ms=3.5, color=col, label=lab)
        fam = r.get("family")
        if fam is not None:
            ax[0].loglog(w, np.abs(fam["along_turn"]["P"]), "--", lw=1, color=col)
            ax[1].loglog(w, np.abs(fam["along_turn"]["L"]), "--", lw=1, color=col)
    plant_drawn, loops_drawn = False, set()
    for r in res.values():  # the linearisation of the ideal drive: one plant, one loop per mode
        if r["P_lin"] is not None and not plant_drawn:
            ax[0].loglog(r["omega"], np.abs(r["P_lin"]), "-", lw=1, color="k", alpha=0.6, label="linearisation at q*")
            plant_drawn = True
        mode = r["json"]["mode"]
        if r["L_lin"] is not None and mode not in loops_drawn:
            ax[1].loglog(r["omega"], np.abs(r["L_lin"]), "-", lw=1, color="k", alpha=0.6, label=f"linearisation ({mode})")
            loops_drawn.add(mode)
    ax[0].set_title("plant q̇/V: measured (dots), frozen family along the turn (dashed)", fontsize=9)
    ax[1].set_title("loop |L| at the plant input", fontsize=9)
    for a in ax:
        a.set_xlabel(ps.label("ω", "rad/s"))
    ax[0].legend(fontsize=7)
    ax[1].legend(fontsize=7)
    ps.finish(fig, f"{name}: frequency response of the running machine, ideal vs realistic drive (mjbench frest)")
    return save(fig, ctx.out / "frest_bode.png")
