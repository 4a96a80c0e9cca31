"""Sliding-mode speed control of the crank (seed 004, Eqs 35-37), sampled with a held output.

Sliding surface (Eq 35-36), crank side:  e₁ = ω − ω_d,  e₂ = ω̇ − ω̇_d,  s = λ·e₁ + e₂.

Control law: Eq 37 as printed is dimensionally inconsistent (λ·ė₁ multiplies an inertia) and drops
the reducer ratio n (docs/errata.md, Yiğit & Şen 2023).  Our reading, with the motor model of Eqs 29-32:

    i* = [ (ℑ(q) + J_eq)·(ω̇_d − λ·e₁) + n²B_m·ω + n·T_f + C(q)·ω² − Q₀(q, ω, t) ] / (n·K_m)
    u  = R_m·i* + n·K_g·ω + L_m·ż₃ − K·sign(s)                         (``boundary = 0``)
    u  = R_m·i* + n·K_g·ω + L_m·ż₃ − K·sat(s/φ)                        (``boundary = φ > 0``)

i.e. the current that would give the reaching acceleration ω̇_d − λe₁ against the reduced model
(ℑ, C = ½ℑ', Q₀ = −E_p' + cutting force; J_eq = n²J the motor inertia reflected on the crank),
turned into a voltage through Eq 29.  ż₃ (= di/dt) is not measurable: ``didt = "zero"`` (default)
drops the term, ``"difference"`` uses the backward difference of the sampled current.
``model = false`` drops ℑ', C and Q₀ (only the motor terms are used).

With K = 1000 V and a ±48 V limit the switching term dominates: the law is a bang-bang switch,
whose residual error is set by the control sampling period ``Ts`` (not given in the paper;
docs/quickreturn.md), a parameter here: it is the controller's ``period``, so the kernel computes
the output at t = 0, Ts, 2Ts, ... and holds it in between.
Gains and set-point may be scalars or (nsim,) arrays; the measurement too.

State (``STATE``): ``switches`` (sign changes of s, the chattering count), ``sgn_prev``,
``s_last``, and for ``didt = "difference"`` the previous current sample ``i_prev`` at ``t_prev``.
"""
from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from mjbench.errors import ParameterError
from mjbench.schema import Bool, OptQ, Q, Strict

from . import register
from .base import Controller


class SMCParams(Strict):
    """``[modes.NAME] type = "smc"`` (seed 004 Eqs 35-37, corrected reading)."""

    type: Literal["smc"] = "smc"
    omega_d: Q("angular_velocity") = Field(description="crank-speed set-point")
    lam: Q("gain_per_s", gt=0.0) = Field(50.0, description="sliding-surface slope λ [1/s]")
    K: Q("voltage", ge=0.0) = Field(1000.0, description="switching gain [V]")
    boundary: Q("angular_acceleration", ge=0.0) = Field(0.0, description="boundary-layer width (0: sign)")
    Ts: Q("time", ge=0.0, plausible=False) = Field(description="control sampling period (0: every co-simulation step)")
    v_limit: OptQ("voltage", gt=0.0) = Field(48.0, description="output clip (none: no clip)")
    model: Bool = Field(True, description="equivalent control uses the reduced model (ℑ, C, Q0)")
    didt: Literal["zero", "difference"] = "zero"
    T_f: Q("torque", ge=0.0) = Field(0.0, description="motor torque loss of Eq 30")


@register
class SlidingMode(Controller):
    """Crank-speed SMC.  omega_d [rad/s] crank set-point, lam [1/s] surface slope, K [V] switching
    gain, boundary [rad/s²] boundary-layer width (0 = sign), Ts [s] control sampling period
    (0 = every call), v_limit [V] output clip (None = none)."""

    type_name = "smc"
    Params = SMCParams
    STATE = ("switches", "sgn_prev", "s_last", "i_prev", "t_prev")

    def __init__(self, omega_d, lam=50.0, K=1000.0, boundary=0.0, Ts=1e-3, v_limit=48.0,
                 drive=None, mechanism=None, model=True, didt="zero", T_f=0.0, omega_dot_d=0.0):
        if drive is None:
            raise ParameterError("SlidingMode needs the drive (R, L, K_m, K_g, B_m, J, n) for Eq 37")
        if didt not in ("zero", "difference"):
            raise ParameterError(f"smc.didt = {didt!r}: choose 'zero' or 'difference'")
        if not (np.all(np.asarray(Ts) >= 0) and np.ndim(Ts) == 0):
            raise ParameterError(f"smc.Ts = {Ts!r}: must be a scalar >= 0 [s]")
        self.omega_d, self.lam, self.K, self.boundary = omega_d, lam, K, boundary
        self.Ts = float(Ts)
        self.period = self.Ts
        self.v_limit = v_limit
        self.drive, self.mechanism = drive, mechanism
        self.model = bool(model) and mechanism is not None
        self.didt = didt
        self.T_f = T_f
        self.omega_dot_d = omega_dot_d
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        return cls(omega_d=p.omega_d, lam=p.lam, K=p.K, boundary=p.boundary, Ts=p.Ts, v_limit=p.v_limit,
                   drive=drive, mechanism=mechanism, model=p.model, didt=p.didt, T_f=p.T_f)

    def reset(self):
        self.i_prev = None
        self.t_prev = None
        self.switches = 0  # sign changes of the switching term (chattering count)
        self.sgn_prev = None
        self.s_last = 0.0

    def sliding_variable(self, t, y):
        e1 = y.qd - self.omega_d
        e2 = y.qdd - self.omega_dot_d
        return e1, self.lam * e1 + e2

    def compute(self, t, y):
        """The control law at one sample (no hold)."""
        dr = self.drive
        n = dr.z
        w = y.qd
        e1, s = self.sliding_variable(t, y)
        J_tot = dr.J_eq
        torque = J_tot * (self.omega_dot_d - self.lam * e1) + n * n * dr.lam * w + n * (self.T_f + dr.T_0 * np.sign(w))
        if self.model:
            J, dJ, dEp = self.mechanism.reduced(y.q)
            Q0 = -dEp + self.mechanism.external_torque(y.q, w, t)
            torque = torque + J * (self.omega_dot_d - self.lam * e1) + 0.5 * dJ * w * w - Q0
        i_star = torque / (n * dr.k_m)
        u = dr.R * i_star + n * dr.k_m * w  # K_g = K_m in SI (Table II: both 0.678)
        if self.didt == "difference" and self.i_prev is not None and t > self.t_prev:
            u = u + dr.L * (y.current - self.i_prev) / (t - self.t_prev)
        self.i_prev, self.t_prev = y.current, t
        if isinstance(self.boundary, float) and self.boundary == 0.0 or np.all(np.asarray(self.boundary) == 0):
            sw = np.sign(s)
        else:
            sw = np.clip(s / self.boundary, -1.0, 1.0)
        u = u - self.K * sw
        sg = np.sign(s)
        if self.sgn_prev is not None:
            self.switches = self.switches + (sg != self.sgn_prev) * (sg != 0)
        self.sgn_prev = sg
        self.s_last = s
        if self.v_limit is not None:
            u = np.clip(u, -self.v_limit, self.v_limit)
        if np.ndim(u) == 0:
            u = float(u)
        return u

    def __call__(self, t, y):
        """One sample of the law (the kernel calls it every ``period`` = Ts and holds it)."""
        return self.compute(t, y)
