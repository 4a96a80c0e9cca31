"""Where compiled code lives: a user cache folder, never the source tree or site-packages.

``MJBENCH_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/mjbench`` (default ``~/.cache/mjbench``).
The generated kernel modules go to ``<cache>/kernels/`` and numba's own cache to
``<cache>/numba/`` (``NUMBA_CACHE_DIR``, unless the user set it).  A folder that cannot be
written is not replaced by a temporary one: the compiled loop is then built in memory for this
process only (nothing left behind; :data:`NOTES` says so once).

A generated module carries the SHA-256 of its own text on its first line; a module whose text does
not match (truncated, edited, corrupted on disk) or that fails to load is rebuilt, with numba's
cache entries of that module, and :data:`NOTES` says so.
"""
from __future__ import annotations

import glob
import hashlib
import os
import sys
from pathlib import Path

_ROOT: Path | None = None
_CHECKED = False
NOTES: list = []
HEADER = "# mjbench kernel sha256="


def root() -> Path | None:
    """The cache folder (created on first use), or None when it cannot be written."""
    global _ROOT, _CHECKED
    if not _CHECKED:
        _CHECKED = True
        base = os.environ.get("MJBENCH_CACHE_DIR")
        if not base:
            xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
            base = os.path.join(xdg, "mjbench")
        path = Path(base)
        try:
            path.mkdir(parents=True, exist_ok=True)
            probe = path / f".probe-{os.getpid()}"
            probe.write_text("")
            probe.unlink()
            _ROOT = path
        except OSError as e:
            NOTES.append(f"cache folder {base} is not writable ({e.strerror}): compiled loops are built in memory "
                         f"for this process only (set MJBENCH_CACHE_DIR to a writable folder to keep them)")
    return _ROOT


def kernels() -> Path | None:
    """The generated kernels' folder (on ``sys.path``), or None without a writable cache."""
    r = root()
    if r is None:
        return None
    p = r / "kernels"
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    if str(p) not in sys.path:
        sys.path.append(str(p))
    return p


def configure_numba() -> None:
    """Point numba's cache at the user cache folder (before numba is imported)."""
    r = root()
    if "NUMBA_CACHE_DIR" not in os.environ and r is not None:
        os.environ["NUMBA_CACHE_DIR"] = str(r / "numba")


def stamp(text: str) -> str:
    """``text`` with its checksum line first."""
    return f"{HEADER}{hashlib.sha256(text.encode()).hexdigest()}\n{text}"


def intact(path: Path) -> bool:
    """Whether the module file at ``path`` holds exactly the text its checksum line states."""
    try:
        raw = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    first, _, rest = raw.partition("\n")
    return first.startswith(HEADER) and first[len(HEADER):] == hashlib.sha256(rest.encode()).hexdigest()


def purge(name: str) -> None:
    """Remove a generated module and numba's cache entries for it (a corrupted entry)."""
    k = kernels()
    if k is not None:
        for p in (k / f"{name}.py",):
            try:
                p.unlink()
            except OSError:
                pass
        for d in (k / "__pycache__",):
            for f in glob.glob(str(d / f"{name}.*")):
                try:
                    os.unlink(f)
                except OSError:
                    pass
    nc = os.environ.get("NUMBA_CACHE_DIR")
    for base in filter(None, (nc, str(k / "__pycache__") if k is not None else None)):
        for f in glob.glob(os.path.join(base, "**", f"{name}*"), recursive=True):
            try:
                os.unlink(f)
            except OSError:
                pass


def note(msg: str) -> None:
    if msg not in NOTES:
        NOTES.append(msg)
