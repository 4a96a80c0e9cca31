"""``mjbench reproduce``: every paper case end to end → figures, metrics.json, video, report.

Cases come from the paper registry (:mod:`mjbench.papers`): each paper module lists its cases
(:class:`mjbench.papers.Case`), its report rows ``rows(ctx)`` and its figures ``figures(ctx)``,
where ``ctx`` is a :class:`CaseRun` (scenario, runs {mode: {backend: Trajectory}}, machines,
metrics, output folder; hooks may also append extra tables to ``ctx.tables`` and warnings to
``ctx.warnings``).  A row is ``{"name", "unit", "paper" (number, [lo, hi] band or None),
"compare" ("value" | "band" | "max" | "min"), "tolerance"?, "fitted"?, "ours" {label: number},
"reason"}``; its verdict is computed from the numbers by :mod:`mjbench.verdicts` — never typed
in.  For ``kind = "run"`` the rows of the scenario's ``[[paper.figures]]`` (runner.paper_rows)
come first; ``kind = "optimize-law"`` runs the motion-law study (vibration.study);
``kind = "study"`` calls the paper module's ``study(ctx)``.

Outputs per case in ``DIR/<case>/``: PNG figures, ``metrics.json`` (metrics of every mode and
backend + the comparison rows with their verdicts, exactly the numbers the report tables print),
trajectory CSVs, ``video.mp4``; then ``DIR/report.md`` and ``DIR/report.html`` (figures and videos
embedded by relative path, one table per case: paper, ours, verdict, reason; a glossary).
"""
from __future__ import annotations

import html
import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import outputs
from . import scenario as S
from .errors import MjbenchError, ScenarioError
from . import verdicts as V
from .trajectory import atomic_write
from .manifest import json_default as _json_default

AGREE_REL = V.TOLERANCE  #: relative tolerance of a point value (mjbench.verdicts)


# ============================================================================ registry
def load_cases(scenarios=None) -> list:
    """Every paper case (optionally only those of the given scenario names), by paper then name."""
    from . import papers

    out = [c for c in papers.cases() if scenarios is None or c.scenario in scenarios]
    # within a paper: the order its module lists its cases in
    order = {k: i for i, k in enumerate(papers.MODULES)}
    pos = {c.name: i for i, c in enumerate(papers.cases())}  # a paper's cases in the order it lists them
    return sorted(out, key=lambda c: (order[c.paper], pos[c.name]))


def select(cases, which) -> list:
    """Cases named ``which`` ("all", a case name, or a scenario name = all its cases)."""
    if which in (None, "all"):
        return list(cases)
    sel = [c for c in cases if c.name == which or c.scenario == which]
    if not sel:
        raise ScenarioError(f"unknown reproduce case {which!r}; cases: {[c.name for c in cases]} "
                            f"(or a scenario name, or 'all')")
    return sel


# ============================================================================ one case
@dataclass
class CaseRun:
    """Everything a hook may need about a finished case run."""

    case: object
    scn: object
    out: Path
    runs: dict = field(default_factory=dict)      # {mode: {backend: Trajectory}}
    machines: dict = field(default_factory=dict)  # {mode: Machine} (fresh, for kinematics/references)
    metrics: dict = field(default_factory=dict)   # {mode: runner.mode_metrics(...)}
    extra: dict = field(default_factory=dict)     # kind-specific results (e.g. optimize-law report)
    tables: list = field(default_factory=list)    # extra tables: {"title", "head", "rows", "note"?}
    warnings: list = field(default_factory=list)  # sentences printed in the report above the table


