"""Frequency response of the nonlinear machine (docs/bridges.md §3): Simulink's ``frestimate``.

The running machine — mechanism, drive, drive train, controller, on either backend — is held at an
operating point (q*, q̇*, t*) and excited by a disturbance d added to the controller's output
(the plant input, voltage; the current reference with a current loop): a **multisine** (equal
amplitudes, Schroeder phases, on the harmonics of one period, log-spaced) or a **stepped sine**.
The excitation goes through the real kernel: :class:`Excited` wraps the mode's controller, so the
sensor, the limiter, the delay, PWM, backlash and friction all act on it.

A running linkage is periodically time-varying: its inertia J(q) repeats every turn, so a line at ω
also drives the output at ω ± m·Ω (Ω the turn frequency; harmonic transfer functions).  Its period
holds a whole number of turns and its lines are chosen free of each other's sidebands
(:func:`design_lines`, :func:`free_lines`: no two lines a, b with a ∓ b a multiple m·turns of low
order m, where 1/J_tot still has harmonics): each line then measures the response averaged over the
turn, which is compared with the frozen-angle family *followed along the turn* (:func:`along_turn`:
⟨P·S⟩/⟨S⟩ for the plant, 1/⟨S⟩ − 1 for the loop) and, line by line, with its first sidebands.

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
also the frozen-angle family (mean, envelope, along the turn).  ``max_rel_diff_vs_linear`` is max |G − G_lin| /
|G_lin| over the frozen-angle band (where the frozen picture holds: above 10 × the inertia
variation rate max|J'·q̇*|/J_tot; the platforms: everywhere).
"""
from __future__ import annotations

import copy
import dataclasses
import math
from collections import namedtuple

import numpy as np

from . import compiled as C
from .compiled import law
from .control import Controller

from .errors import ParameterError
from .backends import simulate
from .runner import backend_options
from .linear import response
from . import linear as LN
from . import scenario as S
from .kernel import control_every
from .plotstyle import subplots

SIGNALS = ("multisine", "sine")
DRIVETRAIN = ("pwm", "encoder", "sensor", "gear", "friction", "current_loop")

#: the settling check: the lowest line's response (plant input and speed over the excitation) from the
#: measured periods against the same number of periods one period earlier may differ by at most this
#: fraction; otherwise a default settling time is doubled (up to :data:`SETTLE_GROWTH` ×) and the
#: measurement repeated, a settling time given by the caller is kept and the result flagged
SETTLE_TOL = 1e-4
SETTLE_GROWTH = 8

#: a measurement whose voltage limiter is active over more than this fraction of the measured samples
#: is flagged saturated (a describing function of the limiter, not the loop's linear response)
SAT_FRACTION = 0.01

#: the multisine's period holds at least this many control periods (its lines lie below Nyquist)
MIN_PERIOD_SAMPLES = 8


# ============================================================================ excitation
#: the excitation's parameters: the disturbance sequence d (one value per control sample), the control period T [s]
ExcitationP = namedtuple("ExcitationP", "d T")


@law(outputs=("u",))
def excitation(t, u, P, S):
    """u + d[k] at control sample k = round(t/T) (nothing added past the sequence's end): the disturbance
    added to the controller's output ``u``, before the kernel's clip and delay."""
    k = int(round(t / P.T))
    if k < len(P.d):
        return u + P.d[k]
    return u + 0.0


class Excited(Controller):
    """The mode's controller plus a disturbance sequence: u = C(t, y) + d[k] at control sample k
    (the kernel then limits, delays and applies u as for any controller).

    Compiled form: the controller's own form with :func:`excitation` as its child ``"then"`` (a control
    slot of its own, run right after the controller on its axis): a machine whose parts all compile
    is measured on the compiled loop.  A controller without a law runs both in CPython (``__call__``)."""

    type_name = "excited"

    def __init__(self, inner, d, T):
        inner = copy.deepcopy(inner)  # its own state (a shallow copy would share the law's state array)
        if not float(getattr(inner, "period", 0.0) or 0.0):
            inner.period = float(T)  # sampled every co-step, with its parameters for that period
        inner.reset()
        self.inner, self.d, self.T = inner, np.ascontiguousarray(d, dtype=float).reshape(-1), float(T)
        self.period = float(T)
        self.kp_ramp = False
        self._xP = ExcitationP(self.d, self.T)

    @classmethod
    def from_params(cls, params, drive=None, mechanism=None, scenario=None):  # pragma: no cover - not a mode
        raise ParameterError("the frequency-response excitation is not a scenario mode")

    def form(self, T: float, machine):
        fn = getattr(self.inner, "form", None)
        f = fn(T, machine) if fn is not None else None
        if f is None:
            return None
        then = C.Form(excitation, self._xP, what="frequency-response excitation")
        return dataclasses.replace(f, children={**f.children, "then": then})

    def reset(self):
        self.inner.reset()

    def __call__(self, t, y):
        return float(excitation(t, float(self.inner(t, y)), self._xP, C.NO_STATE))


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
    k_lo, k_hi = max(1, int(math.ceil(f_lo / f0 - 1e-9))), int(math.floor(f_hi / f0 + 1e-9))
    if k_hi < k_lo:
        raise ParameterError(f"frest: the band {f_lo:g}-{f_hi:g} Hz holds no harmonic of the period's {f0:g} Hz; "
                             f"widen --band or lengthen the period")
    cand = np.unique(np.round(np.logspace(math.log10(k_lo), math.log10(k_hi), 4 * n)).astype(int))
    bad = set(int(a) for a in avoid)
    cand = np.array([k for k in cand if k not in bad], dtype=int)
    if len(cand) == 0:
        why = " (the rotation's harmonics take them all)" if bad else ""
        raise ParameterError(f"frest: no free harmonic of {f0:g} Hz in {f_lo:g}-{f_hi:g} Hz{why}: lengthen --period "
                             f"or widen --band")
    if len(cand) > n:
        cand = cand[np.unique(np.round(np.linspace(0, len(cand) - 1, n)).astype(int))]
    return cand


