"""A motion law as the motor-side reference: part of the component interface (:mod:`mjbench.control`).

:meth:`mjbench.motionlaws.MotionLaw.as_reference` returns a :class:`LawReference`; the reference
type ``law`` of a scenario (``controllers.references.law``) builds one from the scenario's ``[law]``.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from . import compiled as C
from .compiled import law
from .control import Reference

#: the reference's parameters: scale (motor rad per law rad), start time [s], the motion law's P
LawRefP = namedtuple("LawRefP", "scale t0 motion")


@law(outputs=("phi_ref", "om_ref", "acc_ref"))
def law_reference(MOTION, t, P, S):
    """(φ, φ̇, φ̈) of the motion law at t − t0, times ``scale`` (at rest before and after the move)."""
    p, v, a, j = MOTION(t - P.t0, 2, P.motion)
    s = P.scale
    return s * p, s * v, s * a


class LawReference(Reference):
    """A motion law (:class:`mjbench.motionlaws.MotionLaw`) as the motor-side reference:
    φ_ref(t) = scale·φ(t − t0) and its derivatives.  ``motion``: the law object."""

    STATE = ()
    law = law_reference

    def __init__(self, motion, scale=1.0, t0=0.0):
        self.motion, self.scale, self.t0 = motion, float(scale), float(t0)
        self.reset()

    def form(self, T, z):
        mf = self.motion.motion_form()
        return C.Form(law_reference, LawRefP(self.scale, self.t0, mf.P), self.initial_state(), fn_args=(mf,))

    def parameters(self, T, z):
        return self.form(T, z).P

    def crank_speed_at(self, machine, q):
        """The law's mean input speed Φ/(T·z) [rad/s]."""
        return float(self.motion.Phi) / float(self.motion.T) / float(machine.drive.z)

    def metrics(self, tr, machine, config) -> dict:
        """On a machine with an internal oscillator (the platforms of seeds 001/003): the residual
        vibration after the move (:meth:`~mjbench.mechanisms.platform.Oscillator.residual_metrics`) and
        the largest tracking error of the motor angle (``residual_vibration``)."""
        mech = machine.mechanism
        osc = getattr(mech, "oscillator", None)
        T = self.t0 + float(self.motion.T)
        after = float(tr.t[-1]) - T
        if not mech.internal or osc is None or after <= 0:
            return {}
        r = osc().residual_metrics(tr, T, after)
        pos = self.scale * np.asarray(self.motion.position(np.maximum(tr.t - self.t0, 0.0)), dtype=float)
        r["max_tracking_error_rad"] = float(np.max(np.abs(pos - tr.q)))
        return {"residual_vibration": r}

    def reference_angle(self, t):
        """φ_ref [rad, motor side] at times t [s] (array): the reference's own law, called once per
        time (what a run's tracking error is measured against)."""
        f = self.form(0.0, 1.0)
        fn, P, S = f.bound(), f.P, f.state()
        ta = np.asarray(t, dtype=float)
        out = np.array([fn(x, P, S)[0] for x in ta.ravel().tolist()], dtype=float)
        return out.reshape(ta.shape)