def run_case(case, out_dir, quick=False, video=True, progress=True, width=None, height=None) -> dict:
    """Run one case; write its files into ``out_dir/<case>/``; return its metrics dict."""
    from . import plotstyle

    t0 = time.perf_counter()
    out = Path(out_dir) / case.name
    out.mkdir(parents=True, exist_ok=True)
    from . import papers

    paper = papers.module(case.paper) if case.paper else None
    if case.kind == "design":  # a requirements file: the paper module runs the design, which writes the machine
        scn, extra = paper.design(case, out)
    else:
        scn, extra = S.load(case.scenario, case.overrides), {}
    ctx = CaseRun(case, scn, out, extra=extra)
    res = {"case": case.name, "scenario": case.scenario, "paper": case.paper,
           "citation": scn.scenario.paper or (getattr(paper, "CITATION", "") if paper is not None else ""),
           "paper_title": (getattr(paper, "SCENARIO_TITLES", {}).get(case.scenario) or getattr(paper, "TITLE", ""))
           if paper is not None else "",
           "title": case.title or scn.scenario.title or case.scenario,
           "scenario_title": scn.scenario.title, "kind": case.kind,
           "overrides": list(case.overrides), "note": case.note, "modes": {}, "rows": [],
           "tables": [], "warnings": [], "figures": [], "video": None}
    with plotstyle.context():
        if case.kind == "run":
            _run_kind(ctx, res, progress)
        elif case.kind == "optimize-law":
            _optimize_law_kind(ctx, res)
        elif case.kind == "study" and paper is not None and hasattr(paper, "study"):
            paper.study(ctx)
        elif case.kind == "design":
            pass  # designed and verified above (mjbench/papers/design_examples.py)
        else:
            raise ScenarioError(f"reproduce case {case.name!r}: kind {case.kind!r} is not 'run', 'optimize-law' "
                                f"or 'study' (with a study(ctx) in its paper module)")
        if paper is not None:
            res["rows"] += [_normalise_row(r) for r in paper.rows(ctx)]
        figs = paper.figures(ctx) if paper is not None else (default_figures(ctx) if case.kind == "run" else [])
        figs = list(figs or [])
        for mode, trajs in ctx.runs.items():  # every case that ran both backends: their comparison
            if "multibody" in trajs and "reduced" in trajs:
                figs.append(backend_comparison(trajs, out / f"backends_{mode}.png",
                                               title=f"{case.name}, mode {mode}: multibody vs reduced"))
        res["figures"] += [os.path.relpath(os.fspath(p), out) for p in figs or []]
        res["tables"] = [_normalise_table(t) for t in ctx.tables]
        res["warnings"] = [str(w) for w in ctx.warnings]
        res["counts"] = V.counts(res["rows"])
    res["sim_figures_s"] = time.perf_counter() - t0
    try:  # a video that cannot be made (no OpenGL, encoder) is recorded; the report goes on
        if video and case.video and case.kind in ("run", "design"):
            res["video"] = _video(ctx, quick, progress, width, height)
        elif video and case.video and case.kind == "optimize-law":
            res["video"] = _platform_video(ctx, quick, progress, width, height)
    except MjbenchError as e:
        res["video_error"] = str(e)
    res["runtime_s"] = time.perf_counter() - t0
    _write_json(out / "metrics.json", res)
    return res


def _run_kind(ctx: CaseRun, res: dict, progress: bool):
    from . import runner

    case, scn = ctx.case, ctx.scn
    backends = runner.BACKENDS if case.backend == "both" else (case.backend,)
    for mode in case.modes:
        trajs = runner.run_mode(scn, mode, backends, case.t_end, progress=progress)
        ctx.runs[mode] = trajs
        ctx.machines[mode] = S.make_machine(scn, mode)
        m = runner.mode_metrics(scn, mode, trajs)
        ctx.metrics[mode] = m
        res["modes"][mode] = {k: v for k, v in m.items() if k != "paper"}
        for row in m.get("paper", []):  # the scenario's [[paper.figures]], verdicts computed by the runner
            res["rows"].append(_normalise_row(row))
        for b, tr in trajs.items():
            tr.write_csv(ctx.out / f"trajectory_{mode}_{b}.csv")


def _optimize_law_kind(ctx: CaseRun, res: dict):
    from . import vibration

    st = vibration.study(ctx.scn)
    ctx.extra["study"] = st
    res["optimize_law"] = json.loads(json.dumps(st["report"], default=_json_default))


