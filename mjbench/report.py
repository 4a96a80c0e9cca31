"""The reproduction report: ``report.md`` and ``report.html`` from the case results of
:func:`mjbench.reproduce.reproduce` (docs/show_it.md).

The page a newcomer opens first leads with pictures:

* at the top, a summary read at a glance: one line per case with a bar of its verdicts (meet /
  fitted / differ / no paper figure, to scale) and the counts, grouped by paper, and the totals;
* per case: the **headline figure** (the first figure the paper module lists) and the **video**,
  next to the **headline numbers** (:func:`headline`: at most :data:`HEADLINE_MAX` rows with their
  verdicts), then the other figures as a row of thumbnails (each a link to the full image);
* folded (``<details>``): the full table of every row (quantity, unit, paper, ours, verdict,
  reason), each extra table, and the notes on how to read the page.

Nothing is dropped: every row, table, figure, warning and note of a case is on the page, and
every number is :func:`mjbench.verdicts.fmt` of the number stored in the case's
``metrics.json``.  report.md mirrors the page (GitHub-flavoured markdown: ``<details>`` and
``<img width>`` are HTML it renders).
"""
from __future__ import annotations

import html
import os
import re
import time
from pathlib import Path

from . import verdicts as V
from .trajectory import atomic_write
from .metrics import LIMIT_FRACTION_WARN

fmt = V.fmt
HEADLINE_MAX = 5  #: headline numbers shown per case before its figures' thumbnails (3-5; fewer if the case has fewer)
MAX_OURS_COLUMNS = 3  #: more distinct labels of ours in a table: one "ours" column of "label: value" items

GLOSSARY = [
    ("Incerti 2012", "G. Incerti, four-bar linkage driven by a DC motor under a PID with the time-varying "
                     "gain K_p·t (scenarios incerti2012, incerti2012-calibrated)."),
    ("Incerti belt / Incerti Bezier", "G. Incerti's two motion-law studies on elastic rotary platforms: the "
                                      "belt-driven platform with pseudo-polynomial laws (incerti-belt) and the "
                                      "elastic-joint platform with Bezier laws (incerti-bezier)."),
    ("Hülako & Çakar 2025", "four-bar whose coupler point C moves at a constant speed V_C under a crank-speed "
                            "PID (hulako2025-model1, -model2)."),
    ("Yiğit & Şen 2023", "quick-return mechanism: optimum design (Eqs 1-2, Table I) and sliding-mode speed "
                         "control (yigit2023)."),
    ("multibody", "the MuJoCo model of the mechanism (joints, bodies, loop-closure constraints), stepped by "
                  "MuJoCo."),
    ("reduced", "the same machine written as one equation of motion in the crank angle α: "
                "J(α)·α̈ + ½J′(α)·α̇² + dE_p/dα = torque (Eksergian's form), integrated by RK4; the two "
                "backends share the drive and the controller, so their difference is the mechanics alone."),
    ("J(α)", "reduced (generalised) inertia of the mechanism seen at the crank [kg·m²]; it varies with the "
             "crank angle α."),
    ("χ", "speed fluctuation of Incerti 2012 Eq 22: (φ̇_max − φ̇_min)/φ̇_average of the motor speed over a "
          "crank cycle or a time window, in percent, from the recorded samples (their interval is "
          "chi_sampling_s in metrics.json: a coarser record misses the extremes and gives a smaller χ)."),
    ("last cycle from α(0)", "the last complete crank cycle counted from the initial angle α(0): it may end up "
                             "to one period before the end of the run."),
    ("last 2π to t_end", "the last 2π of crank travel, ending at the end of the run."),
    ("V_C, V_des", "speed of the coupler point C [m/s], and the speed the reference asks for."),
    ("E(T)", "residual vibration energy of the platform when the motor stops at the end T of the move [J]."),
    ("ψ", "deflection of the elastic transmission (platform side) [rad]."),
    ("residual envelope at T", "amplitude of the free vibration that starts at T from the state at T "
                               "(√(ψ² + ((ψ̇ + ξω_nψ)/ω_d)²)): an envelope, not a measured peak."),
    ("peak |ψ| over [T, T+2 s]", "the largest deflection actually reached in the 2 s after the move."),
    ("ideal servo / DC motor + servo", "the motor follows the law exactly (the papers' assumption) / a DC "
                                       "motor under a cascade position servo tracks the law (our machine)."),
    ("Ts", "control sampling period of the sliding-mode controller (Yiğit & Şen give none)."),
    ("requirement / prediction (design cases)", "`mjbench design` cases have no paper: the 'paper' column holds "
                                                "the requirement (a bound or a target) or the sizing model's "
                                                "prediction, checked against the multibody run (docs/design.md)."),
    ("headline numbers", f"the up to {HEADLINE_MAX} rows shown next to a case's first figure: the rows its paper "
                         "module marks as headline, then those with a paper figure, then the others, in table "
                         "order; the folded full table below them holds every row."),
    ("verdict", f"computed from the numbers: a point value agrees when |ours − paper| ≤ {100 * V.TOLERANCE:g} % "
                "of the paper's value (else 'differs', signed); a band [lo, hi] is 'inside', 'below by X' or "
                "'above by X'; an upper bound is 'met' or 'exceeded by X'. 'fitted': a figure our parameters "
                "were fitted to (agreement by construction, not a prediction)."),
    ("reason", "why ours differs, or what the figure depends on: stated by the paper module or the "
               "scenario file; it never states the verdict."),
]

