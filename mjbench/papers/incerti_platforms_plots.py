"""Plots of the residual-vibration study (Incerti belt Fig. 3, Incerti Bezier Figs 5-6, ω_n sensitivity).

All curves come from the reduced ODE (``vibration.ode_response``, DOP853 rtol 1e-12) run past
the end of the move by ``t_after`` seconds with the motor locked; files are written atomically.
"""
from __future__ import annotations

import io

from mjbench.plotstyle import no_pyplot as plt  # figures without pyplot: the user's backend is left alone
import numpy as np  # noqa: E402

from mjbench.motionlaws import BezierLaw  # noqa: E402
from mjbench.trajectory import atomic_write  # noqa: E402
from mjbench.vibration import ode_response  # noqa: E402
from mjbench.vibration import simulate_multibody


def save(fig, path):
    buf = io.BytesIO()
    # a figure laid out by its layout engine (mjbench.plotstyle) fits its canvas: drawn once, not cropped
    tight = fig.get_layout_engine() is None
    fig.savefig(buf, format=str(path).rsplit(".", 1)[-1], dpi=130, bbox_inches="tight" if tight else None)
    plt.close(fig)
    atomic_write(path, lambda f: f.write(buf.getvalue()), mode="wb")
    return path


def response(law, osc, t_after=0.5, n=3001):
    """Platform-side signals on [0, T + t_after]: dict of arrays (t, commands ρφ, ρφ̇, ρφ̈,
    platform angle/speed/acceleration, deflection ψ, kinetic and potential energy)."""
    t_end = law.T + t_after
    t = np.linspace(0.0, t_end, n)
    t, psi, psid, _ = ode_response(law, osc, t_end=t_end, t_eval=t)
    p, v, a, _ = law.evaluate(t)
    rho, wn, xi = osc.ratio, osc.omega_n, osc.xi
    th, thd = psi + rho * p, psid + rho * v
    thdd = -2 * xi * wn * psid - wn * wn * psi  # Eq 4: ϑ̈ = ψ̈ + ρφ̈
    return {"t": t, "cmd": rho * p, "cmd_d": rho * v, "cmd_dd": rho * a, "th": th, "thd": thd,
            "thdd": thdd, "psi": psi, "Ek": 0.5 * osc.J * thd ** 2, "Ep": 0.5 * osc.k * psi ** 2, "T": law.T}


def fig_energy_response(law_before, law_after, osc, path, t_after=0.5, titles=("non-optimised", "optimised"),
                        suptitle=""):
    """Incerti belt Fig. 3: platform speed and acceleration (solid) with the commands λφ̇, λφ̈
    (dashed), kinetic and elastic potential energy; left before, right after the optimisation."""
    fig, ax = plt.subplots(4, 2, figsize=(11, 10), sharex=True)
    for col, (law, title) in enumerate(zip((law_before, law_after), titles)):
        r = response(law, osc, t_after)
        t = r["t"]
        ax[0, col].plot(t, r["thd"], "b-", lw=1.2, label="platform ϑ̇")
        ax[0, col].plot(t, r["cmd_d"], "k--", lw=1, label="command ρφ̇")
        ax[1, col].plot(t, r["thdd"], "b-", lw=1.2, label="platform ϑ̈")
        ax[1, col].plot(t, r["cmd_dd"], "k--", lw=1, label="command ρφ̈")
        ax[2, col].plot(t, r["Ek"], "g-", lw=1.2)
        ax[3, col].plot(t, r["Ep"], "m-", lw=1.2)
        ax[0, col].set_title(title)
        for a in ax[:, col]:
            a.axvline(r["T"], color="0.6", lw=0.8, ls=":")
            a.grid(alpha=0.3)
        ax[3, col].set_xlabel("t [s]")
    ax[0, 0].set_ylabel("speed [rad/s]")
    ax[1, 0].set_ylabel("acceleration [rad/s²]")
    ax[2, 0].set_ylabel("kinetic energy [J]")
    ax[3, 0].set_ylabel("potential energy [J]")
    ax[0, 0].legend(fontsize=8)
    ax[1, 0].legend(fontsize=8)
    for row in range(4):  # same y scale left/right, as in the paper
        lo = min(ax[row, 0].get_ylim()[0], ax[row, 1].get_ylim()[0])
        hi = max(ax[row, 0].get_ylim()[1], ax[row, 1].get_ylim()[1])
        ax[row, 0].set_ylim(lo, hi)
        ax[row, 1].set_ylim(lo, hi)
    if suptitle:
        fig.suptitle(suptitle)
    return save(fig, path)


def fig_commands_platform(law, osc, path, t_after=0.5, title=""):
    """Incerti Bezier Figs 5-6: left, the commands α = zφ, α̇, α̈ with their control polygons (Bezier
    laws); right, the platform rotation β, speed β̇ and acceleration β̈."""
    r = response(law, osc, t_after)
    t, rho = r["t"], osc.ratio
    fig, ax = plt.subplots(3, 2, figsize=(11, 8.5), sharex=True)
    cmds = (r["cmd"], r["cmd_d"], r["cmd_dd"])
    plat = (r["th"], r["thd"], r["thdd"])
    names = ("position α = ρφ [rad]", "velocity α̇ [rad/s]", "acceleration α̈ [rad/s²]")
    pnames = ("platform β [rad]", "platform β̇ [rad/s]", "platform β̈ [rad/s²]")
    polys = law.polygons()[:3] if isinstance(law, BezierLaw) else None
    for k in range(3):
        ax[k, 0].plot(t, cmds[k], "k-", lw=1.2)
        if polys is not None:
            ax[k, 0].plot(law.knots(k), rho * polys[k], "o--", color="tab:red", ms=4, lw=0.8, label="control polygon")
        ax[k, 1].plot(t, plat[k], "b-", lw=1.2)
        ax[k, 1].plot(t, cmds[k], "k--", lw=0.8)
        ax[k, 0].set_ylabel(names[k])
        ax[k, 1].set_ylabel(pnames[k])
        for a in ax[k]:
            a.axvline(r["T"], color="0.6", lw=0.8, ls=":")
            a.grid(alpha=0.3)
    if polys is not None:
        ax[0, 0].legend(fontsize=8)
    ax[2, 0].set_xlabel("t [s]")
    ax[2, 1].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    return save(fig, path)


