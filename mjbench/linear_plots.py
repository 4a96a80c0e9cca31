"""Figures of the linear analysis (``mjbench linearize``, paper reports): Bode plots of the loop
with the frozen-angle family, Nyquist plot, poles in the s-plane, plant agreement.

Every frequency response is evaluated by :func:`mjbench.linear.response` on the python-control
objects; discrete-time systems are drawn up to 0.9 × their Nyquist frequency.  The frozen-angle
family is coloured by the input angle with a cyclic colour map (0 and 2π the same colour).
"""
from __future__ import annotations

import math

import numpy as np

from . import linear as LN
from .linear import multi as LM
from . import plotstyle as ps
from .plots import save

CMAP = "twilight"


def _grid(sys, lo=0.1):
    return LN.frequency_grid(float(sys.dt) if sys.dt else None, lo=lo, n=500, hi=None if sys.dt else 1e4)


def _unwrap_deg(G, om=None, w_ref=None):
    """Unwrapped phase [deg], shifted by a multiple of 360° so that it lies in (−360°, 0°] at
    ``w_ref`` (the crossover: the phase margin is read there), or at the first frequency."""
    ph = np.degrees(np.unwrap(np.angle(G)))
    i = 0 if (om is None or w_ref is None or not math.isfinite(w_ref)) else int(np.argmin(np.abs(np.log(om / w_ref))))
    return ph - 360.0 * np.ceil(ph[i] / 360.0)


def _angle_colors(angles):
    import matplotlib

    cmap = matplotlib.colormaps[CMAP]
    return [cmap(float(a) / (2 * math.pi)) for a in angles], cmap


def _colorbar(fig, ax, cmap):
    import matplotlib

    sm = matplotlib.cm.ScalarMappable(cmap=cmap, norm=matplotlib.colors.Normalize(0.0, 2 * math.pi))
    cb = fig.colorbar(sm, ax=ax, pad=0.02)
    cb.set_label(ps.label("frozen input angle q", "rad"))
    return cb


def bode(systems, path, angles=None, nominal=None, title="", ylabel="loop L at the plant input",
         margins=None, lo=0.1):
    """Magnitude [dB] and phase [deg] of ``systems`` (SISO), one per angle in ``angles`` (coloured
    by angle), and ``nominal`` (black, the operating point) with its margins annotated."""
    fig, (am, ap) = ps.new(2, 1, figsize=(8.6, 6.6), sharex=True, layout="constrained")
    ref = nominal if nominal is not None else systems[0]
    om = _grid(ref, lo)
    w_ref = margins.w_gain_crossover_rad_s if margins is not None else None
    if angles is not None and len(systems):
        cols, cmap = _angle_colors(angles)
        for sys, c in zip(systems, cols):
            G = LN.response(sys, om)
            am.semilogx(om, 20 * np.log10(np.abs(G)), color=c, lw=0.8)
            ap.semilogx(om, _unwrap_deg(G, om, w_ref), color=c, lw=0.8)
        _colorbar(fig, [am, ap], cmap)
    if nominal is not None:
        G = LN.response(nominal, om)
        am.semilogx(om, 20 * np.log10(np.abs(G)), color="k", lw=1.6, label="operating point")
        ap.semilogx(om, _unwrap_deg(G, om, w_ref), color="k", lw=1.6)
        am.legend(loc="lower left")
    am.axhline(0.0, color="0.4", lw=0.8, ls=":")
    ap.axhline(-180.0, color="0.4", lw=0.8, ls=":")
    if margins is not None:
        txt = (f"GM = {_fmt(margins.gain_margin_dB)} dB, PM = {_fmt(margins.phase_margin_deg)}°\n"
               f"peak |S| = {_fmt(margins.Ms)}, bandwidth = {_fmt(margins.bandwidth_rad_s)} rad/s")
        am.text(0.99, 0.97, txt, transform=am.transAxes, ha="right", va="top", fontsize=8,
                bbox=dict(boxstyle="round", fc="white", ec="0.7"))
        if math.isfinite(margins.w_gain_crossover_rad_s):
            for ax in (am, ap):
                ax.axvline(margins.w_gain_crossover_rad_s, color="tab:red", lw=0.8, ls="--")
    am.set_ylabel(ps.label(f"|{ylabel}|", "dB"))
    ap.set_ylabel(ps.label("phase", "deg"))
    ap.set_xlabel(ps.label("frequency ω", "rad/s"))
    if ref.dt:
        ap.set_xlim(om[0], om[-1])
    if title:
        ps.suptitle(fig, title, fontsize=10.5)
    return save(fig, path)


