"""``mjbench analyze`` on a machine with several motors: inverse dynamics along the path, the
workspace, both kinds of singularity of a parallel mechanism and the Jacobian's conditioning
(docs/linkages.md §8.6).  No simulation.

**Inverse dynamics along the prescribed motion.**  The scenario's ``[path]`` gives, through the
inverse kinematics (:func:`mjbench.taskpath.joint_trajectories`, the stated pose's branch), the
inputs q(t), q̇(t), q̈(t) over one cycle.  The reduced model, solved exactly at every sample (no
table), gives each input's joint torque

    τ = M̄(q)·q̈ + c̄(q, q̇) + ḡ(q) + D̄(q)·q̇

and with the drive of each axis k (Eq 9 of Incerti 2012 per axis; J_eq the reflected inertia,
c = z²λ the reflected viscous friction, both carried by the input joint)

    τ_drive = τ + J_eq·q̈ + c·q̇                   (what the gearbox output must deliver)
    I = τ_drive/(z·k_m) + T_0·sgn(z·q̇)/k_m        V = R·I + L·dI/dt + k_m·z·q̇

dI/dt is the time derivative of the current's smooth part (the Coulomb term's step at a speed
reversal is left out: the real current cannot jump).  RMS and peak per axis over the cycle.

**Checked against MuJoCo.**  At up to :data:`ID_CHECK_POINTS` samples of the path, the machine's
own MJCF model (the drives' J_eq as armature and z²λ as damping on the input joints, as the
multibody backend builds it) is put in the configuration and velocity of the sample (Γ = ∂qpos/∂q
from the mechanism's kinematics, qvel = Γq̇) and ``mj_inverse`` with the constraints off gives the
joint forces for qacc = Γq̈ + Γ̇q̇ (Γ̇q̇ by central differences of Γq̇ along q̇); Γᵀ·qfrc_inverse
are the input torques (the loop constraints do no work along Γ).  ``inverse_dynamics_max_rel_diff_vs_mujoco``
= max |τ_drive − Γᵀ·qfrc_inverse| / max |Γᵀ·qfrc_inverse|, required ≤ :data:`ID_TOLERANCE`.

**Workspace and singularities** (two inputs and a point: ``path.point``, else ``mechanism.trace``).
The inputs are gridded over a full turn each (``grid`` nodes per input), and the assembly of the
stated pose is followed from node to node (a wavefront over the grid: predictor z + VΔq + ½w,
Newton corrector, a node accepted only when the corrector stays close to the prediction and the
sign of det Φ_z — the assembly mode — is the stated pose's).  At every node reached:

* the point's Jacobian J_x = ∂x/∂q (2×2, m/rad), its determinant and condition number
  κ = σ_max/σ_min.  det J_x = 0 is the *inverse-kinematic* (serial, type-1) singularity: the point
  cannot move in some direction whatever the inputs do (a leg stretched or folded);
* the driven constraint Jacobian Φ_z (joints and driving rows, scaled) and σ_min/σ_max of it:
  → 0 at the *direct* (parallel, type-2) singularity, where the inputs no longer fix the linkage;
  the assembly mode cannot be followed through it, so it bounds the region reached.

The **workspace** is where the point goes with the branch kept over the input ranges
(``input_ranges``; without them, every input's full turn): the nodes inside the ranges.  Numbers
(``analysis.json``): its extent and swept area (∫|det J_x| dq over the ranges: a region the point
reaches in two configurations counts twice, as the 2R arm's elbow up and down), whether each singularity
locus meets it, κ over it, and the same measures along the path (exact, at every sample).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from . import plotstyle as ps
from .backends.multibody import build_model
from .errors import ParameterError
from .machine import Machine
from .mechanisms.linkage.topology import GROUND
from .outputs import write_json
from .plots import save
from .taskpath import joint_trajectories

#: largest relative difference of the inverse dynamics from MuJoCo's mj_inverse (issue 32 item 7)
ID_TOLERANCE = 1e-6
#: samples of the path at which the inverse dynamics is checked against mj_inverse
ID_CHECK_POINTS = 160
#: nodes per input of the workspace grid (a full turn: 2° apart)
GRID = 181
#: σ_min/σ_max of the scaled driven constraint Jacobian below which a node counts as singular
SINGULAR_TOL = 1e-6


# ============================================================================ inverse dynamics
def _drive_constants(d) -> dict:
    """The constants of one axis's drive (SI); ``electric`` False for an ideal torque/speed source
    (and for no drive at all: a mechanism analysed alone, its joint torques only)."""
    if d is None:
        return {"type": "none", "J_eq": 0.0, "c": 0.0, "z": 1.0, "electric": False}
    kind = str(getattr(d, "type_name", "dcmotor") or "dcmotor")
    out = {"type": kind, "J_eq": float(d.J_eq), "c": float(d.crank_damping), "z": float(getattr(d, "z", 1.0)),
           "electric": kind == "dcmotor"}
    if out["electric"]:
        out.update(k_m=float(d.k_m), R=float(d.R), L=float(d.L), T_0=float(d.T_0), v_max=float(d.v_max),
                   i_max=float(d.i_max))
    return out


def _stats(x, t) -> dict:
    x = np.asarray(x, float)
    k = int(np.argmax(np.abs(x)))
    return {"rms": float(np.sqrt(np.mean(x * x))), "peak": float(abs(x[k])), "at_t_s": float(t[k]),
            "min": float(np.min(x)), "max": float(np.max(x))}


def inverse_dynamics(mech, drives, labels, path) -> tuple[dict, dict]:
    """Per axis along one cycle of ``path``: the joint torque, the drive torque, and a DC motor's
    current and voltage (module docstring).  Returns (rows, curves)."""
    t, Q, Qd, Qdd, tp = joint_trajectories(mech, path)
    M, G, g, D = mech.reduced_n(Q)
    from_model = mech.bias_n(Q, Qd)
    inertial = np.einsum("bij,bj->bi", M, Qdd)
    tau = inertial + from_model
    visc = np.einsum("bij,bj->bi", D, Qd)
    vel = from_model - g - visc
    periodic = bool(path.repeat)
    curves = {"t": t}
    rows = {}
    for k, (lab, d) in enumerate(zip(labels, drives)):
        dc = _drive_constants(d)
        td = tau[:, k] + dc["J_eq"] * Qdd[:, k] + dc["c"] * Qd[:, k]
        row = {"drive": dc["type"], "joint_torque_Nm": _stats(tau[:, k], t), "drive_torque_Nm": _stats(td, t),
               "parts_absmax_Nm": {"inertial": float(np.max(np.abs(inertial[:, k]))),
                                   "velocity": float(np.max(np.abs(vel[:, k]))),
                                   "gravity_springs": float(np.max(np.abs(g[:, k]))),
                                   "joint_friction": float(np.max(np.abs(visc[:, k]))),
                                   "drive_inertia": float(np.max(np.abs(dc["J_eq"] * Qdd[:, k]))),
                                   "drive_viscous": float(np.max(np.abs(dc["c"] * Qd[:, k])))},
               "input_speed_rad_s": _stats(Qd[:, k], t), "input_accel_rad_s2": _stats(Qdd[:, k], t)}
        curves.update({f"q:{lab}": Q[:, k], f"qd:{lab}": Qd[:, k], f"qdd:{lab}": Qdd[:, k], f"tau:{lab}": tau[:, k],
                       f"tau_drive:{lab}": td})
        if dc["electric"]:
            z, km = dc["z"], dc["k_m"]
            w = z * Qd[:, k]
            Is = td / (z * km)
            I = Is + dc["T_0"] * np.sign(w) / km
            dIdt = _time_derivative(Is, t, periodic)
            V = dc["R"] * I + dc["L"] * dIdt + km * w
            row.update(motor_torque_Nm=_stats(km * I, t), current_A=_stats(I, t), voltage_V=_stats(V, t),
                       motor_speed_rad_s=_stats(w, t),
                       mean_power_W=float(np.mean(V * I)),
                       limits={"v_max": dc["v_max"] if math.isfinite(dc["v_max"]) else None,
                               "i_max": dc["i_max"] if math.isfinite(dc["i_max"]) else None})
            curves.update({f"I:{lab}": I, f"V:{lab}": V})
        rows[lab] = row
    info = {"point": path.point, "cycle_s": float(tp.duration), "samples": int(len(t)),
            "sample_dt_s": float(t[1] - t[0]) if len(t) > 1 else 0.0, "repeat": periodic,
            "model": "exact (position solve at every sample, no table)",
            "method": "τ = M̄q̈ + c̄ + ḡ + D̄q̇ (reduced model); τ_drive = τ + J_eq·q̈ + z²λ·q̇; "
                      "I = τ_drive/(z·k_m) + T_0·sgn(zq̇)/k_m; V = R·I + L·dI/dt + k_m·z·q̇",
            "axes": rows}
    return info, {"curves": curves, "Q": Q, "Qd": Qd, "Qdd": Qdd, "xy": tp.at(t)[0], "tau_drive": np.stack(
        [curves[f"tau_drive:{lab}"] for lab in labels], axis=1)}


def _time_derivative(x, t, periodic):
    if len(t) < 3:
        return np.zeros_like(x)
    h = float(t[1] - t[0])
    if periodic:  # one cycle with both ends the same instant: differences across the seam
        y = x[:-1]
        d = (np.roll(y, -1) - np.roll(y, 1)) / (2.0 * h)
        return np.append(d, d[0])
    return np.gradient(x, h)


def joint_states_n(mech, model, Z):
    """(qpos (B, nq), Γ = ∂qvel/∂q̇ (B, nv, n)) of the MJCF model at configurations Z (B, 3·nbody):
    what ``initial_qpos`` / ``initial_qvel`` give, for a batch (tree joints from the body
    coordinates; their rates from the velocity coefficients V = ∂z/∂q)."""
    c = mech.c
    Z = np.atleast_2d(Z)
    n = int(mech.n_inputs)
    V = c.sys.vmatrix(Z)
    _, th = c.frames(Z)
    JR = np.stack([c.joint_rates(Z, V[:, :, k]) for k in range(n)], axis=-1)
    sl = c.slide_positions(Z)
    qpos = np.tile(np.asarray(model.qpos0, float), (len(Z), 1))
    G = np.zeros((len(Z), model.nv, n))
    for e in c.edges:
        jn = model.joint(e.name)
        a, d = int(jn.qposadr[0]), int(jn.dofadr[0])
        if e.kind == "R":
            qpos[:, a] = th[:, c.index[e.child]] - (th[:, c.index[e.parent]] if e.parent != GROUND else 0.0)
            G[:, d] = JR[:, e.k] if e.line_first else -JR[:, e.k]
        else:
            qpos[:, a] = sl[:, e.k]
            G[:, d] = JR[:, e.k]
    return qpos, G


def inverse_dynamics_vs_mujoco(mech, drives, options, Q, Qd, Qdd, tau_drive, n=ID_CHECK_POINTS) -> dict:
    """The drive torques of the reduced model against Γᵀ·mj_inverse of the machine's MJCF model
    at ``n`` samples (module docstring)."""
    import mujoco

    idx = np.unique(np.linspace(0, len(Q) - 1, min(int(n), len(Q))).round().astype(int))
    # (a compliant gear is taken rigid: along a prescribed motion the drive delivers τ + J_eq·q̈ + z²λ·q̇)
    _, model = build_model(Machine(mech, list(drives), None), options, rigid_gears=True)
    data = mujoco.MjData(model)
    eps = 1e-6
    q, qd, qdd = Q[idx], Qd[idx], Qdd[idx]
    B = len(idx)
    Zall = mech.c.exact_z(np.concatenate([q, q + eps * qd, q - eps * qd]))
    qpos, G = joint_states_n(mech, model, Zall)
    Gm, Gp, Gn = G[:B], G[B:2 * B], G[2 * B:]
    Gd = np.einsum("bvk,bk->bv", Gp - Gn, qd) / (2 * eps)
    tm = np.empty((B, int(mech.n_inputs)))
    old = model.opt.disableflags
    model.opt.disableflags = old | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    try:
        for m in range(B):
            data.qpos[:] = qpos[m]
            data.qvel[:] = Gm[m] @ qd[m]
            data.qacc[:] = Gm[m] @ qdd[m] + Gd[m]
            mujoco.mj_inverse(model, data)
            tm[m] = Gm[m].T @ data.qfrc_inverse
    finally:
        model.opt.disableflags = old
    tr = tau_drive[idx]
    scale = max(float(np.max(np.abs(tm))), 1e-300)
    err = np.abs(tr - tm)
    worst = np.unravel_index(int(np.argmax(err)), err.shape)
    rel = float(np.max(err) / scale)
    return {"_samples": idx, "_torques": tm, "n_points": int(len(idx)), "max_rel_diff": rel,
            "max_abs_diff_Nm": float(np.max(err)),
            "worst_sample": int(idx[worst[0]]), "worst_axis": int(worst[1]), "tolerance": ID_TOLERANCE,
            "agree": bool(math.isfinite(rel) and rel <= ID_TOLERANCE),
            "method": "Γᵀ·mj_inverse(q, Γq̇, Γq̈ + Γ̇q̇) with the constraints off, on the machine's MJCF (drive "
                      "inertia as armature, z²λ as damping); Γ = ∂qpos/∂q from the mechanism's kinematics, Γ̇q̇ by "
                      "central differences; relative to the largest |Γᵀ·qfrc_inverse|"}


# ============================================================================ workspace, singularities
def _point_jacobian(sysm, z, V, b, sp):
    """J_x = ∂x/∂q (B, 2, n) of the point (body b, local point sp) from V = ∂z/∂q (B, 3nb, n)."""
    return np.stack([sysm.point_vel(z, V[:, :, i], b, sp) for i in range(V.shape[-1])], axis=-1)


def _scaled_jac(sysm, z):
    return sysm.jac(z) * sysm.row_scale[None, :, None] / sysm.col_scale[None, None, :]


def _parallel_measure(sysm, z):
    """(σ_min/σ_max, sign of det) of the scaled driven constraint Jacobian Φ_z, per configuration."""
    Jm = _scaled_jac(sysm, z)
    sv = np.linalg.svd(Jm, compute_uv=False)
    sign, _ = np.linalg.slogdet(Jm)
    return sv[:, -1] / sv[:, 0], sign


def _kappa(Jx):
    sv = np.linalg.svd(Jx, compute_uv=False)
    with np.errstate(divide="ignore"):
        return np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)


def workspace_grid(mech, point: str, grid: int = GRID) -> dict:
    """Every input over a full turn (``grid`` nodes each), the stated pose's assembly followed over
    the grid (module docstring).  Returns arrays on the grid (NaN where not reached)."""
    c = mech.c
    sysm = c.sys
    n = int(mech.n_inputs)
    if n != 2:
        raise ParameterError(f"workspace: a map over the inputs needs 2 inputs; {mech.name!r} has {n}")
    b, sp = mech.point_ref(point)
    N = int(grid)
    ranges = c.ranges()
    centre = [0.5 * (lo + hi) if not per else float(c.q_ref[k]) for k, (lo, hi, per) in enumerate(ranges)]
    step = 2.0 * math.pi / N
    axes = [cen - math.pi + step * np.arange(N) for cen in centre]
    shape = (N, N)
    nz = sysm.nz
    Z = np.full(shape + (nz,), np.nan)
    Qn = np.full(shape + (2,), np.nan)  # the inputs each node was solved at (continuous, unwrapped)
    done = np.zeros(shape, bool)
    # the start: the node nearest the stated pose, reached by continuation from it
    i0 = [int(np.argmin(np.abs(((ax - q + math.pi) % (2 * math.pi)) - math.pi))) for ax, q in zip(axes, c.q_ref)]
    q_start = np.array([axes[0][i0[0]], axes[1][i0[1]]])
    q_start = c.q_ref + (((q_start - c.q_ref) + math.pi) % (2 * math.pi) - math.pi)
    z0 = sysm.move(c.z_ref, c.q_ref, q_start)
    sign0 = _parallel_measure(sysm, z0[None])[1][0]
    Z[tuple(i0)], Qn[tuple(i0)], done[tuple(i0)] = z0, q_start, True
    front = [tuple(i0)]
    moves = ((1, 0), (-1, 0), (0, 1), (0, -1))
    while front:
        cand = {}
        for (i, j) in front:
            for di, dj in moves:
                a, bb = (i + di) % N, (j + dj) % N
                if not done[a, bb] and (a, bb) not in cand:
                    cand[(a, bb)] = (i, j, di, dj)
        if not cand:
            break
        keys = list(cand)
        par = np.array([cand[k][:2] for k in keys])
        dq = np.array([[cand[k][2] * step, cand[k][3] * step] for k in keys])
        Zp = Z[par[:, 0], par[:, 1]]
        Qp = Qn[par[:, 0], par[:, 1]]
        with np.errstate(all="ignore"):
            Zn, ok, corr, size = sysm.predict_correct(Zp, Qp, dq)
            sign = np.linalg.slogdet(_scaled_jac(sysm, np.where(np.isfinite(Zn), Zn, 0.0)))[0]
        good = ok & (corr <= 0.1 * size + 1e-9) & (sign == sign0)
        front = []
        for m in np.flatnonzero(good):
            a, bb = keys[m]
            Z[a, bb], Qn[a, bb], done[a, bb] = Zn[m], Qp[m] + dq[m], True
            front.append((a, bb))
    flat = Z.reshape(-1, nz)
    sel = done.reshape(-1)
    X = np.full((N * N, 2), np.nan)
    detJ = np.full(N * N, np.nan)
    kappa = np.full(N * N, np.nan)
    par = np.full(N * N, np.nan)
    if sel.any():
        zs = flat[sel]
        V = sysm.vmatrix(zs)
        Jx = _point_jacobian(sysm, zs, V, b, sp)
        X[sel] = sysm.point(zs, b, sp)
        detJ[sel] = np.linalg.det(Jx)
        kappa[sel] = _kappa(Jx)
        par[sel] = _parallel_measure(sysm, zs)[0]
        # a node on the assembly but (numerically) at a direct singularity is not a usable pose
        bad = np.flatnonzero(sel)[par[sel] <= SINGULAR_TOL]
        done.reshape(-1)[bad] = False
        X[bad], detJ[bad], kappa[bad] = np.nan, np.nan, np.nan
    inside = np.ones(shape, bool)
    for k, (lo, hi, per) in enumerate(ranges):
        if not per:
            ax = np.broadcast_to(axes[k][:, None] if k == 0 else axes[k][None, :], shape)
            inside &= (ax >= lo - 1e-12) & (ax <= hi + 1e-12)
    return {"axes": axes, "reached": done, "X": X.reshape(shape + (2,)), "detJ": detJ.reshape(shape),
            "kappa": kappa.reshape(shape), "parallel": par.reshape(shape), "inside": inside, "step": step,
            "point": point, "ranges": ranges}


def _sign_change_nodes(f, reached, periodic=(True, True)):
    """Nodes where f changes sign towards a reached neighbour (a locus f = 0 passes between them)."""
    s = np.sign(f)
    out = np.zeros(f.shape, bool)
    for ax in (0, 1):
        for sh in (1, -1):
            g = np.roll(s, sh, axis=ax)
            r = np.roll(reached, sh, axis=ax)
            out |= reached & r & (s * g < 0)
    return out


def _boundary_nodes(reached):
    out = np.zeros(reached.shape, bool)
    for ax in (0, 1):
        for sh in (1, -1):
            out |= reached & ~np.roll(reached, sh, axis=ax)
    return out


def workspace_numbers(mech, W: dict, path_measures: dict | None) -> dict:
    """The workspace, singularity and conditioning rows of analysis.json from :func:`workspace_grid`."""
    reached, inside = W["reached"], W["inside"]
    box = inside & reached
    X, detJ, kap, par = W["X"], W["detJ"], W["kappa"], W["parallel"]
    type1 = _sign_change_nodes(detJ, reached)
    edge = _boundary_nodes(reached)
    h = W["step"]
    ws = {"point": W["point"], "grid_nodes_per_input": int(len(W["axes"][0])), "grid_step_deg": math.degrees(h),
          "input_ranges_rad": [[float(lo), float(hi)] if not per else None for lo, hi, per in W["ranges"]],
          "nodes_in_ranges": int(inside.sum()), "reached_in_ranges": int(box.sum()),
          "reached_fraction_in_ranges": float(box.sum() / max(int(inside.sum()), 1)),
          "reached_over_full_turns": int(reached.sum())}
    if box.any():
        xs, ys = X[..., 0][box], X[..., 1][box]
        # ∫|det J_x| dq over the ranges: the nodes' mean |det J_x| times the ranges' area in the inputs
        span = math.prod((hi - lo) if not per else 2 * math.pi for lo, hi, per in W["ranges"])
        ws.update(x_range_m=[float(xs.min()), float(xs.max())], y_range_m=[float(ys.min()), float(ys.max())],
                  swept_area_m2=float(np.mean(np.abs(detJ[box])) * span))
    t1_in = bool((type1 & inside).any())
    edge_in = bool(box.sum() < inside.sum())
    sing = {
        "inverse_kinematic": {
            "what": "det J_x = 0 (J_x = ∂x/∂q of the point, 2×2): the point cannot move in some direction "
                    "(type 1, a leg stretched or folded)",
            "locus_nodes_over_full_turns": int(type1.sum()), "meets_workspace": t1_in,
            "min_abs_det_in_ranges_m2": float(np.nanmin(np.abs(detJ[box]))) if box.any() else None},
        "direct": {
            "what": "the driven constraint Jacobian Φ_z singular (σ_min/σ_max → 0): the inputs do not fix the "
                    "linkage (type 2); the assembly mode cannot be followed through it, so it bounds the region "
                    "reached from the stated pose",
            "boundary_nodes_over_full_turns": int(edge.sum()), "meets_workspace": edge_in,
            "min_sigma_ratio_in_ranges": float(np.nanmin(par[box])) if box.any() else None,
            "threshold": SINGULAR_TOL}}
    cond = {"what": "κ = σ_max/σ_min of J_x (2×2, m/rad both ways): 1 isotropic, → ∞ at an inverse-kinematic "
                    "singularity"}
    if box.any():
        kk = kap[box]
        cond.update(min=float(np.min(kk)), median=float(np.median(kk)), max=float(np.max(kk)),
                    fraction_below_10=float(np.mean(kk < 10.0)))
    if path_measures:
        ws["path_inside_workspace"] = path_measures.pop("inside", None)
        cond["along_path"] = {k: path_measures[k] for k in ("kappa_max", "kappa_max_at_t_s", "kappa_min")}
        sing["inverse_kinematic"]["along_path_min_abs_det_m2"] = path_measures["det_min_abs"]
        sing["direct"]["along_path_min_sigma_ratio"] = path_measures["parallel_min"]
    return {"workspace": ws, "singularities": sing, "conditioning": cond}


def path_measures(mech, point, t, Q) -> dict:
    """κ, det J_x and the parallel measure exactly at every path sample."""
    sysm = mech.c.sys
    b, sp = mech.point_ref(point)
    z, V = mech.jacobian_inputs(Q)
    Jx = _point_jacobian(sysm, z, V, b, sp)
    kap = _kappa(Jx)
    det = np.linalg.det(Jx)
    par = _parallel_measure(sysm, z)[0]
    k = int(np.argmax(kap))
    inside = True
    for j, (lo, hi, per) in enumerate(mech.c.ranges()):
        if not per:
            inside &= bool(np.all((Q[:, j] >= lo - 1e-12) & (Q[:, j] <= hi + 1e-12)))
    return {"kappa_max": float(kap[k]), "kappa_max_at_t_s": float(t[k]), "kappa_min": float(np.min(kap)),
            "det_min_abs": float(np.min(np.abs(det))), "parallel_min": float(np.min(par)), "inside": inside,
            "kappa": kap}


# ============================================================================ the analysis
def analyze_multi(name, mech, drives, labels, path=None, options=None, grid: int = GRID, check: bool = True,
                  mech_type: str = "linkage", started=None) -> tuple[dict, dict]:
    """The analysis of a machine with several motors (module docstring): (analysis.json data,
    the arrays of the figures)."""
    t_cpu, t_wall = started or (time.process_time(), time.perf_counter())
    res = {"scenario": name, "mechanism": mech_type, "multi_axis": True, "axes": list(labels),
           "reduced_model": getattr(mech, "reduced_source", ""), "applicable": True,
           "table_info": getattr(mech, "table_info", None), "flags": []}
    maps: dict = {"labels": list(labels)}
    why_none = []
    if path is None:
        why_none.append("no [path]: no motion is prescribed, so there is no inverse dynamics to compute")
        res["inverse_dynamics"] = None
    else:
        info, arr = inverse_dynamics(mech, drives, labels, path)
        res["inverse_dynamics"] = info
        res["curves"] = {k: np.asarray(v, float).tolist() for k, v in arr["curves"].items()}
        maps["path"] = arr
        if check:
            chk = inverse_dynamics_vs_mujoco(mech, drives, options, arr["Q"], arr["Qd"], arr["Qdd"], arr["tau_drive"])
            maps["check"] = {"samples": chk.pop("_samples"), "torques": chk.pop("_torques"), **chk}
            info["checked_against_mujoco"] = chk
            res["inverse_dynamics_max_rel_diff_vs_mujoco"] = chk["max_rel_diff"]
        _flags(res)
    point = path.point if path is not None else getattr(mech.params, "trace", None)
    if mech.n_inputs != 2 or point is None:
        why = (f"the workspace map needs 2 inputs ({mech.n_inputs} here)" if mech.n_inputs != 2 else
               "no point to map: give [path] point or mechanism.trace")
        res["workspace"] = res["singularities"] = res["conditioning"] = None
        res["workspace_unavailable"] = why
    else:
        W = workspace_grid(mech, point, grid)
        pm = None
        if path is not None:
            arr = maps["path"]
            pm = path_measures(mech, point, arr["curves"]["t"], arr["Q"])
            maps["path"]["kappa"] = pm.pop("kappa")
        res.update(workspace_numbers(mech, W, pm))
        maps["workspace"] = W
        sg = res["singularities"]
        if sg["inverse_kinematic"]["meets_workspace"]:
            res["flags"].append({"kind": "singularity", "where": "workspace",
                                 "text": "an inverse-kinematic singularity (det J_x = 0) lies inside the input ranges"})
        if sg["direct"]["meets_workspace"]:
            res["flags"].append({"kind": "singularity", "where": "workspace",
                                 "text": "the assembly cannot be followed over the whole input ranges (a direct "
                                         "singularity, or the loops cannot close, inside them)"})
    res["unavailable"] = why_none
    res["timing"] = {"cpu_s": time.process_time() - t_cpu, "wall_s": time.perf_counter() - t_wall}
    return res, maps


def _flags(res):
    for lab, row in res["inverse_dynamics"]["axes"].items():
        lim = row.get("limits") or {}
        if lim.get("v_max") is not None and row["voltage_V"]["peak"] > lim["v_max"]:
            res["flags"].append({"kind": "voltage", "where": lab,
                                 "text": f"axis {lab}: the path needs up to {row['voltage_V']['peak']:.3g} V > v_max = "
                                         f"{lim['v_max']:g} V at t = {row['voltage_V']['at_t_s']:.3g} s"})
        if lim.get("i_max") is not None and row["current_A"]["peak"] > lim["i_max"]:
            res["flags"].append({"kind": "current", "where": lab,
                                 "text": f"axis {lab}: the path needs up to {row['current_A']['peak']:.3g} A > i_max = "
                                         f"{lim['i_max']:g} A"})
    chk = res["inverse_dynamics"].get("checked_against_mujoco")
    if chk and not chk["agree"]:
        res["flags"].append({"kind": "model", "where": "inverse dynamics",
                             "text": f"the reduced model's inverse dynamics differs from MuJoCo's mj_inverse by "
                                     f"{chk['max_rel_diff']:.3g} (tolerance {ID_TOLERANCE:g}): one of the models is wrong"})


# ============================================================================ outputs
def write(res: dict, maps: dict, out_dir) -> list:
    """analysis.json and the figures into ``out_dir``; returns the written paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "analysis.json"]
    write_json(paths[0], res)
    if maps.get("path"):
        paths.append(inverse_dynamics_figure(res, maps, out / "inverse_dynamics.png"))
    if maps.get("workspace"):
        paths += workspace_figures(res, maps, out)
    return paths


