"""``mjbench identify``: fit the DC-motor parameters to a logged voltage/speed(/current) record."""
from __future__ import annotations

import os

from ..outputs import add_force_option
from . import cli_command, quantity
from ..errors import ParameterError
from ..identify import PARAMS, UNITS
from .. import api
from .. import identify as ID
from ..outputs import check_out_dir


def register(sub):
    p = sub.add_parser(
        "identify", help="identify R, L, K, friction and rotor inertia of a DC motor from a CSV record",
        description="Fit R, L, K (torque = back-EMF constant), viscous b and Coulomb T_c friction and the "
                    "shaft inertia J to a record with columns t_s, voltage_V, motor_speed_rad_s[, current_A] "
                    "(an mjbench trajectory CSV works) by output-error least squares "
                    "(scipy.optimize.least_squares). Prints values with 95 %% confidence intervals and the "
                    "scenario [drive] keys; writes identify.json and a fit plot with --out.")
    p.add_argument("--data", required=True, help="CSV record (header row; see mjbench/identify.py COLUMNS)")
    p.add_argument("--fix", action="append", default=[], metavar="P=VALUE",
                   help="hold a parameter (R, L, K, J, b, T_c) at a known value; needed (≥ 2) without current")
    p.add_argument("--guess", action="append", default=[], metavar="P=VALUE", help="starting value of a parameter")
    p.add_argument("--no-current", action="store_true", help="ignore a current column (voltage/speed fit)")
    p.add_argument("--omega-s", type=quantity("angular_velocity", gt=0.0), default=0.05,
                   help="speed scale of the smoothed Coulomb friction tanh(ω/ω_s) [rad/s] (default 0.05)")
    p.add_argument("--synthetic", action="store_true",
                   help="first write a synthetic noisy record of the Incerti 2012 motor to --data (demo/check)")
    p.add_argument("--out", help="write identify.json and identify_fit.png here")
    add_force_option(p)
    p.set_defaults(func=cmd_identify)


SEED000_MOTOR = {"R": 2.0, "L": 9e-3, "K": 0.48, "J": 13e-4 + 9.8e-5, "b": 0.08, "T_c": 0.05}


def _kv(items, what):
    """``--fix/--guess P=VALUE`` → {P: value}: P one of the fitted parameters (given once), the
    value finite, > 0 for R, L, K, J and >= 0 for the frictions b, T_c (the fit's bounds)."""
    import math


    out = {}
    for it in items:
        if "=" not in it:
            raise ParameterError(f"--{what} {it!r}: expected P=VALUE with P one of {', '.join(PARAMS)}")
        k, v = (x.strip() for x in it.split("=", 1))
        if k not in PARAMS:
            raise ParameterError(f"--{what} {it!r}: {k!r} is not a parameter of the fit; choose {', '.join(PARAMS)}")
        if k in out:
            raise ParameterError(f"--{what} {k} is given twice")
        try:
            x = float(v)
        except ValueError:
            raise ParameterError(f"--{what} {it!r}: {v!r} is not a number [{UNITS[k]}]") from None
        low_ok = x >= 0 if k in ("b", "T_c") else x > 0
        if not (math.isfinite(x) and low_ok):
            raise ParameterError(f"--{what} {it!r}: must be a finite number {'>= 0' if k in ('b', 'T_c') else '> 0'} "
                                 f"[{UNITS[k]}]")
        out[k] = x
    return out


@cli_command
def cmd_identify(args):
    """``mjbench identify`` = ``mjbench.identify_motor`` → ``MotorFit.save`` (docs/api.md)."""

    if args.out:
        check_out_dir(args.out, force=args.force)  # before the fit
    truth = None
    if args.synthetic:
        truth = SEED000_MOTOR
        ID.write_record(args.data, ID.synthetic_record(truth, seed=0, omega_s=args.omega_s))
        print(f"synthetic record (Incerti 2012 motor, T_c = 0.05 N·m, noise 0.05 rad/s and 0.05 A) -> {args.data}")
    fixed, guess = _kv(args.fix, "fix"), _kv(args.guess, "guess")
    if len(fixed) == len(ID.PARAMS):
        raise ParameterError("--fix: every parameter is fixed, nothing is left to fit")
    both = sorted(set(fixed) & set(guess))
    if both:
        raise ParameterError(f"--guess {both[0]}: the parameter is also fixed (--fix); a start value of a fixed "
                             f"parameter has no effect")
    rec = ID.read_record(args.data)  # (errors name --data, the row and the column)
    if args.no_current and "I" not in rec:
        raise ParameterError(f"--no-current: {args.data} has no current column to ignore")
    res = api.identify_motor(rec, fix=fixed, guess=guess, current=not args.no_current, omega_s=args.omega_s,
                             source=os.path.abspath(args.data))
    print(res.report(truth))
    if args.out:
        res.save(args.out, force=args.force, what="--out")
        print(f"results written to {args.out}")
    return 0
