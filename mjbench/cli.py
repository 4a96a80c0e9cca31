"""``mjbench`` command line: one entry point, subcommands discovered in ``mjbench.commands``."""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from .errors import MjbenchError


def build_parser():
    p = argparse.ArgumentParser(prog="mjbench", description=(
        "MuJoCo testbed for motor-driven mechanisms under feedback control. "
        "Scenarios are built-in names (see `mjbench list`) or TOML files."))
    p.add_argument("--version", action="version", version=f"mjbench {version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    from . import commands
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name):
        mod = importlib.import_module(f"mjbench.commands.{info.name}")
        if hasattr(mod, "register"):
            mod.register(sub)
    return p


def version() -> str:
    """The installed distribution's version (importlib.metadata), else the package's."""
    from importlib.metadata import PackageNotFoundError, version as _v
    try:
        return _v("mjbench")
    except PackageNotFoundError:
        from . import __version__
        return __version__


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    from . import outputs
    from .render import check_gl_env

    restore = outputs.install_signal_handlers()  # SIGTERM cleans up like Ctrl-C (mjbench/outputs.py)
    try:
        check_gl_env()
        if not getattr(args, "gl", False):  # render/reproduce/demo choose the OpenGL backend first
            outputs.route_mujoco_log()
        return int(args.func(args) or 0)
    except MjbenchError as e:
        print(f"mjbench: error: {e}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `mjbench list | head`
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt as e:
        signum = getattr(e, "signum", 2)
        print(f"mjbench: interrupted ({'SIGTERM' if signum == 15 else 'SIGINT'})", file=sys.stderr)
        return 128 + signum
    finally:
        restore()


if __name__ == "__main__":
    sys.exit(main())