LEAD = ("Every case below was run end to end by `mjbench reproduce`: the machine simulated on MuJoCo (multibody) "
        "and on its reduced J(α) model, figures in the papers' style, a real-time video.  Each case is judged "
        "first as a machine — **engineering verdicts**: the drive's voltage and current limits respected, the "
        "duty within the motor's rating, the two backends and the reduced model agreeing, the χ or "
        "tracking bound met — and, beside them, each number the paper states set against ours with a "
        "**verdict computed from the two numbers**.")

INTRO = ("Each case opens with its headline figure, its video and its headline numbers; the full table below "
         "them (folded) lists, for every quantity, the paper's figure (a value, a band lo–hi, or a bound ≤ / ≥), "
         "ours (one column per simulator backend where both ran), the **verdict computed from these numbers** "
         "and the reason where ours differs.  A point value "
         f"agrees when it is within ±{100 * V.TOLERANCE:g} % of the paper's; a band or a bound is met or "
         "missed by the amount shown.  'meet the paper' counts the rows that agree, lie inside the band or "
         "meet the bound, out of the rows with a paper figure.  Words and symbols: see the glossary at the end.")

SUMMARY_HEAD = ["case", "paper", "verdicts", "rows", "meet the paper", "differ", "no paper figure", "runtime [s]",
                "CPU [s]"]
#: verdict classes in the order the summary bar draws them: (key in verdicts.counts, legend text)
BAR = (("meet", "meet the paper"), ("fitted", "fitted (agree by construction)"), ("differ", "differ"),
       ("unjudged", "no paper figure"))
#: the bar in markdown: one square per tenth of a case's rows
MD_SQUARE = {"meet": "🟩", "fitted": "🟦", "differ": "🟧", "unjudged": "⬜"}


# ============================================================================ engineering verdicts
#: the engineering checks every case gets, in the order the page shows them: (key, column title)
CHECKS = (("limits", "limits respected"), ("duty", "duty within rating"), ("models", "backends and model agree"),
          ("bound", "χ / tracking bound"))
#: design requirement rows (by the start of their name, after "requirement: ") that make each check
DESIGN_ROWS = {"limits": ("armature voltage ≤ supply", "current ≤ amplifier limit", "motor speed ≤ maximum",
                          "gearbox input speed ≤ maximum"),
               "duty": ("RMS motor torque ≤ continuous rating", "peak motor torque ≤ T_peak", "winding temperature",
                        "gearbox output torque"),
               "bound": ("speed fluctuation χ", "RMS tracking error", "peak tracking error",
                         "largest speed deviation")}


def _check(ok, text, detail=""):
    return {"ok": ok, "text": text, "detail": detail}


