"""Every ``reproduce`` case as a single multibody run on the compiled co-step vs a bare step loop on the same model.

For each of the 16 cases of ``mjbench reproduce`` (each of its modes) the machine's MuJoCo model
is built once; the co-simulation (drive, controller, drive train, loads, record — the compiled
loop around MuJoCo's own ``mj_step``) is timed against two bare loops on the same model that
replay the forces our run applied before every step (so MuJoCo does the same work):

* ``bare`` — a Python loop of ``mujoco.mj_step`` (the issue's reference: cost ≤ 1.05× this);
* ``rollout`` — MuJoCo's own compiled loop (``mujoco.rollout``, one thread): the stricter floor.

CPU time of this process, best of --repeat, the three measured in turn.  Rows per case/mode, then
``cosim_over_bare_worst`` and the case it belongs to.
"""
from mjbench import kernel, papers
from mjbench import scenario as S
from mjbench.backends import multibody
from bench_parts import bare_python, bare_rollout, case_machines, interleaved, record_forces

T_END = 1.0  # simulated seconds per measurement (10 000 co-steps at 0.1 ms)


def run(args):
    kernel.preload(1e9)  # numba loaded: every run below is compiled
    rows, worst = [], (0.0, "")
    for case in papers.cases():
        for label, scn, mode in case_machines(case):
            from mjbench.runner import backend_options

            opts = backend_options(scn, "multibody")
            mc = S.make_machine(scn, mode)
            h = float(opts.get("timestep", 1e-4))
            _, model = multibody.build_model(mc, opts)
            try:
                q0, v0, Q = record_forces(S.make_machine(scn, mode), model, T_END, h)
            except Exception as e:  # noqa: BLE001 - a case that cannot run is a row, not the end of the bench
                print(f"  {label}: not measured ({type(e).__name__}: {e})")
                continue

            def ours():
                tr = multibody.simulate(S.make_machine(scn, mode), T_END, dt=h, record_dt=scn.simulation.record_dt
                                        if scn.simulation.record_dt >= h else h, model=model, options=opts)
                ours.loop = tr.meta["loop"]
            t = interleaved({"ours": ours, "bare": bare_python(model, q0, v0, Q),
                             "rollout": bare_rollout(model, q0, v0, Q)}, args.repeat)
            r = t["ours"] / t["bare"]
            tag = label.replace("/", "_").replace(".", "")
            rows.append((f"cosim_over_bare_{tag}", r,
                         f"{label}: co-simulation / bare mj_step loop ({ours.loop} loop; "
                         f"{1e6 * t['ours'] / len(Q):.2f} µs per step)"))
            rows.append((f"cosim_over_rollout_{tag}", t["ours"] / t["rollout"],
                         f"{label}: co-simulation / mujoco.rollout (MuJoCo's compiled loop)"))
            if ours.loop != "compiled":
                rows.append((f"cosim_not_compiled_{tag}", 1.0, f"{label}: ran the CPython loop"))
            if r > worst[0]:
                worst = (r, label)
    rows.append(("cosim_over_bare_worst", worst[0], f"worst case: {worst[1]} (goal ≤ 1.05)"))
    print(f"cosim_over_bare_worst_case={worst[1]}")
    return rows
