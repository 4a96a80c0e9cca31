"""What mjbench writes: whole output folders or none, files with mode 0644, strict JSON.

Staged folders (docs/outputs.md)
--------------------------------
:func:`staged_dir` is used by every command that writes an output folder (``run``, ``reproduce``,
``demo``, ``optimize-law``, ``design``, ``tune``, ``calibrate``, ``identify``, ``analyze``)::

    with staged_dir(args.out, force=args.force) as tmp:   # checks --out, creates the staging folder
        ...write every file into tmp...
    # here --out holds the complete new outputs

* The files go into ``.<name>.staging-<pid>-<random>`` beside ``--out`` (same filesystem) and the
  folder is renamed into place at the end, so ``--out`` never holds a partial or mixed run.
* ``--out`` must be missing or an empty folder; a non-empty folder is refused (exit 2) unless
  ``force``: the old folder is then renamed aside, the new one renamed in, the old one deleted —
  the old outputs stay complete until the new ones are.
* Failure, Ctrl-C or SIGTERM (turned into the same ``KeyboardInterrupt`` path by
  :func:`install_signal_handlers`) removes the staging folder and any parent folders the run
  created; the swap itself runs with SIGINT/SIGTERM deferred.
* A folder left by a killed (SIGKILL) run is removed by the next run into the same ``--out``.

``mjbench render`` writes one file; :func:`output_file` checks its path the same way and the video
writer renames a temporary file into place.  ``mjbench sweep`` writes straight into ``--out``
(resumable: ``results.csv`` is rewritten atomically after every chunk).

Strict JSON
-----------
:func:`dumps` / :func:`write_json` write standard JSON only (``allow_nan=False``).  A non-finite
number (e.g. ``v_max = inf``: no voltage limit) is written as ``null`` and, when the document is
an object, listed in its top-level ``"_nonfinite"`` object, which maps the value's JSON Pointer
(RFC 6901) to ``"inf"``, ``"-inf"`` or ``"nan"``, e.g.
``"_nonfinite": {"/scenario/modes/pid/t_ramp_max": "inf"}``.

Test hook
---------
``MJBENCH_TEST_KILL_AFTER=<event>`` makes the process send itself ``MJBENCH_TEST_KILL_SIGNAL``
(``TERM``, default, or ``INT``) at that event, so tests can interrupt a real run at a chosen
point: ``<file name>`` just after that file is complete, ``during:<file name>`` while its
temporary file exists, ``staged`` when every file is written but not moved in yet, ``swap``
inside the final swap (the signal is deferred to its end).
"""
from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import shutil
import signal
import sys
import tempfile
import threading
from pathlib import Path

from .errors import MjbenchError


