#!/usr/bin/env python
"""A command's cost in instructions (callgrind), next to the CPU times of scripts/bench_parts/command.py.

On a shared machine a command's CPU time varies by 1.5× with the other tenants' load; the number of
instructions it executes does not.  This runs, each once under ``valgrind --tool=callgrind``, the
2 s multibody ``mjbench run press-slidercrank --no-figure`` and the bare script of
scripts/bench_parts/command.py (NumPy and MuJoCo imported, the same 20 000 ``mj_step`` on
``assets/mjcf/press_slidercrank.xml``), and prints their instruction counts, the ratio (the goal of
the CPU ratio is ≤ 1.5), and ``mj_step``'s own share of each.  The user cache is a fresh folder
filled by one run outside valgrind first (valgrind's floating point is not the processor's: a
linkage built under it is not the one a user's second command reads back).

Usage: python scripts/command_instructions.py [--t-end 2]   (≈ 3 min; needs valgrind)
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_parts.command import BARE  # noqa: E402 - the script beside this one


def _callgrind(cmd, env, tmp, name):
    out = Path(tmp) / f"cg.{name}"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *cmd], check=True, env=env,
                   cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    total = step = 0
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", str(out)], check=True, capture_output=True,
                          text=True).stdout
    for line in text.splitlines():
        m = re.match(r"\s*([\d,]+)\s+\([^)]*\)\s+(.*)$", line)
        if not m:
            continue
        n = int(m.group(1).replace(",", ""))
        if "PROGRAM TOTALS" in m.group(2):
            total = n
        elif re.search(r":mj_step \[", m.group(2)) and not step:
            step = n
    return total, step


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--t-end", type=float, default=2.0)
    args = ap.parse_args()
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        sys.exit("command_instructions.py: valgrind (callgrind) is not installed")
    steps = int(round(args.t_end / 1e-4))
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), MJBENCH_CACHE_DIR=str(Path(tmp) / "cache"))
        run = [sys.executable, "-m", "mjbench", "run", "press-slidercrank", "--backend", "multibody", "--t-end",
               repr(args.t_end), "--no-figure", "--quiet", "--out", str(Path(tmp) / "out"), "--force"]
        bare = [sys.executable, "-c", BARE.format(xml=str(ROOT / "assets" / "mjcf" / "press_slidercrank.xml"))
                .replace("range(20000)", f"range({steps})")]
        subprocess.run(run, check=True, env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        r, rs = _callgrind(run, env, tmp, "run")
        b, bs = _callgrind(bare, env, tmp, "bare")
    print(f"run   {r / 1e9:7.3f} G instructions (mj_step {rs / 1e9:.3f} G)")
    print(f"bare  {b / 1e9:7.3f} G instructions (mj_step {bs / 1e9:.3f} G)")
    print(f"run_over_bare_press_instructions={r / b:.4f}")


if __name__ == "__main__":
    main()
