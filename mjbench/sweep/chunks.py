"""Running a chunk of rows as one batch on the sweep's backend (the same pure function locally
and on a Dask worker), and the best rows verified on the multibody backend."""
from __future__ import annotations

import csv
import io
import os

import numpy as np

from .. import metrics as M
from .. import outputs
from .. import scenario as S
from ..errors import MjbenchError, ParameterError
from ..trajectory import atomic_write
from .rows import RowScenarios
from .spec import SweepSpec, VERIFY
from .table import _fmt, default_metric
from ..backends import SEARCH_BACKENDS
from ..runner import backend_options, duty_limits
from ..backends import batch, simulate_many


# ======================================================================== simulation of a chunk
def settings(spec: SweepSpec, scn) -> dict:

    if spec.backend not in SEARCH_BACKENDS:
        raise ParameterError(f"--backend {spec.backend!r}: choose one of {list(SEARCH_BACKENDS)}")
    mode = scn.mode(spec.mode)
    return {"mode": mode, "t_end_fixed": spec.t_end, "backend": spec.backend,
            **_run_settings(scn, spec.t_end, spec.backend)}


def _run_settings(scn, t_end_fixed, backend="multibody"):
    """Per-row run settings (a sweep may vary simulation.dt, the integrator, the χ window ...)."""

    opts = backend_options(scn, backend)
    if backend == "reduced":
        opts["method"] = "rk4"  # the batched reduced model's integrator
    return {"t_end": float(t_end_fixed if t_end_fixed is not None else scn.simulation.t_end),
            "record_dt": scn.simulation.record_dt,
            "options": opts,
            "chi_window": scn.metrics.chi_window,
            "chi_average": scn.metrics.chi_average,
            "steady_from": scn.metrics.steady_start, "band_rel": scn.metrics.band_rel}


def row_metrics(traj, st, machine=None) -> dict:
    """A row's numeric metrics (:func:`mjbench.metrics.summary`; a mechanism with change points: how
    many its run passed, ``change_points_passed``).  Several motors: each axis's, named
    ``A:peak_current_A`` …, and the end effector's tracking of the path (``end_effector_max_error_m``,
    ``end_effector_rms_error_m``) when the machine's controllers track one."""
    if traj.axes:
        out = {}
        for lab in traj.axes:
            m = M.summary(traj.axis(lab), average=st["chi_average"])
            out.update({f"{lab}:{k}": v for k, v in m.items() if _number(v)})
        for c, _ in (machine.controllers if machine is not None else ()):
            ee = (c.metrics(traj, machine, None) or {}).get("end_effector")
            if ee:
                out.update({f"end_effector_{k}": v for k, v in ee.items() if _number(v)})
                break
        return out
    win = st["chi_window"]
    drive, v_limit = st.get("duty") or (None, None)
    m = M.summary(traj, chi_window=win, average=st["chi_average"], steady_from=st.get("steady_from"),
                  band_rel=st.get("band_rel", 0.10), drive=drive, v_limit=v_limit)
    out = {k: v for k, v in m.items() if _number(v)}
    if machine is not None and machine.mechanism.change_points():
        out["change_points_passed"] = len(M.change_points(machine.mechanism, traj))
    return out


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def run_chunk(scn, rows: list, keys: list, st: dict, nthread: int = 0) -> list[dict]:
    """Simulate ``rows`` of the sweep in one batch (per model structure) on ``st["backend"]`` →
    result rows.  Pure: the same input gives the same output locally and on a Dask worker."""

    backend = st.get("backend", "multibody")
    outputs.route_mujoco_log()  # on a Dask worker too: MuJoCo warnings recorded, no ./MUJOCO_LOG.TXT
    out = {r["row"]: dict(r) for r in rows}
    machines, ok_rows, models, sts, sigs, cache = [], [], [], [], [], {}
    scenarios = RowScenarios(scn, keys)
    for r in rows:
        try:
            s = scenarios(r)
            st_r = _run_settings(s, st.get("t_end_fixed"), backend)
            mc = S.make_machine(s, st["mode"])
            # the row's limits for its duty figures (several axes: the rows carry no per-axis duty figures)
            st_r["duty"] = duty_limits(mc.drive, mc.controller) if mc.naxes == 1 else (None, None)
            if backend == "multibody":
                o = {**batch.DEFAULT_OPTIONS, **st_r["options"]}
                key = batch._model_key(mc, o)
                if key not in cache:
                    cache[key] = batch.build_models([mc], o)[0]
                m = cache[key]
                models.append(m)
                sig = (m.nq, m.nv, m.nbody, m.neq, m.nsite, m.nu, m.na)
            else:
                sig = (type(mc.mechanism).__name__, mc.mechanism.internal)
            machines.append(mc)
            sts.append(st_r)
            sigs.append(sig + (repr(sorted(st_r["options"].items())), st_r["t_end"], st_r["record_dt"]))
            ok_rows.append(r)
        except (MjbenchError, ValueError) as e:  # invalid combination: a row of the table, not a crash
            out[r["row"]].update(status="error", message=str(e))
    groups = {}
    for i, sig in enumerate(sigs):
        groups.setdefault(sig, []).append(i)
    for idx in groups.values():
        st0 = sts[idx[0]]
        try:
            if backend == "multibody":
                o = {**batch.DEFAULT_OPTIONS, **st0["options"]}
                res = batch.simulate([machines[i] for i in idx], st0["t_end"], record_dt=st0["record_dt"],
                                     options=o, nthread=nthread, models=[models[i] for i in idx])
            else:  # metrics computed as each run ends: one record per thread in memory, not the batch's
                res = simulate_many([machines[i] for i in idx], backend, st0["t_end"], record_dt=st0["record_dt"],
                                    options=st0["options"],
                                    consume=lambda j, tr: _outcome(tr, sts[idx[j]], machines[idx[j]]))
        except MjbenchError as e:
            for i in idx:
                out[ok_rows[i]["row"]].update(status="error", message=str(e))
            continue
        for j, i in enumerate(idx):
            rr = out[ok_rows[i]["row"]]
            if res.diverged[j]:
                rr.update(status="diverged", message=res.messages[j])
                continue
            rr.update(**(res.results[j] if res.results is not None else _outcome(res.trajectory(j), sts[i], machines[i])))
    return [out[r["row"]] for r in rows]


