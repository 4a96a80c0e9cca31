"""The angle dependence: the loop at frozen angles over one turn, worst-case margins, the
frozen-angle validity number, margin constraints (``--margin``) and the K_p·t ramp limit."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .controller import controller_counterpart, reference_gain, running_speed
from .loop import _reachable, analyse, loop, margins
from .plant import _angle_mode, reduced_plant, sample
from .point import operating_point
from .signals import MEAS, _ct
from ..kernel import control_every


# ============================================================================ angle dependence
@dataclass
class Family:
    """Frozen-angle loops over one turn.  ``angles`` [rad], ``speeds`` [rad/s], ``margins`` (one
    :class:`Margins` per angle), ``loops``; ``worst``: worst-case figures and the angle where each
    occurs; ``validity``: the frozen-angle validity number and verdict."""

    angles: np.ndarray
    speeds: np.ndarray
    margins: list
    loops: list
    worst: dict
    validity: dict


VALID_BELOW = 0.1  #: validity ratio below which the frozen-angle picture holds


FAILS_ABOVE = 1.0  #: ... and above which it fails


def frozen_angle_family(machine, h: float, n_angles: int = 36, speed=None, t: float = 0.0,
                        plant_kind="reduced", options=None, keep_loops=True, angle=None) -> Family:
    """The loop at ``n_angles`` frozen input angles over [0, 2π) at the running speed (or
    ``speed``: a number or a function of q) at time ``t`` (K_p·t); ``angle`` as in
    :func:`analyse` (None: frozen when running)."""
    qs = np.linspace(0.0, 2 * np.pi, int(n_angles), endpoint=False)
    if speed is None:
        speeds = np.array([running_speed(machine, q) for q in qs])
    elif callable(speed):
        speeds = np.array([float(speed(q)) for q in qs])
    else:
        speeds = np.full(len(qs), float(speed))
    ms, lps = [], []
    for q, w in zip(qs, speeds):
        op = operating_point(machine, q, w, t=t)
        lp, m = analyse(machine, op, h, plant_kind, options, angle)
        ms.append(m)
        lps.append(lp if keep_loops else None)
    worst = worst_case(qs, ms)
    validity = frozen_validity(machine, qs, speeds, ms)
    return Family(qs, speeds, ms, lps, worst, validity)


def worst_case(qs, ms) -> dict:
    """Worst figures over a family and the angle [rad] where each occurs."""
    def pick(key, fn):
        vals = np.array([getattr(m, key) for m in ms], dtype=float)
        ok = np.isfinite(vals)
        if not ok.any():
            return {"value": float(vals[0]) if len(vals) else float("nan"), "at_q_rad": None}
        i = int(np.flatnonzero(ok)[fn(vals[ok])])
        return {"value": float(vals[i]), "at_q_rad": float(qs[i])}

    return {"gain_margin_dB": pick("gain_margin_dB", np.argmin), "phase_margin_deg": pick("phase_margin_deg", np.argmin),
            "peak_sensitivity": pick("Ms", np.argmax), "bandwidth_rad_s": pick("bandwidth_rad_s", np.argmin),
            "spectral_radius": pick("spectral_radius", np.argmax),
            "all_stable": bool(all(m.stable for m in ms))}


def frozen_validity(machine, qs, speeds, ms) -> dict:
    """Frozen-angle validity number ν = max_q max(|J'(q)·q̇*|/(J_eq + J(q)), |∂q̇_ref/∂q|) /
    min_q ω_bw: how fast the loop's plant (inertia) and reference change along the turn, over
    the slowest closed-loop (speed-loop) bandwidth.  ν < 0.1: the frozen-angle loops describe
    the machine; 0.1-1: marginal; > 1: they fail (the machine changes faster than its loop
    responds; the speed fluctuation is then set by the angle-periodic dynamics)."""
    J, dJ, _ = machine.mechanism.reduced(qs)
    Jt = float(machine.drive.J_eq) + np.asarray(J, dtype=float) + 0.0 * qs
    rate_J = np.abs(np.asarray(dJ, dtype=float) * speeds) / Jt
    rate_r = np.abs(np.array([reference_gain(machine.controller, q) for q in qs]))
    rate = np.maximum(rate_J, rate_r)
    bws = np.array([m.bandwidth_rad_s for m in ms], dtype=float)
    ok = np.isfinite(bws) & (bws > 0)
    bw = float(np.min(bws[ok])) if ok.any() else float("nan")
    i = int(np.argmax(rate))
    nu = float(rate[i] / bw) if math.isfinite(bw) else float("nan")
    if not math.isfinite(nu):
        verdict = "undefined (no finite closed-loop bandwidth)"
    else:
        verdict = "valid" if nu < VALID_BELOW else ("marginal" if nu <= FAILS_ABOVE else "fails")
    return {"inertia_rate_max_1_s": float(rate_J.max()), "reference_rate_max_1_s": float(rate_r.max()),
            "at_q_rad": float(qs[i]), "bandwidth_min_rad_s": bw, "ratio": nu, "verdict": verdict,
            "rotation_to_bandwidth": float(np.max(np.abs(speeds)) / bw) if math.isfinite(bw) else float("nan")}


# ============================================================================ margins for design
MARGIN_KEYS = {"pm": ("phase_margin_deg", ">=", "phase margin [deg]"),
               "gm": ("gain_margin_dB", ">=", "gain margin [dB]"),
               "ms": ("peak_sensitivity", "<=", "peak |S|"),
               "bw": ("bandwidth_rad_s", ">=", "closed-loop bandwidth [rad/s]")}


def parse_margin(text: str) -> tuple:
    """``"pm>=45"`` → ("pm", ">=", 45.0); keys pm [deg], gm [dB], ms (peak |S|), bw [rad/s]."""
    import re

    m = re.fullmatch(r"\s*(pm|gm|ms|bw)\s*(>=|<=)\s*([-+0-9.eE]+)\s*", str(text))
    if not m:
        raise ParameterError(f"--margin {text!r}: expected pm>=DEG, gm>=DB, ms<=VALUE or bw>=RAD_S "
                             f"(e.g. --margin 'pm>=45' --margin 'ms<=2', quoted for the shell)")
    key, op, val = m.group(1), m.group(2), float(m.group(3))
    if op != MARGIN_KEYS[key][1]:
        raise ParameterError(f"--margin {text!r}: {key} is a {'lower' if MARGIN_KEYS[key][1] == '>=' else 'upper'} "
                             f"bound, write {key}{MARGIN_KEYS[key][1]}{val:g}")
    if not math.isfinite(val) or (key in ("ms", "bw", "pm") and val <= 0):
        raise ParameterError(f"--margin {text!r}: the bound must be finite and > 0")
    return key, op, val


def plant_family(machine, h: float, n_angles: int = 12, t: float = 0.0, speed=None) -> list:
    """(angle, operating point, plant at the controller period) at ``n_angles`` frozen angles:
    the part of the loop analysis that does not depend on the controller gains."""

    N = control_every(machine.controller, h)
    out = []
    for q in np.linspace(0.0, 2 * np.pi, int(n_angles), endpoint=False):
        w = running_speed(machine, q) if speed is None else float(speed)
        op = operating_point(machine, q, w, t=t)
        out.append((float(q), op, sample(reduced_plant(machine, op, h, angle=_angle_mode(None, op)), N)))
    return out


def family_margins(machine, plants, h: float, with_bandwidth: bool = False) -> dict:
    """Worst-case margins of ``machine``'s controller over a :func:`plant_family` (frozen loops):
    {"phase_margin_deg", "gain_margin_dB", "peak_sensitivity", "bandwidth_rad_s", "all_stable"}."""
    ms = []
    for q, op, P in plants:
        ang = _angle_mode(None, op)
        lp = loop(P, controller_counterpart(machine, op, h, angle=ang))
        if ang == "state" and reference_gain(machine.controller, op.q) != 0.0:
            lp.speed = loop(P, controller_counterpart(machine, op, h, reference_feedback=False))
        ms.append(margins(lp, with_bandwidth))
    w = worst_case(np.array([p[0] for p in plants]), ms)
    return {"phase_margin_deg": w["phase_margin_deg"]["value"], "gain_margin_dB": w["gain_margin_dB"]["value"],
            "peak_sensitivity": w["peak_sensitivity"]["value"], "bandwidth_rad_s": w["bandwidth_rad_s"]["value"],
            "all_stable": w["all_stable"]}


def margin_violation(worst: dict, constraints) -> float:
    """Sum over ``constraints`` [(key, op, value)] of the relative violation by the worst-case
    margins, each capped at 1 (0: all met); an unstable frozen loop, or a margin that cannot be
    computed, violates every constraint fully."""
    total = 0.0
    for key, _, val in constraints:
        v = worst.get(MARGIN_KEYS[key][0])
        if not worst.get("all_stable", True) or v is None or (isinstance(v, float) and math.isnan(v)):
            total += 1.0
        elif key == "ms":
            total += min(1.0, max(0.0, v / val - 1.0))
        elif v != math.inf:
            total += min(1.0, max(0.0, (val - v) / abs(val)))
    return float(total)


# ============================================================================ K_p·t
def kp_ramp_limit(machine, h: float, n_angles: int = 24, t_max: float = 1e4, speed=None) -> dict:
    """Seed 000 Eq 15, K_p·t PID sampled at its period: ``t_s`` — the time at which the growing
    gain makes the frozen loop unstable at the worst angle (``at_q_rad``; bisection on the
    closed-loop spectral radius), ``kp_eff`` = K_p·t there [V·s/rad]; ``t_stable_from_s`` — before
    it the gain is too small to stabilise every frozen angle (where J'·q̇ < 0 the frozen plant has
    negative damping).  ``None``: no such time below ``t_max``."""
    ctrl = machine.controller
    if not getattr(ctrl, "kp_ramp", False):
        raise ParameterError("kp_ramp_limit: the controller has no K_p·t ramp (kp_ramp = false)")
    ct = _ct()
    cases = [(q, op, P[list(MEAS), ["V"]]) for q, op, P in plant_family(machine, h, n_angles, 0.0, speed)]

    def radius(k, t):
        q, op, Pfb = cases[k]
        C = _reachable(controller_counterpart(machine, dataclasses.replace(op, t=t), h,
                                              angle=_angle_mode(None, op))[["V"], list(MEAS)])
        return float(np.max(np.abs(ct.feedback(Pfb, C, sign=1).poles())))

    def rho(t):
        worst, at = 0.0, None
        for k, (q, _, _) in enumerate(cases):
            r = radius(k, t)
            if r > worst:
                worst, at = r, q
        return worst, at

    order = list(range(len(cases)))

    def stable(t):  # rho(t) < 1: the angle found unstable last is tried first, and the first unstable one decides
        for i, k in enumerate(order):
            if radius(k, t) >= 1.0:
                order.insert(0, order.pop(i))
                return False
        return True

    def bisect(lo, hi):  # rho(lo) and rho(hi) on opposite sides of 1
        s_lo = stable(lo)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if stable(mid) == s_lo:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-4 * hi:
                break
        return lo, hi

    out = {"n_angles": int(n_angles), "t_stable_from_s": None, "t_s": None, "kp_eff": None, "at_q_rad": None}
    # a stable instant: the first of 1, 2, 4 ... s where every frozen angle is stable
    t_ok = 1.0
    while not stable(t_ok):
        t_ok *= 2.0
        if t_ok > t_max:
            return out
    if not stable(1e-6):  # unstable at the start of the ramp (small K_p·t): where it becomes stable
        out["t_stable_from_s"] = bisect(1e-6, t_ok)[1]
    else:
        out["t_stable_from_s"] = 0.0
    hi = 2.0 * t_ok
    while stable(hi):
        t_ok, hi = hi, 2.0 * hi
        if hi > t_max:
            return out
    lo, hi = bisect(t_ok, hi)
    r, at = rho(hi)
    kp = float(np.asarray(ctrl.gain_p(hi)))
    out.update({"t_s": hi, "kp_eff": kp, "at_q_rad": at})
    return out
