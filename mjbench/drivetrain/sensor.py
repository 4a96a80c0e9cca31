"""What a digital controller measures: encoder quantisation, speed estimation, noise.

Called by the kernel at every control sample (period T = the controller's ``period``); the ideal
sensor (no ``[drive.encoder]``/``[drive.sensor]``) is the kernel's own fill of the
:class:`~controllers.base.Measurement` with the exact values, at no cost.

Measured shaft: the encoder's side (motor by default).  Angle θ on that shaft (motor: φ, with a
compliant gear the motor coordinate itself; output: the crank angle α):

* **encoder**: θ_m = Δ·round(θ/Δ), Δ = 2π/(lines·edges): an incremental count whose reported
  angle is the centre of the count interval, so |θ_m − θ| ≤ Δ/2 (edges at (k + ½)·Δ, count 0 at
  the start position);
* **speed** (``[drive.sensor] speed``):
  - ``difference``: ω̂_k = (θ_m,k − θ_m,k−1)/T (0 at the first sample);
  - ``observer``: type-2 tracking observer (a PLL on the count), discretised as the α-β tracker
    θ̂⁻ = θ̂ + T·ω̂, e = θ_m − θ̂⁻, θ̂ = θ̂⁻ + 2ζω_nT·e, ω̂ = ω̂ + ω_n²T·e (ζ = 1): a double
    integrator in the loop, so a constant-speed ramp is tracked with zero steady error; its
    acceleration estimate is ω_n²·e;
  - ``mt``: M/T method, (angle between the latest encoder edge and the latest edge before the
    previous sample) / (time between them); the edge time comes from a capture timer (exact
    here: back-interpolated with the true speed from the sample, within the sample period).  At
    standstill the estimate decays as Δ/(t − t_edge);
  - ``true``: the exact speed;
* **acceleration** for D terms: (ω̂_k − ω̂_k−1)/T (observer: its own estimate; ``true``: the
  kernel's backward difference of the exact speed, or, for the motor of a compliant gear, the
  difference of its exact speed over the sample period);
* **noise** (Gaussian, ``seed``): on the angle before quantisation, on the speed estimate and on
  the current.

The controller receives the values converted to the crank side (÷ z for the motor shaft); the
Measurement then holds the motor-side ones as z × crank (exactly the measured shaft's values).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError

SPEED_METHODS = ("difference", "observer", "mt", "true")


class Sensor:
    """Encoder, speed estimator and noise of the measurement (see the module docstring).

    lines: encoder lines per revolution (0: no encoder, exact angle); side: "motor" | "output";
    edges: counts per line; speed: one of :data:`SPEED_METHODS`; bandwidth [Hz]: observer natural
    frequency (None: sample rate / 20); noise_* standard deviations [rad, rad/s, A] on the
    measured shaft; seed; delay: one-sample computation delay (applied by the kernel hook)."""

    def __init__(self, lines=0, side="motor", edges=4, speed="difference", bandwidth=None,
                 noise_angle=0.0, noise_speed=0.0, noise_current=0.0, seed=0, delay=False):
        if speed not in SPEED_METHODS:
            raise ParameterError(f"drive.sensor.speed = {speed!r}: choose one of {list(SPEED_METHODS)}")
        if side not in ("motor", "output"):
            raise ParameterError(f"drive.encoder.side = {side!r}: choose 'motor' or 'output'")
        if speed == "mt" and not np.all(np.asarray(lines) > 0):
            raise ParameterError("drive.sensor.speed = 'mt' needs an encoder (drive.encoder.lines > 0)")
        self.lines, self.side, self.edges = lines, side, edges
        self.speed, self.bandwidth = speed, bandwidth
        self.noise_angle, self.noise_speed, self.noise_current = noise_angle, noise_speed, noise_current
        self.seed, self.delay = int(seed), bool(delay)

    def describe(self) -> dict:
        return {"lines": _plain(self.lines), "side": self.side, "edges": _plain(self.edges), "speed": self.speed,
                "bandwidth_Hz": None if self.bandwidth is None else _plain(self.bandwidth),
                "noise_angle_rad": _plain(self.noise_angle), "noise_speed_rad_s": _plain(self.noise_speed),
                "noise_current_A": _plain(self.noise_current), "seed": self.seed, "delay": self.delay}

    @property
    def exact(self) -> bool:
        """No encoder, no noise, the exact speed: the kernel's own measurement (only the delay left)."""
        return (self.speed == "true" and not np.any(np.asarray(self.lines) > 0)
                and not any(np.any(np.asarray(v) > 0) for v in (self.noise_angle, self.noise_speed, self.noise_current)))

    @property
    def resolution(self):
        """Count width Δ = 2π/(lines·edges) [rad] on the measured shaft (0: no encoder)."""
        if not np.any(np.asarray(self.lines) > 0):
            return 0.0
        return 2.0 * math.pi / (np.asarray(self.lines, dtype=float) * self.edges) if np.ndim(self.lines) \
            else 2.0 * math.pi / (self.lines * self.edges)

    def observer_gains(self, T):
        """(α, β) of the discrete observer for sample period T: α = 2ω_nT, β = (ω_nT)²."""
        fn = self.bandwidth if self.bandwidth is not None else 1.0 / (20.0 * T)
        w = 2.0 * math.pi * np.asarray(fn, dtype=float) * T if np.ndim(fn) else 2.0 * math.pi * fn * T
        a, b = 2.0 * w, w * w
        if not np.all((a < 2.0) & (b < 4.0 - 2.0 * a)):
            raise ParameterError(f"drive.sensor.bandwidth = {fn!r} Hz: unstable for the sample period {T:g} s "
                                 f"(need 2π·f·T < 0.828)")
        return a, b

    # ------------------------------------------------------------------ binding
    def bind(self, z, T, nsim, rates=None):
        """A function (y, t, q, q̇, q̈, I) → y filling the Measurement with the measured values.

        ``rates()`` → (δ, δ̇): the compliant gear's deflection (motor = crank + δ, output units),
        None for a rigid gear.  ``nsim``: None for a single run, else the batch size."""
        batch = nsim is not None
        motor = self.side == "motor"
        zz = z if motor else 1.0          # measured-shaft units per crank-side unit
        inv_zz = 1.0 / zz
        D = self.resolution
        quant = bool(np.any(np.asarray(D) > 0))
        if quant and batch and np.ndim(D) == 0:
            D = float(D)
        inv_D = (1.0 / D) if quant else 0.0
        rng = np.random.default_rng(self.seed)
        size = nsim
        sa, ss, sc = self.noise_angle, self.noise_speed, self.noise_current
        na, ns, nc = (bool(np.any(np.asarray(v) > 0)) for v in (sa, ss, sc))
        method = self.speed
        inv_T = 1.0 / T
        use_rates = rates is not None and motor
        rnd = np.rint if batch else round
        st = self._state = {"n": 0, "th": None, "w": 0.0, "a": 0.0, "te": None, "the": None, "c": None}
        last = self._last = [0.0, 0.0, 0.0]  # crank-side angle, speed, acceleration the controller saw
        if method == "observer":
            alpha, beta = self.observer_gains(T)

        def noise(s):
            return s * (rng.standard_normal(size) if batch else float(rng.standard_normal()))

        def measure(y, t, q, qd, qdd, I):
            # true angle and speed on the measured shaft
            if use_rates:
                dl, dd = rates()
                th, w_true = zz * (q + dl), zz * (qd + dd)
            else:
                th, w_true = zz * q, zz * qd
            if na:
                th = th + noise(sa)
            if quant:
                c = rnd(th * inv_D)
                thm = D * c
            else:
                c = None
                thm = th
            n = st["n"]
            if method == "difference":
                if n == 0:
                    w = 0.0 * thm
                    a = w
                else:
                    w = (thm - st["th"]) * inv_T
                    a = (w - st["w"]) * inv_T if n > 1 else 0.0 * w
            elif method == "observer":
                if n == 0:
                    st["oth"], st["ow"] = thm, 0.0 * thm
                    w = a = 0.0 * thm
                else:
                    pred = st["oth"] + T * st["ow"]
                    e = thm - pred
                    st["oth"] = pred + alpha * e
                    w = st["ow"] + beta * inv_T * e
                    a = beta * inv_T * inv_T * e
                    st["ow"] = w
            elif method == "mt":
                w, a = _mt(st, t, T, c, th, w_true, D, n, batch)
            else:  # true
                w = w_true
                if use_rates:  # the motor's own speed: its difference over the sample period
                    a = (w - st["wt"]) * inv_T if n > 0 else 0.0 * w
                    st["wt"] = w
                else:
                    a = zz * qdd
            if ns:
                w = w + noise(ss)
            st["n"] = n + 1
            st["th"], st["w"] = thm, w
            qm, wm, am = thm * inv_zz, w * inv_zz, a * inv_zz
            if not batch:
                qm, wm, am = float(qm), float(wm), float(am)
            last[0], last[1], last[2] = qm, wm, am
            Im = I + noise(sc) if nc else I
            return y.set(t, qm, wm, am, Im)

        def current(I):
            """A current-loop sample of the measured current."""
            return I + noise(sc) if nc else I

        self._measure_current = current
        return measure

    # per-run state lives in private attributes (a batch stacks only the public parameters)
    @property
    def last(self):
        """(angle, speed, acceleration) the controller saw at the last sample, crank side."""
        return self._last

    def measure_current(self, I):
        """A current-loop sample of the measured current (after :meth:`bind`)."""
        return self._measure_current(I)