def default_figures(ctx: CaseRun):
    """Incerti 2012 Fig. 4 layout: one column per mode, every backend drawn, set-point dashed."""
    from .plots import fig4
    from .runner import chi_text, setpoint

    sp = next((v for v in (setpoint(ctx.scn, m) for m in ctx.case.modes) if v is not None), None)
    chi = {mode: txt for mode, m in ctx.metrics.items() if (txt := chi_text(m))}
    p = fig4(ctx.runs, ctx.out / "fig4.png", setpoint=sp, chi=chi or None,
             title=f"{ctx.case.name}: {ctx.case.title or S.get(ctx.scn, 'scenario.title', '')}")
    return [p]


def backend_comparison(trajs: dict, path, title=""):
    """Crank speed of both backends (plotstyle.BACKEND) and their difference, with units."""
    from . import plotstyle as ps
    from .plots import save

    ref, oth = trajs["reduced"], trajs["multibody"]
    fig, (a0, a1) = ps.new(2, 1, figsize=(8, 5.5), sharex=True)
    for b in ("multibody", "reduced"):
        a0.plot(trajs[b].t, trajs[b].qd, **ps.backend_style(b))
    a0.set_ylabel(ps.label("crank speed α̇", "rad/s"))
    a0.legend(loc="lower right")
    diff = np.interp(ref.t, oth.t, oth.qd) - ref.qd
    a1.plot(ref.t, diff, color="k", lw=0.9, label="multibody − reduced")
    a1.set_ylabel(ps.label("difference", "rad/s"))
    a1.set_xlabel(ps.label("time t", "s"))
    a1.legend(loc="upper left")
    ps.finish(fig, title)
    return save(fig, path)


def _video(ctx: CaseRun, quick, progress, width=None, height=None):
    from . import render

    case = ctx.case
    mode = case.video_mode or case.modes[-1]
    t_run = case.t_end or S.get(ctx.scn, "simulation.t_end", 2.0)
    t_vid = case.video_t_end or min(float(t_run), 4.0)
    if quick:
        t_vid = min(t_vid, 2.0)
    w, h = (width or (640 if quick else 960)), (height or (360 if quick else 540))
    info = render.render_scenario(ctx.scn, ctx.out / "video.mp4", mode=mode, fps=30, width=w, height=h,
                                  t_end=t_vid, progress=progress)
    return {"file": "video.mp4", "mode": mode, "frames": info["frames"], "width": w, "height": h,
            "duration_s": info["duration_s"], "render_s": info["wall_s"], "frames_per_s": info["frames_per_s"]}


def _platform_video(ctx: CaseRun, quick, progress, width=None, height=None):
    """Incerti belt / Bezier platforms: the platform driven by the initial, then the optimised law (top view; the
    deflection ψ is shown magnified by a needle, render.PlatformView)."""
    from . import render

    o = ctx.extra["study"]["objects"]
    laws = {k: o["laws"][k] for k in ("initial", "optimised")}
    w, h = (width or (640 if quick else 960)), (height or (360 if quick else 540))
    info = render.render_platform_laws(o["platform"], laws, ctx.out / "video.mp4", t_after=o["t_after"], fps=30,
                                       width=w, height=h, progress=progress)
    return {"file": "video.mp4", "mode": "initial, then optimised law", "frames": info["frames"], "width": w,
            "height": h, "duration_s": info["duration_s"], "render_s": info["wall_s"],
            "frames_per_s": info["frames_per_s"], "needle_gain": info["needle_gain"]}


# ============================================================================ rows
def _num(x):
    return V._num(x)


