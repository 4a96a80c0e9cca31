"""Whole commands: a 2 s multibody `mjbench run press-slidercrank` against a bare numpy + mujoco script.

CPU time (user + system) of child processes, interleaved, best of --repeat: the bare script imports
numpy and mujoco, loads assets/mjcf/press_slidercrank.xml at its keyframe and takes the same 20 000
``mj_step``.  The ratio is the fixed cost of a command over its simulation (goal ≤ 1.5).
"""
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BARE = ("import numpy, mujoco\n"
        "m = mujoco.MjModel.from_xml_path({xml!r})\n"
        "d = mujoco.MjData(m)\n"
        "mujoco.mj_resetDataKeyframe(m, d, 0)\n"
        "for _ in range(20000):\n"
        "    mujoco.mj_step(m, d)\n")


def _cpu(cmd, env):
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def run(args):
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    with tempfile.TemporaryDirectory() as tmp:
        run_cmd = [sys.executable, "-m", "mjbench", "run", "press-slidercrank", "--backend", "multibody", "--t-end",
                   "2", "--no-figure", "--quiet", "--out", str(Path(tmp) / "out"), "--force"]
        bare_cmd = [sys.executable, "-c", BARE.format(xml=str(ROOT / "assets" / "mjcf" / "press_slidercrank.xml"))]
        ver_cmd = [sys.executable, "-m", "mjbench", "--version"]
        _cpu(run_cmd, env)  # the caches (compiled loops, a built linkage) as a user's second run finds them
        tr, tb, tv = [], [], []
        for _ in range(max(1, args.repeat)):
            tr.append(_cpu(run_cmd, env))
            tb.append(_cpu(bare_cmd, env))
            tv.append(_cpu(ver_cmd, env))
    r, b = sorted(tr)[len(tr) // 2], sorted(tb)[len(tb) // 2]
    return [
        ("run_over_bare_press", r / b, "`mjbench run press-slidercrank --backend multibody --t-end 2 --no-figure` CPU "
                                       "/ bare numpy+mujoco script, same 20 000 mj_step (medians; goal ≤ 1.5)"),
        ("run_press_cpu_s", r, "that run's CPU [s] (median)"),
        ("bare_press_cpu_s", b, "the bare script's CPU [s] (median)"),
        ("version_cpu_s", sorted(tv)[len(tv) // 2], "`mjbench --version` CPU [s] (median)"),
    ]
