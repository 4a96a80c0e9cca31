"""Run a scenario end to end: machine(s) → backend(s) → trajectories, metrics, manifest, figure.

This is what ``mjbench run`` calls; ``reproduce``, sweeps and tests use the same function.
"""
from __future__ import annotations

import math
from pathlib import Path

from . import metrics as M
from . import plausibility
from . import scenario as S
from .backends import simulate
from .manifest import copy_model_files, manifest, write_json
from . import mechanisms
from .schema import Metrics
from . import verdicts
from .errors import ParameterError
from .plots import fig4
from .backends import multibody as MB
from .backends import reduced as RD
from .kernel import Program, machine_every
from .compiled import jit

BACKENDS = ("multibody", "reduced")


def backend_options(scn, backend: str) -> dict:
    """Options of a backend from the scenario's [multibody] / [reduced] tables and simulation.dt
    (``record_joints`` from [simulation]: the joint columns, mjbench.backends.joints)."""
    joints = {"record_joints": True} if getattr(scn.simulation, "record_joints", False) else {}
    if backend == "multibody":
        return {**scn.multibody_options(), **joints}
    r = scn.reduced
    return {"timestep": scn.simulation.dt, "method": r.method, "rtol": r.rtol, "atol": r.atol, "model": r.model,
            **joints}


def run_mode(scn, mode: str, backends=BACKENDS, t_end=None, progress=False, machine=None) -> dict:
    """Simulate one mode on the given backends: {backend: Trajectory}.  ``machine``: the mode's
    machine, built once by the caller (each run starts its components afresh)."""
    t_end = float(t_end if t_end is not None else scn.simulation.t_end)
    record_dt = scn.simulation.record_dt
    machine = machine if machine is not None else S.make_machine(scn, mode)
    out = {}
    for b in backends:
        bar = None
        if progress:
            from tqdm import tqdm
            dt = backend_options(scn, b).get("timestep", 1e-4)
            bar = tqdm(total=int(round(t_end / dt)), desc=f"{mode}/{b}", unit="step", unit_scale=True,
                       leave=False, mininterval=0.5)
        try:
            out[b] = simulate(machine, b, t_end, record_dt=record_dt, options=backend_options(scn, b),
                              progress=bar)
        finally:
            if bar is not None:
                bar.close()
    return out


def reduced_source(scn) -> str:
    """Where the scenario's reduced model comes from (``Mechanism.reduced_source``)."""

    cls = mechanisms.get(scn.mechanism.type)
    return getattr(cls, "reduced_source", "") if cls is not None else ""


def mujoco_derived(scn) -> bool:
    """True if the reduced model is derived from the MJCF (not an independent check)."""
    return reduced_source(scn).startswith("MuJoCo-derived")


