"""Speed PID on the motor shaft (seed 000, Eqs 14-16) with optional time-varying K_p·t.

    V_a(t) = K_p(t)·(φ̇_ref − φ̇) + K_i·(φ_ref − φ − φ_w) + K_d·(φ̈_ref − φ̈)          (Eq 16)

K_p(t) = K_p (Eq 14) or K_p·min(t, t_ramp_max) (Eq 15, ``kp_ramp=True``; ``t_ramp_max`` bounds
the ramp — the unbounded Eq 15 gain eventually destabilises any fixed-step integrator).

The integral term is written as the paper writes it: the integral of the speed error is the
angle error φ_ref − φ, available exactly from the measurement, so the PID has no integrator
state to discretise and behaves identically in both backends.  The derivative term uses
``y.omega_dot``, the backward difference of the shaft speed over one co-simulation step (see
:class:`controllers.base.Measurement`): the seed needs φ̈ (Eqs 16-19) without saying how it is
measured; a digital drive differences its speed signal.

Output saturation and anti-windup: with ``v_limit`` set, the output is clipped to ±v_limit and
the integral is *conditionally frozen* (clamping): during a control step in which the unclipped
output exceeds the limit and the step's integral increment pushes it further out, that increment
is moved into the windup offset φ_w (state ``offset``) instead of the integral.  Without
saturation φ_w stays 0 and the law is exactly Eq 16.  ``v_limit=None`` disables both (the
backend's drive limiter still applies).

State (``STATE``): ``offset`` φ_w [rad], ``epos_prev`` the previous angle error [rad].
"""
from __future__ import annotations

import math
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from mjbench.errors import ParameterError
from mjbench.schema import Bool, OptQ, Q, Strict

from . import register
from .base import Controller
from .reference import ConstantSpeed
from .references.coupler_speed import CouplerSpeedParams
from .references.law import LawReferenceParams

ReferenceParams = Annotated[Union[CouplerSpeedParams, LawReferenceParams], Field(discriminator="type")]


class PIDParams(Strict):
    """``[modes.NAME] type = "pid"``: gains on motor-shaft errors (``side = "motor"``) or on
    crank-side errors (``side = "crank"``, seed 002 Eqs 21-22: built as kp/z, ki/z, kd/z)."""

    type: Literal["pid"] = "pid"
    kp: Q("gain_v_per_rad_s") = Field(description="proportional gain (×t with kp_ramp) [V·s/rad]")
    ki: Q("gain_v_per_rad") = Field(description="integral gain [V/rad]")
    kd: Q("gain_v_per_rad_s2") = Field(description="derivative gain [V·s²/rad]")
    omega0: OptQ("angular_velocity") = Field(None, description="motor-speed set-point (or a reference table)")
    kp_ramp: Bool = Field(False, description="time-varying gain K_p·t (seed 000 Eq 15)")
    t_ramp_max: Q("time", gt=0.0, finite=False, plausible=False) = Field(math.inf, description="bound of the K_p·t ramp")
    v_limit: OptQ("voltage", gt=0.0) = Field(None, description="output clip + anti-windup (none: plain Eq 16)")
    side: Literal["motor", "crank"] = "motor"
    period: Q("time", ge=0.0, plausible=False) = Field(0.0, description="sample period (0: every co-simulation step)")
    reference: ReferenceParams | None = None

    @model_validator(mode="after")
    def _ref(self):
        if self.reference is None and self.omega0 is None:
            raise PydanticCustomError("mjbench_value", "needs omega0 (motor-speed set-point [rad/s]) or a [reference] table")
        if self.reference is not None and self.omega0 is not None:
            raise PydanticCustomError("mjbench_value", "give omega0 or a [reference] table, not both")
        return self


