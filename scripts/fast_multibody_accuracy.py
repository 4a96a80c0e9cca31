#!/usr/bin/env python
"""Accuracy and cost of the opt-in fast multibody mode (Euler / implicitfast instead of RK4).

Seed 000, h = 0.1 ms, 2 s: PID (K_p·t) and open loop 25 V.  Reference: the reduced model with the
closed forms (an independent formulation of the same mechanics).  Prints, per integrator, the
largest crank-speed difference relative to the peak speed, the largest loop-closure residual [m]
and the CPU cost per step relative to RK4.  The numbers quoted by ``mjbench`` when the fast mode
is chosen (mjbench.backends.multibody.FAST_ACCURACY) come from this script.
Usage: python scripts/fast_multibody_accuracy.py [--t-end 2]
"""
import argparse
import time

import numpy as np

from mjbench import scenario as S
from mjbench.backends import multibody, reduced


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--t-end", type=float, default=2.0)
    args = ap.parse_args()
    scn = S.load("incerti2012")
    ref = {m: reduced.simulate(S.make_machine(scn, m), args.t_end, record_dt=1e-3, model="closed")
           for m in ("pid", "open")}
    cost = {}
    for integ in ("RK4", "implicitfast", "Euler"):
        o = {"integrator": integ}
        row = {}
        for mode in ("pid", "open"):
            c0 = time.process_time()
            tr = multibody.simulate(S.make_machine(scn, mode), args.t_end, record_dt=1e-3, options=o)
            cost.setdefault(integ, 0.0)
            cost[integ] += time.process_time() - c0
            r = ref[mode]
            n = min(tr.n, r.n)
            row[mode] = float(np.max(np.abs(tr.qd[:n] - r.qd[:n])) / np.max(np.abs(r.qd[:n])))
            row[f"closure_{mode}"] = float(np.nanmax(tr.closure))
        print(f"{integ:>12s}: PID speed error {row['pid']:.2g} of peak, open loop {row['open']:.2g} of peak, "
              f"closure ≤ {max(row['closure_pid'], row['closure_open']):.2g} m, cost {cost[integ] / cost['RK4']:.2f}× RK4",
              flush=True)


if __name__ == "__main__":
    main()
