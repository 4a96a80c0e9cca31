"""Figures of the Yiğit & Şen 2023 scenario in the style of the paper's Figs 6-7 (matplotlib, no pyplot).

``plot_speed`` (Fig. 6: crank angular velocity, with a zoom on the steady state) and
``plot_voltage`` (Fig. 7: a section of the input signal) take Trajectory objects.
"""
from __future__ import annotations

import os

from mjbench.plotstyle import no_pyplot as plt  # figures without pyplot: the user's backend is left alone
import numpy as np  # noqa: E402
from mjbench.trajectory import atomic_write
from mjbench import scenario
from mjbench.backends import simulate


def _save(fig, path):

    ext = os.path.splitext(path)[1].lstrip(".") or "png"
    atomic_write(path, lambda f: fig.savefig(f, format=ext, dpi=130), mode="wb")
    plt.close(fig)
    return path


def plot_speed(trajs, labels=None, path=None, omega_d=None, zoom=None, band=None, title=None):
    """Crank speed vs time for each trajectory (Fig. 6).  ``zoom`` = (t0, t1) adds an inset of the
    steady state; ``band`` = (lo, hi) shades a reported speed band (e.g. the paper's 6.1-6.4 rad/s)."""
    trajs = list(trajs)
    labels = list(labels or [f"{tr.backend}" for tr in trajs])
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for i, (tr, lab) in enumerate(zip(trajs, labels)):
        ax.plot(tr.t, tr.qd, lw=1.0, label=lab, color=f"C{i}")
    if omega_d is not None:
        ax.axhline(omega_d, color="k", ls="--", lw=0.8, label=f"ω_d = {omega_d:g} rad/s")
    if band is not None:
        ax.axhspan(band[0], band[1], color="0.8", alpha=0.5, label=f"paper band {band[0]:g}-{band[1]:g} rad/s")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("crank angular velocity ω [rad/s]")
    ax.set_title(title or "Crank angular velocity (cf. Yiğit & Şen Fig. 6)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    if zoom is not None:
        ins = ax.inset_axes([0.22, 0.1, 0.36, 0.36])
        for i, tr in enumerate(trajs):
            m = (tr.t >= zoom[0]) & (tr.t <= zoom[1])
            if omega_d is not None and m.any() and abs(np.mean(tr.qd[m]) - omega_d) > 0.1 * abs(omega_d):
                continue  # the zoom shows the traces near the set-point (closed loop)
            ins.plot(tr.t[m], tr.qd[m], lw=0.8, color=f"C{i}")
        if omega_d is not None:
            ins.axhline(omega_d, color="k", ls="--", lw=0.6)
        ins.set_xlabel("t [s]", fontsize=7)
        ins.set_ylabel("ω [rad/s]", fontsize=7)
        ins.tick_params(labelsize=6)
        ins.set_title("zoom (steady state)", fontsize=7)
    if path:
        return _save(fig, path)
    return fig


def plot_voltage(trajs, labels=None, path=None, window=None, v_limit=None, title=None):
    """Armature (input) voltage vs time over ``window`` = (t0, t1) (Fig. 7)."""
    trajs = list(trajs)
    labels = list(labels or [f"{tr.backend}" for tr in trajs])
    fig, ax = plt.subplots(figsize=(8, 3.8))
    for tr, lab in zip(trajs, labels):
        m = np.ones(tr.n, bool) if window is None else (tr.t >= window[0]) & (tr.t <= window[1])
        ax.step(tr.t[m], tr.voltage[m], where="post", lw=0.8, label=lab)
    if v_limit is not None:
        for s in (-1, 1):
            ax.axhline(s * v_limit, color="k", ls=":", lw=0.8)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("input voltage V_m [V]")
    ax.set_title(title or "Input signal (cf. Yiğit & Şen Fig. 7)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    if path:
        return _save(fig, path)
    return fig


def figures(runs: dict, outdir, omega_d=5.0, zoom=(3.0, 4.0), window=(3.0, 3.05), band=(6.1, 6.4), v_limit=48.0):
    """Write fig6_speed.png and fig7_voltage.png from ``runs`` = {label: Trajectory}."""
    os.makedirs(outdir, exist_ok=True)
    labels, trajs = list(runs), list(runs.values())
    p6 = plot_speed(trajs, labels, os.path.join(outdir, "fig6_speed.png"), omega_d=omega_d, zoom=zoom, band=band)
    closed = [(k, v) for k, v in runs.items() if "open" not in k] or list(runs.items())
    p7 = plot_voltage([v for _, v in closed], [k for k, _ in closed], os.path.join(outdir, "fig7_voltage.png"),
                      window=window, v_limit=v_limit)
    return [p6, p7]


def ts_study(rows, path, paper_pct=None, default_Ts=None, matched=None, title=""):
    """SMC steady error against the control period: ``rows`` = [(Ts [s], |mean e| [%], max |e| [%])];
    the paper's figure dashed, the scenario's Ts and the interpolated matching Ts marked."""
    Ts = np.array([r[0] for r in rows]) * 1e3
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ax.loglog(Ts, [r[1] for r in rows], "o-", color="C0", label="|mean e| (steady state, t ≥ 2 s)")
    ax.loglog(Ts, [r[2] for r in rows], "s--", color="C1", ms=4, lw=0.9, label="max |e|")
    if paper_pct is not None:
        ax.axhline(paper_pct, color="k", ls="--", lw=0.9, label=f"paper §4: {paper_pct:g} %")
    if default_Ts is not None:
        ax.axvline(1e3 * default_Ts, color="0.5", ls=":", lw=1, label=f"scenario Ts = {1e3 * default_Ts:g} ms")
    if matched is not None:
        ax.plot([1e3 * matched], [paper_pct], "r*", ms=12, label=f"matches the paper at Ts ≈ {1e3 * matched:.2g} ms")
    ax.set_xlabel("control period Ts [ms]")
    ax.set_ylabel("crank-speed error [%] of ω_d")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title(title or "SMC steady error vs control period", fontsize=10)
    return _save(fig, path)


def design_comparison(designs: dict, path, title=""):
    """The mechanisms of several designs {label: (r₂, r₃, r₄, a, b) [mm]} at one scale: crank
    circle, lever and rod at both swing ends (solid) and at mid-swing (dotted), slider path and
    stroke."""
    n = len(designs)
    fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 5.2), squeeze=False)
    xs, ys = [0.0], [0.0]
    for ax, (label, x) in zip(axes[0], designs.items()):
        r2, r3, r4, a, b = (float(v) for v in x)
        H = a + b
        d = np.arcsin(min(r2 / a, 1.0))
        tt = np.linspace(0, 2 * np.pi, 200)
        ax.plot(r2 * np.cos(tt), a + r2 * np.sin(tt), color="tab:red", lw=1)
        for th, ls in ((np.pi / 2 - d, "-"), (np.pi / 2 + d, "-"), (np.pi / 2, ":")):
            B = np.array([r3 * np.cos(th), r3 * np.sin(th)])
            sphi = (H - B[1]) / r4
            if abs(sphi) <= 1:
                C = B + np.array([r4 * np.sqrt(1 - sphi * sphi), H - B[1]])
                ax.plot(*zip(B, C), color="tab:green", lw=2 if ls == "-" else 1, ls=ls)
                ax.plot(*C, "s", color="tab:purple", ms=5, mfc="none" if ls == ":" else "tab:purple")
            ax.plot([0, B[0]], [0, B[1]], color="tab:blue", lw=2 if ls == "-" else 1, ls=ls)
            xs += [B[0], B[0] + r4]
            ys += [B[1], H]
        ax.axhline(H, color="0.4", lw=0.8)
        ax.plot([0, 0], [0, a], "ko", ms=4)
        ax.text(4, 4, "B₀", fontsize=8)
        ax.text(4, a + 4, "A₀", fontsize=8)
        ax.set_title(f"{label}\nsum {r2 + r3 + r4 + a + b:.1f} mm", fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("x [mm]")
    pad = 20.0
    for ax in axes[0]:  # one scale for every design
        ax.set_xlim(min(xs) - pad, max(xs) + pad)
        ax.set_ylim(min(ys) - pad, max(ys) + pad)
        ax.set_aspect("equal")
    axes[0, 0].set_ylabel("y [mm]")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def draw_geometry(mech, path=None, q=2.0):
    """Drawing of the reconstructed geometry (docs/quickreturn_geometry.png): B₀ origin, A₀ above it,
    crank circle, lever extremes, rod, slider line y = a + b, stroke, angles θ₂, θ₃, θ₄ at crank
    angle ``q`` [rad]."""
    mm = 1e3
    fig, ax = plt.subplots(figsize=(7.5, 8))
    H = mech.a + mech.b
    # crank circle and lever extremes (crank normal to the lever)
    tt = np.linspace(0, 2 * np.pi, 200)
    ax.plot(mm * mech.r2 * np.cos(tt), mm * (mech.a + mech.r2 * np.sin(tt)), color="0.7", lw=0.8, ls="--")
    for qe, lab in ((mech._work_q0, "working stroke starts"), (mech._work_q0 + mech._work_arc, "working stroke ends")):
        p = mech.joints(float(qe))
        ax.plot([0, mm * p["B"][0]], [0, mm * p["B"][1]], color="tab:blue", lw=0.8, ls=":", alpha=0.7)
        ax.plot([mm * p["B"][0], mm * p["C"][0]], [mm * p["B"][1], mm * p["C"][1]], color="tab:green", lw=0.8,
                ls=":", alpha=0.7)
        ax.plot(mm * p["C"][0], mm * H, "s", ms=6, mfc="none", color="tab:purple")
    # slider path and stroke
    xs, xe = mm * mech._x_start, mm * mech._x_end
    ax.plot([min(xs, xe) - 60, max(xs, xe) + 60], [mm * H] * 2, color="0.3", lw=1)
    ax.annotate("", xy=(xe, mm * H + 25), xytext=(xs, mm * H + 25), arrowprops=dict(arrowstyle="->", color="tab:red"))
    ax.text(0.5 * (xs + xe), mm * H + 32, f"working stroke {mm * mech.stroke:.1f} mm (cutting force on slider)",
            ha="center", fontsize=8, color="tab:red")
    # configuration at q
    p = mech.joints(float(q))
    k = mech.kin(float(q))
    A0, A, B0, B, C = (np.array(p[n]) * mm for n in ("A0", "A", "B0", "B", "C"))
    ax.plot(*zip(A0, A), color="tab:red", lw=3, label=f"crank r₂ = {mm * mech.r2:.0f} mm (link 2)")
    ax.plot(*zip(B0, B), color="tab:blue", lw=3, label=f"slotted lever r₃ = {mm * mech.r3:.0f} mm (link 3)")
    ax.plot(*zip(B, C), color="tab:green", lw=3, label=f"rod r₄ = {mm * mech.r4:.0f} mm (link 4)")
    ax.add_patch(plt.Rectangle((C[0] - 15, C[1] - 8), 30, 16, color="tab:purple", alpha=0.8,
                               label=f"slider (link 5), m = {mech.m5:g} kg"))
    ax.add_patch(plt.Rectangle((A[0] - 7, A[1] - 5), 14, 10, angle=np.degrees(k["th3"]), rotation_point="center",
                               color="gold", label="block on crank pin, slides in the lever"))
    for P, n in ((A0, "A₀"), (B0, "B₀"), (A, "A"), (B, "B"), (C, "C")):
        ax.plot(*P, "ko", ms=4)
        ax.text(P[0] + 6, P[1] + (4 if n == "B₀" else -12), n, fontsize=10)
    # dimensions a, b
    ax.annotate("", xy=(-120, 0), xytext=(-120, mm * mech.a), arrowprops=dict(arrowstyle="<->"))
    ax.text(-115, 0.5 * mm * mech.a, f"a = {mm * mech.a:.0f}", fontsize=9)
    ax.annotate("", xy=(-120, mm * mech.a), xytext=(-120, mm * H), arrowprops=dict(arrowstyle="<->"))
    ax.text(-115, mm * (mech.a + 0.5 * mech.b), f"b = {mm * mech.b:.0f}", fontsize=9)
    ax.text(A0[0] + 8, A0[1] + 8, f"θ₂ = q = {np.degrees(q):.0f}°", fontsize=8, color="tab:red")
    ax.text(20, 40, f"θ₃ = {np.degrees(k['th3']):.0f}°", fontsize=8, color="tab:blue")
    ax.text(B[0] - 5, B[1] - 28, f"θ₄ = {np.degrees(k['th4']):.0f}°", fontsize=8, color="tab:green")
    ax.text(0.02, 0.02, f"TR = {mech.time_ratio:.3f},  μ_min = {np.degrees(mech.min_transmission_angle()):.1f}° "
            f"(rod vs slider-path normal),  gravity −y", transform=ax.transAxes, fontsize=8)
    ax.set_aspect("equal")
    ax.set_ylim(-30, mm * H + 60)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("Yiğit & Şen quick-return mechanism: geometry reconstructed from Eqs 3-6 (Table I)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="center right", fontsize=7)
    if path:
        return _save(fig, path)
    return fig


def docs_figures(outdir="docs", t_end=5.0, backend="multibody"):
    """Regenerate docs/quickreturn_{geometry,fig6,fig7}.png from the yigit2023 scenario
    (open 48 V, SMC, PID; ≈ 5 s of computing per mode)."""

    scn = scenario.load("yigit2023")
    runs = {}
    for mode in ("open", "smc", "pid"):
        runs[mode] = simulate(scenario.make_machine(scn, mode), backend, t_end, dt=1e-4,
                              record_dt=1e-3 if mode == "open" else 1e-4)
    Ts = scn.modes["smc"].Ts
    out = [draw_geometry(scenario.make_mechanism(scn), os.path.join(outdir, "quickreturn_geometry.png")),
           plot_speed([runs["open"], runs["smc"], runs["pid"]],
                      ["open loop 48 V", f"SMC (λ=50, K=1000, Ts={1e3 * Ts:g} ms)", "PID (our gains)"],
                      os.path.join(outdir, "quickreturn_fig6.png"), omega_d=5.0, zoom=(3.0, 4.0), band=(6.1, 6.4)),
           plot_voltage([runs["smc"], runs["pid"]], ["SMC", "PID"], os.path.join(outdir, "quickreturn_fig7.png"),
                        window=(3.0, 3.05), v_limit=48.0)]
    return out
