"""``mjbench tune``: autotune controller gains (batched global search + Nelder–Mead + validation)."""
from __future__ import annotations

from . import add_fast_multibody, apply_fast_multibody, cli_command, given, integer, parse_numbers, quantity, refuse_unused
from ..outputs import add_force_option
from ..errors import ParameterError
from .. import api
from ..linear import parse_margin
from ..tune import tune_spec
from ..outputs import check_out_dir


def register(sub):
    p = sub.add_parser(
        "tune", help="autotune controller gains (search on the reduced model, verify on MuJoCo)",
        description="Search the gains of the scenario's controller minimising --objective: a global stage "
                    "(Sobol candidates simulated together on the --backend's batch), local Nelder-Mead "
                    "refinement, then the --verify best candidates re-run on the multibody backend "
                    "and the scenario's own gains on the single-run multibody backend; the report states both "
                    "backends' figures. Peaks of |voltage| and |current| above --limit are penalised "
                    "(default limits: the peaks of the scenario's gains).")
    p.add_argument("scenario", help="built-in scenario name or TOML path")
    p.add_argument("--controller", required=True, metavar="NAME",
                   help="a controller type that declares its tunable gains (Controller.TUNABLE; `mjbench list` "
                        "shows them, plugins included): pid: constant K_p; pid-tv: K_p·t (Incerti 2012 Eq 15); "
                        "smc: sliding mode (λ, K); servo: cascade servo tracking a motion law (K_pp, K_vp, K_vi)")
    p.add_argument("--objective", default="chi",
                   choices=["chi", "chi_cycle", "ise", "iae", "itae", "tracking_rms", "tracking_peak"],
                   help="chi: χ on the scenario's metrics.chi_window (default); chi_cycle: last crank cycle; "
                        "ise/iae/itae: crank-speed error to the set-point; tracking_rms/tracking_peak: crank-angle "
                        "error to a motion-law reference (over metrics.chi_window, else the run)")
    p.add_argument("--limit", action="append", default=[], metavar="voltage=V,current=A",
                   help="allowed peak |voltage| [V] and |current| [A]")
    p.add_argument("--margin", action="append", default=[], metavar="'pm>=45'",
                   help="robustness constraint on the linear model (worst frozen angle), quoted for the shell: 'pm>=DEG', 'gm>=DB', "
                        "'ms<=PEAK_S', 'bw>=RAD_S' (repeatable; docs/linear.md)")
    p.add_argument("--margin-mode", choices=["penalty", "constraint"], default=None,
                   help="penalty: objective + 10 × relative violation (default); constraint: violating "
                        "candidates are not simulated, and exit status 1 when no candidate meets them")
    p.add_argument("--margin-angles", type=integer(ge=1, le=3600), default=None,
                   help="frozen angles for the margins (default 12)")
    p.add_argument("--bounds", action="append", default=[], metavar="GAIN=LO:HI",
                   help="search interval of a gain (default: scenario value ×/÷ --span)")
    p.add_argument("--span", type=quantity("ratio", gt=1.0), default=None,
                   help="default search factor around the scenario's gains (> 1; default 10)")
    p.add_argument("--global", dest="n_global", type=integer(ge=1, le=100_000), default=64,
                   help="global-stage candidates (default 64)")
    p.add_argument("--starts", type=integer(ge=0, le=1000), default=1,
                   help="local refinements from the best global candidates")
    p.add_argument("--maxfev", type=integer(ge=1, le=100_000), default=80, help="simulations per local refinement")
    p.add_argument("--t-end", type=quantity("time", gt=0.0), help="simulated time per candidate [s] (default: χ window end)")
    p.add_argument("--backend", default="reduced", choices=["reduced", "multibody"],
                   help="search backend (default reduced: the batched reduced model; the best candidates are then "
                        "re-run on the multibody backend and both figures reported)")
    p.add_argument("--verify", type=integer(ge=0, le=1000), default=None,
                   help="best distinct candidates re-run on the multibody backend (default 3; 0: only the winner)")
    p.add_argument("--seed", type=integer(ge=0, le=2 ** 32 - 1), default=0)
    p.add_argument("--threads", type=integer(ge=0, le=1024), default=0, help="MuJoCo batch threads (0: all CPUs)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--out", help="write tune.json and a speed comparison plot here")
    add_force_option(p)
    add_fast_multibody(p)
    p.set_defaults(func=cmd_tune)


