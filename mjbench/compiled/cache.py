"""Where compiled code lives: a user cache folder, never the source tree or site-packages.

``MJBENCH_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/mjbench`` (default ``~/.cache/mjbench``).
The generated kernel modules go to ``<cache>/kernels/`` and numba's own cache to
``<cache>/numba/`` (``NUMBA_CACHE_DIR``, unless the user set it).  A folder that cannot be
created falls back to a private temporary folder for this process (compiled code is then rebuilt
by every process; :func:`note` says so once).
"""
from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

_ROOT: Path | None = None
NOTES: list = []


def root() -> Path:
    """The cache folder (created on first use)."""
    global _ROOT
    if _ROOT is None:
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
        except OSError as e:
            path = Path(tempfile.mkdtemp(prefix="mjbench-cache-"))
            NOTES.append(f"cache folder {base} is not writable ({e.strerror}); compiled code goes to {path} "
                         f"for this process only (set MJBENCH_CACHE_DIR)")
        _ROOT = path
    return _ROOT


def kernels() -> Path:
    p = root() / "kernels"
    p.mkdir(parents=True, exist_ok=True)
    if str(p) not in sys.path:
        sys.path.append(str(p))
    return p


def configure_numba() -> None:
    """Point numba's cache at the user cache folder (before numba is imported)."""
    if "NUMBA_CACHE_DIR" not in os.environ:
        os.environ["NUMBA_CACHE_DIR"] = str(root() / "numba")
