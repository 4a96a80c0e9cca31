"""``mjbench paper STUDY COMMAND``: the paper-specific tools, apart from the general commands.

    mjbench paper yigit2023 design [--starts N] [--c4 max-abs|signed] ...   Yiğit & Şen 2023: optimum
                                                                           quick-return (Eqs 1-2)
    mjbench paper hulako2025 demand [SCENARIO] [--vc ...]                   Hülako & Çakar 2025: what a
                                                                           coupler-speed reference demands
    mjbench paper incerti2012 calibrate [SCENARIO] [--params ...]           Incerti 2012: fit of the
                                                                           illegible Table I values

The old spellings (``mjbench design quickreturn``, ``mjbench demand``, ``mjbench calibrate``) still
work and say where the study now lives; ``mjbench design`` is the general design command
(docs/design.md).
"""
from __future__ import annotations

import argparse
import os
import sys
from ..errors import ParameterError
from ..outputs import maybe_staged_dir, write_json
from ..outputs import check_out_dir
from ..outputs import add_force_option
from .. import papers
from . import add_fast_multibody, apply_fast_multibody, calibrate, check_reference, given, integer, quantity, refuse_unused

#: study → (paper title, {command: help})
STUDIES = {
    "yigit2023": ("Yiğit & Şen 2023, quick-return mechanism + SMC",
                  {"design": "optimum design of the quick-return mechanism (Eqs 1-2), closed-loop check"}),
    "hulako2025": ("Hülako & Çakar 2025, four-bar with constant coupler-point speed",
                   {"demand": "peak speed/torque/voltage a coupler-speed reference demands"}),
    "incerti2012": ("Incerti 2012, four-bar + DC motor + PID K_p·t",
                    {"calibrate": "fit the missing (illegible) Table I values to the paper's χ figures"}),
}

#: the Yiğit & Şen design study's option defaults (also applied to the old spelling `design quickreturn`);
#: ``verify`` stays None when not given (it is refused with --backend multibody / none)
YIGIT_DEFAULTS = {"starts": 8, "seed": 0, "bounds": (10.0, 500.0), "c4": "max-abs", "eps": 1e-3, "local_only": False,
                  "backend": "reduced", "verify": None, "t_end": None, "fast_multibody": None}


def add_yigit_options(p, hidden=False):
    """The options of the Yiğit & Şen design study; ``hidden``: accepted but not listed, default
    None (the old spelling ``mjbench design quickreturn`` on the general design command)."""

    H = (lambda text: argparse.SUPPRESS) if hidden else (lambda text: text)
    D = (lambda k: None) if hidden else (lambda k: YIGIT_DEFAULTS[k])
    p.add_argument("--starts", type=integer(ge=1, le=10_000), default=D("starts"),
                   help=H("number of SLSQP starts (Table I + random; default 8)"))
    p.add_argument("--seed", type=integer(ge=0, le=2 ** 32 - 1), default=D("seed"),
                   help=H("random seed of the start points"))
    p.add_argument("--bounds", type=float, nargs=2, metavar=("LO", "HI"), default=D("bounds"),
                   help=H("bounds of every design variable [mm] (not given in the paper; default 10 500)"))
    p.add_argument("--c4", choices=("max-abs", "signed"), default=D("c4"),
                   help=H("reading of constraint c4 (stroke + r4·sin θ4): 'max-abs' = the largest |rod angle| over "
                          "the swing (default), 'signed' = the signed rod angle at the lever extremes"))
    p.add_argument("--eps", type=quantity("ratio", ge=0.0, lt=1.0), default=D("eps"),
                   help=H("margin of the strict inequalities [mm; TR] (default 1e-3: costs ≈ 0.3 mm of the sum)"))
    p.add_argument("--local-only", action="store_true", default=D("local_only"),
                   help=H("SLSQP from the starts only, no differential evolution (may miss the optimum: the "
                          "feasible set is not connected)"))
    p.add_argument("--backend", default=D("backend"), choices=["reduced", "multibody", "none"],
                   help=H("closed-loop check of the designs (Yiğit & Şen SMC): reduced (default; the best designs are "
                          "then re-run on the multibody backend and both figures reported), multibody, or none"))
    p.add_argument("--verify", type=integer(ge=0, le=100), default=None,
                   help=H("optimum designs re-run on the multibody backend besides Table I (default 1)"))
    p.add_argument("--t-end", type=quantity("time", gt=0.0), default=None,
                   help=H("simulated time of the closed-loop check [s] (default: the scenario's)"))
    if not hidden:

        add_fast_multibody(p)
    else:
        p.add_argument("--fast-multibody", choices=["Euler", "implicitfast"], default=None, help=argparse.SUPPRESS)


