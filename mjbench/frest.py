"""Frequency response of the nonlinear machine (docs/bridges.md §3): Simulink's ``frestimate``.

The running machine — mechanism, drive, drive train, controller, on either backend — is held at an
operating point (q*, q̇*, t*) and excited by a disturbance d added to the controller's output
(the plant input, voltage; the current reference with a current loop): a **multisine** (equal
amplitudes, Schroeder phases, on the harmonics of one period, log-spaced) or a **stepped sine**.
The excitation goes through the real kernel: :class:`Excited` wraps the mode's controller, so the
sensor, the limiter, the delay, PWM, backlash and friction all act on it.

Estimation.  Two runs from the same state — excited and not — are subtracted (Δ = excited −
baseline): what the machine does by itself (the start from the operating point, a linkage's
angle-periodic speed fluctuation) cancels, what is left is the response to d.  After ``settle``
seconds the per-period spectra at the excited lines give

* the sensitivity S = ΔV/d (V: the plant input the kernel records) and the loop L = 1/S − 1,
  broken where d enters (L = −C·P at the plant input, as :func:`mjbench.linear.loop`);
* the plant P = Δq̇/ΔV (crank speed over plant input);
* per line, the coherence γ² of Δq̇ and ΔV with d over the periods (1: the same response every
  period; < 1: noise, chattering, nonlinear distortion) and the distortion ratio (the RMS of the
  non-excited lines relative to the excited ones).

All of it as python-control ``FrequencyResponseData``; gain/phase margins and peak |S| read from the
measured loop (crossings interpolated between lines).  The linearisation of the same machine at
the same point (:mod:`mjbench.linear`: the co-step plant lifted to the control period, the
controller's discrete counterpart) is evaluated at the same lines; for an angle-dependent linkage
also the frozen-angle family (mean and envelope).  ``max_rel_diff_vs_linear`` is max |G − G_lin| /
|G_lin| over the frozen-angle band (where the frozen picture holds: above 10 × the inertia
variation rate max|J'·q̇*|/J_tot; the platforms: everywhere).
"""
from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from controllers.base import Controller

from .errors import ParameterError

SIGNALS = ("multisine", "sine")
DRIVETRAIN = ("pwm", "encoder", "sensor", "gear", "friction", "current_loop")


# ============================================================================ excitation
class Excited(Controller):
    """The mode's controller plus a disturbance sequence: u = C(t, y) + d[k] at control sample k
    (the kernel then limits, delays and applies u as for any controller)."""

    type_name = "excited"

    def __init__(self, inner, d, T):
        inner = copy.deepcopy(inner)  # its own state (a shallow copy would share the law's state array)
        if not float(getattr(inner, "period", 0.0) or 0.0):
            inner.period = float(T)  # sampled every co-step, with its parameters for that period
        inner.reset()
        self.inner, self.d, self.T = inner, np.asarray(d, dtype=float), float(T)
        self.period = float(T)
        self.kp_ramp = False

    @classmethod
    def from_params(cls, params, drive=None, mechanism=None, scenario=None):  # pragma: no cover - not a mode
        raise ParameterError("the frequency-response excitation is not a scenario mode")

    def reset(self):
        self.inner.reset()

    def __call__(self, t, y):
        k = int(round(t / self.T))
        return float(self.inner(t, y)) + (float(self.d[k]) if k < len(self.d) else 0.0)


def multisine(N: int, lines, amplitude: float) -> np.ndarray:
    """One period of N samples: Σ_k cos(2π·k·n/N + φ_k) over the harmonic ``lines`` with Schroeder
    phases φ_k = −π·i(i+1)/K, scaled to the peak ``amplitude``."""
    n = np.arange(N)
    K = len(lines)
    x = np.zeros(N)
    for i, k in enumerate(lines):
        x += np.cos(2 * np.pi * k * n / N - np.pi * i * (i + 1) / K)
    return amplitude * x / np.max(np.abs(x))


