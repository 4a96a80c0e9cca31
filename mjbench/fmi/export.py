"""Export a scenario's plant (or one mode's controller) as an FMI 2.0 co-simulation FMU (pythonfmu).

:func:`export_fmu` writes a ``.fmu`` holding

* ``modelDescription.xml`` — inputs, outputs and the scenario's physical parameters with FMI units
  (:mod:`mjbench.fmi.units`), ``DefaultExperiment`` = the scenario's run (t_end, record_dt);
* ``binaries/<platform>/`` — pythonfmu's FMI wrapper, which runs the Python shell
  (:mod:`mjbench.fmi.slave`) in the Python of the importing process (FMPy; any tool with
  ``libpython3.x`` preloaded);
* ``resources/`` — ``mjbench_fmu.json`` (the resolved scenario and the export's choices), the
  mechanism's model file if it has one, ``requirements.txt`` (the third-party packages the importing
  Python needs) and a copy of mjbench's own Python sources (used only when the importing Python has
  no mjbench of its own).
"""
from __future__ import annotations

import copy
import importlib.util
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

from .._version import __version__
from ..errors import ParameterError
from .session import ControllerSession, PlantSession

#: third-party distributions the FMU's Python code imports at run time (name → import name)
RUNTIME = (("mujoco", "mujoco"), ("numpy", "numpy"), ("scipy", "scipy"), ("pydantic", "pydantic"), ("pint", "pint"))
KINDS = ("plant", "controller")


def _ident(s: str) -> str:
    out = "".join(c if (c.isalnum() or c == "_") else "_" for c in s)
    return out if out and not out[0].isdigit() else f"m_{out}"


def _requirements() -> str:
    """requirements.txt of the FMU: the installed versions of the runtime packages (as minimums;
    MuJoCo pinned to the version the FMU was exported and checked with)."""
    from importlib.metadata import PackageNotFoundError, version

    lines = []
    for dist, _ in RUNTIME:
        names = ("mujoco-core", "mujoco") if dist == "mujoco" else (dist,)
        for d in names:
            try:
                v = version(d)
            except PackageNotFoundError:
                continue
            lines.append(f"{d}=={v}" if dist == "mujoco" else f"{d}>={v}")
            break
        else:
            lines.append(dist)
    return "\n".join(lines) + "\n"


def _copy_sources(dest: Path) -> list[Path]:
    """mjbench's and the controllers' Python sources and data files (no caches) under ``dest``."""
    out = []
    for src in (Path(__file__).resolve().parents[1], Path(importlib.util.find_spec("controllers").origin).parent):
        dst = dest / src.name
        shutil.copytree(src, dst, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so"))
        out.append(dst)
    return out


def export_fmu(scn, out, kind: str = "plant", input: str = "voltage", backend: str = "multibody",
               mode: str | None = None, bundle_sources: bool = True) -> Path:
    """Write the FMU of ``scn`` (a validated scenario) to ``out`` (a ``.fmu`` path) → its path.

    ``kind = "plant"``: mechanism + drive (+ drive train) on ``backend``, input ``voltage`` [V] or
    ``torque`` [N·m] (an ideal current source on the rigid drive); ``kind = "controller"``: the
    controller of ``mode`` (inputs q, q̇, q̈, I; output u).  The plant is checked by building it
    once before anything is written."""
    from pythonfmu.builder import FmuBuilder


    out = Path(out)
    if out.suffix != ".fmu":
        raise ParameterError(f"--out {out}: an FMU file name ends in .fmu")
    if kind not in KINDS:
        raise ParameterError(f"kind = {kind!r}: choose one of {', '.join(KINDS)}")
    name = scn.name
    if kind == "plant":
        s = PlantSession(scn, input, backend)
        s.start()  # the machine builds with these values (errors before anything is written)
        s.finish()
        model = _ident(f"{name}_plant_{input}")
        desc = (f"mjbench plant of scenario {name!r}: mechanism + drive"
                f"{' + drive train' if getattr(scn.drive, 'pwm', None) or scn.drive.gear or scn.drive.encoder else ''}"
                f", {backend} backend, input {input}, co-simulation step {scn.simulation.dt:g} s")
        config = {"kind": "plant", "input": input, "backend": backend}
        slave = "PlantSlave"
    else:
        mode = scn.mode(mode)
        c = ControllerSession(scn, mode)
        c.start()
        model = _ident(f"{name}_{mode}_controller")
        desc = f"mjbench controller of scenario {name!r}, mode {mode!r} ({scn.modes[mode].type})"
        config = {"kind": "controller", "mode": mode}
        slave = "ControllerSlave"
    raw = copy.deepcopy(scn.raw)
    with tempfile.TemporaryDirectory(prefix="mjbench_fmu_") as tmp:
        tmp = Path(tmp)
        files: list[Path] = []
        mech = raw.get("mechanism", {})
        f = mech.get("file") if isinstance(mech, dict) else None
        if isinstance(f, str) and os.path.isfile(f):  # a user's MJCF: shipped in resources/models
            (tmp / "models").mkdir()
            shutil.copy2(f, tmp / "models" / os.path.basename(f))
            mech["file"] = f"models/{os.path.basename(f)}"
            files.append(tmp / "models")
        config.update({"model_name": model, "description": desc, "scenario": raw,
                       "source": scn.source, "mjbench_version": __version__,
                       "overrides": list(scn.overrides)})
        cfg = tmp / "mjbench_fmu.json"
        cfg.write_text(json.dumps(config, indent=1, allow_nan=True), encoding="utf-8")
        req = tmp / "requirements.txt"
        req.write_text(_requirements(), encoding="utf-8")
        files += [cfg, req]
        if bundle_sources:
            src = tmp / "src"
            src.mkdir()
            files += _copy_sources(src)
        module = f"mjbench_fmu_{model}"
        script = tmp / "script" / f"{module}.py"
        script.parent.mkdir()
        script.write_text(_SCRIPT.format(slave=slave, cls=model), encoding="utf-8")
        out.parent.mkdir(parents=True, exist_ok=True)
        try:
            path = FmuBuilder.build_FMU(script, dest=out, project_files=files)
        finally:
            sys.modules.pop(module, None)
            if str(script.parent) in sys.path:
                sys.path.remove(str(script.parent))
    return Path(path)


_SCRIPT = '''"""pythonfmu entry point generated by mjbench (mjbench/fmi/export.py)."""
import os
import sys

try:
    import mjbench  # noqa: F401 - the importing Python's own mjbench
except ImportError:  # the copy shipped in resources/
    sys.path.append(os.path.dirname(os.path.abspath(__file__)))

from mjbench.fmi.slave import {slave}, keep_namespace

keep_namespace(globals(), 4)  # pythonfmu 0.7.0 releases one reference to this namespace per instance


class {cls}({slave}):
    pass
'''
