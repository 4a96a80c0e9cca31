"""``mjbench analyze``: the reduced model, kinematics and torque demand over one input revolution."""
from __future__ import annotations

import sys

from . import cli_command, integer, quantity
from ..outputs import add_force_option
from .. import api
from .. import units as U
from ..api.analysis import analysis_size
from ..errors import ParameterError
from ..outputs import check_out_dir

#: most samples ``--points`` takes (0.00036° apart); each is checked against the available memory
#: before computing (``mjbench.api.analysis.POINT_BYTES``)
MAX_POINTS = 1_000_000


def register(sub):
    p = sub.add_parser("analyze", help="reduced model, velocity ratios, transmission angles and torque demand "
                                       "over one input revolution (no simulation)",
                       description="Analyse SCENARIO's mechanism over one input revolution: J(q), J'(q), E_p'(q), "
                                   "velocity ratios of every joint, transmission angles, toggle and limit "
                                   "positions, the input torque to run at constant speed and what it asks of the "
                                   "motor through the gearbox.  Writes analysis.json and PNG figures into --out.")
    p.add_argument("scenario", help="built-in scenario name, a TOML file, or a run's manifest.json")
    p.add_argument("--out", help="output directory, written whole or not at all (default: print the summary only)")
    p.add_argument("--speed", action="append", default=[], metavar="SPEED",
                   help="constant input speed, e.g. 30 (rad/s) or '60 rpm'; repeat for several "
                        "(default: the set-points of the scenario's modes)")
    p.add_argument("--points", type=integer(ge=16, le=MAX_POINTS), default=720,
                   help=f"samples over the revolution (16 to {MAX_POINTS:,}; default 720)")
    p.add_argument("--mu-min", type=quantity("ratio", ge=0.0, le=90.0), default=40.0,
                   help="transmission angle [deg] flagged as poor (0-90; default 40)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value")

    add_force_option(p)
    p.set_defaults(func=cmd_analyze)


@cli_command
def cmd_analyze(args):
    """``mjbench analyze`` = ``mjbench.analyze_mechanism`` → ``Analysis.save`` (docs/api.md)."""

    scn = api.load(args.scenario, args.overrides)
    for w in scn.warnings:
        print(f"mjbench: warning: {w}", file=sys.stderr)
    import math

    speeds = []
    for text in args.speed:
        try:
            v = U.to_si(float(text) if _is_number(text) else text, "angular_velocity")
        except U.UnitError as e:
            raise ParameterError(f"--speed {text!r}: {e}") from None
        if not (math.isfinite(v) and abs(v) <= 1e5):
            raise ParameterError(f"--speed {text!r}: must be a finite input speed up to 1e5 rad/s in magnitude")
        speeds.append(v)
    analysis_size(args.points, len(speeds), "--points")
    if args.out:

        check_out_dir(args.out, force=args.force)  # refuse a bad --out before computing
    res = api.analyze_mechanism(scn, speeds, points=args.points, mu_min_deg=args.mu_min)
    if args.out:
        res.save(args.out, force=args.force, what="--out")
    print(res.summary())
    for w in res.warnings:
        print(f"mjbench: warning: {w}", file=sys.stderr)
    if args.out:
        print(f"results written to {args.out}")
    return 0


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True
