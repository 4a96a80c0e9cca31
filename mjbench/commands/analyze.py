"""``mjbench analyze``: the reduced model, kinematics and torque demand over one input revolution."""
from __future__ import annotations

import sys


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
    p.add_argument("--points", type=int, default=720, help="samples over the revolution (default 720)")
    p.add_argument("--mu-min", type=float, default=40.0, help="transmission angle [deg] flagged as poor (default 40)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value")
    from ..outputs import add_force_option

    add_force_option(p)
    p.set_defaults(func=cmd_analyze)


def cmd_analyze(args):
    from .. import analyze as A
    from .. import scenario as S
    from .. import units as U
    from ..errors import ParameterError

    scn = S.load(args.scenario, args.overrides)
    for w in scn.warnings:
        print(f"mjbench: warning: {w}", file=sys.stderr)
    speeds = []
    for text in args.speed:
        try:
            v = U.to_si(float(text) if _is_number(text) else text, "angular_velocity")
        except U.UnitError as e:
            raise ParameterError(f"--speed {text!r}: {e}") from None
        speeds.append(v)
    if args.out:
        from ..outputs import check_out_dir

        check_out_dir(args.out, force=args.force)  # refuse a bad --out before computing
    res = A.analyze(scn, speeds or None, n=args.points, mu_min_deg=args.mu_min)
    if args.out:
        from ..outputs import staged_dir

        with staged_dir(args.out, force=args.force) as out:
            A.write(res, out)
    print(A.summary_text(res))
    if args.out:
        print(f"results written to {args.out}")
    return 0


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True
