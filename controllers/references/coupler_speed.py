"""Crank-speed reference for a prescribed coupler-point speed (seed 002, Eq 17).

The coupler point C moves along its closed path with speed V_C = S(q)·|q̇|, where
S(q) = |dC/dq| = √(r₂² + r_C²g₁² + 2·r₂·r_C·g₁·cos(q − φ₁ − β_C)) [m/rad] (Eqs 13-17).  For a
desired speed V_C the crank-speed reference is computed on-line from the *measured* crank angle:

    q̇_trj = V_C(s) / S(q)                                                          (Eq 17)

with s the path length travelled since q = 0 (``FourBar.arc_length``).  V_C(s) is

* ``profile = "constant"``: V_C = ``vc`` (the paper's case);
* ``profile = "piecewise"``: V_C = v_i on s ∈ [s_i, s_{i+1}) of every lap ("partially constant",
  §2), optional cosine blend of length ``blend`` [m] centred on each break;
* ``profile = "table"``: V_C linear in s between the points (s_i, v_i), periodic per lap
  ("fully variable");
* any Python callable ``vc(s_lap)`` [m → m/s] (API only; an attribute ``vc.derivative(s_lap)``
  gives dV_C/ds for ``derivative = "analytic"``).  It has no compiled form: a run with it executes
  the kernel in CPython (a Python adapter, ``meta["loop_reason"]`` says so).

``s`` breaks are in metres (``s_unit = "m"``) or in fractions of the path length
(``s_unit = "fraction"``); values are in m/s (``v``) or multiples of ``vc`` (``v_rel``).
``t_ramp`` [s] ramps V_C linearly from 0 at start-up; ``qd_max`` [rad/s] caps q̇_trj.

Motor-side outputs (motor = z × crank):  ω_ref = z·q̇_trj;  φ_ref = z·(q(0) + ∫q̇_trj dt), the
integral taken by the trapezoidal rule over the control steps, so that the PID integral term
K_i·(φ_ref − φ) is K_i·∫e dt of Eq 21 with e = q̇_trj − q̇ (Eq 22) (zero at t = 0);
ω̇_ref = z·dq̇_trj/dt, by default the backward difference of q̇_trj over the control period
(``derivative = "difference"``), the same operator the backends apply to the measured speed, so
that K_d·(ω̇_ref − ω̇) is the digital derivative of the error, K_d·Δe/h, of Eq 21.  Alternatives:
``"analytic"`` (dq̇_trj/dq · q̇ measured, + dV_C/ds·S·q̇/S for profiles) and ``"zero"``.
``kick = true`` (difference only): the derivative memory starts at q̇_trj = 0, so the D term
sees the reference step at start-up (one control step late, as a sampled controller whose first
sample has no predecessor), the way a continuous d e/dt with e(0⁻) = 0 (e.g. Simulink's
filtered derivative with zero initial state) would; default false: the step is not
differentiated.

**Laws** (one formula for the kernel, compiled or not, and the methods): the profile
``PROFILE(s_lap, P) → (V_C, dV_C/ds)`` (:func:`profile_constant`, :func:`profile_piecewise`,
:func:`profile_table`: breaks and values as arrays in P); the target :func:`coupler_target`
(Eq 17 with the ramp and the cap: S(q), dS/dq read from the four-bar's periodic spline table of
:func:`~mjbench.mechanisms.fourbar.coupler_speed_ratio_law`, ``FourBar.speed_ratio_table``, ≤ 1e-9
of the peak — the closed forms cost four trigonometric calls, two atan2 and a square root per
step —, s(q) by its :func:`~mjbench.mechanisms.linkage_kin.arc_length_law` on the tabulated arc
length); the reference
:func:`coupler_speed_law` (state: previous time, φ_ref, q̇_trj, the derivative memory, the last
ω̇_ref).  ``crank_speed``, ``vc_at`` and the FourBar methods run the same laws elementwise.

The object keeps the state of its Python calls: it must be called once per control step with
non-decreasing t; ``reset()`` clears it (a call with t below the previous one also does).  The
kernel starts every run from a fresh state.
"""

