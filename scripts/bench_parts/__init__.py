"""Benchmark parts discovered by scripts/bench.py: each module defines run(args) -> [(name, value, desc)].

Shared tools: CPU and wall clocks, interleaved best-of-N measurement (load drift affects both
sides alike), the machines of the ``reproduce`` cases, and the replay of a run's applied forces
for MuJoCo's own bare step loops (the same states, hence the same MuJoCo work: the constraint
solver's iterations depend on the state)."""
import time

import numpy as np


def best_time(fn, repeat, clock=time.perf_counter):
    """Minimum wall (or given clock) time of ``repeat`` calls of fn [s]."""
    best = float("inf")
    for _ in range(max(1, repeat)):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return best


def interleaved(fns: dict, repeat: int, clock=time.process_time) -> dict:
    """{name: best time} of several functions measured in turn, ``repeat`` rounds."""
    best = {k: float("inf") for k in fns}
    for _ in range(max(1, repeat)):
        for k, fn in fns.items():
            t0 = clock()
            fn()
            best[k] = min(best[k], clock() - t0)
    return best


def case_machines(case):
    """[(label, scenario, mode)] of a ``reproduce`` case: the modes it runs (a motion-law study or a
    paper study: the scenario's default mode)."""
    from mjbench import scenario as S

    if case.kind == "design":  # a requirements file, not a scenario: nothing to measure before the design runs
        return []
    scn = S.load(case.scenario, list(case.overrides))
    modes = list(case.modes) or [scn.mode(None)]
    return [(f"{case.name}/{m}", scn, m) for m in modes]


def record_forces(machine, model, t_end, h):
    """(qpos0, qvel0, Q): the initial state and the ``qfrc_applied`` before every step of the
    machine's co-simulation on ``model`` (CPython loop; the same bits as the compiled one), for a
    bare loop that replays exactly the same MuJoCo work."""
    import mujoco

    from mjbench.backends import multibody

    rec = []
    real = multibody.mujoco

    class Spy:
        def __getattr__(self, name):
            return getattr(real, name)

        @staticmethod
        def mj_step(m, d):
            rec.append(d.qfrc_applied.copy())
            real.mj_step(m, d)

    plant = multibody.MultibodyPlant(machine, model=model)
    plant.start()
    qpos0, qvel0 = plant.data.qpos.copy(), plant.data.qvel.copy()
    try:
        multibody.mujoco = Spy()
        multibody.simulate(machine, t_end, dt=h, record_dt=10 * h, model=model, loop="python")
    finally:
        multibody.mujoco = real
    del mujoco
    return qpos0, qvel0, np.array(rec)


def bare_python(model, qpos0, qvel0, Q):
    """The bare ``mj_step`` loop in Python, replaying ``Q`` (one row copy per step)."""
    import mujoco

    def f():
        d = mujoco.MjData(model)
        d.qpos[:] = qpos0
        d.qvel[:] = qvel0
        mujoco.mj_forward(model, d)
        qf = d.qfrc_applied
        step = mujoco.mj_step
        for row in Q:
            qf[:] = row
            step(model, d)
    return f


def bare_rollout(model, qpos0, qvel0, Q, nbatch=1, nthread=1):
    """MuJoCo's own compiled loop (``mujoco.rollout``) replaying ``Q`` as ``qfrc_applied``, for
    ``nbatch`` copies on ``nthread`` threads."""
    import mujoco
    from mujoco import rollout

    datas = [mujoco.MjData(model) for _ in range(nthread)]
    d = datas[0]
    d.qpos[:] = qpos0
    d.qvel[:] = qvel0
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, d, state0, spec)
    ctrl = np.ascontiguousarray(np.broadcast_to(Q[None], (nbatch,) + Q.shape))
    cspec = int(mujoco.mjtState.mjSTATE_QFRC_APPLIED)
    state = np.empty((nbatch, len(Q), state0.size))

    def f():
        rollout.rollout(model, datas, np.tile(state0, (nbatch, 1)), ctrl, control_spec=cspec, state=state)
    return f