def _mt(st, t, T, c, th, w_true, D, n, batch):
    """M/T speed estimate (see the module docstring) on the measured shaft; updates ``st``."""
    if not batch:
        return _mt_scalar(st, t, T, c, th, w_true, D, n)
    w_prev = st["w"]
    if n == 0:
        st["c"], st["te"], st["the"] = c, None, None
        z0 = 0.0 * th
        return z0, z0
    c_prev = st["c"]
    new = c != c_prev
    s = np.sign(c - c_prev)
    the = (c - 0.5 * s) * D  # angle of the latest edge crossed
    # capture time of that edge: back from the sample with the true speed, within the last period
    with np.errstate(divide="ignore", invalid="ignore"):
        back = np.where(w_true * s > 0, (th - the) / np.where(w_true == 0, 1.0, w_true), 0.0)
    te = t - np.clip(back, 0.0, T)
    te_last, the_last = st["te"], st["the"]
    if te_last is None:
        te_last = np.full_like(np.asarray(te, dtype=float), np.nan)
        the_last = np.full_like(te_last, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        span = te - te_last
        w_edge = np.where(new & (span > 0) & np.isfinite(span), (the - the_last) / np.where(span > 0, span, 1.0), np.nan)
        # no new edge: the speed is at most one count since the latest edge
        bound = np.where(np.isfinite(te_last), D / np.maximum(t - te_last, 1e-300), np.inf)
        w_hold = np.sign(w_prev) * np.minimum(np.abs(w_prev), bound)
    w = np.where(new, np.where(np.isfinite(w_edge), w_edge, w_prev), w_hold)
    st["c"] = c
    st["te"] = np.where(new, te, te_last)
    st["the"] = np.where(new, the, the_last)
    a = (w - w_prev) / T if n > 1 else 0.0 * w
    if not batch:
        w, a = float(w), float(a)
    return w, a


def _mt_scalar(st, t, T, c, th, w_true, D, n):
    """:func:`_mt` for one run (Python floats)."""
    w_prev = st["w"]
    if n == 0:
        st["c"], st["te"], st["the"] = c, None, None
        return 0.0, 0.0
    c_prev = st["c"]
    te_last = st["te"]
    if c != c_prev:
        s = 1.0 if c > c_prev else -1.0
        the = (c - 0.5 * s) * D
        back = (th - the) / w_true if w_true * s > 0 else 0.0
        te = t - (0.0 if back < 0.0 else (T if back > T else back))
        w = w_prev
        if te_last is not None and te > te_last:
            w = (the - st["the"]) / (te - te_last)
        st["c"], st["te"], st["the"] = c, te, the
    elif te_last is not None:
        bound = D / max(t - te_last, 1e-300)
        w = w_prev if abs(w_prev) <= bound else math.copysign(bound, w_prev)
    else:
        w = w_prev
    a = (w - w_prev) / T if n > 1 else 0.0
    return float(w), float(a)


def _plain(v):
    return v.tolist() if isinstance(v, np.ndarray) else v