#: the harmonics of the inertia along the turn that couple lines (above this fraction of its mean), at most
ORDER_TOL, MAX_ORDER = 1e-4, 32


def rotation_orders(mechanism, J_eq, tol=ORDER_TOL, cap=MAX_ORDER) -> int:
    """Highest harmonic m of 1/J_tot(q) along the turn above ``tol`` of its mean (at most ``cap``; 0:
    constant inertia).  A running linkage is periodically time-varying: its response to a line at ω
    also carries ω ± m·Ω (Ω: the turn frequency; harmonic transfer functions), weighted like the
    harmonics of the inertia the motor sees."""
    q = np.linspace(0.0, 2 * np.pi, 256, endpoint=False)
    J = np.asarray(mechanism.reduced(q)[0], dtype=float) + float(J_eq) + 0.0 * q
    c = np.abs(np.fft.rfft(1.0 / J))
    big = np.flatnonzero(c[1:] > tol * c[0]) + 1
    return int(min(cap, big.max())) if big.size else 0


def collide(a: int, b: int, turns: int, reach: int) -> bool:
    """Whether lines a, b (harmonic indices of a period of ``turns`` turns) meet through the rotation:
    a − b or a + b (b's mirror −b) equal to m·turns with 1 ≤ m ≤ ``reach``."""
    d, s = abs(a - b), a + b
    return (d % turns == 0 and 0 < d <= reach * turns) or (s % turns == 0 and s <= reach * turns)


def free_lines(f0: float, f_lo: float, f_hi: float, n: int, turns: int, orders: int) -> np.ndarray:
    """Up to n harmonic indices of f0 near log-spaced targets over [f_lo, f_hi] for an angle-periodic
    machine with ``turns`` turns per period whose lines carry sidebands k ± m·turns up to m = ``orders``:
    no two lines collide (:func:`collide`) up to reach = orders + 1 (each line's first sidebands are
    measured too), no line on a rotation harmonic (k = m·turns: the machine's own fluctuation) or on
    its own mirror (2k = m·turns, m ≤ reach).  Each target takes the nearest free index within half a
    log step; a target with none is dropped."""
    k_lo, k_hi = max(1, int(math.ceil(f_lo / f0 - 1e-9))), int(math.floor(f_hi / f0 + 1e-9))
    if k_hi < k_lo:
        raise ParameterError(f"frest: the band {f_lo:g}-{f_hi:g} Hz holds no harmonic of the period's {f0:g} Hz; "
                             f"widen --band or lengthen the period")
    reach = int(orders) + 1
    step = (k_hi / k_lo) ** (0.5 / max(n - 1, 1))
    out: list[int] = []
    for t in np.logspace(math.log10(k_lo), math.log10(k_hi), n):
        lo, hi = max(k_lo, int(math.floor(t / step))), min(k_hi, int(math.ceil(t * step)))
        for b in sorted(range(lo, hi + 1), key=lambda b: (abs(b - t), b)):
            if b in out or b % turns == 0 or (2 * b % turns == 0 and 2 * b <= reach * turns):
                continue
            if not any(collide(a, b, turns, reach) for a in out):
                out.append(b)
                break
    if not out:
        raise ParameterError(f"frest: no line of {f0:g} Hz in {f_lo:g}-{f_hi:g} Hz is free of the rotation's "
                             f"harmonics: lengthen --period or widen --band")
    return np.array(sorted(out), dtype=int)


def along_turn(G, angles, q, lags) -> np.ndarray:
    """(len(lags), lines) time-Fourier coefficients over one period of the frozen-angle responses ``G``
    (uniform ``angles`` × lines) followed along the machine's own motion ``q`` (its N samples over one
    period): c_s = (1/N)·Σ_n G(q_n)·e^{−j2π·s·n/N}, G(q) by trigonometric interpolation over the angles.
    Lag 0 is the time average over the turn — what a line measures if the frozen picture holds; lag
    ±turns the first sidebands."""
    G = np.asarray(G, dtype=complex)
    na = G.shape[0]
    m = np.fft.fftfreq(na, 1.0 / na)
    keep = np.abs(m) < na / 2
    Gh = (np.fft.fft(G, axis=0) / na)[keep]
    Gq = np.exp(1j * np.outer(np.asarray(q, dtype=float) - float(angles[0]), m[keep])) @ Gh
    n = np.arange(len(q))
    return np.array([(Gq * np.exp(-2j * np.pi * s * n / len(q))[:, None]).mean(axis=0) for s in lags])


def voltage_limit(drive) -> float:
    """The largest |voltage| the drive applies: ``v_max``, and a PWM amplifier's bus voltage."""
    amp = getattr(getattr(drive, "train", None), "pwm", None)
    return min(float(drive.v_max), float(amp.v_bus)) if amp is not None else float(drive.v_max)


def inertia_rate(mechanism, J_eq, qd) -> float:
    """max|J'(q)·q̇|/J_tot(q) over the turn [1/s]: how fast the inertia changes (0: constant)."""
    J, dJ, _ = mechanism.reduced(np.linspace(0, 2 * np.pi, 72, endpoint=False))
    Jt = float(J_eq) + np.asarray(J, dtype=float)
    return float(np.max(np.abs(np.asarray(dJ, dtype=float) * qd) / Jt))


def periodic_note(turns: int, orders: int) -> str:
    """The note of a running linkage's excitation design (frest.json ``notes``)."""
    return (f"angle-periodic machine: {turns} turns per period; a line at ω also drives ω ± m·Ω (Ω the turn "
            f"frequency, harmonic transfer functions; 1/J_tot has harmonics up to m = {orders} above {ORDER_TOL:g} of its mean), "
            f"so the lines are chosen with no line's sidebands k ± m·{turns} (m ≤ {orders + 1}) on another line or its "
            f"mirror: each line measures the response averaged over the turn (the diagonal H₀(ω)), compared with the "
            f"frozen-angle family followed along the turn (`comparison.*_vs_family_along_turn`, band) and its first "
            f"sidebands ω ± Ω")


