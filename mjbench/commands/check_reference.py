"""``mjbench demand SCENARIO --set vc=0.3``: what a coupler-speed reference demands (peak crank
speed, acceleration, torque, current, voltage) and whether the motor can deliver it, before
simulating (mjbench/papers/hulako2025_demand.py)."""
from __future__ import annotations

from ..outputs import dumps
from . import quantity
from ..papers import hulako2025_demand as gains
from .. import scenario as S
from ..errors import MjbenchError, ParameterError
from . import note


def register(sub, paper_study=False):
    p = sub.add_parser("demand", help="peak speed/torque/voltage a coupler-speed reference demands (Hülako & Çakar)"
                       + ("" if paper_study else "; paper study, also `mjbench paper hulako2025 demand`"),
                       description=__doc__)
    if paper_study:  # `mjbench paper hulako2025 demand [SCENARIO]` (commands/paper.py)
        p.add_argument("scenario", nargs="?", default="hulako2025-model1",
                       help="built-in scenario name or TOML path (default hulako2025-model1)")
    else:
        p.add_argument("scenario", help="built-in scenario name or TOML path (e.g. hulako2025-model1)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value or alias, e.g. vc=0.3 (repeatable)")
    p.add_argument("--mode", default=None, help="controller mode (default: simulation.mode)")
    p.add_argument("--vc", type=quantity("speed", gt=0.0), nargs="*", default=None,
                   help="several desired coupler speeds [m/s] at once, e.g. --vc 0.1 0.2 0.3 0.4")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run, paper_study=paper_study)


def run(args):


    if args.vc is not None and not args.vc:
        raise ParameterError("--vc needs at least one desired coupler speed [m/s], e.g. --vc 0.1 0.2")
    if args.vc:
        base = S.load(args.scenario, args.set)
        if "vc" not in base.aliases:
            raise ParameterError(f"--vc: scenario {base.name!r} has no coupler-speed reference (no alias vc); "
                                 f"`mjbench demand` is for coupler-speed scenarios such as hulako2025-model1")
    vcs = args.vc if args.vc else [None]
    results = []
    for vc in vcs:
        sets = list(args.set) + ([f"vc={vc!r}"] if vc is not None else [])
        scn = S.load(args.scenario, sets)
        try:
            r = gains.from_scenario(scn, args.mode)
        except MjbenchError:
            raise
        except (ValueError, TypeError, AttributeError, ArithmeticError) as e:
            what = f" with --vc {vc:g}" if vc is not None else (f" with --set {' --set '.join(args.set)}" if args.set else "")
            raise ParameterError(f"demand: scenario {scn.name!r}{what}: {e}") from None
        results.append(r)
        if not args.json:
            vcv = S.get(scn, "modes.pid.reference.vc")
            print(f"{scn.name}: desired coupler speed V_C = {vcv} m/s")
            print(gains.format_report(r))
    if args.json:
        print(dumps(results if len(results) > 1 else results[0], indent=1))  # strict JSON (outputs.py)
    if not getattr(args, "paper_study", False):
        note("demand", "paper hulako2025 demand")
    sat = [r for r in results if r.get("voltage_saturated")]
    if sat:  # the exit status says a reference asks more than the supply gives (a check, not an error)
        import sys

        print(f"mjbench: exit status 1: {len(sat)} of {len(results)} references need more than the supply voltage "
              f"(the warnings above say which and by how much)", file=sys.stderr)
        return 1
    return 0
