"""The synthesis re-solved by mjbench's own position solver (``design.json``: ``synthesis.solver_check``).

The ``[mechanism] type = "linkage"`` table built from a synthesis (:mod:`mjbench.design.build`) is
solved by :func:`mjbench.mechanisms.linkage.compiled` (Newton on the loop-closure equations), and
compared with the synthesis's closed-form analysis: the branch over a turn, and each kind's
figures at its precision positions (dead centres, precision points, poses).
"""
from __future__ import annotations

import math

import numpy as np

from . import synthesis as S
from ..mechanisms import linkage as LK

TWO_PI = 2.0 * math.pi


def solver_check(syn, table) -> dict:
    """The synthesised positions re-solved by mjbench's own position solver (Newton on the
    loop-closure equations, mjbench.mechanisms.linkage): residuals at the synthesis's precision
    positions and, over 72 crank angles, the largest distance between the closed-form and the
    solver's joint positions (the branch)."""

    params = LK.LinkageParams.model_validate(table)
    c = LK.compiled(params)
    g = syn.geometry

    def solve(q):
        z, v, _ = c.exact(np.asarray(q, float))
        return z, v, c.world_points(z)

    qg = np.linspace(0.0, TWO_PI, 72, endpoint=False)
    _, _, pts = solve(qg)
    cf = g.solve(qg)
    if isinstance(g, S.SliderCrank):
        keys = (("crank.B", "B"), ("ram.C", "C"))
    else:
        keys = (("crank.B", "B"), ("rocker.C", "C")) + ((("coupler.P", "P"),) if g.P is not None else ())
    out = {"branch_max_position_diff_m": float(max(np.max(np.hypot(pts[k][0] - cf[kk][:, 0], pts[k][1] - cf[kk][:, 1]))
                                                   for k, kk in keys))}
    check = _SOLVER_CHECKS.get(syn.kind)
    if check is not None:
        out.update(check(syn, params, c, solve))
    out["table_info"] = dict(c.table_info)
    out["links"] = list(params.links)
    return out


def _angle_of(pts, a, b):
    """Angle [rad] of the line from point a to point b (world points of the solver)."""
    pa, pb = pts[a], pts[b]
    return np.arctan2(pb[1] - pa[1], pb[0] - pa[0])


def _check_slider_crank(syn, params, c, solve) -> dict:
    """The ram at both dead centres (its position along the stroke), the stroke, the guide's rate there."""
    a, g = syn.achieved, syn.geometry
    q = np.array([a["q_extended_rad"], a["q_folded_rad"]])
    z, v, p = solve(q)
    u = (p["ram.C"][0] - g.O[0]) * g.w[0] + (p["ram.C"][1] - g.O[1]) * g.w[1]
    kg = [j.name for j in params.joints].index("guide")
    rate = c.joint_rates(z, v)[:, kg]
    out = dict(u_solver_m=u.tolist(), u_synthesis_m=[a["u_extended_m"], a["u_folded_m"]],
               position_residual_m=float(np.max(np.abs(u - [a["u_extended_m"], a["u_folded_m"]]))),
               stroke_solver_m=float(u[0] - u[1]), stroke_residual_m=float(abs(u[0] - u[1] - a["stroke_m"])),
               dead_centre_rate_m_per_rad=float(np.max(np.abs(rate))))
    out["residual"] = max(out["position_residual_m"], out["dead_centre_rate_m_per_rad"])
    return out


def _check_crank_rocker(syn, params, c, solve) -> dict:
    """The rocker's angles at both dead centres, its swing, the rocker pivot's rate there."""
    a = syn.achieved
    q = np.array([a["q_extended_rad"], a["q_folded_rad"]])
    z, v, p = solve(q)
    psi = _angle_of(p, "rocker.D", "rocker.C")
    kd = [j.name for j in params.joints].index("D")
    rate = c.joint_rates(z, v)[:, kd]
    out = dict(psi_solver_rad=psi.tolist(), psi_synthesis_rad=[a["psi_extended_rad"], a["psi_folded_rad"]],
               angle_residual_rad=float(np.max(np.abs(S.wrap(psi - [a["psi_extended_rad"], a["psi_folded_rad"]])))),
               swing_solver_deg=float(np.degrees(abs(S.wrap(psi[1] - psi[0])))),
               dead_centre_rate=float(np.max(np.abs(rate))))
    out["residual"] = max(out["angle_residual_rad"], out["dead_centre_rate"])
    return out


def _check_function_generator(syn, params, c, solve) -> dict:
    """The output angles at the precision points and the structural error over 201 points."""
    a, g = syn.achieved, syn.geometry
    ph = np.asarray(syn.info["phi_points"])
    ps = np.asarray(syn.info["psi_points"])
    z, v, p = solve(ph + g.crank_offset)
    psi = _angle_of(p, "rocker.D", "rocker.C") - g.rocker_offset
    out = dict(psi_solver_rad=psi.tolist(), psi_target_rad=ps.tolist(),
               angle_residual_rad=float(np.max(np.abs(S.wrap(psi - ps)))))
    spec = syn.info["spec"]
    x = np.linspace(spec.x0, spec.x1, 201)
    _, _, pp = solve(spec.phi(x, math.radians(a["phi0_deg"])) + g.crank_offset)
    err = S.wrap(_angle_of(pp, "rocker.D", "rocker.C") - g.rocker_offset - spec.psi(x, math.radians(a["psi0_deg"])))
    out["structural_error_max_deg_solver"] = float(np.degrees(np.max(np.abs(err))))
    out["residual"] = out["angle_residual_rad"]
    if syn.info.get("method") == "least-squares":
        out["residual"] = 0.0  # no precision points: the structural error is the figure
    return out


def _check_motion_generator(syn, params, c, solve) -> dict:
    """The coupler point and the coupler's angle at the input angles of the poses."""
    a = syn.achieved
    phi = np.asarray(syn.info["input_angles"])
    z, v, p = solve(phi)
    poses = np.asarray(syn.targets["poses"])
    P_ = np.stack([p["coupler.P"][0], p["coupler.P"][1]], axis=-1)
    mA, mB = np.asarray(a["moving_pivot_A"]), np.asarray(a["moving_pivot_B"])
    th = _angle_of(p, "coupler.B", "coupler.C") - math.atan2(*(mB - mA)[::-1])
    out = dict(position_residual_m=float(np.max(np.hypot(*(P_ - poses[:, :2]).T))),
               angle_residual_rad=float(np.max(np.abs(S.wrap(th - poses[:, 2])))))
    out["residual"] = max(out["position_residual_m"], out["angle_residual_rad"])
    return out


#: the solver check of each synthesis kind (its figures at the synthesis's positions)
_SOLVER_CHECKS = {"slider-crank": _check_slider_crank, "crank-rocker": _check_crank_rocker,
                  "function-generator": _check_function_generator, "motion-generator": _check_motion_generator}
