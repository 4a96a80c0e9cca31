"""``mjbench`` command line: one entry point, subcommands discovered in ``mjbench.commands``."""
from __future__ import annotations

import argparse
import gc
import importlib
import os
import pkgutil
import sys

from . import environment  # (the standard library only: checked before any command)
from ._version import __version__
from .errors import MjbenchError


#: subcommand → the module of ``mjbench.commands`` that registers it: a command imports only its
#: own module (a command costs its work, not every other command's imports); tests/test_cli.py
#: checks this table against the modules' own registrations
COMMAND_MODULES = {
    "analyze": "analyze", "calibrate": "calibrate", "demand": "check_reference", "demo": "demo",
    "design": "design", "identify": "identify", "linearize": "linearize", "optimize-law": "optimize_law",
    "render": "render", "reproduce": "reproduce", "run": "run", "list": "run", "sweep": "sweep", "tune": "tune",
    "export-fmu": "export_fmu", "frest": "frest", "paper": "paper", "check": "check",
}


#: the commands that render with MuJoCo's OpenGL context (the others import MuJoCo without it)
GL_COMMANDS = {"render", "reproduce", "demo"}


def _command_in(argv) -> str | None:
    """The subcommand named in argv (the first word that is not an option), if any."""
    for a in argv:
        if not a.startswith("-"):
            return a
    return None


class Parser(argparse.ArgumentParser):
    """argparse with mjbench's error format: ONE line ``mjbench: error: --opt: what is wrong (see
    mjbench CMD --help)`` on stderr and exit status 2 (docs/outputs.md), instead of the usage block
    plus a line.  Subcommand parsers are of the same class (``add_subparsers`` uses the parent's)."""

    def error(self, message):
        msg = message[len("argument "):] if message.startswith("argument ") else message
        sub = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        self.exit(2, f"mjbench: error: {msg} (see mjbench {sub + ' ' if sub else ''}--help)\n")


class _Version(argparse.Action):
    """``--version`` after a subcommand's options: the version read when asked for (importlib.metadata
    is not imported to build the parser; a bare ``mjbench --version`` never builds it, :func:`main`)."""

    def __call__(self, parser, namespace, values, option_string=None):
        parser.exit(message=f"mjbench {version()}\n")