class OutputError(MjbenchError, OSError):
    """An output path cannot be used (exists as a file, not writable, non-empty without --force)."""


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM: raised in the main thread so that every ``finally`` cleans up."""

    def __init__(self, signum=signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)


# ============================================================================ permissions
def _read_umask() -> int:
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    old = os.umask(0o022)
    os.umask(old)
    return old


_UMASK = _read_umask()
FILE_MODE = 0o666 & ~_UMASK  #: 0644 with the usual umask 022 (mkstemp alone gives 0600)
DIR_MODE = 0o777 & ~_UMASK   #: 0755 with umask 022 (mkdtemp alone gives 0700)


# ============================================================================ test hook
def _test_hook(event: str):
    """See the module docstring: deterministic interruption points for tests (a dict lookup)."""
    if os.environ.get("MJBENCH_TEST_KILL_AFTER") == event:
        name = os.environ.get("MJBENCH_TEST_KILL_SIGNAL", "TERM").upper().removeprefix("SIG")
        os.kill(os.getpid(), getattr(signal, "SIG" + name))


# ============================================================================ signals
_critical = 0
_deferred = None
_installed = False
_received = None  #: the last signal our handler turned into :class:`Interrupted` (see interrupted_by)


def _handler(signum, frame):
    global _deferred, _received
    _received = signum
    if _critical:  # Python runs signal handlers in the main thread, between bytecodes
        _deferred = signum
        return
    raise Interrupted(signum)


def interrupted_by():
    """The signal number our handler received since it was installed (None: none).  An
    :class:`Interrupted` raised where Python cannot pass it on — inside an extension module's
    initialisation (it becomes "ImportError: initialization failed"), a weak-reference callback
    of the import system ("Exception ignored") — is still known here (mjbench/cli.py)."""
    return _received


def raise_if_interrupted():
    """Raise :class:`Interrupted` if a signal arrived and was swallowed on its way (see
    :func:`interrupted_by`)."""
    if _received is not None:
        raise Interrupted(_received)


def install_signal_handlers():
    """SIGINT and SIGTERM raise :class:`Interrupted` (a KeyboardInterrupt) in the main thread, so
    a terminated run cleans up exactly like Ctrl-C.  Returns a function restoring the previous
    handlers.  Only handlers still at their defaults are replaced."""
    global _installed, _received
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    _received = None
    old = {}
    hook = sys.unraisablehook

    def quiet(u):  # an interrupt swallowed by a callback: no "Exception ignored" traceback (see interrupted_by)
        if not isinstance(u.exc_value, Interrupted):
            hook(u)
    sys.unraisablehook = quiet
    for sig, default in ((signal.SIGINT, signal.default_int_handler), (signal.SIGTERM, signal.SIG_DFL)):
        cur = signal.getsignal(sig)
        if cur in (default, signal.SIG_DFL, _handler):
            old[sig] = cur
            signal.signal(sig, _handler)
    _installed = True

    def restore():
        global _installed
        for sig, h in old.items():
            signal.signal(sig, h)
        sys.unraisablehook = hook
        _installed = False
    return restore


@contextlib.contextmanager
def _signals_deferred():
    """SIGINT/SIGTERM arriving inside the block take effect at its end (with our handlers)."""
    global _critical, _deferred
    _critical += 1
    try:
        yield
    finally:
        _critical -= 1
        if not _critical and _deferred is not None:
            sig, _deferred = _deferred, None
            raise Interrupted(sig)


# ============================================================================ files
def atomic_write(path, writer, mode="w"):
    """Call ``writer(file)`` on a temporary file beside ``path`` (mode 0644), then rename it into
    place: the file is complete or absent, never partial.  Text files are UTF-8."""
    path = os.fspath(path)
    name = os.path.basename(path)
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix="-" + name)
    try:
        os.fchmod(fd, FILE_MODE)
        with os.fdopen(fd, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as f:
            writer(f)
            _test_hook("during:" + name)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _test_hook(name)


# ============================================================================ strict JSON
def _pointer_part(k) -> str:
    return str(k).replace("~", "~0").replace("/", "~1")


def clean(obj, notes: dict | None = None, _path: str = ""):
    """JSON-safe copy of ``obj``: NumPy scalars/arrays → numbers/lists, tuples/sets → lists, paths
    and unknown objects → strings, non-finite floats → ``None`` (recorded in ``notes`` as
    {JSON Pointer: "inf" | "-inf" | "nan"} when given)."""
    if isinstance(obj, dict):
        return {str(k): clean(v, notes, f"{_path}/{_pointer_part(k)}") for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [clean(v, notes, f"{_path}/{i}") for i, v in enumerate(obj)]
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        if math.isfinite(obj):
            return float(obj)
        if notes is not None:
            notes[_path or "/"] = "nan" if math.isnan(obj) else ("inf" if obj > 0 else "-inf")
        return None
    np = sys.modules.get("numpy")
    if np is not None:
        if isinstance(obj, np.bool_):
            return bool(obj)
        if isinstance(obj, np.integer):
            return int(obj)
        if isinstance(obj, np.floating):
            return clean(float(obj), notes, _path)
        if isinstance(obj, np.ndarray):
            return clean(obj.tolist(), notes, _path)
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    return str(obj)


def dumps(obj, indent=2, sort_keys=False) -> str:
    """Strict JSON text of ``obj`` (see the module docstring for non-finite numbers)."""
    notes = {}
    doc = clean(obj, notes)
    if notes and isinstance(doc, dict):
        doc["_nonfinite"] = notes
    return json.dumps(doc, indent=indent, sort_keys=sort_keys, ensure_ascii=False, allow_nan=False)


def write_json(path, obj, indent=2, sort_keys=False):
    """Write ``obj`` as strict JSON, atomically, mode 0644."""
    text = dumps(obj, indent=indent, sort_keys=sort_keys) + "\n"
    atomic_write(path, lambda f: f.write(text))
    return path


def _reject_constant(name):
    raise ValueError(f"not strict JSON: {name}")


def read_json(path):
    """Parse a JSON file strictly: NaN, Infinity and -Infinity are errors (as in most parsers)."""
    with open(path, encoding="utf-8") as f:
        return json.loads(f.read(), parse_constant=_reject_constant)


# ============================================================================ output paths
def _nearest_existing(p: Path) -> Path:
    while not p.exists() and not p.is_symlink() and p != p.parent:
        p = p.parent
    return p


def _check_parent(out: Path, what: str):
    """The nearest existing ancestor of ``out`` must be a writable folder."""
    anc = _nearest_existing(out.parent)
    if not anc.is_dir():
        raise OutputError(f"{what} {out}: {anc} is a file, not a folder")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputError(f"{what} {out}: cannot write in {anc} (permission denied)")


def _dangerous(out: Path) -> str | None:
    """Why ``out`` must never be replaced wholesale, even with --force (or None)."""
    real = out.resolve()
    cwd = Path.cwd().resolve()
    if real == Path(real.anchor) or real == Path.home().resolve():
        return "it is the filesystem root or your home folder"
    if real == cwd or real in cwd.parents:
        return "it is the current folder or one of its parents"
    if (real / ".git").exists():
        return "it holds a .git checkout"
    return None


def _sweep_leftovers(parent: Path, name: str):
    """Remove staging folders of runs that were killed outright (their process is gone); restore
    an old folder a killed swap had renamed aside (returns True then)."""
    restored = False
    try:
        siblings = os.listdir(parent)
    except OSError:
        return restored
    for kind in ("staging", "old"):
        prefix = f".{name}.{kind}-"
        for entry in siblings:
            if not entry.startswith(prefix):
                continue
            p = parent / entry
            try:
                pid = int(entry[len(prefix):].split("-")[0])
                os.kill(pid, 0)
                continue  # still running
            except ProcessLookupError:
                pass
            except (ValueError, PermissionError, OSError):
                continue
            if kind == "old" and not (parent / name).exists():
                with contextlib.suppress(OSError):  # the only copy: restore it, never delete it
                    os.rename(p, parent / name)
                    restored = True
                continue
            shutil.rmtree(p, ignore_errors=True)
    return restored


def force_name(what: str) -> str:
    """How the caller says "replace it": the option ``--force`` on the command line (``what`` is an
    option such as ``--out``), the keyword ``force=True`` from Python (``what`` names a call)."""
    return "--force" if str(what).startswith("--") else "force=True"


def force_hint(what: str) -> str:
    """"add --force" (a command's option) or "pass force=True" (a Python call)."""
    return "add --force" if str(what).startswith("--") else "pass force=True"


def check_out_dir(out, what="--out", force=False, must_be_empty=True) -> Path:
    """Refuse an output folder path that cannot be used, before any work starts.  A symbolic link
    to a folder stands for that folder (the outputs are staged beside the link's target)."""
    out = Path(os.path.abspath(os.fspath(out)))
    if out.is_symlink():
        out = Path(os.path.realpath(out))
    if out.exists() and not out.is_dir():
        raise OutputError(f"{what} {out} is an existing file, not a folder: choose a folder path")
    _check_parent(out, what)
    if must_be_empty and out.is_dir():
        try:
            entries = sorted(os.listdir(out))
        except OSError as e:
            raise OutputError(f"{what} {out}: cannot read it ({e.strerror})") from None
        if entries:
            if not force:
                shown = ", ".join(entries[:4]) + (", ..." if len(entries) > 4 else "")
                n = f"{len(entries)} entr{'y' if len(entries) == 1 else 'ies'}"
                raise OutputError(
                    f"{what} {out} already holds {n} ({shown}); {force_hint(what)} to replace "
                    f"the whole folder (the old one is kept until the new outputs are complete), or "
                    f"choose another {what if str(what).startswith('--') else 'folder'}")
            why = _dangerous(out)
            if why:
                raise OutputError(f"{what} {out}: refusing to replace it even with {force_name(what)}: {why}")
    return out


def check_out_file(path, what="--out", suffixes=None) -> Path:
    """Refuse an output file path that cannot be used, before any work starts."""
    out = Path(os.path.abspath(os.fspath(path)))
    if suffixes and out.suffix.lower() not in suffixes:
        raise OutputError(f"{what} {out}: the file name must end in {' or '.join(suffixes)}")
    if out.is_dir():
        raise OutputError(f"{what} {out} is an existing folder: give a file name")
    _check_parent(out, what)
    return out


def _make_parents(p: Path) -> list:
    """mkdir -p; returns the folders created (deepest last)."""
    made = []
    for d in reversed([p, *p.parents]):
        if not d.exists():
            try:
                d.mkdir(mode=DIR_MODE)
            except FileExistsError:
                continue
            made.append(d)
    return made


def _remove_empty(folders):
    for d in reversed(folders):
        with contextlib.suppress(OSError):
            d.rmdir()


@contextlib.contextmanager
def output_file(path, what="--out", suffixes=None):
    """Check a single output file path; create missing parent folders and remove them again if
    the block fails.  Yields the absolute path (the writer renames a temporary file into place)."""
    out = check_out_file(path, what, suffixes)
    made = []
    try:
        made = _make_parents(out.parent)
    except OSError as e:
        raise OutputError(f"{what} {out}: cannot create {e.filename or out.parent} ({e.strerror})") from None
    try:
        yield out
    except BaseException as e:
        with _signals_deferred():
            _remove_empty(made)
        if isinstance(e, OSError) and not isinstance(e, MjbenchError) and e.errno in _DISK_ERRNOS:
            raise OutputError(f"{what} {out}: cannot write it ({e.strerror or e}); an existing file there was "
                              f"left as it was") from e
        raise


#: errors of the disk itself (full, over quota, read-only, I/O): reported naming --out, no traceback
_DISK_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EIO, errno.EFBIG)


