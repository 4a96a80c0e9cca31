"""Figures in the style of seed 000 Fig. 4 — one column per control mode, rows: motor speed,
voltage, current, mechanical and electrical power; every backend that ran drawn together."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from .trajectory import atomic_write  # noqa: E402

BACKEND_STYLE = {"multibody": dict(color="tab:blue", lw=1.4, label="multibody (MuJoCo)"),
                 "reduced": dict(color="tab:orange", lw=1.0, ls="--", label="reduced J(α) model")}
MODE_TITLE = {"open": "open loop", "pid": "closed loop (PID)", "smc": "sliding-mode control"}


def save(fig, path, dpi=130):
    """Save a figure atomically (complete file or none) and close it."""
    fmt = str(path).rsplit(".", 1)[-1]
    atomic_write(path, lambda f: fig.savefig(f, format=fmt, dpi=dpi, bbox_inches="tight"), mode="wb")
    plt.close(fig)
    return path


def fig4(runs: dict, path, setpoint=None, title=None, chi=None):
    """Seed 000 Fig. 4.  ``runs`` = {mode: {backend: Trajectory}}; ``setpoint`` [rad/s] drawn dashed
    on the speed plots (the paper's ω₀); ``chi`` = {mode: text} annotated on the speed plots."""
    modes = list(runs)
    fig, axes = plt.subplots(4, len(modes), figsize=(5.2 * len(modes), 10.5), sharex="col", squeeze=False)
    letters = "abcdefgh"
    for j, mode in enumerate(modes):
        col = axes[:, j]
        for backend, tr in runs[mode].items():
            st = BACKEND_STYLE.get(backend, dict(label=backend))
            col[0].plot(tr.t, tr.omega, **st)
            col[1].plot(tr.t, tr.voltage, **st)
            col[2].plot(tr.t, tr.current, **st)
            pm = dict(st, label=f"mechanical k_m·I·φ̇ ({backend})")
            pe = dict(st, label=f"electrical V·I ({backend})", color="tab:red" if backend == "multibody" else "tab:pink")
            col[3].plot(tr.t, tr.p_mech, **pm)
            col[3].plot(tr.t, tr.p_elec, **pe)
        if setpoint is not None:
            col[0].axhline(setpoint, color="k", ls=":", lw=1.0, label=f"set-point ω₀ = {setpoint:g} rad/s")
        col[0].set_title(MODE_TITLE.get(mode, mode))
        if chi and mode in chi:
            col[0].text(0.98, 0.04, chi[mode], transform=col[0].transAxes, ha="right", va="bottom",
                        fontsize=9, bbox=dict(boxstyle="round", fc="white", ec="0.7"))
        labels = ["motor speed φ̇ [rad/s]", "armature voltage V_a [V]", "armature current I [A]", "power [W]"]
        for i, ax in enumerate(col):
            ax.set_ylabel(labels[i])
            ax.grid(True, alpha=0.3)
            if len(modes) == 2:  # the paper's panel letters: a, c, e, g left; b, d, f, h right
                ax.text(0.01, 0.97, f"{letters[2 * i + j]})", transform=ax.transAxes, va="top", fontsize=9)
        col[0].legend(fontsize=8, loc="lower right" if not chi else "upper right")
        col[3].legend(fontsize=7, loc="upper right")
        col[-1].set_xlabel("time t [s]")
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return save(fig, path)


def comparison(tr_ref, tr_other, path, column="crank_speed_rad_s", title=None):
    """Two backends on one signal, with their difference underneath."""
    import numpy as np

    fig, (a0, a1) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    a0.plot(tr_ref.t, tr_ref[column], **BACKEND_STYLE.get(tr_ref.backend, {}))
    a0.plot(tr_other.t, tr_other[column], **BACKEND_STYLE.get(tr_other.backend, {}))
    a0.set_ylabel(column.replace("_", " "))
    a0.legend()
    a0.grid(True, alpha=0.3)
    diff = np.interp(tr_ref.t, tr_other.t, tr_other[column]) - tr_ref[column]
    a1.plot(tr_ref.t, diff, color="k", lw=1.0)
    a1.set_ylabel(f"{tr_other.backend} − {tr_ref.backend}")
    a1.set_xlabel("time t [s]")
    a1.grid(True, alpha=0.3)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return save(fig, path)