def inverse_dynamics_figure(res, maps, path):
    arr = maps["path"]
    c = arr["curves"]
    t = c["t"]
    labels = maps["labels"]
    rows = res["inverse_dynamics"]["axes"]
    electric = [lab for lab in labels if f"I:{lab}" in c]
    n = 2 + (2 if electric else 0)
    fig, ax = ps.new(n, 1, figsize=(8.5, 2.1 * n + 0.6), sharex=True)
    for k, lab in enumerate(labels):
        col = f"C{k}"
        ax[0].plot(t, c[f"tau:{lab}"], color=col, lw=1.0, ls="--", label=f"{lab}: joint τ (mechanism)")
        ax[0].plot(t, c[f"tau_drive:{lab}"], color=col, label=f"{lab}: drive torque (+ J_eq·q̈ + z²λ·q̇)")
        ax[1].plot(t, c[f"qd:{lab}"], color=col, label=f"{lab}")
    chk = maps.get("check")
    if chk is not None:
        idx, tm = chk["samples"], chk["torques"]
        for k in range(len(labels)):
            ax[0].plot(t[idx], tm[:, k], "k.", ms=2.5, label=(f"MuJoCo Γᵀ·mj_inverse at {chk['n_points']} samples "
                                                             f"(max rel. diff {chk['max_rel_diff']:.1e})")
                       if k == 0 else None)
    ax[0].set_ylabel(ps.label("torque at the input", "N·m"))
    ax[0].legend(fontsize=6.5, loc="best", ncol=1)
    ax[1].set_ylabel(ps.label("input speed q̇", "rad/s"))
    ax[1].legend(fontsize=7, loc="upper right")
    if electric:
        for k, lab in enumerate(labels):
            if lab not in electric:
                continue
            r = rows[lab]
            ax[2].plot(t, c[f"I:{lab}"], color=f"C{k}",
                       label=f"{lab}: RMS {r['current_A']['rms']:.3g} A, peak {r['current_A']['peak']:.3g} A")
            ax[3].plot(t, c[f"V:{lab}"], color=f"C{k}",
                       label=f"{lab}: RMS {r['voltage_V']['rms']:.3g} V, peak {r['voltage_V']['peak']:.3g} V")
            vm = (r.get("limits") or {}).get("v_max")
            if vm is not None and k == 0 and vm <= 3.0 * max(r["voltage_V"]["peak"] for r in
                                                             (rows[x] for x in electric)):
                for sgn_ in (1, -1):
                    ax[3].axhline(sgn_ * vm, color="0.4", ls=":", lw=0.8)
        ax[2].set_ylabel(ps.label("motor current I", "A"))
        ax[3].set_ylabel(ps.label("motor voltage V", "V"))
        ax[2].legend(fontsize=7, loc="upper right")
        vms = sorted({(rows[lab].get("limits") or {}).get("v_max") for lab in electric} - {None})
        ax[3].legend(fontsize=7, loc="best", title_fontsize=7,
                     title=("v_max = " + ", ".join(f"{v:g}" for v in vms) + " V") if vms else None)
    ax[-1].set_xlabel(ps.label("time along the path (one cycle)", "s"))
    ps.finish(fig, f"{res['scenario']}: inverse dynamics along the path ({res['inverse_dynamics']['point']}), "
                   f"reduced model")
    return save(fig, path)