def run_metrics(machine, trajs: dict, config=None, multibody_options=None, reduced_model: str = "") -> dict:
    """The one metrics path (scenarios and machines built in code): every backend's metrics
    (:func:`mjbench.metrics.summary` with the ``[metrics]`` settings ``config``), the loop each ran,
    the metric families the controller adds (its :meth:`~mjbench.control.Controller.metrics`: the
    coupler-speed tracking, the residual vibration after a move …), the backends' comparison, the
    reduced model against MuJoCo's own mass matrix and bias (the model check, whenever both backends
    ran), the per-step plausibility check, the process loads along the motion and the duty and
    load warnings."""

    mt = config if config is not None else Metrics()
    first = next(iter(trajs.values()))
    if first.axes:  # several motors: every axis's metrics, then the machine's
        return _multi_axis_metrics(machine, trajs, mt, multibody_options, reduced_model)
    drive, v_limit = duty_limits(machine.drive, machine.controller)
    res = {"mode": None, "backends": {b: M.summary(tr, chi_window=mt.chi_window, average=mt.chi_average,
                                                   steady_from=mt.steady_start, band_rel=mt.band_rel,
                                                   drive=drive, v_limit=v_limit)
                                      for b, tr in trajs.items()}}
    res["reduced_model"] = reduced_model or getattr(type(machine.mechanism), "reduced_source", "")
    sp = machine.controller.setpoint(machine)
    if sp is not None:  # which shaft the set-point was given on, and the other shaft's speed
        res["setpoint"] = sp
    # which loop ran each backend (compiled or CPython) and why (mjbench.kernel.choose_loop)
    res["loop"] = {b: {"loop": tr.meta.get("loop", ""), "loop_reason": tr.meta.get("loop_reason", "")}
                   for b, tr in trajs.items()}
    for b, tr in trajs.items():  # the families the controller (and its reference) and the mechanism add
        res["backends"][b].update(machine.controller.metrics(tr, machine, mt) or {})
        res["backends"][b].update(machine.mechanism.metrics(tr, machine, mt) or {})
    if "multibody" in trajs and "reduced" in trajs:
        res["multibody_vs_reduced"] = M.compare(trajs["reduced"], trajs["multibody"])
        res["plausibility"] = plausibility.backends(res["multibody_vs_reduced"], mt.backend_tolerance)
        why = res["backends"]["multibody"].get("backends_differ_by_design")
        if why and not res["plausibility"]["backends_agree"]:  # the mechanism's own reason (a cam's jump)
            res["plausibility"].update(expected=True, note=why)
        # the reduced model against MuJoCo's own mass matrix and bias forces: controller-independent
        try:
            res["plausibility"]["model"] = plausibility.reduced_vs_mujoco(machine.mechanism, multibody_options or {})
        except Exception as e:  # noqa: BLE001 - a diagnostic must not lose the run: reported instead
            res["plausibility"]["model"] = {"applicable": False, "models_agree": None,
                                            "note": f"not compared: {type(e).__name__}: {e}"}
        if str(res["reduced_model"]).startswith("MuJoCo-derived"):
            res["multibody_vs_reduced"]["note"] = ("reduced model MuJoCo-derived (from the same MJCF): "
                                                   "not an independent check")
    # a step too coarse for the motion (per-step input-angle bound)
    res.setdefault("plausibility", {})["step"] = {
        b: plausibility.step_check(tr, float(tr.meta.get("dt", 1e-4))) for b, tr in trajs.items()}
    add_loads(res, machine.mechanism, trajs)
    add_change_points(res, machine.mechanism, trajs)
    res["warnings"] = M.duty_warnings(res["backends"]) + M.load_warnings(res["backends"])
    return res


def _multi_axis_metrics(machine, trajs, mt, multibody_options, reduced_model) -> dict:
    """:func:`run_metrics` of a machine with several motors: per backend ``axes`` {label: the one-axis
    metrics of that axis}, the families its controllers add once (the end effector's tracking of a
    path …); the backends compared per axis (``multibody_vs_reduced``: the worst axis, and each);
    the n-input model check."""
    labels = next(iter(trajs.values())).axes
    ctrl_of = {k: c for c, k in machine.controllers}  # (one controller for all axes: its limits on each)
    drives, limits = [], []
    for k, d in enumerate(machine.drives):
        d, v = duty_limits(d, ctrl_of.get(k, machine.controllers[0][0]))
        drives.append(d)
        limits.append(v)
    res = {"mode": None, "axes": list(labels), "backends": {}}
    for b, tr in trajs.items():
        res["backends"][b] = {"axes": {lab: M.summary(tr.axis(lab), steady_from=mt.steady_start, band_rel=mt.band_rel,
                                                       drive=drives[k], v_limit=limits[k])
                                       for k, lab in enumerate(labels)}}
        for c, _ in machine.controllers:
            res["backends"][b].update(c.metrics(tr, machine, mt) or {})
    res["reduced_model"] = reduced_model or getattr(type(machine.mechanism), "reduced_source", "")
    res["loop"] = {b: {"loop": tr.meta.get("loop", ""), "loop_reason": tr.meta.get("loop_reason", "")}
                   for b, tr in trajs.items()}
    if "multibody" in trajs and "reduced" in trajs:
        per = {lab: M.compare(trajs["reduced"].axis(lab), trajs["multibody"].axis(lab)) for lab in labels}
        worst = max(per, key=lambda k: per[k]["max_rel_diff"])
        res["multibody_vs_reduced"] = {**per[worst], "axis": worst, "axes": per}
        res["plausibility"] = plausibility.backends(res["multibody_vs_reduced"], mt.backend_tolerance)
        try:
            res["plausibility"]["model"] = plausibility.reduced_vs_mujoco(machine.mechanism, multibody_options or {})
        except Exception as e:  # noqa: BLE001 - a diagnostic must not lose the run: reported instead
            res["plausibility"]["model"] = {"applicable": False, "models_agree": None,
                                            "note": f"not compared: {type(e).__name__}: {e}"}
    res.setdefault("plausibility", {})["step"] = {
        b: plausibility.step_check(tr.axis(labels[0]), float(tr.meta.get("dt", 1e-4))) for b, tr in trajs.items()}
    res["warnings"] = M.duty_warnings({f"{b}, axis {lab}": m["axes"][lab] for b, m in res["backends"].items()
                                       for lab in labels})
    return res


