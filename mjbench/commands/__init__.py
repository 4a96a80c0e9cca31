"""CLI subcommands.  Each module here defines ``register(subparsers)`` adding one (or a few)
subcommands whose parser sets ``func=callable(args) -> int``.  ``mjbench.cli`` discovers them.

Every option value is checked when the command line is parsed, the way scenario values are
(:mod:`mjbench.schema`): :func:`integer` and :func:`quantity` are argparse ``type=`` functions
with bounds (a quantity may carry a unit: ``--t-end "500 ms"``); a bad value is ONE line naming the
option and what is wrong (``--samples: must be an integer >= 0, got '-3'``), exit 2, before any
work.  An option the chosen run does not use is refused (:func:`refuse_unused`), never ignored.

Each command is a thin layer over the Python API (:mod:`mjbench.api`, docs/api.md): it parses and
checks its options, calls the API function, and prints; the files it writes are the API's
(``Result.save``, ``TuneResult.save`` ...).  The API's :class:`~mjbench.api.scenarios.MjbenchWarning`
is silenced while a command runs (:func:`cli_command`): the command prints the same lines as
``mjbench: warning: ...``.
"""
import argparse
import functools
import math
import sys
import warnings

from ..api.video import MAX_HEIGHT, MAX_WIDTH, check_frame  # noqa: F401 - the frame limits of render/reproduce
from ..errors import ParameterError
from ..backends.multibody import accuracy_note
from ..api.scenarios import MjbenchWarning
from .. import units as U


def cli_command(func):
    """Decorator of a command's ``func(args)``: the API's warnings are not shown as Python
    warnings (the command prints them itself, one ``mjbench: warning: ...`` line each)."""
    @functools.wraps(func)
    def run(args):

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", MjbenchWarning)
            return func(args)
    return run


def integer(ge=None, le=None, what="an integer"):
    """argparse ``type=``: a whole number within [ge, le] (1e3 is accepted as 1000)."""
    def conv(text):
        try:
            x = float(text)
            ok = math.isfinite(x) and x == int(x)
        except (ValueError, OverflowError):
            ok = False
        if not ok:
            raise argparse.ArgumentTypeError(f"must be {what}, got {text!r}")
        v = int(x)
        if ge is not None and v < ge:
            raise argparse.ArgumentTypeError(f"must be {what} >= {ge}, got {text!r}")
        if le is not None and v > le:
            raise argparse.ArgumentTypeError(f"must be {what} <= {le:,}, got {text!r}")
        return v
    return conv


def number(gt=None, ge=None, le=None, what="a number"):
    """argparse ``type=``: a finite number within the bounds (no unit)."""
    def conv(text):
        try:
            x = float(text)
            ok = math.isfinite(x)
        except (ValueError, OverflowError):
            ok = False
        if not ok:
            raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
        if gt is not None and not x > gt:
            raise argparse.ArgumentTypeError(f"must be {what} > {gt:g}, got {text!r}")
        if ge is not None and not x >= ge:
            raise argparse.ArgumentTypeError(f"must be {what} >= {ge:g}, got {text!r}")
        if le is not None and not x <= le:
            raise argparse.ArgumentTypeError(f"must be {what} <= {le:g}, got {text!r}")
        return x
    return conv


def quantity(kind, gt=None, ge=None, lt=None, le=None):
    """argparse ``type=``: a finite number in the SI unit of ``kind`` (:data:`mjbench.units.KINDS`),
    or a string with a unit ("500 ms", "60 rpm"), within the bounds (as the scenario schema)."""
    def conv(text):

        try:
            try:
                x = float(text)
            except ValueError:
                x = U.to_si(text, kind)
            U.Bound(gt, ge, lt, le, True).check(x, U.KINDS[kind][1])
        except U.UnitError as e:
            raise argparse.ArgumentTypeError(f"{e}{'' if str(text) in str(e) else f' ({text!r})'}") from None
        return x
    return conv


def given(args, name) -> bool:
    """Whether option ``name`` was given on the command line (its default is the None sentinel)."""
    return getattr(args, name, None) is not None


def refuse_unused(option, why):
    """An option the run would ignore: one line naming it and why (exit 2)."""

    raise ParameterError(f"{option} has no effect here: {why}")


def add_fast_multibody(p):
    """``--fast-multibody {Euler,implicitfast}``: the opt-in fast multibody mode (see apply_fast_multibody)."""
    p.add_argument("--fast-multibody", choices=["Euler", "implicitfast"], default=None,
                   help="opt-in: multibody runs with this MuJoCo integrator instead of RK4 (≈ 2× cheaper per step, "
                        "less accurate: the measured accuracy is printed; docs/performance.md)")


def apply_fast_multibody(args, overrides):
    """The overrides with ``multibody.integrator`` set when ``--fast-multibody`` is given, after
    printing that mode's measured accuracy (never a silent default)."""
    fast = getattr(args, "fast_multibody", None)
    if not fast:
        return list(overrides)

    print(f"mjbench: fast multibody mode: {accuracy_note(fast)}")
    return [*overrides, f"multibody.integrator={fast}"]


def parse_numbers(items, option, keys, suffix=""):
    """``["k=v,k=v", ...]`` of a repeatable CLI option → {key: float}.  ``keys`` are the allowed
    names (a list of (name, unit help) pairs); ``suffix`` characters (units such as "VA") may end a
    value.  Malformed, unknown or non-finite values raise ParameterError (exit 2) naming ``option``."""
    import math


    allowed = dict(keys)
    choices = ", ".join(f"{k} [{u}]" if u else k for k, u in keys)
    out = {}
    for item in items:
        for part in item.split(","):
            if not part.strip():
                continue
            if "=" not in part:
                raise ParameterError(f"{option} {part!r}: expected KEY=VALUE with KEY in {choices}")
            k, v = (s.strip() for s in part.split("=", 1))
            if k not in allowed:
                raise ParameterError(f"{option} {k!r}: choose {choices}")
            try:
                x = float(v.rstrip(suffix) if suffix else v)
            except ValueError:
                raise ParameterError(f"{option} {part!r}: {v!r} is not a number") from None
            if not math.isfinite(x):
                raise ParameterError(f"{option} {part!r}: must be finite")
            if k in out:
                raise ParameterError(f"{option} {k} is given twice ({k}={out[k]:g} and {part.strip()})")
            out[k] = x
    return out


def note(old: str, new: str):
    """One line on stderr after an old spelling ran."""
    print(f"mjbench: note: `mjbench {old}` is a paper study, now `mjbench {new}` (the old spelling still works)",
          file=sys.stderr)