def _normalise_row(r: dict) -> dict:
    """A report row with its verdict (mjbench.verdicts.finish_row): numbers cast to float, the
    paper column's text, the verdict computed from the numbers, and a reason where the verdict
    is not a match and the paper module states none."""
    row = {"name": str(r["name"]), "unit": r.get("unit", "") or "", "paper": r.get("paper"),
           "compare": r.get("compare"), "tolerance": r.get("tolerance"), "fitted": r.get("fitted", False),
           "ours": {k: (float(v) if _num(v) else v) for k, v in (r.get("ours") or {}).items()},
           "reason": r.get("reason", "") or ""}
    for k in ("mode", "metric"):
        if r.get(k) is not None:
            row[k] = r[k]
    if isinstance(row["paper"], (list, tuple)):
        row["paper"] = [float(x) for x in row["paper"]]
    elif _num(row["paper"]):
        row["paper"] = float(row["paper"])
    V.finish_row(row)
    if not row["reason"] and row["verdict"]["ok"] is False:
        row["reason"] = "no reason stated"
    return row


def _normalise_table(t: dict) -> dict:
    """An extra table: {"title", "head": [..], "rows": [[..]], "note"} with cells as printed."""
    return {"title": str(t.get("title", "")), "head": [str(h) for h in t["head"]],
            "rows": [[c if isinstance(c, str) else fmt(c) for c in row] for row in t["rows"]],
            "note": str(t.get("note", "") or "")}


# ============================================================================ report
fmt = V.fmt

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
    ("verdict", f"computed from the numbers: a point value agrees when |ours − paper| ≤ {100 * V.TOLERANCE:g} % "
                "of the paper's value (else 'differs', signed); a band [lo, hi] is 'inside', 'below by X' or "
                "'above by X'; an upper bound is 'met' or 'exceeded by X'. 'fitted': a figure our parameters "
                "were fitted to (agreement by construction, not a prediction)."),
    ("reason", "why ours differs, or what the figure depends on: stated by the paper module or the "
               "scenario file; it never states the verdict."),
]


def _rel(v):
    return "—" if v is None else f"{100 * v:+.1f} %"


def _labels(rows):
    labs = []
    for r in rows:
        for k in r["ours"]:
            if k not in labs:
                labs.append(k)
    return labs


def _counts(r):
    return r.get("counts") or V.counts(r["rows"])


def _count_text(c):
    judged = c["meet"] + c["differ"] + c["fitted"]
    if not judged:
        return "—"
    txt = f"{c['meet'] + c['fitted']}/{judged}"
    return txt + (f" ({c['fitted']} fitted)" if c["fitted"] else "")


SUMMARY_HEAD = ["case", "paper", "rows", "meet the paper", "differ", "no paper figure", "runtime [s]"]


def _summary_cells(r):
    c = _counts(r)
    return [r["case"], r.get("citation") or r.get("paper") or "", str(len(r["rows"])), _count_text(c),
            str(c["differ"]), str(c["unjudged"]), f"{r['runtime_s']:.1f}"]


INTRO = ("Every paper case run end to end by `mjbench reproduce` (figures in the papers' style, metrics, "
         "a real-time video of the multibody run).  Each table lists, for every quantity, the paper's figure "
         "(a value, a band lo–hi, or a bound ≤ / ≥), ours (one column per simulator backend where both ran), "
         "the **verdict computed from these numbers** and the reason where ours differs.  A point value "
         f"agrees when it is within ±{100 * V.TOLERANCE:g} % of the paper's; a band or a bound is met or "
         "missed by the amount shown.  'meet the paper' counts the rows that agree, lie inside the band or "
         "meet the bound, out of the rows with a paper figure.  Words and symbols: see the glossary at the end.")


def write_report(results: list, out_dir, total_s=None) -> tuple:
    """``report.md`` and ``report.html`` in ``out_dir`` from the case results."""
    out = Path(out_dir)
    md = ["# mjbench — reproduction report", "", INTRO, ""]
    if total_s is not None:
        md += [f"Total runtime: {total_s:.0f} s.", ""]
    md += [f"Environment: {_env_text()}.", ""]
    md += ["| " + " | ".join(SUMMARY_HEAD) + " |", "|" + "---|" * len(SUMMARY_HEAD)]
    for r in results:
        cells = _summary_cells(r)
        cells[0] = f"[{r['case']}](#{_anchor(r['case'])})"
        md.append("| " + " | ".join(cells) + " |")
    md.append("")
    for r in results:
        md += _case_md(r)
    md += ["## Glossary", ""] + [f"* **{k}** — {v}" for k, v in GLOSSARY] + [""]
    md_text = "\n".join(md) + "\n"
    html_text = _html(results, total_s)
    atomic_write(out / "report.md", lambda f: f.write(md_text))
    atomic_write(out / "report.html", lambda f: f.write(html_text))
    return out / "report.md", out / "report.html"


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