def workspace_figures(res, maps, out) -> list:
    """workspace.png (the plane) and singularities.png (the inputs' plane)."""
    from matplotlib.colors import LogNorm

    W = maps["workspace"]
    labels = maps["labels"]
    reached, inside = W["reached"], W["inside"]
    X, kap, detJ = W["X"], W["kappa"], W["detJ"]
    type1 = _sign_change_nodes(detJ, reached)
    edge = _boundary_nodes(reached)
    box = reached & inside
    path = maps.get("path")
    paths = []
    kmax = float(np.nanpercentile(kap[reached], 99)) if reached.any() else 10.0
    norm = LogNorm(vmin=1.0, vmax=max(kmax, 2.0))
    # ---- the plane
    fig, ax = ps.new(1, 1, figsize=(7.5, 6.6))
    allx = X[reached]
    ax.scatter(allx[:, 0], allx[:, 1], s=1.0, c="0.85", lw=0, label="reached over full input turns (branch kept)",
               rasterized=True)
    kb = kap[box]
    wnorm = LogNorm(vmin=1.0, vmax=max(float(np.max(kb)) if kb.size else 2.0, 1.5))
    sc = ax.scatter(X[box][:, 0], X[box][:, 1], c=kb, s=3.0, lw=0, cmap="viridis", norm=wnorm,
                    rasterized=True, label="workspace: the input ranges (colour: κ)")
    if type1.any():
        p1 = X[type1]
        ax.plot(p1[:, 0], p1[:, 1], ".", color="tab:red", ms=2.0, label="inverse-kinematic singularity (det J_x = 0)")
    if edge.any():
        p2 = X[edge]
        ax.plot(p2[:, 0], p2[:, 1], ".", color="k", ms=1.2,
                label="direct singularity / edge of the branch (nodes next to it)")
    if path is not None:
        xy = path["xy"]
        ax.plot(xy[:, 0], xy[:, 1], color="tab:orange", lw=2.0, label="path")
    cb = fig.colorbar(sc, ax=ax)
    cb.set_label("condition number κ of J_x over the workspace")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(ps.label(f"x of {W['point']}", "m"))
    ax.set_ylabel(ps.label(f"y of {W['point']}", "m"))
    ax.legend(fontsize=7, loc="lower left", markerscale=4)
    ps.finish(fig, f"{res['scenario']}: workspace of {W['point']}, conditioning and singularities")
    paths.append(save(fig, out / "workspace.png"))
    # ---- the inputs' plane
    a0, a1 = (np.degrees(a) for a in W["axes"])
    fig, ax = ps.new(1, 1, figsize=(7.5, 6.4))
    K = np.where(reached, kap, np.nan)
    m = ax.pcolormesh(a1, a0, K, cmap="viridis", norm=norm, shading="nearest", rasterized=True)
    cb = fig.colorbar(m, ax=ax)
    cb.set_label("condition number κ of J_x (blank: the branch cannot be reached)")
    with np.errstate(invalid="ignore"):
        D = np.where(reached, detJ, np.nan)
    if np.nanmin(D) < 0 < np.nanmax(D):
        ax.contour(a1, a0, D, levels=[0.0], colors="tab:red", linewidths=1.4)
    ax.contour(a1, a0, reached.astype(float), levels=[0.5], colors="k", linewidths=1.0)
    if np.nanmin(D) < 0 < np.nanmax(D):
        ax.plot([], [], color="tab:red", label="inverse-kinematic singularity (det J_x = 0)")
    if not reached.all():
        ax.plot([], [], color="k", label="direct singularity / edge of the branch")
    for k, (lo, hi, per) in enumerate(W["ranges"]):
        if per:
            continue
        lo_d, hi_d = math.degrees(lo), math.degrees(hi)
        if k == 0:
            ax.axhline(lo_d, color="w", ls="--", lw=0.9)
            ax.axhline(hi_d, color="w", ls="--", lw=0.9)
        else:
            ax.axvline(lo_d, color="w", ls="--", lw=0.9)
            ax.axvline(hi_d, color="w", ls="--", lw=0.9)
    if not all(per for _, _, per in W["ranges"]):
        ax.plot([], [], color="w", ls="--", label="input ranges")
    if path is not None:
        c = path["curves"]
        ax.plot(np.degrees(_wrap_to(c[f"q:{labels[1]}"], W["axes"][1])),
                np.degrees(_wrap_to(c[f"q:{labels[0]}"], W["axes"][0])), color="tab:orange", lw=2.0, label="path")
    ax.set_xlabel(ps.label(f"input {labels[1]}", "°"))
    ax.set_ylabel(ps.label(f"input {labels[0]}", "°"))
    leg = ax.legend(fontsize=7, loc="upper right")
    leg.get_frame().set_facecolor("0.85")
    ps.finish(fig, f"{res['scenario']}: singularity loci over the inputs (assembly of the stated pose)")
    paths.append(save(fig, out / "singularities.png"))
    return paths


