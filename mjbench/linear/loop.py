"""The loop broken at the plant input: sensitivities, closed loop, margins, bandwidth, poles."""
from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError
from .controller import controller_counterpart, reference_gain
from .plant import (
    _angle_mode, frequency_grid, multibody_plant, reduced_plant, response, s_poles, sample)
from .point import OperatingPoint
from .signals import MEAS, _ct
from ..kernel import control_every


# ============================================================================ loop
@dataclass
class Loop:
    """A closed loop, discrete time at the controller period: ``plant`` (V → q, qd, I, ...,
    qd_prev), ``controller``, ``L`` (loop at the plant input, SISO: input ``V``, output ``-u``,
    the controller's reaction with the loop's sign), ``S`` = 1/(1+L) (``d`` → ``V``),
    ``T`` = L/(1+L) (``d`` → ``-u``), ``closed`` (q_set, qd_set, d → q, qd, I, V, u; d = voltage
    disturbance added at the plant input), ``feedback`` (the feedback loop alone, without pure
    reference dynamics: ``d`` → the measurements; its poles are the closed-loop poles).  Every one
    names its states: the plant's (``q``, ``qd``, ``I``, ``qd_prev`` ...) then the controller's
    (``ctrl.<name>``)."""

    plant: object
    controller: object
    L: object
    S: object
    T: object
    closed: object
    op: OperatingPoint | None = None
    feedback: object = None
    speed: "Loop | None" = None  #: the speed loop (angle-dependent reference as exogenous), or self


def loop(plant_T, controller) -> Loop:
    """Close ``controller`` around ``plant_T`` (both discrete at the same period)."""
    ct = _ct()
    if controller is None:
        raise ParameterError("open-loop controller: there is no feedback loop to analyse")
    if abs(float(plant_T.dt) - float(controller.dt)) > 1e-12 * float(plant_T.dt):
        raise ParameterError(f"plant period {plant_T.dt} s != controller period {controller.dt} s")
    Cfb = _reachable(_sub(controller, ["V"], list(MEAS)))
    # measurements the controller does not use are left out, then plant states no used output
    # sees (e.g. the angle of a frozen plant under a pure speed law: a free integrator, z = 1)
    used = [k for k, nm in enumerate(MEAS) if np.any(np.asarray(Cfb.D)[:, k] != 0)
            or (Cfb.nstates and np.any(np.asarray(Cfb.B)[:, k] != 0))]
    meas = [MEAS[k] for k in used] or ["qd"]
    Cfb = _reachable(_sub(controller, ["V"], meas))
    Pfb = _observable(_sub(plant_T, meas, ["V"]))
    # python-control names the signals of a product or a feedback u[0], y[0], x[0..]: every loop
    # object is given its signals' names again (the plant's states first, then the controller's)
    states = list(Pfb.state_labels) + [f"ctrl.{s}" for s in Cfb.state_labels]
    L = _named(-(Cfb * Pfb), ["V"], ["-u"], states, "L")
    S = _named(ct.feedback(ct.ss([], [], [], [[1.0]], dt=plant_T.dt), L), ["d"], ["V"], states, "S")
    T = _named(ct.feedback(L, 1), ["d"], ["-u"], states, "T")
    # the feedback loop alone: its poles are the loop's
    fb = _named(ct.feedback(Pfb, Cfb, sign=1), ["d"], list(Pfb.output_labels), states, "feedback")
    # closed loop: the controller's output u plus a voltage disturbance d drives the plant
    ctrl_u = ct.ss(controller.A, controller.B, controller.C, controller.D, controller.dt,
                   inputs=list(controller.input_labels), outputs=["u"], states=list(controller.state_labels),
                   name="ctrl")
    sj = ct.summing_junction(inputs=["u", "d"], output="V", name="sum", dt=plant_T.dt)
    outs = [o for o in plant_T.output_labels if o != "qd_prev"]
    closed = ct.interconnect([plant_T, ctrl_u, sj], inplist=["q_set", "qd_set", "d"], outlist=outs + ["V", "u"],
                             inputs=["q_set", "qd_set", "d"], outputs=outs + ["V", "u"], name="closed_loop",
                             check_unused=False)
    return Loop(plant_T, controller, L, S, T, closed, feedback=fb)


def _sub(sys, outputs, inputs):
    """``sys[outputs, inputs]`` keeping the names of its states (python-control's indexing
    numbers them)."""
    sub = sys[outputs, inputs]
    return _named(sub, inputs, outputs, list(sys.state_labels), sys.name)


def _named(sys, inputs, outputs, states, name):
    """``sys`` with its signals named (python-control's products and feedbacks number them)."""
    ct = _ct()
    return ct.ss(sys.A, sys.B, sys.C, sys.D, sys.dt, inputs=list(inputs), outputs=list(outputs),
                 states=list(states), name=name)


