"""CLI subcommands.  Each module here defines ``register(subparsers)`` adding one (or a few)
subcommands whose parser sets ``func=callable(args) -> int``.  ``mjbench.cli`` discovers them."""