def mode_metrics(scn, mode: str, trajs: dict, machine=None) -> dict:
    """A scenario mode's metrics: :func:`run_metrics` of its machine with the scenario's settings,
    then the paper comparison rows."""
    machine = machine if machine is not None else S.make_machine(scn, mode)
    res = run_metrics(machine, trajs, scn.metrics, scn.multibody_options(), reduced_source(scn))
    res["mode"] = mode
    res["paper"] = paper_rows(scn, mode, res["backends"])
    return res


def add_loads(res: dict, mech, trajs: dict) -> None:
    """Each backend's process loads along its motion (:func:`mjbench.metrics.loads`), when the
    mechanism has any."""
    for b, tr in trajs.items():
        ld = M.loads(mech, tr)
        if ld:
            res["backends"][b]["loads"] = ld


def add_change_points(res: dict, mech, trajs: dict) -> None:
    """Each backend's change points passed along its motion (:func:`mjbench.metrics.change_points`),
    when the mechanism has any: ``change_points`` per backend."""
    if not mech.change_points():
        return
    for b, tr in trajs.items():
        res["backends"][b]["change_points"] = M.change_points(mech, tr)


def duty_limits(drive, controller) -> tuple:
    """The drive and the controller's output clip [V] the duty figures are measured against
    (:func:`mjbench.metrics.duty`): (drive, :func:`limit_v` of the controller's ``v_limit`` and
    ``command_bound``)."""
    return drive, limit_v(getattr(controller, "v_limit", None), getattr(controller, "command_bound", None))


def limit_v(v_limit, command_bound=None):
    """The controller's voltage clip for the duty figures: its ``v_limit``, or — for a mode whose
    command is bounded (open loop, a signal: ``command_bound()``) — ``(v_limit, bound)`` so that a
    limiter at or above the largest command is known never to act."""
    bound = command_bound() if callable(command_bound) else None
    return v_limit if bound is None else (v_limit, bound)


def metric_value(m: dict, key: str):
    """A metric of one backend's dict by name; dotted names reach nested dicts
    ("coupler_speed.coupler_dev_max_after_m_s")."""
    v = m
    for part in key.split("."):
        if not isinstance(v, dict) or part not in v:
            return None
        v = v[part]
    return v


def paper_rows(scn, mode: str, backend_metrics: dict) -> list:
    """The scenario's ``[[paper.figures]]`` entries of this mode as verdict rows (mjbench.verdicts):
    {name, mode, metric, unit, paper, compare, tolerance, fitted, ours {backend: number},
    paper_text, verdict, difference, rel_difference, reason}.  Each entry names a ``metric`` of
    the run and states the paper's figure as one of ``value``, ``band``, ``max``, ``min``;
    ``unit = "%"`` shows a fraction (χ, relative errors) in percent."""

    rows = []
    for fig in scn.paper.get("figures", []) or []:
        if fig.get("mode") not in (None, mode):
            continue
        exp = verdicts.from_figure(fig)
        scale = 100.0 if exp["unit"] == "%" else 1.0
        ours = {}
        for b, m in backend_metrics.items():
            v = metric_value(m, fig["metric"])
            ours[b] = scale * float(v) if verdicts._num(v) else None
        row = {"name": fig["name"], "mode": mode, "metric": fig["metric"], "ours": ours,
               "reason": fig.get("note", ""), **exp}
        row["unit"] = exp["unit"] or M.unit_of(fig["metric"])
        rows.append(verdicts.finish_row(row))
    return rows


def backends_of(backend: str) -> tuple:
    """The backends a ``backend`` choice runs: ``"both"`` → (multibody, reduced), else (backend,)."""
    backends = BACKENDS if backend == "both" else (backend,)
    for b in backends:
        if b not in BACKENDS:
            raise ParameterError(f"--backend {b!r}: choose multibody, reduced or both")
    return backends


