"""Cascade position/velocity servo with feed-forward, as in an industrial servo drive.

    ω_cmd = φ̇_ref + K_pp·(φ_ref − φ)                         (P position loop, 1/s)
    V     = K_ffv·φ̇_ref + K_ffa·φ̈_ref + K_vp·(ω_cmd − φ̇) + K_vi·∫(ω_cmd − φ̇) dt

on the motor shaft [rad, rad/s, V].  The feed-forward gains cancel the back-EMF (+ viscous drop)
and the rigid-body inertia: K_ffv = k_m + R·λ/k_m [V·s/rad], K_ffa = R·J_rigid/k_m [V·s²/rad],
with J_rigid the inertia the motor would see through a rigid transmission (drive J_eq/z² plus the
mechanism's rigid J(q)/z² at q = 0; ``"auto"``).  The velocity integral is a rectangle rule over the
sample period, frozen while the output is clipped (v_limit).  Used to show how a real servo
departs from the ideal-servo hypothesis of seeds 001/003.

State (``STATE``): ``integ`` the velocity-loop integral [V], ``t_prev`` the previous sample time.
Gains may be scalars or (nsim,) arrays.
"""
from __future__ import annotations

from typing import Annotated, Literal, Union

import numpy as np
from pydantic import Field

from mjbench.errors import ParameterError
from mjbench.schema import OptQ, Q, Strict

from . import register
from .base import Controller
from .references.law import LawReferenceParams

Auto = Union[Literal["auto"], float]


class ServoParams(Strict):
    """``[modes.NAME] type = "servo"``: cascade P-position / PI-velocity with feed-forward."""

    type: Literal["servo"] = "servo"
    kpp: Q("gain_per_s", ge=0.0) = Field(description="position loop gain [1/s]")
    kvp: Q("gain_v_per_rad_s", ge=0.0) = Field(description="velocity loop P [V·s/rad]")
    kvi: Q("gain_v_per_rad", ge=0.0) = Field(description="velocity loop I [V/rad]")
    kffv: Auto = Field("auto", description="speed feed-forward [V·s/rad] (auto: k_m + R·λ/k_m)")
    kffa: Auto = Field("auto", description="acceleration feed-forward [V·s²/rad] (auto: R·J_rigid/k_m)")
    v_limit: OptQ("voltage", gt=0.0) = None
    period: Q("time", ge=0.0, plausible=False) = 0.0
    reference: Annotated[LawReferenceParams, Field(description="what to track (default: the scenario's [law])")] = \
        Field(default_factory=LawReferenceParams)


@register
class CascadeServo(Controller):
    type_name = "servo"
    Params = ServoParams
    STATE = ("integ", "t_prev")

    def __init__(self, reference, kpp, kvp, kvi, kffv=0.0, kffa=0.0, v_limit=None, period=0.0):
        self.reference = reference
        for name, v in (("kpp", kpp), ("kvp", kvp), ("kvi", kvi), ("kffv", kffv), ("kffa", kffa)):
            if not np.all(np.isfinite(v)):
                raise ParameterError(f"servo {name} = {v!r}: must be finite")
        # gains stay as given: floats, or (nsim,) arrays in a batch
        self.kpp, self.kvp, self.kvi = kpp, kvp, kvi
        self.kffv, self.kffa = kffv, kffa
        self.v_limit = v_limit
        self.period = float(period)
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None, reference=None):
        from . import references

        if reference is None:
            reference = references.build(p.reference, drive=drive, mechanism=mechanism, scenario=scenario)
        kffv, kffa = p.kffv, p.kffa
        if kffv == "auto":
            kffv = 0.0 if drive is None else drive.k_m + drive.R * drive.lam / drive.k_m
        if kffa == "auto":
            J_rigid = 0.0
            if drive is not None:
                z = float(drive.z)
                J_rigid = float(drive.J_eq) / z ** 2
                if mechanism is not None:
                    J_rigid += float(mechanism.reduced(0.0)[0]) / z ** 2
            kffa = 0.0 if drive is None else drive.R * J_rigid / drive.k_m
        return cls(reference, p.kpp, p.kvp, p.kvi, float(kffv), float(kffa), p.v_limit, p.period)

    def reset(self):
        self.integ = 0.0
        self.t_prev = None
        self.reference.reset()

    def __call__(self, t, y):
        phi_r, om_r, acc_r = self.reference(t, y)
        om_cmd = om_r + self.kpp * (phi_r - y.phi)
        e_v = om_cmd - y.omega
        dt = 0.0 if self.t_prev is None else t - self.t_prev
        self.t_prev = t
        u_noint = self.kffv * om_r + self.kffa * acc_r + self.kvp * e_v
        inc = self.kvi * e_v * dt
        u = u_noint + self.integ + inc
        vl = self.v_limit
        if vl is None:
            self.integ = self.integ + inc
            return u
        if isinstance(u, float):
            if (u > vl and inc > 0) or (u < -vl and inc < 0):
                u -= inc  # conditional integration (anti-windup)
            else:
                self.integ += inc
            return vl if u > vl else (-vl if u < -vl else u)
        frozen = ((u > vl) & (inc > 0)) | ((u < -vl) & (inc < 0))
        u = np.where(frozen, u - inc, u)
        self.integ = self.integ + np.where(frozen, 0.0, inc)
        return np.minimum(np.maximum(u, -vl), vl)
