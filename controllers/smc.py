"""Sliding-mode speed control of the crank (seed 004, Eqs 35-37), sampled with a held output.

Sliding surface (Eq 35-36), crank side:  e₁ = ω − ω_d,  e₂ = ω̇ − ω̇_d,  s = λ·e₁ + e₂.

Control law: Eq 37 as printed is dimensionally inconsistent (λ·ė₁ multiplies an inertia) and drops
the reducer ratio n (docs/errata.md, Yiğit & Şen 2023).  Our reading, with the motor model of Eqs 29-32:

    i* = [ (ℑ(q) + J_eq)·(ω̇_d − λ·e₁) + n²B_m·ω + n·T_f + C(q)·ω² − Q₀(q, ω, t) ] / (n·K_m)
    u  = R_m·i* + n·K_g·ω + L_m·ż₃ − K·sign(s)                         (``boundary = 0``)
    u  = R_m·i* + n·K_g·ω + L_m·ż₃ − K·sat(s/φ)                        (``boundary = φ > 0``)

i.e. the current that would give the reaching acceleration ω̇_d − λe₁ against the reduced model
(ℑ, C = ½ℑ', Q₀ = −E_p' + cutting force; J_eq = n²J the motor inertia reflected on the crank),
turned into a voltage through Eq 29 (n·T_f also carries the drive's Coulomb T_0·sgn ω).  ż₃
(= di/dt) is not measurable: ``didt = "zero"`` (default) drops the term, ``"difference"`` uses the
backward difference of the sampled current.  ``model = false`` drops ℑ, C and Q₀ (only the motor
terms are used).

**The model the controller evaluates** is the mechanism's own reduced-model law
(:meth:`mjbench.mechanisms.base.Mechanism.model_form`): for a rigid crank mechanism the periodic
spline table of ℑ, ½ℑ', E_p' (:mod:`mjbench.backends.table`, measured ≤ 1e-9 of the closed forms,
relative) plus the mechanism's external-torque law — the same function the reduced plant
integrates — instead of the closed forms.  A mechanism without a model law runs its closed forms
through a Python adapter (the run is then not compiled, and says so).

With K = 1000 V and a ±48 V limit the switching term dominates: the law is a bang-bang switch,
whose residual error is set by the control sampling period ``Ts`` (not given in the paper;
docs/quickreturn.md), a parameter here: it is the controller's ``period``, so the kernel computes
the output at t = 0, Ts, 2Ts, ... and holds it in between.

The law is :func:`smc_law`, which takes the model law as its first argument (``Form.fn_args``);
the object's ``__call__`` runs the same law with the model bound.  State (``STATE``):
``switches`` (sign changes of s, the chattering count), ``sgn_prev`` (NaN before the first
sample), ``s_last``, and the previous current sample ``i_prev`` at ``t_prev`` (NaN before the
first sample; used by ``didt = "difference"``).
"""
from __future__ import annotations

import functools
import math
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field

from mjbench.compiled import clip, law, sgn
from mjbench.errors import ParameterError
from mjbench.fields import Bool, OptQ, Q, Strict

from . import register
from mjbench.control import FD_Q, LAW_INPUTS, Controller
from mjbench import compiled as C


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


#: the SMC law's parameters: set-point, surface, switching, clip, the drive's constants (n = z,
#: J_eq, n²λ, R, L, n·K_m, T_0), T_f, whether the model is used, di/dt by difference, the model's P
SMCP = namedtuple("SMCP", "omega_d omega_dot_d lam K boundary v_limit n J_eq n2lam R L k_m T_0 T_f use_model "
                          "didt_diff model")


@law
def no_model(q, qd, t, P):
    """The empty reduced model (``model = false``): ℑ = ½ℑ' = E_p' = Q_ext = 0."""
    return 0.0, 0.0, 0.0, 0.0


@law(outputs=("u",))
def smc_law(MODEL, t, q, qd, qdd, I, P, S):
    """Seed 004 Eq 37 (our reading, module docstring), sampled: crank speed ω = q̇, ω̇ = q̈ (the
    backward difference); MODEL(q, ω, t, P.model) → (ℑ, ½ℑ', E_p', Q_ext) the mechanism's reduced
    model.  S = [switches, sgn_prev, s_last, i_prev, t_prev].  → armature voltage [V]."""
    n = P.n
    w = qd
    e1 = w - P.omega_d
    s = P.lam * e1 + (qdd - P.omega_dot_d)
    a_r = P.omega_dot_d - P.lam * e1  # reaching acceleration
    torque = P.J_eq * a_r + P.n2lam * w + n * (P.T_f + P.T_0 * sgn(w))
    if P.use_model:
        J, H, E, Qx = MODEL(q, w, t, P.model)
        torque = torque + J * a_r + H * w * w - (Qx - E)  # Q₀ = Q_ext − E_p'
    i_star = torque / (n * P.k_m)
    u = P.R * i_star + n * P.k_m * w  # K_g = K_m in SI (Table II: both 0.678)
    if P.didt_diff and t > S[4]:  # S[4] NaN before the first sample: no term
        u = u + P.L * (I - S[3]) / (t - S[4])
    S[3] = I
    S[4] = t
    if P.boundary == 0.0:
        sw = sgn(s)
    else:
        sw = clip(s / P.boundary, -1.0, 1.0)
    u = u - P.K * sw
    sg = sgn(s)
    if not math.isnan(S[1]) and sg != S[1] and sg != 0.0:
        S[0] += 1.0
    S[1] = sg
    S[2] = s
    return clip(u, -P.v_limit, P.v_limit)


