"""Cascade position/velocity servo with feed-forward, as in an industrial servo drive.

    ω_cmd = φ̇_ref + K_pp·(φ_ref − φ)                         (P position loop, 1/s)
    V     = K_ffv·φ̇_ref + K_ffa·φ̈_ref + K_vp·(ω_cmd − φ̇) + K_vi·∫(ω_cmd − φ̇) dt

on the motor shaft [rad, rad/s, V].  The feed-forward gains cancel the back-EMF (+ viscous drop)
and the rigid-body inertia: K_ffv = k_m + R·λ/k_m [V·s/rad], K_ffa = R·J_rigid/k_m [V·s²/rad],
with J_rigid the inertia the motor would see through a rigid transmission (set by
:func:`from_params` from the drive and the mechanism, ``"auto"``).  The velocity integral is
a rectangle rule over the (fixed) control period, frozen while the output is clipped (v_limit).
Used to show how a real servo departs from the ideal-servo hypothesis of seeds 001/003.
"""
from __future__ import annotations

from .base import Controller


class CascadeServo(Controller):
    def __init__(self, reference, kpp, kvp, kvi, kffv=0.0, kffa=0.0, v_limit=None):
        self.reference = reference
        self.kpp, self.kvp, self.kvi = float(kpp), float(kvp), float(kvi)
        self.kffv, self.kffa = float(kffv), float(kffa)
        self.v_limit = v_limit
        self.reset()

    def reset(self):
        self._integ = 0.0
        self._t_prev = None
        if hasattr(self.reference, "reset"):
            self.reference.reset()

    def __call__(self, t, y):
        phi_r, om_r, acc_r = self.reference(t, y)
        om_cmd = om_r + self.kpp * (phi_r - y.phi)
        e_v = om_cmd - y.omega
        dt = 0.0 if self._t_prev is None else t - self._t_prev
        self._t_prev = t
        u_noint = self.kffv * om_r + self.kffa * acc_r + self.kvp * e_v
        inc = self.kvi * e_v * dt
        u = u_noint + self._integ + inc
        vl = self.v_limit
        if vl is not None and ((u > vl and inc > 0) or (u < -vl and inc < 0)):
            u -= inc  # conditional integration (anti-windup)
        else:
            self._integ += inc
        if vl is not None:
            u = vl if u > vl else (-vl if u < -vl else u)
        return u


def from_params(params, drive=None, mechanism=None, reference=None):
    """Keys: kpp [1/s], kvp [V·s/rad], kvi [V/rad], kffv, kffa ("auto" or a number), v_limit [V].
    ``reference``: an object (t, y) → (φ_ref, φ̇_ref, φ̈_ref) (e.g. ``MotionLaw.as_reference()``)."""
    p = dict(params)
    if reference is None:
        raise ValueError("servo controller needs a reference (a motion law)")
    kffv, kffa = p.pop("kffv", "auto"), p.pop("kffa", "auto")
    if kffv == "auto":
        kffv = 0.0 if drive is None else drive.k_m + drive.R * drive.lam / drive.k_m
    if kffa == "auto":
        J_rigid = 0.0
        if drive is not None:
            J_rigid += drive.J_eq
        if mechanism is not None and hasattr(mechanism, "oscillator"):
            o = mechanism.oscillator()
            J_rigid += getattr(mechanism, "J_motor", 0.0) + o.ratio ** 2 * o.J
        kffa = 0.0 if drive is None else drive.R * J_rigid / drive.k_m
    v_limit = p.pop("v_limit", None)
    ctrl = CascadeServo(reference, float(p.pop("kpp")), float(p.pop("kvp")), float(p.pop("kvi")),
                        float(kffv), float(kffa), None if v_limit in (None, 0, "none") else float(v_limit))
    if p:
        raise ValueError(f"unknown servo parameters: {sorted(p)}")
    return ctrl