import math
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field

from mjbench import metrics as M
from mjbench.compiled import law
from mjbench.errors import ParameterError
from mjbench.mechanisms.linkage_kin import arc_length_law, ptable_channel
from mjbench.fields import Bool, Q, Strict

from mjbench.control import REF_INPUTS, REF_OUTPUTS, Reference
from mjbench import compiled as C

PROFILES = ("constant", "piecewise", "table")
DERIVATIVES = ("difference", "analytic", "zero")

#: a profile's parameters: vc [m/s]; n breaks s [m] with values v [m/s], the jump at each break
#: (v_i − v_{i−1}, periodic) and the blend length [m]; path length L [m]; the table's nodes sp
#: (s and L), values vp and slopes dv (n of them)
ProfileP = namedtuple("ProfileP", "vc n s v jumps blend L sp vp dv")


@law
def profile_constant(sl, P):
    """V_C = vc, dV_C/ds = 0."""
    return P.vc, 0.0


@law
def profile_piecewise(sl, P):
    """V_C = v_i on [s_i, s_{i+1}) of the lap, each break blended over ±blend/2 by a half cosine
    (periodic); → (V_C, dV_C/ds)."""
    i = 0
    for k in range(1, P.n):
        if P.s[k] <= sl:
            i = k
    out = P.v[i]
    dout = 0.0
    bl = P.blend
    if bl > 0.0:
        L = P.L
        for k in range(P.n):
            d = (sl - P.s[k] + 0.5 * L) % L - 0.5 * L
            if abs(d) < 0.5 * bl:
                w = 0.5 * (1.0 + math.sin(math.pi * d / bl))
                out = out + P.jumps[k] * (w - (1.0 if d >= 0.0 else 0.0))
                dout = dout + P.jumps[k] * 0.5 * math.pi / bl * math.cos(math.pi * d / bl)
    return out, dout


@law
def profile_table(sl, P):
    """V_C linear in s between the nodes (s_i, v_i) (and (L, v_0): periodic) → (V_C, dV_C/ds)."""
    j = 0
    for k in range(1, P.n):
        if P.sp[k] <= sl:
            j = k
    return P.vp[j] + P.dv[j] * (sl - P.sp[j]), P.dv[j]


#: the target's parameters: the coupler point's speed-ratio table (S, dS/dq: ``FourBar.speed_ratio_table``),
#: its arc-length P, the path length L [m], whether the profile needs s, the start-up ramp [s], the
#: cap q̇_max [rad/s], the profile's P
TargetP = namedtuple("TargetP", "ratio arc L need_s t_ramp qd_max profile")


@law
def coupler_target(PROFILE, t, q, P):
    """Eq 17 at crank angle q [rad] and time t [s]: → (q̇_trj, V_C, dV_C/ds, S, dS/dq, ramp) with
    V_C = PROFILE(s_lap)·ramp(t), q̇_trj = min(V_C/S(q), q̇_max)."""
    Sq = ptable_channel(q, 0, P.ratio)
    dS = ptable_channel(q, 1, P.ratio)
    sl = 0.0
    if P.need_s:
        sl = arc_length_law(q, P.arc) % P.L
    V, dV = PROFILE(sl, P.profile)
    ramp = 1.0
    if P.t_ramp > 0.0 and t < P.t_ramp:
        ramp = t / P.t_ramp
    V = V * ramp
    qdt = V / Sq
    if qdt > P.qd_max:
        qdt = P.qd_max
    return qdt, V, dV, Sq, dS, ramp


#: the reference's parameters: gear ratio z, derivative (0 difference, 1 analytic, 2 zero), kick,
#: the target's P
CouplerRefP = namedtuple("CouplerRefP", "z derivative kick target")


