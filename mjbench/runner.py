"""Run a scenario end to end: machine(s) → backend(s) → trajectories, metrics, manifest, figure.

This is what ``mjbench run`` calls; ``reproduce``, sweeps and tests use the same function.
"""
from __future__ import annotations

from pathlib import Path

from . import metrics as M
from . import plausibility
from . import scenario as S
from .backends import simulate
from .manifest import manifest, write_json

BACKENDS = ("multibody", "reduced")


def backend_options(scn, backend: str) -> dict:
    """Options of a backend from the scenario's [multibody] / [reduced] tables and simulation.dt."""
    if backend == "multibody":
        return scn.multibody_options()
    r = scn.reduced
    return {"timestep": scn.simulation.dt, "method": r.method, "rtol": r.rtol, "atol": r.atol, "model": r.model}


def run_mode(scn, mode: str, backends=BACKENDS, t_end=None, progress=False) -> dict:
    """Simulate one mode on the given backends: {backend: Trajectory}."""
    t_end = float(t_end if t_end is not None else scn.simulation.t_end)
    record_dt = scn.simulation.record_dt
    out = {}
    for b in backends:
        machine = S.make_machine(scn, mode)
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
    from . import mechanisms

    cls = mechanisms.get(scn.mechanism.type)
    return getattr(cls, "reduced_source", "") if cls is not None else ""


def mujoco_derived(scn) -> bool:
    """True if the reduced model is derived from the MJCF (not an independent check)."""
    return reduced_source(scn).startswith("MuJoCo-derived")


def mode_metrics(scn, mode: str, trajs: dict) -> dict:
    """Metrics of every backend, their cross-comparison and the paper comparison rows."""
    mt = scn.metrics
    res = {"mode": mode, "backends": {b: M.summary(tr, chi_window=mt.chi_window, average=mt.chi_average,
                                                   steady_from=mt.steady_start)
                                      for b, tr in trajs.items()}}
    res["reduced_model"] = reduced_source(scn)
    if scn.law is not None and S.make_mechanism(scn).internal:
        # a motion law run by a real motor + servo (seeds 001/003 machines): residual vibration
        from .vibration import residual_from_trajectory

        mech, law = S.make_mechanism(scn), scn.law.build()
        after = max(0.0, float(next(iter(trajs.values())).t[-1]) - law.T)
        for b, tr in trajs.items():
            if after > 0:
                r = residual_from_trajectory(tr, mech.oscillator(), law.T, after)
                r["max_tracking_error_rad"] = float(abs(law.position(tr.t) - tr.q).max())
                res["backends"][b]["residual_vibration"] = r
    if "multibody" in trajs and "reduced" in trajs:
        res["multibody_vs_reduced"] = M.compare(trajs["reduced"], trajs["multibody"])
        res["plausibility"] = plausibility.backends(res["multibody_vs_reduced"])
        if mujoco_derived(scn):
            res["multibody_vs_reduced"]["note"] = ("reduced model MuJoCo-derived (from the same MJCF): "
                                                   "not an independent check")
    res["paper"] = paper_rows(scn, mode, res["backends"])
    return res


def paper_rows(scn: dict, mode: str, backend_metrics: dict) -> list:
    """Rows {name, paper, ours (per backend), difference, note} for the scenario's
    ``[[paper.figures]]`` entries of this mode (each: name, mode, metric, value, note)."""
    rows = []
    for fig in scn.paper.get("figures", []) or []:
        if fig.get("mode") not in (None, mode):
            continue
        row = {"name": fig["name"], "metric": fig["metric"], "paper": fig["value"], "note": fig.get("note", "")}
        for b, m in backend_metrics.items():
            v = m.get(fig["metric"])
            row[b] = v
            if v is not None and fig["value"]:
                row[f"{b}_rel_diff"] = (v - fig["value"]) / abs(fig["value"])
        rows.append(row)
    return rows


def run(scn, out_dir, mode=None, backend="both", t_end=None, progress=True, argv=None,
        figure=True) -> dict:
    """``mjbench run``: simulate, then write trajectory CSV(s), metrics.json, manifest.json and the
    Fig.-4-style PNG into ``out_dir``.  Returns the metrics dict."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    mode = scn.mode(mode)
    backends = BACKENDS if backend == "both" else (backend,)
    for b in backends:
        if b not in BACKENDS:
            from .errors import ParameterError
            raise ParameterError(f"--backend {b!r}: choose multibody, reduced or both")
    trajs = run_mode(scn, mode, backends, t_end, progress)
    res = mode_metrics(scn, mode, trajs)
    res["scenario"] = scn.name
    for b, tr in trajs.items():
        name = "trajectory.csv" if len(trajs) == 1 else f"trajectory_{b}.csv"
        tr.write_csv(out / name)
    write_json(out / "metrics.json", res)
    write_json(out / "manifest.json", manifest(scn, argv, {"mode": mode, "backend": backend, "backends": list(backends),
                                                            "reduced_model": res["reduced_model"],
                                                            "t_end_s": float(next(iter(trajs.values())).t[-1]),
                                                            "run_meta": {b: tr.meta for b, tr in trajs.items()}}))
    if figure:
        from .plots import fig4
        chi_txt = chi_text(res)
        tag = " [reduced model MuJoCo-derived]" if mujoco_derived(scn) and "reduced" in trajs else ""
        fig4({mode: trajs}, out / "fig4.png", setpoint=setpoint(scn, mode),
             title=f"{scn.scenario.title or scn.name} — {mode}{tag}",
             chi={mode: chi_txt} if chi_txt else None)
    return res


def setpoint(scn, mode):
    """Motor-speed set-point drawn on the speed plot (PID ``omega0``, SMC ``omega_d`` × z)."""
    p = scn.modes.get(mode)
    v = getattr(p, "omega0", None)
    if v is None and getattr(p, "omega_d", None) is not None:
        v = float(p.omega_d) * float(scn.drive.z)
    return float(v) if v is not None else None


def chi_text(res):
    """χ annotation for the Fig.-4 speed plot from a mode's metrics dict."""
    parts = []
    for b, m in res["backends"].items():
        if "chi_window" in m:
            t0, t1 = m["chi_window_s"]
            parts.append(f"{b}: χ({t0:g}–{t1:g} s) = {100 * m['chi_window']:.2f} %")
        if "chi_last_cycle" in m:
            parts.append(f"{b}: χ(last cycle) = {100 * m['chi_last_cycle']:.2f} %")
    return "\n".join(parts)
