"""Crank-speed reference for a prescribed coupler-point speed (seed 002, Eq 17).

The coupler point C moves along its closed path with speed V_C = S(q)·|q̇|, where
S(q) = |dC/dq| = √(r₂² + r_C²g₁² + 2·r₂·r_C·g₁·cos(q − φ₁ − β_C)) [m/rad] (Eqs 13-17).  For a
desired speed V_C the crank-speed reference is computed on-line from the *measured* crank angle:

    q̇_trj = V_C(s) / S(q)                                                          (Eq 17)

with s the path length travelled since q = 0 (``FourBar.arc_length``).  V_C(s) is

* ``profile = "constant"``: V_C = ``vc`` (the paper's case);
* ``profile = "piecewise"``: V_C = v_i on s ∈ [s_i, s_{i+1}) of every lap ("partially constant",
  §2), optional cosine blend of length ``blend`` [m] centred on each break;
* ``profile = "table"``: V_C linear in s between the points (s_i, v_i), periodic per lap
  ("fully variable");
* any Python callable ``vc(s_lap)`` [m → m/s] (API only).

``s`` breaks are in metres (``s_unit = "m"``) or in fractions of the path length
(``s_unit = "fraction"``); values are in m/s (``v``) or multiples of ``vc`` (``v_rel``).

Motor-side outputs (motor = z × crank):  ω_ref = z·q̇_trj;  φ_ref = z·(q(0) + ∫q̇_trj dt), the
integral taken by the trapezoidal rule over the control steps, so that the PID integral term
K_i·(φ_ref − φ) is K_i·∫e dt of Eq 21 with e = q̇_trj − q̇ (Eq 22) (zero at t = 0);
ω̇_ref = z·dq̇_trj/dt, by default the backward difference of q̇_trj over the control period
(``derivative = "difference"``), the same operator the backends apply to the measured speed, so
that K_d·(ω̇_ref − ω̇) is the digital derivative of the error, K_d·Δe/h, of Eq 21.  Alternatives:
``"analytic"`` (dq̇_trj/dq · q̇ measured, + dV_C/ds·S·q̇/S for profiles) and ``"zero"``.
``kick = true`` (difference only): the derivative memory starts at q̇_trj = 0, so the D term
sees the reference step at start-up (one control step late, as a sampled controller whose first
sample has no predecessor), the way a continuous d e/dt with e(0⁻) = 0 (e.g. Simulink's
filtered derivative with zero initial state) would; default false: the step is not
differentiated.

The object keeps state (previous time, φ_ref, q̇_trj): it must be called once per control step
with non-decreasing t; ``reset()`` clears it (a call with t below the previous one also does).
Scalars or arrays of shape (nsim,) are accepted for the measurement (and ``vc``).
"""
from __future__ import annotations

import math

import numpy as np

from typing import Literal

from pydantic import Field

from mjbench.errors import ParameterError
from mjbench.schema import Bool, Q, Strict

PROFILES = ("constant", "piecewise", "table")
DERIVATIVES = ("difference", "analytic", "zero")