def _fmt(v):
    return "∞" if v == math.inf else ("—" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.3g}")


def nyquist(systems, path, angles=None, nominal=None, title="", margins=None, span=3.0):
    """Nyquist plot of L(e^{jωT}), ω ∈ (0, Nyquist), near the critical point −1 (the family
    coloured by angle, the operating point in black, the circle |1 + L| = 1/peak|S|)."""
    fig, ax = ps.new(1, 1, figsize=(7.6, 6.4), layout="constrained")
    ref = nominal if nominal is not None else systems[0]
    om = _grid(ref, 1e-3)
    if angles is not None and len(systems):
        cols, cmap = _angle_colors(angles)
        for sys, c in zip(systems, cols):
            G = LN.response(sys, om)
            ax.plot(G.real, G.imag, color=c, lw=0.8)
            ax.plot(G.real, -G.imag, color=c, lw=0.5, ls=":")
        _colorbar(fig, ax, cmap)
    if nominal is not None:
        G = LN.response(nominal, om)
        ax.plot(G.real, G.imag, color="k", lw=1.6, label="L, ω > 0 (operating point)")
        ax.plot(G.real, -G.imag, color="k", lw=0.8, ls=":", label="ω < 0")
    ax.plot([-1.0], [0.0], "r+", ms=12, mew=2, label="−1")
    th = np.linspace(0, 2 * np.pi, 200)
    ax.plot(np.cos(th), np.sin(th), color="0.5", lw=0.7, ls="--", label="|L| = 1")
    if margins is not None and math.isfinite(margins.Ms) and margins.Ms > 0:
        r = 1.0 / margins.Ms
        ax.plot(-1 + r * np.cos(th), r * np.sin(th), color="tab:red", lw=0.8,
                label=f"|1 + L| = 1/peak|S| = {r:.3g}")
    ax.set_xlim(-1 - span, 1 + 0.5 * span)
    ax.set_ylim(-span, span)
    ax.set_aspect("equal")
    ax.set_xlabel("Re L")
    ax.set_ylabel("Im L")
    ax.legend(loc="lower right")
    if title:
        ps.suptitle(fig, title, fontsize=10.5)
    return save(fig, path)


def poles(groups, path, title=""):
    """s-plane poles (discrete poles mapped by ln z / T): ``groups`` = list of (label, poles,
    style dict, colours or None); symmetric-log axes (fast digital poles and slow ones)."""
    fig, ax = ps.new(1, 1, figsize=(8.0, 6.0))
    allp = []
    for label, pl, style, colors in groups:
        pl = np.asarray(pl, dtype=complex)
        if not len(pl):
            continue
        allp.append(pl)
        kw = dict(style)
        if colors is not None:
            kw["c"] = colors
        ax.scatter(pl.real, pl.imag, label=label, **kw)
    ax.axvline(0.0, color="0.3", lw=0.8)
    ax.axhline(0.0, color="0.3", lw=0.5)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_yscale("symlog", linthresh=1.0)
    if allp:
        p = np.concatenate(allp)
        im = max(1.0, float(np.max(np.abs(p.imag))))
        ax.set_ylim(-2.0 * im, 2.0 * im)
        ax.set_xlim(-2.0 * max(1.0, float(np.max(-p.real, initial=0.0))), 2.0 * max(1.0, float(np.max(p.real, initial=0.0))))
    ax.set_xlabel(ps.label("Re s", "1/s"))
    ax.set_ylabel(ps.label("Im s", "rad/s"))
    ax.legend(loc="lower right", fontsize=7.5)
    ps.finish(fig, title)
    return save(fig, path)