def harmonic_lines(f0: float, f_lo: float, f_hi: float, n: int, avoid=()) -> np.ndarray:
    """Up to n distinct harmonic indices k (frequency k·f0) log-spaced over [f_lo, f_hi], skipping
    the indices in ``avoid`` (the rotation's harmonics of a linkage)."""
    k_lo, k_hi = max(1, int(math.ceil(f_lo / f0))), max(1, int(math.floor(f_hi / f0)))
    if k_hi < k_lo:
        raise ParameterError(f"frest: the band {f_lo:g}-{f_hi:g} Hz holds no harmonic of the period's {f0:g} Hz; "
                             f"widen --band or lengthen the period")
    cand = np.unique(np.round(np.logspace(math.log10(k_lo), math.log10(k_hi), 4 * n)).astype(int))
    bad = set(int(a) for a in avoid)
    cand = np.array([k for k in cand if k not in bad], dtype=int)
    if len(cand) == 0:
        raise ParameterError(f"frest: no free harmonic of {f0:g} Hz in {f_lo:g}-{f_hi:g} Hz (the rotation's harmonics "
                             f"take them all): lengthen --period or widen --band")
    if len(cand) > n:
        cand = cand[np.unique(np.round(np.linspace(0, len(cand) - 1, n)).astype(int))]
    return cand


# ============================================================================ operating point
def hold_machine(mach, op, h):
    """The machine held at ``op``: K_p·t frozen at t*, the reference replaced by a constant speed
    q̇* through q* (offset so the controller outputs V* there, as :func:`mjbench.linear.step_check`),
    started in the operating point's state."""
    from controllers.reference import ConstantSpeed

    ctrl = copy.copy(mach.controller)
    z = float(mach.drive.z)
    tn = getattr(ctrl, "type_name", "")
    if getattr(ctrl, "kp_ramp", False):
        ctrl.kp = float(np.asarray(ctrl.gain_p(op.t)))
        ctrl.kp_ramp = False
    if getattr(ctrl, "reference", None) is not None:
        q_off = 0.0
        if tn == "pid" and float(ctrl.ki):
            q_off = op.V / (float(ctrl.ki) * z)
        elif tn == "servo":
            rest = op.V - float(ctrl.kffv) * z * op.qd
            q_off = rest / (float(ctrl.kvp) * float(ctrl.kpp) * z) if rest else 0.0
        ctrl.reference = ConstantSpeed(z * op.qd, phi0=z * (op.q + q_off))
    ctrl.reset()
    return dataclasses.replace(mach, controller=ctrl, q0=op.q, qd0=op.qd, I0=op.I, x0=op.x or None,
                               xd0=op.xd or None)


# ============================================================================ estimation
def _spectra(x, N, P, lines):
    """(P, len(lines)) complex DFT coefficients of the last P periods of N samples."""
    seg = np.asarray(x, dtype=float)[-P * N:].reshape(P, N)
    return np.fft.rfft(seg, axis=1)[:, lines]


def coherence(X, Y) -> np.ndarray:
    """γ² per line of Y with the excitation X over the periods (rows)."""
    num = np.abs(np.sum(Y * np.conj(X), axis=0)) ** 2
    den = np.sum(np.abs(X) ** 2, axis=0) * np.sum(np.abs(Y) ** 2, axis=0)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def margins_from_frd(omega, L) -> dict:
    """Gain/phase margins and peak |S| of a measured loop L(jω) (crossings interpolated linearly in
    log ω between measured lines; peak |S| over the lines)."""
    w = np.asarray(omega, dtype=float)
    L = np.asarray(L, dtype=complex)
    mag, ph = np.abs(L), np.unwrap(np.angle(L))
    pm, wgc = math.inf, float("nan")
    for i in np.flatnonzero(np.sign(mag[:-1] - 1.0) != np.sign(mag[1:] - 1.0)):
        a = (0.0 - math.log(mag[i])) / (math.log(mag[i + 1]) - math.log(mag[i]))
        p = math.degrees(ph[i] + a * (ph[i + 1] - ph[i])) + 180.0
        p = (p + 180.0) % 360.0 - 180.0
        if abs(p) < abs(pm):
            pm, wgc = p, float(math.exp(math.log(w[i]) + a * (math.log(w[i + 1]) - math.log(w[i]))))
    gm, wpc = math.inf, float("nan")
    d = (np.degrees(ph) + 180.0) / 360.0  # crossings of −180° (mod 360)
    for i in range(len(w) - 1):
        k0, k1 = math.floor(d[i]), math.floor(d[i + 1])
        if k0 != k1:
            target = max(k0, k1)
            a = (target - d[i]) / (d[i + 1] - d[i])
            m = math.exp(math.log(mag[i]) + a * (math.log(mag[i + 1]) - math.log(mag[i])))
            g = -20.0 * math.log10(m)
            if m < 1.0 and g < gm:
                gm, wpc = g, float(math.exp(math.log(w[i]) + a * (math.log(w[i + 1]) - math.log(w[i]))))
    s = np.abs(1.0 / (1.0 + L))
    k = int(np.argmax(s))
    return {"gain_margin_dB": gm, "w_phase_crossover_rad_s": wpc, "phase_margin_deg": pm,
            "w_gain_crossover_rad_s": wgc, "peak_sensitivity": float(s[k]), "w_peak_sensitivity_rad_s": float(w[k])}