class CouplerSpeed:
    """On-line Eq 17 reference.  ``mechanism`` needs ``coupler_speed_ratio_derivative(q)`` and
    ``arc_length(q)``/``path_length()`` (FourBar); ``z`` is the gear ratio (motor per crank)."""

    def __init__(self, mechanism, z=1.0, vc=0.1, profile="constant", s=None, v=None, v_rel=None,
                 s_unit="m", blend=0.0, derivative="difference", qd_max=math.inf, t_ramp=0.0, kick=False):
        self.mechanism = mechanism
        self.z = z
        self.vc = vc
        self.derivative = str(derivative)
        if self.derivative not in DERIVATIVES:
            raise ParameterError(f"reference.derivative = {derivative!r}: choose one of {DERIVATIVES}")
        self.qd_max = float(qd_max)
        if not self.qd_max > 0:
            raise ParameterError(f"reference.qd_max = {qd_max!r}: must be > 0 [rad/s]")
        self.t_ramp = float(t_ramp)
        self.kick = bool(kick)
        if not (np.isfinite(self.t_ramp) and self.t_ramp >= 0):
            raise ParameterError(f"reference.t_ramp = {t_ramp!r}: must be finite >= 0 [s]")
        self.L = float(mechanism.path_length())
        self._fn = None
        if callable(profile):
            self.profile = "callable"
            self._fn = profile
        else:
            self.profile = str(profile)
            if self.profile not in PROFILES:
                raise ParameterError(f"reference.profile = {profile!r}: choose one of {PROFILES}")
            if self.profile == "constant":
                if not np.all(np.isfinite(vc)) or np.any(np.asarray(vc) < 0):
                    raise ParameterError(f"reference.vc = {vc!r}: desired coupler speed must be finite >= 0 [m/s]")
            else:
                self._fn = self._make_profile(s, v, v_rel, s_unit, float(blend))
        self.reset()

    # ------------------------------------------------------------------ profile V_C(s)
    def _make_profile(self, s, v, v_rel, s_unit, blend):
        if s is None or (v is None and v_rel is None):
            raise ParameterError(f"reference.profile = {self.profile!r} needs 's' and 'v' (m/s) or 'v_rel' (× vc)")
        s = np.asarray(s, dtype=float)
        if v is not None:
            vals = np.asarray(v, dtype=float)
        else:
            vals = np.asarray(v_rel, dtype=float) * float(self.vc)
        if s_unit == "fraction":
            s = s * self.L
        elif s_unit != "m":
            raise ParameterError(f"reference.s_unit = {s_unit!r}: choose 'm' or 'fraction'")
        if s.ndim != 1 or len(s) < 1 or len(s) != len(vals):
            raise ParameterError(f"reference.s and reference.v must be 1-D lists of equal length (got {len(s)}, {len(vals)})")
        if not np.all(np.isfinite(vals)) or np.any(vals < 0):
            raise ParameterError(f"reference.v = {vals.tolist()}: speeds must be finite >= 0 [m/s]")
        if s[0] != 0.0 or np.any(np.diff(s) <= 0) or s[-1] >= self.L:
            raise ParameterError(f"reference.s = {s.tolist()} m: must start at 0, increase, and stay below the "
                                 f"path length {self.L:.6g} m")
        if not (np.isfinite(blend) and blend >= 0):
            raise ParameterError(f"reference.blend = {blend!r}: must be finite >= 0 [m]")
        L = self.L
        if self.profile == "table":
            sp = np.concatenate((s, [L]))
            vp = np.concatenate((vals, [vals[0]]))
            dv = np.diff(vp) / np.diff(sp)

            def fn(sl):
                return np.interp(sl, sp, vp)

            def dfn(sl):
                i = np.clip(np.searchsorted(sp, sl, side="right") - 1, 0, len(dv) - 1)
                return dv[i]
        else:
            prev = np.roll(vals, 1)  # value before each break (periodic)
            jumps = vals - prev

            def fn(sl):
                i = np.searchsorted(s, sl, side="right") - 1
                out = vals[i]
                if blend > 0:
                    for k in range(len(s)):  # smooth each break over ±blend/2, periodic
                        d = (sl - s[k] + 0.5 * L) % L - 0.5 * L
                        inside = np.abs(d) < 0.5 * blend
                        w = 0.5 * (1.0 + np.sin(np.pi * d / blend))
                        out = np.where(inside, out + jumps[k] * (w - (d >= 0)), out)
                return out

            def dfn(sl):
                out = np.zeros_like(np.asarray(sl, dtype=float))
                if blend > 0:
                    for k in range(len(s)):
                        d = (sl - s[k] + 0.5 * L) % L - 0.5 * L
                        inside = np.abs(d) < 0.5 * blend
                        out = np.where(inside, out + jumps[k] * 0.5 * np.pi / blend * np.cos(np.pi * d / blend), out)
                return out
        fn.derivative = dfn
        return fn

    def vc_at(self, q, t=None):
        """Desired coupler speed V_C [m/s] at crank angle(s) q [rad] (and time t, for the ramp)."""
        if self._fn is None:
            v = self.vc + 0.0 * np.asarray(q, dtype=float) if not isinstance(q, float) else self.vc
        else:
            sl = np.mod(self.mechanism.arc_length(np.asarray(q, dtype=float)), self.L)
            v = self._fn(sl)
        if t is not None and self.t_ramp > 0:
            v = v * np.minimum(np.asarray(t, dtype=float) / self.t_ramp, 1.0)
        return v

    def _dvc_ds(self, q):
        if self._fn is None or not hasattr(self._fn, "derivative"):
            return 0.0 * q
        sl = np.mod(self.mechanism.arc_length(np.asarray(q, dtype=float)), self.L)
        return self._fn.derivative(sl)

    def crank_speed(self, q, t=None):
        """q̇_trj(q) of Eq 17 [rad/s] (clamped to ``qd_max``)."""
        S = self.mechanism.coupler_speed_ratio(q)
        qd = self.vc_at(q, t) / S
        return np.minimum(qd, self.qd_max) if not isinstance(qd, float) else min(qd, self.qd_max)

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None):
        if mechanism is None or not hasattr(mechanism, "coupler_speed_ratio_derivative"):
            raise ParameterError("reference type 'coupler_speed' needs a four-bar mechanism with a coupler point")
        z = float(drive.z) if drive is not None else 1.0
        return cls(mechanism, z=z, vc=p.vc, profile=p.profile, s=p.s or None, v=p.v or None,
                   v_rel=p.v_rel or None, s_unit=p.s_unit, blend=p.blend, derivative=p.derivative,
                   qd_max=p.qd_max, t_ramp=p.t_ramp, kick=p.kick)

    # ------------------------------------------------------------------ controller protocol
    STATE = ("t_last", "phi", "qd_last", "qd_diff", "acc_last")

    def reset(self):
        self.t_last = None
        self.phi = None
        self.qd_last = None
        self.qd_diff = None
        self.acc_last = None

    def __call__(self, t, y):
        q = y.q
        S, dS = self.mechanism.coupler_speed_ratio_derivative(q)
        if self._fn is None:
            V, dV = self.vc, 0.0
        else:
            V = self.vc_at(q)
            dV = self._dvc_ds(q)
        ramp = 1.0
        if self.t_ramp > 0 and t < self.t_ramp:
            ramp = t / self.t_ramp
        V = V * ramp
        qd = V / S
        if self.qd_max != math.inf:
            qd = min(qd, self.qd_max) if isinstance(qd, float) else np.minimum(qd, self.qd_max)
        z = self.z
        if self.t_last is None or t < self.t_last:  # first call of a run
            self.t_last, self.phi, self.qd_last = t, z * q, qd
            self.qd_diff = 0.0 * qd if self.kick else qd
            acc = 0.0 * qd
        elif t == self.t_last:  # repeated call at the same instant: do not advance
            acc = self.acc_last
        else:
            h = t - self.t_last
            self.phi = self.phi + 0.5 * h * z * (qd + self.qd_last)
            if self.derivative == "difference":
                acc = (qd - self.qd_diff) / h
            elif self.derivative == "analytic":
                # d/dt (V/S) along the measured motion: (dV/ds·S − V·dS/dq/S)·q̇/S
                acc = (dV * ramp - V * dS / (S * S)) * y.qd
            else:
                acc = 0.0 * qd
            self.t_last, self.qd_last, self.qd_diff = t, qd, qd
        self.acc_last = acc
        return self.phi, z * qd, z * acc


class CouplerSpeedParams(Strict):
    """``[modes.NAME.reference] type = "coupler_speed"`` (seed 002 Eq 17)."""

    type: Literal["coupler_speed"] = "coupler_speed"
    vc: Q("speed", ge=0.0) = Field(description="desired coupler-point speed V_C")
    profile: Literal["constant", "piecewise", "table"] = "constant"
    s: list[float] = Field(default_factory=list, description="profile breaks (s_unit)")
    v: list[float] = Field(default_factory=list, description="profile speeds [m/s]")
    v_rel: list[float] = Field(default_factory=list, description="profile speeds × vc")
    s_unit: Literal["m", "fraction"] = "m"
    blend: Q("length", ge=0.0, plausible=False) = Field(0.0, description="piecewise: cosine blend length")
    derivative: Literal["difference", "analytic", "zero"] = "difference"
    qd_max: Q("angular_velocity", gt=0.0, finite=False, plausible=False) = math.inf
    t_ramp: Q("time", ge=0.0, plausible=False) = 0.0
    kick: Bool = False
