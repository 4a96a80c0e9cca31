"""``mjbench optimize-law SCENARIO``: minimise the residual energy E(T) of an elastic platform
over the shape parameters of its motion law (Incerti belt, Incerti Bezier); before/after figures, shapers and
ω_n sensitivity.  Writes ``<out>/optimize_law.json`` and PNG plots (atomic writes)."""
from __future__ import annotations

import os
import sys

from ..api.motion_law import paper_check  # noqa: F401 - (the paper digits check, tests/test_vibration.py)
from ..outputs import add_force_option
from . import cli_command
from .. import api
from ..outputs import check_out_dir


def register(sub):
    p = sub.add_parser("optimize-law", help="optimise a motion law against residual vibration (Incerti belt/Bezier)",
                       description=__doc__)
    p.add_argument("scenario", help="built-in scenario name (incerti-belt, incerti-bezier) or TOML path")
    p.add_argument("--out", default=None, help="output folder (default results/<scenario>-optimize-law)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value, e.g. --set law.gammas=[3,4,6] (repeatable)")
    p.add_argument("--no-multibody", action="store_true", help="skip the MuJoCo E(T) check")
    p.add_argument("--no-plots", action="store_true", help="write the JSON only")
    add_force_option(p)
    p.set_defaults(func=main)


@cli_command
def main(args) -> int:
    """``mjbench optimize-law`` = ``mjbench.optimize_motion_law`` → ``LawOptimization.save`` (docs/api.md)."""

    scn = api.load(args.scenario, args.overrides)
    final = args.out or os.path.join("results", f"{scn.name}-optimize-law")
    check_out_dir(final, force=args.force)
    res = api.optimize_motion_law(scn, multibody=False if args.no_multibody else None,
                                   progress=sys.stderr.isatty())
    res.save(final, force=args.force, plots=not args.no_plots, what="--out")
    print(res.summary())
    for w in res.warnings:
        print(f"mjbench: warning: {w}", file=sys.stderr)
    print("  optimize_law.json" + (f" and {len(res.files)} plots" if res.files else ""))
    print(f"  results written to {final}")
    return 0
