"""The calibration: screening, least squares from distant starts, the choice among the converged
solutions, the polish at the scenario's step, the multibody verification, the sensitivity."""
from __future__ import annotations

from mjbench import scenario as S
from mjbench.errors import MjbenchError, ParameterError
import numpy as np

from .measure import measure
from .params import DEFAULT_PARAMS, TARGETS, _with, bounds_text, check_params
from .problem import Problem, _fit_one, _preload, _worker, feasible_starts


def distinct(solutions, names, tol=0.05):
    """Group converged solutions whose normalised search vectors differ by < tol (max-norm)."""
    groups = []
    for s in solutions:
        u = np.asarray(s["u"])
        for g in groups:
            if np.max(np.abs(u - np.asarray(g[0]["u"]))) < tol:
                g.append(s)
                break
        else:
            groups.append([s])
    return groups


def screen(prob, n, seed=0):
    """Global stage: evaluate n feasible Sobol points (plus the scenario's own values when
    feasible); returns [(cost, u)] sorted by cost."""
    pts = feasible_starts(prob, n, seed=seed)
    out = []
    for u, (r, *_) in zip(pts, prob.evaluate_many(pts)):  # one batch
        out.append((float(0.5 * np.sum(r * r)), np.asarray(u)))
    out.sort(key=lambda cu: cu[0])
    return out


def pick_starts(scored, k, min_dist=0.15):
    """The k best screened points that differ pairwise by ≥ min_dist (max-norm in u)."""
    chosen = []
    for cost, u in scored:
        if all(np.max(np.abs(u - v)) >= min_dist for v in chosen):
            chosen.append(u)
            if len(chosen) == k:
                break
    return chosen


def calibrate(scn, names=DEFAULT_PARAMS, starts=6, dt=1e-3, max_nfev=30, seed=0, n_screen=256,
              polish=True, polish_nfev=4, jobs=1, progress=True, accept=1.0, select="closest",
              backend="reduced"):
    """Fit the missing parameters ``names`` of an Incerti 2012 scenario to TARGETS.

    Stages: (1) ``n_screen`` feasible Sobol points evaluated at ``dt``; (2) ``least_squares``
    from the ``starts`` best mutually distant ones (``max_nfev`` iterations each, finite-
    difference Jacobian); (3) if ``polish``, a few iterations from the best solution at the
    scenario's dt and record_dt.  Returns a dict: settings, per-start solutions (values,
    measurements, residuals), the distinct converged solutions, and ``result``."""
    import time

    t0 = time.perf_counter()
    names = check_params(list(names), scn)
    prob = Problem(scn, names, dt=dt, backend=backend)
    n = len(names)
    _preload(backend, (n_screen + starts * max_nfev * (n + 1)), dt)
    prob.bar = _bar(progress, n_screen, "calibrate: screening")
    scored = screen(prob, max(n_screen, starts), seed=seed)
    if prob.bar is not None:
        prob.bar.close()
        prob.bar = None
    u_starts = pick_starts(scored, starts)
    sols = _fits(prob, scn, names, dt, u_starts, max_nfev, backend, jobs, progress)
    for k, (s, u) in enumerate(zip(sols, u_starts)):
        s["start"] = k
        s["u_start"] = u.tolist()
        s["values_start"] = prob.values(u)
        s["converged"] = bool(s["max_abs_residual"] <= accept and not s["infeasible"])
    conv = sorted([s for s in sols if s["converged"]], key=lambda s: s["cost"])
    groups = distinct(conv, names)
    best = min(sols, key=lambda s: s["cost"])
    u_prior = prob.u0()
    for s in sols:
        s["distance_to_prior"] = float(np.linalg.norm(np.asarray(s["u"]) - u_prior))
    if select not in ("closest", "best"):
        raise ParameterError(f"--select {select!r}: choose 'closest' (to the uncalibrated values) or 'best'")
    chosen = best
    if select == "closest" and conv:
        # the solution set is not a point: take the converged solution nearest the a-priori
        # (uncalibrated) values, Euclidean distance of the normalised search vectors
        chosen = min(conv, key=lambda s: s["distance_to_prior"])
    out = {"scenario": S.get(scn, "scenario.name"), "params": names, "starts": starts, "dt_search_s": dt,
           "max_nfev": max_nfev, "seed": seed, "n_screen": n_screen, "accept_max_abs_residual": accept,
           "targets": {k: {"value": v[0], "tolerance": v[1], "unit": v[2]} for k, v in TARGETS.items()},
           "bounds": bounds_text(), "screen_best_cost": scored[0][0], "solutions": sols,
           "n_converged": len(conv), "distinct": [g[0] for g in groups],
           "distinct_counts": [len(g) for g in groups], "best": best, "select": select,
           "chosen_start": chosen["start"]}
    out["sensitivity"] = sensitivity(chosen, names)
    if polish:
        out["polished"], out["result"] = _polish(scn, names, chosen, polish_nfev, progress, backend)
    else:
        out["result"] = chosen
    out["result"]["start"] = chosen["start"]
    out["search_backend"] = backend
    out["seconds_search"] = time.perf_counter() - t0
    if backend != "multibody":
        out["verification"] = verify(scn, out["result"])
    out["seconds"] = time.perf_counter() - t0
    return out


