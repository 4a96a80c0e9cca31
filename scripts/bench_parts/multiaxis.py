"""The two-motor five-bar (mjbench/scenarios/fivebar.toml, decentralised PID on its path): the
compiled co-simulation against a bare ``mj_step`` loop replaying the same forces on the same model
(goal ≤ 1.05), and the reduced n×n model's run against the multibody one (goal ≤ 0.02) — and the same
with a compliant gear on both motors (``_gear``: a mesh stiffness, each motor a coordinate of its own:
MuJoCo's motor hinges and tendons, the reduced plant's RK4 on (q, q̇, δ, δ̇); no goal of its own).

Rows: ``cosim_over_bare_fivebar``, ``reduced_over_multibody_fivebar``, ``cosim_over_bare_fivebar_gear``,
``reduced_over_multibody_fivebar_gear`` (CPU of this process, best of --repeat, measured in turn),
and the per-step costs.
"""
import time

from mjbench import kernel
from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from bench_parts import bare_python, interleaved, record_forces

T_END = 1.0
REDUCED_REPS = 5
#: the compliant gear of the ``_gear`` rows (both axes; no play: the bare loop replays the same MuJoCo work)
GEAR = ["drive.gear={stiffness=2e4}"]


def run(args):
    kernel.preload(1e9)  # numba loaded: every run below is compiled
    return _rows(args, [], "", True) + _rows(args, GEAR, "_gear", False)


def _rows(args, sets, suffix, goals):
    scn = S.load("fivebar", sets)
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
    what = f"fivebar{' ' + ', '.join(sets) if sets else ''}:{mode}"
    return [
        (f"cosim_over_bare_fivebar{suffix}", t["ours"] / t["bare"],
         f"{what} co-simulation / bare mj_step loop ({ours.loop} loop; {1e6 * t['ours'] / n:.2f} µs per "
         f"co-step, bare {1e6 * t['bare'] / n:.2f} µs{'; goal ≤ 1.05' if goals else ''})"),
        (f"reduced_over_multibody_fivebar{suffix}", min(samples) / t["multibody"],
         f"{what} reduced / multibody, {T_END:g} s, loops {red.tr.meta['loop']}/{mb.tr.meta['loop']} "
         f"({1e6 * min(samples) / n:.2f} µs per co-step{'; goal ≤ 0.02' if goals else ''})"),
    ]
