"""Plots of constant-coupler-speed runs in the style of Hülako & Çakar:
Figs 9-12 (desired vs actual crank speed, crank-speed error), Figs 18-21 (coupler-point speed
vs desired), Fig. 22 (coupler speed for several V_C; deviation vs V_C)."""
from __future__ import annotations

from mjbench.plotstyle import no_pyplot as plt  # figures without pyplot: the user's backend is left alone
import numpy as np  # noqa: E402

from .hulako2025_metrics import signals  # noqa: E402
from mjbench.trajectory import atomic_write  # noqa: E402

STYLE = {"multibody": dict(color="C0", lw=1.0), "reduced": dict(color="C1", lw=1.0, ls="--")}


def _save(fig, path):
    atomic_write(path, lambda f: fig.savefig(f, dpi=130, format=str(path).rsplit(".", 1)[-1]), mode="wb")
    plt.close(fig)


def crank_speed(trajs: dict, mechanism, reference, path, title=""):
    """Figs 9-12: (a) desired q̇_trj and actual q̇; (b) error e = q̇_trj − q̇.  ``trajs``: {backend: Trajectory}."""
    fig, (a, b) = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
    first = True
    for name, tr in trajs.items():
        sg = signals(tr, mechanism, reference)
        if first:
            a.plot(sg["t"], sg["qd_ref"], color="k", lw=1.2, label="desired q̇_trj (Eq 17)")
            first = False
        a.plot(sg["t"], sg["qd"], label=f"actual q̇ ({name})", **STYLE.get(name, {}))
        b.plot(sg["t"], sg["e"], label=name, **STYLE.get(name, {}))
    a.set_ylabel("crank speed [rad/s]")
    a.legend(fontsize=8)
    a.set_title(title, fontsize=9)
    b.axhline(0.1, color="gray", lw=0.6, ls=":")
    b.axhline(-0.1, color="gray", lw=0.6, ls=":")
    b.set_ylabel("crank-speed error [rad/s]")
    b.set_xlabel("time [s]")
    b.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def coupler_speed(trajs: dict, mechanism, reference, path, title="", paper_dev=None):
    """Figs 18-21: coupler-point speed vs desired (band = Table 3 simulation deviation if given)."""
    fig, ax = plt.subplots(figsize=(7, 3.5))
    first = True
    for name, tr in trajs.items():
        sg = signals(tr, mechanism, reference)
        if first:
            ax.plot(sg["t"], sg["vdes"], color="k", lw=1.2, label="desired V_C")
            if paper_dev:
                ax.fill_between(sg["t"], sg["vdes"] - paper_dev, sg["vdes"] + paper_dev, color="0.85",
                                label=f"paper Table 3 ±{paper_dev} m/s")
            first = False
        ax.plot(sg["t"], sg["vc"], label=f"simulated ({name})", **STYLE.get(name, {}))
    ax.set_ylabel("coupler-point speed [m/s]")
    ax.set_xlabel("time [s]")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def deviation_vs_vc(rows, path, title=""):
    """Fig. 22 style: max coupler-speed deviation after settling vs V_C, per model, our simulation
    and the paper's (simulation, Table 3; experiment, Table 3 and §6).
    ``rows``: list of dicts with keys model, vc, dev (ours after settling), dev_last (ours, last
    second; optional), paper_sim, paper_exp (None if absent)."""
    fig, ax = plt.subplots(figsize=(6, 3.8))
    models = sorted({r["model"] for r in rows})
    for i, mname in enumerate(models):
        rr = sorted((r for r in rows if r["model"] == mname), key=lambda r: r["vc"])
        vc = [r["vc"] for r in rr]
        ax.plot(vc, [r["dev"] for r in rr], "o-", color=f"C{i}", label=f"{mname} (this model, after 1.5 s)")
        if all(r.get("dev_last") is not None for r in rr):
            ax.plot(vc, [r["dev_last"] for r in rr], "o--", mfc="none", color=f"C{i}",
                    label=f"{mname} (this model, last 1 s)")
        ps = [(r["vc"], r["paper_sim"]) for r in rr if r.get("paper_sim") is not None]
        if ps:
            ax.plot(*zip(*ps), "s", mfc="none", color=f"C{i}", label=f"{mname} paper simulation")
        pe = [(r["vc"], r["paper_exp"]) for r in rr if r.get("paper_exp") is not None]
        if pe:
            ax.plot(*zip(*pe), "^", mfc="none", color=f"C{i}", ls=":", label=f"{mname} paper experiment")
    ax.set_xlabel("desired coupler speed V_C [m/s]")
    ax.set_ylabel("max |V_C − V_des| after settling [m/s]")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, path)


def coupler_speed_family(runs, path, title=""):
    """Fig. 22 a/b style: coupler speed vs time for several V_C (``runs``: list of (vc, t, V_C))."""
    fig, ax = plt.subplots(figsize=(7, 3.8))
    for i, (vc, t, v) in enumerate(runs):
        ax.plot(t, v, color=f"C{i}", lw=0.9, label=f"V_C = {vc} m/s")
        ax.axhline(vc, color=f"C{i}", lw=0.6, ls=":")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("coupler-point speed [m/s]")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)


def coupler_curve(mechanism, reference, path, title=""):
    """The coupler curve over one turn, coloured by the Eq 17 crank-speed reference."""
    q = np.linspace(0, 2 * np.pi, 721)
    x, y = mechanism.coupler_point_position(q)
    qd = reference.crank_speed(q)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    sc = ax.scatter(np.asarray(x) * 1e3, np.asarray(y) * 1e3, c=qd, s=4, cmap="viridis")
    j = mechanism.joints(0.0)
    for nm in ("A", "D"):
        ax.plot(j[nm][0] * 1e3, j[nm][1] * 1e3, "ks")
    jj, cp = mechanism.joints(np.pi / 2), mechanism.coupler_point_position(np.pi / 2)
    xs = [jj[k][0] * 1e3 for k in "ABCD"]
    ys = [jj[k][1] * 1e3 for k in "ABCD"]
    ax.plot(xs, ys, "-o", color="0.5", lw=1, ms=3, label="linkage at q = 90°")
    ax.fill([jj["B"][0] * 1e3, jj["C"][0] * 1e3, cp[0] * 1e3], [jj["B"][1] * 1e3, jj["C"][1] * 1e3, cp[1] * 1e3],
            color="0.8", alpha=0.6)
    ax.legend(fontsize=7, loc="upper right")
    fig.colorbar(sc, ax=ax, shrink=0.8, label="q̇_trj [rad/s]")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    _save(fig, path)