def fig_sensitivity(errors, table, path, title="Residual energy vs error in ω_n"):
    """E(T_end) of each law (designed for the nominal ω_n) against the relative error of ω_n."""
    fig, ax = plt.subplots(figsize=(8, 5))
    errors = np.asarray(errors)
    styles = ["-", "--", "-.", ":"]
    for i, (name, rows) in enumerate(table.items()):
        E = np.array([r[1] for r in rows])
        ax.semilogy(100 * errors, np.maximum(E, 1e-30), lw=1.6, ls=styles[i % len(styles)], label=name)
    ax.set_xlabel("error in ω_n [%]")
    ax.set_ylabel("residual energy E(T_end) [J]")
    ax.set_ylim(bottom=max(1e-16, ax.get_ylim()[0]))
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title(title)
    return save(fig, path)


def fig_laws(laws: dict, path, title="Motor laws"):
    """Position, speed and acceleration of several motor laws on one time axis."""
    fig, ax = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    tmax = max(law.T for law in laws.values())
    t = np.linspace(0.0, tmax, 2001)
    for name, law in laws.items():
        p, v, a, _ = law.evaluate(t)
        for k, y in enumerate((p, v, a)):
            ax[k].plot(t, y, lw=1.2, label=name)
    for a, lab in zip(ax, ("φ [rad]", "φ̇ [rad/s]", "φ̈ [rad/s²]")):
        a.set_ylabel(lab)
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8)
    ax[2].set_xlabel("t [s]")
    ax[0].set_title(title)
    return save(fig, path)


def fig_multibody_check(platform, law, osc, path, t_after=0.5, dt=1e-3):
    """Transmission deflection ψ(t) from MuJoCo (RK4, driven joint imposed per stage) over the
    reduced ODE, and their difference."""

    t_end = law.T + t_after
    r = simulate_multibody(platform, law, t_end=t_end, dt=dt, record_dt=max(dt, 1e-3))
    t, psi, _, _ = ode_response(law, osc, t_end=t_end, t_eval=r["t"])
    fig, ax = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    ax[0].plot(t, 1e3 * psi, "k-", lw=1.4, label="reduced ODE (DOP853)")
    ax[0].plot(r["t"], 1e3 * r["psi"], "r--", lw=1.0, label=f"MuJoCo RK4 h = {dt:g} s")
    ax[0].set_ylabel("deflection ψ [mrad]")
    ax[0].legend(fontsize=8)
    ax[1].plot(t, r["psi"] - psi, "b-", lw=1)
    ax[1].set_ylabel("MuJoCo − ODE [rad]")
    ax[1].set_xlabel("t [s]")
    for a in ax:
        a.axvline(law.T, color="0.6", lw=0.8, ls=":")
        a.grid(alpha=0.3)
    ax[0].set_title("Multibody vs reduced model (initial law)")
    return save(fig, path)


def fig_servo(laws: dict, runs: dict, osc, path, t_after=0.5, title="Ideal vs real servo"):
    """Deflection ψ(t) with the ideal servo (law followed exactly, ODE) and with the DC motor +
    cascade servo (the machine run by the co-step kernel, a Trajectory), for each law in ``runs``:
    the whole run (left) and the residual vibration after T on its own scale (right)."""
    fig, ax = plt.subplots(len(runs), 2, figsize=(12, 3.2 * len(runs)), squeeze=False,
                           gridspec_kw={"width_ratios": [1.2, 1]})
    for row, (name, r) in zip(ax, runs.items()):
        law = laws[name]
        t, psi, _, _ = ode_response(law, osc, t_end=float(r.t[-1]), t_eval=r.t[::5])
        after_i, after_r = t >= law.T, r.t >= law.T
        for a, sel_i, sel_r in ((row[0], slice(None), slice(None)), (row[1], after_i, after_r)):
            a.plot(t[sel_i], 1e3 * psi[sel_i], "k-", lw=1.3, label="ideal servo (ODE)")
            a.plot(r.t[sel_r], 1e3 * r["deflection_rad"][sel_r], "r--", lw=1.0, label="DC motor + cascade servo")
            a.grid(alpha=0.3)
        row[0].axvline(law.T, color="0.6", lw=0.8, ls=":")
        row[0].set_ylabel(f"{name}: ψ [mrad]")
        row[0].legend(fontsize=8)
        row[1].set_title(f"after the move (t ≥ T = {law.T:g} s), own scale", fontsize=9)
        row[1].set_ylabel("ψ [mrad]")
    ax[-1, 0].set_xlabel("t [s]")
    ax[-1, 1].set_xlabel("t [s]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return save(fig, path)
