"""A command costs its simulation, not its imports: which modules a command loads, checked by module
name (deterministic, unlike timings; the CPU figures are in scripts/bench.py and docs/performance.md)."""
import importlib
import json
import os
import pkgutil
import subprocess
import sys

import pytest

from mjbench import cli

HEAVY_FOR_A_RUN = ("control", "matplotlib.pyplot", "scipy.integrate", "scipy.stats", "numba", "pint", "OpenGL",
                   "dask", "tqdm.contrib")


def _modules_after(args, tmp_path, env_extra=None):
    """sys.modules of a `mjbench ARGS` process at exit (through a sitecustomize-free wrapper)."""
    out = tmp_path / "mods.json"
    code = ("import atexit, json, sys\n"
            f"atexit.register(lambda: json.dump(sorted(sys.modules), open({str(out)!r}, 'w')))\n"
            "from mjbench.cli import main\n"
            f"rc = main({list(args)!r})\n"
            "sys.exit(rc)\n")
    env = {**os.environ, "MUJOCO_GL": "egl", **(env_extra or {})}
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    return set(json.loads(out.read_text())), p


def test_command_table_matches_the_modules_registrations():
    """cli.COMMAND_MODULES (which module to import for a command) is exactly what the modules register."""
    import argparse

    from mjbench import commands

    found = {}
    for info in pkgutil.iter_modules(commands.__path__):
        mod = importlib.import_module(f"mjbench.commands.{info.name}")
        if not hasattr(mod, "register"):
            continue
        sub = argparse.ArgumentParser().add_subparsers()
        mod.register(sub)
        for name in sub.choices:
            found[name] = info.name
    assert found == cli.COMMAND_MODULES


def test_version_imports_nothing_heavy(tmp_path):
    mods, p = _modules_after(["--version"], tmp_path)
    assert p.stdout.startswith("mjbench ")
    assert not {"numpy", "mujoco", "pydantic"} & mods


def test_a_plain_run_loads_only_what_it_uses(tmp_path):
    """A short multibody run of a plain-number scenario without the figure: no python-control,
    pyplot, scipy.integrate/stats, numba, pint, PyOpenGL, Dask."""
    mods, _ = _modules_after(["run", "incerti2012", "--mode", "pid", "--backend", "multibody", "--t-end", "0.05",
                              "--no-figure", "--out", str(tmp_path / "o")], tmp_path)
    assert "mujoco" in mods and "mjbench.kernel" in mods
    loaded = sorted(m for m in HEAVY_FOR_A_RUN if m in mods)
    assert not loaded, loaded


@pytest.mark.parametrize("sub", ["list", "run"])
def test_a_command_imports_only_its_own_module(tmp_path, sub):
    args = ["list"] if sub == "list" else ["run", "incerti2012", "--backend", "reduced", "--t-end", "0.02",
                                           "--no-figure", "--out", str(tmp_path / "o")]
    mods, _ = _modules_after(args, tmp_path)
    cmds = {m for m in mods if m.startswith("mjbench.commands")}
    assert cmds == {"mjbench.commands", f"mjbench.commands.{cli.COMMAND_MODULES[sub]}"}, cmds


def test_a_press_run_needs_neither_pint_nor_scipy_optimize_the_second_time(tmp_path):
    """press-slidercrank writes its angles with units and is a generic linkage: its unit strings are
    read without pint (mjbench.units' fast path) and, from the second run on, its built linkage comes
    from the user cache (no assembly: no scipy.optimize)."""
    env = {"MJBENCH_CACHE_DIR": str(tmp_path / "cache")}
    args = ["run", "press-slidercrank", "--backend", "multibody", "--t-end", "0.01", "--no-figure", "--force",
            "--out", str(tmp_path / "o")]
    first, _ = _modules_after(args, tmp_path, env)
    second, _ = _modules_after(args, tmp_path, env)
    assert "scipy.optimize" in first and "pint" not in first
    heavy = sorted(m for m in HEAVY_FOR_A_RUN + ("scipy.optimize", "scipy.linalg") if m in second)
    assert not heavy, heavy


def test_the_manifest_states_the_installed_versions():
    """The manifest reads scipy's and matplotlib's versions from their dist-info without parsing the
    whole METADATA file: the same strings importlib.metadata gives."""
    from importlib.metadata import version

    from mjbench import manifest

    v = manifest.versions()
    assert v["scipy"] == version("scipy") and v["matplotlib"] == version("matplotlib")
    assert manifest._dist_version("no-such-distribution-here") is None
