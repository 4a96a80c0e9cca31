"""``mjbench linearize SCENARIO [--mode M] [--at q=..,omega=..] --out DIR``: the machine's linear
model (reduced and multibody), its loop, margins, poles and the frozen-angle family
(:mod:`mjbench.linear`).  Writes bode.png, nyquist.png, poles.png, plant.png and linear.json."""
from __future__ import annotations

from ..outputs import add_force_option
from . import cli_command, integer, parse_numbers
from ..errors import ParameterError
from .. import api
from ..outputs import check_out_dir

AT_KEYS = {"q": "q", "omega": "qd", "qd": "qd", "I": "I", "t": "t"}


def register(sub):
    p = sub.add_parser(
        "linearize", help="linear model, loop margins, poles and frozen-angle Bode family (python-control)",
        description="Linearise SCENARIO at an operating point (input angle q [rad], input speed omega [rad/s], "
                    "current I [A], time t [s] for K_p·t): the reduced model (analytic Jacobian) and the multibody "
                    "model (MuJoCo mjd_transitionFD), their agreement, the controller's discrete-time counterpart, "
                    "the loop at the plant input (gain/phase margins, peak |S|, bandwidth, closed-loop poles) and "
                    "the loop at frozen angles over one turn. Default point: the initial angle, the controller's "
                    "running speed there, the turn-averaged current (running: the mean over one turn of the currents that "
                    "would hold q̈ = 0 at that speed — a linkage is then not stationary at the point, q̈* ≠ 0, printed; "
                    "at rest: the current holding q̈ = 0), t = simulation.t_end for a K_p·t PID.")
    p.add_argument("scenario", help="built-in scenario name or TOML path")
    p.add_argument("--mode", help="controller mode (default: the scenario's)")
    p.add_argument("--at", action="append", default=[], metavar="q=..,omega=..",
                   help="operating point: q [rad], omega [rad/s, input side], I [A], t [s] (comma-separated)")
    p.add_argument("--angles", type=integer(ge=0, le=3600), default=36,
                   help="frozen angles over one turn (0: none; default 36)")
    p.add_argument("--no-multibody", action="store_true", help="skip the MuJoCo linearisation")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--out", required=True, help="output directory (written whole or not at all)")
    add_force_option(p)
    p.set_defaults(func=cmd_linearize)


#: |value| limits of an operating point: beyond any motor a DC drive model covers (the plausible
#: ranges of mjbench.units for angular velocity and current); t: a run length
AT_LIMITS = {"q": 1e6, "omega": 1e5, "qd": 1e5, "I": 1e5, "t": 1e5}


def parse_at(items) -> dict:
    """``--at q=..,omega=..,I=..,t=..`` → {q, qd, I, t} (floats, SI), checked: finite, |ω| and
    |I| ≤ 1e5, 0 ≤ t ≤ 1e5 s (t is the time of the K_p·t ramp: a negative one is a negative gain)."""

    got = parse_numbers(items, "--at", [("q", "rad"), ("omega", "rad/s"), ("qd", "rad/s"), ("I", "A"), ("t", "s")])
    if "omega" in got and "qd" in got:
        raise ParameterError("--at omega and qd are the same input speed: give one of them")
    for k, v in got.items():
        lim = AT_LIMITS.get(k)
        if lim is not None and abs(v) > lim:
            why = ("an angle that large has no precision left" if k == "q" else "beyond what the drive model covers")
            raise ParameterError(f"--at {k}={v:g}: |{k}| must be <= {lim:g} "
                                 f"{dict(q='rad', omega='rad/s', qd='rad/s', I='A', t='s')[k]} ({why})")
    if got.get("t", 0.0) < 0:
        raise ParameterError(f"--at t={got['t']:g}: must be >= 0 s (the time of the run; K_p·t would be a negative gain)")
    return {AT_KEYS[k]: v for k, v in got.items()}


@cli_command
def cmd_linearize(args):
    """``mjbench linearize`` = ``mjbench.linearize`` → ``LinearResult.save`` (docs/api.md)."""

    at = parse_at(args.at)
    scn = api.load(args.scenario, args.overrides)
    scn.check(args.mode)
    check_out_dir(args.out, force=args.force)
    res = api.linearize(scn, args.mode, angles=args.angles, multibody=not args.no_multibody, **at)
    res.save(args.out, force=args.force, what="--out")
    print(res.summary())
    print(f"results written to {args.out}")
    return 0