def simulate_mode(scn, mode: str, backend: str = "both", t_end=None, progress=False, machine=None) -> tuple:
    """Simulate ``mode`` on the backends of ``backend`` and compute what ``metrics.json`` holds:
    ({backend: Trajectory}, metrics dict).  The computing half of :func:`run`; the machine is built
    once (here, unless given) and flows one way: machine → runs → trajectories → metrics."""
    backends = backends_of(backend)
    machine = machine if machine is not None else S.make_machine(scn, mode)
    trajs = run_mode(scn, mode, backends, t_end, progress, machine)
    res = mode_metrics(scn, mode, trajs, machine)
    res["scenario"] = scn.name
    res["setpoint_motor_rad_s"] = setpoint(scn, mode, machine)
    return trajs, res


def write_run(scn, out_dir, mode: str, backend: str, trajs: dict, res: dict, argv=None, figure=True) -> None:
    """Write what ``mjbench run`` writes into ``out_dir``: trajectory CSV(s), metrics.json,
    manifest.json (``argv``: its ``command``, default ``sys.argv``), the scenario's model files
    and the Fig.-4-style PNG.  The writing half of :func:`run` (the Python API's
    ``Result.save`` calls it too)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for b, tr in trajs.items():
        name = "trajectory.csv" if len(trajs) == 1 else f"trajectory_{b}.csv"
        tr.write_csv(out / name)
    write_json(out / "metrics.json", res)
    copy_model_files(scn, out)
    write_json(out / "manifest.json", manifest(scn, argv, {"mode": mode, "backend": backend, "backends": list(trajs),
                                                            "reduced_model": res["reduced_model"],
                                                            # a controller given in code instead of the mode's
                                                            **({"controller_replaced_by": res["controller"]}
                                                               if "controller" in res else {}),
                                                            "t_end_s": float(next(iter(trajs.values())).t[-1]),
                                                            "run_meta": {b: tr.meta for b, tr in trajs.items()}}))
    if figure and "axes" in res:  # several motors: one row of plots per axis
        views = {f"{mode}, axis {lab}": {b: tr.axis(lab) for b, tr in trajs.items()} for lab in res["axes"]}
        fig4(views, out / "fig4.png", setpoint=None, title=f"{scn.scenario.title or scn.name} — {mode}")
    elif figure:
        chi_txt = chi_text(res)
        tag = " [reduced model MuJoCo-derived]" if mujoco_derived(scn) and "reduced" in trajs else ""
        sp = res["setpoint_motor_rad_s"] if "setpoint_motor_rad_s" in res else setpoint(scn, mode)
        fig4({mode: trajs}, out / "fig4.png", setpoint=sp,
             title=f"{scn.scenario.title or scn.name} — {mode}{tag}",
             chi={mode: chi_txt} if chi_txt else None)


def run(scn, out_dir, mode=None, backend="both", t_end=None, progress=True, argv=None,
        figure=True) -> dict:
    """``mjbench run``: simulate, then write trajectory CSV(s), metrics.json, manifest.json and the
    Fig.-4-style PNG into ``out_dir``.  Returns the metrics dict."""
    mode = scn.mode(mode)
    trajs, res = simulate_mode(scn, mode, backend, t_end, progress)
    write_run(scn, out_dir, mode, backend, trajs, res, argv, figure)
    return res


def setpoint(scn, mode, machine=None):
    """Motor-speed set-point drawn on the speed plot: the controller's own
    :meth:`~mjbench.control.Controller.setpoint` (PID ``omega0``, SMC ``omega_d`` × z), None without one
    (or with several axes)."""
    machine = machine if machine is not None else S.make_machine(scn, mode)
    if machine.naxes > 1:
        return None
    sp = machine.controller.setpoint(machine)
    return None if sp is None else float(sp["motor_rad_s"])


def chi_text(res):
    """χ annotation for the Fig.-4 speed plot from a mode's metrics dict (percent).  The first
    backend's values are printed; another backend's only where they differ in the digits shown."""
    bs = list(res["backends"])
    seen, lines, differ = {}, [], False
    for b in bs:
        m = res["backends"][b]
        items = []
        if "chi_window" in m:
            t0, t1 = m["chi_window_s"]
            items.append((f"χ({t0:g}–{t1:g} s)", m["chi_window"]))
        if "chi_last_cycle" in m:
            items.append((f"χ(last cycle from α(0), {m['last_cycle_start_s']:.3f}–{m['last_cycle_end_s']:.3f} s)",
                          m["chi_last_cycle"]))
        if "chi_last_turn" in m:
            items.append((f"χ(last 2π to t_end, {m['last_turn_start_s']:.3f}–{m['last_turn_end_s']:.3f} s)",
                          m["chi_last_turn"]))
        for label, v in items:
            txt = f"{label} = {100 * v:.2f} %"
            if b == bs[0]:
                lines.append(txt)
                seen[label] = txt
            elif seen.get(label) != txt:
                lines.append(f"{b}: {txt}")
                differ = True
    if lines and len(bs) > 1 and not differ:
        lines.append(f"({bs[0]}; {', '.join(bs[1:])}: the same)")
    elif lines and len(bs) > 1:
        lines.insert(0, f"{bs[0]}:")
    dts = {res["backends"][b].get("chi_sampling_s") for b in bs} - {None}
    if lines and dts:  # χ is max − min of the recorded samples: it depends on their interval
        lines.append(f"(from samples every {', '.join(f'{1e3 * d:g}' for d in sorted(dts))} ms)")
    return "\n".join(lines)


#: the duty lines of the summary: (label, metric keys joined by " / ", format, scale)
DUTY_LINES = (("RMS / peak motor current [A]", ("current_rms_steady_A", "current_peak_steady_A"), "{:.3g}", 1.0),
              ("RMS motor torque k_m·I [N·m]", ("torque_motor_rms_steady_Nm",), "{:.3g}", 1.0),
              ("RMS / peak gearbox output torque [N·m]", ("torque_output_rms_steady_Nm",
                                                           "torque_output_peak_steady_Nm"), "{:.4g}", 1.0),
              ("at the current limit {current_limit_A:g} A [% of time]", ("current_limit_fraction_steady",), "{:.2f}",
               100.0),
              ("at the voltage limit {voltage_limit_V:g} V [% of time]", ("voltage_limit_fraction_steady",), "{:.2f}",
               100.0))


def duty_text(res: dict) -> list:
    """The summary's duty lines (:func:`mjbench.metrics.duty`): over the steady-state window."""
    bs = {b: m for b, m in res["backends"].items() if m and "duty_window_s" in m}
    if not bs:
        return []
    t0, t1 = next(iter(bs.values()))["duty_window_s"]
    lines = [f"  duty over the steady state t = {t0:g}–{t1:g} s (from metrics.steady_start; default: half the run):"]
    for label, keys, fmt, scale in DUTY_LINES:
        vals = []
        for b, m in bs.items():
            xs = [m.get(k) for k in keys]
            if all(x is not None for x in xs):
                vals.append(f"{b}: " + " / ".join(fmt.format(scale * x) for x in xs))
        if vals:
            first = next(m for m in bs.values() if all(m.get(k) is not None for k in keys))
            lines.append(f"    {label.format(**first):<38s} " + "   ".join(vals))
    return lines


