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
