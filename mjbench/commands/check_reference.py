"""``mjbench demand SCENARIO --set vc=0.3``: what a coupler-speed reference demands (peak crank
speed, acceleration, torque, current, voltage) and whether the motor can deliver it, before
simulating (mjbench/papers/hulako2025_demand.py)."""
from __future__ import annotations

from ..outputs import dumps


def register(sub):
    p = sub.add_parser("demand", help="peak speed/torque/voltage a coupler-speed reference demands (Hülako & Çakar)",
                       description=__doc__)
    p.add_argument("scenario", help="built-in scenario name or TOML path (e.g. hulako2025-model1)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value or alias, e.g. vc=0.3 (repeatable)")
    p.add_argument("--mode", default=None, help="controller mode (default: simulation.mode)")
    p.add_argument("--vc", type=float, nargs="*", default=None,
                   help="several desired coupler speeds [m/s] at once, e.g. --vc 0.1 0.2 0.3 0.4")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run)


def run(args):
    from ..papers import hulako2025_demand as gains
    from .. import scenario as S

    vcs = args.vc if args.vc else [None]
    results = []
    for vc in vcs:
        sets = list(args.set) + ([f"vc={vc}"] if vc is not None else [])
        scn = S.load(args.scenario, sets)
        r = gains.from_scenario(scn, args.mode)
        results.append(r)
        if not args.json:
            vcv = S.get(scn, "modes.pid.reference.vc")
            print(f"{scn.name}: desired coupler speed V_C = {vcv} m/s")
            print(gains.format_report(r))
    if args.json:
        print(dumps(results if len(results) > 1 else results[0], indent=1))  # strict JSON (outputs.py)
    return 1 if any(r.get("voltage_saturated") for r in results) else 0