def change_points_text(res: dict, shown: int = 4) -> list:
    """The summary's change-point line: per backend, how many it passed and the first ``shown``
    (input angle @ time)."""
    bs = {b: m["change_points"] for b, m in res["backends"].items() if m and "change_points" in m}
    if not bs:
        return []
    vals = []
    for b, cps in bs.items():
        first = ", ".join(f"{round(e['angle_deg'], 1) % 360.0:.1f}° @ {e['time_s']:.4g} s" for e in cps[:shown])
        vals.append(f"{b}: {len(cps)}" + (f" ({first}{', …' if len(cps) > shown else ''})" if cps else ""))
    return [f"  {'change points passed (angle @ time)':<40s} " + "   ".join(vals)]


def summary_text(res: dict) -> str:
    """The summary ``mjbench run`` prints from a mode's metrics dict (:func:`simulate_mode`)."""
    if "axes" in res:
        return _multi_axis_summary(res)
    lines = [f"scenario {res['scenario']}, mode {res['mode']}"]
    sp = res.get("setpoint")
    if sp:
        rpm = 60.0 / (2.0 * math.pi)
        lines.append(f"  set-point modes.{res['mode']}.{sp['source']}: motor {sp['motor_rad_s']:.5g} rad/s "
                     f"({rpm * sp['motor_rad_s']:.4g} rpm) = crank {sp['input_rad_s']:.5g} rad/s "
                     f"({rpm * sp['input_rad_s']:.4g} rpm), z = {sp['z']:g}")
    keys = [("mean_motor_speed_rad_s", "mean motor speed (steady state) [rad/s]", "{:.3f}"),
            ("mean_crank_speed_rad_s", "mean crank speed (steady state) [rad/s]", "{:.4g}"),
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
    lines += duty_text(res)
    for name in dict.fromkeys(n for m in res["backends"].values() for n in ((m or {}).get("loads") or {})):
        vals = [f"{b}: {m['loads'][name]['peak_abs']:.4g} / {100 * m['loads'][name]['active_fraction']:.1f}"
                for b, m in res["backends"].items() if name in ((m or {}).get("loads") or {})]
        unit = next(m["loads"][name]["unit"] for m in res["backends"].values() if name in ((m or {}).get("loads") or {}))
        lines.append(f"  {f'load {name!r}: peak [{unit}] / acting [% of time]':<40s} " + "   ".join(vals))
    lines += change_points_text(res)
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


# ============================================================================ mjbench check
def check_mode(scn, mode: str, backends=BACKENDS, t_end: float = 0.05) -> list[dict]:
    """The law contract of a mode's components, checked the way a run uses them (``mjbench check``):
    per backend, the run is composed (every control law's contract and signals: a broken law is a
    ParameterError naming it), each control law is listed with the signals it reads and writes,
    then ``t_end`` s run in CPython and — when every law compiles — in the compiled loop with every
    array access bounds-checked (``MJBENCH_JIT=check``); the two must give the same bits.  Returns
    one row per backend: {backend, laws [(component, law, reads, writes)], compiled, reason, agree}."""
    import numpy as np


    rows = []
    for b in backends:
        mc = S.make_machine(scn, mode)
        o = backend_options(scn, b)
        plant = MB.MultibodyPlant(mc, o) if b == "multibody" else RD.ReducedPlant(
            mc, o["timestep"], o["method"], o["rtol"], o["atol"], o["model"])
        plant.start()
        h = float(plant.h)
        pr = Program.build(plant, mc, h, machine_every(mc, h))
        getattr(plant, "finish", lambda: None)()
        laws = []
        for slot, (form, w) in sorted(pr.wired.items()):
            if w is None:
                continue
            laws.append((form.what or slot, f"{getattr(form.law, '__module__', '?')}.{getattr(form.law, '__qualname__', '?')}",
                         list(w.names), list(w.outputs)))
        row = {"backend": b, "laws": laws, "compiled": pr.compiled, "reason": "; ".join(pr.reasons), "agree": None}
        py = simulate(S.make_machine(scn, mode), b, t_end, record_dt=h, options=o, loop="python")
        if pr.compiled:

            if jit.available():
                ck = simulate(S.make_machine(scn, mode), b, t_end, record_dt=h, options=o, loop="check")
                row["agree"] = bool(py.columns == ck.columns and np.array_equal(py.data, ck.data, equal_nan=True))
        rows.append(row)
    return rows


def _multi_axis_summary(res: dict) -> str:
    """:func:`summary_text` of a machine with several motors: per axis the speed, voltage and current
    peaks, the end effector's tracking, the backends and the model check."""
    lines = [f"scenario {res['scenario']}, mode {res['mode']} ({len(res['axes'])} axes: {', '.join(res['axes'])})"]
    for lab in res["axes"]:
        for key, label, fmt in (("peak_voltage_V", "peak |voltage| [V]", "{:.2f}"),
                                ("peak_current_A", "peak |current| [A]", "{:.2f}")):
            vals = [f"{b}: " + fmt.format(m["axes"][lab][key]) for b, m in res["backends"].items()
                    if key in m["axes"][lab]]
            lines.append(f"  axis {lab}: {label:<34s} " + "   ".join(vals))
    for b, m in res["backends"].items():
        ee = m.get("end_effector")
        if ee:
            lines.append(f"  end effector ({b}): max |error| {1e3 * ee['max_error_m']:.4f} mm, RMS "
                         f"{1e3 * ee['rms_error_m']:.4f} mm (after {ee['from_s']:g} s)")
    if "multibody_vs_reduced" in res:
        c = res["multibody_vs_reduced"]
        lines.append(f"  {'multibody vs reduced input speed':<40s} max {c['max_rel_diff']:.2e} (axis {c['axis']}, of peak)")
    mdl = res.get("plausibility", {}).get("model", {})
    if mdl.get("applicable"):
        lines.append(f"  {'reduced model vs MuJoCo (M̄, bias, inverse dynamics)':<40s} {mdl['M_rel_err']:.1e}, "
                     f"{mdl['bias_rel_err']:.1e}, {mdl['inverse_dynamics_rel_err']:.1e}")
    return "\n".join(lines)
