"""Plausibility flags in metrics.json: results that are computed fine but should not be trusted.

Backends agreement
------------------
When a mode runs on both backends, the multibody (MuJoCo) and reduced (Eksergian J(α)) crank
speeds are compared (``metrics.compare``: max |difference| over the run, divided by the peak
|crank speed| of the reduced run).  They model the same machine with the same drive and
controller, so they must agree: on every built-in scenario and mode the difference is at most
1.3e-5 of the peak (incerti2012 open loop; 1e-7 to 2e-6 for the other machines).

:data:`BACKENDS_TOLERANCE` = 1e-3 of the peak (over 70 times the largest healthy difference).
Above it, ``metrics.json`` holds ``"plausibility": {"backends_agree": false, ...}`` and
``mjbench run`` prints a warning on stderr: one of the models is then outside its validity range
(e.g. ``--set modes.pid.kd=1e3`` on incerti2012: 178 % of the peak, a loop that is unstable at the
control period), and neither trajectory should be used without checking why.
"""
from __future__ import annotations

import math

import numpy as np

BACKENDS_TOLERANCE = 1e-3  #: max |multibody − reduced| crank speed / peak |crank speed|


def backends(compare: dict, tolerance: float = BACKENDS_TOLERANCE) -> dict:
    """The ``plausibility`` entry of a mode's metrics from its ``multibody_vs_reduced`` entry
    (``tolerance``: the scenario's ``metrics.backend_tolerance``, default :data:`BACKENDS_TOLERANCE`)."""
    mx = compare.get("max_rel_diff")
    agree = mx is not None and math.isfinite(mx) and mx <= tolerance
    out = {"backends_agree": bool(agree), "max_rel_diff": mx, "tolerance": float(tolerance),
           "column": compare.get("column", "crank_speed_rad_s"),
           "normalisation": compare.get("normalisation", "peak |reference| over the run")}
    if not agree:
        out["note"] = ("the multibody and reduced models of the same machine disagree: at least one is "
                       "outside its validity range (unstable loop at the control period, step too large, "
                       "non-physical parameters); do not use these trajectories without finding out why")
    return out


def warnings_of(res: dict) -> list:
    """Warning lines for the CLI from a mode's metrics dict (runner.mode_metrics): the backends'
    agreement, the reduced model against MuJoCo's (``model``), the step size (``step``), then the
    run's own ``warnings`` (a limit active over the steady state, a load never engaged ...)."""
    p = res.get("plausibility") or {}
    out = model_warnings(p.get("model"))
    for b, st in (p.get("step") or {}).items():
        if not st.get("step_ok", True):
            out.append(f"{b}: {st['note']} (metrics.json \"plausibility\": {{\"step\": ...}})")
    return _backend_warnings(p) + out + [str(w) for w in res.get("warnings") or []]


def _backend_warnings(p: dict) -> list:
    if not p or p.get("backends_agree", True):
        return []
    mx = p.get("max_rel_diff")
    mx_txt = "not finite" if mx is None or not math.isfinite(mx) else f"{100 * mx:.3g} % of the peak"
    if p.get("expected"):  # the mechanism says why the backends must differ (a cam's follower left it)
        return [f"multibody and reduced crank speeds differ by {mx_txt}, as expected: {p['note']}"]
    return [f"multibody and reduced crank speeds differ by {mx_txt} (tolerance "
            f"{100 * p['tolerance']:g} %): the results are not plausible; metrics.json has "
            f"\"plausibility\": {{\"backends_agree\": false}}"]


# ============================================================================ the reduced model vs MuJoCo, directly
#: angles of one period at which :func:`reduced_vs_mujoco` compares the two models
MODEL_ANGLES = 24
#: largest relative error of the reduced model's J(q), J'(q) and E_p'(q) against MuJoCo's mass
#: matrix and bias forces along the closed chain.  Measured on the built-in mechanisms: ≤ 3e-10
#: (closed forms, generic linkages, the MJCF table), 1.3e-6 / 4.1e-7 for the Hülako & Çakar
#: four-bars, whose joint masses are point masses in the reduced model but bodies with a 1e-9
#: kg·m² inertia in MuJoCo; 1e-5 is 7.7 times that (docs/outputs.md)
MODEL_TOLERANCE = 1e-5


#: the n-input model check's tolerance (relative, the reduced model solved exactly against MuJoCo's)
MODEL_TOLERANCE_N = 1e-6


