"""``mjbench demo --out DIR``: ``make demo`` — every paper case with short videos
(``mjbench reproduce all --quick``), then prints where the report is."""
from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco's renderer

from . import cli_command  # noqa: E402
from .reproduce import add_common
from .. import api
from .reproduce import check_video_options, with_gl
from .reproduce import closing_lines


def register(sub):

    p = sub.add_parser("demo", help="run every paper case (short videos) and write DIR/report.html",
                       description=__doc__)
    add_common(p)
    p.set_defaults(func=run, quick=True, gl=True)


@cli_command
def run(args) -> int:
    """``mjbench demo`` = ``mjbench.reproduce_papers(out, quick=True)`` (docs/api.md)."""
    import sys
    import time


    check_video_options(args)
    t0 = time.perf_counter()
    with_gl(args)
    results = api.reproduce_papers(args.out, "all", quick=True, video=not args.no_video, width=args.width,
                                   height=args.height, force=args.force,
                                   progress=not args.no_progress and sys.stderr.isatty(), log=print, what="--out",
                                   jobs=args.jobs)
    out = os.path.abspath(args.out)
    print(f"demo done in {time.perf_counter() - t0:.0f} s (or read {os.path.join(out, 'report.md')})")
    print(closing_lines(results, args.out))
    return 0
