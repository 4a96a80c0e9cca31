"""``mjbench analyze``: the reduced model, kinematics and torque demand over one input revolution."""
from __future__ import annotations

import sys

from . import integer, quantity

#: most samples ``--points`` takes (0.00036° apart); ``POINT_BYTES`` each are checked against the
#: available memory before computing (measured ≈ 1.3 kB per point, press-slidercrank; ×3 margin)
MAX_POINTS = 1_000_000
POINT_BYTES = 4096


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
    import math

    from ..kernel import memory_limit

    speeds = []
    for text in args.speed:
        try:
            v = U.to_si(float(text) if _is_number(text) else text, "angular_velocity")
        except U.UnitError as e:
            raise ParameterError(f"--speed {text!r}: {e}") from None
        if not (math.isfinite(v) and abs(v) <= 1e5):
            raise ParameterError(f"--speed {text!r}: must be a finite input speed up to 1e5 rad/s in magnitude")
        speeds.append(v)
    need, lim = args.points * POINT_BYTES * max(1, len(speeds)), memory_limit()
    if need > lim:
        raise ParameterError(f"--points {args.points:,}: the analysis would need about {need / 2 ** 20:,.0f} MiB, more "
                             f"than {lim / 2 ** 20:,.0f} MiB (half the available memory; MJBENCH_MAX_RECORD_MB "
                             f"overrides): use fewer points")
    if args.out:
        from ..outputs import check_out_dir

        check_out_dir(args.out, force=args.force)  # refuse a bad --out before computing
    res = A.analyze(scn, speeds or None, n=args.points, mu_min_deg=args.mu_min)
    check = None
    if res.get("applicable"):
        from ..plausibility import model_warnings, reduced_vs_mujoco

        # the reduced model against MuJoCo's mass matrix and bias forces (analysis.json "plausibility")
        check = res["plausibility"] = {"model": reduced_vs_mujoco(S.make_mechanism(scn), scn.multibody_options())}
    if args.out:
        from ..outputs import staged_dir

        with staged_dir(args.out, force=args.force) as out:
            A.write(res, out)
    print(A.summary_text(res))
    if check is not None:
        m = check["model"]
        if m.get("applicable"):
            print(f"  reduced model vs MuJoCo at {m['n_angles']} angles: J {m['J_rel_err']:.2g}, J' {m['dJ_rel_err']:.2g}, "
                  f"E_p' {m['dEp_rel_err']:.2g} (relative; tolerance {m['tolerance']:g})")
        for w in model_warnings(m):
            print(f"mjbench: warning: {w.replace('metrics.json', 'analysis.json')}", file=sys.stderr)
    if args.out:
        print(f"results written to {args.out}")
    return 0


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True