def _fits(prob, scn, names, dt, u_starts, max_nfev, backend, jobs, progress) -> list:
    """``least_squares`` from each start (``jobs`` > 1: in worker processes)."""
    sols = []
    n = len(names)
    if jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        bar = _bar(progress, len(u_starts), "calibrate: least squares (starts)")
        with ProcessPoolExecutor(max_workers=jobs) as ex:
            for s in ex.map(_worker, [(scn, names, dt, u.tolist(), max_nfev, backend) for u in u_starts]):
                sols.append(s)
                if bar is not None:
                    bar.update(1)
        if bar is not None:
            bar.close()
        return sols
    prob.bar = _bar(progress, len(u_starts) * max_nfev * (n + 1), "calibrate: least squares")
    for u in u_starts:
        sols.append(_fit_one(prob, u, max_nfev))
    if prob.bar is not None:
        prob.bar.close()
        prob.bar = None
    return sols


def _polish(scn, names, chosen, polish_nfev, progress, backend):
    """A few iterations from the chosen solution at the scenario's dt and record step → (the
    polished fit, the result: the polished fit if it halves the cost there, else the chosen one
    re-measured at that step)."""
    n = len(names)
    pprob = Problem(scn, names, dt=float(S.get(scn, "simulation.dt", 1e-4)),
                    record_dt=float(S.get(scn, "simulation.record_dt", 5e-4)), refine=False, backend=backend)
    pprob.bar = _bar(progress, polish_nfev * (n + 1) + 1, "calibrate: polish at the scenario dt")
    r0, m0, _, why0 = pprob.evaluate(np.asarray(chosen["u"]))
    pol = _fit_one(pprob, np.asarray(chosen["u"]), polish_nfev)
    if pprob.bar is not None:
        pprob.bar.close()
    pol["dt_s"] = pprob.dt
    if pol["cost"] <= 0.5 * float(np.sum(r0 * r0)):
        return pol, pol
    return pol, {**chosen, "measured": m0, "residuals": r0.tolist(), "dt_s": pprob.dt,
                 "max_abs_residual": float(np.max(np.abs(r0))), "infeasible": why0,
                 "cost": 0.5 * float(np.sum(r0 * r0))}


def verify(scn, result) -> dict:
    """The calibrated values re-measured on the multibody backend at the scenario's dt and record
    step (``metrics.chi`` as ``mjbench run``), next to the search backend's figures."""
    s = _with(scn, result["values"])
    dt = float(S.get(scn, "simulation.dt", 1e-4))
    red = measure(s, dt=dt, backend="reduced")
    try:
        mb = measure(s, dt=dt, backend="multibody")
    except MjbenchError as e:
        return {"error": str(e), "reduced": red}
    return {"dt_s": dt, "reduced": red, "multibody": mb,
            "difference": {k: mb[k] - red[k] for k in TARGETS},
            "relative": {k: (mb[k] - red[k]) / abs(mb[k]) if mb[k] else float("nan") for k in TARGETS}}


def sensitivity(sol, names):
    """Singular values of the scaled Jacobian d r / d u at a solution: the number of directions
    the three targets constrain (≤ 3) and the null-space dimension (non-uniqueness)."""
    J = np.asarray(sol.get("jac", []), dtype=float)
    if J.size == 0:
        return {}
    sv = np.linalg.svd(J, compute_uv=False)
    _, _, vt = np.linalg.svd(J)
    rank = int(np.sum(sv > 1e-3 * sv[0])) if sv.size and sv[0] > 0 else 0
    null = vt[rank:] if rank < len(names) else np.empty((0, len(names)))
    return {"singular_values": sv.tolist(), "rank": rank, "n_params": len(names),
            "null_space_dim": len(names) - rank,
            "null_directions": [dict(zip(names, np.round(v, 3).tolist())) for v in null]}


def _bar(progress, total, desc):
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="sim", leave=False, mininterval=0.5)