def _wrap_to(q, axis):
    lo = float(axis[0])
    return lo + np.mod(np.asarray(q, float) - lo, 2 * math.pi)


def summary_text(res: dict) -> str:
    """Plain-text summary printed by ``mjbench analyze`` (several motors)."""
    what = res["scenario"] if res.get("built_in_code") else f"scenario {res['scenario']}"
    lines = [f"{what} ({res['mechanism']}, {len(res['axes'])} axes: {', '.join(res['axes'])}): "
             f"reduced model {res['reduced_model']}"]
    ti = res.get("table_info") or {}
    if ti.get("model") == "solve":
        lines.append(f"  reduced model solved at every evaluation (Newton on the loop constraints, residual ≤ "
                     f"{ti.get('newton_tol', float('nan')):.0e}; reduced_model = 'solve')")
    elif ti:
        lines.append(f"  reduced-model table {ti.get('nodes')} nodes: error M̄ {ti.get('rel_error_M', float('nan')):.2g}, "
                     f"c̄ {ti.get('rel_error_c', float('nan')):.2g}, ḡ {ti.get('rel_error_g', float('nan')):.2g} (relative)")
    idn = res.get("inverse_dynamics")
    if idn:
        lines.append(f"  inverse dynamics along the path ({idn['point']}, one cycle {idn['cycle_s']:.4g} s, "
                     f"{idn['samples']} samples):")
        for lab, r in idn["axes"].items():
            t, td = r["joint_torque_Nm"], r["drive_torque_Nm"]
            s = (f"    axis {lab}: joint torque RMS {t['rms']:.3g} N·m, peak {t['peak']:.3g} N·m; drive torque RMS "
                 f"{td['rms']:.3g}, peak {td['peak']:.3g} N·m")
            if "current_A" in r:
                s += (f"; current RMS {r['current_A']['rms']:.3g} A, peak {r['current_A']['peak']:.3g} A; voltage RMS "
                      f"{r['voltage_V']['rms']:.3g} V, peak {r['voltage_V']['peak']:.3g} V")
            lines.append(s)
        chk = idn.get("checked_against_mujoco")
        if chk:
            lines.append(f"    against MuJoCo's mj_inverse at {chk['n_points']} samples: max relative difference "
                         f"{chk['max_rel_diff']:.2g} (tolerance {chk['tolerance']:g})")
    for why in res.get("unavailable", []):
        lines.append(f"  no inverse dynamics: {why}")
    ws = res.get("workspace")
    if ws:
        ext = ""
        if "x_range_m" in ws:
            ext = (f": x {ws['x_range_m'][0]:.4g} … {ws['x_range_m'][1]:.4g} m, y {ws['y_range_m'][0]:.4g} … "
                   f"{ws['y_range_m'][1]:.4g} m, swept area {ws['swept_area_m2'] * 1e4:.4g} cm²")
        lines.append(f"  workspace of {ws['point']} over the input ranges{ext} "
                     f"({100 * ws['reached_fraction_in_ranges']:.1f} % of the ranges reached on the branch)")
        sg = res["singularities"]
        lines.append(f"  singularities: inverse-kinematic {'INSIDE' if sg['inverse_kinematic']['meets_workspace'] else 'outside'} "
                     f"the input ranges, direct {'INSIDE' if sg['direct']['meets_workspace'] else 'outside'}"
                     + (f"; along the path min |det J_x| {sg['inverse_kinematic']['along_path_min_abs_det_m2']:.3g} m², "
                        f"min σ ratio {sg['direct']['along_path_min_sigma_ratio']:.3g}"
                        if "along_path_min_abs_det_m2" in sg["inverse_kinematic"] else ""))
        cd = res["conditioning"]
        if "median" in cd:
            s = f"  conditioning κ(J_x) over the workspace: {cd['min']:.3g} … {cd['max']:.3g} (median {cd['median']:.3g})"
            if "along_path" in cd:
                s += f"; along the path ≤ {cd['along_path']['kappa_max']:.3g} (t = {cd['along_path']['kappa_max_at_t_s']:.3g} s)"
            lines.append(s)
    elif res.get("workspace_unavailable"):
        lines.append(f"  no workspace map: {res['workspace_unavailable']}")
    for f in res.get("flags", []):
        lines.append(f"  FLAG {f['kind']}: {f['text']}")
    tm = res["timing"]
    lines.append(f"  analysis took {tm['cpu_s']:.2f} s CPU ({tm['wall_s']:.2f} s wall)")
    return "\n".join(lines)


__all__ = ["analyze_multi", "inverse_dynamics", "inverse_dynamics_vs_mujoco", "workspace_grid", "workspace_numbers",
           "path_measures", "write", "summary_text", "ID_TOLERANCE", "GRID"]
