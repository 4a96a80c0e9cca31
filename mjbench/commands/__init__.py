"""CLI subcommands.  Each module here defines ``register(subparsers)`` adding one (or a few)
subcommands whose parser sets ``func=callable(args) -> int``.  ``mjbench.cli`` discovers them."""


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
    from ..backends.multibody import accuracy_note

    print(f"mjbench: fast multibody mode: {accuracy_note(fast)}")
    return [*overrides, f"multibody.integrator={fast}"]


def parse_numbers(items, option, keys, suffix=""):
    """``["k=v,k=v", ...]`` of a repeatable CLI option → {key: float}.  ``keys`` are the allowed
    names (a list of (name, unit help) pairs); ``suffix`` characters (units such as "VA") may end a
    value.  Malformed, unknown or non-finite values raise ParameterError (exit 2) naming ``option``."""
    import math

    from ..errors import ParameterError

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
            out[k] = x
    return out
