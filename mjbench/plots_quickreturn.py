"""Figures of the seed-004 scenario in the style of the paper's Figs 6-7 (matplotlib, Agg).

``plot_speed`` (Fig. 6: crank angular velocity, with a zoom on the steady state) and
``plot_voltage`` (Fig. 7: a section of the input signal) take Trajectory objects.
"""
from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def _save(fig, path):
    from .trajectory import atomic_write

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
    for tr, lab in zip(trajs, labels):
        ax.plot(tr.t, tr.qd, lw=1.0, label=lab)
    if omega_d is not None:
        ax.axhline(omega_d, color="k", ls="--", lw=0.8, label=f"ω_d = {omega_d:g} rad/s")
    if band is not None:
        ax.axhspan(band[0], band[1], color="0.8", alpha=0.5, label=f"paper band {band[0]:g}-{band[1]:g} rad/s")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("crank angular velocity ω [rad/s]")
    ax.set_title(title or "Crank angular velocity (cf. seed 004 Fig. 6)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    if zoom is not None:
        ins = ax.inset_axes([0.45, 0.35, 0.3, 0.3])
        for tr in trajs:
            m = (tr.t >= zoom[0]) & (tr.t <= zoom[1])
            ins.plot(tr.t[m], tr.qd[m], lw=0.8)
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
    ax.set_title(title or "Input signal (cf. seed 004 Fig. 7)")
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
