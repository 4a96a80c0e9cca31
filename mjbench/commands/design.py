"""``mjbench design quickreturn [--starts N] [--seed S] [--bounds LO HI] [--c4 max-abs|signed]
[--eps E] [--local-only] [--out DIR]``: optimum design of the Yiğit & Şen 2023 quick-return
mechanism (Eqs 1-2; mjbench/papers/yigit2023_design.py), compared with their Table I.  The
paper's constraint c4 is read two ways (--c4, docs/quickreturn.md)."""
from __future__ import annotations

import os

from ..errors import ParameterError
from ..outputs import add_force_option, maybe_staged_dir, write_json
from . import add_fast_multibody, apply_fast_multibody

MECHANISMS = ("quickreturn",)


def register(sub):
    p = sub.add_parser("design", help="optimum design of a mechanism (Yiğit & Şen 2023 quick-return, Eqs 1-2)",
                       description=__doc__)
    p.add_argument("mechanism", choices=MECHANISMS)
    p.add_argument("--starts", type=int, default=8, help="number of SLSQP starts (Table I + random; default 8)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the start points")
    p.add_argument("--bounds", type=float, nargs=2, metavar=("LO", "HI"), default=(10.0, 500.0),
                   help="bounds of every design variable [mm] (not given in the paper; default 10 500)")
    p.add_argument("--c4", choices=("max-abs", "signed"), default="max-abs",
                   help="reading of constraint c4 (stroke + r4·sin θ4): 'max-abs' = the largest |rod angle| over "
                        "the swing (default), 'signed' = the signed rod angle at the lever extremes")
    p.add_argument("--eps", type=float, default=1e-3,
                   help="margin of the strict inequalities [mm; TR] (default 1e-3: costs ≈ 0.3 mm of the sum)")
    p.add_argument("--local-only", action="store_true",
                   help="SLSQP from the starts only, no differential evolution (may miss the optimum: the "
                        "feasible set is not connected)")
    p.add_argument("--backend", default="reduced", choices=["reduced", "multibody", "none"],
                   help="closed-loop check of the designs (Yiğit & Şen SMC): reduced (default; the best designs are then "
                        "re-run on the multibody backend and both figures reported), multibody, or none")
    p.add_argument("--verify", type=int, default=1,
                   help="optimum designs re-run on the multibody backend besides Table I (default 1)")
    p.add_argument("--t-end", type=float, help="simulated time of the closed-loop check [s] (default: the scenario's)")
    p.add_argument("--out", help="folder for design.json")
    add_force_option(p)
    add_fast_multibody(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..papers import yigit2023_design as design

    if args.starts < 1:
        raise ParameterError(f"--starts = {args.starts}: need at least 1")
    lo, hi = args.bounds
    if not (0 < lo < hi):
        raise ParameterError(f"--bounds = {lo} {hi}: need 0 < LO < HI [mm]")
    if not (0 <= args.eps < 1):
        raise ParameterError(f"--eps = {args.eps}: need 0 <= EPS < 1 [mm; TR]")
    with maybe_staged_dir(args.out, force=args.force) as out:
        res = design.optimise(starts=args.starts, seed=args.seed, bounds=((lo, hi),) * 5, c4=args.c4, eps=args.eps,
                              global_search=not args.local_only)
        _print(res)
        if args.backend != "none":
            res["dynamics"] = design.dynamic_check(res, backend=args.backend, verify=args.verify, t_end=args.t_end,
                                                   overrides=apply_fast_multibody(args, []))
            print(design.dynamic_table(res["dynamics"]))
        if out is not None:
            write_json(os.path.join(out, "design.json"), res)
    if args.out:
        print(f"wrote {os.path.join(args.out, 'design.json')}")
    return 0 if "best" in res else 1


def _print(res):
    tab = res["table_I"]
    print(f"{'':10s} {'r2':>8s} {'r3':>8s} {'r4':>8s} {'a':>8s} {'b':>8s} {'sum':>8s} {'TR':>6s} "
          f"{'stroke':>8s} {'mu_min':>7s}")

    def row(name, x, f):
        print(f"{name:10s} " + " ".join(f"{v:8.2f}" for v in x) + f" {f['sum_mm']:8.2f} {f['TR']:6.3f} "
              f"{f['stroke_mm']:8.2f} {f['mu_min_deg']:7.2f}")

    row("Table I", tab["x"], tab)
    if "from_table_I" in res:
        row("local*", res["from_table_I"]["x"], res["from_table_I"])
    if "best" in res:
        row("optimum", res["best"]["x"], res["best"])
    else:
        print("no feasible design found; try more --starts or wider --bounds")
    nfeas = sum(r["feasible"] for r in res["runs"])
    print(f"c4 read as {res['c4']}, margin eps = {res['eps']:g}; optimum found by: "
          f"{res['best']['start'] if 'best' in res else '—'}")
    print(f"* local: SLSQP started from Table I.  {nfeas}/{len(res['runs'])} runs ended feasible; "
          f"Table I violates: {tab['violated'] or 'nothing'}")
