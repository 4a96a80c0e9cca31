"""Figures in the style of seed 000 Fig. 4 — one column per control mode, rows: motor speed,
voltage, current, mechanical and electrical power; every backend that ran drawn together."""
from __future__ import annotations

import sys

from .plotstyle import backend_style
from .plotstyle import SETPOINT, context, suptitle
from .trajectory import atomic_write

MODE_TITLE = {"open": "open loop", "pid": "closed loop (PID)", "smc": "sliding-mode control"}


def save(fig, path, dpi=130, tight=None):
    """Save a figure atomically (complete file or none) and close it.

    ``tight``: crop to a tight bounding box, which draws the figure twice (once to measure it).
    By default only a figure with no layout of its own is cropped: a figure made in the mjbench
    style (:mod:`mjbench.plotstyle`: tight layout engine, or ``tight_layout()`` / constrained
    layout) already fits its canvas and is drawn once."""
    fmt = str(path).rsplit(".", 1)[-1]
    if tight is None:
        tight = fig.get_layout_engine() is None
    atomic_write(path, lambda f: fig.savefig(f, format=fmt, dpi=dpi, bbox_inches="tight" if tight else None),
                 mode="wb")
    plt = sys.modules.get("matplotlib.pyplot")  # a figure made by pyplot is released there too
    if plt is not None:
        plt.close(fig)
    return path


def fig4(runs: dict, path, setpoint=None, title=None, chi=None):
    """Seed 000 Fig. 4.  ``runs`` = {mode: {backend: Trajectory}}; ``setpoint`` [rad/s] drawn dashed
    on the speed plots (the paper's ω₀); ``chi`` = {mode: text} annotated on the speed plots."""
    with context():
        return _fig4(runs, path, setpoint, title, chi)


def _fig4(runs, path, setpoint, title, chi):
    modes = list(runs)
    # machines with internal (elastic) coordinates get one more row per coordinate
    first = next(iter(next(iter(runs.values())).values()))
    extra = [c for c in first.columns[11:] if c.endswith("_rad") and not c.endswith("_rate_rad")]
    nrow = 4 + len(extra)
    from matplotlib.figure import Figure  # no pyplot: a run's figure costs its drawing, not pyplot's import

    fig = Figure(figsize=(5.2 * len(modes), 10.5 + 2.4 * len(extra)))
    axes = fig.subplots(nrow, len(modes), sharex="col", squeeze=False)
    letters = "abcdefgh"
    for j, mode in enumerate(modes):
        col = axes[:, j]
        for backend, tr in runs[mode].items():
            st = backend_style(backend, "z_axes" in tr.meta)  # (an axis of a machine with several motors)
            col[0].plot(tr.t, tr.omega, **st)
            col[1].plot(tr.t, tr.voltage, **st)
            col[2].plot(tr.t, tr.current, **st)
            pm = dict(st, label=f"mechanical k_m·I·φ̇ ({backend})")
            pe = dict(st, label=f"electrical V·I ({backend})", color="tab:red" if backend == "multibody" else "tab:pink")
            col[3].plot(tr.t, tr.p_mech, **pm)
            col[3].plot(tr.t, tr.p_elec, **pe)
            for i, c in enumerate(extra):
                if tr.has(c):
                    col[4 + i].plot(tr.t, 1e3 * tr[c], **st)
        if setpoint is not None:
            col[0].axhline(setpoint, **SETPOINT, label=f"set-point ω₀ = {setpoint:g} rad/s")
        col[0].set_title(MODE_TITLE.get(mode, mode))
        if chi and mode in chi:
            col[0].text(0.98, 0.04, chi[mode], transform=col[0].transAxes, ha="right", va="bottom",
                        fontsize=9, bbox=dict(boxstyle="round", fc="white", ec="0.7"))
        labels = ["motor speed φ̇ [rad/s]", "armature voltage V_a [V]", "armature current I [A]", "power [W]"]
        labels += [f"{c[:-4].replace('_', ' ')} [mrad]" for c in extra]
        for i, ax in enumerate(col):
            ax.set_ylabel(labels[i])
            ax.grid(True, alpha=0.3)
            if len(modes) == 2 and i < 4:  # the paper's panel letters: a, c, e, g left; b, d, f, h right
                ax.text(0.01, 0.97, f"{letters[2 * i + j]})", transform=ax.transAxes, va="top", fontsize=9)
        col[0].legend(fontsize=8, loc="lower right" if not chi else "upper right")
        col[3].legend(fontsize=7, loc="upper right")
        col[-1].set_xlabel("time t [s]")
    if title:
        suptitle(fig, title, fontsize=11)
    # laid out once, when drawn: the style's tight layout engine (plotstyle.RC "figure.autolayout")
    return save(fig, path, tight=False)