@contextlib.contextmanager
def staged_dir(out, force=False, what="--out"):
    """Write a whole output folder or nothing (see the module docstring).  Yields the staging
    folder (a :class:`Path`); on normal exit it becomes ``out``."""
    out = check_out_dir(out, what, force)
    parent, name = out.parent, out.name
    try:
        made = _make_parents(parent)
    except OSError as e:
        raise OutputError(f"{what} {out}: cannot create {e.filename or parent} ({e.strerror})") from None
    if _sweep_leftovers(parent, name):
        out = check_out_dir(out, what, force)  # --out is back: check it again
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{name}.staging-{os.getpid()}-", dir=parent))
        os.chmod(staging, DIR_MODE)
    except OSError as e:
        _remove_empty(made)
        raise OutputError(f"{what} {out}: cannot create a folder in {parent} ({e.strerror})") from None
    try:
        yield staging
        _test_hook("staged")
        with _signals_deferred():
            _test_hook("swap")
            _swap(staging, out, force, what)
    except BaseException as e:
        with _signals_deferred():
            shutil.rmtree(staging, ignore_errors=True)
            _remove_empty(made)
        if isinstance(e, OSError) and not isinstance(e, MjbenchError) and \
                str(getattr(e, "filename", "") or "").startswith(str(staging)):
            raise OutputError(f"{what} {out}: cannot write {Path(e.filename).name} "
                              f"({e.strerror or e}); {out} was left as it was") from e
        if isinstance(e, OSError) and not isinstance(e, MjbenchError) and e.errno in _DISK_ERRNOS:
            raise OutputError(f"{what} {out}: cannot write the outputs ({e.strerror or e}); {out} was left as it "
                              f"was") from e
        raise