def engineering(r) -> dict:
    """The engineering verdicts of a case, {key of :data:`CHECKS`: {ok (True, False or None: not
    applicable / not stated), text, detail}}, from the numbers its metrics.json holds: for a run,
    the duty figures of every mode and backend (limits: the voltage and current limits active over
    at most 1 % of the steady state; duty: the steady-state RMS current within the motor's
    ``drive.i_rated``), the plausibility checks (the two backends' crank speeds and the reduced
    model against MuJoCo's mass matrix), and the rows that are bounds on χ or on a tracking error;
    for a design case, its requirement rows (supply and current limit, motor and gearbox ratings
    and temperature, χ or tracking error) and the sizing model's predictions against the multibody
    run."""
    modes = r.get("modes") or {}
    rows = r.get("rows") or []
    if r.get("kind") == "design":
        return _design_checks(rows)
    out = {}
    # limits
    hits, limits = [], 0
    for mode, m in modes.items():
        for b, bm in (m.get("backends") or {}).items():
            for key, what, unit in (("voltage_limit_fraction_steady", "voltage_limit_V", "V"),
                                    ("current_limit_fraction_steady", "current_limit_A", "A")):
                if key in (bm or {}):
                    limits += 1
                    if bm[key] > LIMIT_FRACTION_WARN:
                        hits.append(f"{mode}/{b}: at {bm[what]:g} {unit} {100 * bm[key]:.1f} % of the steady state")
    if not modes:
        out["limits"] = _check(None, "—", "no simulation run in this case")
    elif hits:
        out["limits"] = _check(False, "at a limit", "; ".join(hits))
    elif limits:
        out["limits"] = _check(True, "respected", f"every limit active ≤ {100 * LIMIT_FRACTION_WARN:g} % of the steady state")
    else:
        out["limits"] = _check(None, "no limit set", "no voltage or current limit in the scenario")
    # duty against the motor's rating
    rms = [(mode, b, bm) for mode, m in modes.items() for b, bm in (m.get("backends") or {}).items()
           if "current_rms_steady_A" in (bm or {})]
    rated = [x for x in rms if "current_rated_A" in x[2]]
    worst = max(rms, key=lambda x: x[2]["current_rms_steady_A"], default=None)
    if rated:
        over = [x for x in rated if x[2]["current_rms_steady_A"] > x[2]["current_rated_A"]]
        w = max(rated, key=lambda x: x[2]["current_rms_steady_A"] / x[2]["current_rated_A"])
        txt = f"RMS {w[2]['current_rms_steady_A']:.3g} A of {w[2]['current_rated_A']:g} A rated ({w[0]}/{w[1]})"
        out["duty"] = _check(not over, "within rating" if not over else "over rating", txt)
    elif worst is not None:
        out["duty"] = _check(None, "no rating stated", f"RMS current {worst[2]['current_rms_steady_A']:.3g} A, peak "
                                                       f"{worst[2]['current_peak_steady_A']:.3g} A ({worst[0]}/{worst[1]}); "
                                                       f"drive.i_rated not given")
    else:
        out["duty"] = _check(None, "—", "no motor current (ideal drive or no run)")
    # the two backends and the reduced model against MuJoCo's
    agree, disagree, notes = 0, [], []
    for mode, m in modes.items():
        p = m.get("plausibility") or {}
        if "backends_agree" in p:
            if p["backends_agree"]:
                agree += 1
                notes.append(f"{mode}: {p['max_rel_diff']:.2g} of the peak")
            else:
                disagree.append(f"{mode}: backends differ by {p['max_rel_diff']:.3g} of the peak")
        mod = p.get("model") or {}
        if mod.get("models_agree") is False:
            disagree.append(f"{mode}: reduced model ≠ MuJoCo's")
        elif mod.get("models_agree"):
            agree += 1
    if disagree:
        out["models"] = _check(False, "disagree", "; ".join(disagree))
    elif agree:
        out["models"] = _check(True, "agree", "multibody vs reduced crank speed " + ", ".join(notes)
                               if notes else "reduced model = MuJoCo's")
    else:
        out["models"] = _check(None, "—", "one backend ran")
    out["bound"] = _bound_check([x for x in rows if _is_bound(x["name"])])
    return out


def _is_bound(name: str) -> bool:
    n = name.lower()
    return any(k in n for k in ("χ", "chi", "tracking", "coupler", "residual", "deviation"))


def _bound_check(rows) -> dict:
    """A check from rows that are bounds (compare max/min) with a verdict."""
    judged = [x for x in rows if x.get("compare") in ("max", "min") and (x.get("verdict") or {}).get("ok") is not None]
    if not judged:
        return _check(None, "none stated", "no bound on χ or a tracking error for this case (the paper's figures are "
                                            "compared beside)")
    bad = [x for x in judged if not x["verdict"]["ok"]]
    detail = "; ".join(f"{x['name']}: {x['verdict']['text']}" for x in (bad or judged)[:3])
    return _check(not bad, "met" if not bad else "missed", detail)


def _design_checks(rows) -> dict:
    out = {}
    req = [x for x in rows if x["name"].startswith("requirement: ")]
    for key in ("limits", "duty"):
        mine = [x for x in req if x["name"][len("requirement: "):].startswith(DESIGN_ROWS[key])
                and (x.get("verdict") or {}).get("ok") is not None]
        if not mine:
            out[key] = _check(None, "—", "not a requirement of this design")
            continue
        bad = [x for x in mine if not x["verdict"]["ok"]]
        out[key] = _check(not bad, ("respected" if key == "limits" else "within rating") if not bad
                          else ("exceeded" if key == "limits" else "over rating"),
                          f"{len(mine) - len(bad)}/{len(mine)} requirements met"
                          + ("; " + "; ".join(x["name"][13:] for x in bad) if bad else ""))
    pred = [x for x in rows if x["name"].startswith("prediction: ") and (x.get("verdict") or {}).get("ok") is not None]
    if pred:
        bad = [x for x in pred if not x["verdict"]["ok"]]
        out["models"] = _check(not bad, "agree" if not bad else "disagree",
                               f"sizing model vs multibody run: {len(pred) - len(bad)}/{len(pred)} predictions agree")
    else:
        out["models"] = _check(None, "—", "no prediction checked")
    bound = [x for x in req if x["name"][len("requirement: "):].startswith(DESIGN_ROWS["bound"])]
    out["bound"] = _bound_check(bound)
    return out


def _engineering_of(r) -> dict:
    return r.get("engineering") or engineering(r)


def _eng_counts(results) -> dict:
    n = {"ok": 0, "fail": 0, "na": 0}
    for r in results:
        for c in _engineering_of(r).values():
            n["ok" if c["ok"] else "fail" if c["ok"] is False else "na"] += 1
    return n


# ============================================================================ selection
def headline(rows, n: int = HEADLINE_MAX) -> list:
    """Indices (in table order) of a case's headline rows, at most ``n``: the rows a paper module
    marks ``"headline": True``, then the rows with a paper figure, then the others."""

    def rank(i):
        r = rows[i]
        judged = (r.get("verdict") or {}).get("ok") is not None
        return (0 if r.get("headline") else 1 if judged else 2, i)

    return sorted(sorted(range(len(rows)), key=rank)[:n])