def reduced_vs_mujoco_n(mech, options=None, n: int = MODEL_ANGLES, seed: int = 0) -> dict:
    """The n-input reduced model (solved exactly, no table) against MuJoCo's own dynamics of the
    machine's MJCF at ``n`` points of the input ranges with random input rates (rng ``seed``): at
    each, Γ = ∂qpos/∂q (n columns, from the mechanism's kinematics; constraint forces do no work
    along it) and its rate Γ̇q̇ (central differences of Γq̇ along q̇), then

    * M̄_mj = Γᵀ·M·Γ (``mj_fullM``);
    * the bias b_mj = Γᵀ·(qfrc_bias − qfrc_passive + M·Γ̇q̇) — the velocity terms, gravity, springs
      and dampers — against c̄(q, q̇) + ḡ(q) + D̄(q)·q̇;
    * the inverse dynamics along a random q̈: Γᵀ·``mj_inverse``(q, Γq̇, Γq̈ + Γ̇q̇) with the constraints
      off, against M̄q̈ + c̄ + ḡ + D̄q̇ (what ``analyze`` reports as ``inverse_dynamics_max_rel_diff_vs_mujoco``).

    Errors relative to max|M̄| (M̄), and to max(|b|, max|M̄|·1 rad/s²) (bias, inverse dynamics)."""
    import mujoco

    mech = mech.mechanism_alone()  # (the mechanism's own model: no motor hinges, no friction)
    nin = int(mech.n_inputs)
    out = {"n_points": int(n), "tolerance": MODEL_TOLERANCE_N,
           "method": "M̄ = Γᵀ M Γ (mj_fullM); bias Γᵀ(qfrc_bias − qfrc_passive + M Γ̇q̇); inverse dynamics "
                     "Γᵀ·mj_inverse with the constraints off; Γ = ∂qpos/∂q from the mechanism's kinematics"}
    model = mech.build_spec(tuple([0.0] * nin), dict(options or {})).compile()
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    lo = np.array([r[0] for r in mech.c.ranges()])
    hi = np.array([r[1] for r in mech.c.ranges()])
    per = np.array([r[2] for r in mech.c.ranges()])
    span = np.where(per, hi - lo, hi - lo)
    Q = lo + (0.05 + 0.9 * rng.random((n, nin))) * span
    Qd = rng.normal(size=(n, nin))
    Qdd = rng.normal(size=(n, nin)) * 10.0
    nv = model.nv
    M = np.zeros((nv, nv))

    def gamma(q):
        return np.stack([mech.initial_qvel(model, q, np.eye(nin)[k]) for k in range(nin)], axis=1)

    Mr = mech.reduced_n(Q)[0]
    bias_r = mech.bias_n(Q, Qd)
    tau_r = np.einsum("bij,bj->bi", Mr, Qdd) + bias_r
    Mm, bm, tm, pos = np.empty_like(Mr), np.empty_like(bias_r), np.empty_like(tau_r), 0.0
    eps = 1e-6
    for k in range(n):
        q, qd = Q[k], Qd[k]
        Gm = gamma(q)
        Gd = (gamma(q + eps * qd) @ qd - gamma(q - eps * qd) @ qd) / (2 * eps)
        data.qpos[:] = mech.rigid_qpos(model, q)
        data.qvel[:] = Gm @ qd
        mujoco.mj_forward(model, data)
        mujoco.mj_fullM(model, data, M)
        ne = int(data.ne)
        pos = max(pos, float(np.max(np.abs(data.efc_pos[:ne]))) if ne else 0.0)
        Mm[k] = Gm.T @ M @ Gm
        bm[k] = Gm.T @ (data.qfrc_bias - data.qfrc_passive + M @ Gd)
        old = model.opt.disableflags
        model.opt.disableflags = old | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
        data.qacc[:] = Gm @ Qdd[k] + Gd
        mujoco.mj_inverse(model, data)
        tm[k] = Gm.T @ data.qfrc_inverse
        model.opt.disableflags = old
    ms = float(np.max(np.abs(Mm)))
    bs = max(float(np.max(np.abs(bm))), ms)
    ts = max(float(np.max(np.abs(tm))), ms)
    err = {"M_rel_err": float(np.max(np.abs(Mr - Mm)) / ms), "bias_rel_err": float(np.max(np.abs(bias_r - bm)) / bs),
           "inverse_dynamics_rel_err": float(np.max(np.abs(tau_r - tm)) / ts)}
    out.update(applicable=True, **err, closure_position_m=pos, closure_velocity_rel=0.0,
               M_range=[float(np.min(Mm)), float(np.max(Mm))])
    bad = [k for k, v in err.items() if not (np.isfinite(v) and v <= MODEL_TOLERANCE_N)]
    out["models_agree"] = not bad
    if bad:
        out["note"] = ("the n-input reduced model and MuJoCo's differ: " +
                       ", ".join(f"{k} = {err[k]:.3g}" for k in bad) + f" (tolerance {MODEL_TOLERANCE_N:g})")
    return out