def parse_limits(items):
    """``--limit voltage=48V,current=30A`` → {"voltage": 48.0, "current": 30.0} (each > 0)."""

    out = parse_numbers(items, "--limit", [("voltage", "V"), ("current", "A")], suffix="VA")
    for k, v in out.items():
        if v <= 0:
            raise ParameterError(f"--limit {k}={v:g}: must be > 0")
    return out


def parse_bounds(items, gains=None):
    """``--bounds GAIN=LO:HI`` → {gain: (lo, hi)}; ``gains``: the controller's gain names (an
    unknown name, a gain given twice, or a bad interval is ONE error)."""
    import math


    out = {}
    for item in items:
        try:
            k, v = item.split("=", 1)
            lo, hi = (float(x) for x in v.split(":"))
        except ValueError:
            raise ParameterError(f"--bounds {item!r}: expected GAIN=LO:HI"
                                 + (f" with GAIN one of {', '.join(gains)}" if gains else "")) from None
        k = k.strip()
        if gains is not None and k not in gains:
            raise ParameterError(f"--bounds {item!r}: {k!r} is not a gain of this controller; its gains are "
                                 f"{', '.join(gains)}")
        if k in out:
            raise ParameterError(f"--bounds {k} is given twice")
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
            raise ParameterError(f"--bounds {item!r}: need finite 0 < LO < HI (gains are searched in log scale)")
        out[k] = (lo, hi)
    return out


@cli_command
def cmd_tune(args):
    """``mjbench tune`` = ``mjbench.tune_gains`` → ``TuneResult.save`` (docs/api.md)."""
    import sys


    gains = tune_spec(args.controller).params
    limits, bounds = parse_limits(args.limit), parse_bounds(args.bounds, gains)
    for m in args.margin:
        parse_margin(m)  # a malformed --margin: one message before anything runs
    if not args.margin:
        for opt, name in (("--margin-mode", "margin_mode"), ("--margin-angles", "margin_angles")):
            if given(args, name):
                refuse_unused(opt, "it applies to --margin constraints and none is given")
    if given(args, "span") and set(gains) <= set(bounds):
        refuse_unused("--span", f"every gain ({', '.join(gains)}) has its --bounds")
    if given(args, "verify") and args.backend == "multibody":
        refuse_unused("--verify", "it re-runs the best candidates of a reduced-model search on the multibody "
                                  "backend, and --backend multibody searches on MuJoCo itself")
    if args.out:

        check_out_dir(args.out, force=args.force)  # a bad --out: before the search, not after it
    scn = api.load(args.scenario, apply_fast_multibody(args, args.overrides))
    scn.check()  # bad --set values: one message before any simulation
    res = api.tune_gains(scn, args.controller, args.objective, limits=limits, bounds=bounds,
                         span=10.0 if args.span is None else args.span, margins=args.margin,
                         margin_mode=args.margin_mode or "penalty", margin_angles=args.margin_angles or 12,
                         n_global=args.n_global, starts=args.starts, maxfev=args.maxfev, t_end=args.t_end,
                         backend=args.backend, verify=3 if args.verify is None else args.verify, seed=args.seed,
                         threads=args.threads, log=print)
    violated, exceeded = res.violated, res.limits_exceeded
    print(res.report())
    if args.out:
        res.save(args.out, force=args.force, what="--out")
        print(f"results written to {args.out}")
    gtxt = ", ".join(f"{p} = {res.best[p]:.4g}" for p in res.result.params)
    if exceeded:
        print(f"mjbench: warning: the tuned gains ({gtxt}) exceed {'; '.join(exceeded)} (a penalty of the objective, "
              f"not a hard limit)", file=sys.stderr)
    if violated and args.margin_mode == "constraint" and res.result.margins:
        print(f"mjbench: tune: no candidate meets the constraints; the closest ({gtxt}) violates "
              f"{'; '.join(violated)}", file=sys.stderr)
        return 1
    if violated:
        print(f"mjbench: warning: the tuned gains ({gtxt}) do not meet {'; '.join(violated)} (penalised, not "
              f"enforced: use --margin-mode constraint to require the margins)", file=sys.stderr)
    return 0
