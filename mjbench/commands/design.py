"""``mjbench design REQUIREMENTS [--out DIR]``: design a machine from its requirements — linkage
synthesis, motor / gearbox / flywheel sizing from a catalogue, speed-loop tuning and verification
on the multibody backend (mjbench/design/, docs/design.md).  Exit 0: the design meets its
requirements (DIR/machine.toml, design.json, design.md, design.html); 1: it cannot (the closest
candidate and what fails); 2: bad input (every problem of the requirements file in one message).

REQUIREMENTS is a TOML file or a built-in example (press, rocker, function, motion, seed000).

``mjbench design quickreturn [...]`` is the old spelling of the Yiğit & Şen paper study
``mjbench paper yigit2023 design [...]`` (mjbench/commands/paper.py); it still works."""
from __future__ import annotations

import argparse
import sys

from ..outputs import add_force_option
from . import note, paper, refuse_unused
from ..design.pipeline import design
from ..design.report import summary_text

#: the old paper-study spelling `mjbench design quickreturn`
PAPER_TARGETS = ("quickreturn",)


def register(sub):
    p = sub.add_parser("design", help="design a machine from its requirements: linkage synthesis, motor/gearbox/"
                                      "flywheel sizing, tuning, multibody verification",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("requirements", metavar="REQUIREMENTS",
                   help="requirements TOML file or built-in example (press, rocker, function, motion, seed000); "
                        "'quickreturn': the Yiğit & Şen paper study (old spelling of `mjbench paper yigit2023 design`)")
    p.add_argument("--out", help="output folder: machine.toml, design.json, design.md, design.html, design.png")
    add_force_option(p)
    p.add_argument("--no-tune", action="store_true", help="keep the design rule's gains (no mjbench tune stage)")
    p.add_argument("--no-verify", action="store_true",
                   help="no multibody verification (no checks: the design is then not verified, and says so)")
    p.add_argument("--quiet", action="store_true", help="print only the summary")
    paper.add_yigit_options(p, hidden=True)  # the old spelling's options (`design quickreturn --starts 2 ...`)
    p.set_defaults(func=run)


def run(args) -> int:

    if args.requirements in PAPER_TARGETS:
        for opt in ("no_tune", "no_verify", "quiet"):
            if getattr(args, opt):
                refuse_unused("--" + opt.replace("_", "-"), "it belongs to the general design command, not to the "
                                                            "Yiğit & Şen paper study")
        rc = paper.run_yigit_design(args)
        note("design quickreturn", "paper yigit2023 design")
        return rc
    used = paper.yigit_options_given(args)
    if used:
        refuse_unused(used[0], "it is an option of the Yiğit & Şen paper study (`mjbench paper yigit2023 design`)")

    log = (lambda *a: None) if args.quiet else print
    res = design(args.requirements, out=args.out, force=args.force, log=log, verify=not args.no_verify,
                 tune=False if args.no_tune else None)
    if args.quiet:

        print(summary_text(res).splitlines()[0])
    if args.out:
        print(f"wrote {args.out}: {', '.join(res.get('files', []))}", file=sys.stdout)
    if args.no_verify and res["status"] == "ok":
        print("mjbench: note: --no-verify: the design was not simulated; its predictions are unchecked",
              file=sys.stderr)
    return 0 if res["status"] == "ok" else 1