def _headline_of(r) -> list:
    h = r.get("headline")
    return list(h) if h is not None else headline(r["rows"])


def _counts(r):
    return r.get("counts") or V.counts(r["rows"])


def _count_text(c):
    judged = c["meet"] + c["differ"] + c["fitted"]
    if not judged:
        return "—"
    txt = f"{c['meet'] + c['fitted']}/{judged}"
    return txt + (f" ({c['fitted']} fitted)" if c["fitted"] else "")


def _summary_cells(r):
    """The summary columns of a case, as text (the "verdicts" column: the markdown bar)."""
    c = _counts(r)
    return [r["case"], r.get("citation") or r.get("paper") or "", _bar_md(c), str(len(r["rows"])),
            _count_text(c), str(c["differ"]), str(c["unjudged"]), f"{r['runtime_s']:.1f}",
            f"{r['cpu_s']:.1f}" if r.get("cpu_s") is not None else "—"]


def _bar_text(c) -> str:
    """The verdict bar in words (the HTML bar's tooltip)."""
    return ", ".join(f"{c[k]} {t.split(' (')[0]}" for k, t in BAR if c[k]) or "no rows"


def _bar_md(c, width=10) -> str:
    """The verdict bar as ``width`` squares (largest remainders; a class with rows gets one at least)."""
    n = sum(c[k] for k, _ in BAR)
    if not n:
        return "—"
    share = {k: width * c[k] / n for k, _ in BAR}
    cells = {k: max(1, int(share[k])) if c[k] else 0 for k, _ in BAR}
    while sum(cells.values()) > width:  # the minimum of one square pushed it over: trim another class
        k = max((j for j in cells if cells[j] > 1), key=lambda j: cells[j] - share[j])
        cells[k] -= 1
    while sum(cells.values()) < width:
        k = max((j for j in cells if c[j]), key=lambda j: share[j] - cells[j])
        cells[k] += 1
    return "".join(MD_SQUARE[k] * cells[k] for k, _ in BAR)


def _totals(results) -> dict:
    tot = {k: 0 for k, _ in BAR}
    for r in results:
        for k, v in _counts(r).items():
            tot[k] += v
    tot["cases"] = len(results)
    tot["videos"] = sum(1 for r in results if r.get("video"))
    tot["figures"] = sum(len(r["figures"]) for r in results)
    return tot


def _eng_totals_text(results) -> str:
    n = _eng_counts(results)
    return (f"Engineering verdicts: {n['ok']} met, {n['fail']} not met, {n['na']} not applicable or not stated "
            f"({len(CHECKS)} checks per case).")


def _eng_cell_text(c) -> str:
    return ("✓ " if c["ok"] else "✗ " if c["ok"] is False else "") + c["text"]


def _eng_class(c) -> str:
    return "meet" if c["ok"] else "differ" if c["ok"] is False else "unjudged"


def _totals_text(results) -> str:
    t = _totals(results)
    judged = t["meet"] + t["fitted"] + t["differ"]
    return (f"{t['cases']} cases, {t['figures']} figures, {t['videos']} videos. Of the {judged} numbers with a paper "
            f"figure, {t['meet']} meet the paper, {t['differ']} differ (each with its reason)"
            + (f" and {t['fitted']} were fitted to it" if t["fitted"] else "")
            + f"; {t['unjudged']} more are computed with no paper figure to compare.")


# ============================================================================ tables
def _labels(rows):
    labs = []
    for r in rows:
        for k in r["ours"]:
            if k not in labs:
                labs.append(k)
    return labs


def ours_columns(rows) -> list | None:
    """The labels of ours shown as columns, or None when they are folded into one column."""
    labs = _labels(rows)
    return labs if len(labs) <= MAX_OURS_COLUMNS else None


def _ours_head(b):
    return "ours" if b == "ours" else f"ours: {b}"


def _ours_text(ours: dict) -> str:
    return "; ".join(fmt(v) if k == "ours" else f"{k}: {fmt(v)}" for k, v in ours.items())


def table_rows(rows, reason=True):
    """Header and cells of a verdict table (every number printed with :func:`fmt`); without the
    reason column for the headline numbers."""
    labs = ours_columns(rows)
    head = ["quantity", "unit", "paper"] + ([_ours_head(b) for b in labs] if labs is not None else ["ours"]) \
        + ["verdict"] + (["reason"] if reason else [])
    body = []
    for row in rows:
        ours = [fmt(row["ours"].get(b)) for b in labs] if labs is not None else [_ours_text(row["ours"])]
        body.append([row["name"], row.get("unit", ""), row.get("paper_text") or fmt(row["paper"])] + ours
                    + [row["verdict"]["text"]] + ([row.get("reason", "") or "—"] if reason else []))
    return head, body


def _full_summary(r) -> str:
    """The line that unfolds a case's full table."""
    c = _counts(r)
    judged = c["meet"] + c["fitted"] + c["differ"]
    what = (f"{judged} with a paper figure ({_count_text(c)} meet it), {c['unjudged']} computed without one"
            if judged else "none with a paper figure to compare")
    return f"All {len(r['rows'])} rows: {what} — quantity, paper, ours, verdict, reason"