@register
class SlidingMode(Controller):
    """Crank-speed SMC.  omega_d [rad/s] crank set-point, lam [1/s] surface slope, K [V] switching
    gain, boundary [rad/s²] boundary-layer width (0 = sign), Ts [s] control sampling period
    (0 = every co-simulation step), v_limit [V] output clip (None = none), model (use the
    mechanism's reduced model), didt ("zero" | "difference"), T_f [N·m] motor torque loss."""

    type_name = "smc"
    Params = SMCParams
    STATE = ("switches", "sgn_prev", "s_last", "i_prev", "t_prev")
    law = smc_law
    TUNABLE = {"lam": (0.0, math.inf), "K": (0.0, math.inf)}

    def __init__(self, omega_d, lam=50.0, K=1000.0, boundary=0.0, Ts=1e-3, v_limit=48.0,
                 drive=None, mechanism=None, model=True, didt="zero", T_f=0.0, omega_dot_d=0.0):
        if drive is None:
            raise ParameterError("SlidingMode needs the drive (R, L, K_m, K_g, B_m, J, n) for Eq 37")
        if didt not in ("zero", "difference"):
            raise ParameterError(f"smc.didt = {didt!r}: choose 'zero' or 'difference'")
        if not (np.ndim(Ts) == 0 and np.all(np.asarray(Ts) >= 0)):
            raise ParameterError(f"smc.Ts = {Ts!r}: must be a scalar >= 0 [s]")
        for name, v in (("omega_d", omega_d), ("lam", lam), ("K", K), ("boundary", boundary), ("T_f", T_f),
                        ("omega_dot_d", omega_dot_d)):
            if not (np.ndim(v) == 0 and math.isfinite(float(v))):
                raise ParameterError(f"smc.{name} = {v!r}: must be a finite number")
        if float(boundary) < 0:
            raise ParameterError(f"smc.boundary = {boundary!r}: must be >= 0 [rad/s²]")
        self.omega_d, self.lam, self.K, self.boundary = float(omega_d), float(lam), float(K), float(boundary)
        self.Ts = float(Ts)
        self.period = self.Ts
        self.v_limit = v_limit
        self.drive, self.mechanism = drive, mechanism
        self.model = bool(model) and mechanism is not None
        self.didt = didt
        self.T_f = float(T_f)
        self.omega_dot_d = float(omega_dot_d)
        self._model = None
        self.reset()

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        return cls(omega_d=p.omega_d, lam=p.lam, K=p.K, boundary=p.boundary, Ts=p.Ts, v_limit=p.v_limit,
                   drive=drive, mechanism=mechanism, model=p.model, didt=p.didt, T_f=p.T_f)

    # ------------------------------------------------------------------ the law's form
    def model_form(self, mechanism=None):
        """The plant model the law evaluates: ``mechanism.model_form()`` (default: the controller's
        own mechanism, built once; also when ``mechanism`` is the machine's drive-train wrapper of
        it — the controller models the mechanism it was built for, not the drive-train elements),
        or :func:`no_model` with ``model = false``."""

        if not self.model:
            return C.Form(no_model)
        if mechanism is None or mechanism is self.mechanism or getattr(mechanism, "inner", None) is self.mechanism:
            if self._model is None:
                self._model = self.mechanism.model_form()
            return self._model
        return mechanism.model_form()

    def _parameters(self, T, model_form):
        dr = self.drive
        n = float(dr.z)
        vl = math.inf if self.v_limit is None else float(self.v_limit)
        return SMCP(self.omega_d, self.omega_dot_d, self.lam, self.K, self.boundary, vl, n, float(dr.J_eq),
                    n * n * float(dr.lam), float(dr.R), float(dr.L), float(dr.k_m), float(dr.T_0), self.T_f,
                    bool(self.model), self.didt == "difference", model_form.P)

    def parameters(self, T, z):
        """The law's parameters (the drive's constants are the controller's own drive: n = its z)."""
        return self._parameters(T, self.model_form())

    def form(self, T, machine):
        """``Form(smc_law, P, S0, fn_args=(model,))`` with the machine's mechanism's model law."""

        mf = self.model_form(machine.mechanism if machine is not None else None)
        return C.Form(smc_law, self._parameters(T, mf), self.initial_state(), fn_args=(mf,))

    def form_law(self):
        """:func:`smc_law` with the model law bound (what the kernel's CTRL slot runs)."""
        if self._bound is None:
            self._bound = functools.partial(smc_law, self.model_form().bound())
        return self._bound

    def initial_state(self):
        return np.array([0.0, math.nan, 0.0, math.nan, math.nan])

    def reset(self):
        super().reset()
        self._bound = None

    # ------------------------------------------------------------------ Python helpers
    def sliding_variable(self, t, y):
        """(e₁, s) at a measurement (Eqs 35-36)."""
        e1 = y.qd - self.omega_d
        e2 = y.qdd - self.omega_dot_d
        return e1, self.lam * e1 + e2

    def compute(self, t, y):
        """The control law at one sample (no hold): the law, run by ``__call__``."""
        return self(t, y)

    @property
    def switches(self):
        """Sign changes of s counted by the Python calls (state)."""
        return self.state()["switches"]

    # ------------------------------------------------------------------ capabilities
    def running_speed(self, machine, q):
        return self.omega_d

    def setpoint(self, machine):
        z = float(machine.drive.z)
        return {"input_rad_s": self.omega_d, "motor_rad_s": self.omega_d * z, "z": z,
                "source": "omega_d (crank shaft)"}

    def linear(self, machine, op, T, h, angle="state"):
        """Inside the boundary layer, |s| < φ: the computed-torque part linearised at the point
        (ℑ, ℑ', ℑ'' and Q₀ from the mechanism's closed forms by central differences) plus the
        linear switching term −(K/φ)·s, s = λ·e₁ + e₂, e₂ = (q̇ − qd_prev)/h − ω̇_d; ω_d ↔ qd_ref (a
        set-point offset).  ``angle = "frozen"``: the model terms do not follow δq.  With
        ``boundary = 0`` (sign) there is no linear counterpart (ParameterError)."""
        import control as ct


        if self.boundary <= 0.0:
            raise ParameterError("SMC with boundary = 0 switches (sign(s)): it has no linear counterpart; set "
                                 "modes.<mode>.boundary > 0 [rad/s²] (boundary layer) to analyse its linear part")
        dr, mech = self.drive, machine.mechanism
        n, km, R, L = float(dr.z), float(dr.k_m), float(dr.R), float(dr.L)
        lam, K, phi = self.lam, self.K, self.boundary
        q, w, t = op.q, op.qd, op.t
        e1 = w - self.omega_d
        Jt = float(dr.J_eq)
        dtq = dtw = 0.0  # ∂torque/∂q, ∂torque/∂w (computed-torque part)
        dtw += -Jt * lam + n * n * float(dr.lam)
        dtd = Jt * lam  # ∂torque/∂ω_d
        if self.model:
            J, dJ, _ = (float(v) for v in mech.reduced(q))
            e = FD_Q

            def Q0(qq, ww):
                return -float(mech.reduced(qq)[2]) + float(mech.external_torque(qq, ww, t))

            _, dJp, _ = mech.reduced(q + e)
            _, dJm, _ = mech.reduced(q - e)
            ddJ = (float(dJp) - float(dJm)) / (2 * e)
            Q0q = (Q0(q + e, w) - Q0(q - e, w)) / (2 * e)
            Q0w = (Q0(q, w + e) - Q0(q, w - e)) / (2 * e)
            dtq += dJ * (-lam * e1) + 0.5 * ddJ * w * w - Q0q
            dtw += -J * lam + dJ * w - Q0w
            dtd += J * lam
        if angle == "frozen":  # the angle is a parameter of the model-based terms
            dtq = 0.0
        c = R / (n * km)
        ks = K / phi
        Dm = np.array([[0.0, c * dtd + ks * lam, 0.0, c * dtq, c * dtw + n * km - ks * (lam + 1.0 / h), ks / h, 0.0]])
        if self.didt == "difference":  # + L·(I − I_prev)/T: one state, the previous current sample
            Dm[0, 6] = L / T
            return ct.ss([[0.0]], [[0, 0, 0, 0, 0, 0, 1.0]], [[-L / T]], Dm, T, inputs=list(LAW_INPUTS),
                         outputs=["V"], states=["I_prev"], name="smc")
        return ct.ss(np.zeros((0, 0)), np.zeros((0, 7)), np.zeros((1, 0)), Dm, T, inputs=list(LAW_INPUTS),
                     outputs=["V"], name="smc")