def compare(G, G_lin, band_mask) -> dict:
    """Relative, magnitude and phase differences of a measured response against a linear one over
    the lines in ``band_mask``."""
    m = np.asarray(band_mask, dtype=bool)
    if not m.any():
        return {"max_rel_diff": None, "max_mag_diff": None, "max_phase_diff_deg": None}
    r = np.abs(G - G_lin) / np.abs(G_lin)
    mag = np.abs(np.abs(G) / np.abs(G_lin) - 1.0)
    ph = np.abs(np.degrees(np.angle(G / G_lin)))
    return {"max_rel_diff": float(np.max(r[m])), "max_mag_diff": float(np.max(mag[m])),
            "max_phase_diff_deg": float(np.max(ph[m]))}


# ============================================================================ the measurement
def _simulate(mach, backend, t_end, h, T, scn):
    from .backends import simulate
    from .runner import backend_options

    o = backend_options(scn, backend)
    return simulate(mach, backend, t_end, record_dt=T, options=o)


def measure(scn, mode=None, q=None, qd=None, I=None, t=None, backend="reduced", signal="multisine",
            amplitude=None, band=None, period=None, periods=3, settle=None, n_lines=30, linear=True,
            n_angles=12) -> dict:
    """Measure the plant and loop responses of ``scn``'s ``mode`` at an operating point (module doc).

    ``q``, ``qd`` [rad, rad/s]: the point (default: the initial angle, the controller's running
    speed); ``t`` [s]: K_p·t frozen there (default: simulation.t_end for a K_p·t PID); ``amplitude``
    [V]: the excitation's peak (default: 2 % of max(|V*|, 1 V), at most 10 % of the voltage headroom);
    ``band`` (lo, hi) [rad/s]; ``period`` [s] of the multisine (default 0.5 s, a whole number of
    crank turns for a running linkage); ``periods`` measured after ``settle`` [s] (default: 7 time
    constants of the slowest linear closed-loop pole, 0.5–12 s).  Returns {"json": plain data,
    "frd": python-control FRD objects, "lines_rad_s", ...}."""
    from . import linear as LN
    from . import scenario as S
    from .kernel import control_every

    if signal not in SIGNALS:
        raise ParameterError(f"--signal {signal!r}: choose one of {', '.join(SIGNALS)}")
    if backend not in ("reduced", "multibody"):
        raise ParameterError(f"--backend {backend!r}: choose reduced or multibody")
    mode = scn.mode(mode)
    mach = S.make_machine(scn, mode)
    ctrl = mach.controller
    h = float(scn.simulation.dt)
    N_every = control_every(ctrl, h)
    T = N_every * h
    tn = getattr(ctrl, "type_name", "")
    ramp = bool(getattr(ctrl, "kp_ramp", False))
    if t is None:
        t = float(scn.simulation.t_end) if ramp else 0.0
    q = float(scn.initial.q0) if q is None else float(q)
    qd = LN.running_speed(mach, q) if qd is None else float(qd)
    # the operating point and the linearisation: the ideal drive (the drive-train elements — PWM,
    # encoder, backlash, friction, current loop — have no linear model; what they change is measured)
    train = [k for k in DRIVETRAIN if getattr(scn.drive, k, None) is not None]
    scn_lin = scn
    if train:
        raw = copy.deepcopy(scn.raw)
        for k in train:
            raw.get("drive", {}).pop(k, None)
        scn_lin = S.from_raw(raw, scn.source)
    mach_lin = S.make_machine(scn_lin, mode)
    op = LN.operating_point(mach_lin, q, qd, I, t)
    held = hold_machine(mach, op, h)
    held_lin = hold_machine(mach_lin, op, h)
    z = float(mach.drive.z)
    notes = [f"linearisation of the ideal drive: drive.{', drive.'.join(train)} have no linear model"] if train else []
    # ---- the linear machine at the point (same held machine)
    lin = {"loop": None, "plant": None, "family": None, "note": ""}
    angle = "frozen" if op.qd != 0.0 else "state"
    if linear:
        try:
            p_h = (LN.reduced_plant(held_lin, op, h, angle=angle) if backend == "reduced" else
                   LN.multibody_plant(held_lin, op, scn.multibody_options(), h, coordinates="input", angle=angle))
            lin["plant"] = LN.sample(p_h, N_every)
            if tn != "open":
                lp, mg = LN.analyse(held_lin, op, h, backend, scn.multibody_options(), angle=angle)
                lin["loop"], lin["margins"] = lp, mg
        except ParameterError as e:
            lin["note"] = str(e)
    # ---- how long to settle
    if settle is None:
        settle = 1.0
        fb = getattr(lin.get("loop"), "feedback", None)
        if fb is not None:
            pz = np.asarray(fb.poles(), dtype=complex)
            pz = pz[np.abs(pz) > 0]
            if len(pz):
                s = np.log(pz) / T
                slow = float(np.min(-s.real[s.real < 0])) if np.any(s.real < 0) else 0.0
                settle = 7.0 / slow if slow > 0 else 4.0
        settle = float(min(12.0, max(0.5, settle)))
    # ---- period and lines
    rigid = len(S.make_mechanism(scn).internal) == 0
    if period is None:
        period = 0.5
        if rigid and op.qd != 0.0:  # a running linkage: a whole number of turns per period
            T_rot = 2 * math.pi / abs(op.qd)
            period = max(2, round(period / T_rot)) * T_rot  # ≥ 2 turns: free lines between its harmonics
    N = int(round(period / T))
    period = N * T
    f0 = 1.0 / period
    nyq = 0.5 / T
    lo, hi = band if band is not None else (2 * math.pi * f0, min(2 * math.pi * 0.25 * nyq, 2 * math.pi * 500.0))
    rot_bins = []
    notes_period = ""
    turns = period * abs(op.qd) / (2 * math.pi)
    if op.qd != 0.0 and rigid and round(turns) >= 2 and abs(turns - round(turns)) < 1e-3:
        # a whole number of turns per period: the rotation's harmonics fall on lines, left out
        rot_bins = [int(round(m * turns)) for m in range(1, int(N / 2 / turns) + 1)]
        if signal == "multisine":
            notes_period = (f"angle-periodic machine ({turns:.0f} turns per period): an output line k also carries "
                            f"the response to the excited lines k ± m·{turns:.0f} (harmonic transfer), so a multisine's "
                            f"lines couple; --signal sine measures each frequency alone")
    elif op.qd != 0.0 and rigid:
        notes_period = (f"the period {period:g} s is not a whole number of turns ({turns:.3g}): the angle-periodic "
                        f"fluctuation leaks into the excited lines")
    if amplitude is None:
        vmax = float(mach.drive.v_max)
        amplitude = 0.02 * max(abs(op.V), 1.0)
        if math.isfinite(vmax):
            amplitude = min(amplitude, 0.1 * max(vmax - abs(op.V), 0.0)) or 0.02 * vmax
    amplitude = float(amplitude)
    nset = int(math.ceil(settle / period))
    P = int(periods)
    if signal == "multisine":
        lines = harmonic_lines(f0, lo / (2 * math.pi), hi / (2 * math.pi), n_lines, rot_bins)
        one = multisine(N, lines, amplitude)
        runs = [(np.tile(one, nset + P), lines, N)]
        t_end = (nset + P) * period
    else:
        lines = harmonic_lines(f0, lo / (2 * math.pi), hi / (2 * math.pi), n_lines, rot_bins)
        runs = []
        for k in lines:
            n = np.arange((nset + P) * N)
            runs.append((amplitude * np.sin(2 * np.pi * k * n / N), np.array([k]), N))
        t_end = (nset + P) * period
    # ---- baseline and excited runs through the kernel
    base = _simulate(dataclasses.replace(held, controller=Excited(held.controller, [], T)), backend, t_end, h, T, scn)
    Dl, Vl, Yl, Cv, Cy, Dist, Sat = [], [], [], [], [], [], []
    vlim = float(mach.drive.v_max)
    meta = {"loop": base.meta.get("loop"), "loop_reason": base.meta.get("loop_reason")}
    for d, ks, NN in runs:
        ex = _simulate(dataclasses.replace(held, controller=Excited(held.controller, d, T)), backend, t_end, h, T, scn)
        n = min(len(ex.t), len(base.t), len(d))
        dV = ex.voltage[:n] - base.voltage[:n]
        if math.isfinite(vlim):
            Sat.append(float(np.mean(np.abs(ex.voltage[:n]) >= 0.999 * vlim)))
        dY = ex.qd[:n] - base.qd[:n]
        D = _spectra(d[:n], NN, P, ks)
        V = _spectra(dV, NN, P, ks)
        Y = _spectra(dY, NN, P, ks)
        Dl.append(D.mean(axis=0))
        Vl.append(V.mean(axis=0))
        Yl.append(Y.mean(axis=0))
        Cv.append(coherence(D, V))
        Cy.append(coherence(D, Y))
        full = np.abs(np.fft.rfft(np.asarray(dY[-P * NN:]).reshape(P, NN), axis=1)).mean(axis=0)
        mask = np.zeros(len(full), dtype=bool)
        mask[ks] = True
        mask[0] = True
        Dist.append(float(np.sqrt(np.mean(full[~mask] ** 2)) / np.sqrt(np.mean(full[ks] ** 2))))
    if notes_period:
        notes.append(notes_period)
    D, V, Y = (np.concatenate(a) for a in (Dl, Vl, Yl))
    coh_v, coh_y = np.concatenate(Cv), np.concatenate(Cy)
    omega = 2 * np.pi * f0 * np.asarray(lines, dtype=float)
    Sm = V / D
    Pm = Y / V
    closed = tn != "open"
    Lm = 1.0 / Sm - 1.0 if closed else None
    # ---- linear overlay and comparison band
    from .linear import response

    P_lin = response(lin["plant"], omega, "qd", "V") if lin["plant"] is not None else None
    L_lin = response(lin["loop"].L, omega) if lin["loop"] is not None else None
    mech = held_lin.mechanism
    Jq, dJ, _ = mech.reduced(np.linspace(0, 2 * np.pi, 72, endpoint=False))
    Jt = float(held_lin.drive.J_eq) + np.asarray(Jq, dtype=float)
    rate = float(np.max(np.abs(np.asarray(dJ, dtype=float) * op.qd) / Jt))
    band_lo = max(float(omega[0]), 10.0 * rate)
    in_band = omega >= band_lo * (1 - 1e-12)
    fam = None
    if linear and rate > 0 and closed and lin["loop"] is not None:
        try:
            F = LN.frozen_angle_family(held_lin, h, n_angles, speed=op.qd, t=op.t, plant_kind="reduced", angle="frozen")
            Ls = np.array([response(lp_.L, omega) for lp_ in F.loops])
            Ps = np.array([response(lp_.plant, omega, "qd", "V") for lp_ in F.loops])
            fam = {"angles_rad": F.angles, "L": Ls, "P": Ps}
        except Exception as e:  # noqa: BLE001 - the family is an overlay only
            notes.append(f"frozen-angle family not computed: {e}")
    ct = LN._ct()
    frd = {"plant": ct.frd(Pm, omega, name="plant_measured"), "S": ct.frd(Sm, omega, name="S_measured")}
    if closed:
        frd["loop"] = ct.frd(Lm, omega, name="L_measured")
    js = {"scenario": scn.name, "mode": mode, "controller": tn, "backend": backend, "signal": signal,
          "operating_point": op.as_dict(), "co_step_s": h, "control_period_s": T, "amplitude_V": amplitude,
          "period_s": period, "periods": P, "settle_s": nset * period, "n_runs": len(runs) + 1,
          "lines_rad_s": omega, "drivetrain": bool(getattr(held.drive, "train", None)),
          "band_rad_s": [float(band_lo), float(omega[-1])],
          "band_note": ("constant inertia: the frozen-angle model is exact over the whole band" if rate == 0 else
                        f"frozen-angle band: above 10 × the inertia variation rate max|J'·q̇*|/J_tot = {rate:.4g} 1/s"),
          "inertia_rate_1_s": rate,
          "plant": {"re": Pm.real, "im": Pm.imag, "coherence": np.minimum(coh_v, coh_y)},
          "distortion_ratio": float(max(Dist)),
          "limiter_active_fraction": float(max(Sat)) if Sat else 0.0, "loop_meta": meta, "notes": notes + ([lin["note"]] if lin["note"] else [])}
    if closed:
        js["loop"] = {"re": Lm.real, "im": Lm.imag, "coherence": coh_v, "margins": margins_from_frd(omega, Lm)}
        js["sensitivity"] = {"re": Sm.real, "im": Sm.imag}
    cmp = {}
    if P_lin is not None:
        cmp["plant"] = compare(Pm, P_lin, in_band)
        js["plant"]["linear"] = {"re": P_lin.real, "im": P_lin.imag}
    if L_lin is not None and closed:
        cmp["loop"] = compare(Lm, L_lin, in_band)
        js["loop"]["linear"] = {"re": L_lin.real, "im": L_lin.imag}
        js["loop"]["margins_linear"] = lin["margins"].as_dict()
    if fam is not None:
        Lmean, Pmean = fam["L"].mean(axis=0), fam["P"].mean(axis=0)
        cmp["loop_vs_family_mean"] = compare(Lm, Lmean, np.ones(len(omega), bool))
        cmp["plant_vs_family_mean"] = compare(Pm, Pmean, np.ones(len(omega), bool))
        inside = (np.abs(Pm) >= np.abs(fam["P"]).min(axis=0) * 0.99) & (np.abs(Pm) <= np.abs(fam["P"]).max(axis=0) * 1.01)
        js["frozen_family"] = {"n_angles": len(fam["angles_rad"]), "plant_inside_envelope_fraction": float(inside.mean()),
                               "plant_mag_min": np.abs(fam["P"]).min(axis=0), "plant_mag_max": np.abs(fam["P"]).max(axis=0)}
    js["comparison"] = cmp
    vals = [c["max_rel_diff"] for k, c in cmp.items() if k in ("plant", "loop") and c["max_rel_diff"] is not None]
    js["max_rel_diff_vs_linear"] = max(vals) if vals else None
    return {"json": LN.plain(js), "frd": frd, "omega": omega, "P": Pm, "L": Lm, "S": Sm, "P_lin": P_lin,
            "L_lin": L_lin, "coherence": np.minimum(coh_v, coh_y), "family": fam, "in_band": in_band}