def _reachable(sys):
    """``sys`` without the states no input reaches (structurally: zero B rows, not coupled through
    A) — e.g. a reference integrator driven only by the set-point, whose pole at z = 1 is not a
    pole of the feedback loop."""
    ct = _ct()
    A, B = np.asarray(sys.A), np.asarray(sys.B)
    n = A.shape[0]
    if n == 0:
        return sys
    reach = np.any(B != 0, axis=1)
    while True:
        new = reach | np.any((A != 0) & reach[None, :], axis=1)
        if (new == reach).all():
            break
        reach = new
    if reach.all():
        return sys
    k = np.flatnonzero(reach)
    return ct.ss(A[np.ix_(k, k)], B[k], np.asarray(sys.C)[:, k], sys.D, sys.dt, inputs=list(sys.input_labels),
                 outputs=list(sys.output_labels), states=[sys.state_labels[i] for i in k], name=sys.name)


def _observable(sys):
    """``sys`` without the states no output sees (structurally: zero C columns, not coupled into
    observed states through A)."""
    ct = _ct()
    A, C = np.asarray(sys.A), np.asarray(sys.C)
    n = A.shape[0]
    if n == 0:
        return sys
    obs = np.any(C != 0, axis=0)
    while True:
        new = obs | np.any((A != 0) & obs[:, None], axis=0)
        if (new == obs).all():
            break
        obs = new
    if obs.all():
        return sys
    k = np.flatnonzero(obs)
    return ct.ss(A[np.ix_(k, k)], np.asarray(sys.B)[k], C[:, k], sys.D, sys.dt, inputs=list(sys.input_labels),
                 outputs=list(sys.output_labels), states=[sys.state_labels[i] for i in k], name=sys.name)


@dataclass
class Margins:
    """Robustness and speed of a loop (SI; dB, degrees).  Margins at the plant input: gain
    margin (inf: none), phase margin, the frequencies where they are read; ``Ms`` = peak |S|
    (= 1/stability margin); ``bandwidth_rad_s``: −3 dB of the set-point response q̇/q̇_set;
    ``stable``: every closed-loop pole inside the unit circle; ``poles``: closed-loop poles
    (s-plane, ln z / T)."""

    gain_margin_dB: float
    phase_margin_deg: float
    w_phase_crossover_rad_s: float
    w_gain_crossover_rad_s: float
    Ms: float
    w_Ms_rad_s: float
    bandwidth_rad_s: float
    stable: bool
    spectral_radius: float
    poles: list = field(default_factory=list)
    lower_gain_margin_dB: float = float("nan")

    def as_dict(self) -> dict:
        return {"gain_margin_dB": self.gain_margin_dB, "phase_margin_deg": self.phase_margin_deg,
                "w_phase_crossover_rad_s": self.w_phase_crossover_rad_s,
                "w_gain_crossover_rad_s": self.w_gain_crossover_rad_s,
                "lower_gain_margin_dB": self.lower_gain_margin_dB, "peak_sensitivity": self.Ms,
                "w_peak_sensitivity_rad_s": self.w_Ms_rad_s, "bandwidth_rad_s": self.bandwidth_rad_s,
                "stable": self.stable, "spectral_radius": self.spectral_radius,
                "closed_loop_poles_s": [[p.real, p.imag] for p in self.poles]}


def _db(x):
    return 20.0 * math.log10(x) if x > 0 and math.isfinite(x) else (math.inf if x == math.inf else float("nan"))


def bandwidth(sys, output="qd", input="qd_set", dbdrop=-3.0) -> float:
    """First frequency [rad/s] where |G| drops ``dbdrop`` dB below its DC gain (nan: infinite or
    zero DC gain; inf: it never drops below 0.9 × the Nyquist frequency)."""
    from scipy.optimize import brentq

    G = sys[output, input]
    omega = frequency_grid(float(G.dt) if G.dt else None, lo=1e-3, n=300)
    g0 = abs(complex(response(G, [1e-6])[0]))
    if not (math.isfinite(g0) and g0 > 0):
        return float("nan")
    lim = g0 * 10 ** (dbdrop / 20.0)
    mag = np.abs(response(G, omega))
    below = np.flatnonzero(mag < lim)
    if len(below) == 0:
        return math.inf
    i = int(below[0])
    if i == 0:
        return float(omega[0])
    f = lambda w: abs(complex(response(G, [w])[0])) - lim  # noqa: E731
    return float(brentq(f, omega[i - 1], omega[i], xtol=1e-9, rtol=1e-9))