def periodic_explanation(js) -> str:
    """How a running linkage's measured response departs from the frozen-angle picture, and why
    (frest.json ``periodic.explanation``; numbers from ``js``'s comparisons over the frozen band)."""
    c, ff = js["comparison"], js.get("frozen_family") or {}

    def pct(key):
        x = (c.get(key) or {}).get("max_rel_diff")
        return "—" if x is None else f"{100 * x:.3g} %"

    coh = min(js["plant"]["coherence"])
    head = ("A running linkage is periodically time-varying (its inertia J(q) and the rates J'(q)·q̇ repeat every "
            "turn): a line at ω drives the output at ω and at ω ± m·Ω (Ω the turn frequency). What a line measures "
            "is the response averaged over the turn — the frozen-angle loops followed along the machine's own "
            "motion, ⟨P·S⟩/⟨S⟩ for the plant and 1/⟨S⟩ − 1 for the loop, not the loop at the operating angle nor "
            "the plain mean of the family over the angles.")
    if coh < 0.9 or js["limiter_active_fraction"] > 0.05:
        return (head + f" Here the response is not a linear one (min γ² {coh:.3g}, {100 * js['limiter_active_fraction']:.0f} % "
                "of the time at the voltage limit): the comparison below does not measure the time variation.")
    sb = ff.get("sidebands") or {}
    side = (f" The first sidebands ω ± Ω carry up to {100 * sb['speed_measured_max_rel']:.3g} % of each line's speed "
            f"response (the frozen family along the turn: {100 * sb['speed_frozen_max_rel']:.3g} %)." if sb else "")
    return (head + f" Over the frozen band the measured plant is {pct('plant')} from the linearisation at the operating "
            f"angle, {pct('plant_vs_family_mean')} from the family's mean over the angles, {pct('plant_vs_family_along_turn')} "
            f"from the family along the turn (loop: {pct('loop')}, {pct('loop_vs_family_mean')}, "
            f"{pct('loop_vs_family_along_turn')})." + side + " The frozen model keeps the angle as a parameter: what "
            "depends on the angle's own perturbation (a position-dependent load's stiffness, an angle-dependent "
            "reference) is in the measurement only.")


def along_turn_prediction(fam, q_turn, turns) -> dict:
    """What the lines of a running linkage measure if the frozen-angle picture holds: the frozen
    family (sensitivity S = 1/(1+L) and d → q̇ response P·S at each angle) followed along the
    baseline's turn ``q_turn`` (one period): S̄ = ⟨S⟩, T̄ = ⟨P·S⟩ over time, so the measured
    plant is T̄/S̄ and the loop 1/S̄ − 1 (not the mean of P or L over the angles); with ``turns``,
    the first sidebands S_±1, T_±1 (lags ±turns)."""
    S_ang = 1.0 / (1.0 + fam["L"])
    T_ang = fam["P"] * S_ang
    lags = [0, turns, -turns] if turns else [0]
    cS = along_turn(S_ang, fam["angles_rad"], q_turn, lags)
    cT = along_turn(T_ang, fam["angles_rad"], q_turn, lags)
    out = {"S": cS[0], "T": cT[0], "P": cT[0] / cS[0], "L": 1.0 / cS[0] - 1.0}
    if turns:
        out["S_side"], out["T_side"] = cS[1:], cT[1:]
    return out