def _swap(staging: Path, out: Path, force: bool, what: str):
    try:
        os.replace(staging, out)  # out missing, or an empty folder: one atomic rename
        return
    except OSError as e:
        if e.errno not in (errno.ENOTEMPTY, errno.EEXIST):
            raise OutputError(f"{what} {out}: cannot move the outputs into place ({e.strerror})") from None
    if not force:  # it was empty or missing when the run started
        raise OutputError(f"{what} {out} was filled by another process during the run; the new outputs "
                          f"were not moved in ({force_hint(what)} to replace it)")
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-{os.getpid()}-", dir=out.parent))
    os.rmdir(old)
    os.rename(out, old)
    try:
        os.rename(staging, out)
    except BaseException:
        os.rename(old, out)
        raise
    shutil.rmtree(old, ignore_errors=True)


@contextlib.contextmanager
def maybe_staged_dir(out, force=False, what="--out"):
    """:func:`staged_dir` when ``out`` is given, else yields None (commands whose --out is optional)."""
    if out is None:
        yield None
    else:
        with staged_dir(out, force, what) as tmp:
            yield tmp


def add_force_option(parser):
    parser.add_argument("--force", action="store_true",
                        help="replace a non-empty --out folder (the old one is kept until the new outputs "
                             "are complete)")


