"""``mjbench reproduce``: every paper case end to end → figures, metrics.json, video, report.

Cases come from the paper registry (:mod:`mjbench.papers`): each paper module lists its cases
(:class:`mjbench.papers.Case`), its report rows ``rows(ctx)`` and its figures ``figures(ctx)``,
where ``ctx`` is a :class:`CaseRun` (scenario, runs {mode: {backend: Trajectory}}, machines,
metrics, output folder; hooks may also append extra tables to ``ctx.tables`` and warnings to
``ctx.warnings``).  A row is ``{"name", "unit", "paper" (number, [lo, hi] band or None),
"compare" ("value" | "band" | "max" | "min"), "tolerance"?, "fitted"?, "ours" {label: number},
"reason", "headline"?}``; its verdict is computed from the numbers by :mod:`mjbench.verdicts` —
never typed in; ``headline = True`` puts the row among the case's headline numbers
(:func:`mjbench.report.headline`).  For ``kind = "run"`` the rows of the scenario's
``[[paper.figures]]`` (runner.paper_rows) come first; ``kind = "optimize-law"`` runs the
motion-law study (vibration.study); ``kind = "study"`` calls the paper module's ``study(ctx)``.

Outputs per case in ``DIR/<case>/``: PNG figures, ``metrics.json`` (metrics of every mode and
backend + the comparison rows with their verdicts, exactly the numbers the report tables print),
trajectory CSVs, ``video.mp4``; then ``DIR/report.md`` and ``DIR/report.html`` (:mod:`mjbench.report`:
a summary of every case's verdicts, then per case its headline figure, video and headline numbers, the
other figures, and the full tables folded; figures and videos embedded by relative path; a glossary).
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import outputs
from . import scenario as S
from .errors import MjbenchError, ScenarioError
from . import verdicts as V
from .manifest import json_default as _json_default
# report.md / report.html: mjbench/report.py (summary, headline numbers, folded tables)
from .report import GLOSSARY, engineering, fmt, headline, write_report  # noqa: F401
from . import papers
from . import plotstyle
from . import runner
from . import vibration
from .plots import fig4
from .runner import chi_text, setpoint
from . import plotstyle as ps
from .plots import save
from . import render

AGREE_REL = V.TOLERANCE  #: relative tolerance of a point value (mjbench.verdicts)


# ============================================================================ registry
def load_cases(scenarios=None) -> list:
    """Every paper case (optionally only those of the given scenario names), by paper then name."""

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

    t0, c0 = time.perf_counter(), time.process_time()
    out = Path(out_dir) / case.name
    out.mkdir(parents=True, exist_ok=True)

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
        res["headline"] = headline(res["rows"])  # indices of the rows shown next to the headline figure
        res["engineering"] = engineering(res)  # limits, duty, models agree, χ / tracking bound
    res["sim_figures_s"] = time.perf_counter() - t0
    try:  # a video that cannot be made (no OpenGL, encoder) is recorded; the report goes on
        if video and case.video and case.kind in ("run", "design"):
            res["video"] = _video(ctx, quick, progress, width, height)
        elif video and case.video and case.kind == "optimize-law":
            res["video"] = _platform_video(ctx, quick, progress, width, height)
    except MjbenchError as e:
        res["video_error"] = str(e)
    res["runtime_s"] = time.perf_counter() - t0
    res["cpu_s"] = time.process_time() - c0  # this process, every thread (a shared machine inflates runtime_s)
    _write_json(out / "metrics.json", res)
    return res


def _run_kind(ctx: CaseRun, res: dict, progress: bool):

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

    st = vibration.study(ctx.scn)
    ctx.extra["study"] = st
    res["optimize_law"] = json.loads(json.dumps(st["report"], default=_json_default))


def default_figures(ctx: CaseRun, name: str = "timeseries.png"):
    """The time series of the case's runs in the Incerti 2012 Fig. 4 layout (one column per mode,
    every backend drawn, set-point dashed), saved as ``name`` (the Incerti 2012 cases: fig4.png)."""

    sp = next((v for v in (setpoint(ctx.scn, m) for m in ctx.case.modes) if v is not None), None)
    chi = {mode: txt for mode, m in ctx.metrics.items() if (txt := chi_text(m))}
    p = fig4(ctx.runs, ctx.out / name, setpoint=sp, chi=chi or None,
             title=f"{ctx.case.name}: {ctx.case.title or S.get(ctx.scn, 'scenario.title', '')}")
    return [p]


def backend_comparison(trajs: dict, path, title=""):
    """Crank speed of both backends (plotstyle.BACKEND) and their difference, with units."""

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
    """The case's video (real time, 30 fps): its own multibody run of the video mode, the run its
    figures and numbers come from, when the case recorded one that covers the video (frame k shows
    the recorded sample nearest k/30 s, at most half a record step off); else the scenario run
    again on MuJoCo with every step recorded (``render.render_scenario``)."""

    case = ctx.case
    mode = case.video_mode or case.modes[-1]
    t_run = case.t_end or S.get(ctx.scn, "simulation.t_end", 2.0)
    t_vid = case.video_t_end or min(float(t_run), 4.0)
    if quick:
        t_vid = min(t_vid, 2.0)
    w, h = (width or (640 if quick else 960)), (height or (360 if quick else 540))
    tr = _recorded_run(ctx, mode, t_vid)
    if tr is None:
        info = render.render_scenario(ctx.scn, ctx.out / "video.mp4", mode=mode, fps=30, width=w, height=h,
                                      t_end=t_vid, progress=progress, poster=ctx.out / "video_poster.png")
        source = "a multibody run recorded at every step"
    else:
        render.gl_setup()
        machine = ctx.machines.get(mode) or S.make_machine(ctx.scn, mode)
        info = render.render_trajectory(machine, tr, ctx.out / "video.mp4", fps=30, width=w, height=h,
                                        title=f"{ctx.scn.name} — mode {mode} (multibody)", progress=progress,
                                        t_end=t_vid, options=ctx.scn.multibody_options(),
                                        poster=ctx.out / "video_poster.png")
        step = float(np.median(np.diff(tr.t[: min(tr.n, 1000)])))
        source = f"the case's multibody run (samples every {1e3 * step:.3g} ms)"
    out = {"file": "video.mp4", "mode": mode, "frames": info["frames"], "width": w, "height": h,
           "duration_s": info["duration_s"], "render_s": info["wall_s"], "frames_per_s": info["frames_per_s"],
           "source": source}
    if info.get("poster"):  # the still shown before the video plays: the machine running
        out.update(poster="video_poster.png", poster_t_s=info["poster_t_s"])
    return out


def _recorded_run(ctx: CaseRun, mode, t_vid):
    """The multibody trajectory of ``mode`` the case already holds (its run; a design case's
    verification run) if it covers [0, t_vid], else None."""
    tr = (ctx.runs.get(mode) or {}).get("multibody")
    if tr is None and ctx.case.kind == "design":
        tr = ((ctx.extra.get("design") or {}).get("_trajectories") or {}).get("multibody")
    if tr is None or tr.n < 2 or tr.meta.get("diverged") or float(tr.t[-1]) < t_vid - 1e-9:
        return None
    return tr


def _platform_video(ctx: CaseRun, quick, progress, width=None, height=None):
    """Incerti belt / Bezier platforms: the platform driven by the initial, then the optimised law (top view; the
    deflection ψ is shown magnified by a needle, render.PlatformView)."""

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
    if r.get("headline"):  # the paper module's pick for the case's headline numbers (mjbench.report.headline)
        row["headline"] = True
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


# ============================================================================ driver
def _clean(o):
    """JSON-safe copy (NaN/inf → None so that the file is strict JSON; mjbench/outputs.py)."""
    return outputs.clean(o)


def _write_json(path, obj):
    outputs.write_json(path, obj)


def reproduce(which="all", out_dir="results", quick=False, video=True, progress=True, width=None,
              height=None, log=print, jobs=1) -> list:
    """Run the selected cases and write the report; returns the list of case results (report
    order).  ``jobs`` > 1: the cases run in that many worker processes (each case is independent;
    same numbers as in one process), the report is written when all are done."""
    t0, c0 = time.perf_counter(), time.process_time()
    cases = select(load_cases(), which)
    jobs = max(1, min(int(jobs or 1), len(cases)))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results = run_cases(cases, out, dict(quick=quick, video=video, width=width, height=height), progress=progress,
                        log=log, jobs=jobs)
    total = time.perf_counter() - t0
    cpu = time.process_time() - c0 + (sum(r["cpu_s"] for r in results) if jobs > 1 else 0.0)
    md, htm = write_report(results, out, total)
    _write_json(out / "summary.json", {"cases": [r["case"] for r in results], "total_runtime_s": total,
                                       "total_cpu_s": cpu, "jobs": int(jobs),
                                       "cases_runtime_s": {r["case"]: r["runtime_s"] for r in results},
                                       "cases_cpu_s": {r["case"]: r["cpu_s"] for r in results}})
    log(f"report: {md.name} and {htm.name} ({total:.0f} s, CPU {cpu:.0f} s)")
    return results


def _done(r) -> str:
    return (f"{len(r['rows'])} comparison rows, {len(r['figures'])} figures"
            + (f", video {r['video']['frames']} frames" if r.get("video") else "")
            + f" — {r['runtime_s']:.1f} s (CPU {r['cpu_s']:.1f} s)")


def run_cases(cases, out, kw: dict, progress=True, log=print, jobs=1) -> list:
    """:func:`run_case` for every case (keywords ``kw``), in this process or, ``jobs`` > 1, in
    that many worker processes (spawned: each sets up its own OpenGL context and numba; the
    compiled-code cache is shared and written atomically); JSON-safe results in ``cases``' order."""
    n, jobs = len(cases), max(1, min(int(jobs or 1), len(cases) or 1))
    if jobs == 1:
        results = []
        for i, case in enumerate(cases, 1):
            log(f"[{i}/{n}] {case.name} ({case.scenario}, {case.kind}) ...")
            results.append(_clean(run_case(case, out, progress=progress, **kw)))
            log(f"        {_done(results[-1])}")
        return results
    import concurrent.futures as cf
    import multiprocessing as mp

    log(f"{n} cases on {jobs} worker processes ...")
    results = [None] * n
    with cf.ProcessPoolExecutor(jobs, mp_context=mp.get_context("spawn"), initializer=_worker_init) as ex:
        # the longest cases first (longest-processing-time order): a long case started last would
        # leave the other workers idle at the end; the results keep the cases' order
        order = sorted(range(n), key=lambda i: -cost_hint(cases[i]))
        futs = {ex.submit(_worker_case, cases[i], os.fspath(out), kw): i for i in order}
        try:
            for k, f in enumerate(cf.as_completed(futs), 1):
                r = results[futs[f]] = f.result()
                log(f"[{k}/{n}] {r['case']} ({r['scenario']}, {r['kind']}): {_done(r)}")
        except BaseException:
            ex.shutdown(wait=True, cancel_futures=True)
            raise
    return results


def cost_hint(case) -> float:
    """A rough relative cost of a case, to start the longest first: a realistic drive with its
    frequency-response measurement, then the designs (synthesis, sizing, tuning, verification), the
    motion-law optimisations, then plain runs (measured on `make demo`: 50, 15-20, 18, 5-16 s of CPU)."""
    if case.name.endswith("-realdrive"):
        return 4.0
    return {"design": 3.0, "optimize-law": 2.5, "study": 1.0}.get(case.kind, 1.5)


def _worker_init():
    """A worker process: MuJoCo's log file routed like the parent's (the OpenGL backend is set up
    on the first video, as in the parent: ``MUJOCO_GL`` is inherited)."""
    outputs.route_mujoco_log()


def _worker_case(case, out, kw):
    return _clean(run_case(case, Path(out), progress=False, **kw))
