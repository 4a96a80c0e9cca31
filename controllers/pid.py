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

State (``STATE``): ``offset`` φ_w [rad], ``epos_prev`` the previous angle error [rad],
``started`` (1 once ``epos_prev`` holds a sample).  The law is :func:`pid_law`; its linear
counterpart (:meth:`PID.linear`) is :func:`pid_counterpart` with K_p(t*) frozen.
"""

import math
from collections import namedtuple
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from mjbench.compiled import clip, law
from mjbench.errors import ParameterError
from mjbench.fields import Bool, OptQ, Q, Strict

from . import register
from mjbench.control import LAW_INPUTS, ConstantSpeed, Controller
from .references.coupler_speed import CouplerSpeedParams
from .references.law import LawReferenceParams
from mjbench.taskpath import PathReferenceParams
from . import references

ReferenceParams = Annotated[Union[CouplerSpeedParams, LawReferenceParams, PathReferenceParams],
                            Field(discriminator="type")]


class PIDParams(Strict):
    """``[modes.NAME] type = "pid"``: gains on motor-shaft errors (``side = "motor"``) or on
    crank-side errors (``side = "crank"``, seed 002 Eqs 21-22: built as kp/z, ki/z, kd/z)."""

    type: Literal["pid"] = "pid"
    kp: Q("gain_v_per_rad_s") = Field(description="proportional gain (×t with kp_ramp) [V·s/rad]")
    ki: Q("gain_v_per_rad") = Field(description="integral gain [V/rad]")
    kd: Q("gain_v_per_rad_s2") = Field(description="derivative gain [V·s²/rad]")
    omega0: OptQ("angular_velocity") = Field(None, description="speed set-point on the MOTOR shaft, φ̇ (the crank "
                                                                  "turns at omega0 / z); or omega_crank, or a reference table")
    omega_crank: OptQ("angular_velocity") = Field(None, description="speed set-point on the CRANK (input) shaft, α̇: "
                                                                       "the motor's is z·omega_crank")
    kp_ramp: Bool = Field(False, description="time-varying gain K_p·t (seed 000 Eq 15)")
    t_ramp_max: Q("time", gt=0.0, finite=False, plausible=False) = Field(math.inf, description="bound of the K_p·t ramp")
    v_limit: OptQ("voltage", gt=0.0) = Field(None, description="output clip + anti-windup (none: plain Eq 16)")
    side: Literal["motor", "crank"] = "motor"
    period: Q("time", ge=0.0, plausible=False) = Field(0.0, description="sample period (0: every co-simulation step)")
    reference: ReferenceParams | None = None

    @model_validator(mode="after")
    def _ref(self):
        given = [k for k in ("omega0", "omega_crank", "reference") if getattr(self, k) is not None]
        if not given:
            raise PydanticCustomError("mjbench_value", "needs a set-point: omega0 (motor shaft [rad/s]), omega_crank "
                                      "(crank shaft [rad/s]) or a [reference] table")
        if len(given) > 1:
            raise PydanticCustomError("mjbench_value", "give one of omega0 (motor shaft), omega_crank (crank shaft) or "
                                      "a [reference] table, not {keys}", {"keys": " and ".join(given)})
        return self

    def motor_setpoint(self, z: float):
        """The motor-shaft speed set-point [rad/s]: omega0, or z·omega_crank (None: a reference table)."""
        if self.omega0 is not None:
            return float(self.omega0)
        return None if self.omega_crank is None else float(z) * float(self.omega_crank)


#: the PID law's parameters (motor-side gains, K_p·t ramp and its bound, output clip, gear ratio)
PIDP = namedtuple("PIDP", "kp ki kd ramp t_ramp_max v_limit z")


@law(outputs=("u",))
def pid_law(t, q, qd, qdd, phi_ref, om_ref, acc_ref, P, S):
    """Eq 16 with K_p(t) (Eqs 14-15), output clip and conditional-integration anti-windup.

    Crank-side measurement (× z: the motor side), motor-side reference.  State: S[0] the windup
    offset φ_w [rad], S[1] the previous angle error [rad], S[2] 1 once S[1] is set."""
    z = P.z
    e = om_ref - z * qd
    epos = phi_ref - z * q
    prev = S[1] if S[2] != 0.0 else epos
    if P.ramp:
        kp = P.kp * (t if t < P.t_ramp_max else P.t_ramp_max)
    else:
        kp = P.kp
    ki = P.ki
    u = kp * e + ki * (epos - S[0]) + P.kd * (acc_ref - z * qdd)
    vl = P.v_limit
    d = epos - prev
    if (u > vl and d > 0.0) or (u < -vl and d < 0.0):  # vl = inf: never
        S[0] += d
        u -= ki * d
    u = clip(u, -vl, vl)
    S[1] = epos
    S[2] = 1.0
    return u


@register
class PID(Controller):
    type_name = "pid"
    Params = PIDParams
    STATE = ("offset", "epos_prev", "started")
    law = pid_law
    TUNABLE = {"kp": (0.0, math.inf), "ki": (0.0, math.inf), "kd": (0.0, math.inf)}
    TUNE_VARIANTS = {"pid": {"kp_ramp": False}, "pid-tv": {"kp_ramp": True}}  # constant K_p; K_p·t (Eq 15)

    def __init__(self, kp, ki, kd, reference=None, omega0=None, kp_ramp=False,
                 t_ramp_max=math.inf, v_limit=None, period=0.0):
        if reference is None:
            if omega0 is None:
                raise ParameterError("PID needs a reference or omega0 (motor speed set-point, rad/s)")
            reference = ConstantSpeed(omega0)
        for name, v in (("kp", kp), ("ki", ki), ("kd", kd)):
            if not (math.isfinite(v) if type(v) is float else np.all(np.isfinite(v))):
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
            reference = references.build(p.reference, drive=drive, mechanism=mechanism, scenario=scenario)
        omega0 = p.omega0
        if p.omega_crank is not None:
            if drive is None:
                raise ParameterError("PID omega_crank needs the drive (gear ratio z)")
            omega0 = p.motor_setpoint(drive.z)
        c = cls(kp, ki, kd, reference=reference, omega0=omega0, kp_ramp=p.kp_ramp,
                t_ramp_max=p.t_ramp_max, v_limit=p.v_limit, period=p.period)
        if p.omega_crank is not None:
            c.setpoint_given = "omega_crank (crank shaft)"
        return c

    def parameters(self, T, z):
        vl = math.inf if self.v_limit is None else float(self.v_limit)
        return PIDP(float(self.kp), float(self.ki), float(self.kd), bool(self.kp_ramp), float(self.t_ramp_max),
                    vl, float(z))

    @property
    def time_varying(self) -> bool:
        """K_p·t (Eq 15) changes with time."""
        return bool(self.kp_ramp)

    @property
    def offset(self):
        """The windup offset φ_w [rad] (state)."""
        return self.state()["offset"]

    def gain_p(self, t):
        """Proportional gain at time t [V·s/rad]."""
        if self.kp_ramp:
            return self.kp * np.minimum(t, self.t_ramp_max)
        return self.kp

    # ------------------------------------------------------------------ capabilities
    def linear(self, machine, op, T, h, angle="state"):
        """Eq 16 with K_p(t*) frozen at the operating point's time (:func:`pid_counterpart`; the
        generic numerical linearisation of :func:`pid_law` gives the same, tests/test_linearise.py)."""
        return pid_counterpart(float(np.asarray(self.gain_p(op.t))), float(self.ki), float(self.kd),
                               float(machine.drive.z), T, h)

    def frozen(self, t):
        """A copy with K_p·t frozen at K_p(t) (a constant gain)."""
        c = super().frozen(t)
        if self.kp_ramp:
            c.kp = float(np.asarray(self.gain_p(t)))
            c.kp_ramp = False
        return c

    #: the parameter the constant set-point was given by (``from_params``: omega0 or omega_crank)
    setpoint_given = "omega0 (motor shaft)"

    def setpoint(self, machine):
        sp = super().setpoint(machine)  # (the constant-speed reference's; a reference table: None)
        if sp is not None:
            sp["source"] = self.setpoint_given
        return sp

    def hold_offset(self, machine, op):
        """K_i·z·q_off = V* (the integral term alone holds the point: no speed or acceleration error)."""
        kp = float(np.asarray(self.gain_p(op.t)))
        if kp != float(np.asarray(self.gain_p(op.t + 1.0))):
            raise ParameterError("step_check: K_p·t changes during the run; use a constant K_p (kp_ramp = false)")
        z = float(machine.drive.z)
        return op.V / (float(self.ki) * z) if float(self.ki) else 0.0

    def divergence_hint(self, t, h):
        """Explanation appended to a divergence error (seed 000 errata: the unbounded K_p·t)."""
        if not self.kp_ramp:
            return ""
        return (f" The time-varying gain K_p·t = {np.max(self.gain_p(t)):.4g} V·s/rad at t = {t:.4g} s grows "
                f"without bound (Eq 15): past some t it exceeds the stability limit of the loop sampled "
                f"at h = {h:g} s. Use a smaller step (--set simulation.dt=...) or bound the ramp "
                f"(--set modes.<mode>.t_ramp_max=...).")


def pid_counterpart(kp, ki, kd, z, T, h):
    """Eq 16 as a DT system at period T: V = K_p·z·(q̇_ref − q̇) + K_i·z·(q_ref − q) +
    K_d·z·(q̈_ref − (q̇ − qd_prev)/h) (gains on motor-shaft errors; crank-side gains: z = 1)."""
    import control as ct

    D = float(z) * np.array([[ki, kp, kd, -ki, -kp - kd / h, kd / h, 0.0]], dtype=float)
    return ct.ss(np.zeros((0, 0)), np.zeros((0, 7)), np.zeros((1, 0)), D, T,
                 inputs=list(LAW_INPUTS), outputs=["V"], name="pid")
