#!/usr/bin/env python
"""mjbench benchmarks: ratios against the bare MuJoCo loop on the same model, measured in one run.

Each module in scripts/bench_parts/ defines ``run(args) -> list[(name, value, description)]``.
Prints a human-readable table, then one machine-readable ``name=value`` line per figure.
Usage: python scripts/bench.py [--only PART ...] [--repeat N]

Runs are on the compiled co-step loop (mjbench.kernel, numba; each part loads it first) unless a
row says otherwise; the CPython loop is the reference of the tests, not of the benchmarks.
"""
import argparse
import importlib
import pkgutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", nargs="*", help="run only these parts (module names in bench_parts)")
    ap.add_argument("--repeat", type=int, default=3, help="repetitions; the best (minimum) time is kept")
    args = ap.parse_args()
    import bench_parts
    names = sorted(i.name for i in pkgutil.iter_modules(bench_parts.__path__))
    if args.only:
        names = [n for n in names if n in args.only]
    rows = []
    for n in names:
        mod = importlib.import_module(f"bench_parts.{n}")
        print(f"== {n}: {(mod.__doc__ or '').strip().splitlines()[0] if mod.__doc__ else ''}", flush=True)
        for name, value, desc in mod.run(args):
            rows.append((name, value, desc))
            print(f"  {name:<40s} {value:>12.4g}   {desc}", flush=True)
    print()
    for name, value, _ in rows:
        print(f"{name}={value:.6g}")


if __name__ == "__main__":
    main()