def _anchor(name):
    return "case-" + "".join(c if c.isalnum() else "-" for c in name.lower())


def _ours_head(b):
    return "ours" if b == "ours" else f"ours: {b}"


MAX_OURS_COLUMNS = 3  #: more distinct labels of ours in a case: one "ours" column of "label: value" items


def ours_columns(rows) -> list | None:
    """The labels of ours shown as columns, or None when they are folded into one column."""
    labs = _labels(rows)
    return labs if len(labs) <= MAX_OURS_COLUMNS else None


def _ours_text(ours: dict) -> str:
    return "; ".join(fmt(v) if k == "ours" else f"{k}: {fmt(v)}" for k, v in ours.items())


def _table_rows(r):
    """Header and cells of a case's verdict table (every number printed with :func:`fmt`)."""
    labs = ours_columns(r["rows"])
    head = ["quantity", "unit", "paper"] + ([_ours_head(b) for b in labs] if labs is not None else ["ours"]) \
        + ["verdict", "reason"]
    body = []
    for row in r["rows"]:
        ours = [fmt(row["ours"].get(b)) for b in labs] if labs is not None else [_ours_text(row["ours"])]
        body.append([row["name"], row.get("unit", ""), row.get("paper_text") or fmt(row["paper"])] + ours
                    + [row["verdict"]["text"], row.get("reason", "") or "—"])
    return head, body


def _case_intro(r):
    bits = [f"Paper: **{r.get('citation') or r.get('paper')}**"
            + (f", “{r['paper_title']}”" if r.get("paper_title") else "") + ".",
            f"Scenario `{r['scenario']}` — {r.get('scenario_title', '')}."]
    return bits


def _md_cell(x):
    return str(x).replace("|", "\\|").replace("\n", " ")


def _md_table(head, body):
    out = ["| " + " | ".join(_md_cell(h) for h in head) + " |", "|" + "---|" * len(head)]
    for b in body:
        out.append("| " + " | ".join(_md_cell(x) for x in b) + " |")
    return out


def _case_md(r):
    case = r["case"]
    md = [f'<a id="{_anchor(case)}"></a>', f"## {case}: {r['title']}", ""]
    md += _case_intro(r)
    if r.get("overrides"):
        md.append(f"Overrides: `{' '.join(r['overrides'])}`.")
    if r.get("note"):
        md.append(r["note"])
    md.append(f"Files: [`{case}/metrics.json`]({case}/metrics.json).")
    md.append("")
    for w in r.get("warnings") or []:
        md += [f"> **Warning:** {w}", ""]
    head, body = _table_rows(r)
    if body:
        md += _md_table(head, body) + [""]
    for t in r.get("tables") or []:
        if t.get("title"):
            md += [f"**{t['title']}**", ""]
        md += _md_table(t["head"], t["rows"]) + [""]
        if t.get("note"):
            md += [t["note"], ""]
    for f in r["figures"]:
        md += [f"![{f}]({case}/{f})", ""]
    v = r.get("video")
    if v:
        md += [f'<video src="{case}/{v["file"]}" controls muted loop width="{v["width"]}"></video>', "",
               f"Video: [`{case}/{v['file']}`]({case}/{v['file']}) — mode {v['mode']}, {v['frames']} frames "
               f"{v['width']}×{v['height']} at 30 fps (real time, {v['duration_s']:.2f} s).", ""]
    elif r.get("video_error"):
        md += [f"No video: {r['video_error']}", ""]
    elif r["kind"] == "optimize-law":
        md += ["No video: a motion-law case (`mjbench optimize-law`), evaluated on the platform model.", ""]
    if v and v.get("needle_gain"):
        md += [f"Top view of the platform; grey needle: rigid-transmission angle ρ·φ, magenta needle: ρ·φ + "
               f"{v['needle_gain']:g}·ψ (the deflection ψ magnified ×{v['needle_gain']:g}).", ""]
    return md