# ============================================================================ MuJoCo's log
MUJOCO_WARNINGS: list = []  #: MuJoCo warnings of this process (at most 100 kept)
_seen_warnings: dict = {}


def _mujoco_warning(msg: str):
    """Called by MuJoCo (mju_user_warning) instead of appending to ./MUJOCO_LOG.TXT and printing
    on stdout: kept in MUJOCO_WARNINGS and printed once per kind on stderr.  MuJoCo calls it only
    when a warning is raised (once per MjData and warning type), never per step."""
    msg = str(msg).strip()
    if len(MUJOCO_WARNINGS) < 100:
        MUJOCO_WARNINGS.append(msg)
    kind = msg.split(" Time =")[0]
    n = _seen_warnings.get(kind, 0)
    _seen_warnings[kind] = n + 1
    if n == 0:
        print(f"mjbench: MuJoCo warning: {msg}", file=sys.stderr)


def mujoco_log_path() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mjbench" / "MUJOCO_LOG.TXT"


def route_mujoco_log():
    """Keep MuJoCo's log out of the working folder: warnings go to :func:`_mujoco_warning` (unless
    the process already set its own handler) and MuJoCo's log file, used for its remaining
    messages, is moved to ~/.cache/mjbench/MUJOCO_LOG.TXT (file logging is switched off if that
    folder cannot be created)."""
    try:
        import mujoco
    except Exception as e:  # noqa: BLE001 - e.g. MUJOCO_GL=osmesa without libOSMesa
        raise MjbenchError(f"MuJoCo cannot be imported with MUJOCO_GL={os.environ.get('MUJOCO_GL')!r} "
                           f"({type(e).__name__}: {e}); unset MUJOCO_GL or set MUJOCO_GL=egl") from None
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_mujoco_warning)
    cfg_cls = getattr(mujoco, "MjLogConfig", None)
    if cfg_cls is not None:
        try:
            cfg = cfg_cls.get()
            if os.path.basename(cfg.logfile or "") == "MUJOCO_LOG.TXT" and not os.path.isabs(cfg.logfile):
                path = mujoco_log_path()
                try:
                    path.parent.mkdir(parents=True, exist_ok=True)
                    cfg.logfile = str(path)
                except OSError:
                    cfg.logto_file = False
                cfg.set()
        except Exception:  # noqa: BLE001 - best effort, never fatal
            pass
