"""``mjbench reproduce CASE|all --out DIR``: paper cases end to end → figures, metrics, videos,
``DIR/report.md`` + ``DIR/report.html`` (see mjbench/reproduce.py, docs/show_it.md)."""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco's renderer

from . import cli_command  # noqa: E402
from .. import api
from .. import reproduce as R
from ..errors import ParameterError
from .. import outputs, render
from . import MAX_HEIGHT, MAX_WIDTH, check_frame, given, integer, refuse_unused
from .. import report as RP


def add_common(p, out_required=True):
    p.add_argument("--out", required=out_required, default=None, help="output folder (report.md, report.html, one folder per case)")
    p.add_argument("--quick", action="store_true",
                   help="short videos (≤ 2 s, 640x360); simulations and figures unchanged")
    p.add_argument("--no-video", action="store_true", help="skip the videos")

    p.add_argument("--width", type=integer(ge=16, le=MAX_WIDTH), default=None,
                   help="video width [px] (even; default 960, --quick 640)")
    p.add_argument("--height", type=integer(ge=16, le=MAX_HEIGHT), default=None,
                   help="video height [px] (even; default 540, --quick 360)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.add_argument("--jobs", type=integer(ge=1, le=64), default=1,
                   help="run the cases in N worker processes side by side (default 1; `make demo`: 2); "
                        "the numbers do not depend on it")
    p.add_argument("--force", action="store_true",
                   help="replace a non-empty --out folder (the old one is kept until the new report is complete)")


def register(sub):
    p = sub.add_parser("reproduce", help="run the paper cases end to end and write a report",
                       description=__doc__)
    p.add_argument("case", nargs="?", default="all",
                   help="case name, scenario name (all its cases) or 'all' (default); see --list")
    p.add_argument("--list", action="store_true", help="list the registered cases and exit")
    add_common(p, out_required=False)
    p.set_defaults(func=run, gl=True)


def list_cases():

    for c in api.paper_cases():
        extra = f" modes {','.join(c.modes)}" if c.modes else ""
        print(f"{c.name:<28s} {c.paper:<18s} {c.scenario:<22s} {c.kind:<12s}{extra}  {c.title}")
    return 0


@cli_command
def run(args) -> int:
    """``mjbench reproduce`` = ``mjbench.reproduce_papers`` (docs/api.md)."""
    import sys


    if args.list:
        return list_cases()
    if not args.out:
        raise ParameterError("mjbench reproduce: --out DIR is required (the report folder)")
    R.select(R.load_cases(), args.case)  # an unknown case name: an error before anything is written
    check_video_options(args)
    with_gl(args)
    results = api.reproduce_papers(args.out, args.case, quick=args.quick, video=not args.no_video, width=args.width,
                                   height=args.height, force=args.force,
                                   progress=not args.no_progress and sys.stderr.isatty(), log=print, what="--out",
                                   jobs=args.jobs)
    print(f"results written to {args.out}")
    print(closing_lines(results, args.out))
    return 0


def closing_lines(results, out) -> str:
    """What a finished report run ends with: the verdict counts and the page to open."""
    import os

    page = os.path.join(os.path.abspath(os.fspath(out)), "report.html")
    cases = [r for r in results or [] if isinstance(r, dict) and "rows" in r]
    if not cases:
        return f"open the report: {page}"
    eng = RP._eng_counts(cases)
    tot = RP._totals(cases)
    return (f"{len(cases)} cases — engineering verdicts: {eng['ok']} met, {eng['fail']} not met, {eng['na']} not "
            f"applicable or not stated; paper figures: {tot['meet']} meet, {tot['differ']} differ, {tot['fitted']} "
            f"fitted, {tot['unjudged']} rows without a paper figure\n"
            f"open the report: {page}")


def check_video_options(args):
    """--width/--height: a valid frame, and only when videos are made (else they are refused)."""

    if args.no_video:
        for opt in ("width", "height"):
            if given(args, opt):
                refuse_unused(f"--{opt}", "--no-video makes no video")
        return
    w, h = args.width, args.height
    if w is not None or h is not None:
        check_frame(w if w is not None else (640 if args.quick else 960), h if h is not None else (360 if args.quick else 540))


def with_gl(args):
    """Choose the OpenGL backend for the videos; without one, the cases run and the report says
    why each video is missing (the simulations need no OpenGL)."""
    import sys


    if not args.no_video:
        try:
            render.gl_setup()
        except render.RenderError as e:
            print(f"mjbench: warning: {e} The report is written without videos.", file=sys.stderr)
    outputs.route_mujoco_log()
