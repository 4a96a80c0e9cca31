"""What a digital controller measures: encoder quantisation, speed estimation, noise.

The law :func:`sensor_law` is the kernel's SENSE slot, called at every control sample (period T =
the controller's ``period``); the ideal sensor (no ``[drive.encoder]``/``[drive.sensor]``, or
only the delay) is the kernel's own exact measurement, at no cost.

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
  the current; one stream per signal of the counter-based generator of
  :mod:`mjbench.drivetrain.noise`, drawn at the sample's index (the same numbers in CPython and
  in the compiled loop).

The controller receives the values converted to the crank side (÷ z for the motor shaft); the
Measurement then holds the motor-side ones as z × crank (exactly the measured shaft's values).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .. import compiled as C
from ..compiled import clip, law
from ..errors import ParameterError
from .noise import STREAM_ANGLE, STREAM_CURRENT, STREAM_SPEED, gauss, stream_key

SPEED_METHODS = ("difference", "observer", "mt", "true")
#: the law's codes of the speed estimates
DIFFERENCE, OBSERVER, MT, TRUE = range(4)

#: the sensor law's parameters on the measured shaft: speed estimate (code), quantisation on/off,
#: count width Δ and 1/Δ, measured-shaft units per crank unit zz (z on the motor, 1 on the output)
#: and 1/zz, sample period T and 1/T, observer gains α, β, whether the measured shaft is the motor
#: of a compliant gear (its own coordinate: crank + δ), noise deviations (angle, speed, current)
#: and their streams' keys
SensorP = namedtuple("SensorP", "method quant D inv_D zz inv_zz T inv_T alpha beta motor_own sa ss sc "
                                "key_a key_s key_c")
#: the sensor law's state: samples taken, last measured angle and speed estimate, observer angle
#: and speed, last exact motor speed (compliant gear, speed "true"), M/T: last count, time and
#: angle of the latest edge (NaN: none yet)
STATE = ("n", "angle", "speed", "obs_angle", "obs_speed", "true_speed", "count", "edge_time", "edge_angle")
S_N, S_TH, S_W, S_OTH, S_OW, S_WT, S_C, S_TE, S_THE = range(len(STATE))


@law
def rint(x):
    """x rounded to the nearest whole number, halves to even (as Python's ``round``) — a float, and
    NaN passes (a diverging run reaches the kernel's check instead of an exception)."""
    if abs(x) < 2251799813685248.0:  # 2^51: 1.5·2^52 + x has a unit last place
        return (x + 6755399441055744.0) - 6755399441055744.0
    return x


@law
def mt_speed(t, c, th, w_true, n, P, S):
    """M/T speed estimate and its difference on the measured shaft (see the module docstring);
    ``c``: the count, ``th``: the true angle, ``n``: the sample's index.  Updates the M/T state."""
    w_prev = S[S_W]
    if n == 0.0:
        S[S_C] = c
        S[S_TE] = math.nan
        S[S_THE] = math.nan
        return 0.0, 0.0
    c_prev = S[S_C]
    te_last = S[S_TE]
    if c != c_prev:
        s = 1.0 if c > c_prev else -1.0
        the = (c - 0.5 * s) * P.D  # the angle of the latest edge crossed
        # its capture time: back from the sample with the true speed, within the last period
        back = (th - the) / w_true if w_true * s > 0.0 else 0.0
        te = t - clip(back, 0.0, P.T)
        w = w_prev
        if not math.isnan(te_last) and te > te_last:
            w = (the - S[S_THE]) / (te - te_last)
        S[S_C] = c
        S[S_TE] = te
        S[S_THE] = the
    elif not math.isnan(te_last):
        # no new edge: the speed is at most one count since the latest edge
        bound = P.D / max(t - te_last, 1e-300)
        w = w_prev if abs(w_prev) <= bound else math.copysign(bound, w_prev)
    else:
        w = w_prev
    a = (w - w_prev) / P.T if n > 1.0 else 0.0
    return w, a


@law
def sensor_law(t, q, qd, qdd, I, dm, dmd, P, S):
    """The kernel's SENSE slot: angle noise → encoder count → speed estimate → speed noise, and the
    current with its noise; → (angle, speed, acceleration) on the crank side and the current.

    ``q, qd, qdd``: the crank's exact values (q̈ the kernel's backward difference); ``dm, dmd``:
    the compliant gear's deflection and rate (motor = crank + δ), 0 for a rigid gear."""
    n = S[S_N]
    zz = P.zz
    if P.motor_own:
        th = zz * (q + dm)
        w_true = zz * (qd + dmd)
    else:
        th = zz * q
        w_true = zz * qd
    if P.sa > 0.0:
        th = th + P.sa * gauss(P.key_a, n)
    if P.quant:
        c = rint(th * P.inv_D)
        thm = P.D * c
    else:
        c = 0.0
        thm = th
    m = P.method
    inv_T = P.inv_T
    if m == DIFFERENCE:
        if n == 0.0:
            w = 0.0
            a = 0.0
        else:
            w = (thm - S[S_TH]) * inv_T
            a = (w - S[S_W]) * inv_T if n > 1.0 else 0.0
    elif m == OBSERVER:
        if n == 0.0:
            S[S_OTH] = thm
            S[S_OW] = 0.0
            w = 0.0
            a = 0.0
        else:
            pred = S[S_OTH] + P.T * S[S_OW]
            e = thm - pred
            S[S_OTH] = pred + P.alpha * e
            w = S[S_OW] + P.beta * inv_T * e
            a = P.beta * inv_T * inv_T * e
            S[S_OW] = w
    elif m == MT:
        w, a = mt_speed(t, c, th, w_true, n, P, S)
    else:  # the exact speed
        w = w_true
        if P.motor_own:  # the motor's own speed: its difference over the sample period
            a = (w - S[S_WT]) * inv_T if n > 0.0 else 0.0
            S[S_WT] = w
        else:
            a = zz * qdd
    if P.ss > 0.0:
        w = w + P.ss * gauss(P.key_s, n)
    S[S_N] = n + 1.0
    S[S_TH] = thm
    S[S_W] = w
    Im = I + P.sc * gauss(P.key_c, n) if P.sc > 0.0 else I
    inv_zz = P.inv_zz
    return thm * inv_zz, w * inv_zz, a * inv_zz, Im


class Sensor:
    """Encoder, speed estimator and noise of the measurement (see the module docstring).

    lines: encoder lines per revolution (0: no encoder, exact angle); side: "motor" | "output";
    edges: counts per line; speed: one of :data:`SPEED_METHODS`; bandwidth [Hz]: observer natural
    frequency (None: sample rate / 20); noise_* standard deviations [rad, rad/s, A] on the
    measured shaft; seed; delay: one-sample computation delay (applied by the kernel).

    Its law is :func:`sensor_law` (the kernel's SENSE slot, :meth:`form`); :meth:`start` and
    :meth:`measure` run the same law from Python."""

    def __init__(self, lines=0, side="motor", edges=4, speed="difference", bandwidth=None,
                 noise_angle=0.0, noise_speed=0.0, noise_current=0.0, seed=0, delay=False):
        if speed not in SPEED_METHODS:
            raise ParameterError(f"drive.sensor.speed = {speed!r}: choose one of {list(SPEED_METHODS)}")
        if side not in ("motor", "output"):
            raise ParameterError(f"drive.encoder.side = {side!r}: choose 'motor' or 'output'")
        if not (int(lines) == lines and lines >= 0):
            raise ParameterError(f"drive.encoder.lines = {lines!r}: must be a whole number >= 0")
        if edges not in (1, 2, 4):
            raise ParameterError(f"drive.encoder.edges = {edges!r}: choose 1, 2 or 4")
        if speed == "mt" and not lines > 0:
            raise ParameterError("drive.sensor.speed = 'mt' needs an encoder (drive.encoder.lines > 0)")
        for name, v in (("noise_angle", noise_angle), ("noise_speed", noise_speed), ("noise_current", noise_current)):
            if not (math.isfinite(float(v)) and float(v) >= 0.0):
                raise ParameterError(f"drive.sensor.{name} = {v!r}: must be finite and >= 0")
        if not (int(seed) == seed and seed >= 0):
            raise ParameterError(f"drive.sensor.seed = {seed!r}: must be a whole number >= 0")
        self.lines, self.side, self.edges = int(lines), side, int(edges)
        self.speed, self.bandwidth = speed, bandwidth
        self.noise_angle, self.noise_speed = float(noise_angle), float(noise_speed)
        self.noise_current = float(noise_current)
        self.seed, self.delay = int(seed), bool(delay)

    def describe(self) -> dict:
        return {"lines": self.lines, "side": self.side, "edges": self.edges, "speed": self.speed,
                "bandwidth_Hz": None if self.bandwidth is None else float(self.bandwidth),
                "noise_angle_rad": self.noise_angle, "noise_speed_rad_s": self.noise_speed,
                "noise_current_A": self.noise_current, "seed": self.seed, "delay": self.delay}

    @property
    def exact(self) -> bool:
        """No encoder, no noise, the exact speed: the kernel's own measurement (only the delay left)."""
        return (self.speed == "true" and self.lines == 0
                and not (self.noise_angle > 0 or self.noise_speed > 0 or self.noise_current > 0))

    @property
    def resolution(self) -> float:
        """Count width Δ = 2π/(lines·edges) [rad] on the measured shaft (0: no encoder)."""
        return 2.0 * math.pi / (self.lines * self.edges) if self.lines > 0 else 0.0

    def observer_gains(self, T):
        """(α, β) of the discrete observer for sample period T: α = 2ω_nT, β = (ω_nT)²."""
        fn = float(self.bandwidth) if self.bandwidth is not None else 1.0 / (20.0 * T)
        w = 2.0 * math.pi * fn * T
        a, b = 2.0 * w, w * w
        if not (a < 2.0 and b < 4.0 - 2.0 * a):
            raise ParameterError(f"drive.sensor.bandwidth = {fn!r} Hz: unstable for the sample period {T:g} s "
                                 f"(need 2π·f·T < 0.828)")
        return a, b

    # ------------------------------------------------------------------ the law's form
    def needs_law(self, compliant: bool = False) -> bool:
        """Whether the measurement differs from the kernel's exact one (else only the delay and the
        recorded columns remain): an encoder, noise, an estimate, or the motor of a compliant gear."""
        return not self.exact or (compliant and self.side == "motor")

    def params(self, z: float, T: float, compliant: bool = False) -> SensorP:
        """The law's parameters for gear ratio z, sample period T [s] and a compliant gear or not."""
        motor = self.side == "motor"
        zz = float(z) if motor else 1.0
        D = self.resolution
        alpha = beta = 0.0
        if self.speed == "observer":
            alpha, beta = self.observer_gains(T)
        return SensorP(SPEED_METHODS.index(self.speed), D > 0.0, D, (1.0 / D) if D > 0.0 else 0.0, zz, 1.0 / zz,
                       float(T), 1.0 / T, float(alpha), float(beta), bool(compliant and motor),
                       self.noise_angle, self.noise_speed, self.noise_current,
                       stream_key(self.seed, STREAM_ANGLE), stream_key(self.seed, STREAM_SPEED),
                       stream_key(self.seed, STREAM_CURRENT))

    @staticmethod
    def initial_state() -> np.ndarray:
        S = np.zeros(len(STATE))
        S[S_TE] = S[S_THE] = math.nan
        return S

    def form(self, z: float, T: float, compliant: bool = False) -> C.Form:
        """The kernel's SENSE form (:func:`sensor_law`)."""
        return C.Form(sensor_law, self.params(z, T, compliant), self.initial_state())

    # ------------------------------------------------------------------ Python use of the law
    def start(self, z: float, T: float, compliant: bool = False) -> "Sensor":
        """Fresh state for :meth:`measure` (a run of samples every T seconds, gear ratio z)."""
        self._P = self.params(z, T, compliant)
        self._S = self.initial_state()
        return self

    def measure(self, t, q, qd, qdd, I, dm=0.0, dmd=0.0):
        """One sample (after :meth:`start`): the law on the crank's exact values (and the compliant
        gear's deflection and rate) → (angle, speed, acceleration) crank side, current."""
        return sensor_law(float(t), float(q), float(qd), float(qdd), float(I), float(dm), float(dmd), self._P,
                          self._S)

    def state(self) -> dict:
        """The law's state after :meth:`start`/:meth:`measure` {name: value}."""
        return {k: float(v) for k, v in zip(STATE, self._S)}
