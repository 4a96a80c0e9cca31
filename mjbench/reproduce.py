"""``mjbench reproduce``: every paper case end to end → figures, metrics.json, video, report.

Cases come from the paper registry (:mod:`mjbench.papers`): each paper module lists its cases
(:class:`mjbench.papers.Case`), its report rows ``rows(ctx)`` and its figures ``figures(ctx)``,
where ``ctx`` is a :class:`CaseRun` (scenario, runs {mode: {backend: Trajectory}}, machines,
metrics, output folder) and a row is ``{"name", "unit", "paper" (number, text or None),
"ours" {label: number}, "reason"}``.  For ``kind = "run"`` the rows of the scenario's
``[[paper.figures]]`` (runner.paper_rows) come first.

Outputs per case in ``DIR/<case>/``: PNG figures, ``metrics.json`` (metrics of every mode and
backend + the comparison rows, exactly the numbers the report tables print), trajectory CSVs,
``video.mp4``; then ``DIR/report.md`` and ``DIR/report.html`` (figures and videos embedded by
relative path, one table per case: paper, ours, difference, stated reason).
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
from .trajectory import atomic_write
from .manifest import json_default as _json_default

AGREE_REL = 0.05  #: |relative difference| up to which a row counts as agreeing with the paper


# ============================================================================ registry
def load_cases(scenarios=None) -> list:
    """Every paper case (optionally only those of the given scenario names), by paper then name."""
    from . import papers

    out = [c for c in papers.cases() if scenarios is None or c.scenario in scenarios]
    # within a paper: the paper's own scenario before derived ones (e.g. "-calibrated")
    order = {k: i for i, k in enumerate(papers.MODULES)}
    return sorted(out, key=lambda c: (order[c.paper], "calibrated" in c.scenario, c.name))


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


def run_case(case, out_dir, quick=False, video=True, progress=True, width=None, height=None) -> dict:
    """Run one case; write its files into ``out_dir/<case>/``; return its metrics dict."""
    from . import plotstyle

    t0 = time.perf_counter()
    out = Path(out_dir) / case.name
    out.mkdir(parents=True, exist_ok=True)
    scn = S.load(case.scenario, case.overrides)
    ctx = CaseRun(case, scn, out)
    res = {"case": case.name, "scenario": case.scenario, "seed": scn.scenario.seed, "paper": case.paper,
           "title": case.title or scn.scenario.title or case.scenario,
           "scenario_title": scn.scenario.title, "kind": case.kind,
           "overrides": list(case.overrides), "note": case.note, "modes": {}, "rows": [],
           "figures": [], "video": None}
    from . import papers

    paper = papers.module(case.paper) if case.paper else None
    with plotstyle.context():
        if case.kind == "run":
            _run_kind(ctx, res, progress)
        elif case.kind == "optimize-law":
            _optimize_law_kind(ctx, res)
        else:
            raise ScenarioError(f"reproduce case {case.name!r}: kind {case.kind!r} is not 'run' or 'optimize-law'")
        if paper is not None:
            res["rows"] += [_normalise_row(r) for r in paper.rows(ctx)]
        figs = paper.figures(ctx) if paper is not None else (default_figures(ctx) if case.kind == "run" else [])
        figs = list(figs or [])
        for mode, trajs in ctx.runs.items():  # every case that ran both backends: their comparison
            if "multibody" in trajs and "reduced" in trajs:
                figs.append(backend_comparison(trajs, out / f"backends_{mode}.png",
                                               title=f"{case.name}, mode {mode}: multibody vs reduced"))
        res["figures"] += [os.path.relpath(os.fspath(p), out) for p in figs or []]
    res["sim_figures_s"] = time.perf_counter() - t0
    try:  # a video that cannot be made (no OpenGL, encoder) is recorded; the report goes on
        if video and case.video and case.kind == "run":
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
        for row in m.get("paper", []):
            res["rows"].append(_normalise_row({
                "name": row["name"], "mode": mode, "metric": row.get("metric"), "paper": row.get("paper"),
                "unit": row.get("unit") or _unit_of(row.get("metric")),
                "ours": {b: row.get(b) for b in backends if row.get(b) is not None}, "reason": row.get("note", "")}))
        for b, tr in trajs.items():
            tr.write_csv(ctx.out / f"trajectory_{mode}_{b}.csv")


def _unit_of(metric):
    """Unit from a metric key's SI suffix (metrics.summary naming), '1' for ratios such as χ."""
    if not metric:
        return ""
    for suf, unit in (("_rad_s2", "rad/s²"), ("_rad_s", "rad/s"), ("_m_s", "m/s"), ("_rad", "rad"),
                      ("_s", "s"), ("_V", "V"), ("_A", "A"), ("_W", "W"), ("_J", "J"), ("_m", "m"),
                      ("_Nm", "N·m")):
        if metric.endswith(suf):
            return unit
    return "1"


