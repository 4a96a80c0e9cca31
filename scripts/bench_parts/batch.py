"""Batches of multibody runs (compiled co-step, one run per thread) vs MuJoCo's own batched loop.

N seed-000 PID runs of 0.2 s with different gains; the bare reference is ``mujoco.rollout`` over
the same N runs replaying the forces each of our runs applied (the same MuJoCo work), on the same
number of threads.  Each repetition measures ours then the bare loop (interleaved), best of
--repeat: CPU time of the process (1 thread: the overhead ratio) and wall time (all threads:
the thread scaling, which needs an idle machine).
"""
import os
import time

import numpy as np

from mjbench import kernel
from mjbench import scenario as S
from mjbench.backends import multibody
from bench_parts import bare_rollout, record_forces

H = 1e-4
T_END = 0.2


def run(args):
    kernel.preload(1e9)
    ncpu = os.cpu_count() or 1
    rows = []
    for n in (16, 64):
        kps = np.linspace(40.0, 320.0, n)
        scns = [S.load("incerti2012", [f"modes.pid.kp={k}"]) for k in kps]
        _, model = multibody.build_model(S.make_machine(scns[0], "pid"))
        forces = [record_forces(S.make_machine(s, "pid"), model, T_END, H) for s in scns]
        Q = np.stack([f[2] for f in forces])
        q0, v0 = forces[0][0], forces[0][1]
        for nthread in sorted({1, ncpu}):
            def ours():
                ms = [S.make_machine(s, "pid") for s in scns]
                plants = [multibody.MultibodyPlant(m, model=model) for m in ms]
                kernel.run_many(plants, ms, T_END, 5e-4, loop="compiled", threads=nthread)
                for p in plants:
                    p.finish()
            bare = _rollout_batch(model, q0, v0, Q, nthread)
            best = {"ours_cpu": np.inf, "bare_cpu": np.inf, "ours_wall": np.inf, "bare_wall": np.inf}
            for _ in range(max(1, args.repeat)):
                for k, fn in (("ours", ours), ("bare", bare)):
                    w0, c0 = time.perf_counter(), time.process_time()
                    fn()
                    best[k + "_cpu"] = min(best[k + "_cpu"], time.process_time() - c0)
                    best[k + "_wall"] = min(best[k + "_wall"], time.perf_counter() - w0)
            rows.append((f"batch_over_rollout_cpu_N{n}_t{nthread}", best["ours_cpu"] / best["bare_cpu"],
                         f"N = {n}, {nthread} thread(s): ours / mujoco.rollout, CPU time"))
            rows.append((f"batch_over_rollout_wall_N{n}_t{nthread}", best["ours_wall"] / best["bare_wall"],
                         f"N = {n}, {nthread} thread(s): ours / mujoco.rollout, wall time (load-sensitive)"))
            rows.append((f"batch_us_per_run_step_N{n}_t{nthread}", 1e6 * best["ours_wall"] / (n * T_END / H),
                         f"N = {n}, {nthread} thread(s): wall µs per run-step"))
    return rows


def _rollout_batch(model, q0, v0, Q, nthread):
    """mujoco.rollout of N runs, each replaying its own forces (Q: N × nstep × nv)."""
    import mujoco
    from mujoco import rollout

    datas = [mujoco.MjData(model) for _ in range(nthread)]
    d = datas[0]
    d.qpos[:] = q0
    d.qvel[:] = v0
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, d, s0, spec)
    init = np.tile(s0, (Q.shape[0], 1))
    cspec = int(mujoco.mjtState.mjSTATE_QFRC_APPLIED)
    state = np.empty((Q.shape[0], Q.shape[1], s0.size))

    def f():
        rollout.rollout(model, datas, init, Q, control_spec=cspec, state=state)
    return f
