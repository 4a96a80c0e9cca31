"""Cascade position/velocity servo with feed-forward, as in an industrial servo drive.

    ω_cmd = φ̇_ref + K_pp·(φ_ref − φ)                         (P position loop, 1/s)
    V     = K_ffv·φ̇_ref + K_ffa·φ̈_ref + K_vp·(ω_cmd − φ̇) + K_vi·∫(ω_cmd − φ̇) dt

on the motor shaft [rad, rad/s, V].  The feed-forward gains cancel the back-EMF (+ viscous drop)
and the rigid-body inertia: K_ffv = k_m + R·λ/k_m [V·s/rad], K_ffa = R·J_rigid/k_m [V·s²/rad],
with J_rigid the inertia the motor would see through a rigid transmission (drive J_eq/z² plus the
mechanism's rigid J(q)/z² at q = 0; ``"auto"``).  The velocity integral is a rectangle rule over the
sample period, frozen while the output is clipped (v_limit).  Used to show how a real servo
departs from the ideal-servo hypothesis of seeds 001/003.

The law is :func:`servo_law`; the reference (a motion law, ``controllers/references/law.py``)
reaches it through the kernel's REF slot.  State (``STATE``): ``integ`` the velocity-loop
integral [V], ``t_prev`` the previous sample time [s] (NaN before the first sample).
"""
from __future__ import annotations

import math
from collections import namedtuple
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import Field

from mjbench.compiled import clip, law
from mjbench.errors import ParameterError
from mjbench.fields import OptQ, Q, Strict

from . import register
from mjbench.control import LAW_INPUTS, Controller
from .references.law import LawReferenceParams
from . import references

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


#: the servo law's parameters (gains on the motor shaft, output clip, gear ratio)
ServoP = namedtuple("ServoP", "kpp kvp kvi kffv kffa v_limit z")


@law(outputs=("u",))
def servo_law(t, q, qd, phi_ref, om_ref, acc_ref, P, S):
    """Cascade P-position / PI-velocity with feed-forward (module docstring), motor side (φ = z·q).
    S = [integral [V], previous sample time (NaN before the first)]: the rectangle rule over the
    measured sample interval, frozen while the output is clipped (conditional integration)."""
    z = P.z
    om_cmd = om_ref + P.kpp * (phi_ref - z * q)
    e_v = om_cmd - z * qd
    dt = 0.0 if math.isnan(S[1]) else t - S[1]
    S[1] = t
    u_noint = P.kffv * om_ref + P.kffa * acc_ref + P.kvp * e_v
    inc = P.kvi * e_v * dt
    u = u_noint + S[0] + inc
    vl = P.v_limit
    if (u > vl and inc > 0.0) or (u < -vl and inc < 0.0):  # vl = inf: never
        u -= inc  # conditional integration (anti-windup)
    else:
        S[0] += inc
    return clip(u, -vl, vl)


@register
class CascadeServo(Controller):
    type_name = "servo"
    Params = ServoParams
    STATE = ("integ", "t_prev")
    law = servo_law
    TUNABLE = {"kpp": (0.0, math.inf), "kvp": (0.0, math.inf), "kvi": (0.0, math.inf)}  # feed-forward kept

    def __init__(self, reference, kpp, kvp, kvi, kffv=0.0, kffa=0.0, v_limit=None, period=0.0):
        self.reference = reference
        for name, v in (("kpp", kpp), ("kvp", kvp), ("kvi", kvi), ("kffv", kffv), ("kffa", kffa)):
            if not (np.ndim(v) == 0 and math.isfinite(float(v))):
                raise ParameterError(f"servo {name} = {v!r}: must be a finite number")
        self.kpp, self.kvp, self.kvi = float(kpp), float(kvp), float(kvi)
        self.kffv, self.kffa = float(kffv), float(kffa)
        self.v_limit = v_limit
        self.period = float(period)
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None, reference=None):

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

    def parameters(self, T, z):
        vl = math.inf if self.v_limit is None else float(self.v_limit)
        return ServoP(self.kpp, self.kvp, self.kvi, self.kffv, self.kffa, vl, float(z))

    def initial_state(self):
        return np.array([0.0, math.nan])

    @property
    def integ(self):
        """The velocity-loop integral [V] of the Python calls (state)."""
        return self.state()["integ"]

    # ------------------------------------------------------------------ capabilities
    def linear(self, machine, op, T, h, angle="state"):
        """e_v = z·(q̇_ref + K_pp·(q_ref − q) − q̇); V = K_ffv·z·q̇_ref + K_ffa·z·q̈_ref + K_vp·e_v + s
        + K_vi·T·e_v, s⁺ = s + K_vi·T·e_v (rectangle rule, increment applied at once)."""
        import control as ct


        z = float(machine.drive.z)
        kpp, kvp, kvi, kffv, kffa = self.kpp, self.kvp, self.kvi, self.kffv, self.kffa
        ev = z * np.array([kpp, 1.0, 0.0, -kpp, -1.0, 0.0, 0.0])  # e_v from q_ref, qd_ref, qdd_ref, q, qd, qd_prev, I
        ff = z * np.array([0.0, kffv, kffa, 0.0, 0.0, 0.0, 0.0])
        A = np.array([[1.0]])
        B = (kvi * T * ev)[None, :]
        C = np.array([[1.0]])
        D = (ff + (kvp + kvi * T) * ev)[None, :]
        return ct.ss(A, B, C, D, T, inputs=list(LAW_INPUTS), outputs=["V"], states=["servo_integral"], name="servo")

    def hold_offset(self, machine, op):
        """K_vp·K_pp·z·q_off = V* − K_ffv·z·q̇* (the position loop's offset holds the point)."""
        z = float(machine.drive.z)
        rest = op.V - self.kffv * z * op.qd
        return rest / (self.kvp * self.kpp * z) if rest else 0.0