def _case_intro(r):
    return [f"Paper: **{r.get('citation') or r.get('paper')}**"
            + (f", “{r['paper_title']}”" if r.get("paper_title") else "") + ".",
            f"Scenario `{r['scenario']}` — {r.get('scenario_title', '')}."]


def _video_caption(v) -> str:
    txt = (f"mode {v['mode']}, {v['frames']} frames {v['width']}×{v['height']} at 30 fps "
           f"(real time, {v['duration_s']:.2f} s)" + (f", from {v['source']}" if v.get("source") else "")
           + (f"; still image: the frame at t = {v['poster_t_s']:.2f} s" if v.get("poster") else "")
           + ("" if v.get("needle_gain") else
              "; overlay: speeds, voltage V, current I, drive torque T on the crank and the process loads"))
    if v.get("needle_gain"):
        g = f"{v['needle_gain']:g}"
        txt += (f"; top view of the platform, grey needle: rigid-transmission angle ρ·φ, magenta needle: "
                f"ρ·φ + {g}·ψ (the deflection ψ magnified ×{g})")
    return txt


def _no_video(r) -> str | None:
    if r.get("video"):
        return None
    if r.get("video_error"):
        return f"No video: {r['video_error']}"
    if r["kind"] == "optimize-law":
        return "No video: a motion-law case (`mjbench optimize-law`), evaluated on the platform model."
    return None


def _groups(results):
    """Cases grouped by paper, in report order: [(citation, [results])]."""
    out = []
    for r in results:
        key = r.get("citation") or r.get("paper") or ""
        if out and out[-1][0] == key:
            out[-1][1].append(r)
        else:
            out.append((key, [r]))
    return out


def _anchor(name):
    return "case-" + "".join(c if c.isalnum() else "-" for c in name.lower())


# ============================================================================ markdown
def _md_cell(x):
    return str(x).replace("|", "\\|").replace("\n", " ")


def _md_table(head, body):
    out = ["| " + " | ".join(_md_cell(h) for h in head) + " |", "|" + "---|" * len(head)]
    for b in body:
        out.append("| " + " | ".join(_md_cell(x) for x in b) + " |")
    return out


def _md_details(summary, lines):
    return [f"<details><summary>{html.escape(summary)}</summary>", ""] + lines + ["</details>", ""]


