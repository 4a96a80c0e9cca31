"""Generic linkage and user MJCF: table build, reduced-model call, co-simulation with a point load, analyze.

CPU time (time.process_time): the machine is shared.
"""
import time

import mujoco

from bench_parts import best_time
from mjbench import scenario as S
from mjbench.backends import multibody, reduced


def _cpu(fn, repeat):
    return best_time(fn, repeat, clock=time.process_time)


def run(args):
    from mjbench import analyze as A
    from mjbench.mechanisms import linkage as LK
    from mjbench.mechanisms import mjcf as MJ
    from mjbench.mechanisms.linkage import model as LKM

    LKM.DISK_FOLDER = None  # time the build itself, not its copy in the user cache

    r = args.repeat
    press = S.load("press-slidercrank")
    six = S.load("sixbar-watt2")

    def build(scn):
        def f():
            LK._CACHE.clear()
            S.make_mechanism(scn)
        return f

    def build_mjcf():
        MJ._CACHE.clear()
        S.make_mechanism(S.load("mjcf-fourbar"))

    S.make_mechanism(press)  # imports, scipy.optimize
    t_press = _cpu(build(press), r)
    t_six = _cpu(build(six), r)
    t_mjcf = _cpu(build_mjcf, max(1, r // 2))

    lk = S.make_mechanism(press)
    fb = S.make_mechanism(S.load("incerti2012"))
    n = 200000

    def calls(m):
        def f():
            red = m.reduced
            for i in range(n):
                red(0.001 * i)
        return f

    t_lk = _cpu(calls(lk), r) / n
    t_fb = _cpu(calls(fb), r) / n

    # 2 s PI run of the press (forming load through the tree Jacobian) vs a bare mj_step loop
    t_end, h = 2.0, 1e-4
    machine = S.make_machine(press, "pi")
    _, model = multibody.build_model(machine, press.multibody_options())
    nst = int(round(t_end / h))

    def bare():
        d = mujoco.MjData(model)
        d.qpos[:] = machine.mechanism.initial_qpos(model, 0.0)
        for _ in range(nst):
            mujoco.mj_step(model, d)

    def cosim():
        multibody.simulate(machine, t_end, dt=h, record_dt=1e-3, model=model)

    def red():
        reduced.simulate(S.make_machine(press, "pi"), t_end, dt=h, record_dt=1e-3)

    tb, tc, tr = [], [], []
    for _ in range(r):  # interleaved: machine-load drift affects all alike
        tb.append(_cpu(bare, 1)); tc.append(_cpu(cosim, 1)); tr.append(_cpu(red, 1))  # noqa: E702
    tb, tc, tr = min(tb), min(tc), min(tr)
    t_an = _cpu(lambda: A.analyze(press), r)
    return [
        ("linkage_build_press_s", t_press, "press: assembly, mobility, branch over a turn, reduced table [s CPU]"),
        ("linkage_build_sixbar_s", t_six, "Watt II six-bar: the same [s CPU]"),
        ("mjcf_build_fourbar_s", t_mjcf, "user MJCF four-bar: MuJoCo-derived table, 1024 nodes [s CPU]"),
        ("linkage_reduced_call_us", 1e6 * t_lk, "linkage reduced(q), scalar (table lookup) [µs]"),
        ("fourbar_reduced_call_us", 1e6 * t_fb, "hand-coded FourBar.reduced(q), scalar (closed form) [µs]"),
        ("press_cosim_over_bare_step", tc / tb, "press co-simulation (drive + PI + forming load) / bare mj_step loop"),
        ("press_reduced_over_bare_step", tr / tb, "press reduced model (RK4, 0.1 ms) / bare mj_step loop"),
        ("analyze_press_s", t_an, "mjbench analyze press-slidercrank, 720 points, no figures [s CPU]"),
    ]
