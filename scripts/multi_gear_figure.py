#!/usr/bin/env python
"""The figure of compliant gears on a machine with several motors (docs/linkages.md §8.2), against
what tests/test_multi_gear.py asserts:

* left — ``arm2r`` in a horizontal plane, 2 V on the shoulder's motor from the middle of a 0.5° play:
  the motor turns alone (the arm at rest) along ``solve_ivp`` of its own ODE until the play closes,
  then drives the arm; both backends;
* right — ``fivebar`` on its path under PID with a 2e4 N·m/rad mesh on both motors: each mesh's
  deflection δ = θ_motor/z − q (the torque it carries over k), both backends.

Writes docs/multi_gear.png (or --out DIR) and prints the numbers shown.
Usage: python scripts/multi_gear_figure.py [--out docs]   (≈ 20 s)
"""
import argparse
import math
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from mjbench import plotstyle as ps  # noqa: E402
from mjbench import scenario as S  # noqa: E402
from mjbench.backends import simulate  # noqa: E402
from mjbench.plots import save  # noqa: E402

PLAY = 0.5  # [deg]


def play_panel(ax):
    sets = [f'drive.gear={{backlash="{PLAY} deg"}}', "mechanism.gravity=[0.0, 0.0]", "drive.T_0=0.0",
            'modes.open={type="open", voltage=2.0}', "modes.open.axes.B.voltage=0.0"]
    scn = S.load("arm2r", sets)
    for b in ("reduced", "multibody"):
        m = S.make_machine(scn, "open")
        tr = simulate(m, b, 0.03, record_dt=1e-4, loop="python")
        ax.plot(1e3 * tr["t_s"], np.degrees(tr["A:gear_deflection_rad"]),
                **ps.backend_style(b, label=f"shoulder's mesh deflection δ_A ({b})"))
    d = m.drives[0]
    z, jmo = float(d.z), float((d.J_m + d.J_a) * d.z ** 2)
    R, L, km, lam = float(d.R), float(d.L), float(d.k_m), float(d.lam)
    t = tr["t_s"]
    ref = solve_ivp(lambda _, y: [(2.0 - R * y[0] - km * z * y[1]) / L, z * (km * y[0] - lam * z * y[1]) / jmo, y[1]],
                    (0.0, t[-1]), [0.0, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t).y[2]
    free = np.cumprod(tr["A:gear_deflection_rad"] < 0.5 * math.radians(PLAY)).astype(bool)
    err = np.max(np.abs(tr["A:gear_deflection_rad"][free] - ref[free])) / (0.5 * math.radians(PLAY))
    print(f"play: the motor alone along solve_ivp to {err:.2g} of the half-play until t = {1e3 * t[free][-1]:.1f} ms; "
          f"arm speed meanwhile ≤ {np.max(np.abs(tr['A:crank_speed_rad_s'][free])):.1g} rad/s")
    ax.plot(1e3 * t[free][::10], np.degrees(ref[free][::10]), "k.", ms=3, label="the motor alone: solve_ivp of its ODE")
    ax.axhline(0.5 * PLAY, color="k", ls="--", lw=0.8)
    ax2 = ax.twinx()
    ax2.plot(1e3 * t, tr["A:crank_speed_rad_s"], color="0.6", lw=0.8)
    ax2.set_ylabel(ps.label("shoulder speed q̇_A (grey)", "rad/s"))
    ax.set_xlabel(ps.label("time t", "ms"))
    ax.set_ylabel(ps.label("mesh deflection δ_A", "deg"))
    ax.set_title(f"arm2r, {PLAY}° play: the motor crosses it alone, then hits and drives the arm", fontsize=9)
    ax.legend(fontsize=7, loc="lower right")


def mesh_panel(ax):
    scn = S.load("fivebar", ["drive.gear={stiffness=2e4}"])
    trs = {b: simulate(S.make_machine(scn, "pid"), b, 1.0, record_dt=1e-3) for b in ("multibody", "reduced")}
    for b, tr in trs.items():
        for a, c in (("A", "C0"), ("E", "C1")):
            st = ps.backend_style(b, label=f"δ_{a} ({b})")
            st["color"] = c
            ax.plot(tr["t_s"], 1e3 * np.degrees(tr[f"{a}:gear_deflection_rad"]), **st)
    r, m = trs["reduced"], trs["multibody"]
    diff = max(np.max(np.abs(r[f"{a}:crank_speed_rad_s"] - m[f"{a}:crank_speed_rad_s"]))
               / np.max(np.abs(m[f"{a}:crank_speed_rad_s"])) for a in ("A", "E"))
    print(f"fivebar: backends' joint speeds agree to {diff:.2g} of the peak; largest |δ| "
          f"{1e3 * np.degrees(max(np.max(np.abs(m[f'{a}:gear_deflection_rad'])) for a in 'AE')):.3g} mdeg")
    ax.set_xlabel(ps.label("time t", "s"))
    ax.set_ylabel(ps.label("mesh deflection δ", "mdeg"))
    ax.set_title(f"fivebar on its path (PID), 2e4 N·m/rad meshes: δ = torque / k; backends agree to {diff:.1g}",
                 fontsize=9)
    ax.legend(fontsize=7, ncol=2)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs"))
    out = Path(ap.parse_args().out)
    out.mkdir(parents=True, exist_ok=True)
    with ps.context():
        fig, ax = ps.new(1, 2, figsize=(13, 4.4))
        play_panel(ax[0])
        mesh_panel(ax[1])
        ps.finish(fig, "Compliant gears on a machine with several motors: each motor a coordinate of its own, both backends")
        print("wrote", save(fig, out / "multi_gear.png"))


if __name__ == "__main__":
    main()
