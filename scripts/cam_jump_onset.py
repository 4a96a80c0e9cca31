"""Where MuJoCo's follower first leaves the cam, against the predicted jump speed (docs/higher_pairs.md §2.4).

For the ``cam-follower`` scenario's cam (or a TOML given as the first argument), for each contact
setting of the follower-on-cam constraint — the default (time constant 3h, impedance 0.9999),
a 1 ms time constant, and MuJoCo's defaults (solref 20 ms, solimp 0.9 0.95 0.001 0.5 2) — the
lowest constant cam speed at which the multibody run shows a separation (the follower more than
GAP_TOL of the lift off the cam), by bisection on runs at constant speed (an ideal speed source
with a stiff loop, the run started at that speed, three cam turns).  Prints one line per setting:
the onset speed, its ratio to the predicted jump speed, the runs it took.

    python scripts/cam_jump_onset.py [scenario] [--tol 5e-4]
"""
from __future__ import annotations

import argparse
import math
import sys
import time

from controllers.constant import ConstantCommand
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.drives.ideal import SpeedDrive
from mjbench.machine import Machine
from mjbench.mechanisms import build

SETTINGS = {
    "default (3h, 0.9999)": {},
    "1 ms, 0.9999": {"contact_solref": (1e-3, 1.0)},
    "5 ms, 0.9999": {"contact_solref": (5e-3, 1.0)},
    "MuJoCo default (20 ms, 0.9-0.95)": {"contact_solref": (0.02, 1.0), "contact_solimp": (0.9, 0.95, 0.001, 0.5, 2.0)},
}


def separates(mech, w, turns=3.0, dt=1e-4) -> bool:
    """Whether the follower leaves the cam within ``turns`` cam turns at the constant speed ``w``."""
    drive = SpeedDrive(k_v=200.0, k_i=2e4)
    ctrl = ConstantCommand.from_params(ConstantCommand.Params(type="constant", speed=w), drive=drive, mechanism=mech)
    t_end = round(turns * 2.0 * math.pi / w / dt) * dt
    tr = simulate(Machine(mech, drive, ctrl, 0.0, w, 0.0), "multibody", t_end, record_dt=dt,
                  options={"timestep": dt, "record_joints": True})
    return mech.metrics(tr, None, None)["follower_first_separation_s"] is not None


def onset(mech, lo, hi, tol):
    """Bisection of the separation onset in [lo, hi] rad/s to a relative ``tol``; (speed, runs)."""
    runs = 0
    while (hi - lo) > tol * hi:
        mid = 0.5 * (lo + hi)
        runs += 1
        if separates(mech, mid):
            hi = mid
        else:
            lo = mid
    return hi, runs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", nargs="?", default="cam-follower")
    ap.add_argument("--tol", type=float, default=5e-4, help="relative bisection tolerance")
    a = ap.parse_args(argv)
    scn = S.load(a.scenario)
    table = scn.mechanism.model_dump()
    for label, extra in SETTINGS.items():
        t0 = time.process_time()
        mech = build(type(scn.mechanism).model_validate({**table, **extra}))
        wj = mech.jump["speed_rad_s"]
        w, runs = onset(mech, 0.5 * wj, 1.6 * wj, a.tol)
        print(f"{label:34s} onset {w:.5g} rad/s = {w / wj:.4f} × predicted {wj:.5g} rad/s "
              f"({runs} runs, {time.process_time() - t0:.0f} s CPU)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
