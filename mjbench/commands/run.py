"""``mjbench run`` and ``mjbench list``."""
from __future__ import annotations

import sys

from . import add_fast_multibody, apply_fast_multibody, quantity, refuse_unused
from ..outputs import add_force_option


def register(sub):
    p = sub.add_parser("run", help="simulate a scenario on one or both backends and write results",
                       description="Simulate SCENARIO (built-in name or TOML path). Writes trajectory CSV(s), "
                                   "metrics.json, manifest.json and a Fig.-4-style PNG into --out.")
    p.add_argument("scenario", help="built-in scenario name (see `mjbench list`), a TOML file, or a run's "
                                    "manifest.json (repeats that run)")
    p.add_argument("--mode", help="control mode defined in the scenario, e.g. open, pid (default: the scenario's)")
    p.add_argument("--backend", default=None, choices=["multibody", "reduced", "both"],
                   help="simulator backend (default: the scenario's, else both)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value, e.g. --set drive.R=2.5 --set modes.pid.kp=100")
    p.add_argument("--t-end", type=quantity("time", gt=0.0), help="simulated time [s] (default: the scenario's)")
    p.add_argument("--out", required=True, help="output directory (written whole or not at all: docs/outputs.md)")
    add_force_option(p)
    p.add_argument("--no-figure", action="store_true", help="skip the PNG")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    add_fast_multibody(p)
    p.set_defaults(func=cmd_run)

    q = sub.add_parser("list", help="list the built-in scenarios and their modes")
    q.set_defaults(func=cmd_list)


def cmd_run(args):
    from .. import scenario as S
    from ..outputs import staged_dir
    from ..plausibility import warnings_of
    from ..preflight import check_machine, simulation_errors
    from ..runner import run

    scn = S.load(args.scenario, apply_fast_multibody(args, args.overrides))
    for w in scn.warnings:
        print(f"mjbench: warning: {w}", file=sys.stderr)
    mode, backend, t_end = args.mode, args.backend, args.t_end
    if args.scenario.endswith(".json"):  # a run's manifest: repeat that run unless told otherwise
        man = _read_manifest(args.scenario)
        mode = mode or man.get("mode")
        backend = backend or man.get("backend")
        t_end = t_end if t_end is not None else man.get("t_end_s")
    backend = backend or scn.simulation.backend
    if getattr(args, "fast_multibody", None) and backend == "reduced":
        refuse_unused("--fast-multibody", "it sets the multibody integrator and --backend reduced runs no multibody "
                                          "simulation")
    check_machine(scn, mode)  # bad values: one message before simulating
    with staged_dir(args.out, force=args.force) as tmp, simulation_errors(scn):
        res = run(scn, tmp, mode=mode, backend=backend, t_end=t_end,
                  progress=not args.quiet and sys.stderr.isatty(), argv=sys.argv, figure=not args.no_figure)
    if not args.quiet:
        print(_summary_text(res))
        print(f"results written to {args.out}")
    for w in warnings_of(res):
        print(f"mjbench: warning: {w}", file=sys.stderr)
    return 0


def _read_manifest(path):
    import json

    with open(path) as f:
        return json.load(f)


def _summary_text(res):
    lines = [f"scenario {res['scenario']}, mode {res['mode']}"]
    keys = [("mean_motor_speed_rad_s", "mean motor speed (2nd half) [rad/s]", "{:.3f}"),
            ("chi_last_cycle", "χ last complete cycle from α(0) [%]", "pct"),
            ("chi_last_turn", "χ last 2π of travel to t_end [%]", "pct"),
            ("chi_window", "χ in the metrics window [%]", "pct"),
            ("peak_voltage_V", "peak |voltage| [V]", "{:.2f}"),
            ("peak_current_A", "peak |current| [A]", "{:.2f}"),
            ("max_closure_error_m", "max loop-closure error [m]", "{:.2e}")]
    cs = next((m["coupler_speed"] for m in res["backends"].values() if "coupler_speed" in m), None)
    after = f"after {cs['settle_time_s']:g} s" if cs else "after settle_time"
    keys += [("coupler_speed.coupler_dev_max_after_m_s", f"max |V_C − V_des| {after} [m/s]", "{:.5f}"),
             ("coupler_speed.crank_error_max_after_rad_s", f"max |crank error| {after} [rad/s]", "{:.4f}"),
             ("coupler_speed.rise_time_s", "rise time of V_C [s]", "{:.3f}"),
             ("coupler_speed.settling_time_s", "settling time of V_C [s]", "{:.3f}")]
    from ..runner import metric_value

    for k, label, fmt in keys:
        vals = []
        for b, m in res["backends"].items():
            v = metric_value(m, k)
            if v is not None:
                vals.append(f"{b}: " + (f"{100 * v:.3f}" if fmt == "pct" else fmt.format(v)))
        if vals:
            lines.append(f"  {label:<40s} " + "   ".join(vals))
    dts = {m.get("chi_sampling_s") for m in res["backends"].values()} - {None}
    if dts:  # χ is max − min of the record's samples: it depends on their interval
        lines.append(f"  {'χ computed from samples every':<40s} {', '.join(f'{1e3 * d:g}' for d in sorted(dts))} ms "
                     f"(simulation.record_dt)")
    if "multibody_vs_reduced" in res:
        c = res["multibody_vs_reduced"]
        lines.append(f"  {'multibody vs reduced crank speed':<40s} max {c['max_rel_diff']:.2e}   RMS {c['rms_rel_diff']:.2e} (of peak)")
        if c.get("note"):
            lines.append(f"  {'':<40s} ({c['note']})")
    if str(res.get("reduced_model", "")).startswith("MuJoCo-derived"):
        lines.append(f"  reduced model: {res['reduced_model']}")
    for row in res.get("paper", []):
        ours = "   ".join(f"{b}: {v:.4g}" for b, v in row["ours"].items() if v is not None)
        unit = "" if row.get("unit") in ("", "1", None) else f" {row['unit']}"
        lines.append(f"  paper: {row['name']}: {row['paper_text']}{unit}   ours {ours}\n"
                     f"         verdict: {row['verdict']['text']}")
    return "\n".join(lines)


def cmd_list(args):
    from .. import scenario as S

    for name in S.builtin_names():
        try:
            scn = S.load(name)
        except Exception as e:  # noqa: BLE001 - listing must not die on one bad file
            print(f"{name:<22s} (cannot load: {e})")
            continue
        modes = ", ".join(S.modes(scn)) + (" + optimize-law" if scn.law is not None else "")
        print(f"{name:<22s} modes: {modes:<18s} {scn.scenario.title}")
    return 0
