"""Optimum design of the Yiğit & Şen 2023 quick-return mechanism (Eqs 1-2), scipy SLSQP from several starts.

Design variables (mm, as the paper): x = (r₂, r₃, r₄, a, b) = (x₁ … x₅).  Objective (Eq 1):
minimise x₁ + x₂ + x₃ + x₄ + x₅.  Constraints (Eq 2) in our reading (docs/quickreturn.md):

* c1  r₂ < a                                   (crank shorter than the pivot distance)
* c2  200 < a + b < 500                        (height of the slider line above B₀)
* c3  250 < 2 r₃ sin δ < 350,  sin δ = r₂/a    (slider stroke; δ = half swing of the lever, the
                                                paper's "θ₃" in c3/c4 read as this angle)
* c4  250 < 2 r₃ sin δ + r₄ sin φ₄ < 500       (stroke + the rod's vertical extent; the paper's
                                                "θ₄" is read two ways, ``c4 =``:
                                                "max-abs" (default): φ₄ = φ_max, the largest
                                                |rod angle| to the slider path over the swing;
                                                "signed": φ₄ = the signed rod angle at the lever
                                                extremes, sin φ₄ = (a + b − r₃ cos δ)/r₄)
* c5  45° < μ_min < 55°,  μ = 90° − φ          (transmission angle at the slider: μ_min = 90° − φ_max)
* c6  1.5 < TR < 2,  TR = (π + 2δ)/(π − 2δ)

Closed forms (mechanisms/quickreturn.py): the lever swings over θ₃ ∈ [90° − δ, 90° + δ]; the rod
angle φ obeys r₄ sin φ = a + b − r₃ sin θ₃, so sin φ_max = max(|a+b−r₃|, |a+b−r₃ cos δ|)/r₄.
Strict inequalities are enforced with a margin ``eps`` (mm for lengths, the same number for TR;
1e-3 by default — on TR < 2 it costs about 0.15 mm of the optimum sum, reported by
``mjbench reproduce``).  The two c4 readings give the same optimum with the default bounds, and
different ones once the lower bound reaches 54 mm (Table I's smallest length; docs/quickreturn.md).
The bounds are not given
in the paper (docs/errata.md): default 10 … 500 mm for every variable (without a lower bound
the objective decreases without limit as r₂, a → 0 with r₂/a fixed).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize
from mjbench.mechanisms.quickreturn import QuickReturn
from mjbench import scenario as S
from mjbench.backends import simulate_many
from mjbench.errors import MjbenchError
from mjbench.runner import backend_options
from . import yigit2023_metrics as MQ

TABLE_I = np.array([54.0, 324.0, 78.0, 140.0, 207.0])  #: paper's optimum (mm)
NAMES = ("r2", "r3", "r4", "a", "b")
DEFAULT_BOUNDS = ((10.0, 500.0),) * 5
C4_READINGS = ("max-abs", "signed")  #: readings of constraint c4 (module doc)
DEFAULT_EPS = 1e-3  #: margin of the strict inequalities [mm; TR]


def figures(x) -> dict:
    """Design figures of x = (r₂, r₃, r₄, a, b) [mm]: δ [deg], TR, stroke [mm], c4 [mm] in both
    readings (``c4_mm`` max-abs, ``c4_signed_mm``), μ_min [deg], sum [mm]."""
    r2, r3, r4, a, b = (float(v) for v in x)
    H = a + b
    ratio = r2 / a
    d = math.asin(min(max(ratio, -1.0), 1.0))
    sphi = max(abs(H - r3), abs(H - r3 * math.cos(d))) / r4
    phi = math.asin(min(sphi, 1.0))
    stroke = 2 * r3 * math.sin(d)
    return {"delta_deg": math.degrees(d), "TR": (math.pi + 2 * d) / (math.pi - 2 * d), "stroke_mm": stroke,
            "c4_mm": stroke + r4 * math.sin(phi), "c4_signed_mm": stroke + (H - r3 * math.cos(d)),
            "mu_min_deg": 90.0 - math.degrees(phi),
            "sum_mm": r2 + r3 + r4 + a + b, "a_plus_b_mm": H, "sin_phi_max": sphi}


def constraint_values(x, eps: float = DEFAULT_EPS, c4: str = "max-abs") -> np.ndarray:
    """Inequalities g(x) ≥ 0 of c1-c6 (each strict bound with margin eps; c4 in the reading ``c4``)."""
    if c4 not in C4_READINGS:
        raise ValueError(f"c4 = {c4!r}: choose one of {C4_READINGS}")
    r2, r3, r4, a, b = x
    H = a + b
    ratio = np.clip(r2 / a, 1e-9, 1 - 1e-9)
    d = np.arcsin(ratio)
    stroke = 2 * r3 * ratio
    TR = (np.pi + 2 * d) / (np.pi - 2 * d)
    p_lo, p_hi = (H - r3) / r4, (H - r3 * np.cos(d)) / r4  # sin of the rod angle at both swing ends
    s45, s35 = math.sin(math.radians(45.0)), math.sin(math.radians(35.0))
    pmax_sq = np.maximum(p_lo * p_lo, p_hi * p_hi)
    if c4 == "max-abs":
        c4v = stroke + r4 * np.sqrt(np.clip(pmax_sq, 0.0, 1.0))
    else:  # signed rod angle at the lever extremes: r4·sin φ = a + b − r3·cos δ
        c4v = stroke + r4 * p_hi
    return np.array([
        a - r2 - eps,                       # c1
        H - 200.0 - eps, 500.0 - H - eps,   # c2
        stroke - 250.0 - eps, 350.0 - stroke - eps,  # c3
        c4v - 250.0 - eps, 500.0 - c4v - eps,        # c4
        s45 ** 2 - p_lo * p_lo - eps * 1e-3, s45 ** 2 - p_hi * p_hi - eps * 1e-3,  # c5: μ_min > 45°
        pmax_sq - s35 ** 2 - eps * 1e-3,    # c5: μ_min < 55°
        TR - 1.5 - eps, 2.0 - TR - eps,     # c6
    ])


CONSTRAINT_LABELS = ("c1 r2<a", "c2 a+b>200", "c2 a+b<500", "c3 stroke>250", "c3 stroke<350", "c4 >250",
                     "c4 <500", "c5 mu>45 (lower swing end)", "c5 mu>45 (upper swing end)", "c5 mu<55",
                     "c6 TR>1.5", "c6 TR<2")


def feasible(x, tol: float = 1e-6, c4: str = "max-abs") -> bool:
    return bool(np.all(constraint_values(x, eps=0.0, c4=c4) >= -tol))


def _slsqp(x0, bounds, cons, maxiter, c4, label):
    res = minimize(lambda x: float(np.sum(x)), x0, jac=lambda x: np.ones(5), method="SLSQP",
                   bounds=bounds, constraints=cons, options={"maxiter": maxiter, "ftol": 1e-10})
    x = np.asarray(res.x, dtype=float)
    return {"start": label, "x0": np.asarray(x0, dtype=float).tolist(), "x": x.tolist(), "sum_mm": float(np.sum(x)),
            "success": bool(res.success), "feasible": feasible(x, c4=c4), "message": str(res.message)}


def optimise(starts: int = 8, seed: int = 0, bounds=DEFAULT_BOUNDS, include_table: bool = True,
             eps: float = DEFAULT_EPS, maxiter: int = 500, c4: str = "max-abs", global_search: bool = True) -> dict:
    """Minimise Eq 1 under Eq 2 (our reading): SLSQP from ``starts`` points (Table I first when
    ``include_table``, then uniform random points in the bounds, seeded) and, with
    ``global_search``, scipy's differential evolution (seeded, constraints handled by DE)
    polished by SLSQP.  The feasible set is not connected (for lower bounds ≳ 50 mm the slider
    line can sit above or below the lever tip at the swing ends, and μ_min < 55° separates the
    two branches), so local starts alone can miss the optimum; DE does not (docs/quickreturn.md).

    Returns every run, the best feasible design ("best", with the start that found it), the
    local answer from Table I ("from_table_I", what a local optimiser started there gives) and
    Table I's own figures.  ``c4``: the reading of constraint c4 (:data:`C4_READINGS`); ``eps``:
    margin of the strict inequalities."""
    if c4 not in C4_READINGS:
        raise ValueError(f"c4 = {c4!r}: choose one of {C4_READINGS}")
    rng = np.random.default_rng(seed)
    lo, hi = np.array([b[0] for b in bounds]), np.array([b[1] for b in bounds])
    x0s = [("Table I", TABLE_I.copy())] if include_table else []
    while len(x0s) < starts:
        x0s.append((f"random {len(x0s)}", lo + (hi - lo) * rng.random(5)))
    cons = [{"type": "ineq", "fun": lambda x: constraint_values(x, eps, c4)}]
    runs = [_slsqp(x0, bounds, cons, maxiter, c4, label) for label, x0 in x0s[:starts]]
    if global_search:
        from scipy.optimize import NonlinearConstraint, differential_evolution

        nlc = NonlinearConstraint(lambda x: constraint_values(x, eps, c4), 0.0, np.inf)
        de = differential_evolution(lambda x: np.sum(x, axis=0), bounds, constraints=(nlc,), seed=seed, tol=1e-8,
                                    maxiter=1000, polish=False, vectorized=True, updating="deferred")
        runs.append(_slsqp(de.x, bounds, cons, maxiter, c4, "differential evolution + SLSQP"))
    ok = [r for r in runs if r["feasible"]]
    best = min(ok, key=lambda r: r["sum_mm"]) if ok else None
    out = {"bounds_mm": [list(b) for b in bounds], "starts": starts, "seed": seed, "c4": c4, "eps": eps,
           "global_search": bool(global_search), "runs": runs,
           "table_I": {"x": TABLE_I.tolist(), **figures(TABLE_I), "feasible": feasible(TABLE_I, c4=c4),
                       "violated": [lbl for lbl, v in zip(CONSTRAINT_LABELS, constraint_values(TABLE_I, 0.0, c4))
                                    if v < 0]}}
    if best is not None:
        out["best"] = {"x": best["x"], "start": best["start"], **dict(zip(NAMES, best["x"])), **figures(best["x"])}
    if include_table and runs[0]["feasible"]:
        out["from_table_I"] = {"x": runs[0]["x"], **figures(runs[0]["x"])}
    return out


def check_with_mechanism(x_mm) -> dict:
    """Cross-check the closed forms with the full kinematics of QuickReturn (lengths in mm)."""

    r2, r3, r4, a, b = (float(v) * 1e-3 for v in x_mm)
    m = QuickReturn(r2=r2, r3=r3, r4=r4, a=a, b=b)
    return {"TR": m.time_ratio, "stroke_mm": 1e3 * m.stroke, "mu_min_deg": math.degrees(m.min_transmission_angle())}


# ------------------------------------------------------------------ dynamic check of the designs
#: figures of the closed-loop run of a design (Yiğit & Şen SMC at ω_d, steady window)
DYN_FIGURES = (("error_abs_mean", "SMC |mean e| / ω_d", "1"), ("current_rms_steady", "steady rms current", "A"),
               ("current_peak", "peak current", "A"), ("speed_mean", "mean crank speed", "rad/s"))


def candidates(res) -> list:
    """[(label, x_mm)]: Table I, then the distinct feasible SLSQP end points by increasing sum."""
    out = [("Table I", [float(v) for v in TABLE_I])]
    seen = []
    for r in sorted((r for r in res["runs"] if r["feasible"]), key=lambda r: r["sum_mm"]):
        x = np.round(np.asarray(r["x"]), 2)
        if any(np.max(np.abs(x - y)) < 0.05 for y in seen):
            continue
        seen.append(x)
        out.append((f"optimum {len(seen)}" if len(seen) > 1 else "optimum", [float(v) for v in r["x"]]))
    return out


def _scenario(x_mm, overrides=()):

    keys = {n: float(v) * 1e-3 for n, v in zip(NAMES, x_mm)}
    return S.with_values(S.load("yigit2023", list(overrides)), {f"mechanism.{k}": v for k, v in keys.items()})


def simulate_designs(designs, backend="reduced", mode="smc", t_end=None, overrides=()) -> list:
    """Closed-loop figures (:data:`DYN_FIGURES`) of each design x [mm] with Table I's masses and drive,
    the runs simulated together on ``backend``; a design that cannot be built or diverges gives
    {"error": message}."""


    out, machines, idx = [None] * len(designs), [], []
    scn0 = None
    for i, x in enumerate(designs):
        try:
            s = _scenario(x, overrides)
            machines.append(S.make_machine(s, mode))
            idx.append(i)
            scn0 = scn0 or s
        except (MjbenchError, ValueError) as e:
            out[i] = {"error": str(e)}
    if not machines:
        return out
    t_end = float(t_end if t_end is not None else scn0.simulation.t_end)
    opts = backend_options(scn0, backend)
    wd = float(S.get(scn0, "metrics.omega_d", 5.0))
    t0 = min(float(S.get(scn0, "metrics.steady_start", 2.0)), 0.5 * t_end)
    res = simulate_many(machines, backend, t_end, record_dt=scn0.simulation.record_dt, options=opts)
    for j, i in enumerate(idx):
        if res.diverged[j]:
            out[i] = {"error": res.messages[j]}
            continue
        tr = res.trajectory(j)
        out[i] = {**MQ.steady_error(tr, wd, t0), **MQ.current_stats(tr, t0), **MQ.speed_stats(tr, t0)}
    return out


def dynamic_check(res, backend="reduced", verify=2, mode="smc", t_end=None, overrides=()) -> dict:
    """Every candidate design (:func:`candidates`) in closed loop on ``backend``; the first
    ``verify`` + 1 (Table I and the best optima) re-run on the multibody backend when the search
    backend is the reduced model.  Masses, drive and controller: Table I's scenario (the paper
    gives no mass model for other lengths)."""
    cands = candidates(res)
    figs = simulate_designs([x for _, x in cands], backend, mode, t_end, overrides)
    rows = [{"label": lab, "x": x, backend: f} for (lab, x), f in zip(cands, figs)]
    if backend != "multibody" and verify > 0:
        k = min(len(cands), 1 + verify)
        mb = simulate_designs([x for _, x in cands[:k]], "multibody", mode, t_end, overrides)
        for r, f in zip(rows, mb):
            r["multibody"] = f
    return {"backend": backend, "mode": mode, "rows": rows,
            "note": "masses, drive and SMC of Table I's scenario for every design"}


def dynamic_table(dyn) -> str:
    b = dyn["backend"]
    lines = [f"closed loop ({dyn['mode']}) of each design on the {b} backend"
             + (" → multibody (verification)" if any("multibody" in r for r in dyn["rows"]) and b != "multibody" else "")
             + f"; {dyn['note']}"]
    for r in dyn["rows"]:
        f = r[b]
        if "error" in f:
            lines.append(f"  {r['label']:<10s} {f['error']}")
            continue
        for key, text, unit in DYN_FIGURES:
            line = f"  {r['label']:<10s} {text:<20s} {f[key]:12.6g}"
            m = r.get("multibody")
            if m is not None and b != "multibody":
                if "error" in m:
                    line += f"   multibody: {m['error']}"
                else:
                    d = m[key] - f[key]
                    line += f" → {m[key]:12.6g} {unit:<5s} (difference {d:+.3g}, {100 * d / abs(m[key]) if m[key] else float('nan'):+.3g} %)"
            else:
                line += f" {unit}"
            lines.append(line)
    return "\n".join(lines)