def _outcome(traj, st, machine=None) -> dict:
    """The result cells of one run that ended: its metrics, or the error computing them."""
    if traj.meta.get("diverged"):
        return {}
    try:
        return {"status": "ok", **row_metrics(traj, st, machine)}
    except MjbenchError as e:
        return {"status": "error", "message": str(e)}


def verify_best(spec: SweepSpec, scn, results: list[dict], keys: list, st: dict, metric: str | None,
                out_dir=None, nthread: int = 0) -> list[dict]:
    """Re-run the ``spec.verify`` best rows (smallest ``metric``) on the multibody backend →
    [{row, keys..., metric, reduced, multibody, difference, relative}], written to verify.csv."""
    metric = metric or default_metric(results)
    ok = [r for r in results if r.get("status") == "ok" and metric in r and np.isfinite(r[metric])]
    best = sorted(ok, key=lambda r: r[metric])[:max(0, int(spec.verify))]
    if not best or metric is None:
        return []
    rows = [{k: r[k] for k in ("row", *keys) if k in r} for r in best]
    mb = run_chunk(scn, rows, keys, {**st, "backend": "multibody"}, nthread)
    out = []
    for r, m in zip(best, mb):
        v = m.get(metric, float("nan")) if m.get("status") == "ok" else float("nan")
        d = {"row": r["row"], **{k: r[k] for k in keys if k in r}, "metric": metric, st["backend"]: r[metric],
             "multibody": v, "difference": v - r[metric],
             "relative": (v - r[metric]) / abs(v) if v else float("nan")}
        out.append(d)
    if out_dir is not None:
        cols = list(out[0])
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(cols)
        for d in out:
            w.writerow([_fmt(d[c]) for c in cols])
        atomic_write(os.path.join(out_dir, VERIFY), lambda f: f.write(buf.getvalue()))
    return out
