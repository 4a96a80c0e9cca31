"""The two-motor five-bar (mjbench/scenarios/fivebar.toml, decentralised PID on its path): the
compiled co-simulation against a bare ``mj_step`` loop replaying the same forces on the same model
(goal ≤ 1.05), and the reduced n×n model's run against the multibody one (goal ≤ 0.02).

Rows: ``cosim_over_bare_fivebar``, ``reduced_over_multibody_fivebar`` (CPU of this process, best
of --repeat, measured in turn), and the per-step costs.
"""
import time

from mjbench import kernel
from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from bench_parts import bare_python, interleaved, record_forces

T_END = 1.0
REDUCED_REPS = 5


def run(args):
    kernel.preload(1e9)  # numba loaded: every run below is compiled
    scn = S.load("fivebar")
    mode = "pid"
    opts = scn.multibody_options()
    h = float(scn.simulation.dt)
    mc = S.make_machine(scn, mode)
    _, model = multibody.build_model(mc, opts)
    q0, v0, Q = record_forces(S.make_machine(scn, mode), model, T_END, h)

    def ours():
        tr = multibody.simulate(S.make_machine(scn, mode), T_END, dt=h, record_dt=scn.simulation.record_dt,
                                model=model, options=opts)
        ours.loop = tr.meta["loop"]

    def mb():
        mb.tr = multibody.simulate(S.make_machine(scn, mode), T_END, record_dt=scn.simulation.record_dt, options=opts)

    samples = []

    def red_round():
        for _ in range(REDUCED_REPS):
            t0 = time.process_time()
            red.tr = reduced.simulate(S.make_machine(scn, mode), T_END, record_dt=scn.simulation.record_dt)
            samples.append(time.process_time() - t0)

    def red():
        pass

    ours()
    mb()
    red_round()  # tables, models and loops built once
    samples.clear()
    t = interleaved({"ours": ours, "bare": bare_python(model, q0, v0, Q), "multibody": mb, "reduced": red_round},
                    args.repeat)
    n = len(Q)
    return [
        ("cosim_over_bare_fivebar", t["ours"] / t["bare"],
         f"fivebar:{mode} co-simulation / bare mj_step loop ({ours.loop} loop; {1e6 * t['ours'] / n:.2f} µs per "
         f"co-step, bare {1e6 * t['bare'] / n:.2f} µs; goal ≤ 1.05)"),
        ("reduced_over_multibody_fivebar", min(samples) / t["multibody"],
         f"fivebar:{mode} reduced / multibody, {T_END:g} s, loops {red.tr.meta['loop']}/{mb.tr.meta['loop']} "
         f"({1e6 * min(samples) / n:.2f} µs per co-step; goal ≤ 0.02)"),
    ]