@law(outputs=("phi_ref", "om_ref", "acc_ref"))
def coupler_speed_law(TARGET, t, q, qd, P, S):
    """(φ_ref, ω_ref, ω̇_ref) motor side (module docstring).  S = [t_last (NaN: no sample yet),
    φ_ref, q̇_trj at t_last, the derivative memory, the last ω̇_ref/z]."""
    qdt, V, dV, Sq, dS, ramp = TARGET(t, q, P.target)
    z = P.z
    if math.isnan(S[0]) or t < S[0]:  # first call of a run
        S[0] = t
        S[1] = z * q
        S[2] = qdt
        S[3] = 0.0 * qdt if P.kick else qdt
        acc = 0.0 * qdt
    elif t == S[0]:  # repeated call at the same instant: do not advance
        acc = S[4]
    else:
        h = t - S[0]
        S[1] = S[1] + 0.5 * h * z * (qdt + S[2])
        if P.derivative == 0:
            acc = (qdt - S[3]) / h
        elif P.derivative == 1:
            # d/dt (V/S) along the measured motion: (dV/ds·S − V·dS/dq/S)·q̇/S
            acc = (dV * ramp - V * dS / (Sq * Sq)) * qd
        else:
            acc = 0.0 * qdt
        S[0] = t
        S[2] = qdt
        S[3] = qdt
    S[4] = acc
    return S[1], z * qdt, z * acc