@register
class PID(Controller):
    type_name = "pid"
    Params = PIDParams
    STATE = ("offset", "epos_prev")

    def __init__(self, kp, ki, kd, reference=None, omega0=None, kp_ramp=False,
                 t_ramp_max=math.inf, v_limit=None, period=0.0):
        if reference is None:
            if omega0 is None:
                raise ParameterError("PID needs a reference or omega0 (motor speed set-point, rad/s)")
            reference = ConstantSpeed(omega0)
        for name, v in (("kp", kp), ("ki", ki), ("kd", kd)):
            if not np.all(np.isfinite(v)):
                raise ParameterError(f"PID {name} = {v!r}: must be finite")
        self.kp, self.ki, self.kd = kp, ki, kd
        self.kp_ramp = bool(kp_ramp)
        self.t_ramp_max = t_ramp_max
        self.v_limit = v_limit
        self.reference = reference
        self.period = float(period)
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        kp, ki, kd = p.kp, p.ki, p.kd
        if p.side == "crank":  # every motor-side error is z × the crank-side one
            if drive is None:
                raise ParameterError("PID side = 'crank' needs the drive (gear ratio z)")
            kp, ki, kd = kp / drive.z, ki / drive.z, kd / drive.z
        reference = None
        if p.reference is not None:
            from . import references
            reference = references.build(p.reference, drive=drive, mechanism=mechanism, scenario=scenario)
        return cls(kp, ki, kd, reference=reference, omega0=p.omega0, kp_ramp=p.kp_ramp,
                   t_ramp_max=p.t_ramp_max, v_limit=p.v_limit, period=p.period)

    def reset(self):
        self._tm_array = bool(np.ndim(self.t_ramp_max))
        self._const_ref = type(self.reference) is ConstantSpeed  # inlined in __call__ (hot path)
        self.offset = 0.0
        self.epos_prev = None
        self.reference.reset()

    def gain_p(self, t):
        """Proportional gain at time t [V·s/rad]."""
        if self.kp_ramp:
            tm = self.t_ramp_max
            if self._tm_array:  # (nsim,) ramp limits
                return self.kp * np.minimum(t, tm)
            return self.kp * (t if t < tm else tm)
        return self.kp

    def divergence_hint(self, t, h):
        """Explanation appended to a divergence error (seed 000 errata: the unbounded K_p·t)."""
        if not self.kp_ramp:
            return ""
        return (f" The time-varying gain K_p·t = {np.max(self.gain_p(t)):.4g} V·s/rad at t = {t:.4g} s grows "
                f"without bound (Eq 15): past some t it exceeds the stability limit of the loop sampled "
                f"at h = {h:g} s. Use a smaller step (--set simulation.dt=...) or bound the ramp "
                f"(--set modes.<mode>.t_ramp_max=...).")

    def __call__(self, t, y):
        ref = self.reference
        if self._const_ref:  # ConstantSpeed.__call__ inlined: the same operations, one call less per sample
            omega_r = ref.omega0
            ps = ref.phi_start
            if ps is None:
                ref.phi_start = ps = y.phi - omega_r * t
            phi_r, acc_r = ps + omega_r * t, 0.0 * omega_r
        else:
            phi_r, omega_r, acc_r = ref(t, y)
        e = omega_r - y.omega
        epos = phi_r - y.phi
        prev = self.epos_prev
        if prev is None:
            prev = epos
        if not self.kp_ramp:
            kp = self.kp
        elif self._tm_array:
            kp = self.gain_p(t)
        else:  # gain_p(t) inlined (the per-step hot path of a single run)
            tm = self.t_ramp_max
            kp = self.kp * (t if t < tm else tm)
        ki = self.ki
        u = kp * e + ki * (epos - self.offset) + self.kd * (acc_r - y.omega_dot)
        vl = self.v_limit
        if vl is not None:
            d = epos - prev
            if isinstance(u, float):
                if (u > vl and d > 0) or (u < -vl and d < 0):
                    self.offset += d
                    u -= ki * d
                u = vl if u > vl else (-vl if u < -vl else u)
            else:
                # else freezing and clipping are no-ops (the common case); fmax ignores NaN rows
                if np.fmax.reduce(np.abs(u) - vl) > 0:
                    frozen = ((u > vl) & (d > 0)) | ((u < -vl) & (d < 0))
                    self.offset = self.offset + np.where(frozen, d, 0.0)
                    u = np.minimum(np.maximum(u - np.where(frozen, self.ki * d, 0.0), -vl), vl)  # clip
        self.epos_prev = epos
        return u
