"""The reduced model on the compiled co-step: every shipped controller against its multibody run, and long runs.

* per controller (open loop, PID, PID K_p·t, PI of the generic linkages, sliding-mode, cascade servo
  tracking a motion law, PID tracking a coupler speed): CPU time of a 2 s reduced run (best of
  10 per round) / the same machine's multibody run (best of the rounds), both compiled (goal ≤ 0.01);
* the seed-000 PID reduced run over 10⁶ co-steps (100 s simulated): µs per co-step and its ratio to
  the multibody run (enough work to time reliably);
* a batch of 256 reduced runs (compiled, threads) in µs per run-step.

CPU time of this process (all threads), best of --repeat, measured in turn.
"""
import time

from mjbench import kernel
from mjbench import scenario as S
from mjbench.backends import multibody, reduced, simulate_many
from bench_parts import interleaved

H = 1e-4
#: 2 s reduced runs per round of the per-controller rows (the best single run is kept)
REDUCED_REPS = 10
#: controller → (scenario, mode, overrides)
CONTROLLERS = {
    "open": ("incerti2012", "open", []),
    "pid_kp_t": ("incerti2012", "pid", []),
    "pi_linkage": ("press-slidercrank", "pi", []),
    "smc": ("yigit2023", "smc", []),
    "servo_law": ("incerti-bezier", None, []),
    "pid_coupler_speed": ("hulako2025-model1", "pid", ["vc=0.2"]),
}


def run(args):
    kernel.preload(1e9)
    rows = []
    for name, (scn_name, mode, sets) in CONTROLLERS.items():
        scn = S.load(scn_name, sets)
        mode = scn.mode(mode)
        t_end = 2.0

        def red():
            red.tr = reduced.simulate(S.make_machine(scn, mode), t_end, record_dt=scn.simulation.record_dt)

        def mb():
            mb.tr = multibody.simulate(S.make_machine(scn, mode), t_end, record_dt=scn.simulation.record_dt,
                                       options=scn.multibody_options())
        red()
        mb()  # tables, models and loops built once
        # a 2 s reduced run is 1–3 ms of CPU, where the clock's and the allocator's noise count: each
        # round runs it REDUCED_REPS times and the best single run is kept (rounds interleaved with
        # the multibody runs as everywhere)
        samples = []

        def red_round():
            for _ in range(REDUCED_REPS):
                t0 = time.process_time()
                red()
                samples.append(time.process_time() - t0)
        t = interleaved({"reduced": red_round, "multibody": mb}, args.repeat)
        loops = f"{red.tr.meta['loop']}/{mb.tr.meta['loop']}"
        rows.append((f"reduced_over_multibody_{name}", min(samples) / t["multibody"],
                     f"{scn_name}:{mode} reduced / multibody, 2 s, loops {loops} (goal ≤ 0.01)"))
    # a long single reduced run: ≥ 1e6 co-steps
    scn = S.load("incerti2012")
    n = 1_000_000

    def long_red():
        reduced.simulate(S.make_machine(scn, "pid"), n * H, record_dt=1e-2)

    def short_mb():
        multibody.simulate(S.make_machine(scn, "pid"), 20000 * H, record_dt=1e-2)
    long_red()
    t = interleaved({"reduced": long_red, "multibody": short_mb}, args.repeat)
    us_red = 1e6 * t["reduced"] / n
    us_mb = 1e6 * t["multibody"] / 20000
    rows.append(("reduced_compiled_us_per_step_1e6", us_red, "seed-000 PID reduced run of 1e6 co-steps, µs per co-step"))
    rows.append(("reduced_over_multibody_per_step", us_red / us_mb, "µs per co-step: reduced / multibody (seed 000 PID)"))
    # a batch
    ms = [S.make_machine(S.load("incerti2012", [f"modes.pid.kp={40 + k}"]), "pid") for k in range(256)]

    def batch():
        simulate_many(ms, "reduced", 0.5, record_dt=5e-3)
    batch()
    t = interleaved({"batch": batch}, args.repeat)
    rows.append(("reduced_batch_us_per_run_step_N256", 1e6 * t["batch"] / (256 * 5000),
                 "256 reduced PID runs of 0.5 s (compiled, threads), CPU µs per run-step"))
    return rows