def build_parser(argv=None):
    """The parser; with ``argv`` naming a known subcommand only that command's module is imported
    (help and unknown commands import every command module)."""
    p = Parser(prog="mjbench", description=(
        "MuJoCo testbed for motor-driven mechanisms under feedback control. "
        "Scenarios are built-in names (see `mjbench list`) or TOML files."))
    p.add_argument("--version", action=_Version, nargs=0, help="show the version and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    cmd = _command_in(argv) if argv is not None else None
    if cmd in COMMAND_MODULES:
        names = [COMMAND_MODULES[cmd]]
    else:
        from . import commands  # help or an unknown command: every command module (--version imports none)
        names = [i.name for i in sorted(pkgutil.iter_modules(commands.__path__), key=lambda i: i.name)]
    for name in names:
        mod = importlib.import_module(f"mjbench.commands.{name}")
        if hasattr(mod, "register"):
            mod.register(sub)
    return p


def version() -> str:
    """The installed distribution's version (importlib.metadata), else the package's."""
    from importlib.metadata import PackageNotFoundError, version as _v
    try:
        return _v("mjbench")
    except PackageNotFoundError:
        return __version__


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["--version"]:
        print(f"mjbench {version()}")
        return 0
    from . import outputs  # (the standard library only: cheap)

    # first of all, before MuJoCo, NumPy or a command module is imported (≈ 0.4 s): Ctrl-C or SIGTERM
    # at any moment is one line and exit status 130 / 143, never a traceback
    restore = outputs.install_signal_handlers()  # SIGTERM cleans up like Ctrl-C (mjbench/outputs.py)
    try:
        return _main(argv, outputs)
    except KeyboardInterrupt as e:
        return _interrupted(getattr(e, "signum", 2))
    except BaseException:  # an interrupt turned into another error on its way (an extension's import)
        if outputs.interrupted_by() is None:
            raise
        return _interrupted(outputs.interrupted_by())
    finally:
        restore()


def _interrupted(signum) -> int:
    print(f"mjbench: interrupted ({'SIGTERM' if signum == 15 else 'SIGINT'})", file=sys.stderr)
    return 128 + signum


_FROZE = False


def _froze() -> None:
    global _FROZE
    gc.freeze()
    gc.enable()
    _FROZE = True


def _main(argv, outputs) -> int:
    from .render.gl import check_gl_env  # not for --version, which imports nothing of ours

    try:
        environment.check()  # every MJBENCH_* variable, before anything runs (mjbench/environment.py)
    except MjbenchError as e:
        print(f"mjbench: error: {e}", file=sys.stderr)
        return 2
    check_gl_env()  # a MUJOCO_GL typo is replaced (with a warning) before MuJoCo is imported
    cmd = _command_in(argv)
    gl = os.environ.get("MUJOCO_GL")
    if cmd in COMMAND_MODULES and cmd not in GL_COMMANDS and "mujoco" not in sys.modules:
        os.environ["MUJOCO_GL"] = "disable"  # no PyOpenGL for a command that never renders
    # the command's modules and the classes they build (pydantic's schemas, dataclasses) are made
    # without the cyclic collector, then kept out of its later passes (gc.freeze): they live as long
    # as the process, and collecting them while they are made costs ≈ 3 % of a short run's CPU (once
    # a process: a caller's own objects are frozen only by the first command it runs)
    freeze = not _FROZE and gc.isenabled()
    if freeze:
        gc.disable()
    try:
        try:
            args = build_parser(argv).parse_args(argv)
        except SystemExit as e:  # a bad command line (Parser.error): exit 2; --help exits 0 as usual
            if e.code == 2:
                return 2
            raise
        if os.environ.get("MUJOCO_GL") == "disable" and gl != "disable":
            import mujoco  # noqa: F401 - imported once without its GL context
        outputs.raise_if_interrupted()  # a Ctrl-C the import system swallowed ("Exception ignored")
    except MjbenchError as e:  # an environment variable or a plugin found wrong while the command loads
        print(f"mjbench: error: {e}", file=sys.stderr)
        return 2
    finally:
        if freeze:
            _froze()
        if gl is None:
            os.environ.pop("MUJOCO_GL", None)
        else:
            os.environ["MUJOCO_GL"] = gl
    try:
        if not getattr(args, "gl", False):  # render/reproduce/demo choose the OpenGL backend first
            outputs.route_mujoco_log()
        return int(args.func(args) or 0)
    except MjbenchError as e:
        print(f"mjbench: error: {e}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `mjbench list | head`
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as e:  # the environment: disk full, a file that vanished, permissions (no traceback)
        print(f"mjbench: error: {os_error_text(e)}", file=sys.stderr)
        return 2
    except MemoryError:
        print("mjbench: error: out of memory: the command needs more memory than is available (shorten the "
              "run, raise simulation.record_dt, or use fewer points/rows)", file=sys.stderr)
        return 2


def os_error_text(e: OSError) -> str:
    """One line for an operating-system error: what failed, on which file, and what to do."""
    import errno

    where = f" ({e.filename})" if getattr(e, "filename", None) else ""
    what = e.strerror or str(e) or type(e).__name__
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        return (f"cannot write the outputs{where}: {what}; nothing was left half-written (free some space, or "
                f"choose an --out on another disk)")
    if e.errno == errno.EROFS:
        return f"cannot write the outputs{where}: {what}; choose an --out on a writable disk"
    return f"{what}{where}"


if __name__ == "__main__":
    sys.exit(main())
