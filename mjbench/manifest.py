"""Run manifests and JSON output (all parameters, versions, command), written atomically."""
from __future__ import annotations

import datetime
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np

from . import outputs


def versions() -> dict:
    """Versions of mjbench and the libraries a run depends on (installed distributions' metadata:
    a run need not import matplotlib or scipy to state their versions)."""
    import mujoco

    from . import __version__

    return {"mjbench": __version__, "mujoco": mujoco.__version__, "numpy": np.__version__,
            "scipy": _dist_version("scipy"), "matplotlib": _dist_version("matplotlib"),
            "python": sys.version.split()[0], "platform": platform.platform()}


def _dist_version(name: str) -> str | None:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return None


def git_commit() -> str | None:
    try:
        here = Path(__file__).resolve().parent
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True, timeout=5)
        return out.stdout.strip() or None
    except Exception:  # noqa: BLE001 - informative only
        return None


def manifest(scn, argv=None, extra=None) -> dict:
    """Run manifest: the fully resolved scenario (every value, SI, defaults filled in — a run can be
    repeated from it: ``mjbench run manifest.json``), where it came from, the overrides applied,
    plausibility warnings, versions, command and git commit."""
    return {"created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
            "command": list(sys.argv if argv is None else argv), "versions": versions(),
            "git_commit": git_commit(), "scenario_source": scn.source, "overrides": list(scn.overrides),
            "warnings": list(scn.warnings), "scenario": scn.resolved(), **(extra or {})}


def json_default(o):
    """JSON encoder fallback for NumPy scalars/arrays and paths (shared by every JSON writer)."""
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    return str(o)


def write_json(path, obj):
    """Strict JSON (no NaN/Infinity: see mjbench/outputs.py), written atomically."""
    return outputs.write_json(path, obj)
