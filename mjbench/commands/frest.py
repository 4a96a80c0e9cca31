"""``mjbench frest SCENARIO [--mode M] [--at q=..,omega=..,t=..] --out DIR``: the frequency response
of the running nonlinear machine (plant and loop) with coherence, margins from the measured loop and
the linearisation overlaid (:mod:`mjbench.frest`, docs/bridges.md).  Writes frest.json and bode.png."""
from __future__ import annotations

import math
import sys

from ..outputs import add_force_option
from . import cli_command, integer, number, quantity
from .. import api
from ..errors import ParameterError
from ..outputs import check_out_dir
from .linearize import parse_at


def register(sub):
    p = sub.add_parser(
        "frest", help="frequency response of the nonlinear machine (multisine / stepped sine), vs the linearisation",
        description="Excite SCENARIO's running machine (mechanism, drive, drive train, controller) around an operating "
                    "point with a disturbance added to the controller output, measure the plant q̇/V and the loop L at "
                    "the plant input as python-control FRD with coherence, read gain/phase margins and peak |S| from the "
                    "measured loop, and overlay the linearisation (mjbench linearize) at the same point. Default point: "
                    "the initial angle at the controller's running speed (K_p·t frozen at simulation.t_end).")
    p.add_argument("scenario", help="built-in scenario name or TOML path")
    p.add_argument("--mode", help="controller mode (default: the scenario's)")
    p.add_argument("--at", action="append", default=[], metavar="q=..,omega=..",
                   help="operating point: q [rad], omega [rad/s, input side], I [A], t [s] (comma-separated)")
    p.add_argument("--signal", choices=["multisine", "sine"], default="multisine",
                   help="multisine (one run, default) or stepped sine (one run per frequency)")
    p.add_argument("--amplitude", type=number(gt=0.0, le=1e5), default=None,
                   help="excitation peak [V] (the current reference [A] with a current loop; default: 2 %% of the "
                        "operating voltage, within the limiter's headroom). A run that holds the limiter over 1 %% "
                        "of the time is reported as saturated (exit 1)")
    p.add_argument("--band", default=None, metavar="LO,HI", help="frequency band [rad/s] (default: 1/period … "
                   "min(0.25 × Nyquist, 500 Hz); a running linkage from a decade below its frozen-angle band)")
    p.add_argument("--lines", type=integer(ge=1, le=1000), default=30,
                   help="number of excited frequencies (default 30)")
    p.add_argument("--periods", type=integer(ge=2, le=1000), default=3,
                   help="measured periods (default 3: coherence over 3)")
    p.add_argument("--period", type=quantity("time", gt=0.0, le=1e4), default=None,
                   help="multisine period [s] (default 0.5 s; a running linkage: whole turns, ≥ 2, its lines free of "
                        "each other's rotation sidebands); at least 2 × (lines + 1) control periods")
    p.add_argument("--settle", type=quantity("time", ge=0.0, le=1e4), default=None,
                   help="settling time before measuring [s] (default: from the linear closed loop's slowest pole; the "
                        "lowest line's change over one more period is checked, and the settling extended until it "
                        "is below 1e-3 of the line, or a warning)")
    p.add_argument("--backend", choices=["reduced", "multibody"], default="reduced")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--out", required=True, help="output directory (written whole or not at all)")
    add_force_option(p)
    p.set_defaults(func=cmd_frest)


@cli_command
def cmd_frest(args):
    """``mjbench frest`` = ``mjbench.frequency_response`` → ``FrequencyResponse.save`` (docs/api.md)."""

    scn = api.load(args.scenario, args.overrides)
    scn.check(args.mode)
    at = parse_at(args.at)
    band = None
    if args.band:
        try:
            lo, hi = (float(x) for x in args.band.split(","))
        except ValueError:
            raise ParameterError(f"--band {args.band!r}: expected LO,HI in rad/s") from None
        if not (0 < lo < hi and math.isfinite(hi)):
            raise ParameterError(f"--band {args.band!r}: need 0 < LO < HI (finite, rad/s)")
        band = (lo, hi)
    check_out_dir(args.out, force=args.force)
    res = api.frequency_response(scn, args.mode, backend=args.backend, signal=args.signal, amplitude=args.amplitude,
                                 band=band, period=args.period, periods=args.periods, settle=args.settle,
                                 lines=args.lines, **at)
    res.save(args.out, force=args.force, what="--out")
    print(res.summary())
    print(f"results written to {args.out}")
    sat = res.data.get("saturation") or {}
    if sat.get("saturated"):
        print(f"mjbench: frest: {sat['note']}", file=sys.stderr)
        return 1
    return 0
