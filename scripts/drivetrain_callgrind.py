#!/usr/bin/env python
"""Instructions per co-simulation step of each drive-train element (callgrind): a cost measure that
does not depend on the machine's load, next to the CPU-time ratios of scripts/bench_parts/drivetrain.py.

Runs itself under ``valgrind --tool=callgrind``; inside each run a tiny C helper (compiled here from
valgrind/callgrind.h), called by a wrapper of the mode's controller, zeroes the counters at sample n₁
and dumps them at sample n₂, so imports, set-up, compile and allocation are not counted: instructions
per co-step = I / (n₂ − n₁).  Seed-000 four-bar open loop at 0.1 ms, each element alone (the
configurations and mode of scripts/bench_parts/drivetrain.py).

Usage: python scripts/drivetrain_callgrind.py [--only ideal pwm_switching ...] [--n1 300 --n2 1300]
       (≈ 5-10 min; needs valgrind, its headers and a C compiler)
"""
import argparse
import gc
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
HELPER = r"""
#include <valgrind/callgrind.h>
void cg_zero(void) { CALLGRIND_ZERO_STATS; }
void cg_dump(const char *label) { CALLGRIND_DUMP_STATS_AT(label); }
"""


def inner(args):
    import ctypes

    sys.path.insert(0, str(HERE))  # bench_parts (mjbench: the installed one, or PYTHONPATH's)
    from bench_parts.drivetrain import ALL, ELEMENTS, MODE

    from mjbench import scenario as S
    from mjbench.backends import multibody, reduced

    print("mjbench from", S.__file__, file=sys.stderr)
    lib = ctypes.CDLL(args.lib)
    lib.cg_dump.argtypes = [ctypes.c_char_p]

    class Probe:
        """The mode's controller, zeroing the counters at sample n1 and dumping them at n2 (inside
        one run: no set-up, allocation or compile is counted)."""

        def __init__(self, inner, label):
            self.inner, self.label, self.period, self.n = inner, label, inner.period, 0

        def reset(self):
            self.n = 0
            self.inner.reset()

        def __call__(self, t, y):
            if self.n == args.n1:
                lib.cg_zero()
            elif self.n == args.n2:
                lib.cg_dump(self.label)
            self.n += 1
            return self.inner(t, y)

    configs = {"ideal": [], **ELEMENTS, "realistic_all": ALL}
    if args.only:
        configs = {k: v for k, v in configs.items() if k in args.only}
    h = 1e-4
    warm = S.load("incerti2012")  # the first run of a process costs more (lazy initialisations)
    for mod in (multibody, reduced):
        mod.simulate(S.make_machine(warm, MODE), 0.05, dt=h, record_dt=1e-3)
    # the cyclic GC's full collections scan the whole heap (numpy, scipy, pint ...): one landing in a
    # window adds ~1e5 instructions per step to that configuration only; freeze the start-up heap
    gc.collect()
    gc.freeze()
    lib.cg_zero()  # the first ctypes calls cost ~1e8 instructions (set-up): not in a measured window
    lib.cg_dump(b"warm-up|none|1")
    for k, sets in configs.items():
        scn = S.load("incerti2012", sets)
        for b, mod in (("multibody", multibody), ("reduced", reduced)):
            m = S.make_machine(scn, MODE)
            m.controller = Probe(m.controller, f"{k}|{b}|{args.n2 - args.n1}".encode())
            gc.collect()
            mod.simulate(m, (args.n2 + 5) * h, dt=h, record_dt=1e-3)


def outer(args):
    tmp = Path(tempfile.mkdtemp(prefix="mjbench-cg-"))
    (tmp / "helper.c").write_text(HELPER)
    lib = tmp / "libcghelper.so"
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-o", str(lib), str(tmp / "helper.c")], check=True)
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={tmp}/cg.out", "--dump-instr=no",
           "--collect-jumps=no", sys.executable, __file__, "--inner", "--lib", str(lib),
           "--n1", str(args.n1), "--n2", str(args.n2)] + (["--only", *args.only] if args.only else [])
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env={**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "PYTHONHASHSEED": "0"})
    per = {}
    for f in tmp.glob("cg.out*"):
        text = f.read_text(errors="replace")
        m = re.search(r"Client Request: (\S+)", text)
        t = re.search(r"^(?:summary|totals): (\d+)", text, re.M)
        if m and t:
            k, b, n = m.group(1).split("|")
            if k != "warm-up":
                per[(k, b)] = int(t.group(1)) / int(n)
    res = {"instructions_per_step": {f"{k}/{b}": v for (k, b), v in sorted(per.items())}}
    for b in ("multibody", "reduced"):
        if ("ideal", b) in per:
            res[f"ratio_to_ideal_{b}"] = {k: v / per[("ideal", b)] for (k, bb), v in sorted(per.items()) if bb == b}
    print(json.dumps(res, indent=1))
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--inner", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--lib", help=argparse.SUPPRESS)
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--n1", type=int, default=300)
    ap.add_argument("--n2", type=int, default=1300)
    ap.add_argument("--out", help="also write the JSON here")
    args = ap.parse_args()
    (inner if args.inner else outer)(args)


if __name__ == "__main__":
    main()
