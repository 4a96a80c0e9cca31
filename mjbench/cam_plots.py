"""The cam designer's figures of ``mjbench analyze`` (a ``type = "cam"`` mechanism, docs/higher_pairs.md §2).

From ``analysis.json["cam"]`` (:meth:`mjbench.mechanisms.cam.Cam.analysis_rows`):

* ``cam_svaj.png`` — the follower's displacement, velocity, acceleration and jerk over one cam turn
  at the first analysed speed (S-V-A-J; the kinematic coefficients y, y', y'', y''' times ω, ω², ω³);
* ``cam_pressure_curvature.png`` — the pressure angle (and the limit), the radius of curvature of
  the pitch curve and of the cam surface (and the roller radius: undercut below it);
* ``cam_contact_force.png`` — the contact force along the cycle at every analysed speed and at the
  predicted jump speed (where it touches zero);
* ``cam_profile.png`` — the cam profile, the pitch curve, the base and prime circles.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import plotstyle as ps
from .plots import save


def figures(res: dict, out: Path) -> list:
    """Write the four cam figures into ``out``; returns their paths."""
    cam = res["cam"]
    c = {k: np.asarray(v, float) for k, v in cam["curves"].items()}
    deg = np.degrees(c["theta"]) % 360.0
    order = np.argsort(deg)
    x = deg[order]
    c = {k: v[order] for k, v in c.items()}
    lin = cam["follower"] == "translating"
    scale, unit = (1000.0, "mm") if lin else (180.0 / math.pi, "°")
    name = res["scenario"]
    paths = []
    speeds = [r for r in cam["speeds"] if not r["is_jump_speed"]]
    w = speeds[0]["cam_speed_rad_s"] if speeds else 1.0
    wj = cam["jump"]["speed_rad_s"]
    with ps.context():
        fig, ax = ps.new(4, 1, figsize=(8, 9), sharex=True)
        vals = [c["y"] * scale, c["y1"] * w * scale, c["y2"] * w * w * scale, c["y3"] * w ** 3 * scale]
        labels = [ps.label("S: displacement", unit), ps.label("V: velocity", f"{unit}/s"),
                  ps.label("A: acceleration", f"{unit}/s²"), ps.label("J: jerk", f"{unit}/s³")]
        for k in range(4):
            ax[k].plot(x, vals[k], color=f"C{k}")
            ax[k].axhline(0.0, color="0.6", lw=0.6)
            ax[k].set_ylabel(labels[k], fontsize=8)
        _segments(ax, cam)
        ax[3].set_xlabel(ps.label("cam angle θ", "°"))
        ax[3].set_xlim(0, 360)
        ps.finish(fig, f"{name}: follower S-V-A-J at {w:.4g} rad/s ({w * 30 / math.pi:.4g} rpm)")
        paths.append(save(fig, out / "cam_svaj.png"))

        fig, ax = ps.new(2, 1, figsize=(8, 7), sharex=True)
        ax[0].plot(x, np.degrees(c["pressure_angle"]), color="C0", label="pressure angle φ")
        chk = cam["checks"]
        lim = chk.get("pressure_angle_limit_deg")
        ax[0].axhline(0.0, color="0.6", lw=0.6)
        pk = chk["max_pressure_angle_deg"]
        ax[0].axhline(pk, color="C3", ls=":", lw=0.9, label=f"|φ| max {pk:.2f}°")
        ax[0].axhline(-pk, color="C3", ls=":", lw=0.9)
        if lim:
            ax[0].axhline(lim, color="k", ls="--", lw=0.8, label=f"limit {lim:g}°")
        ax[0].set_ylabel(ps.label("pressure angle φ", "°"))
        ax[0].legend(loc="upper right", fontsize=7)
        rp, rc = c["rho_pitch"] * 1000, c["rho_cam"] * 1000
        cap = 4.0 * max(float(np.median(np.abs(rp))), 1.0)
        ax[1].plot(x, np.clip(rp, -cap, cap), color="C1", label="pitch curve ρ_p")
        if cam["contact"] == "roller":
            ax[1].plot(x, np.clip(rc, -cap, cap), color="C2", label="cam surface ρ_p − R_r")
            rr = cam["follower_geometry"]["roller_radius_m"] * 1000
            ax[1].axhline(rr, color="k", ls="--", lw=0.8, label=f"roller R_r = {rr:.3g} mm (undercut below, convex)")
        ax[1].axhline(0.0, color="0.6", lw=0.6)
        ax[1].set_ylabel(ps.label("radius of curvature (clipped)", "mm"))
        ax[1].set_xlabel(ps.label("cam angle θ", "°"))
        ax[1].set_xlim(0, 360)
        ax[1].legend(loc="lower right", fontsize=7)
        _segments(ax, cam)
        ps.finish(fig, f"{name}: pressure angle and radius of curvature (> 0 convex)")
        paths.append(save(fig, out / "cam_pressure_curvature.png"))

        fig, ax = ps.new(1, 1, figsize=(8, 4.8))
        ax = np.atleast_1d(ax)[0]
        for i, r in enumerate(cam["speeds"]):
            N = c[r["curve"]]
            if r["is_jump_speed"]:
                ax.plot(x, N, color="C3", lw=1.6, label=f"predicted jump speed {r['cam_speed_rad_s']:.4g} rad/s "
                                                         f"({r['cam_speed_rpm']:.4g} rpm)")
                ax.plot([cam["jump"]["theta_deg"]], [0.0], "o", color="C3", ms=5)
            else:
                ax.plot(x, N, color=f"C{i}", label=f"{r['cam_speed_rad_s']:.4g} rad/s ({r['cam_speed_rpm']:.4g} rpm)")
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_xlabel(ps.label("cam angle θ", "°"))
        ax.set_ylabel(ps.label("contact force N", "N"))
        ax.set_xlim(0, 360)
        ax.legend(loc="upper right", fontsize=7)
        _segments([ax], cam)
        ps.finish(fig, f"{name}: contact force along the cycle at constant speed (below 0: the follower leaves the cam)")
        paths.append(save(fig, out / "cam_contact_force.png"))

        fig, ax = ps.new(1, 1, figsize=(6.5, 6.5))
        ax = np.atleast_1d(ax)[0]
        px, py = np.append(c["profile_x"], c["profile_x"][0]) * 1000, np.append(c["profile_y"], c["profile_y"][0]) * 1000
        ax.fill(px, py, color="C1", alpha=0.35, lw=0)
        ax.plot(px, py, color="C1", lw=1.4, label="cam surface")
        if cam["contact"] == "roller":
            ax.plot(np.append(c["pitch_x"], c["pitch_x"][0]) * 1000, np.append(c["pitch_y"], c["pitch_y"][0]) * 1000,
                    color="C0", ls="--", lw=1.0, label="pitch curve (roller centre)")
        g = cam["follower_geometry"]
        t = np.linspace(0, 2 * np.pi, 200)
        for r, sty, lab in ((g["base_radius_m"], ":", "base circle"), (g["prime_radius_m"], "-.", "prime circle")):
            if lab == "prime circle" and cam["contact"] != "roller":
                continue
            ax.plot(1000 * r * np.cos(t), 1000 * r * np.sin(t), color="0.5", ls=sty, lw=0.8, label=lab)
        ax.plot([0], [0], "k+", ms=8)
        if g["motion"] == "oscillating":
            A = np.asarray(g["pivot_m"]) * 1000
            ax.plot([A[0]], [A[1]], "ks", ms=5, label="follower pivot")
        ax.set_aspect("equal")
        ax.set_xlabel(ps.label("x (cam frame, θ = 0)", "mm"))
        ax.set_ylabel(ps.label("y", "mm"))
        ax.legend(loc="upper right", fontsize=7)
        ps.finish(fig, f"{name}: cam profile (turning counter-clockwise)")
        paths.append(save(fig, out / "cam_profile.png"))
    return paths


def _segments(axes, cam):
    """Faint vertical lines at the program's segment boundaries."""
    for r in cam["program"]:
        for a in np.atleast_1d(axes):
            a.axvline(r["start_deg"] % 360.0, color="0.85", lw=0.7, zorder=0)
