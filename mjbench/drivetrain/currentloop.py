"""Inner PI current loop: the mode's controller sets a current reference, the PI the voltage.

    e_k = i*_k − I_k (measured),  x_k+1 = x_k + K_i·T_c·e_k,  V_k = K_p·e_k + x_k+1

sampled every T_c (the loop's ``period``, or every co-simulation step), output held in between,
clipped to ±V_max (the drive's v_max and the PWM bus) with conditional integration (the integral
is not advanced while the output is clipped in the direction of the error).  ``bandwidth`` f_c
gives K_p = L·ω_c, K_i = R·ω_c (ω_c = 2πf_c): the PI zero cancels the armature pole R/L and the
locked-rotor closed loop is the first-order lag 1/(1 + s/ω_c) (back-EMF: a slow disturbance the
integral removes).

The measured current I_k carries the sensor's current noise (``[drive.sensor] noise_current``)
from a stream of its own (:mod:`mjbench.drivetrain.noise`), drawn at the loop's sample k.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .. import compiled as C
from ..compiled import law
from ..errors import ParameterError
from .noise import STREAM_CURRENT_LOOP, gauss, stream_key

#: the loop's parameters: co-steps per sample, K_p, K_i·T_c, output bound V_max (inf: none),
#: current-noise deviation and its stream's key
CurrentLoopP = namedtuple("CurrentLoopP", "every kp kiT vmax sc key")
#: the loop's state: the integral x, the held output V
STATE = ("integral", "voltage")


@law
def current_loop_law(n, iref, I, P, S):
    """The kernel's CLOOP slot at co-step n: a PI sample every ``P.every`` steps (clip ±V_max,
    conditional integration), the output held in between → the armature voltage command [V]."""
    every = P.every
    if n % every != 0:
        return S[1]
    Im = I + P.sc * gauss(P.key, n // every) if P.sc > 0.0 else I
    e = iref - Im
    x = S[0]
    xn = x + P.kiT * e
    V = P.kp * e + xn
    vm = P.vmax
    if V > vm:
        if e > 0:
            xn = x
        V = P.kp * e + xn
        V = vm if V > vm else V
    elif V < -vm:
        if e < 0:
            xn = x
        V = P.kp * e + xn
        V = -vm if V < -vm else V
    S[0] = xn
    S[1] = V
    return V


class CurrentLoop:
    """PI current controller (see the module docstring).  kp [V/A], ki [V/(A·s)], period [s].

    Its law is :func:`current_loop_law` (the kernel's CLOOP slot, :meth:`form`); :meth:`start` and
    :meth:`__call__` run the same law from Python."""

    def __init__(self, kp, ki, period=0.0, bandwidth=None):
        for name, v in (("kp", kp), ("ki", ki)):
            if not (math.isfinite(float(v)) and float(v) >= 0):
                raise ParameterError(f"drive.current_loop.{name} = {v!r}: must be finite and >= 0")
        self.kp, self.ki = float(kp), float(ki)
        self.period = float(period)
        self.bandwidth = bandwidth

    @classmethod
    def from_bandwidth(cls, bandwidth, L, R, period=0.0):
        w = 2.0 * math.pi * bandwidth
        return cls(L * w, R * w, period, bandwidth)

    def describe(self) -> dict:
        return {"kp_V_per_A": self.kp, "ki_V_per_As": self.ki, "period_s": self.period,
                "bandwidth_Hz": None if self.bandwidth is None else float(self.bandwidth)}

    def every(self, h: float) -> int:
        """Co-simulation steps per loop sample (the period must be a whole multiple of h)."""
        if self.period <= 0:
            return 1
        k = int(round(self.period / h))
        if k < 1 or abs(self.period - k * h) > 1e-9 * max(self.period, h):
            raise ParameterError(f"drive.current_loop.period = {self.period:g} s must be a whole multiple of "
                                 f"the co-simulation step {h:g} s")
        return k

    # ------------------------------------------------------------------ the law's form
    def params(self, h: float, vmax: float, noise_current: float = 0.0, seed: int = 0) -> CurrentLoopP:
        """The law's parameters at co-step h [s] with output bound ``vmax`` [V] (inf: none) and the
        current sensor's noise deviation [A] and seed."""
        every = self.every(h)
        return CurrentLoopP(every, self.kp, self.ki * (every * h), float(vmax), float(noise_current),
                            stream_key(seed, STREAM_CURRENT_LOOP))

    def form(self, h: float, vmax: float, noise_current: float = 0.0, seed: int = 0) -> C.Form:
        """The kernel's CLOOP form (:func:`current_loop_law`)."""
        return C.Form(current_loop_law, self.params(h, vmax, noise_current, seed), np.zeros(len(STATE)))

    # ------------------------------------------------------------------ Python use of the law
    def start(self, h: float, vmax: float = math.inf, noise_current: float = 0.0, seed: int = 0) -> "CurrentLoop":
        """Fresh state for :meth:`__call__` (a run at co-step h)."""
        self._P = self.params(h, vmax, noise_current, seed)
        self._S = np.zeros(len(STATE))
        return self

    def __call__(self, n: int, iref, I) -> float:
        """Co-step n (after :meth:`start`): the voltage command for reference i* and current I."""
        return current_loop_law(int(n), float(iref), float(I), self._P, self._S)
