"""Seed 002: cost of the on-line Eq 17 reference and the hinge-friction load in the co-simulation.

* ``coupler_ref_call_us``: one call of the coupler-speed reference (constant V_C), microseconds;
* ``coupler_cosim_ratio``: steps/s of the single multibody co-simulation of hulako2025-model1
  (drive + crank-side PID + Eq 17 reference + hinge friction in multibody_load + recording) over a
  bare ``mj_step`` loop on the same compiled model (1 = no overhead), CPU time, best of --repeat;
* ``coupler_reduced_steps_per_s``: the reduced backend on the same scenario.
"""
import time

import mujoco

from controllers.base import Measurement
from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from bench_parts import best_time

H = 1e-4


def _best(fn, repeat):
    return best_time(fn, repeat, clock=time.process_time)


def run(args):
    repeat = max(3, getattr(args, "repeat", 3))
    scn = S.load("hulako2025-model1", ["vc=0.2"])
    mach = S.make_machine(scn)
    ref = mach.controller.reference
    y = Measurement(z=float(mach.drive.z))
    n = 20000

    def calls():
        ref.reset()
        for i in range(n):
            t = i * H
            ref(t, y.set(t, 0.5 + 5.0 * t, 5.0, 0.0, 0.0))
    t_ref = _best(calls, repeat) / n * 1e6

    _, model = multibody.build_model(mach)
    qpos0 = mach.mechanism.initial_qpos(model, 0.0)
    nsteps = 10000

    def bare():
        d = mujoco.MjData(model)
        d.qpos[:] = qpos0
        for _ in range(nsteps):
            d.qfrc_applied[0] = 0.05
            mujoco.mj_step(model, d)

    def ours():
        multibody.simulate(S.make_machine(scn), nsteps * H, dt=H, record_dt=1e-3, model=model)

    def red():
        reduced.simulate(S.make_machine(scn), nsteps * H, dt=H, record_dt=1e-3)

    tb, to, tr = _best(bare, repeat), _best(ours, repeat), _best(red, repeat)
    return [("coupler_ref_call_us", t_ref, "µs per Eq 17 reference call (constant V_C)"),
            ("coupler_cosim_ratio", tb / to, "multibody co-sim steps/s over bare mj_step (1 = no overhead)"),
            ("coupler_multibody_steps_per_s", nsteps / to, "co-simulation steps per CPU second"),
            ("coupler_reduced_steps_per_s", nsteps / tr, "reduced-backend steps per CPU second")]