_CSS = """
body{font-family:DejaVu Sans,Arial,sans-serif;max-width:1200px;margin:1.5em auto;padding:0 1em;color:#222}
h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.88em}
th,td{border:1px solid #bbb;padding:.25em .5em;text-align:left;vertical-align:top}
th{background:#eef1f5}td.num{text-align:right;font-family:DejaVu Sans Mono,monospace}
tr.meet td.verdict{background:#e6f5e6}tr.differ td.verdict{background:#fdebd6}tr.fitted td.verdict{background:#eceff7}
img{max-width:100%;border:1px solid #ddd;margin:.4em 0}video{max-width:100%;background:#000}
.meta{color:#555;font-size:.9em}.warn{background:#fff4d6;border-left:4px solid #e0a000;padding:.4em .8em}
dt{font-weight:bold;margin-top:.4em}dd{margin-left:1.5em}
"""

_CHECK_JS = """
window.addEventListener('load', function () {
  var imgs = document.images, ok = 0;
  for (var i = 0; i < imgs.length; i++) { if (imgs[i].complete && imgs[i].naturalWidth > 0) ok++; }
  var vids = document.getElementsByTagName('video'), verr = 0;
  for (var j = 0; j < vids.length; j++) { if (vids[j].error) verr++; }
  document.body.setAttribute('data-check', 'images ' + ok + '/' + imgs.length + ' video-errors ' + verr + '/' + vids.length);
});
"""


def _md_inline(text):
    """HTML of a sentence written with the report's markdown subset (**bold**, `code`)."""
    import re

    t = html.escape(text)
    t = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", t)
    return re.sub(r"`(.+?)`", r"<code>\1</code>", t)


def _html_table(head, body, num_cols=(), row_classes=None, col_classes=None):
    e = html.escape
    parts = ['<table class="rows"><tr>' + "".join(f"<th>{e(h)}</th>" for h in head) + "</tr>"]
    for i, cells in enumerate(body):
        cls = f' class="{row_classes[i]}"' if row_classes and row_classes[i] else ""
        tds = []
        for j, c in enumerate(cells):
            k = (col_classes or {}).get(j) or ("num" if j in num_cols else "")
            tds.append(f'<td class="{k}">{_md_inline(str(c))}</td>' if k else f"<td>{_md_inline(str(c))}</td>")
        parts.append(f"<tr{cls}>" + "".join(tds) + "</tr>")
    parts.append("</table>")
    return "\n".join(parts)


def _row_class(row):
    v = row.get("verdict") or {}
    if v.get("ok") is None:
        return ""
    if v.get("fitted"):
        return "fitted"
    return "meet" if v["ok"] else "differ"


