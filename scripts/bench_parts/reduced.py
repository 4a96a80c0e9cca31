"""Reduced model vs multibody, single runs and batches (issue 16): µs per run-step, CPU time.

Seed-000 PID at h = 0.1 ms, record every 0.5 ms.  Every figure is the process's CPU time (all
threads: mujoco.batch uses every core) per simulated step of one run ("run-step"), measured as the
difference of two run lengths (set-up — model compilation, tables, stacking — cancels), best of
--repeat, the backends interleaved so that load drift affects them alike.

* single: bare ``mj_step`` loop (RK4), multibody co-simulation, reduced model with the tabulated
  J/J'/E_p' (default) and with the closed forms;
* batch: ``mujoco.batch`` co-simulation at N = 256 (the reference of the issue's 1/10 … 1/30
  target), the batched reduced model at N = 16 … 4096 (with numba when installed, and its
  pure-NumPy step at N = 256);
* growth with t_end: whole-call cost (set-up included) of the reduced batch at N = 256 for
  t_end = 0.05, 0.2, 0.8 s, per run-step;
* the compiled co-step (:mod:`mjbench.backends.fused`, numba: kernel loop, PID, drive and table
  plant in one function, the same bits): single run and N = 256, with their ratios to MuJoCo, and
  the single multibody run on it (the same loop around MuJoCo's own ``mj_step``);
  every other reduced figure is the Python kernel's (``MJBENCH_FUSED=0``);
* the fast multibody mode: Euler / implicitfast vs RK4 co-simulation cost (accuracy: docs/performance.md).
"""
import os
import time

import mujoco

from mjbench import scenario as S
from mjbench.backends import _jit, batch, multibody, reduced, reduced_batch

H = 1e-4
NS = (16, 64, 256, 1024, 4096)


def _cpu(fn, repeat):
    best = float("inf")
    for _ in range(max(1, repeat)):
        c0 = time.process_time()
        fn()
        best = min(best, time.process_time() - c0)
    return best


def _per_step(make, n1, n2, repeat, nsim=1):
    """CPU µs per run-step from two run lengths (n1 < n2 steps)."""
    a, b = make(n1), make(n2)
    t1 = t2 = float("inf")
    for _ in range(max(1, repeat)):  # interleaved
        t1 = min(t1, _cpu(a, 1))
        t2 = min(t2, _cpu(b, 1))
    return 1e6 * max(t2 - t1, 1e-9) / (nsim * (n2 - n1))