def yigit_options_given(args) -> list:
    """The Yiğit & Şen options given on the general design command line (hidden ones)."""
    return ["--" + k.replace("_", "-") for k in YIGIT_DEFAULTS if getattr(args, k, None) not in (None, False)]


def run_yigit_design(args) -> int:
    """The Yiğit & Şen 2023 optimum design (mjbench/papers/yigit2023_design.py)."""
    design = papers.yigit2023_design  # (scipy.optimize: loaded on first use, mjbench/papers/__init__.py)

    for k, v in YIGIT_DEFAULTS.items():
        if getattr(args, k, None) is None and v is not None:
            setattr(args, k, v)
    if args.starts < 1:
        raise ParameterError(f"--starts = {args.starts}: need at least 1")
    lo, hi = args.bounds
    if not (0 < lo < hi < float("inf")):
        raise ParameterError(f"--bounds = {lo} {hi}: need 0 < LO < HI [mm]")
    if not (0 <= args.eps < 1):
        raise ParameterError(f"--eps = {args.eps}: need 0 <= EPS < 1 [mm; TR]")
    if args.backend == "none":
        for opt, name in (("--verify", "verify"), ("--t-end", "t_end"), ("--fast-multibody", "fast_multibody")):
            if given(args, name):
                refuse_unused(opt, "--backend none runs no closed-loop check")
    elif given(args, "verify") and args.backend == "multibody":
        refuse_unused("--verify", "it re-runs reduced-model checks on the multibody backend, and --backend multibody "
                                  "checks on MuJoCo itself")
    if args.out:

        check_out_dir(args.out, force=args.force)
    verify = 1 if args.verify is None else args.verify
    with maybe_staged_dir(args.out, force=args.force) as out:
        res = design.optimise(starts=args.starts, seed=args.seed, bounds=((lo, hi),) * 5, c4=args.c4, eps=args.eps,
                              global_search=not args.local_only)
        _print_yigit(res)
        if args.backend != "none":
            res["dynamics"] = design.dynamic_check(res, backend=args.backend, verify=verify, t_end=args.t_end,
                                                   overrides=apply_fast_multibody(args, []))
            print(design.dynamic_table(res["dynamics"]))
        if out is not None:
            write_json(os.path.join(out, "design.json"), res)
    if args.out:
        print(f"wrote {os.path.join(args.out, 'design.json')}")
    return 0 if "best" in res else 1


def _print_yigit(res):
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


def register(sub):

    p = sub.add_parser("paper", help="paper studies: yigit2023 design, hulako2025 demand, incerti2012 calibrate",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    studies = p.add_subparsers(dest="study", metavar="STUDY")
    studies.required = True
    for key, (title, cmds) in STUDIES.items():
        s = studies.add_parser(key, help=f"{title}: {', '.join(cmds)}", description=title)
        c = s.add_subparsers(dest="paper_command", metavar="COMMAND")
        c.required = True
        if key == "yigit2023":
            d = c.add_parser("design", help=cmds["design"],
                             description="Optimum design of the Yiğit & Şen 2023 quick-return mechanism (Eqs 1-2; "
                                         "mjbench/papers/yigit2023_design.py), compared with their Table I. The "
                                         "paper's constraint c4 is read two ways (--c4, docs/quickreturn.md).")
            add_yigit_options(d)
            d.add_argument("--out", help="folder for design.json")
            add_force_option(d)
            d.set_defaults(func=run_yigit_design, paper_study=True)
        elif key == "hulako2025":
            check_reference.register(c, paper_study=True)
        elif key == "incerti2012":
            calibrate.register(c, paper_study=True)
