"""``mjbench run`` and ``mjbench list``."""
from __future__ import annotations

import sys
import warnings

from . import add_fast_multibody, apply_fast_multibody, cli_command, quantity, refuse_unused
from ..outputs import add_force_option
from .. import api
from ..outputs import check_out_dir
from ..registry import PluginWarning


def register(sub):
    p = sub.add_parser("run", help="simulate a scenario on one or both backends and write results",
                       description="Simulate SCENARIO (built-in name or TOML path). Writes trajectory CSV(s), "
                                   "metrics.json, manifest.json and a Fig.-4-style PNG into --out.")
    p.add_argument("scenario", help="built-in scenario name (see `mjbench list`), a TOML file, or a run's "
                                    "manifest.json (repeats that run)")
    p.add_argument("--mode", help="control mode defined in the scenario, e.g. open, pid (default: the scenario's)")
    p.add_argument("--backend", default=None, choices=["multibody", "reduced", "both"],
                   help="simulator backend (default: the scenario's, else both)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value, e.g. --set drive.R=2.5 --set modes.pid.kp=100")
    p.add_argument("--t-end", type=quantity("time", gt=0.0), help="simulated time [s] (default: the scenario's)")
    p.add_argument("--out", required=True, help="output directory (written whole or not at all: docs/outputs.md)")
    add_force_option(p)
    p.add_argument("--no-figure", action="store_true", help="skip the PNG")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.add_argument("--verbose", action="store_true",
                   help="also print which loop ran each backend (compiled or CPython) and why (metrics.json \"loop\")")
    add_fast_multibody(p)
    p.set_defaults(func=cmd_run)

    q = sub.add_parser("list", help="list the scenarios (built-in and plugins) with their modes, and the mechanism, "
                                    "controller and drive types (plugins included)")
    q.set_defaults(func=cmd_list)


@cli_command
def cmd_run(args):
    """``mjbench run`` = ``mjbench.load`` → ``simulate`` → ``Result.save`` (docs/api.md)."""

    scn = api.load(args.scenario, apply_fast_multibody(args, args.overrides))
    for w in scn.warnings:
        print(f"mjbench: warning: {w}", file=sys.stderr)
    backend = args.backend or scn.default_backend  # a run's manifest: that run's, unless told otherwise
    if getattr(args, "fast_multibody", None) and backend == "reduced":
        refuse_unused("--fast-multibody", "it sets the multibody integrator and --backend reduced runs no multibody "
                                          "simulation")
    scn.check(args.mode)  # bad values: one message before simulating
    check_out_dir(args.out, force=args.force)  # an unusable --out: before simulating too
    res = api.simulate(scn, args.mode, backend, args.t_end, progress=not args.quiet and sys.stderr.isatty(),
                       check=False)
    res.save(args.out, force=args.force, figure=not args.no_figure, argv=sys.argv, what="--out")
    if not args.quiet:
        print(res.summary())
        print(f"results written to {args.out}")
    if args.verbose:
        for b, how in res.metrics.get("loop", {}).items():
            why = how.get("loop_reason") or ""
            print(f"loop {b}: {how.get('loop', '')}" + (f" ({why})" if why else ""))
    for w in res.warnings:
        print(f"mjbench: warning: {w}", file=sys.stderr)
    return 0


@cli_command
def cmd_list(args):
    """``mjbench list`` = ``mjbench.list_scenarios`` + ``mjbench.load``, then ``mjbench.list_components``."""

    for name in api.list_scenarios():
        try:
            scn = api.load(name)
        except Exception as e:  # noqa: BLE001 - listing must not die on one bad file
            print(f"{name:<22s} (cannot load: {e})")
            continue
        modes = ", ".join(scn.modes) + (" + optimize-law" if scn.spec.law is not None else "")
        print(f"{name:<22s} modes: {modes:<18s} {scn.title}")
    with warnings.catch_warnings(record=True) as caught:  # a broken plugin: one line each, the rest listed
        warnings.simplefilter("always", PluginWarning)
        comps = api.list_components()
    for w in caught:
        if issubclass(w.category, PluginWarning):
            print(f"mjbench: warning: {w.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    for kind in ("mechanism", "controller", "drive"):
        print(f"\n{kind} types:")
        for c in (c for c in comps if c.kind == kind):
            tune = "; ".join(f"{t} ({', '.join(g)})" for t, g in c.tunable.items())
            print(f"  {c.name:<14s} {c.origin:<10s} {c.source}" + (f"  tune --controller {tune}" if tune else ""))
    return 0