def run(args):
    repeat = max(3, getattr(args, "repeat", 3))
    os.environ["MJBENCH_FUSED"] = "0"  # the kernel's figures (Python loop, + compiled plant step in batches)
    scn = S.load("incerti2012")
    machine = S.make_machine(scn, "pid")
    _, model = multibody.build_model(machine)
    qpos0 = machine.mechanism.initial_qpos(model, 0.0)
    rows = []

    # ---------------------------------------------------------------- single runs
    def bare(n):
        def f():
            d = mujoco.MjData(model)
            d.qpos[:] = qpos0
            step = mujoco.mj_step
            for _ in range(n):
                step(model, d)
        return f

    def mb(n, m=model, opts=None):
        return lambda: multibody.simulate(S.make_machine(scn, "pid"), n * H, record_dt=5e-4, model=m, options=opts)

    def red(n, model_kind="table"):
        return lambda: reduced.simulate(S.make_machine(scn, "pid"), n * H, record_dt=5e-4, model=model_kind)

    reduced.simulate(S.make_machine(scn, "pid"), 0.01)  # build (and cache) the table
    n1, n2 = 2000, 10000
    singles = {}
    for _ in range(repeat):  # interleave the backends
        for name, mk in (("bare", bare), ("multibody", mb), ("reduced", red),
                         ("reduced_closed", lambda n: red(n, "closed"))):
            v = _per_step(mk, n1, n2, 1)
            singles[name] = min(singles.get(name, float("inf")), v)
    rows += [
        ("single_bare_mj_step_us", singles["bare"], "bare mj_step loop (RK4), µs per step [CPU]"),
        ("single_multibody_us", singles["multibody"], "multibody co-simulation (drive + PID + record), µs per step"),
        ("single_reduced_us", singles["reduced"], "reduced model, tabulated J/J'/E_p' (default), µs per step"),
        ("single_reduced_closed_us", singles["reduced_closed"], "reduced model, closed forms, µs per step"),
        ("multibody_single_over_bare", singles["multibody"] / singles["bare"],
         "multibody co-simulation / bare mj_step (goal ≤ 1.2)"),
        ("reduced_single_over_multibody_single", singles["reduced"] / singles["multibody"],
         "single reduced run / single multibody co-simulation (goal ≤ 1/3)"),
        ("reduced_closed_over_multibody_single", singles["reduced_closed"] / singles["multibody"],
         "single reduced run with the closed forms / multibody (before the table)"),
    ]

    # ---------------------------------------------------------------- batches
    def mb_batch(nsim):
        machines = [S.make_machine(scn, "pid") for _ in range(nsim)]
        models = [model] * nsim
        return lambda n: (lambda: batch.simulate(machines, n * H, record_dt=5e-4, models=models))

    def red_batch(nsim):
        machines = [S.make_machine(scn, "pid") for _ in range(nsim)]
        return lambda n: (lambda: reduced_batch.simulate(machines, n * H, record_dt=5e-4, single_fast_path=False))

    if _jit.AVAILABLE:  # the compiled step for the batch figures (by default it starts at 2e6 run-steps)
        os.environ["MJBENCH_JIT"] = "1"
    mb256 = _per_step(mb_batch(256), 100, 400, repeat, 256)
    rows.append(("multibody_batch_us_per_run_step_N256", mb256,
                 "mujoco.batch co-simulation, N = 256, all threads: CPU µs per run-step"))
    red_us = {}
    for nsim in NS:
        n1, n2 = (400, 2000) if nsim <= 256 else (200, 800)
        red_us[nsim] = _per_step(red_batch(nsim), n1, n2, repeat, nsim)
        rows.append((f"reduced_batch_us_per_run_step_N{nsim}", red_us[nsim],
                     f"batched reduced model, N = {nsim}: CPU µs per run-step"))
    rows.append(("reduced_batch_over_multibody_batch_N256", red_us[256] / mb256,
                 "reduced batch / multibody batch per run-step at N = 256 (goal ≤ 1/10, stretch 1/30)"))
    if _jit.AVAILABLE:  # the pure-NumPy step, for comparison (the default when numba is absent)
        os.environ["MJBENCH_JIT"] = "0"
        try:
            np256 = _per_step(red_batch(256), 400, 2000, repeat, 256)
        finally:
            os.environ["MJBENCH_JIT"] = "1"
        rows.append(("reduced_batch_numpy_us_per_run_step_N256", np256,
                     "batched reduced model without numba (pure NumPy), N = 256: CPU µs per run-step"))
        rows.append(("reduced_batch_numpy_over_multibody_batch_N256", np256 / mb256,
                     "pure-NumPy reduced batch / multibody batch per run-step at N = 256"))
    rows.append(("reduced_batch_N256_over_single_reduced", red_us[256] / singles["reduced"],
                 "reduced batch at N = 256 / single reduced run, per run-step"))

    # ---------------------------------------------------------------- the compiled co-step (backends/fused.py)
    if _jit.AVAILABLE:  # MJBENCH_JIT=1 is set: the kernel's loop, PID, drive and plant compiled (same bits)
        os.environ["MJBENCH_FUSED"] = "1"
        fs = _per_step(red, 2000, 10000, repeat)
        rows.append(("single_reduced_fused_us", fs, "reduced model on the compiled co-step, single run, µs per step"))
        rows.append(("reduced_fused_single_over_multibody_single", fs / singles["multibody"],
                     "compiled single reduced run / single multibody co-simulation"))
        fm = _per_step(mb, 2000, 10000, repeat)  # the same loop around MuJoCo's own mj_step
        rows.append(("single_multibody_fused_us", fm,
                     "multibody co-simulation on the compiled co-step, single run, µs per step"))
        rows.append(("multibody_fused_single_over_bare", fm / singles["bare"],
                     "compiled multibody co-simulation / bare mj_step"))
        f256 = _per_step(red_batch(256), 400, 2000, repeat, 256)
        rows.append(("reduced_fused_batch_us_per_run_step_N256", f256,
                     "compiled co-step, N = 256: CPU µs per run-step"))
        rows.append(("reduced_fused_batch_over_multibody_batch_N256", f256 / mb256,
                     "compiled co-step batch / multibody batch per run-step at N = 256"))

    # ---------------------------------------------------------------- growth with t_end (set-up included)
    os.environ["MJBENCH_FUSED"] = "0"  # the kernel's figure
    machines = [S.make_machine(scn, "pid") for _ in range(256)]
    for t_end in (0.05, 0.2, 0.8):
        t = _cpu(lambda: reduced_batch.simulate(machines, t_end, record_dt=5e-4, single_fast_path=False),
                 max(1, repeat - 1))
        rows.append((f"reduced_batch_N256_t{int(round(t_end * 1000))}ms_us_per_run_step", 1e6 * t / (256 * t_end / H),
                     f"reduced batch N = 256, t_end = {t_end:g} s, whole call incl. set-up: CPU µs per run-step"))

    os.environ.pop("MJBENCH_JIT", None)  # (MJBENCH_FUSED stays 0: the fast mode below is the Python kernel's)

    # ---------------------------------------------------------------- fast multibody mode (opt-in)
    for integ in ("Euler", "implicitfast"):
        o = {"integrator": integ}
        _, m2 = multibody.build_model(machine, o)
        v = _per_step(lambda n: mb(n, m2, o), 2000, 10000, repeat)
        rows.append((f"multibody_{integ}_over_RK4_single", v / singles["multibody"],
                     f"multibody co-simulation with {integ} / with RK4 (cost; accuracy in docs/performance.md)"))
    return rows