def _optimize_law_kind(ctx: CaseRun, res: dict):
    from . import vibration

    st = vibration.study(ctx.scn)
    ctx.extra["study"] = st
    res["optimize_law"] = json.loads(json.dumps(st["report"], default=_json_default))


def default_figures(ctx: CaseRun):
    """Seed 000 Fig. 4 layout: one column per mode, every backend drawn, set-point dashed."""
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
    """Seeds 001/003: the platform driven by the initial, then the optimised law (top view; the
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
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def _normalise_row(r: dict) -> dict:
    """Fill unit/reason, cast numbers to float and add difference columns (first 'ours' value)."""
    row = {"name": str(r["name"]), "unit": r.get("unit", ""), "paper": r.get("paper"),
           "ours": {k: (float(v) if _num(v) else v) for k, v in (r.get("ours") or {}).items()},
           "reason": r.get("reason", "") or ""}
    for k in ("mode", "metric"):
        if r.get(k) is not None:
            row[k] = r[k]
    if _num(row["paper"]):
        row["paper"] = float(row["paper"])
    first = next((v for v in row["ours"].values() if _num(v) and math.isfinite(v)), None)
    if _num(row["paper"]) and first is not None:
        row["difference"] = first - row["paper"]
        row["rel_difference"] = row["difference"] / abs(row["paper"]) if row["paper"] else None
    else:
        row["difference"] = row["rel_difference"] = None
    rel = row["rel_difference"]
    if not row["reason"]:
        if rel is not None and abs(rel) <= AGREE_REL:
            row["reason"] = f"agrees within {100 * AGREE_REL:g} %"
        elif row["paper"] is None:
            row["reason"] = "not reported in the paper (our figure for reference)"
        elif rel is not None:
            row["reason"] = "no reason stated by the scenario"
    return row


# ---------------------------------------------------------------------------- seed 002 hooks
# ============================================================================ report
def fmt(v) -> str:
    """How every number appears in the report tables (4 significant digits)."""
    if v is None:
        return "—"
    if isinstance(v, bool):
        return str(v)
    if _num(v):
        v = float(v)
        if math.isnan(v):
            return "nan"
        return f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(fmt(x) for x in v) + "]"
    return str(v)


def _rel(v):
    return "—" if v is None else f"{100 * v:+.1f} %"


def _labels(rows):
    labs = []
    for r in rows:
        for k in r["ours"]:
            if k not in labs:
                labs.append(k)
    return labs


def write_report(results: list, out_dir, total_s=None) -> tuple:
    """``report.md`` and ``report.html`` in ``out_dir`` from the case results."""
    out = Path(out_dir)
    md = ["# mjbench — reproduction report", "",
          "Every paper case run end to end by `mjbench reproduce` (figures in the papers' style, metrics, "
          "a real-time video of the multibody run).  Tables: the paper's reported figure, ours, the "
          "difference (ours − paper, relative to the paper; first 'ours' column) and the stated reason "
          f"where they differ (|difference| > {100 * AGREE_REL:g} %).", ""]
    if total_s is not None:
        md += [f"Total runtime: {total_s:.0f} s.", ""]
    md += [f"Environment: {_env_text()}.", ""]
    md += ["| case | scenario | seed | rows | within 5 % | runtime [s] |", "|---|---|---|---|---|---|"]
    for r in results:
        n_ok = sum(1 for row in r["rows"] if row.get("rel_difference") is not None and abs(row["rel_difference"]) <= AGREE_REL)
        n_cmp = sum(1 for row in r["rows"] if row.get("rel_difference") is not None)
        md.append(f"| [{r['case']}](#{_anchor(r['case'])}) | {r['scenario']} | {r.get('seed') or ''} | "
                  f"{len(r['rows'])} | {n_ok}/{n_cmp} | {r['runtime_s']:.1f} |")
    md.append("")
    for r in results:
        md += _case_md(r)
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


def _table_rows(r):
    labs = _labels(r["rows"])
    head = ["quantity", "unit", "paper"] + [("ours" if b == "ours" else f"ours: {b}") for b in labs] + ["difference", "relative", "reason"]
    body = []
    for row in r["rows"]:
        body.append([row["name"], row.get("unit", ""), fmt(row["paper"])]
                    + [fmt(row["ours"].get(b)) for b in labs]
                    + [fmt(row.get("difference")), _rel(row.get("rel_difference")), row.get("reason", "")])
    return head, body


def _case_md(r):
    case = r["case"]
    md = [f'<a id="{_anchor(case)}"></a>', f"## {case}: {r['title']}", "",
          f"Scenario `{r['scenario']}` (seed {r.get('seed') or '?'}) — {r.get('scenario_title', '')}."]
    if r.get("overrides"):
        md.append(f"Overrides: `{' '.join(r['overrides'])}`.")
    if r.get("note"):
        md.append(r["note"])
    md.append(f"Files: [`{case}/metrics.json`]({case}/metrics.json).")
    md.append("")
    head, body = _table_rows(r)
    if body:
        md.append("| " + " | ".join(head) + " |")
        md.append("|" + "---|" * len(head))
        for b in body:
            md.append("| " + " | ".join(str(x).replace("|", "\\|") for x in b) + " |")
        md.append("")
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
tr.agree td{background:#f1faf1}tr.differ td.rel{background:#fff3e6}
img{max-width:100%;border:1px solid #ddd;margin:.4em 0}video{max-width:100%;background:#000}
.meta{color:#555;font-size:.9em}
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


def _html(results, total_s):
    e = html.escape
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>mjbench reproduction report</title>", f"<style>{_CSS}</style>",
             f"<script>{_CHECK_JS}</script></head><body>",
             "<h1>mjbench — reproduction report</h1>",
             "<p>Every paper case run end to end by <code>mjbench reproduce</code>: figures in the papers' style, "
             "metrics, a real-time video of the multibody run. Tables: the paper's reported figure, ours, the difference "
             "(ours − paper, relative to the paper; first 'ours' column) and the stated reason where they differ "
             f"(|difference| &gt; {100 * AGREE_REL:g} %).</p>"]
    if total_s is not None:
        parts.append(f'<p class="meta">Total runtime: {total_s:.0f} s.</p>')
    parts.append(f'<p class="meta">Environment: {e(_env_text())}.</p>')
    parts.append("<table><tr><th>case</th><th>scenario</th><th>seed</th><th>rows</th><th>runtime [s]</th></tr>")
    for r in results:
        parts.append(f'<tr><td><a href="#{_anchor(r["case"])}">{e(r["case"])}</a></td><td>{e(r["scenario"])}</td>'
                     f'<td>{e(str(r.get("seed") or ""))}</td><td class="num">{len(r["rows"])}</td>'
                     f'<td class="num">{r["runtime_s"]:.1f}</td></tr>')
    parts.append("</table>")
    for r in results:
        case = r["case"]
        parts.append(f'<h2 id="{_anchor(case)}">{e(case)}: {e(r["title"])}</h2>')
        meta = f'Scenario <code>{e(r["scenario"])}</code> (seed {e(str(r.get("seed") or "?"))}) — {e(r.get("scenario_title", ""))}.'
        if r.get("overrides"):
            meta += f' Overrides: <code>{e(" ".join(r["overrides"]))}</code>.'
        meta += f' Files: <a href="{e(case)}/metrics.json">{e(case)}/metrics.json</a>.'
        parts.append(f'<p class="meta">{meta}</p>')
        if r.get("note"):
            parts.append(f"<p>{e(r['note'])}</p>")
        head, body = _table_rows(r)
        if body:
            parts.append('<table class="rows"><tr>' + "".join(f"<th>{e(h)}</th>" for h in head) + "</tr>")
            for row, cells in zip(r["rows"], body):
                rel = row.get("rel_difference")
                cls = "" if rel is None else (" class=\"agree\"" if abs(rel) <= AGREE_REL else " class=\"differ\"")
                tds = []
                for i, c in enumerate(cells):
                    k = "num" if 2 <= i < len(cells) - 1 else ("" if i < 2 else "")
                    if i == len(cells) - 2:
                        k = "num rel"
                    tds.append(f'<td class="{k}">{e(str(c))}</td>' if k else f"<td>{e(str(c))}</td>")
                parts.append(f"<tr{cls}>" + "".join(tds) + "</tr>")
            parts.append("</table>")
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
    parts.append("</body></html>")
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