def plant_agreement(red, mb, path, mb_model=None, title=""):
    """Plant V → q̇: the reduced model against the multibody linearisation (input coordinates,
    and the raw MuJoCo coordinates if given), magnitude, phase and relative difference."""
    fig, (am, ap, ad) = ps.new(3, 1, figsize=(8.0, 7.6), sharex=True)
    om = LN.frequency_grid(None, 0.1, 500, 1e4)
    Gr = LN.response(red, om, "qd", "V")
    series = [("reduced J(q) model (analytic Jacobian)", Gr, dict(color="tab:orange", lw=1.2, ls="--"))]
    Gm = LN.response(mb, om, "qd", "V")
    series.append(("multibody (mjd_transitionFD), input coordinates", Gm, dict(color="tab:blue", lw=1.0)))
    if mb_model is not None:
        Gmm = LN.response(mb_model, om, "qd", "V")
        series.append(("multibody, MuJoCo coordinates (frozen-time)", Gmm, dict(color="tab:green", lw=0.9, ls=":")))
    for lab, G, st in series:
        am.semilogx(om, 20 * np.log10(np.abs(G)), label=lab, **st)
        ap.semilogx(om, _unwrap_deg(G), **st)
    ad.loglog(om, np.abs(Gm - Gr) / np.abs(Gr), color="tab:blue", lw=1.0, label="input coordinates")
    if mb_model is not None:
        ad.loglog(om, np.abs(Gmm - Gr) / np.abs(Gr), color="tab:green", lw=0.9, ls=":", label="MuJoCo coordinates")
    am.set_ylabel(ps.label("|q̇/V|", "dB (rad/s/V)"))
    ap.set_ylabel(ps.label("phase", "deg"))
    ad.set_ylabel("relative difference")
    ad.set_xlabel(ps.label("frequency ω", "rad/s"))
    am.legend(loc="lower left", fontsize=7.5)
    ad.legend(loc="upper right", fontsize=7.5)
    ps.finish(fig, title)
    return save(fig, path)


def family_figures(objs, out, name):
    """bode.png, nyquist.png, poles.png (and plant.png) of a :func:`mjbench.linear.study`."""
    import os

    paths = []
    fam = objs.get("family")
    lp, mg = objs.get("loop"), objs.get("margins")
    op = objs["op"]
    at = f"q* = {op.q:.3g} rad, q̇* = {op.qd:.4g} rad/s" + (f", t = {op.t:g} s" if op.t else "")
    if lp is not None:
        Ls = [x.L for x in fam.loops] if fam is not None else []
        ang = fam.angles if fam is not None else None
        paths.append(bode(Ls, os.path.join(out, "bode.png"), ang, lp.L, margins=mg,
                          title=f"{name}: loop at the plant input, frozen-angle family ({at})"))
        paths.append(nyquist(Ls, os.path.join(out, "nyquist.png"), ang, lp.L, margins=mg,
                             title=f"{name}: Nyquist plot of L ({at})"))
        groups = [("plant (reduced, continuous)", LN.s_poles(objs["plant_reduced"]), dict(marker="x", color="tab:orange", s=40), None)]
        if "plant_multibody_loop" in objs:
            groups.append(("plant (multibody, mjd_transitionFD)", LN.s_poles(objs["plant_multibody_loop"]),
                           dict(marker="+", color="tab:blue", s=50), None))
        if fam is not None:
            cols, _ = _angle_colors(fam.angles)
            pts, cs = [], []
            for x, c in zip(fam.loops, cols):
                p = LN.s_poles(x.feedback)
                pts.extend(p)
                cs.extend([c] * len(p))
            groups.append(("closed loop, frozen angles", pts, dict(marker="o", s=12, alpha=0.8), cs))
        groups.append(("closed loop, operating point", LN.s_poles(lp.feedback),
                       dict(marker="o", facecolors="none", edgecolors="k", s=60), None))
        paths.append(poles(groups, os.path.join(out, "poles.png"), title=f"{name}: poles (s = ln z / T)"))
    else:
        qs, plants = objs.get("plant_family", (None, []))
        paths.append(bode([p["qd", "V"] for p in plants], os.path.join(out, "bode.png"), qs,
                          objs["plant_reduced"]["qd", "V"], ylabel="plant q̇/V", margins=None,
                          title=f"{name}: open loop — plant q̇/V at frozen angles ({at})"))
        paths.append(poles([("plant (reduced)", LN.s_poles(objs["plant_reduced"]), dict(marker="x", color="tab:orange", s=40), None)],
                           os.path.join(out, "poles.png"), title=f"{name}: plant poles"))
    if "plant_multibody_input" in objs:
        paths.append(plant_agreement(objs["plant_reduced_full"] if "plant_reduced_full" in objs else objs["plant_reduced"],
                                     objs["plant_multibody_input"], os.path.join(out, "plant.png"),
                                     objs.get("plant_multibody"),
                                     title=f"{name}: plant q̇/V, reduced vs multibody ({at})"))
    return paths


