"""Run manifests and JSON output (all parameters, versions, command), written atomically."""
from __future__ import annotations

import datetime
import hashlib
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np

from . import outputs
from ._version import __version__
from .scenario import check_model_files  # noqa: F401 - the manifest's check, beside the loading it guards


def versions() -> dict:
    """Versions of mjbench and the libraries a run depends on (installed distributions' metadata:
    a run need not import matplotlib or scipy to state their versions)."""
    import mujoco


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
    plausibility warnings, versions, command and git commit.  A scenario that reads a model file
    (``[mechanism] type = "mjcf"``) also records the file's SHA-256 (``model_files``): repeating
    the run after the file changed is refused (:func:`check_model_files`)."""
    out = {"created_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
           "command": list(sys.argv if argv is None else argv), "versions": versions(),
           "git_commit": git_commit(), "scenario_source": scn.source, "overrides": list(scn.overrides),
           "warnings": list(scn.warnings), "scenario": scn.resolved()}
    files = model_files(scn)
    if files:
        out["model_files"] = files
    ds = getattr(scn.drive, "datasheet", None)
    if ds is not None:  # the drive's values derived from the motor's datasheet, with their formulas
        out["drive_from_datasheet"] = ds.conversion()
    out.update(extra or {})
    return out


def model_files(scn) -> dict:
    """{absolute path: {"sha256": ..., "bytes": n, "copy": name in the run folder}} of the model files the
    scenario reads (the ``file`` of an ``mjcf`` mechanism), {} for the others."""
    path = getattr(scn.mechanism, "file", None)
    if not isinstance(path, str) or not path:
        return {}
    path = os.path.abspath(path)
    with open(path, "rb") as f:
        data = f.read()
    return {path: {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data),
                   "copy": f"{MODEL_COPY_DIR}/{os.path.basename(path)}"}}


#: folder of a run's outputs holding a copy of each model file it read (for the record)
MODEL_COPY_DIR = "model"


def copy_model_files(scn, out_dir) -> None:
    """Copy the scenario's model files into ``out_dir/model/`` (the record of what ran)."""
    import shutil

    for path, info in model_files(scn).items():
        dst = Path(out_dir) / info["copy"]
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, dst)


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
