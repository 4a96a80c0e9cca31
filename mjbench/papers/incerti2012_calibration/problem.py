"""The fit problem: residuals of the search vector (penalised when infeasible), feasible starts,
the Gauss–Newton corrections, one least-squares fit."""
from __future__ import annotations

from dataclasses import dataclass, field

from mjbench import scenario as S
from mjbench.backends import SEARCH_BACKENDS
from mjbench.errors import ParameterError, SimulationDiverged
import numpy as np

from .measure import measure, measure_many, residuals_of
from .params import DIFF_STEP, LINK, PENALTY, TARGETS, _base_values, _with, feasibility, to_u, values
from mjbench import kernel


@dataclass
class Problem:
    scn: object
    names: list
    dt: float = 1e-3
    record_dt: float | None = None
    nfev: int = 0
    bar: object = None
    cache: dict = field(default_factory=dict)
    #: parabola-refined max/min in χ (search); False = metrics.chi exactly as `mjbench run` (polish)
    refine: bool = True
    #: search backend: the (batched) reduced model, or MuJoCo
    backend: str = "reduced"

    def __post_init__(self):
        if self.backend not in SEARCH_BACKENDS:
            raise ParameterError(f"--backend {self.backend!r}: choose one of {list(SEARCH_BACKENDS)}")
        self.base = _base_values(self.scn)
        self.J_G = {i: float(S.get(self.scn, f"mechanism.J_G{i}")) for i in LINK}

    def _key(self, u):
        return tuple(np.round(np.asarray(u, dtype=float), 12))

    def evaluate_many(self, U):
        """:meth:`evaluate` of many search vectors, the feasible ones simulated together."""
        keys = [self._key(u) for u in U]
        todo, seen = [], set()
        for u, k in zip(U, keys):
            if k not in self.cache and k not in seen:
                todo.append((np.asarray(u, dtype=float), k))
                seen.add(k)
        feas = []
        for u, k in todo:
            vals = self.values(u)
            viol, why = feasibility(self.scn, vals, self.J_G)
            if viol > 0:
                self._store(k, (np.full(len(TARGETS), PENALTY * (1.0 + viol)), None, vals, why))
            else:
                feas.append((k, vals, why))
        if feas:
            meas = measure_many([_with(self.scn, v) for _, v, _ in feas], dt=self.dt,
                                record_dt=self.record_dt or self.dt, backend=self.backend, refine=self.refine)
            for (k, vals, why), m in zip(feas, meas):
                if isinstance(m, str):
                    self._store(k, (np.full(len(TARGETS), PENALTY), None, vals, f"diverged: {m}"))
                    continue
                r = residuals_of(m)
                if not np.all(np.isfinite(r)):
                    r, why = np.full(len(TARGETS), PENALTY), "no complete crank cycle"
                self._store(k, (r, m, vals, why))
        self.nfev += len(todo)
        if self.bar is not None and todo:
            self.bar.update(len(todo))
        return [self.cache[k] for k in keys]

    def _store(self, key, out):
        if len(self.cache) > 5000:
            self.cache.clear()
        self.cache[key] = out

    def jac(self, u, h=None):
        """Forward-difference Jacobian of the residuals (steps as scipy's '2-point' scheme with
        ``diff_step``, reversed at the upper bound 1), its columns simulated together."""
        u = np.asarray(u, dtype=float)
        h = DIFF_STEP if h is None else h
        steps = []
        for j in range(len(u)):
            hj = h * max(1.0, abs(u[j]))
            if u[j] + hj > 1.0:
                hj = -hj
            steps.append(hj)
        pts = []
        for j, hj in enumerate(steps):
            e = u.copy()
            e[j] = u[j] + hj
            pts.append(e)
        res = self.evaluate_many([u] + pts)
        r0 = res[0][0]
        J = np.empty((len(r0), len(u)))
        for j, (hj, e) in enumerate(zip(steps, pts)):
            J[:, j] = (res[j + 1][0] - r0) / (e[j] - u[j])
        return J

    def values(self, u):
        return values(u, self.names, self.base, self.J_G)

    def u0(self):
        return to_u(self.base, self.names, self.base, self.J_G)

    def evaluate(self, u):
        """(residual vector, measurements or None, values, feasibility message)."""
        key = tuple(np.round(np.asarray(u, dtype=float), 12))
        if key in self.cache:
            return self.cache[key]
        vals = self.values(u)
        viol, why = feasibility(self.scn, vals, self.J_G)
        meas = None
        if viol > 0:
            r = np.full(len(TARGETS), PENALTY * (1.0 + viol))
        else:
            try:
                meas = measure(_with(self.scn, vals), dt=self.dt, record_dt=self.record_dt or self.dt,
                               refine=self.refine, backend=self.backend)
                r = residuals_of(meas)
                if not np.all(np.isfinite(r)):
                    r = np.full(len(TARGETS), PENALTY)
                    why = "no complete crank cycle"
            except SimulationDiverged as e:
                r, why = np.full(len(TARGETS), PENALTY), f"diverged: {e}"
        self.nfev += 1
        if self.bar is not None:
            self.bar.update(1)
        out = (r, meas, vals, why)
        if len(self.cache) > 5000:
            self.cache.clear()
        self.cache[key] = out
        return out

    def fun(self, u):
        return self.evaluate(u)[0]