def reduced_vs_mujoco(mech, options=None, n: int = MODEL_ANGLES) -> dict:
    """Compare the reduced (Eksergian) model of ``mech`` with MuJoCo's own dynamics of its MJCF
    model at ``n`` input angles over one period — cheap (a few ms) and independent of any
    controller or trajectory, so a controller cannot hide a wrong J(q) (issue 26, item 8).

    At each angle q the chain is assembled, rigid (``rigid_qpos``) and Γ = ∂qpos/∂q the velocity of every
    joint per unit input speed (``initial_qvel`` at q̇ = 1).  Projected on Γ (constraint forces do no
    work along it), MuJoCo's M·q̈ + bias = forces gives

    * J_mj(q) = Γᵀ·M·Γ  (``mj_fullM``, armature of the input joint 0);
    * E_p'_mj(q) = Γᵀ·(qfrc_bias − qfrc_spring) at zero velocity (gravity and springs);
    * J'_mj(q): 4th-order central difference of J_mj over ±δ, ±2δ (δ = 1e-3 rad).

    Errors: max |J − J_mj| / max|J_mj|; max |J' − J'_mj| / max|J_mj| (per radian); max |E_p' −
    E_p'_mj| / max(max|E_p'_mj|, max|J_mj|·1 rad/s²) (a torque scale that stays finite without
    gravity).  Also the assembled pose's loop-closure residual (MuJoCo's efc_pos, m) and Γ's
    violation of the velocity constraints |efc_J·Γ| (relative to |efc_J|·|Γ|), which check the
    mechanism's kinematics against the model's constraints.  Mechanisms with internal (elastic)
    coordinates are not compared (their reduced model is not a J(q))."""
    import mujoco

    if mech.n_inputs > 1:  # several inputs: the n×n model's check
        return reduced_vs_mujoco_n(mech, options, n)
    out = {"n_angles": int(n), "tolerance": MODEL_TOLERANCE,
           "method": "J = Γᵀ M Γ (mj_fullM), E_p' = Γᵀ(qfrc_bias − qfrc_spring) at zero speed, J' by 4th-order "
                     "differences; Γ = d qpos / d q from the mechanism's kinematics"}
    if getattr(mech, "internal", ()):
        out.update(applicable=False, note="not compared: the mechanism has internal (elastic) coordinates")
        return out
    model = mech.build_spec(0.0, dict(options or {})).compile()
    grid = _model_angles(mech, n)
    if grid is None:
        out.update(applicable=False, note="not compared: the input is not periodic and its range is unknown")
        return out
    qs, delta = grid
    state = _mujoco_state(mech, model, mujoco.MjData(model))
    rows = []
    for q in qs:
        J, dEp, pos, vel = state(q, True)
        Jp = [state(q + k * delta, False) for k in (-2, -1, 1, 2)]
        dJ = (8.0 * (Jp[2] - Jp[1]) - (Jp[3] - Jp[0])) / (12.0 * delta)
        Jr, dJr, dEpr = (float(v) for v in mech.reduced(float(q)))
        rows.append((q, J, dJ, dEp, Jr, dJr, dEpr, pos, vel))
    q, J, dJ, dEp, Jr, dJr, dEpr, pos, vel = np.array(rows).T
    jscale = float(np.max(np.abs(J)))
    if not jscale > 0:
        out.update(applicable=False, note="not compared: MuJoCo's model has no inertia at the input (J = 0)")
        return out
    tscale = max(float(np.max(np.abs(dEp))), jscale * 1.0)
    err = {"J_rel_err": float(np.max(np.abs(Jr - J)) / jscale),
           "dJ_rel_err": float(np.max(np.abs(dJr - dJ)) / jscale),
           "dEp_rel_err": float(np.max(np.abs(dEpr - dEp)) / tscale)}
    worst = {k: float(q[int(np.argmax(np.abs(d)))]) for k, d in
             (("J_rel_err", Jr - J), ("dJ_rel_err", dJr - dJ), ("dEp_rel_err", dEpr - dEp))}
    out.update(applicable=True, **err, at_q_rad=worst,
               J_range_kg_m2=[float(np.min(J)), float(np.max(J))],
               closure_position_m=float(np.max(pos)), closure_velocity_rel=float(np.max(vel)))
    _verdict(out, err, worst)
    return out


def _model_angles(mech, n):
    """(angles, δ of the J' differences): ``n`` angles over one period, or over the range a slide
    input's reduced model covers (a user MJCF); None when neither is known."""
    period = getattr(mech, "reduced_period", None)
    if period:
        return np.linspace(0.0, float(period), int(n), endpoint=False), 1e-3
    table = getattr(getattr(mech, "_m", None), "table", None)
    if table is None or not hasattr(table, "lo"):
        return None
    lo, hi = float(table.lo), float(table.hi)
    delta = 1e-3 * (hi - lo)
    return np.linspace(lo + 2 * delta, hi - 2 * delta, int(n)), delta


