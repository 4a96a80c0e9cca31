#!/usr/bin/env python
"""Seed 002 study: Model-1 and Model-2, V_C = 0.1 … 0.4 m/s, 5 s at 0.1 ms, both backends.

Writes <out>/metrics.json (metrics per model, V_C and backend; multibody-vs-reduced
differences; the gains.py demand/prediction), <out>/summary.md and the figures
(Figs 9-12, 18-22 style).  Extra ``--set`` overrides apply to both models (alternative readings,
e.g. --set km=0.0021, --set g=0, --set vlimit=none).

Usage: python scripts/coupler_study.py [--out results/coupler] [--vc 0.1 0.2 0.3 0.4]
       [--t-end 5] [--backends multibody reduced] [--set KEY=VALUE ...]
"""
import argparse
import json
import os
import time

from mjbench.papers import hulako2025_demand as gains
from mjbench.papers import hulako2025_metrics as metrics_coupler
from mjbench.papers import hulako2025_plots as plots_coupler
from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from mjbench.trajectory import atomic_write

BACKENDS = {"multibody": multibody, "reduced": reduced}
PAPER_SIM = {0.1: 0.01, 0.2: 0.01}  # Table 3, simulation, both models
PAPER_EXP = {"hulako2025-model1": {0.1: 0.020, 0.2: 0.025, 0.3: 0.04, 0.4: 0.1},
             "hulako2025-model2": {0.1: 0.025, 0.2: 0.025, 0.3: 0.04, 0.4: 0.1}}  # Table 3; §6 (0.3, 0.4)


def run_one(name, vc, sets, t_end, backends):
    scn = S.load(name, list(sets) + [f"vc={vc}"])
    dt = float(S.get(scn, "simulation.dt", 1e-4))
    rdt = float(S.get(scn, "simulation.record_dt", 1e-3))
    out, trajs = {}, {}
    for be in backends:
        mach = S.make_machine(scn)
        t0 = time.perf_counter()
        opts = dict(scn.get("multibody", {})) if be == "multibody" else dict(scn.get("reduced", {}))
        tr = BACKENDS[be].simulate(mach, t_end, dt=dt, record_dt=rdt, options=opts or None)
        m = metrics_coupler.from_run(scn, tr, mach)
        m["wall_s"] = time.perf_counter() - t0
        out[be], trajs[be] = m, tr
    if len(trajs) == 2:
        out["backend_diff"] = metrics_coupler.compare_backends(trajs["multibody"], trajs["reduced"])
    d = gains.from_scenario(scn)
    out["demand"] = d
    return scn, mach, trajs, out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="results/coupler")
    ap.add_argument("--models", nargs="*", default=["hulako2025-model1", "hulako2025-model2"])
    ap.add_argument("--vc", nargs="*", type=float, default=[0.1, 0.2, 0.3, 0.4])
    ap.add_argument("--t-end", type=float, default=5.0)
    ap.add_argument("--backends", nargs="*", default=["multibody", "reduced"])
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--no-plots", action="store_true")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    results, rows = {}, []
    for name in args.models:
        family = []
        for vc in args.vc:
            scn, mach, trajs, res = run_one(name, vc, args.set, args.t_end, args.backends)
            results[f"{name}/vc={vc}"] = res
            main_be = "multibody" if "multibody" in trajs else args.backends[0]
            r = res[main_be]
            print(f"{name} V_C={vc}: " + ", ".join(
                f"{be}: e1.5={res[be]['crank_error_max_after_rad_s']:.4f} rad/s dev={res[be]['coupler_dev_max_after_m_s']:.4f} m/s "
                f"tr={res[be]['rise_time_s']:.3f} s ts={res[be]['settling_time_s']:.3f} s Vmax={res[be]['voltage_max_V']:.2f} V "
                f"last1s: dev={res[be]['coupler_dev_max_last_1s_m_s']:.4f} e={res[be]['crank_error_max_last_1s_rad_s']:.3f}"
                for be in args.backends) + (f" | diff {res['backend_diff']}" if 'backend_diff' in res else ""), flush=True)
            rows.append({"model": name.split("-")[-1], "vc": vc, "dev": r["coupler_dev_max_after_m_s"],
                         "dev_last": r["coupler_dev_max_last_1s_m_s"],
                         "paper_sim": PAPER_SIM.get(vc), "paper_exp": PAPER_EXP.get(name, {}).get(vc)})
            ref = mach.controller.reference
            sg = metrics_coupler.signals(trajs[main_be], mach.mechanism, ref)
            family.append((vc, sg["t"], sg["vc"]))
            if not args.no_plots:
                tag = f"{name}_vc{vc:g}"
                plots_coupler.crank_speed(trajs, mach.mechanism, ref, os.path.join(args.out, f"{tag}_crank_speed.png"),
                                          title=f"{name}, V_C = {vc} m/s (Figs 9-12 style)")
                plots_coupler.coupler_speed(trajs, mach.mechanism, ref, os.path.join(args.out, f"{tag}_coupler_speed.png"),
                                            title=f"{name}, V_C = {vc} m/s (Figs 18-21 style)",
                                            paper_dev=PAPER_SIM.get(vc))
        if not args.no_plots:
            plots_coupler.coupler_speed_family(family, os.path.join(args.out, f"{name}_fig22.png"),
                                               title=f"{name}: coupler speed for several V_C (Fig. 22 style)")
            plots_coupler.coupler_curve(mach.mechanism, mach.controller.reference,
                                        os.path.join(args.out, f"{name}_coupler_curve.png"),
                                        title=f"{name}: coupler curve, Eq 17 reference at V_C = {args.vc[-1]} m/s")
    if not args.no_plots:
        plots_coupler.deviation_vs_vc(rows, os.path.join(args.out, "deviation_vs_vc.png"),
                                      title="max coupler-speed deviation after 1.5 s vs V_C")
    meta = {"sets": args.set, "t_end": args.t_end, "backends": args.backends}
    atomic_write(os.path.join(args.out, "metrics.json"),
                 lambda f: json.dump({"meta": meta, "results": results}, f, indent=1, default=float))
    print(f"wrote {args.out}/metrics.json")


if __name__ == "__main__":
    main()