def loop_margins(L, n: int = 3000) -> dict:
    """Gain margins (upper and lower), phase margin and peak sensitivity of a SISO loop L from its
    frequency response on a dense log grid up to 0.999 × Nyquist, every crossing refined by
    Brent's method.  (python-control's ``stability_margins`` falls back, for loops sampled this
    finely, to a spline search whose minimum |1 + L| is unreliable — spurious values measured on
    the platform servo — so the crossings are found here on the python-control object's exact
    response.)"""
    from scipy.optimize import brentq, minimize_scalar

    dt = float(L.dt) if L.dt else None
    hi = 0.999 * math.pi / dt if dt else 1e5
    w = np.logspace(-3, math.log10(hi), int(n))
    G = response(L, w)
    f = lambda x: complex(response(L, [x])[0])  # noqa: E731
    gms_up, gms_lo = [], []
    im = G.imag
    for k in np.flatnonzero(np.sign(im[:-1]) != np.sign(im[1:])):
        wc = brentq(lambda x: f(x).imag, w[k], w[k + 1], xtol=1e-12, rtol=1e-10)
        g = f(wc)
        if g.real < 0:
            gm = 1.0 / abs(g)
            (gms_up if gm > 1 else gms_lo).append((gm, wc))
    pms = []
    mag = np.abs(G) - 1.0
    for k in np.flatnonzero(np.sign(mag[:-1]) != np.sign(mag[1:])):
        wc = brentq(lambda x: abs(f(x)) - 1.0, w[k], w[k + 1], xtol=1e-12, rtol=1e-10)
        pm = math.degrees(cmath.phase(f(wc))) + 180.0
        pm = (pm + 180.0) % 360.0 - 180.0
        pms.append((pm, wc))
    d = np.abs(1.0 + G)
    k = int(np.argmin(d))
    lo_w, hi_w = w[max(k - 1, 0)], w[min(k + 1, len(w) - 1)]
    r = minimize_scalar(lambda x: abs(1.0 + f(x)), bounds=(lo_w, hi_w), method="bounded",
                        options={"xatol": 1e-9 * hi_w})
    sm, wms = (float(r.fun), float(r.x)) if r.fun < d[k] else (float(d[k]), float(w[k]))
    gm, wpc = min(gms_up) if gms_up else (math.inf, float("nan"))
    gml = max(gms_lo)[0] if gms_lo else float("nan")
    pm, wgc = min(pms, key=lambda p: abs(p[0])) if pms else (math.inf, float("nan"))
    return {"gm": gm, "wpc": wpc, "gm_lower": gml, "pm": pm, "wgc": wgc, "sm": sm, "wms": wms}


def margins(lp: Loop, with_bandwidth: bool = True) -> Margins:
    """Margins (:func:`loop_margins`), peak |S|, bandwidth and closed-loop poles of a
    :class:`Loop`.  The gain margin is the factor by which the loop gain may grow; when the loop
    is only conditionally stable (an open-loop-unstable frozen plant), ``lower_gain_margin_dB``
    (negative) is how far it may drop."""
    mm = loop_margins(lp.L)
    poles_z = np.asarray(lp.feedback.poles(), dtype=complex)
    rho = float(np.max(np.abs(poles_z))) if len(poles_z) else 0.0
    stable = rho < 1.0
    sp = lp.speed if lp.speed is not None else lp
    sp_stable = stable if sp is lp else float(np.max(np.abs(sp.feedback.poles()))) < 1.0
    bw = bandwidth(sp.closed) if (sp_stable and with_bandwidth) else float("nan")
    Ms = 1.0 / mm["sm"] if mm["sm"] > 0 else math.inf
    return Margins(_db(mm["gm"]), mm["pm"], mm["wpc"], mm["wgc"], Ms, mm["wms"], bw, stable, rho,
                   list(s_poles(lp.feedback)), _db(mm["gm_lower"]))


def analyse(machine, op: OperatingPoint, h: float, plant_kind="reduced", options=None, angle=None):
    """Plant at the controller period + controller counterpart + loop + margins at ``op``.
    ``plant_kind`` "reduced" or "multibody" (input coordinates); ``angle`` None: frozen when
    q̇* ≠ 0, the full Jacobian at a stationary point.  Returns (Loop, Margins)."""

    N = control_every(machine.controller, h)
    if plant_kind == "reduced":
        p_h = reduced_plant(machine, op, h, angle=_angle_mode(angle, op))
    elif plant_kind == "multibody":
        p_h = multibody_plant(machine, op, options, h, coordinates="input", angle=_angle_mode(angle, op))
    else:
        raise ParameterError(f"plant = {plant_kind!r}: choose 'reduced' or 'multibody'")
    P = sample(p_h, N)
    ang = _angle_mode(angle, op)
    C = controller_counterpart(machine, op, h, angle=ang)
    lp = loop(P, C)
    lp.op = op
    if ang == "state" and reference_gain(machine.controller, op.q) != 0.0:
        lp.speed = loop(P, controller_counterpart(machine, op, h, reference_feedback=False))
        lp.speed.op = op
    return lp, margins(lp)
