"""Drive-train elements (issue 15): CPU cost per co-simulation step of each element, as a ratio to the
ideal drive on the same backend (seed-000 four-bar, 1 s at 0.1 ms, both backends).

Open loop at 25 V, control sampled at every step: every element does its work at every step while
the trajectory stays (nearly) the same, so the ratio is the element's own cost, not a change of
MuJoCo's constraint-solver effort along a different closed-loop motion (which the PID would add).
scripts/drivetrain_callgrind.py counts instructions for the same configurations."""

import gc
import statistics
import time

from mjbench import scenario as S
from mjbench.backends import multibody, reduced

#: element → --set overrides (each alone on top of the ideal seed-000 scenario)
ELEMENTS = {
    "pwm_averaged": ['drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48", 'drive.pwm.dead_time="1 us"'],
    "pwm_switching": ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48",
                      'drive.pwm.dead_time="1 us"'],
    "encoder_difference": ["drive.encoder.lines=2000"],
    "encoder_observer": ["drive.encoder.lines=2000", 'drive.sensor.speed="observer"'],
    "encoder_mt": ["drive.encoder.lines=2000", 'drive.sensor.speed="mt"'],
    "noise": ['drive.sensor.speed="true"', 'drive.sensor.noise_speed=0.1', 'drive.sensor.noise_current=0.05'],
    "delay": ['drive.sensor.speed="true"', "drive.sensor.delay=true"],
    "backlash": ['drive.gear.backlash="0.1 deg"'],
    "efficiency": ["drive.gear.efficiency=0.9", "drive.gear.efficiency_back=0.8"],
    "friction_coulomb": ['drive.friction.coulomb="0.05 N*m"'],
    "friction_stribeck": ['drive.friction.coulomb="0.05 N*m"', 'drive.friction.breakaway="0.08 N*m"',
                          'drive.friction.stribeck_speed="1 rad/s"'],
    "current_loop": ['drive.current_loop.bandwidth="1 kHz"', "modes.open.voltage=5"],  # 5 A ≈ the 25 V run's mean current
}
MODE = "open"
ALL = [s for k in ("pwm_switching", "encoder_observer", "backlash", "friction_coulomb") for s in ELEMENTS[k]]


def run(args):
    t_end, h = 1.0, 1e-4
    n = int(round(t_end / h))
    configs = {**ELEMENTS, "realistic_all": ALL}
    scns = {k: S.load("incerti2012", v) for k, v in {"ideal": [], **configs}.items()}
    mods = {"multibody": multibody, "reduced": reduced}

    def cpu(k, mod):
        m = S.make_machine(scns[k], MODE)
        gc.collect()
        t0 = time.process_time()
        mod.simulate(m, t_end, dt=h, record_dt=1e-3)
        return time.process_time() - t0

    # each element timed right after an ideal run (paired ratio: the machine's load drift cancels),
    # median over the repetitions
    ratios = {(k, b): [] for k in configs for b in mods}
    ideal = {b: [] for b in mods}
    for mod in mods.values():  # warm-up (lazy initialisations of the first run)
        cpu("ideal", mod)
    # full GC collections scan the whole start-up heap: freeze it, so none lands in one run only
    gc.collect()
    gc.freeze()
    try:
        for _ in range(max(1, args.repeat)):
            for k in configs:
                for b, mod in mods.items():
                    ti = cpu("ideal", mod)
                    ideal[b].append(ti)
                    ratios[k, b].append(cpu(k, mod) / ti)
    finally:
        gc.unfreeze()
    rows = []
    for b in mods:
        rows.append((f"drivetrain_{b}_ideal_us_per_step", 1e6 * min(ideal[b]) / n,
                     f"ideal drive, {b}: CPU per 0.1 ms co-step [µs] (best run)"))
        for k in configs:
            rows.append((f"drivetrain_{b}_{k}_over_ideal", statistics.median(ratios[k, b]),
                         f"{k} alone ({b}) / ideal drive, CPU per step (median of paired ratios)"))
    return rows
