"""``mjbench sweep``: grid / Monte Carlo sweeps on the batched backend, locally or on Dask."""
from __future__ import annotations

import os
import sys

from . import add_fast_multibody, apply_fast_multibody, cli_command, given, integer, quantity, refuse_unused
from .. import api
from ..errors import ParameterError
from ..outputs import check_out_dir
from ..sweep import check_scheduler, parse_grid, parse_perturb


def register(sub):
    p = sub.add_parser(
        "sweep", help="grid or Monte Carlo sweep of scenario keys (batched reduced model or MuJoCo, optional Dask)",
        description="Simulate SCENARIO for every combination of --grid values (and/or --samples Monte "
                    "Carlo draws of the --perturb keys) on the batched --backend. Writes "
                    "results.csv (one row per simulation: parameters, status, metrics), sweep.json and "
                    "summary plots into --out. Rerunning with the same arguments resumes: finished rows "
                    "are skipped.")
    p.add_argument("scenario", help="built-in scenario name or TOML path")
    p.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2,...",
                   help="swept scenario key (dotted, as --set, or an alias) and its values; or KEY=lo:hi:n")
    p.add_argument("--samples", type=integer(ge=0), default=0, help="Monte Carlo draws per grid point")
    p.add_argument("--perturb", action="append", default=[], metavar="KEY=R%",
                   help="perturb KEY uniformly within ±R%% of its nominal value (with --samples)")
    p.add_argument("--seed", type=integer(ge=0, le=2 ** 63 - 1), default=None,
                   help="random seed of the Monte Carlo draws (default 0)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value in every row")
    p.add_argument("--mode", help="control mode (default: the scenario's)")
    p.add_argument("--t-end", type=quantity("time", gt=0.0), help="simulated time per run [s] (default: the scenario's)")
    p.add_argument("--out", required=True, help="output directory (resumable)")
    p.add_argument("--chunk", type=integer(ge=1, le=100_000), default=None,
                   help="simulations per batch / Dask task (default: follows the number of rows — all in one batch "
                        "up to 256 (multibody) / 1024 (reduced), at least two chunks per Dask worker)")
    p.add_argument("--backend", default="reduced", choices=["reduced", "multibody"],
                   help="reduced (default: the batched reduced model; the --verify best rows are then re-run on "
                        "the multibody backend) or multibody (MuJoCo, one model per distinct row)")
    p.add_argument("--verify", type=integer(ge=0, le=1000), default=None,
                   help="best rows (smallest --metric) re-run on the multibody backend, written to verify.csv "
                        "(default 3; 0: none)")
    p.add_argument("--threads", type=integer(ge=0, le=1024), default=0, help="threads per chunk (the compiled loop runs the chunk's simulations on them; 0: all CPUs)")
    p.add_argument("--scheduler", help="Dask scheduler address tcp://host:port (pip install mjbench[dask])")
    p.add_argument("--metric", help="metric of the summary plots (default chi_window, else chi_last_cycle)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_fast_multibody(p)
    p.set_defaults(func=cmd_sweep)


@cli_command
def cmd_sweep(args):
    """``mjbench sweep`` = ``mjbench.parameter_sweep`` (docs/api.md)."""

    check_out_dir(args.out, must_be_empty=False)  # resumable: an existing sweep folder is fine
    grid, perturb = parse_grid(args.grid), parse_perturb(args.perturb)
    if not grid and not args.samples:
        raise ParameterError("sweep: give at least one --grid KEY=V1,V2 or --samples N --perturb KEY=R%")
    if given(args, "seed") and not args.samples:
        refuse_unused("--seed", "it seeds the Monte Carlo draws and --samples is 0")
    if given(args, "verify") and args.backend == "multibody":
        refuse_unused("--verify", "it re-runs the best rows of a reduced-model sweep on the multibody backend, and "
                                  "--backend multibody already gives multibody figures")
    if args.threads and args.backend != "multibody" and args.verify == 0:
        refuse_unused("--threads", "it sets MuJoCo's batch threads, and --backend reduced with --verify 0 runs no "
                                   "MuJoCo batch")
    if args.scheduler:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise ParameterError("--scheduler needs Dask: pip install 'mjbench[dask]'") from None
        check_scheduler(args.scheduler)  # a malformed address: one line, before anything else
    res = api.parameter_sweep(args.scenario, grid, samples=args.samples, perturb=perturb, seed=args.seed or 0,
                              mode=args.mode, t_end=args.t_end, overrides=apply_fast_multibody(args, args.overrides),
                              backend=args.backend, verify=3 if args.verify is None else args.verify,
                              metric=args.metric, out=args.out, chunk=args.chunk, threads=args.threads,
                              scheduler=args.scheduler, progress=not args.quiet and sys.stderr.isatty())
    for note in res.notes:
        print(f"mjbench: warning: {note}", file=sys.stderr)
    print(f"{len(res.rows)} simulations ({res.ran} run now, {len(res.rows) - res.ran} resumed) -> "
          f"{os.path.join(args.out, 'results.csv')}")
    ver = res.verified
    if ver:
        print(f"best {len(ver)} rows by {ver[0]['metric']}: {args.backend} → multibody (verify.csv)")
        for v in ver:
            print(f"  row {v['row']}: {v[args.backend]:.6g} → {v['multibody']:.6g} "
                  f"(difference {v['difference']:+.3g}, {100 * v['relative']:+.3g} %)")
    for p in res.plots:
        print(f"plot: {p}")
    return 0
