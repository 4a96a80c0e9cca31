"""Speed PID on the motor shaft (seed 000, Eqs 14-16) with optional time-varying K_p·t.

    V_a(t) = K_p(t)·(φ̇_ref − φ̇) + K_i·(φ_ref − φ − φ_w) + K_d·(φ̈_ref − φ̈)          (Eq 16)

K_p(t) = K_p (Eq 14) or K_p·min(t, t_ramp_max) (Eq 15, ``kp_ramp=True``; ``t_ramp_max`` bounds
the ramp — the unbounded Eq 15 gain eventually destabilises any fixed-step integrator).

The integral term is written as the paper writes it: the integral of the speed error is the
angle error φ_ref − φ, available exactly from the measurement, so the PID has no integrator
state to discretise and behaves identically in both backends.  The derivative term uses
``y.omega_dot``, the backward difference of the shaft speed over one control period (see
:class:`controllers.base.Measurement`): the seed needs φ̈ (Eqs 16-19) without saying how it is
measured; a digital drive differences its speed signal.

Output saturation and anti-windup: with ``v_limit`` set, the output is clipped to ±v_limit and
the integral is *conditionally frozen* (clamping): during a control step in which the unclipped
output exceeds the limit and the step's integral increment pushes it further out, that increment
is moved into the windup offset φ_w instead of the integral.  Without saturation φ_w stays 0 and
the law is exactly Eq 16.  ``v_limit=None`` disables both (the backend's drive limiter still
applies).
"""
from __future__ import annotations

import math

import numpy as np

from .base import Controller
from .reference import ConstantSpeed


class PID(Controller):
    def __init__(self, kp, ki, kd, reference=None, omega0=None, kp_ramp=False,
                 t_ramp_max=math.inf, v_limit=None):
        if reference is None:
            if omega0 is None:
                raise ValueError("PID needs a reference or omega0 (motor speed set-point, rad/s)")
            reference = ConstantSpeed(omega0)
        self.kp, self.ki, self.kd = kp, ki, kd
        self.kp_ramp = bool(kp_ramp)
        self.t_ramp_max = t_ramp_max
        self.v_limit = v_limit
        self.reference = reference
        self.reset()

    def reset(self):
        self._tm_array = bool(np.ndim(self.t_ramp_max))
        self._offset = 0.0
        self._epos_prev = None
        if hasattr(self.reference, "reset"):
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
        phi_r, omega_r, acc_r = self.reference(t, y)
        e = omega_r - y.omega
        epos = phi_r - y.phi
        if self._epos_prev is None:
            self._epos_prev = epos
        u = (self.gain_p(t) * e + self.ki * (epos - self._offset)
             + self.kd * (acc_r - y.omega_dot))
        vl = self.v_limit
        if vl is not None:
            d = epos - self._epos_prev
            if isinstance(u, float):
                if (u > vl and d > 0) or (u < -vl and d < 0):
                    self._offset += d
                    u -= self.ki * d
                u = vl if u > vl else (-vl if u < -vl else u)
            else:
                # else freezing and clipping are no-ops (the common case); fmax ignores NaN rows
                if np.fmax.reduce(np.abs(u) - vl) > 0:
                    frozen = ((u > vl) & (d > 0)) | ((u < -vl) & (d < 0))
                    self._offset = self._offset + np.where(frozen, d, 0.0)
                    u = np.minimum(np.maximum(u - np.where(frozen, self.ki * d, 0.0), -vl), vl)  # clip
        self._epos_prev = epos
        return u


def from_params(params, drive=None, mechanism=None):
    """Scenario table → PID.  Keys: kp, ki, kd, omega0 (motor side, rad/s), kp_ramp,
    t_ramp_max, v_limit; or a ``reference`` sub-table {type = "<module in controllers.references>"}.

    ``side = "motor"`` (default): the gains act on motor-shaft errors (seed 000).  ``side = "crank"``:
    the gains are given for crank-side errors (seed 002 Eqs 21-22, e = q̇_trj − q̇); since every
    motor-side error is z × the crank-side one, the PID is built with kp/z, ki/z, kd/z — the same
    control law.  omega0 stays a motor speed."""
    p = dict(params)
    side = str(p.pop("side", "motor"))
    if side not in ("motor", "crank"):
        raise ValueError(f"PID side = {side!r}: choose 'motor' or 'crank'")
    if side == "crank":
        if drive is None:
            raise ValueError("PID side = 'crank' needs the drive (gear ratio z)")
        for k in ("kp", "ki", "kd"):
            if k in p:
                p[k] = float(p[k]) / drive.z
    ref = p.pop("reference", None)
    reference = None
    if isinstance(ref, dict):
        import importlib
        r = dict(ref)
        typ = r.pop("type")
        reference = importlib.import_module(f"controllers.references.{typ}").from_params(
            r, drive=drive, mechanism=mechanism)
    v_limit = p.pop("v_limit", None)
    return PID(float(p.pop("kp")), float(p.pop("ki")), float(p.pop("kd")), reference=reference,
               omega0=p.pop("omega0", None), kp_ramp=bool(p.pop("kp_ramp", False)),
               t_ramp_max=float(p.pop("t_ramp_max", math.inf)),
               v_limit=None if v_limit in (None, 0, "none") else float(v_limit),
               **_no_extra(p))


def _no_extra(p):
    if p:
        raise ValueError(f"unknown PID parameters: {sorted(p)}")
    return {}
