"""Seed-000 co-simulation: 5 s PID run at 0.1 ms vs a bare mj_step loop on the same model."""

import mujoco

from mjbench import scenario as S
from mjbench.backends import _jit, multibody, reduced
from bench_parts import best_time, fused_on


_best = best_time


def run(args):
    # the figures are the Python kernel's (scripts/bench.py sets MJBENCH_FUSED=0), but for cosim_fused
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

    def cosim_fused():  # the compiled co-step around the same mj_step (mjbench/backends/fused.py)
        with fused_on():
            multibody.simulate(machine, t_end, dt=h, record_dt=1e-3, model=model)

    def red():
        reduced.simulate(S.make_machine(scn, "pid"), t_end, dt=h, record_dt=1e-3)

    def red_paper():
        reduced.simulate(S.make_machine(scn, "pid"), t_end, dt=1e-3, record_dt=1e-3)

    r = args.repeat
    # interleave the measurements so that machine-load drift affects both alike
    tb, tc, tr, tp, tf = [], [], [], [], []
    if _jit.AVAILABLE:
        cosim_fused()  # load numba and the compiled loop before timing
    for _ in range(r):
        tb.append(_best(bare, 1)); tc.append(_best(cosim, 1)); tr.append(_best(red, 1)); tp.append(_best(red_paper, 1))
        if _jit.AVAILABLE:
            tf.append(_best(cosim_fused, 1))
    tb, tc, tr, tp = min(tb), min(tc), min(tr), min(tp)
    fused_rows = [("cosim_fused_over_bare_step", min(tf) / tb,
                   "co-simulation on the compiled co-step (numba around the same mj_step) / bare step loop")] if tf else []
    return [
        ("bare_mj_step_5s_s", tb, f"bare mj_step loop, {n} steps (RK4, dense Jacobian) [s]"),
        ("cosim_5s_s", tc, "multibody co-simulation incl. drive + PID + recording [s]"),
        ("cosim_over_bare_step", tc / tb, "co-simulation / bare step loop (goal ≤ 1.2)"),
        ("cosim_us_per_step", 1e6 * tc / n, "co-simulation cost per 0.1 ms step [µs]"),
        ("reduced_over_bare_step", tr / tb, "reduced model (RK4, 0.1 ms) / bare step loop"),
        ("reduced_1ms_over_bare_step", tp / tb, "reduced model at the paper's 1 ms RK4 step / bare step loop"),
        ("realtime_factor_cosim", t_end / tc, "simulated seconds per wall-clock second (co-simulation)"),
    ] + fused_rows