def feasible_starts(prob, n, seed=0, include_scenario=True, max_tries=4000):
    """n feasible start vectors: the scenario's own values (if feasible), then Sobol points."""
    from scipy.stats import qmc

    out = []
    if include_scenario:
        u = prob.u0()
        if feasibility(prob.scn, prob.values(u), prob.J_G)[0] == 0:
            out.append(u)
    sob = qmc.Sobol(len(prob.names), scramble=True, seed=seed)
    tries = 0
    while len(out) < n and tries < max_tries:
        for u in sob.random(16):
            tries += 1
            if feasibility(prob.scn, prob.values(u), prob.J_G)[0] == 0:
                out.append(u)
                if len(out) >= n:
                    break
    if len(out) < n:
        raise ParameterError(f"found only {len(out)} feasible starting points in {tries} tries for "
                             f"--params {','.join(prob.names)} (bounds in mjbench/calibrate.py)")
    return out[:n]


def newton_refine(prob, u, iters=8, goal=0.5, h=DIFF_STEP):
    """Minimum-norm Gauss–Newton corrections u ← u + t·J⁺(−r) (t = 1, ½, ¼; kept in [0, 1]) until
    every |r_i| ≤ ``goal`` or no step lowers the cost.  With fewer targets than parameters this
    moves to the *nearest* point of the solution set; the trust-region search before it stalls
    on the widely different scales of the three residuals (singular values 10 … 10⁴)."""
    u = np.asarray(u, dtype=float)
    r = prob.fun(u)
    n_eval = 1
    for _ in range(iters):
        if np.max(np.abs(r)) <= goal:
            break
        pts = []
        for j in range(len(u)):
            e = np.zeros_like(u)
            e[j] = h if u[j] + h <= 1.0 else -h
            pts.append((u + e, e[j]))
        res = prob.evaluate_many([p for p, _ in pts])  # the columns simulated together
        J = np.empty((len(r), len(u)))
        for j, ((p, ej), rr) in enumerate(zip(pts, res)):
            J[:, j] = (rr[0] - r) / ej
        n_eval += len(u)
        du = np.linalg.lstsq(J, -r, rcond=None)[0]
        c0 = float(np.sum(r * r))
        for t in (1.0, 0.5, 0.25):
            un = np.clip(u + t * du, 0.0, 1.0)
            rn = prob.fun(un)
            n_eval += 1
            if float(np.sum(rn * rn)) < c0:
                u, r = un, rn
                break
        else:
            break
    return u, n_eval


def _fit_one(prob, u0, max_nfev, newton=8):
    from scipy.optimize import least_squares

    res = least_squares(prob.fun, u0, jac=prob.jac, bounds=(0.0, 1.0), method="trf",
                        x_scale=1.0, max_nfev=max_nfev, xtol=1e-8, ftol=1e-10, gtol=1e-10)
    u, n_newton = newton_refine(prob, res.x, iters=newton) if newton else (res.x, 0)
    res.x = u
    r, meas, vals, why = prob.evaluate(res.x)
    return {"u": res.x.tolist(), "values": vals, "measured": meas, "residuals": r.tolist(),
            "cost": float(0.5 * np.sum(r * r)), "max_abs_residual": float(np.max(np.abs(r))),
            "nfev": int(res.nfev), "newton_evals": int(n_newton), "status": int(res.status),
            "message": res.message,
            "infeasible": why, "jac": np.asarray(res.jac).tolist()}


def _worker(args):
    scn, names, dt, u0, max_nfev, backend = args
    prob = Problem(scn, names, dt=dt, backend=backend)
    _preload(backend, max_nfev * (len(names) + 1), dt)
    return _fit_one(prob, np.asarray(u0), max_nfev)


def _preload(backend, evaluations, dt):
    """Load the compiled co-step (numba; same bits) when the planned reduced-model work pays for it:
    every evaluation is an open-loop and a PID run of ≥ 0.5 s each."""
    if backend == "reduced":
        kernel.preload(evaluations * 2 * 0.5 / dt)