class CouplerSpeed(Reference):
    """On-line Eq 17 reference.  ``mechanism`` needs ``speed_ratio_table()`` and ``arc_params()``
    (FourBar); ``z`` is the gear ratio (motor per crank)."""

    STATE = ("t_last", "phi", "qd_last", "qd_diff", "acc_last")
    law = coupler_speed_law

    def __init__(self, mechanism, z=1.0, vc=0.1, profile="constant", s=None, v=None, v_rel=None,
                 s_unit="m", blend=0.0, derivative="difference", qd_max=math.inf, t_ramp=0.0, kick=False):
        self.mechanism = mechanism
        self.z = float(z)
        if not (np.ndim(vc) == 0 and math.isfinite(float(vc)) and float(vc) >= 0):
            raise ParameterError(f"reference.vc = {vc!r}: desired coupler speed must be finite >= 0 [m/s]")
        self.vc = float(vc)
        self.derivative = str(derivative)
        if self.derivative not in DERIVATIVES:
            raise ParameterError(f"reference.derivative = {derivative!r}: choose one of {DERIVATIVES}")
        self.qd_max = float(qd_max)
        if not self.qd_max > 0:
            raise ParameterError(f"reference.qd_max = {qd_max!r}: must be > 0 [rad/s]")
        self.t_ramp = float(t_ramp)
        self.kick = bool(kick)
        if not (np.isfinite(self.t_ramp) and self.t_ramp >= 0):
            raise ParameterError(f"reference.t_ramp = {t_ramp!r}: must be finite >= 0 [s]")
        self.L = float(mechanism.path_length())
        self._user_fn = None
        self._profile = None
        if callable(profile):
            self.profile = "callable"
            self._user_fn = profile
        else:
            self.profile = str(profile)
            if self.profile not in PROFILES:
                raise ParameterError(f"reference.profile = {profile!r}: choose one of {PROFILES}")
            if self.profile == "constant":
                self._profile = ProfileP(self.vc, 0, *(np.zeros(1),) * 3, 0.0, self.L, *(np.zeros(1),) * 3)
            else:
                self._profile = self._make_profile(s, v, v_rel, s_unit, float(blend))
        self._target = None
        self.reset()

    # ------------------------------------------------------------------ profile V_C(s)
    def _make_profile(self, s, v, v_rel, s_unit, blend):
        if s is None or (v is None and v_rel is None):
            raise ParameterError(f"reference.profile = {self.profile!r} needs 's' and 'v' (m/s) or 'v_rel' (× vc)")
        s = np.asarray(s, dtype=float)
        if v is not None:
            vals = np.asarray(v, dtype=float)
        else:
            vals = np.asarray(v_rel, dtype=float) * float(self.vc)
        if s_unit == "fraction":
            s = s * self.L
        elif s_unit != "m":
            raise ParameterError(f"reference.s_unit = {s_unit!r}: choose 'm' or 'fraction'")
        if s.ndim != 1 or len(s) < 1 or len(s) != len(vals):
            raise ParameterError(f"reference.s and reference.v must be 1-D lists of equal length (got {len(s)}, {len(vals)})")
        if not np.all(np.isfinite(vals)) or np.any(vals < 0):
            raise ParameterError(f"reference.v = {vals.tolist()}: speeds must be finite >= 0 [m/s]")
        if s[0] != 0.0 or np.any(np.diff(s) <= 0) or s[-1] >= self.L:
            raise ParameterError(f"reference.s = {s.tolist()} m: must start at 0, increase, and stay below the "
                                 f"path length {self.L:.6g} m")
        if not (np.isfinite(blend) and blend >= 0):
            raise ParameterError(f"reference.blend = {blend!r}: must be finite >= 0 [m]")
        L = self.L
        sp = np.concatenate((s, [L]))
        vp = np.concatenate((vals, [vals[0]]))
        dv = np.diff(vp) / np.diff(sp)
        jumps = vals - np.roll(vals, 1)  # value before each break (periodic)
        c = np.ascontiguousarray
        return ProfileP(self.vc, int(len(s)), c(s), c(vals), c(jumps), blend, L, c(sp), c(vp), c(dv))

    def profile_form(self):
        """The profile's form: ``Form(PROFILE, ProfileP)``, or a Python adapter of a callable."""

        if self._user_fn is not None:
            fn = self._user_fn
            dfn = getattr(fn, "derivative", None)

            def adapter(sl, P):
                return float(fn(sl)), (float(dfn(sl)) if dfn is not None else 0.0)
            return C.python_form(adapter, "coupler-speed profile is a Python callable (no law)")
        law_ = {"constant": profile_constant, "piecewise": profile_piecewise, "table": profile_table}[self.profile]
        return C.Form(law_, self._profile)

    def target_form(self):
        """Eq 17's target as a form: ``Form(coupler_target, TargetP, fn_args=(profile,))``."""

        pf = self.profile_form()
        m = self.mechanism
        P = TargetP(m.speed_ratio_table().P, m.arc_params(), self.L, self.profile != "constant", self.t_ramp,
                    self.qd_max, pf.P)
        return C.Form(coupler_target, P, fn_args=(pf,))

    def _tgt(self):
        if self._target is None:
            f = self.target_form()
            self._target = (f.bound(), f.P)
        return self._target

    def _target_at(self, q, t, k):
        fn, P = self._tgt()
        tt = math.inf if t is None else t
        qa, ta = np.broadcast_arrays(np.asarray(q, dtype=float), np.asarray(tt, dtype=float))
        if qa.ndim == 0:
            return fn(float(ta), float(qa), P)[k]
        out = np.array([fn(b, a, P)[k] for a, b in zip(qa.ravel().tolist(), ta.ravel().tolist())])
        return out.reshape(qa.shape)

    def vc_at(self, q, t=None):
        """Desired coupler speed V_C [m/s] at crank angle(s) q [rad] (and time t, for the ramp)."""
        return self._target_at(q, t, 1)

    def _dvc_ds(self, q):
        """dV_C/ds [1/s] of the profile at crank angle(s) q (0 for a constant speed)."""
        return self._target_at(q, None, 2)

    def crank_speed(self, q, t=None):
        """q̇_trj(q) of Eq 17 [rad/s] (clamped to ``qd_max``)."""
        return self._target_at(q, t, 0)

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None):
        if mechanism is None or not hasattr(mechanism, "coupler_speed_ratio_derivative"):
            raise ParameterError("reference type 'coupler_speed' needs a four-bar mechanism with a coupler point")
        z = float(drive.z) if drive is not None else 1.0
        return cls(mechanism, z=z, vc=p.vc, profile=p.profile, s=p.s or None, v=p.v or None,
                   v_rel=p.v_rel or None, s_unit=p.s_unit, blend=p.blend, derivative=p.derivative,
                   qd_max=p.qd_max, t_ramp=p.t_ramp, kick=p.kick)

    # ------------------------------------------------------------------ the law's form
    def initial_state(self):
        return np.array([math.nan, 0.0, 0.0, 0.0, 0.0])

    def form(self, T, z):
        """``Form(coupler_speed_law, CouplerRefP, S0, fn_args=(target,))`` (z: the reference's own
        gear ratio, set from the drive when built)."""

        tf = self.target_form()
        P = CouplerRefP(self.z, DERIVATIVES.index(self.derivative), self.kick, tf.P)
        return C.Form(coupler_speed_law, P, self.initial_state(), fn_args=(tf,))

    def parameters(self, T, z):
        return self.form(T, z).P

    # ------------------------------------------------------------------ capabilities
    def metrics(self, tr, machine, config) -> dict:
        """The coupler-point speed tracking metrics (:func:`mjbench.metrics.coupler_tracking`,
        ``coupler_speed``), judged with the scenario's ``[metrics]`` settings."""
        cfg = {k: getattr(config, k, None) for k in ("settle_time", "band_rel", "rise_fraction", "crank_error_band")}
        cfg = {k: v for k, v in cfg.items() if v is not None}
        return {"coupler_speed": M.coupler_tracking(tr, machine.mechanism, self, **cfg)}

    def crank_speed_at(self, machine, q):
        return float(self.crank_speed(float(q)))

    def linear(self, machine, op, T, h, feedback=True):
        """Seed 002 Eq 17: q̇_trj = V_C/S(q) of the MEASURED angle: δq̇_trj = δqd_set + g·δq,
        g = ∂q̇_trj/∂q (central differences; ``feedback = False``: g = 0, the speed loop).
        States: r1 = integral part of q_ref (trapezoidal, as the reference integrates φ_ref),
        r2 = q̇_trj and r3 = q at the previous sample (for the trapezoid and the difference); the
        derivative as configured (difference: (q̇_trj − q̇_trj,prev)/T, the set-point part not
        differentiated; analytic: g·δq̇ + g'·q̇*·δq; zero)."""
        import control as ct


        e = 1e-4
        c0, cp, cm = (float(self.crank_speed(op.q + s)) for s in (0.0, e, -e))
        g = (cp - cm) / (2 * e) if feedback else 0.0
        gp = (cp - 2 * c0 + cm) / (e * e) if feedback else 0.0
        A = np.array([[1.0, 0.5 * T, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
        B = np.array([[0.0, 0.5 * T, 0.5 * T * g, 0.0], [0.0, 1.0, g, 0.0], [0.0, 0.0, 1.0, 0.0]])
        C = np.array([[1.0, 0.5 * T, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
        D = np.array([[1.0, 0.5 * T, 0.5 * T * g, 0.0], [0.0, 1.0, g, 0.0], [0.0, 0.0, 0.0, 0.0]])
        if self.derivative == "difference":
            C[2, 2], D[2, 2] = -g / T, g / T
        elif self.derivative == "analytic":
            D[2, 2], D[2, 3] = gp * op.qd, g
        return ct.ss(A, B, C, D, T, inputs=list(REF_INPUTS), outputs=list(REF_OUTPUTS),
                     states=["qref_int", "qdtrj_prev", "q_prev"], name="reference")


class CouplerSpeedParams(Strict):
    """``[modes.NAME.reference] type = "coupler_speed"`` (seed 002 Eq 17)."""

    type: Literal["coupler_speed"] = "coupler_speed"
    vc: Q("speed", ge=0.0) = Field(description="desired coupler-point speed V_C")
    profile: Literal["constant", "piecewise", "table"] = "constant"
    s: list[float] = Field(default_factory=list, description="profile breaks (s_unit)")
    v: list[float] = Field(default_factory=list, description="profile speeds [m/s]")
    v_rel: list[float] = Field(default_factory=list, description="profile speeds × vc")
    s_unit: Literal["m", "fraction"] = "m"
    blend: Q("length", ge=0.0, plausible=False) = Field(0.0, description="piecewise: cosine blend length")
    derivative: Literal["difference", "analytic", "zero"] = "difference"
    qd_max: Q("angular_velocity", gt=0.0, finite=False, plausible=False) = math.inf
    t_ramp: Q("time", ge=0.0, plausible=False) = 0.0
    kick: Bool = False
