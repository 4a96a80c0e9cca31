"""Inner PI current loop: the mode's controller sets a current reference, the PI the voltage.

    e_k = i*_k − I_k (measured),  x_k+1 = x_k + K_i·T_c·e_k,  V_k = K_p·e_k + x_k+1

sampled every T_c (the loop's ``period``, or every co-simulation step), output held in between,
clipped to ±V_max (the drive's v_max and the PWM bus) with conditional integration (the integral
is not advanced while the output is clipped in the direction of the error).  ``bandwidth`` f_c
gives K_p = L·ω_c, K_i = R·ω_c (ω_c = 2πf_c): the PI zero cancels the armature pole R/L and the
locked-rotor closed loop is the first-order lag 1/(1 + s/ω_c) (back-EMF: a slow disturbance the
integral removes).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError


class CurrentLoop:
    """PI current controller (see the module docstring).  kp [V/A], ki [V/(A·s)], period [s]."""

    def __init__(self, kp, ki, period=0.0, bandwidth=None):
        for name, v in (("kp", kp), ("ki", ki)):
            if not np.all(np.isfinite(np.asarray(v, dtype=float))) or np.any(np.asarray(v) < 0):
                raise ParameterError(f"drive.current_loop.{name} = {v!r}: must be finite and >= 0")
        self.kp, self.ki = kp, ki
        self.period = float(period)
        self.bandwidth = bandwidth

    @classmethod
    def from_bandwidth(cls, bandwidth, L, R, period=0.0):
        w = 2.0 * math.pi * bandwidth
        return cls(L * w, R * w, period, bandwidth)

    def describe(self) -> dict:
        return {"kp_V_per_A": _plain(self.kp), "ki_V_per_As": _plain(self.ki), "period_s": self.period,
                "bandwidth_Hz": None if self.bandwidth is None else _plain(self.bandwidth)}

    def bind(self, h, vmax, nsim, measure=None):
        """(i*, I) ↦ V [V]; ``vmax`` output bound [V]; ``measure(I)`` the current sensor."""
        every = 1 if self.period <= 0 else int(round(self.period / h))
        if every < 1 or abs(self.period - every * h) > 1e-9 * max(self.period, h) and self.period > 0:
            raise ParameterError(f"drive.current_loop.period = {self.period:g} s must be a whole multiple of "
                                 f"the co-simulation step {h:g} s")
        Tc = every * h
        kp, kiT = self.kp, self.ki * Tc
        st = self._state = {"n": 0, "x": 0.0 if nsim is None else np.zeros(nsim), "V": 0.0}
        batch = nsim is not None
        unlimited = bool(np.all(np.isinf(vmax)))
        if not batch:
            kp, kiT, vm = float(kp), float(kiT), float(vmax)

            def loop(iref, I):
                n = st["n"]
                st["n"] = n + 1
                if n % every:
                    return st["V"]
                e = iref - (measure(I) if measure is not None else I)
                x = st["x"]
                xn = x + kiT * e
                V = kp * e + xn
                if not unlimited:
                    if V > vm:
                        if e > 0:
                            xn = x
                        V = kp * e + xn
                        V = vm if V > vm else V
                    elif V < -vm:
                        if e < 0:
                            xn = x
                        V = kp * e + xn
                        V = -vm if V < -vm else V
                st["x"], st["V"] = xn, V
                return V
            return loop

        def loop_a(iref, I):
            n = st["n"]
            st["n"] = n + 1
            if n % every:
                return st["V"]
            e = iref - (measure(I) if measure is not None else I)
            x = st["x"]
            xn = x + kiT * e
            V = kp * e + xn
            if not unlimited:
                frozen = ((V > vmax) & (e > 0)) | ((V < -vmax) & (e < 0))
                xn = np.where(frozen, x, xn)
                V = np.minimum(np.maximum(kp * e + xn, -vmax), vmax)
            st["x"], st["V"] = xn, V
            return V
        return loop_a


def _plain(v):
    return v.tolist() if isinstance(v, np.ndarray) else float(v)