# ============================================================================ several motors
def multi_figures(objs, out, name):
    """The figures of a machine with several motors (:func:`mjbench.linear.multi.study_n`):
    bode.png (each axis's loop at a time), sigma.png (singular values of S and T, ‖S‖∞),
    poles.png, plant.png (every q̇_k/V_j, reduced and multibody)."""
    import os

    paths = []
    op, lp, mg = objs["op"], objs.get("loop"), objs.get("margins")
    labels = list(op.labels)
    at = f"t = {op.t:.4g} s on the path" if op.source.startswith("the path") else op.source
    if lp is not None:
        fig, (am, ap) = ps.new(2, 1, figsize=(8.6, 6.6), sharex=True, layout="constrained")
        om = _grid(next(iter(lp.at_a_time.values())))
        txt = []
        for k, (lab, Lk) in enumerate(lp.at_a_time.items()):
            G = LN.response(Lk, om)
            m = mg["loop_at_a_time"][lab]
            am.semilogx(om, 20 * np.log10(np.abs(G)), color=f"C{k}", label=f"axis {lab}")
            ap.semilogx(om, _unwrap_deg(G, om, m["w_gain_crossover_rad_s"]), color=f"C{k}")
            txt.append(f"{lab}: GM {_fmt(m['gain_margin_dB'])} dB, PM {_fmt(m['phase_margin_deg'])}°, "
                       f"peak |S| {_fmt(m['peak_sensitivity'])}")
        am.axhline(0.0, color="0.4", lw=0.8, ls=":")
        ap.axhline(-180.0, color="0.4", lw=0.8, ls=":")
        am.text(0.99, 0.97, "\n".join(txt), transform=am.transAxes, ha="right", va="top", fontsize=8,
                bbox=dict(boxstyle="round", fc="white", ec="0.7"))
        am.set_ylabel(ps.label("|L_k|, one loop broken, the others closed", "dB"))
        ap.set_ylabel(ps.label("phase", "deg"))
        ap.set_xlabel(ps.label("frequency ω", "rad/s"))
        am.legend(loc="lower left")
        ps.finish(fig, f"{name}: each axis's loop at its plant input, the other loops closed ({at})")
        paths.append(save(fig, os.path.join(out, "bode.png")))

        fig, ax = ps.new(1, 1, figsize=(8.6, 5.0))
        svS, svT = LM.sigma_curves(lp.S, om), LM.sigma_curves(lp.T, om)
        for i in range(svS.shape[1]):
            ax.semilogx(om, 20 * np.log10(svS[:, i]), color="tab:red", lw=1.4 if i == 0 else 0.9,
                        ls="-" if i == 0 else "--", label="σ(S), sensitivity" if i == 0 else None)
            ax.semilogx(om, 20 * np.log10(svT[:, i]), color="tab:blue", lw=1.4 if i == 0 else 0.9,
                        ls="-" if i == 0 else "--", label="σ(T), complementary" if i == 0 else None)
        ax.axhline(0.0, color="0.4", lw=0.8, ls=":")
        ax.plot([mg["w_mimo_sensitivity_peak_rad_s"]], [20 * np.log10(mg["mimo_sensitivity_peak"])], "o",
                color="tab:red", label=f"‖S‖∞ = {mg['mimo_sensitivity_peak']:.3g} at "
                                       f"{mg['w_mimo_sensitivity_peak_rad_s']:.4g} rad/s")
        ax.set_xlabel(ps.label("frequency ω", "rad/s"))
        ax.set_ylabel(ps.label("singular values (solid: largest)", "dB"))
        ax.legend(loc="lower left", fontsize=8)
        ps.finish(fig, f"{name}: MIMO sensitivity and complementary sensitivity at the plant inputs ({at})")
        paths.append(save(fig, os.path.join(out, "sigma.png")))
    groups = [("plant (reduced, continuous)", LN.s_poles(objs["plant_reduced"]),
               dict(marker="x", color="tab:orange", s=40), None)]
    if "plant_multibody_input" in objs:
        groups.append(("plant (multibody, mjd_transitionFD)", LN.s_poles(objs["plant_multibody_input"]),
                       dict(marker="+", color="tab:blue", s=50), None))
    if lp is not None:
        groups.append(("closed loop", LN.s_poles(lp.feedback), dict(marker="o", facecolors="none", edgecolors="k",
                                                                    s=60), None))
    paths.append(poles(groups, os.path.join(out, "poles.png"), title=f"{name}: poles (s = ln z / T; {at})"))
    if "plant_multibody_input" in objs:
        red, mb = objs["plant_reduced"], objs["plant_multibody_input"]
        fig, (am, ad) = ps.new(2, 1, figsize=(8.6, 6.8), sharex=True)
        om = LN.frequency_grid(None, 0.1, 400, 1e4)
        ins = list(red.input_labels)
        for i, lab in enumerate(labels):
            for j, u in enumerate(ins):
                Gr = LN.response(red, om, f"qd_{lab}", u)
                Gm = LN.response(mb, om, f"qd_{lab}", u)
                col = f"C{i * len(ins) + j}"
                am.semilogx(om, 20 * np.log10(np.abs(Gr)), color=col, ls="--", lw=1.2, label=f"q̇_{lab}/{u} reduced")
                am.semilogx(om, 20 * np.log10(np.abs(Gm)), color=col, lw=0.8, label=f"q̇_{lab}/{u} multibody")
                Gs = np.maximum(np.abs(Gr), 1e-300)
                ad.loglog(om, np.abs(Gm - Gr) / np.maximum(Gs, np.abs(LN.response(red, om, f"qd_{labels[j]}", u))),
                          color=col, lw=0.9, label=f"q̇_{lab}/{u}")
        am.set_ylabel(ps.label("|q̇/V|", "dB (rad/s/V)"))
        ad.set_ylabel("|Δ| / largest |q̇/V| of the input")
        ad.set_xlabel(ps.label("frequency ω", "rad/s"))
        am.legend(loc="lower left", fontsize=6.5, ncol=2)
        ad.legend(loc="upper right", fontsize=6.5, ncol=2)
        ps.finish(fig, f"{name}: plant, reduced n×n model vs MuJoCo (mjd_transitionFD, input coordinates; {at})")
        paths.append(save(fig, os.path.join(out, "plant.png")))
    return paths
