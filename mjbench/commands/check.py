"""``mjbench check``: the law contract of a scenario's components, before a long run needs it."""
from __future__ import annotations

from . import cli_command, quantity
from .. import api, runner


def register(sub):
    p = sub.add_parser("check", help="check the laws of a scenario's controllers and references (the law contract, "
                                     "their signals, CPython against the bounds-checked compiled loop)",
                       description="Compose each mode of SCENARIO on each backend the way a run does: every control "
                                   "law's contract is checked (a broken law is one line naming the component, the law, "
                                   "the rule and the line), its signals are listed, and a short run in CPython is "
                                   "compared bit for bit with the compiled loop run with every array access "
                                   "bounds-checked (MJBENCH_JIT=check).  Exit 0: all good; 1: the loops disagree; "
                                   "2: a law breaks the contract.")
    p.add_argument("scenario", help="built-in scenario name or a TOML file (its modes use the components to check)")
    p.add_argument("--mode", help="one mode (default: every mode)")
    p.add_argument("--backend", default="both", choices=["multibody", "reduced", "both"])
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value")
    p.add_argument("--t-end", type=quantity("time", gt=0.0), default=0.05,
                   help="simulated time of the comparison run [s] (default 0.05)")
    p.set_defaults(func=cmd_check)


@cli_command
def cmd_check(args):

    scn = api.load(args.scenario, args.overrides)
    modes = [scn.mode(args.mode)] if args.mode else list(scn.modes)
    bad = 0
    for mode in modes:
        scn.check(mode)
        for row in runner.check_mode(scn.spec, mode, runner.backends_of(args.backend), float(args.t_end)):
            print(f"mode {mode}, {row['backend']}:")
            for what, name, reads, writes in row["laws"]:
                print(f"  {what}: law {name} reads {', '.join(reads) or 'nothing'}; writes {', '.join(writes)}")
            if not row["compiled"]:
                print(f"  CPython only: {row['reason']}")
            elif row["agree"] is None:
                print("  compiles (numba is not installed: the compiled loop was not run)")
            elif row["agree"]:
                print(f"  compiled loop (bounds-checked) = CPython loop, bit for bit over {float(args.t_end):g} s")
            else:
                print(f"  MISMATCH: the compiled loop and the CPython loop differ over {float(args.t_end):g} s")
                bad = 1
    return bad
