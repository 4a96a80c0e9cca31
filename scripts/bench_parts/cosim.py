"""Seed-000 co-simulation: 5 s PID run at 0.1 ms vs a bare mj_step loop on the same model."""

import mujoco

from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from bench_parts import best_time


_best = best_time


def run(args):
    import os
    os.environ["MJBENCH_FUSED"] = "0"  # the reduced figures here are the Python kernel's (compiled: part reduced)
    scn = S.load("incerti2012")
    t_end, h = 5.0, 1e-4
    machine = S.make_machine(scn, "pid")
    _, model = multibody.build_model(machine)
    n = int(round(t_end / h))

    def bare():
        d = mujoco.MjData(model)
        d.qpos[:] = machine.mechanism.initial_qpos(model, 0.0)
        step = mujoco.mj_step
        for _ in range(n):
            step(model, d)

    def cosim():
        multibody.simulate(machine, t_end, dt=h, record_dt=1e-3, model=model)

    def red():
        reduced.simulate(S.make_machine(scn, "pid"), t_end, dt=h, record_dt=1e-3)

    def red_paper():
        reduced.simulate(S.make_machine(scn, "pid"), t_end, dt=1e-3, record_dt=1e-3)

    r = args.repeat
    # interleave the measurements so that machine-load drift affects both alike
    tb, tc, tr, tp = [], [], [], []
    for _ in range(r):
        tb.append(_best(bare, 1)); tc.append(_best(cosim, 1)); tr.append(_best(red, 1)); tp.append(_best(red_paper, 1))
    tb, tc, tr, tp = min(tb), min(tc), min(tr), min(tp)
    os.environ.pop("MJBENCH_FUSED", None)
    return [
        ("bare_mj_step_5s_s", tb, f"bare mj_step loop, {n} steps (RK4, dense Jacobian) [s]"),
        ("cosim_5s_s", tc, "multibody co-simulation incl. drive + PID + recording [s]"),
        ("cosim_over_bare_step", tc / tb, "co-simulation / bare step loop (goal ≤ 1.2)"),
        ("cosim_us_per_step", 1e6 * tc / n, "co-simulation cost per 0.1 ms step [µs]"),
        ("reduced_over_bare_step", tr / tb, "reduced model (RK4, 0.1 ms) / bare step loop"),
        ("reduced_1ms_over_bare_step", tp / tb, "reduced model at the paper's 1 ms RK4 step / bare step loop"),
        ("realtime_factor_cosim", t_end / tc, "simulated seconds per wall-clock second (co-simulation)"),
    ]