def _lagged(x, N, P, ks, lag):
    """Per-line DFT coefficient at index k + lag, averaged over the last P periods (NaN off the spectrum)."""
    b = np.asarray(ks, dtype=int) + int(lag)
    ok = (b >= 1) & (b <= N // 2)
    out = np.full(len(b), complex(np.nan, np.nan))
    if ok.any():
        out[ok] = _spectra(x, N, P, b[ok]).mean(axis=0)
    return out


def design_lines(T, qd, orders, rate, settle, n_lines, band=None, period=None, running=False):
    """The excitation's period (N samples of the control period T) and lines: (N, lines, turns, note).

    A machine that does not turn (the platforms, a held point): ``n_lines`` log-spaced harmonics of
    a 0.5 s period (:func:`harmonic_lines`).  A running linkage (``running``):
    a whole number of turns per period (``turns``) and lines free of each other's rotation sidebands
    (:func:`free_lines`); the default band starts a decade below the frozen-angle band (10 × ``rate``),
    and of 2 … 4× the shortest period (≥ 2 turns, ≥ 0.5 s), not longer than ``settle``, the first that
    holds 80 % of ``n_lines`` (else the one that holds most)."""
    w_hi = min(2 * math.pi * 0.25 * 0.5 / T, 2 * math.pi * 500.0)

    def lines_for(N, turns):
        f0 = 1.0 / (N * T)
        lo, hi = band if band is not None else (max(2 * math.pi * f0, rate if running else 0.0), w_hi)
        if turns:
            return free_lines(f0, lo / (2 * math.pi), hi / (2 * math.pi), n_lines, turns, orders)
        return harmonic_lines(f0, lo / (2 * math.pi), hi / (2 * math.pi), n_lines)

    if not running:
        N = int(round((0.5 if period is None else period) / T))
        return N, lines_for(N, 0), 0, ""
    T_rot = 2 * math.pi / abs(qd)
    if period is not None:
        N = int(round(period / T))
        x = N * T / T_rot
        turns = int(round(x)) if round(x) >= 1 and abs(x - round(x)) < 1e-3 else 0
        note = "" if turns else (f"the period {N * T:g} s is not a whole number of turns ({x:.3g}): the angle-periodic "
                                 f"fluctuation and the lines' rotation sidebands leak into the excited lines")
        return N, lines_for(N, turns), turns, note
    n_min = max(2, int(round(0.5 / T_rot)))
    n_max = min(4 * n_min, max(n_min, int(settle / T_rot)))
    best = None
    for nt in range(n_min, n_max + 1):
        N = int(round(nt * T_rot / T))
        L = lines_for(N, nt)
        if best is None or len(L) > len(best[1]):
            best = (N, L, nt)
        if len(L) >= 0.8 * n_lines:
            break
    N, L, nt = best
    return N, L, nt, ""


# ============================================================================ operating point
def hold_machine(mach, op, h):
    """The machine held at ``op``: the controller's own :meth:`~mjbench.control.Controller.hold`
    (time-varying gains frozen at t*, the reference replaced by a constant speed q̇* through q* and
    the offset at which the law outputs V*, as :func:`mjbench.linear.step_check`), started in the
    operating point's state."""
    ctrl = mach.controller.hold(mach, op) if mach.controller.closed_loop else mach.controller
    if ctrl is mach.controller:
        ctrl = copy.copy(ctrl)
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

    o = backend_options(scn, backend)
    return simulate(mach, backend, t_end, record_dt=T, options=o)


def measure(scn, mode=None, q=None, qd=None, I=None, t=None, backend="reduced", signal="multisine",
            amplitude=None, band=None, period=None, periods=3, settle=None, n_lines=30, linear=True,
            n_angles=None) -> dict:
    """Measure the plant and loop responses of ``scn``'s ``mode`` at an operating point (module doc).

    ``q``, ``qd`` [rad, rad/s]: the point (default: the initial angle, the controller's running
    speed); ``t`` [s]: K_p·t frozen there (default: simulation.t_end for a K_p·t PID); ``amplitude``
    [V]: the excitation's peak (default: 2 % of max(|V*|, 1 V), at most 10 % of the voltage headroom);
    ``band`` (lo, hi) [rad/s]; ``period`` [s] of the multisine (default 0.5 s; a running linkage:
    whole turns, :func:`design_lines`); ``periods`` measured after ``settle`` [s] (default: 7 time
    constants of the slowest linear closed-loop pole, 0.5–12 s); ``n_angles`` of the frozen-angle
    family (default: enough for the inertia's harmonics, ≥ 12).  Returns {"json": plain data, "frd":
    python-control FRD objects, "lines_rad_s", ...}."""
    if signal not in SIGNALS:
        raise ParameterError(f"--signal {signal!r}: choose one of {', '.join(SIGNALS)}")
    if backend not in ("reduced", "multibody"):
        raise ParameterError(f"--backend {backend!r}: choose reduced or multibody")
    check_options(amplitude, band, period, periods, settle, n_lines)
    periods, n_lines = int(periods), int(n_lines)
    pt = _operating_point(scn, mode, q, qd, I, t)
    check_timing(pt.T, band, period, n_lines)
    lin = _linearisation(pt, scn, backend) if linear else {"loop": None, "plant": None, "family": None, "note": ""}
    own_settle = settle is None
    if settle is None:
        settle = _settle_time(lin, pt.T)
    ex = _excitation(pt, scn, signal, amplitude, band, period, periods, settle, n_lines)
    meas = _measure_runs(pt, scn, backend, ex)
    settling = {"settle_s": ex.nset * ex.period, "tolerance": SETTLE_TOL, "lowest_line_change": meas.settle_change,
                "extended_from_s": None, "change_before_extension": None, "automatic": own_settle}
    nset0 = ex.nset
    while (own_settle and meas.settle_change is not None and meas.settle_change > SETTLE_TOL
           and ex.nset < SETTLE_GROWTH * max(nset0, 1)):
        if settling["change_before_extension"] is None:
            settling["change_before_extension"] = meas.settle_change
        more = _more_periods(meas.settle_change, meas.settle_change_before, ex.nset)
        # the same lines and period, settled longer (from the start: the runs are repeated)
        ex = _with_settle(ex, signal, min(ex.nset + more, SETTLE_GROWTH * max(nset0, 1)))
        meas = _measure_runs(pt, scn, backend, ex)
        settling.update(settle_s=ex.nset * ex.period, lowest_line_change=meas.settle_change,
                        extended_from_s=nset0 * ex.period)
    settling["settled"] = meas.settle_change is not None and meas.settle_change <= SETTLE_TOL
    settling["note"] = settle_note(settling, ex.period)
    if not settling["settled"]:
        pt.notes.append(f"warning: {settling['note']}")
    if ex.notes_period:
        pt.notes.append(ex.notes_period)
    omega = 2 * np.pi * ex.f0 * np.asarray(ex.lines, dtype=float)
    closed = pt.closed
    Sm = meas.V / meas.D
    Pm = meas.Y / meas.V
    Lm = 1.0 / Sm - 1.0 if closed else None

    P_lin = response(lin["plant"], omega, "qd", "V") if lin["plant"] is not None else None
    L_lin = response(lin["loop"].L, omega) if lin["loop"] is not None else None
    rate, band_lo, in_band = _frozen_band(pt, omega)
    fam = _frozen_family(pt, omega, n_angles, pt.notes, ex, meas) if (linear and rate > 0 and closed and
                                                               lin["loop"] is not None) else None
    import control as ct

    frd = {"plant": ct.frd(Pm, omega, name="plant_measured"), "S": ct.frd(Sm, omega, name="S_measured")}
    if closed:
        frd["loop"] = ct.frd(Lm, omega, name="L_measured")
    js = _report(scn, pt, backend, signal, ex, meas, omega, Pm, Sm, Lm, rate, band_lo, lin)
    js["settling"] = settling
    js["saturation"] = saturation(js["limiter_active_fraction"], meas.vlim)
    _compare_linear(js, Pm, Lm, P_lin, L_lin, fam, in_band, lin, closed, omega, meas.sides, ex)

    return {"json": LN.plain(js), "frd": frd, "omega": omega, "P": Pm, "L": Lm, "S": Sm, "P_lin": P_lin,
            "L_lin": L_lin, "coherence": np.minimum(meas.coh_v, meas.coh_y), "family": fam, "in_band": in_band}


def _operating_point(scn, mode, q, qd, I, t):
    """The mode's machine held at the operating point, and the same machine with the ideal drive (the
    drive-train elements — PWM, encoder, backlash, friction, current loop — have no linear model;
    what they change is measured): a namespace of both, the point, h, T and the notes so far."""
    from types import SimpleNamespace


    mode = scn.mode(mode)
    mach = S.make_machine(scn, mode)
    mach.require_one_axis("frest")
    ctrl = mach.controller
    h = float(scn.simulation.dt)
    N_every = control_every(ctrl, h)
    ramp = bool(ctrl.time_varying)  # a gain that changes with time (K_p·t): the point's time is the run's end
    if t is None:
        t = float(scn.simulation.t_end) if ramp else 0.0
    q = float(scn.initial.q0) if q is None else float(q)
    qd = LN.running_speed(mach, q) if qd is None else float(qd)
    train = [k for k in DRIVETRAIN if getattr(scn.drive, k, None) is not None]
    scn_lin = scn
    if train:
        raw = copy.deepcopy(scn.raw)
        for k in train:
            raw.get("drive", {}).pop(k, None)
        scn_lin = S.from_raw(raw, scn.source)
    mach_lin = S.make_machine(scn_lin, mode)
    op = LN.operating_point(mach_lin, q, qd, I, t)
    notes = [f"linearisation of the ideal drive: drive.{', drive.'.join(train)} have no linear model"] if train else []
    return SimpleNamespace(mode=mode, mach=mach, h=h, N_every=N_every, T=N_every * h,
                           tn=getattr(ctrl, "type_name", "") or type(ctrl).__name__, closed=bool(ctrl.closed_loop),
                           op=op, held=hold_machine(mach, op, h),
                           held_lin=hold_machine(mach_lin, op, h), notes=notes)


def _linearisation(pt, scn, backend) -> dict:
    """The linear machine at the point (the same held machine): its plant lifted to the control
    period and, with feedback, its loop and margins (``note``: why not, when it has none)."""

    lin = {"loop": None, "plant": None, "family": None, "note": ""}
    op, h = pt.op, pt.h
    angle = "frozen" if op.qd != 0.0 else "state"
    try:
        p_h = (LN.reduced_plant(pt.held_lin, op, h, angle=angle) if backend == "reduced" else
               LN.multibody_plant(pt.held_lin, op, scn.multibody_options(), h, coordinates="input", angle=angle))
        lin["plant"] = LN.sample(p_h, pt.N_every)
        if pt.closed:
            lp, mg = LN.analyse(pt.held_lin, op, h, backend, scn.multibody_options(), angle=angle)
            lin["loop"], lin["margins"] = lp, mg
    except ParameterError as e:
        lin["note"] = str(e)
    return lin


def _settle_time(lin, T) -> float:
    """7 time constants of the slowest linear closed-loop pole (1 s without a loop), in 0.5–12 s."""
    settle = 1.0
    fb = getattr(lin.get("loop"), "feedback", None)
    if fb is not None:
        pz = np.asarray(fb.poles(), dtype=complex)
        pz = pz[np.abs(pz) > 0]
        if len(pz):
            s = np.log(pz) / T
            slow = float(np.min(-s.real[s.real < 0])) if np.any(s.real < 0) else 0.0
            settle = 7.0 / slow if slow > 0 else 4.0
    return float(min(12.0, max(0.5, settle)))


def _rotation(scn, pt):
    """(running, inertia rate, rotation orders) of the held machine: a rigid linkage that turns is
    angle-periodic (:func:`rotation_orders`); the rate max|J'·q̇*|/J_tot sets the frozen band."""

    running = len(S.make_mechanism(scn).internal) == 0 and pt.op.qd != 0.0
    mech, J_eq = pt.held_lin.mechanism, pt.held_lin.drive.J_eq
    return running, inertia_rate(mech, J_eq, pt.op.qd), (rotation_orders(mech, J_eq) if running else 0)


def _excitation(pt, scn, signal, amplitude, band, period, periods, settle, n_lines):
    """The disturbance runs: one multisine, or one sine per line, over ``settle`` + ``periods``
    periods (:func:`design_lines`) → a namespace (runs [(d, lines, N)], lines, f0, period, N, P, nset,
    t_end, amplitude, note; running, inertia rate, rotation orders, turns per period)."""
    from types import SimpleNamespace

    op, T = pt.op, pt.T
    running, rate, orders = _rotation(scn, pt)
    N, lines, turns, notes_period = design_lines(T, op.qd, orders, rate, settle, n_lines, band, period, running)
    if turns:
        notes_period = periodic_note(turns, orders)
    period = N * T
    f0 = 1.0 / period
    if amplitude is None:
        vmax = voltage_limit(pt.mach.drive)
        amplitude = 0.02 * max(abs(op.V), 1.0)
        if math.isfinite(vmax):
            amplitude = min(amplitude, 0.1 * max(vmax - abs(op.V), 0.0)) or 0.02 * vmax
    amplitude = float(amplitude)
    nset = max(1, int(math.ceil(settle / period))) if settle > 0 else 0
    P = int(periods)
    return SimpleNamespace(runs=_runs(signal, N, lines, amplitude, nset, P), lines=lines, f0=f0, period=period, N=N,
                           P=P, nset=nset, t_end=(nset + P) * period, amplitude=amplitude, notes_period=notes_period,
                           running=running, rate=rate, orders=orders, turns=turns)


def _runs(signal, N, lines, amplitude, nset, P):
    """The disturbance sequences [(d, lines, N)] over ``nset`` settling + ``P`` measured periods."""
    if signal == "multisine":
        return [(np.tile(multisine(N, lines, amplitude), nset + P), lines, N)]
    n = np.arange((nset + P) * N)
    return [(amplitude * np.sin(2 * np.pi * k * n / N), np.array([k]), N) for k in lines]


def _with_settle(ex, signal, nset):
    """``ex`` with ``nset`` settling periods (the same lines, period and amplitude)."""
    from types import SimpleNamespace

    return SimpleNamespace(**{**vars(ex), "nset": nset, "t_end": (nset + ex.P) * ex.period,
                              "runs": _runs(signal, ex.N, ex.lines, ex.amplitude, nset, ex.P)})


def check_options(amplitude, band, period, periods, settle, n_lines) -> None:
    """Every option value, before any work: one error naming it (the CLI checks them when parsing)."""
    def bad(x):
        try:
            return not math.isfinite(float(x))
        except (TypeError, ValueError):
            return True

    if amplitude is not None and (bad(amplitude) or not float(amplitude) > 0):
        raise ParameterError(f"--amplitude {amplitude!r}: must be a finite excitation peak > 0 (V; A with a current "
                             f"loop)")
    def whole(x, lo, hi):
        try:
            return not isinstance(x, bool) and float(x) == int(x) and lo <= int(x) <= hi
        except (TypeError, ValueError, OverflowError):
            return False

    if not whole(n_lines, 1, 1000):
        raise ParameterError(f"--lines {n_lines!r}: must be a whole number of excited frequencies in 1 … 1000")
    if not whole(periods, 2, 1000):
        raise ParameterError(f"--periods {periods!r}: must be a whole number in 2 … 1000 (the coherence needs two "
                             f"periods)")
    if period is not None and (bad(period) or not float(period) > 0):
        raise ParameterError(f"--period {period!r}: must be a finite time > 0 [s]")
    if settle is not None and (bad(settle) or not float(settle) >= 0):
        raise ParameterError(f"--settle {settle!r}: must be a finite time >= 0 [s]")
    if band is not None:
        lo, hi = band
        if bad(lo) or bad(hi) or not 0 < float(lo) < float(hi):
            raise ParameterError(f"--band {tuple(band)!r}: need 0 < LO < HI, finite [rad/s]")


def check_timing(T, band, period, n_lines) -> None:
    """The options against the control period T: the band below the Nyquist frequency π/T, the
    multisine's period at least :data:`MIN_PERIOD_SAMPLES` control periods."""
    nyq = math.pi / T
    if band is not None and band[1] > nyq * (1 + 1e-12):
        raise ParameterError(f"--band {band[0]:g},{band[1]:g}: the upper edge is above the Nyquist frequency of the "
                             f"control period ({T:g} s): π/T = {nyq:.6g} rad/s; a sampled loop has no response there")
    if period is not None and round(period / T) < MIN_PERIOD_SAMPLES:
        raise ParameterError(f"--period {period:g} s: shorter than {MIN_PERIOD_SAMPLES} control periods "
                             f"({MIN_PERIOD_SAMPLES} × {T:g} s = {MIN_PERIOD_SAMPLES * T:g} s): its harmonics would "
                             f"all lie above the Nyquist frequency")


def settle_note(st: dict, period: float) -> str:
    """One sentence on the settling check (frest.json ``settling.note``)."""
    ch = st["lowest_line_change"]
    if ch is None:
        return "settling not checked (no settling period before the measured ones: --settle 0)"
    txt = (f"the lowest line changed by {ch:.2g} of its value between the measured periods and the same periods one "
           f"period ({period:g} s) earlier, after {st['settle_s']:g} s of settling")
    if st["extended_from_s"] is not None:
        txt += f" (extended from {st['extended_from_s']:g} s, where it changed by {st['change_before_extension']:.2g})"
    if ch <= st["tolerance"]:
        return txt + f": settled (≤ {st['tolerance']:g})"
    how = "lengthen --settle" if not st["automatic"] else f"the settling was extended {SETTLE_GROWTH}× at most"
    return txt + f": NOT settled (> {st['tolerance']:g}; {how}): the responses still carry the start's transient"


def saturation(fraction: float, vlim: float) -> dict:
    """frest.json ``saturation``: whether the limiter was active over more than :data:`SAT_FRACTION`
    of the measured samples, and what that means."""
    sat = bool(fraction > SAT_FRACTION)
    note = (f"the voltage limiter (±{vlim:g} V) was active in {100 * fraction:.3g} % of the measured samples (over "
            f"{100 * SAT_FRACTION:g} %): the loop is saturated, the measured responses and margins describe the limiter, "
            f"not the linear loop; lower --amplitude or move the operating point away from the limit" if sat else "")
    return {"saturated": sat, "limiter_active_fraction": float(fraction), "limit_fraction": SAT_FRACTION, "note": note}


def _measure_runs(pt, scn, backend, ex):
    """The baseline and the excited runs through the kernel, subtracted, and their spectra at the
    excited lines → a namespace (D, V, Y line spectra, coherences, distortion ratios, limiter
    fractions, the baseline's loop meta, the voltage limit, the lines' first rotation sidebands ΔV/d and
    Δq̇/d, the baseline's crank angle over its last period)."""
    from types import SimpleNamespace

    h, T, held, P = pt.h, pt.T, pt.held, ex.P
    base = _simulate(dataclasses.replace(held, controller=Excited(held.controller, [], T)), backend, ex.t_end, h, T, scn)
    Dl, Vl, Yl, Cv, Cy, Dist, Sat, Vs, Ys = [], [], [], [], [], [], [], [], []
    vlim = voltage_limit(pt.mach.drive)
    meta = {"loop": base.meta.get("loop"), "loop_reason": base.meta.get("loop_reason")}
    change = change0 = None
    for i, (d, ks, NN) in enumerate(ex.runs):
        exr = _simulate(dataclasses.replace(held, controller=Excited(held.controller, d, T)), backend, ex.t_end, h, T,
                        scn)
        n = min(len(exr.t), len(base.t), len(d))
        dV = exr.voltage[:n] - base.voltage[:n]
        if math.isfinite(vlim):  # over the measured periods
            Sat.append(float(np.mean(np.abs(exr.voltage[:n][-P * NN:]) >= 0.999 * vlim)))
        dY = exr.qd[:n] - base.qd[:n]
        if i == 0 and ex.nset >= 1:  # the settling check on the lowest line (module constants)
            change = _settle_change(dV, dY, NN, P, int(ks[0]))
            change0 = _settle_change(dV, dY, NN, P, int(ks[0]), shift=1) if ex.nset >= 2 else None
        D = _spectra(d[:n], NN, P, ks)
        V = _spectra(dV, NN, P, ks)
        Y = _spectra(dY, NN, P, ks)
        Dl.append(D.mean(axis=0))
        Vl.append(V.mean(axis=0))
        Yl.append(Y.mean(axis=0))
        Cv.append(coherence(D, V))
        Cy.append(coherence(D, Y))
        Dist.append(_distortion(dY, P, NN, ks))
        if ex.turns:  # the first rotation sidebands of each line (free bins by the line design)
            Vs.append([_lagged(dV, NN, P, ks, g) for g in (ex.turns, -ex.turns)])
            Ys.append([_lagged(dY, NN, P, ks, g) for g in (ex.turns, -ex.turns)])
    D, V, Y = (np.concatenate(a) for a in (Dl, Vl, Yl))
    sides = (np.concatenate(Vs, axis=1) / D, np.concatenate(Ys, axis=1) / D) if Vs else None
    return SimpleNamespace(D=D, V=V, Y=Y, coh_v=np.concatenate(Cv), coh_y=np.concatenate(Cy), Dist=Dist, Sat=Sat,
                           meta=meta, vlim=vlim, sides=sides, q_turn=base.q[:n][-ex.N:], settle_change=change,
                           settle_change_before=change0)


def _settle_change(dV, dY, N, P, k, shift=0) -> float:
    """Relative change of the lowest line (index k) of ΔV and Δq̇ between the last P periods and the
    P periods one period earlier (the excitation repeats every period: a settled machine gives the
    same spectrum); ``shift``: the same, ``shift`` periods earlier."""
    out = 0.0
    for x in (dV, dY):
        x = np.asarray(x, dtype=float)
        ref = abs(_spectra(x, N, P, [k]).mean())
        y = x[:len(x) - shift * N]
        now = _spectra(y, N, P, [k]).mean()
        before = _spectra(y[:-N], N, P, [k]).mean()
        out = max(out, float(abs(now - before) / max(ref, 1e-300)))
    return out


def _more_periods(c1, c0, nset) -> int:
    """Settling periods to add so that the lowest line's change falls to half the tolerance: a
    transient decaying by r = c1/c0 per period (c1: the last change, c0: the one a period before)
    needs ln(tol/2c1)/ln r more periods (× 1.25); without a decay seen, as many again as now."""
    if c0 is not None and 0 < c1 < c0:
        r = c1 / c0
        k = math.log(0.5 * SETTLE_TOL / c1) / math.log(r)
        return max(1, int(math.ceil(1.25 * k)))
    return max(1, nset)


def _distortion(dY, P, N, ks) -> float:
    """RMS of the non-excited lines of Δq̇ relative to the excited ones (last P periods)."""
    full = np.abs(np.fft.rfft(np.asarray(dY[-P * N:]).reshape(P, N), axis=1)).mean(axis=0)
    mask = np.zeros(len(full), dtype=bool)
    mask[ks] = True
    mask[0] = True
    return float(np.sqrt(np.mean(full[~mask] ** 2)) / np.sqrt(np.mean(full[ks] ** 2)))


def _frozen_band(pt, omega):
    """The inertia variation rate max|J'·q̇*|/J_tot and the band above 10 × it where the
    frozen-angle picture holds → (rate, band_lo, in_band mask)."""
    rate = inertia_rate(pt.held_lin.mechanism, pt.held_lin.drive.J_eq, pt.op.qd)
    band_lo = max(float(omega[0]), 10.0 * rate)
    return rate, band_lo, omega >= band_lo * (1 - 1e-12)


def _frozen_family(pt, omega, n_angles, notes, ex=None, meas=None):
    """The frozen-angle family's loops and plants at the lines, and (with the runs ``ex``, ``meas``)
    the family followed along the baseline's turn (:func:`along_turn_prediction`); None, with a note,
    if it cannot be computed.  ``n_angles=None``: enough angles for the inertia's harmonics."""

    op = pt.op
    if n_angles is None:  # follow the inertia's harmonics along the turn without aliasing
        n_angles = max(12, 12 * math.ceil((2 * (ex.orders if ex is not None else 0) + 2) / 12))
    try:
        F = LN.frozen_angle_family(pt.held_lin, pt.h, n_angles, speed=op.qd, t=op.t, plant_kind="reduced",
                                   angle="frozen")
        Ls = np.array([response(lp_.L, omega) for lp_ in F.loops])
        Ps = np.array([response(lp_.plant, omega, "qd", "V") for lp_ in F.loops])
        fam = {"angles_rad": F.angles, "L": Ls, "P": Ps}
        if meas is not None:
            fam["along_turn"] = along_turn_prediction(fam, meas.q_turn, ex.turns)
        return fam
    except Exception as e:  # noqa: BLE001 - the family is an overlay only
        notes.append(f"frozen-angle family not computed: {e}")
    return None


def _report(scn, pt, backend, signal, ex, meas, omega, Pm, Sm, Lm, rate, band_lo, lin) -> dict:
    """``frest.json`` before the comparison with the linear machine."""
    js = {"scenario": scn.name, "mode": pt.mode, "controller": pt.tn, "backend": backend, "signal": signal,
          "operating_point": pt.op.as_dict(), "co_step_s": pt.h, "control_period_s": pt.T,
          "amplitude_V": ex.amplitude, "period_s": ex.period, "periods": ex.P, "settle_s": ex.nset * ex.period,
          "n_runs": len(ex.runs) + 1, "lines_rad_s": omega, "drivetrain": bool(getattr(pt.held.drive, "train", None)),
          "band_rad_s": [float(band_lo), float(omega[-1])],
          "band_note": ("constant inertia: the frozen-angle model is exact over the whole band" if rate == 0 else
                        f"frozen-angle band: above 10 × the inertia variation rate max|J'·q̇*|/J_tot = {rate:.4g} 1/s"),
          "inertia_rate_1_s": rate,
          "plant": {"re": Pm.real, "im": Pm.imag, "coherence": np.minimum(meas.coh_v, meas.coh_y)},
          "distortion_ratio": float(max(meas.Dist)),
          "limiter_active_fraction": float(max(meas.Sat)) if meas.Sat else 0.0, "voltage_limit_V": meas.vlim,
          "loop_meta": meas.meta,
          "notes": pt.notes + ([lin["note"]] if lin["note"] else [])}
    if Lm is not None:
        js["loop"] = {"re": Lm.real, "im": Lm.imag, "coherence": meas.coh_v, "margins": margins_from_frd(omega, Lm)}
        js["sensitivity"] = {"re": Sm.real, "im": Sm.imag}
    return js


def _compare_linear(js, Pm, Lm, P_lin, L_lin, fam, in_band, lin, closed, omega, sides=None, ex=None) -> None:
    """The measured responses against the linearisation (in the frozen-angle band) and the family
    (:func:`family_comparison`); a running linkage's ``periodic`` explanation."""
    cmp = {}
    if P_lin is not None:
        cmp["plant"] = compare(Pm, P_lin, in_band)
        js["plant"]["linear"] = {"re": P_lin.real, "im": P_lin.imag}
    if L_lin is not None and closed:
        cmp["loop"] = compare(Lm, L_lin, in_band)
        js["loop"]["linear"] = {"re": L_lin.real, "im": L_lin.imag}
        js["loop"]["margins_linear"] = lin["margins"].as_dict()
        js["loop"]["margins_linear_on_lines"] = margins_from_frd(omega, L_lin)  # read like the measured ones
    if fam is not None and "along_turn" in fam:
        js["frozen_family"] = family_comparison(fam, Pm, Lm, 1.0 / (1.0 + Lm), in_band, cmp, sides)
    js["comparison"] = cmp
    if ex is not None and ex.running:
        js["periodic"] = {"turns_per_period": ex.turns, "rotation_orders": ex.orders,
                          "explanation": periodic_explanation(js)}
    vals = [c["max_rel_diff"] for k, c in cmp.items() if k in ("plant", "loop") and c["max_rel_diff"] is not None]
    js["max_rel_diff_vs_linear"] = max(vals) if vals else None


def family_comparison(fam, Pm, Lm, Sm, in_band, cmp, sides=None) -> dict:
    """Measured vs the frozen-angle family over the frozen band ``in_band`` (adds to ``cmp``): the
    family's mean over the angles, its envelope, and the family followed along the turn
    (:func:`along_turn_prediction`) with, for a whole number of turns per period, the first sidebands
    (``sides``: measured ΔV/d and Δq̇/d at k ± turns)."""
    m = np.asarray(in_band, dtype=bool)
    cmp["loop_vs_family_mean"] = compare(Lm, fam["L"].mean(axis=0), m)
    cmp["plant_vs_family_mean"] = compare(Pm, fam["P"].mean(axis=0), m)
    at = fam["along_turn"]
    cmp["plant_vs_family_along_turn"] = compare(Pm, at["P"], m)
    cmp["loop_vs_family_along_turn"] = compare(Lm, at["L"], m)
    cmp["sensitivity_vs_family_along_turn"] = compare(Sm, at["S"], m)
    lo, hi = np.abs(fam["P"]).min(axis=0), np.abs(fam["P"]).max(axis=0)
    inside = (np.abs(Pm) >= lo * 0.99) & (np.abs(Pm) <= hi * 1.01)
    js = {"n_angles": len(fam["angles_rad"]),
          "plant_inside_envelope_fraction": float(inside[m].mean()) if m.any() else None,
          "plant_mag_min": lo, "plant_mag_max": hi,
          "plant_along_turn": {"re": at["P"].real, "im": at["P"].imag},
          "loop_along_turn": {"re": at["L"].real, "im": at["L"].imag}}
    if sides is not None and "S_side" in at and m.any():
        Sside, Tside = sides
        s_ref, t_ref = np.abs(at["S"])[m], np.abs(at["T"])[m]
        js["sidebands"] = {
            "what": "first rotation sidebands ω ± Ω of each line, relative to the line's own response",
            "sensitivity_measured_max_rel": float(np.nanmax(np.abs(Sside[:, m]) / s_ref)),
            "sensitivity_frozen_max_rel": float(np.nanmax(np.abs(at["S_side"][:, m]) / s_ref)),
            "speed_measured_max_rel": float(np.nanmax(np.abs(Tside[:, m]) / t_ref)),
            "speed_frozen_max_rel": float(np.nanmax(np.abs(at["T_side"][:, m]) / t_ref)),
            "max_diff_rel": float(max(np.nanmax(np.abs(Sside - at["S_side"])[:, m] / s_ref),
                                      np.nanmax(np.abs(Tside - at["T_side"])[:, m] / t_ref)))}
    return js


def figure(res, path, title=""):
    """Bode plot of the measured plant and loop (dots) with the linearisation (line), the frozen-angle
    envelope (band), the family followed along the turn (dashed) and the coherence."""
    w = res["omega"]
    rows = [("plant q̇/V", res["P"], res["P_lin"], "P")]
    if res["L"] is not None:
        rows.append(("loop L at the plant input", res["L"], res["L_lin"], "L"))
    fig, ax = subplots(3, len(rows), figsize=(6 * len(rows), 8), squeeze=False, sharex=True)
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
            if "along_turn" in fam:  # what a line of the running linkage measures if the frozen picture holds
                ax[0, j].loglog(w, np.abs(fam["along_turn"][key]), "--", lw=1, label="frozen family along the turn")
                ax[1, j].semilogx(w, np.degrees(np.unwrap(np.angle(fam["along_turn"][key]))), "--", lw=1)
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
