"""Sliding-mode speed control of the crank (seed 004, Eqs 35-37), sampled with a held output.

Sliding surface (Eq 35-36), crank side:  e₁ = ω − ω_d,  e₂ = ω̇ − ω̇_d,  s = λ·e₁ + e₂.

Control law: Eq 37 as printed is dimensionally inconsistent (λ·ė₁ multiplies an inertia) and drops
the reducer ratio n (SEED-ERRATA 004).  Our reading, with the motor model of Eqs 29-32:

    i* = [ (ℑ(q) + J_eq)·(ω̇_d − λ·e₁) + n²B_m·ω + n·T_f + C(q)·ω² − Q₀(q, ω, t) ] / (n·K_m)
    u  = R_m·i* + n·K_g·ω + L_m·ż₃ − K·sign(s)                         (``boundary = 0``)
    u  = R_m·i* + n·K_g·ω + L_m·ż₃ − K·sat(s/φ)                        (``boundary = φ > 0``)

i.e. the current that would give the reaching acceleration ω̇_d − λe₁ against the reduced model
(ℑ, C = ½ℑ', Q₀ = −E_p' + cutting force; J_eq = n²J the motor inertia reflected on the crank),
turned into a voltage through Eq 29.  ż₃ (= di/dt) is not measurable: ``didt = "zero"`` (default)
drops the term, ``"difference"`` uses the backward difference of the sampled current.
``model = false`` drops ℑ', C and Q₀ (only the motor terms are used).

With K = 1000 V and a ±48 V limit the switching term dominates: the law is a bang-bang switch,
whose residual error is set by the control sampling period ``Ts`` (SEED-ERRATA 004), a
parameter here: the output is computed at t = 0, Ts, 2Ts, ... and held in between.
Gains and set-point may be scalars or (nsim,) arrays; the measurement too.
"""
from __future__ import annotations

import math

import numpy as np

from .base import Controller


class SlidingMode(Controller):
    """Crank-speed SMC.  omega_d [rad/s] crank set-point, lam [1/s] surface slope, K [V] switching
    gain, boundary [rad/s²] boundary-layer width (0 = sign), Ts [s] control sampling period
    (0 = every call), v_limit [V] output clip (None = none)."""

    def __init__(self, omega_d, lam=50.0, K=1000.0, boundary=0.0, Ts=1e-3, v_limit=48.0,
                 drive=None, mechanism=None, model=True, didt="zero", T_f=0.0, omega_dot_d=0.0):
        if drive is None:
            raise ValueError("SlidingMode needs the drive (R, L, K_m, K_g, B_m, J, n) for Eq 37")
        if didt not in ("zero", "difference"):
            raise ValueError(f"smc.didt = {didt!r}: choose 'zero' or 'difference'")
        if not (np.all(np.asarray(Ts) >= 0) and np.ndim(Ts) == 0):
            raise ValueError(f"smc.Ts = {Ts!r}: must be a scalar >= 0 [s]")
        self.omega_d, self.lam, self.K, self.boundary = omega_d, lam, K, boundary
        self.Ts = float(Ts)
        self.v_limit = v_limit
        self.drive, self.mechanism = drive, mechanism
        self.model = bool(model) and mechanism is not None
        self.didt = didt
        self.T_f = T_f
        self.omega_dot_d = omega_dot_d
        self.reset()

    def reset(self):
        self._t0 = None
        self._k = None
        self._u = 0.0
        self._i_prev = None
        self._t_prev = None
        self.switches = 0  # sign changes of the switching term (chattering count)
        self._sgn_prev = None
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
        if self.didt == "difference" and self._i_prev is not None and t > self._t_prev:
            u = u + dr.L * (y.current - self._i_prev) / (t - self._t_prev)
        self._i_prev, self._t_prev = y.current, t
        if isinstance(self.boundary, float) and self.boundary == 0.0 or np.all(np.asarray(self.boundary) == 0):
            sw = np.sign(s)
        else:
            sw = np.clip(s / self.boundary, -1.0, 1.0)
        u = u - self.K * sw
        sg = np.sign(s)
        if self._sgn_prev is not None:
            self.switches = self.switches + (sg != self._sgn_prev) * (sg != 0)
        self._sgn_prev = sg
        self.s_last = s
        if self.v_limit is not None:
            u = np.clip(u, -self.v_limit, self.v_limit)
        if np.ndim(u) == 0:
            u = float(u)
        return u

    def __call__(self, t, y):
        if self.Ts <= 0.0:
            self._u = self.compute(t, y)
            return self._u
        if self._t0 is None:
            self._t0 = t
        k = math.floor((t - self._t0) / self.Ts + 1e-6)  # sample index (robust to rounding of t)
        if k != self._k:
            self._k = k
            self._u = self.compute(t, y)
        return self._u


def from_params(params, drive=None, mechanism=None):
    """Scenario table → SlidingMode.  Keys: omega_d [rad/s] (crank), lam [1/s], K [V],
    boundary [rad/s²] (0 = sign), Ts [s], v_limit [V] (0/"none" = none), model (bool),
    didt ("zero"|"difference"), T_f [N·m] (motor torque loss of Eq 30)."""
    p = dict(params)
    v_limit = p.pop("v_limit", 48.0)
    kw = dict(omega_d=float(p.pop("omega_d")), lam=float(p.pop("lam", 50.0)), K=float(p.pop("K", 1000.0)),
              boundary=float(p.pop("boundary", 0.0)), Ts=float(p.pop("Ts", 1e-3)),
              v_limit=None if v_limit in (None, 0, "none") else float(v_limit),
              model=bool(p.pop("model", True)), didt=str(p.pop("didt", "zero")), T_f=float(p.pop("T_f", 0.0)))
    if p:
        raise ValueError(f"unknown SMC parameters: {sorted(p)}")
    return SlidingMode(drive=drive, mechanism=mechanism, **kw)
