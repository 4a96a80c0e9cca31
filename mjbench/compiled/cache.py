"""Where compiled code lives: a user cache folder, never the source tree or site-packages.

``MJBENCH_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/mjbench`` (default ``~/.cache/mjbench``).
The generated kernel modules go to ``<cache>/kernels/`` and numba's own cache to
``<cache>/numba/`` (``NUMBA_CACHE_DIR``, unless the user set it).  A folder that cannot be
written is not replaced by a temporary one: the compiled loop is then built in memory for this
process only (nothing left behind; :data:`NOTES` says so once).

A generated module carries the SHA-256 of its own text on its first line; a module whose text does
not match (truncated, edited, corrupted on disk) or that fails to load is rebuilt, with numba's
cache entries of that module, and :data:`NOTES` says so.

Objects that are costly to build and cheap to read back (a linkage's assembled branch and tables)
are kept in ``<cache>/<folder>/`` (:func:`load_object`, :func:`store_object`): keyed by their
description and :func:`code_version`, written atomically, each file carrying the SHA-256 of its
contents (a corrupted entry is removed, rebuilt and said in :data:`NOTES`); without a writable cache
nothing is written.
"""
from __future__ import annotations

import glob
import hashlib
import os
import pickle
import sys
import zlib
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
            NOTES.append(f"cache folder {base} is not writable ({e.strerror}): compiled loops and built linkages are "
                         f"kept in memory for this process only (set MJBENCH_CACHE_DIR to a writable folder to keep "
                         f"them)")
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


# ============================================================================ stored objects
#: first bytes of a stored object's file, then :func:`checksum` of the pickle that follows
OBJECT_MAGIC = b"mjbench-object-2\n"
#: what every version's entries start with (an entry of another version is absent, not corrupted)
OBJECT_FAMILY = b"mjbench-object-"
#: stored objects kept per folder (the oldest beyond are removed when one is stored)
KEEP_OBJECTS = 64
_VERSION: str | None = None


def code_version() -> str:
    """A fingerprint of the code that builds stored objects: every source file of mjbench (its path,
    size and modification time: no file is read), Python's version, NumPy's and SciPy's."""
    global _VERSION
    if _VERSION is None:
        import importlib.util

        h = hashlib.sha256(sys.version.encode())
        here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        for dirpath, dirnames, files in os.walk(here):
            dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
            for f in sorted(files):
                if f.endswith(".py") or f.endswith(".toml"):
                    st = os.stat(os.path.join(dirpath, f))
                    h.update(f"{os.path.relpath(os.path.join(dirpath, f), here)}:{st.st_size}:{st.st_mtime_ns}".encode())
        for pkg in ("numpy", "scipy"):
            spec = importlib.util.find_spec(pkg)
            ver = os.path.join(os.path.dirname(spec.origin), "version.py") if spec and spec.origin else ""
            try:
                with open(ver, "rb") as fh:
                    h.update(fh.read())
            except OSError:
                h.update(pkg.encode())
        _VERSION = h.hexdigest()
    return _VERSION


def checksum(body: bytes) -> bytes:
    """An entry's check: its length and CRC-32 (12 bytes).  It tells a truncated or corrupted file,
    which is all it is for (the cache is the user's own; nothing adversarial), at ≈ 1/30 of SHA-256's
    cost: a built linkage's 2 MB entry is checked in ≈ 1 ms instead of ≈ 20 ms."""
    return len(body).to_bytes(8, "little") + zlib.crc32(body).to_bytes(4, "little")


CHECK_BYTES = 12


def _object_path(folder: str, key: str) -> Path | None:
    r = root()
    return None if r is None else r / folder / f"{key}.pickle"


def load_object(folder: str, key: str, what: str = "cache entry"):
    """The object stored under ``key`` in ``folder``, or None (absent, no cache; an entry whose
    checksum does not match or that cannot be read back is removed and said in :data:`NOTES`)."""
    path = _object_path(folder, key)
    if path is None:
        return None
    try:
        raw = path.read_bytes()
    except OSError:
        return None
    n = len(OBJECT_MAGIC)
    body = raw[n + CHECK_BYTES:]
    if raw[:n] != OBJECT_MAGIC and raw.startswith(OBJECT_FAMILY) and raw[n - 1:n] == b"\n":
        try:  # an entry of an earlier version of this format: not ours to read, replaced silently
            path.unlink()
        except OSError:
            pass
        return None
    try:
        if raw[:n] != OBJECT_MAGIC or raw[n:n + CHECK_BYTES] != checksum(body):
            raise ValueError("checksum")
        return pickle.loads(body)  # noqa: S301 - our own file in the user's own cache, checksummed
    except Exception as e:  # noqa: BLE001 - a corrupted or unreadable entry: rebuilt
        try:
            path.unlink()
        except OSError:
            pass
        note(f"{what}: its cache entry could not be read ({e if isinstance(e, ValueError) else type(e).__name__}); "
             f"rebuilt")
        return None


def store_object(folder: str, key: str, obj) -> bool:
    """Store ``obj`` under ``key`` in ``folder`` (atomically: a temporary file renamed); → whether stored.
    Without a writable cache, or when the write fails, nothing is left behind."""
    path = _object_path(folder, key)
    if path is None:
        return False
    tmp = path.parent / f".{key}.{os.getpid()}.tmp"
    try:
        body = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_bytes(OBJECT_MAGIC + checksum(body) + body)
        os.replace(tmp, path)
    except (OSError, pickle.PicklingError, TypeError, AttributeError):
        try:
            tmp.unlink()
        except OSError:
            pass
        return False
    try:
        entries = sorted(path.parent.glob("*.pickle"), key=lambda p: p.stat().st_mtime_ns)
        for old in entries[:max(0, len(entries) - KEEP_OBJECTS)]:
            old.unlink()
    except OSError:
        pass
    return True