def _md_engineering(results):
    head = ["case"] + [t for _, t in CHECKS]
    md = ["**Engineering verdicts** (the machine: limits, duty, models, bound; hover a cell in report.html for "
          "the numbers):", "", _eng_totals_text(results), "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        e = _engineering_of(r)
        md.append("| " + " | ".join([f"[{r['case']}](#{_anchor(r['case'])})"]
                                    + [_md_cell(_eng_cell_text(e[k])) for k, _ in CHECKS]) + " |")
    return md + [""]


def _md_summary(results):
    legend = "Verdicts of each case's rows, one square per tenth: " + ", ".join(
        f"{MD_SQUARE[k]} {t}" for k, t in BAR) + "."
    md = _md_engineering(results)
    md += ["**Paper comparison:**", "", _totals_text(results), "", legend, "", "| " + " | ".join(SUMMARY_HEAD) + " |",
           "|" + "---|" * len(SUMMARY_HEAD)]
    for r in results:
        cells = _summary_cells(r)
        cells[0] = f"[{r['case']}](#{_anchor(r['case'])})"
        md.append("| " + " | ".join(_md_cell(c) for c in cells) + " |")
    return md + [""]


def _case_md(r):
    case = r["case"]
    md = [f'<a id="{_anchor(case)}"></a>', f"## {case}: {r['title']}", ""]
    md += _case_intro(r)
    if r.get("overrides"):
        md.append(f"Overrides: `{' '.join(r['overrides'])}`.")
    if r.get("note"):
        md.append(r["note"])
    md += [f"Files: [`{case}/metrics.json`]({case}/metrics.json).", ""]
    eng = _engineering_of(r)
    md += ["**Engineering verdicts:**", ""] + _md_table(["check", "verdict", "numbers"],
                                                      [[t, _eng_cell_text(eng[k]), eng[k]["detail"]] for k, t in CHECKS])
    md += [""]
    for w in r.get("warnings") or []:
        md += [f"> **Warning:** {w}", ""]
    figs = list(r["figures"])
    if figs:
        md += [f"[![{figs[0]}]({case}/{figs[0]})]({case}/{figs[0]})", ""]
    v = r.get("video")
    if v:
        poster = f' poster="{case}/{v["poster"]}"' if v.get("poster") else ""
        md += [f'<video src="{case}/{v["file"]}"{poster} controls muted loop width="{v["width"]}"></video>', "",
               f"Video: [`{case}/{v['file']}`]({case}/{v['file']}) — {_video_caption(v)}.", ""]
    elif _no_video(r):
        md += [_no_video(r), ""]
    idx = _headline_of(r)
    if idx:
        head, body = table_rows([r["rows"][i] for i in idx], reason=False)
        md += [f"**Paper comparison, headline numbers** ({len(idx)} of {len(r['rows'])} rows; every row in the table "
               f"below):", ""]
        md += _md_table(head, body) + [""]
    if figs[1:]:
        md += ["More figures (click for full size):", ""]
        md += [" ".join(f'<a href="{case}/{f}"><img src="{case}/{f}" alt="{f}" width="32%"></a>' for f in figs[1:]), ""]
    if r["rows"]:
        md += _md_details(_full_summary(r), _md_table(*table_rows(r["rows"])) + [""])
    for t in r.get("tables") or []:
        body = _md_table(t["head"], t["rows"]) + [""] + ([t["note"], ""] if t.get("note") else [])
        md += _md_details(f"Table: {t.get('title') or 'more numbers'} ({len(t['rows'])} rows)", body)
    return md


def _markdown(results, total_s):
    md = ["# mjbench — reproduction report", "", LEAD, "",
          "Below: every case's verdicts at a glance, then the cases one by one; words and symbols: "
          "[glossary](#glossary).", ""]
    if total_s is not None:
        md += [f"Total runtime: {total_s:.0f} s.", ""]
    md += _md_summary(results)
    md += _md_details("How to read this report", [INTRO, "", f"Environment: {_env_text()}.", ""])
    for r in results:
        md += _case_md(r)
    md += ['<a id="glossary"></a>', "## Glossary", ""] + [f"* **{k}** — {v}" for k, v in GLOSSARY] + [""]
    return "\n".join(md) + "\n"


# ============================================================================ HTML
_CSS = """
body{font-family:DejaVu Sans,Arial,sans-serif;max-width:1280px;margin:1.5em auto;padding:0 1em;color:#222}
h1{font-size:1.6em;margin-bottom:.2em}
h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2.2em}
h3{font-size:1em;margin:1.2em 0 .3em;color:#444}
table{border-collapse:collapse;margin:.6em 0;font-size:.88em}
th,td{border:1px solid #bbb;padding:.25em .5em;text-align:left;vertical-align:top}
th{background:#eef1f5}td.num{text-align:right;font-family:DejaVu Sans Mono,monospace}
tr.meet td.verdict{background:#e6f5e6}tr.differ td.verdict{background:#fdebd6}tr.fitted td.verdict{background:#e3e8f7}
tr.unjudged td.verdict{color:#666}
img{max-width:100%;border:1px solid #ddd}video{max-width:100%;background:#000;display:block}
.meta{color:#555;font-size:.9em}.warn{background:#fff4d6;border-left:4px solid #e0a000;padding:.4em .8em}
.lead{font-size:1.05em}
.head{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}
.head figure{flex:1 1 500px;margin:0}.head .side{flex:1 1 500px;min-width:320px}
figure{margin:0}figcaption{color:#555;font-size:.8em}
table.headline{font-size:.92em;width:100%}table.headline td.verdict{font-weight:bold}
.gallery{display:flex;flex-wrap:wrap;gap:.6em;margin:.8em 0}
.gallery figure{flex:0 1 calc(25% - .6em);min-width:200px}.gallery img{width:100%;height:auto}
details{margin:.5em 0;border:1px solid #ddd;border-radius:4px;padding:.3em .6em;background:#fafafa}
details>summary{cursor:pointer;color:#234;font-size:.92em}
.bar{display:flex;width:220px;height:14px;border:1px solid #999;background:#fff}
.bar span{display:block;height:100%}
.c-meet{background:#4caf50}.c-fitted{background:#7b8fd6}.c-differ{background:#f39c34}.c-unjudged{background:#d5d5d5}
.legend span.sw{display:inline-block;width:12px;height:12px;border:1px solid #999;margin:0 .3em 0 1em;
  vertical-align:-2px}
table.summary td.grp{background:#f3f3f3;font-weight:bold}table.summary td{padding:.15em .5em}
dt{font-weight:bold;margin-top:.4em}dd{margin-left:1.5em}
td.eng{white-space:nowrap}td.eng.meet{background:#e6f5e6}td.eng.differ{background:#fdebd6;font-weight:bold}
td.eng.unjudged{color:#666}th.grouphead{text-align:center;background:#dde3ea}
table.eng{font-size:.9em}table.eng td.meta{font-size:.95em}
"""

#: on load → <body data-check>: images loaded, media errors, in-page links whose target is missing, and
#: where (px from the top) the first case's headline figure and its first folded table are laid out
_CHECK_JS = """
window.addEventListener('load', function () {
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) { if (imgs[i].complete && imgs[i].naturalWidth > 0) ok++; }
  var vids = document.getElementsByTagName('video'), verr = 0;
  for (var j = 0; j < vids.length; j++) { if (vids[j].error) verr++; }
  var links = document.querySelectorAll('a[href^="#"]'), bad = 0;
  for (var k = 0; k < links.length; k++) {
    if (!document.getElementById(links[k].getAttribute('href').slice(1))) bad++;
  }
  var fig = document.querySelector('.head figure img'), det = document.querySelector('h2 ~ details');
  var top = function (el) { return el ? Math.round(el.getBoundingClientRect().top + window.scrollY) : -1; };
  document.body.setAttribute('data-check', 'images ' + ok + '/' + imgs.length + ' video-errors ' + verr + '/'
    + vids.length + ' anchors-missing ' + bad + '/' + links.length + ' first-figure-top ' + top(fig)
    + ' first-details-top ' + top(det));
});
"""


def _md_inline(text):
    """HTML of a sentence written with the report's markdown subset (**bold**, `code`)."""
    t = html.escape(text)
    t = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", t)
    return re.sub(r"`(.+?)`", r"<code>\1</code>", t)


def _html_table(head, body, num_cols=(), row_classes=None, col_classes=None, cls="rows"):
    e = html.escape
    parts = [f'<table class="{cls}"><tr>' + "".join(f"<th>{e(h)}</th>" for h in head) + "</tr>"]
    for i, cells in enumerate(body):
        rc = f' class="{row_classes[i]}"' if row_classes and row_classes[i] else ""
        tds = []
        for j, c in enumerate(cells):
            k = (col_classes or {}).get(j) or ("num" if j in num_cols else "")
            tds.append(f'<td class="{k}">{_md_inline(str(c))}</td>' if k else f"<td>{_md_inline(str(c))}</td>")
        parts.append(f"<tr{rc}>" + "".join(tds) + "</tr>")
    parts.append("</table>")
    return "\n".join(parts)


def _row_class(row):
    v = row.get("verdict") or {}
    if v.get("ok") is None:
        return "unjudged"
    if v.get("fitted"):
        return "fitted"
    return "meet" if v["ok"] else "differ"


def _verdict_table(rows, reason=True, cls="rows"):
    head, body = table_rows(rows, reason=reason)
    nlab = len(head) - (5 if reason else 4)
    return _html_table(head, body, num_cols=range(2, 3 + nlab), row_classes=[_row_class(x) for x in rows],
                       col_classes={3 + nlab: "verdict"}, cls=cls)


def _bar_html(c) -> str:
    n = sum(c[k] for k, _ in BAR) or 1
    spans = "".join(f'<span class="c-{k}" style="width:{100 * c[k] / n:.2f}%"></span>' for k, _ in BAR if c[k])
    return f'<div class="bar" title="{html.escape(_bar_text(c))}">{spans}</div>'


def _eng_td(c) -> str:
    e = html.escape
    return f'<td class="eng {_eng_class(c)}" title="{e(c["detail"])}">{e(_eng_cell_text(c))}</td>'


def _html_summary(results):
    """The engineering verdicts and the paper comparison of every case, one line per case under its
    paper's heading (the paper column of report.md is that heading here): the four checks, then the
    verdict bar of the paper's figures and its counts."""
    e = html.escape
    paper_head = ["paper comparison", "meet the paper", "differ", "no paper figure", "runtime [s]"]
    head = ["case"] + [t for _, t in CHECKS] + paper_head
    parts = [f'<p class="lead">{_md_inline(_eng_totals_text(results))} {_md_inline(_totals_text(results))}</p>',
             '<p class="meta legend">Engineering verdicts: ✓ met, ✗ not met (hover a cell for its numbers). '
             'Paper comparison, verdicts of each case\'s rows to scale:'
             + "".join(f'<span class="sw c-{k}"></span>{e(t)}' for k, t in BAR) + "</p>",
             '<table class="summary"><tr><th></th><th colspan="4" class="grouphead">engineering verdicts</th>'
             '<th colspan="5" class="grouphead">paper comparison</th></tr>',
             "<tr>" + "".join(f"<th>{e(h)}</th>" for h in head) + "</tr>"]
    for paper, rs in _groups(results):
        parts.append(f'<tr><td class="grp" colspan="{len(head)}">{e(paper)}</td></tr>')
        for r in rs:
            cells = _summary_cells(r)
            eng = _engineering_of(r)
            tds = [f'<td><a href="#{_anchor(r["case"])}">{e(r["case"])}</a></td>']
            tds += [_eng_td(eng[k]) for k, _ in CHECKS]
            tds += [f"<td>{_bar_html(_counts(r))}</td>"]
            tds += [f'<td class="num">{e(c)}</td>' for c in (cells[4], cells[5], cells[6], cells[7])]
            parts.append("<tr>" + "".join(tds) + "</tr>")
    parts.append("</table>")
    return parts


def _eng_html(r) -> str:
    """A case's engineering verdicts: one line per check with its numbers."""
    e = html.escape
    eng = _engineering_of(r)
    rows = "".join(f"<tr>{_eng_td(eng[k])}<td>{e(t)}</td><td class=\"meta\">{e(eng[k]['detail'])}</td></tr>"
                   for k, t in CHECKS)
    return f'<table class="eng"><tr><th>verdict</th><th>engineering check</th><th>numbers</th></tr>{rows}</table>'



def _figure_html(case, f, caption=True):
    e = html.escape
    src = f"{e(case)}/{e(f)}"
    return (f'<figure><a href="{src}"><img src="{src}" alt="{e(f)}" loading="eager"></a>'
            + (f"<figcaption>{e(f)}</figcaption>" if caption else "") + "</figure>")


def _head_html(r):
    """The case's lead block: headline figure | video + headline numbers."""
    e = html.escape
    case, figs = r["case"], list(r["figures"])
    side = []
    v = r.get("video")
    if v:  # preload: the first frame shows (the videos are small local files)
        src = f"{e(case)}/{e(v['file'])}"
        poster = f' poster="{e(case)}/{e(v["poster"])}"' if v.get("poster") else ""
        side.append(f'<video src="{src}"{poster} controls muted loop preload="auto" width="{v["width"]}"></video>'
                    f'<p class="meta">Video (<a href="{src}">{e(v["file"])}</a>): {_md_inline(_video_caption(v))}</p>')
    elif _no_video(r):
        side.append(f'<p class="meta">{_md_inline(_no_video(r))}</p>')
    idx = _headline_of(r)
    if idx:
        side.append(f"<h3>Paper comparison: headline numbers ({len(idx)} of {len(r['rows'])} rows)</h3>")
        side.append(_verdict_table([r["rows"][i] for i in idx], reason=False, cls="headline"))
    out = ['<div class="head">']
    if figs:
        out.append(_figure_html(case, figs[0]))
    out += ['<div class="side">'] + side + ["</div></div>"]
    if figs[1:]:
        out.append('<div class="gallery">' + "".join(_figure_html(case, f) for f in figs[1:]) + "</div>")
    return out


def _case_html(r):
    e = html.escape
    case = r["case"]
    parts = [f'<h2 id="{_anchor(case)}">{e(case)}: {e(r["title"])}</h2>']
    meta = " ".join(_md_inline(b) for b in _case_intro(r))
    if r.get("overrides"):
        meta += f' Overrides: <code>{e(" ".join(r["overrides"]))}</code>.'
    meta += f' Files: <a href="{e(case)}/metrics.json">{e(case)}/metrics.json</a>.'
    parts.append(f'<p class="meta">{meta}</p>')
    if r.get("note"):
        parts.append(f"<p>{_md_inline(r['note'])}</p>")
    parts.append(_eng_html(r))
    for w in r.get("warnings") or []:
        parts.append(f'<p class="warn"><b>Warning:</b> {_md_inline(w)}</p>')
    parts += _head_html(r)
    if r["rows"]:
        parts.append(f"<details><summary>{e(_full_summary(r))}</summary>")
        parts += [_verdict_table(r["rows"]), "</details>"]
    for t in r.get("tables") or []:
        title = t.get("title") or "more numbers"
        parts.append(f"<details><summary>Table: {e(title)} ({len(t['rows'])} rows)</summary>")
        parts.append(_html_table(t["head"], t["rows"]))
        if t.get("note"):
            parts.append(f'<p class="meta">{_md_inline(t["note"])}</p>')
        parts.append("</details>")
    return parts


def _html(results, total_s):
    e = html.escape
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             '<meta name="viewport" content="width=device-width, initial-scale=1">',
             "<title>mjbench reproduction report</title>", f"<style>{_CSS}</style>",
             f"<script>{_CHECK_JS}</script></head><body>",
             "<h1>mjbench — reproduction report</h1>", f'<p class="lead">{_md_inline(LEAD)}</p>',
             '<p class="meta">Below: every case\'s verdicts at a glance, then the cases one by one; words and '
             'symbols: <a href="#glossary">glossary</a>.</p>']
    parts += _html_summary(results)
    meta = f"Total runtime: {total_s:.0f} s. " if total_s is not None else ""
    parts.append(f'<details><summary>How to read this report</summary><p>{_md_inline(INTRO)}</p>'
                 f'<p class="meta">{e(meta)}Environment: {e(_env_text())}.</p></details>')
    for r in results:
        parts += _case_html(r)
    parts.append('<h2 id="glossary">Glossary</h2><dl>')
    for k, v in GLOSSARY:
        parts.append(f"<dt>{e(k)}</dt><dd>{_md_inline(v)}</dd>")
    parts.append("</dl></body></html>")
    return "\n".join(parts) + "\n"


# ============================================================================ files
def _env_text():
    import platform
    import sys

    try:
        import mujoco
        mj = mujoco.__version__
    except Exception:  # pragma: no cover
        mj = "?"
    try:
        from importlib.metadata import version
        me = version("mjbench")
    except Exception:  # pragma: no cover
        me = "?"
    gl = os.environ.get("MUJOCO_GL", "")
    return (f"mjbench {me}, MuJoCo {mj}, Python {sys.version.split()[0]}, {platform.system()} "
            f"{platform.machine()}, {os.cpu_count()} CPUs, MUJOCO_GL={gl or 'unset'}, "
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")


def write_report(results: list, out_dir, total_s=None) -> tuple:
    """``report.md`` and ``report.html`` in ``out_dir`` from the case results."""
    out = Path(out_dir)
    md_text = _markdown(results, total_s)
    html_text = _html(results, total_s)
    atomic_write(out / "report.md", lambda f: f.write(md_text))
    atomic_write(out / "report.html", lambda f: f.write(html_text))
    return out / "report.md", out / "report.html"
