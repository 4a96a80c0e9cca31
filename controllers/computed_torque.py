"""Computed-torque control of a machine with several inputs, from its own reduced model.

``[modes.NAME] type = "computed_torque"``: one controller for all axes.  With the joint references
q_r, q̇_r, q̈_r (input side: the axes' motor-side references ÷ z) and the reduced model of the
mechanism the machine is built from (:mod:`mjbench.mechanisms.linkage.multi`: M̄, c̄, ḡ, D̄),

    a   = q̈_r + K_d·(q̇_r − q̇) + K_p·(q_r − q),     K_p = ω_n², K_d = 2ζω_n
    τ   = (M̄(q) + diag J_eq)·a + c̄(q, q̇) + ḡ(q) + D̄(q)·q̇ + c·q̇

(the drives' reflected inertia J_eq and viscous c = z²λ included: the plant integrates them), so
that each axis's error obeys ë + K_d ė + K_p e = 0 while the model is right.  The command per axis:
a torque source's u = τ; a DC motor's armature voltage V = R·I* + k_m·z·q̇ with I* = (τ/z +
T_0·sgn φ̇)/k_m (the current that gives τ, L·dI/dt neglected).  The law reads the signals of every
axis (``q_0``, ``qd_1`` …) and writes ``u_0``, ``u_1``: two axes (the five-bar, the 2R arm).
"""
from __future__ import annotations

import math
from collections import namedtuple
from typing import Annotated, Literal

import numpy as np
from pydantic import Field

from mjbench import compiled as C
from mjbench.compiled import law, sgn
from mjbench.control import Controller
from mjbench.errors import ParameterError
from mjbench.fields import Q, Strict
from mjbench.taskpath import PathReferenceParams

from . import references, register


class ComputedTorqueParams(Strict):
    """``[modes.NAME] type = "computed_torque"``: model-based control of every axis at once."""

    type: Literal["computed_torque"] = "computed_torque"
    wn: Q("gain_per_s", gt=0.0) = Field(description="natural frequency ω_n of each axis's error dynamics [rad/s]")
    zeta: float = Field(1.0, gt=0.0, description="damping ratio ζ of the error dynamics")
    period: Q("time", ge=0.0, plausible=False) = Field(0.0, description="sample period (0: every co-simulation step)")
    reference: Annotated[PathReferenceParams, Field(description="what the axes track")] = \
        Field(default_factory=PathReferenceParams)


#: the law's parameters: gains, per axis the drive's (kind 1: DC motor, 0: torque source), J_eq, c,
#: z, R, k_m, T_0; the model's parameters
CTP = namedtuple("CTP", "kp kd kind Ja c z R km T0 model iw")


@law(outputs=("u_0", "u_1"))
def ct_law(MODEL, t, q_0, q_1, qd_0, qd_1, phi_ref_0, om_ref_0, acc_ref_0, phi_ref_1, om_ref_1, acc_ref_1, P, S):
    """Computed torque for two axes (module docstring); S: the model's work space.  MODEL: the
    mechanism's two-input model law, (M̄₀₀, M̄₀₁, M̄₁₁, bias₀, bias₁) at (q, q̇), its scratch at S[ic:]."""
    m00, m01, m11, g0, g1 = MODEL(q_0, q_1, qd_0, qd_1, t, P.model, S, P.iw + 6)
    a0 = acc_ref_0 / P.z[0] + P.kd * (om_ref_0 / P.z[0] - qd_0) + P.kp * (phi_ref_0 / P.z[0] - q_0)
    a1 = acc_ref_1 / P.z[1] + P.kd * (om_ref_1 / P.z[1] - qd_1) + P.kp * (phi_ref_1 / P.z[1] - q_1)
    tau0 = (m00 + P.Ja[0]) * a0 + m01 * a1 + g0 + P.c[0] * qd_0
    tau1 = m01 * a0 + (m11 + P.Ja[1]) * a1 + g1 + P.c[1] * qd_1
    return ct_command(tau0, qd_0, 0, P), ct_command(tau1, qd_1, 1, P)


@law
def ct_command(tau, qd, a, P):
    """The command of axis a that gives the input torque τ: τ itself (torque source) or the voltage."""
    if P.kind[a] == 0:
        return tau
    w = P.z[a] * qd
    i_star = (tau / P.z[a] + P.T0[a] * sgn(w)) / P.km[a]
    return P.R[a] * i_star + P.km[a] * w


@register
class ComputedTorque(Controller):
    """Computed-torque control of a two-input machine (module docstring)."""

    type_name = "computed_torque"
    Params = ComputedTorqueParams
    multi_axis = True  #: one controller for all axes
    TUNABLE = {"wn": (0.0, math.inf)}

    def __init__(self, wn, zeta=1.0, references=None, mechanism=None, period=0.0):
        if mechanism is None or getattr(mechanism, "n_inputs", 1) != 2:
            raise ParameterError("computed_torque: the machine needs exactly 2 inputs (its mechanism's reduced model "
                                 "M̄(q) is used)")
        self.wn, self.zeta, self.period = float(wn), float(zeta), float(period)
        self.mechanism = mechanism
        self.references = references
        self.reference = None
        self.axis = 0

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        refs = references.build(p.reference, drive=drive, mechanism=mechanism, scenario=scenario)
        return cls(p.wn, p.zeta, refs, mechanism, p.period)

    def form(self, T, machine):
        mf = self.mechanism.model_form()
        drives = machine.drives
        kind = np.array([1 if getattr(d, "type_name", "") == "dcmotor" else 0 for d in drives], dtype=np.int64)

        def arr(name, default=0.0):
            return np.array([float(getattr(d, name, default)) if k else default for d, k in zip(drives, kind)])

        n = 2
        P = CTP(self.wn ** 2, 2.0 * self.zeta * self.wn, kind, np.array([float(d.J_eq) for d in drives]),
                np.array([float(d.crank_damping) for d in drives]), np.array([float(d.z) for d in drives]),
                arr("R", 1.0), arr("k_m", 1.0), arr("T_0"), mf.P, 2 * n)
        S0 = np.zeros(2 * n + n * n + n + int(mf.flags.get("channels", 0)))
        return C.Form(ct_law, P, S0, fn_args=(mf,), what=f"controller {self.type_name!r}")

    def axis_references(self, n):
        """The per-axis references the kernel wires into each axis's REF slot."""
        return [self.references.for_axis(k) for k in range(n)]

    def metrics(self, tr, machine, config) -> dict:
        return self.references.metrics(tr, machine, config)

    def setpoint(self, machine):
        return None

    def linear(self, machine, op, T, h, angle="state"):
        raise ParameterError("computed_torque: its linear counterpart is the multi-axis loop's (mjbench linearize on "
                             "a machine with several inputs)")