def figure(res, path, title=""):
    """Bode plot of the measured plant and loop (dots) with the linearisation (line), the frozen-angle
    envelope (band) and the coherence."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    w = res["omega"]
    rows = [("plant q̇/V", res["P"], res["P_lin"], "P")]
    if res["L"] is not None:
        rows.append(("loop L at the plant input", res["L"], res["L_lin"], "L"))
    fig, ax = plt.subplots(3, len(rows), figsize=(6 * len(rows), 8), squeeze=False, sharex=True)
    for j, (name, G, Gl, key) in enumerate(rows):
        ax[0, j].loglog(w, np.abs(G), "o", ms=3, label="measured (nonlinear machine)")
        ax[1, j].semilogx(w, np.degrees(np.unwrap(np.angle(G))), "o", ms=3)
        if Gl is not None:
            ax[0, j].loglog(w, np.abs(Gl), "-", lw=1, label="linearisation")
            ax[1, j].semilogx(w, np.degrees(np.unwrap(np.angle(Gl))), "-", lw=1)
        fam = res.get("family")
        if fam is not None:
            F = fam[key]
            ax[0, j].fill_between(w, np.abs(F).min(axis=0), np.abs(F).max(axis=0), alpha=0.2,
                                  label="frozen-angle family")
        ax[0, j].set_title(name)
        ax[0, j].legend(fontsize=7)
        ax[1, j].set_ylabel("phase [deg]")
        ax[2, j].semilogx(w, res["coherence"], ".")
        ax[2, j].set_ylim(0, 1.05)
        ax[2, j].set_ylabel("coherence γ²")
        ax[2, j].set_xlabel("ω [rad/s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
