"""A machine built in code, without TOML: a DC gear-motor driving a flywheel (the drive test bench,
``type = "rotor"``), a 12 V step from rest, on both backends — and the same machine at three
voltages in one batch (``simulate_many``).

A motor and a constant inertia are a linear system with a closed form,

    J_t·ω̇ = z·k_m·I − λ·z²·ω,    L·İ = V − R·I − k_m·z·ω,    J_t = J + J_m·z²  (crank side),

so the script prints how far each run is from it: the step response (exact, by the matrix
exponential) and the steady speed ω∞ = z·k_m·V / ((z·k_m)² + R·λ·z²).

    python scripts/examples/machine_in_code.py [OUT]      # default out/machine_in_code; ~3 s

Writes OUT/run/ (trajectory_multibody.csv, trajectory_reduced.csv, metrics.json: ``Result.save``
of a machine) and OUT/steady_speeds.csv (voltage, simulated and closed-form steady speed).
"""
import csv
import sys
from pathlib import Path

import numpy as np

import mjbench as mjb

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/machine_in_code")

# every keyword is a key of the scenario's [mechanism], [drive], [modes.NAME] tables; units allowed
flywheel = mjb.make_mechanism("rotor", J="500 kg*cm^2")                     # 0.05 kg·m²
drive = mjb.make_drive(R="0.5 ohm", L="1 mH", k_m=0.06, J_m="0.5 kg*cm^2", z=20, lam=1e-5, v_max="24 V")
step = mjb.make_controller("open", voltage="12 V")
machine = mjb.Machine(flywheel, drive, step)

res = mjb.simulate(machine, backend="both", t_end="200 ms", record_dt="1 ms")
print(res.summary())
res.save(out / "run", force=True)


def closed_form(t, V):
    """Crank speed [rad/s] and current [A] of the linear motor + flywheel after a step V at t = 0."""
    Jt = flywheel.J + drive.J_m * drive.z**2
    zk = drive.z * drive.k_m
    A = np.array([[-drive.lam * drive.z**2 / Jt, zk / Jt], [-zk / drive.L, -drive.R / drive.L]])
    B = np.array([0.0, 1.0 / drive.L]) * V
    lam, vec = np.linalg.eig(A)                  # x(t) = ∫₀ᵗ exp(A·s)·B ds, in A's eigen-coordinates
    x = ((np.expm1(np.outer(t, lam)) / lam) * np.linalg.solve(vec, B)) @ vec.T
    return x[:, 0].real, x[:, 1].real


for b, run in res.runs.items():
    w, I = closed_form(run.time, 12.0)
    print(f"{b:9s}: speed vs closed form {np.max(np.abs(run['crank_speed_rad_s'] - w)) / np.max(w):.2e} of the peak, "
          f"current {np.max(np.abs(run['current_A'] - I)) / np.max(np.abs(I)):.2e}")

# the same machine at three voltages, one batch of reduced models; 1 s: 40 mechanical time constants
voltages = [6.0, 12.0, 24.0]
machines = [mjb.Machine(flywheel, drive, mjb.make_controller("open", voltage=v)) for v in voltages]
runs = mjb.simulate_many(machines, backend="reduced", t_end=1.0)
zk = drive.z * drive.k_m
with open(out / "steady_speeds.csv", "w", newline="") as f:
    rows = csv.writer(f)
    rows.writerow(["voltage_V", "final_crank_speed_rad_s", "closed_form_rad_s"])
    for v, r in zip(voltages, runs):
        w_inf = zk * v / (zk**2 + drive.R * drive.lam * drive.z**2)
        rows.writerow([v, repr(float(r["reduced"]["crank_speed_rad_s"][-1])), repr(w_inf)])
        print(f"{v:4.0f} V: steady crank speed {r['reduced']['crank_speed_rad_s'][-1]:.6f} rad/s, closed form {w_inf:.6f}")
print(f"wrote {out}")