def _html(results, total_s):
    e = html.escape
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>mjbench reproduction report</title>", f"<style>{_CSS}</style>",
             f"<script>{_CHECK_JS}</script></head><body>",
             "<h1>mjbench — reproduction report</h1>", f"<p>{_md_inline(INTRO)}</p>"]
    if total_s is not None:
        parts.append(f'<p class="meta">Total runtime: {total_s:.0f} s.</p>')
    parts.append(f'<p class="meta">Environment: {e(_env_text())}.</p>')
    parts.append("<table><tr>" + "".join(f"<th>{e(h)}</th>" for h in SUMMARY_HEAD) + "</tr>")
    for r in results:
        cells = _summary_cells(r)
        tds = [f'<td><a href="#{_anchor(r["case"])}">{e(r["case"])}</a></td>', f"<td>{e(cells[1])}</td>"]
        tds += [f'<td class="num">{e(c)}</td>' for c in cells[2:]]
        parts.append("<tr>" + "".join(tds) + "</tr>")
    parts.append("</table>")
    for r in results:
        case = r["case"]
        parts.append(f'<h2 id="{_anchor(case)}">{e(case)}: {e(r["title"])}</h2>')
        meta = " ".join(_md_inline(b) for b in _case_intro(r))
        if r.get("overrides"):
            meta += f' Overrides: <code>{e(" ".join(r["overrides"]))}</code>.'
        meta += f' Files: <a href="{e(case)}/metrics.json">{e(case)}/metrics.json</a>.'
        parts.append(f'<p class="meta">{meta}</p>')
        if r.get("note"):
            parts.append(f"<p>{_md_inline(r['note'])}</p>")
        for w in r.get("warnings") or []:
            parts.append(f'<p class="warn"><b>Warning:</b> {_md_inline(w)}</p>')
        head, body = _table_rows(r)
        if body:
            nlab = len(head) - 5
            parts.append(_html_table(head, body, num_cols=range(2, 3 + nlab),
                                     row_classes=[_row_class(row) for row in r["rows"]],
                                     col_classes={len(head) - 2: "verdict"}))
        for t in r.get("tables") or []:
            if t.get("title"):
                parts.append(f"<p><b>{e(t['title'])}</b></p>")
            parts.append(_html_table(t["head"], t["rows"]))
            if t.get("note"):
                parts.append(f'<p class="meta">{_md_inline(t["note"])}</p>')
        for f in r["figures"]:
            parts.append(f'<div><img src="{e(case)}/{e(f)}" alt="{e(f)}" loading="eager"></div>')
        v = r.get("video")
        if v:
            parts.append(f'<div><video src="{e(case)}/{e(v["file"])}" controls muted loop preload="metadata" '
                         f'width="{v["width"]}"></video><p class="meta">mode {e(v["mode"])}, {v["frames"]} frames '
                         f'{v["width"]}×{v["height"]} at 30 fps (real time, {v["duration_s"]:.2f} s)'
                         + (f'; grey needle: rigid angle ρ·φ, magenta: ρ·φ + {v["needle_gain"]:g}·ψ (deflection '
                            f'magnified ×{v["needle_gain"]:g})' if v.get("needle_gain") else "") + "</p></div>")
        elif r.get("video_error"):
            parts.append(f'<p class="meta">No video: {e(r["video_error"])}</p>')
        elif r["kind"] == "optimize-law":
            parts.append('<p class="meta">No video: a motion-law case (<code>mjbench optimize-law</code>), '
                         "evaluated on the platform model.</p>")
    parts.append('<h2 id="glossary">Glossary</h2><dl>')
    for k, v in GLOSSARY:
        parts.append(f"<dt>{e(k)}</dt><dd>{e(v)}</dd>")
    parts.append("</dl></body></html>")
    return "\n".join(parts) + "\n"


# ============================================================================ driver
def _clean(o):
    """JSON-safe copy (NaN/inf → None so that the file is strict JSON; mjbench/outputs.py)."""
    return outputs.clean(o)


def _write_json(path, obj):
    outputs.write_json(path, obj)


def reproduce(which="all", out_dir="results", quick=False, video=True, progress=True, width=None,
              height=None, log=print) -> list:
    """Run the selected cases and write the report; returns the list of case results."""
    t0 = time.perf_counter()
    cases = select(load_cases(), which)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    for i, case in enumerate(cases, 1):
        log(f"[{i}/{len(cases)}] {case.name} ({case.scenario}, {case.kind}) ...")
        r = run_case(case, out, quick=quick, video=video, progress=progress, width=width, height=height)
        results.append(_clean(r))
        log(f"        {len(r['rows'])} comparison rows, {len(r['figures'])} figures"
            + (f", video {r['video']['frames']} frames" if r.get("video") else "") + f" — {r['runtime_s']:.1f} s")
    total = time.perf_counter() - t0
    md, htm = write_report(results, out, total)
    _write_json(out / "summary.json", {"cases": [r["case"] for r in results], "total_runtime_s": total})
    log(f"report: {md.name} and {htm.name} ({total:.0f} s)")
    return results