def _mujoco_state(mech, model, data):
    """state(q, velocity): MuJoCo's J = Γᵀ·M·Γ of the chain assembled at q and, with ``velocity``,
    also Γᵀ·(qfrc_bias − qfrc_spring), the closure residual [m] and the relative violation |efc_J·Γ|."""
    import mujoco

    nv = model.nv
    M = np.zeros((nv, nv))

    def state(q, velocity):
        data.qpos[:] = mech.rigid_qpos(model, float(q))
        data.qvel[:] = 0.0
        mech.model_at_pose(model, data)
        mujoco.mj_forward(model, data)
        G = np.asarray(mech.initial_qvel(model, float(q), 1.0), dtype=float)
        mujoco.mj_fullM(model, data, M)
        J = float(G @ M @ G)
        if not velocity:
            return J
        dEp = float(G @ (data.qfrc_bias - data.qfrc_spring))
        ne = int(data.ne)
        pos = float(np.max(np.abs(data.efc_pos[:ne]))) if ne else 0.0
        vel = 0.0
        if ne:
            Jc = np.asarray(data.efc_J).reshape(-1)[:ne * nv].reshape(ne, nv)
            vel = float(np.max(np.abs(Jc @ G)) / max(np.linalg.norm(Jc) * np.linalg.norm(G), 1e-300))
        return J, dEp, pos, vel
    return state


def _verdict(out: dict, err: dict, worst: dict) -> None:
    """``models_agree`` and, when not, the note naming each quantity beyond MODEL_TOLERANCE."""
    bad = [k for k, v in err.items() if not (np.isfinite(v) and v <= MODEL_TOLERANCE)]
    if out["closure_velocity_rel"] > MODEL_TOLERANCE or not np.isfinite(out["closure_velocity_rel"]):
        bad.append("closure_velocity_rel")
    out["models_agree"] = not bad
    if bad:
        what = {"J_rel_err": "J(q)", "dJ_rel_err": "J'(q)", "dEp_rel_err": "E_p'(q)",
                "closure_velocity_rel": "the joint velocities per unit input speed (they break the loop constraints)"}
        out["note"] = ("the reduced model differs from MuJoCo's model of the same mechanism: "
                       + ", ".join(f"{what[k]} by {out[k]:.3g}" + (f" (worst at q = {worst[k]:.4g} rad)" if k in worst else "")
                                   for k in bad)
                       + f" (tolerance {MODEL_TOLERANCE:g}); one of the two models is wrong")


def model_warnings(check: dict) -> list:
    """Warning lines for the CLI from a :func:`reduced_vs_mujoco` result."""
    if not check:
        return []
    if check.get("models_agree", True) is None:  # the comparison itself failed
        return [f"the reduced model could not be compared with MuJoCo's: {check.get('note', '')}"]
    if check.get("models_agree", True):
        return []
    return [f"{check['note']}; metrics.json has \"plausibility\": {{\"model\": {{\"models_agree\": false}}}}"]


# ============================================================================ step size
#: largest input-angle change per co-simulation step before a run is flagged (0.05 rad = 2.9°).
#: Measured (docs/outputs.md): the built-in scenarios turn at most 0.022 rad per step at their
#: default dt (incerti-bezier's motor); the Incerti 2012 open loop at 48 V ends 1.7e-5 rad from a
#: 4× finer run at 0.0085 rad/step and 4.4e-4 rad at 0.041 rad/step (the co-step's error grows with
#: the square of the step); the seven-body linkage of issue 26 ran 0.11 rad/step and ended 8.9e-5
#: rad off
STEP_ANGLE_LIMIT = 0.05


def step_check(traj, dt: float) -> dict:
    """Whether the co-simulation step ``dt`` is fine enough for the motion: the largest input-angle
    change per step, max |q̇|·dt, against :data:`STEP_ANGLE_LIMIT` (the record's peak speed)."""
    import numpy as np

    qd = np.asarray(traj.qd, dtype=float)
    fin = qd[np.isfinite(qd)]
    peak = float(np.max(np.abs(fin))) if fin.size else 0.0
    per_step = peak * float(dt)
    out = {"max_input_step_rad": per_step, "limit_rad": STEP_ANGLE_LIMIT, "dt_s": float(dt),
           "peak_input_speed_rad_s": peak, "step_ok": bool(per_step <= STEP_ANGLE_LIMIT)}
    if not out["step_ok"]:
        out["note"] = (f"the input turns {per_step:.3g} rad ({per_step * 57.2958:.2g}°) per co-simulation step (peak "
                       f"|q̇| = {peak:.4g} rad/s at simulation.dt = {dt:g} s), more than {STEP_ANGLE_LIMIT:g} rad: the "
                       f"step is too coarse for this motion; reduce simulation.dt below {STEP_ANGLE_LIMIT / peak:.2g} s")
    return out
