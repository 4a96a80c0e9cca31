"""A speed lead-lag K·(1 + s/ω_z)/(1 + s/ω_p), discretised by Tustin's rule at the sample period.

The law (one scalar function: the kernel runs it in CPython or compiles it with numba):
u_k = b0·e_k + b1·e_{k−1} − a1·u_{k−1}, e = φ̇_ref − φ̇ on the motor shaft; state S = [e_{k−1}, u_{k−1}].
b0, b1, a1 depend on the sample period T, so they are computed in ``parameters(T, z)``, once per
run (never in ``__init__``: a value stored on the object would be shared by every run of a batch).
"""
from __future__ import annotations

import math
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field

from controllers.base import Controller
from controllers.reference import ConstantSpeed
from mjbench.compiled import law
from mjbench.errors import ParameterError
from mjbench.fields import Q, Strict

LeadLagP = namedtuple("LeadLagP", "b0 b1 a1 z")


@law
def lead_lag_law(t, q, qd, qdd, I, phi_r, om_r, acc_r, P, S):
    e = om_r - P.z * qd
    u = P.b0 * e + P.b1 * S[0] - P.a1 * S[1]
    S[0] = e
    S[1] = u
    return u


def tustin(K, wz, wp, T):
    """(b0, b1, a1) of K·(1 + s/ω_z)/(1 + s/ω_p) by Tustin's rule at period T [s]."""
    c = 2.0 / T
    den = 1.0 + c / wp
    return K * (1.0 + c / wz) / den, K * (1.0 - c / wz) / den, (1.0 - c / wp) / den


class LeadLagParams(Strict):
    type: Literal["lead-lag"] = "lead-lag"
    K: Q("gain_v_per_rad_s") = Field(description="DC gain on the motor-speed error")
    wz: Q("gain_per_s", gt=0.0) = Field(description="zero [rad/s]")
    wp: Q("gain_per_s", gt=0.0) = Field(description="pole [rad/s]")
    omega0: Q("angular_velocity") = Field(description="motor-speed set-point")
    period: Q("time", ge=0.0) = Field(0.0, description="sample period (0: every co-simulation step)")


class LeadLag(Controller):
    type_name = "lead-lag"
    Params = LeadLagParams
    STATE = ("e_prev", "u_prev")
    law = lead_lag_law
    #: what ``mjbench tune --controller lead-lag`` searches: the gain, the zero and the pole, these
    #: two below the Nyquist rate π/T of a 1e-4 s sample period (≈ 3.1e4 rad/s)
    TUNABLE = {"K": (0.0, math.inf), "wz": (1.0, 3e4), "wp": (1.0, 3e4)}

    def __init__(self, K, wz, wp, omega0, period=0.0):
        self.K, self.wz, self.wp, self.period = float(K), float(wz), float(wp), float(period)
        self.reference = ConstantSpeed(omega0)
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        return cls(p.K, p.wz, p.wp, p.omega0, p.period)

    def parameters(self, T, z):
        if not T > 0:
            raise ParameterError("lead-lag needs its sample period (prepare(T) for Python calls)")
        return LeadLagP(*tustin(self.K, self.wz, self.wp, T), float(z))

    def linear(self, machine, op, T, h, angle="state"):
        """The law as a discrete-time state space (inputs of ``mjbench.linear.LAW_INPUTS``, output V)."""
        import control

        from mjbench.linear import LAW_INPUTS

        b0, b1, a1 = tustin(self.K, self.wz, self.wp, T)
        z = float(machine.drive.z)
        e = np.array([0.0, z, 0.0, 0.0, -z, 0.0, 0.0])  # e = z·(q̇_ref − q̇)
        return control.ss([[0.0, 0.0], [b1, -a1]], np.vstack([e, b0 * e]), [[b1, -a1]], [b0 * e], T,
                          inputs=list(LAW_INPUTS), outputs=["V"], name="lead-lag")
