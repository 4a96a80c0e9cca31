"""A parameter sweep: the Incerti 2012 K_p·t PID's gain against the motor's resistance, 3 × 3 runs
of 0.5 s on the batched reduced model, χ in the paper's window (0.375–0.5 s) for each, the two
best rows re-run on MuJoCo (search on the fast model, verify on the multibody one).

    python scripts/examples/sweep.py [OUT]       # default out/sweep_kp_R; ~5 s

Writes OUT/ as ``mjbench sweep`` does: results.csv (one row per run, every metric), verify.csv
(the best rows on both backends), sweep.json, heatmap_chi_window.png.  Run it again and the
finished rows are read back instead of re-simulated.
"""
import sys

import mjbench as mjb

out = sys.argv[1] if len(sys.argv) > 1 else "out/sweep_kp_R"
grid = {"modes.pid.kp": [40, 80, 160], "drive.R": ["1.5 ohm", "2 ohm", "2.5 ohm"]}
sweep = mjb.parameter_sweep("incerti2012", grid, t_end=0.5, verify=2, metric="chi_window", out=out)

table = sweep.to_pandas()
print(table[["modes.pid.kp", "drive.R", "status", "chi_window", "peak_current_A", "mean_crank_speed_rad_s"]]
      .to_string(index=False))
for v in sweep.verified:
    print(f"verified on MuJoCo: K_p = {v['modes.pid.kp']}, R = {v['drive.R']}: χ_window reduced "
          f"{v['reduced']:.6f}, multibody {v['multibody']:.6f} (relative difference {v['relative']:.1e})")
print(f"wrote {sweep.out}")
