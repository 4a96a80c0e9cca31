"""Crank-shaper quick-return mechanism of seed 004 (Yiğit & Şen 2023), geometry reconstructed.

The kinematic figure (Fig. 4) is missing from the seed; the geometry below is read from the vector
loops Eqs 3-6 (see docs/quickreturn.md and docs/quickreturn_geometry.png):

* frame: origin at the lever pivot B₀, x horizontal, y vertical (up); gravity −y;
* crank (link 2, length r₂, angle q = θ₂) pivots at A₀ = (0, a), a distance ``a`` above B₀;
* a block rides on the crank pin A and slides in the slot of the lever (link 3, pivot B₀, angle
  θ₃ = φ₁, length r₃); s₂₁ = |B₀A| (Eq 3, "s21");
* a connecting rod (link 4, length r₄, angle θ₄ = φ₂) joins the lever tip B to the output slider
  C (link 5) moving on the horizontal line y = a + b; Eq 4: r₃e^{iθ₃} + r₄e^{iθ₄} = i(a+b) − s₅₁,
  so x_C = −s₅₁ (φ₃ = s₅₁).

a > r₂ makes the lever oscillate (crank-shaper, not Whitworth).  The lever extremes are where
the crank is normal to the lever (sin q = −r₂/a), so the time ratio is
TR = (π + 2δ)/(π − 2δ), δ = asin(r₂/a), and the slider stroke is ≈ 2·r₃·r₂/a (constraint c3).
Assembly mode k = ±1 picks cos θ₄ = k·√(1 − sin²θ₄) (k = +1: slider to the right of the lever tip).

Influence coefficients (own derivation; Eqs 13 and 18 agree with it, Eqs 19-20 are misprinted,
see docs/errata.md):  with s² = r₂² + a² + 2ar₂ sin q,
    g₁ = dθ₃/dq = (r₂² + a r₂ sin q)/s²,              g₁' = a r₂ (a² − r₂²) cos q / s⁴
    g₂ = dθ₄/dq = −r₃ cos θ₃ g₁ /(r₄ cos θ₄)
    g₂' = (r₃ sin θ₃ g₁² + r₄ sin θ₄ g₂² − r₃ cos θ₃ g₁')/(r₄ cos θ₄)
    x_C' = −r₃ sin θ₃ g₁ − r₄ sin θ₄ g₂  ( = −g₃ of Eq 13 )
    x_C'' = −r₃ cos θ₃ g₁² − r₃ sin θ₃ g₁' − r₄ cos θ₄ g₂² − r₄ sin θ₄ g₂'
Reduced (Eksergian) model, Eqs 24-28 with Eq 26 read as Q = Σ F·g + T·g_θ:
    J(q) = J_A₀ + (J_B₀ + I_blk) g₁² + m₄|v_G4|² + I_G4 g₂² + m₅ x_C'²,
    J_A₀ = I_G2 + m₂c₂² + m_blk r₂²,  J_B₀ = I_G3 + m₃c₃²   (I_Gi about the mass centres, Eq 25)
The cutting force acts on the slider against its motion during the slow (working) stroke.

In MuJoCo the plane (x, y) maps to (x, z) and hinges turn about −y (as fourbar.py), so every
hinge angle is the paper's counter-clockwise angle and MuJoCo's default gravity is −y.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from typing import Literal

from pydantic import Field

from .. import compiled as C
from .table import table_model
from ..compiled import law
from ..errors import GeometryError, ParameterError
from ..fields import OptQ, Q, Strict
from . import register
from .linkage_kin import PeriodicTable, ptable_channel
from .base import HINGE_AXIS, INPUT_JOINT, Mechanism, closure_solref, new_spec
from .base import table_form
from .linkage import Linkage, LinkageParams, table_from_quickreturn
from ..trajectory import atomic_write
from .mjcf_export import standalone_xml

G = 9.81  #: gravitational acceleration [m/s²]
AXIS = HINGE_AXIS  #: hinge axis in MuJoCo (the plane convention of mechanisms/base.py)


CUT_PROFILES = ("stroke", "window", "sine", "none")


def _xp(x):
    return math if isinstance(x, float) else np


@dataclass
class QuickReturn(Mechanism):
    """Seed-004 quick-return mechanism.  Lengths [m], masses [kg], inertias about the mass
    centres [kg·m²], forces [N].  Defaults: Table I (mm → m, I × 1e-4)."""

    r2: float = 0.054      # crank
    r3: float = 0.324      # lever (slotted)
    r4: float = 0.078      # connecting rod
    a: float = 0.140       # |A₀B₀|: crank pivot above lever pivot
    b: float = 0.207       # slider line at y = a + b
    m2: float = 0.35
    m3: float = 0.32
    m4: float = 0.36
    m5: float = 1.0        # output slider ("s_s1" row of Table I)
    I_G2: float = 8.95e-4
    I_G3: float = 53e-4
    I_G4: float = 8.5e-4
    c2: float | None = None  # mass-centre distances from the proximal joint [m]; None = mid-length
    c3: float | None = None
    c4: float | None = None
    m_block: float = 0.01    # block on the crank pin sliding in the lever slot (not in Table I)
    I_block: float = 1e-7
    k: int = 1
    g: float = G
    cut_force: float = 50.0      # §4: cutting force [N]
    cut_profile: str = "stroke"  # stroke | window | sine | none
    cut_start: float = 0.0       # window: fraction of the working stroke where cutting starts
    cut_end: float = 1.0         # ... and ends
    name: str = "quickreturn"
    type_name = "quickreturn"

    @classmethod
    def from_params(cls, p):
        return cls(**{k: getattr(p, k) for k in _KEYS})

    def __post_init__(self):
        for nm, L in (("c2", self.r2), ("c3", self.r3), ("c4", self.r4)):
            if getattr(self, nm) is None:
                setattr(self, nm, 0.5 * L)
        self.check()
        self._prepare()

    # ================================================================ validation
    def check(self, n: int = 3600):
        """ParameterError for non-physical values, GeometryError if the linkage cannot be
        assembled for every crank angle (message names the parameters)."""
        for nm in ("r2", "r3", "r4", "a", "b"):
            v = getattr(self, nm)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ParameterError(f"quickreturn.{nm} = {v!r}: length must be a finite number > 0 [m]")
        for nm in ("m2", "m3", "m4", "m5", "I_G2", "I_G3", "I_G4", "m_block", "I_block", "c2", "c3", "c4"):
            v = getattr(self, nm)
            if not (math.isfinite(v) and v >= 0):
                raise ParameterError(f"quickreturn.{nm} = {v!r}: must be finite and >= 0")
        for nm in ("g", "cut_force"):
            if not math.isfinite(getattr(self, nm)):
                raise ParameterError(f"quickreturn.{nm} = {getattr(self, nm)!r}: must be finite")
        if self.k not in (1, -1):
            raise ParameterError(f"quickreturn.k = {self.k!r}: assembly mode must be +1 or -1")
        if self.cut_profile not in CUT_PROFILES:
            raise ParameterError(f"quickreturn.cut_profile = {self.cut_profile!r}: choose one of {CUT_PROFILES}")
        if not (0.0 <= self.cut_start < self.cut_end <= 1.0):
            raise ParameterError(f"quickreturn.cut_start/cut_end = {self.cut_start!r}/{self.cut_end!r}: "
                                 "need 0 <= cut_start < cut_end <= 1 (fractions of the working stroke)")
        if not self.a > self.r2 * (1 + 1e-9):
            raise GeometryError(
                f"quick-return: crank r2 = {self.r2} m must be shorter than the pivot distance a = {self.a} m "
                "(a <= r2: the lever would turn fully or the block would pass through the lever pivot B0)")
        # rod reach: |a + b − r3 sin θ3| < r4 over the lever swing (θ3 ∈ [π/2 − δ, π/2 + δ])
        H = self.a + self.b
        lo, hi = self.r3 * math.sqrt(1 - (self.r2 / self.a) ** 2), self.r3  # range of r3 sin θ3
        worst = max(abs(H - lo), abs(H - hi))
        if worst >= self.r4 * (1 - 1e-6):
            raise GeometryError(
                f"quick-return: rod r4 = {self.r4} m cannot reach the slider line y = a + b = {H:.6g} m "
                f"from the lever tip (r3 = {self.r3} m, r2 = {self.r2} m, a = {self.a} m, b = {self.b} m): "
                f"needs r4 > max|a + b − r3·sin θ3| = {worst:.6g} m over the lever swing (else no assembly or "
                "a toggle with the rod vertical)")

    # ================================================================ position analysis (Eqs 3-8)
    def _prepare(self):
        """Crank angles of the slider extremes, working (slow) stroke and its direction."""
        d = math.asin(self.r2 / self.a)
        # lever extremes: crank normal to the lever, sin q = −r2/a  (g1 = 0)
        q_a, q_b = -d, math.pi + d  # ccw from q_a to q_b passes q = π/2: the long (slow) arc
        self.delta = d
        arc_up = q_b - q_a
        if arc_up >= math.pi:
            self._work_q0, self._work_arc = q_a, arc_up
        else:  # pragma: no cover - cannot happen with a > r2 > 0
            self._work_q0, self._work_arc = q_b, 2 * math.pi - arc_up
        qm = self._work_q0 + 0.5 * self._work_arc
        self._work_sign = 1.0 if self.slider_x_derivs(qm)[1] > 0 else -1.0
        self._x_start = float(self.slider_x_derivs(self._work_q0)[0])
        self._x_end = float(self.slider_x_derivs(self._work_q0 + self._work_arc)[0])

    def angles(self, q):
        """(θ₃, θ₄, s₂₁): lever angle, rod angle [rad] and block distance from B₀ [m]."""
        xp = _xp(q)
        r2, a = self.r2, self.a
        Ax, Ay = r2 * xp.cos(q), a + r2 * xp.sin(q)
        th3 = xp.atan2(Ay, Ax) if xp is math else np.arctan2(Ay, Ax)
        s21 = xp.sqrt(Ax * Ax + Ay * Ay)
        s4 = (self.a + self.b - self.r3 * xp.sin(th3)) / self.r4
        c4 = self.k * xp.sqrt(1.0 - s4 * s4)
        th4 = xp.atan2(s4, c4) if xp is math else np.arctan2(s4, c4)
        return th3, th4, s21

    def kin(self, q):
        """Everything up to second order: dict with th3, th4, s21, ds21, xC and the influence
        coefficients g1, g2, dg1, dg2 (dθ/dq, d²θ/dq²), xd = dx_C/dq, xdd = d²x_C/dq²."""
        xp = _xp(q)
        r2, r3, r4, a = self.r2, self.r3, self.r4, self.a
        sq, cq = xp.sin(q), xp.cos(q)
        Ax, Ay = r2 * cq, a + r2 * sq
        S2 = Ax * Ax + Ay * Ay
        s21 = xp.sqrt(S2)
        th3 = math.atan2(Ay, Ax) if xp is math else np.arctan2(Ay, Ax)
        s3, c3 = Ay / s21, Ax / s21
        sn4 = (a + self.b - r3 * s3) / r4
        cs4 = self.k * xp.sqrt(1.0 - sn4 * sn4)
        th4 = math.atan2(sn4, cs4) if xp is math else np.arctan2(sn4, cs4)
        g1 = (r2 * r2 + a * r2 * sq) / S2
        dg1 = a * r2 * (a * a - r2 * r2) * cq / (S2 * S2)
        g2 = -r3 * c3 * g1 / (r4 * cs4)
        dg2 = (r3 * s3 * g1 * g1 + r4 * sn4 * g2 * g2 - r3 * c3 * dg1) / (r4 * cs4)
        xC = r3 * c3 + r4 * cs4
        xd = -r3 * s3 * g1 - r4 * sn4 * g2
        xdd = -r3 * c3 * g1 * g1 - r3 * s3 * dg1 - r4 * cs4 * g2 * g2 - r4 * sn4 * dg2
        ds21 = a * r2 * cq / s21
        return dict(th3=th3, th4=th4, s21=s21, ds21=ds21, s3=s3, c3=c3, s4=sn4, c4=cs4, xC=xC,
                    g1=g1, g2=g2, dg1=dg1, dg2=dg2, xd=xd, xdd=xdd)

    def influence(self, q):
        """Paper notation: (g₁, g₂, g₃) and (g₁', g₂', g₃') with φ₃ = s₅₁ = −x_C (Eqs 13, 17)."""
        k = self.kin(q)
        return (k["g1"], k["g2"], -k["xd"]), (k["dg1"], k["dg2"], -k["xdd"])

    def slider_x_derivs(self, q):
        """(x_C, dx_C/dq, d²x_C/dq²) of the output slider [m, m/rad, m/rad²]."""
        k = self.kin(q)
        return k["xC"], k["xd"], k["xdd"]

    def slider_position(self, q):
        """Output slider position x_C = −s₅₁ [m]."""
        return self.kin(q)["xC"]

    # ================================================================ design figures
    @property
    def time_ratio(self):
        """TR = working-stroke crank angle / return-stroke crank angle (constraint c6)."""
        return self._work_arc / (2 * math.pi - self._work_arc)

    @property
    def stroke(self):
        """Slider stroke |x_C(start) − x_C(end)| [m] (constraint c3; ≈ 2 r₃ r₂/a)."""
        return abs(self._x_start - self._x_end)

    @property
    def working_direction(self):
        """+1 / −1: direction (x) in which the slider moves on the working stroke for q̇ > 0."""
        return self._work_sign

    def transmission_angle(self, q):
        """Transmission angle at the output slider, μ = 90° − |pressure angle| [rad]: the
        pressure angle is the angle between the rod and the slider path (our reading of c5)."""
        th4 = self.angles(q)[1]
        press = np.abs(np.arcsin(np.sin(th4)))
        return 0.5 * np.pi - press

    def transmission_angle_lever(self, q):
        """Angle between lever and rod folded to [0, π/2] [rad] (alternative reading of c5)."""
        th3, th4, _ = self.angles(q)
        mu = np.abs(np.mod(np.asarray(th4 - th3) + np.pi, 2 * np.pi) - np.pi)
        return np.minimum(mu, np.pi - mu)

    def min_transmission_angle(self, n: int = 3600, which: str = "slider"):
        q = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        f = self.transmission_angle if which == "slider" else self.transmission_angle_lever
        return float(np.min(f(q)))

    # ================================================================ points
    def joints(self, q):
        """A₀, A (crank pin / block), B₀, B (lever tip), C (slider) as (x, y) [m]."""
        xp = _xp(q)
        k = self.kin(q)
        zero = 0.0 * q
        H = self.a + self.b
        return {"A0": (zero, zero + self.a), "A": (self.r2 * xp.cos(q), self.a + self.r2 * xp.sin(q)),
                "B0": (zero, zero), "B": (self.r3 * k["c3"], self.r3 * k["s3"]),
                "C": (k["xC"], zero + H)}

    def points(self, q):
        return self.joints(q)

    def trace_point(self, q):
        return self.kin(q)["xC"], 0.0 * q + self.a + self.b

    # ================================================================ reduced dynamics (Eqs 24-28)
    def _JA0(self):
        return self.I_G2 + self.m2 * self.c2 ** 2 + self.m_block * self.r2 ** 2

    def _JB0(self):
        return self.I_G3 + self.m3 * self.c3 ** 2 + self.I_block

    def reduced(self, q):
        """J(q) [kg·m²], dJ/dq [kg·m²/rad], dE_p/dq [N·m] (Eqs 25, 28; analytic)."""
        k = self.kin(q)
        r3, c4 = self.r3, self.c4
        g1, g2, dg1, dg2 = k["g1"], k["g2"], k["dg1"], k["dg2"]
        s3, c3, s4, cs4 = k["s3"], k["c3"], k["s4"], k["c4"]
        # rod mass centre G4 = B + c4·e^{iθ4}: velocity coefficients and their q-derivatives
        vx = -r3 * s3 * g1 - c4 * s4 * g2
        vy = r3 * c3 * g1 + c4 * cs4 * g2
        ax = -r3 * c3 * g1 * g1 - r3 * s3 * dg1 - c4 * cs4 * g2 * g2 - c4 * s4 * dg2
        ay = -r3 * s3 * g1 * g1 + r3 * c3 * dg1 - c4 * s4 * g2 * g2 + c4 * cs4 * dg2
        JB0 = self._JB0()
        xd, xdd = k["xd"], k["xdd"]
        J = (self._JA0() + JB0 * g1 * g1 + self.m4 * (vx * vx + vy * vy) + self.I_G4 * g2 * g2
             + self.m5 * xd * xd)
        dJ = 2.0 * (JB0 * g1 * dg1 + self.m4 * (vx * ax + vy * ay) + self.I_G4 * g2 * dg2
                    + self.m5 * xd * xdd)
        xp = _xp(q)
        cq = xp.cos(q)
        dEp = self.g * ((self.m2 * self.c2 + self.m_block * self.r2) * cq
                        + self.m3 * self.c3 * c3 * g1 + self.m4 * vy)
        return J, dJ, dEp

    def potential_energy(self, q):
        """E_p = g Σ m_i y_Gi [J], zero level at B₀ (y = 0)."""
        xp = _xp(q)
        k = self.kin(q)
        sq = xp.sin(q)
        return self.g * (self.m2 * (self.a + self.c2 * sq) + self.m_block * (self.a + self.r2 * sq)
                         + self.m3 * self.c3 * k["s3"] + self.m4 * (self.r3 * k["s3"] + self.c4 * k["s4"])
                         + self.m5 * (self.a + self.b))

    # ================================================================ cutting force
    def cut_params(self) -> "CutP":
        """The parameters of the cutting-force laws (:func:`cutting_force_law`)."""
        prof = 0 if (self.cut_profile == "none" or self.cut_force == 0.0) else \
            {"stroke": 1, "window": 2, "sine": 3}[self.cut_profile]
        return CutP(float(self.r2), float(self.r3), float(self.r4), float(self.a), float(self.b), float(self.k),
                    float(self.cut_force), prof, float(self._work_q0), float(self._work_arc), 2 * math.pi,
                    float(self._work_sign), float(self._x_start), float(self._x_end), float(self.cut_start),
                    float(self.cut_end))

    def cutting_force(self, q):
        """Force on the output slider along x [N] at crank angle q (any sign of rotation):
        −(working direction)·F·profile on the working (slow) stroke, 0 on the return stroke.
        For q̇ > 0 it opposes the slider's motion, and its generalised force is
        Q = F_x·dx_C/dq ≤ 0 (Eq 26 with Eq 31's Q_o).  The law :func:`cutting_force_law`."""
        P = self.cut_params()
        return C.vectorize(lambda x: cutting_force_law(x, P), q)

    def has_external_torque(self) -> bool:
        return not (self.cut_profile == "none" or self.cut_force == 0.0)

    def external_torque(self, q, qd, t):
        """Cutting force reduced to the crank, Q = F_x(q)·dx_C/dq [N·m] (Eq 26/31; :func:`cutting_torque`)."""
        P = self.cut_params()
        return C.vectorize(lambda x: cutting_torque(x, P), q)

    def model_form(self):
        """The reduced model as a law: the spline table of J, ½J', E_p' plus the cutting torque
        (:func:`quickreturn_model`)."""

        tf = table_form(self)
        if not self.has_external_torque():
            return tf
        return C.Form(quickreturn_model, QRModelP(tf.P, self.cut_params(), self.slider_table().P),
                      flags=dict(tf.flags))

    def slider_table(self) -> PeriodicTable:
        """Periodic spline table of the slider's x_C(q) and dx_C/dq over one crank turn (channels 0,
        1) for the reduced model's cutting torque, like the table of J, ½J', E_p': nodes doubled
        from 1024 until the error at the cells' mid-points is ≤ ``SLIDER_TABLE_TOL`` of each
        channel's peak (measured: 1024–2048 nodes, ≤ 1e-10).  Cached per parameters."""
        key = (self.cut_params(), self.k)
        hit = self.__dict__.get("_slider_table")
        if hit is not None and hit[0] == key:
            return hit[1]
        for N in (1024, 2048, 4096, 8192, 16384, 32768):
            u = 2 * np.pi * np.arange(N) / N
            k = self.kin(u)
            tab = PeriodicTable(0.0, np.stack([k["xC"], k["xd"]], axis=1))
            um = u + np.pi / N
            km = self.kin(um)
            exact = np.stack([km["xC"], km["xd"]], axis=1)
            err = np.max(np.abs(tab(um) - exact), axis=0) / np.max(np.abs(exact), axis=0)
            if np.all(err <= SLIDER_TABLE_TOL):
                break
        else:
            raise ParameterError(f"quickreturn: the slider's kinematics cannot be tabulated to {SLIDER_TABLE_TOL:g} "
                                 f"(error {np.max(err):.3g} with {N} nodes: a near-singular lever?); use [reduced] "
                                 "model = \"closed\"")
        tab.max_rel_error = float(np.max(err))
        self.__dict__["_slider_table"] = (key, tab)
        return tab

    # ================================================================ MJCF builder
    def build_spec(self, armature: float = 0.0, options=None):
        """MjSpec: crank (hinge "crank" at A₀), lever (hinge at B₀) carrying the block (slide
        along the lever) and the rod (hinge at the lever tip), slider (slide along x on y = a+b);
        loops closed by two site ``connect`` equalities (block–crank pin, rod end–slider).

        ``options``: timestep [s], integrator (Euler|RK4|implicit|implicitfast; default RK4),
        solref (2), solimp (5), iterations, tolerance.  MuJoCo's default constraint Jacobian
        (:func:`~mjbench.mechanisms.base.new_spec`), contacts off, energy computed.
        """
        import mujoco

        o = dict(options or {})
        h = float(o.get("timestep", 1e-4))
        spec = new_spec(self.name, o, gravity=(0.0, 0.0, -self.g))

        H = self.a + self.b
        rad = 0.012 * max(self.r3, H)
        col = {"ground": [0.45, 0.45, 0.5, 1], "crank": [0.85, 0.25, 0.2, 1], "lever": [0.2, 0.55, 0.85, 1],
               "rod": [0.3, 0.7, 0.3, 1], "block": [0.95, 0.75, 0.1, 1], "slider": [0.6, 0.3, 0.7, 1]}
        world = spec.worldbody
        world.add_light(pos=[0, -3, 3], dir=[0, 1, -1], diffuse=[0.8, 0.8, 0.8])
        for nm, z in (("A0", self.a), ("B0", 0.0)):
            world.add_geom(name=f"pivot_{nm}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                           size=[1.8 * rad, 1.5 * rad, 0], pos=[0.0, 0.0, z],
                           quat=[0.7071068, 0.7071068, 0, 0], rgba=col["ground"], contype=0, conaffinity=0)
        half = 0.6 * self.r3
        world.add_geom(name="slider_guide", type=mujoco.mjtGeom.mjGEOM_BOX,
                       size=[half, 0.5 * rad, 0.3 * rad], pos=[self._x_mid(), 2.5 * rad, H + 1.6 * rad],
                       rgba=col["ground"], contype=0, conaffinity=0)

        def inertial(body, mass, cx, I):
            body.mass = max(mass, 1e-9)
            body.ipos = [cx, 0.0, 0.0]
            I = max(I, 1e-12)
            body.inertia = [0.6 * I, I, 0.6 * I]  # only I_yy (hinge axis) matters
            body.explicitinertial = True

        def hinge(body, name):
            return body.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(AXIS))

        crank = world.add_body(name="crank", pos=[0.0, 0.0, self.a])
        hinge(crank, INPUT_JOINT).armature = float(armature)
        inertial(crank, self.m2, self.c2, self.I_G2)
        crank.add_geom(name="crank_geom", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, self.r2, 0, 0],
                       size=[rad, 0, 0], rgba=col["crank"], contype=0, conaffinity=0, mass=0)
        crank.add_site(name="crank_pin", pos=[self.r2, 0, 0], size=[1.2 * rad, 0, 0])

        lever = world.add_body(name="lever", pos=[0.0, 0.0, 0.0])
        hinge(lever, "lever_joint")
        inertial(lever, self.m3, self.c3, self.I_G3)
        lever.add_geom(name="lever_geom", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, self.r3, 0, 0],
                       size=[0.8 * rad, 0, 0], rgba=col["lever"], contype=0, conaffinity=0, mass=0)

        block = lever.add_body(name="block", pos=[0.0, 0.0, 0.0])
        block.add_joint(name="block_slide", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
        inertial(block, self.m_block, 0.0, self.I_block)
        block.add_geom(name="block_geom", type=mujoco.mjtGeom.mjGEOM_BOX, size=[2.0 * rad, 1.2 * rad, 1.4 * rad],
                       rgba=col["block"], contype=0, conaffinity=0, mass=0)
        block.add_site(name="block_pin", pos=[0, 0, 0], size=[1.2 * rad, 0, 0])

        rod = lever.add_body(name="rod", pos=[self.r3, 0.0, 0.0])
        hinge(rod, "rod_joint")
        inertial(rod, self.m4, self.c4, self.I_G4)
        rod.add_geom(name="rod_geom", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, self.r4, 0, 0],
                     size=[0.8 * rad, 0, 0], rgba=col["rod"], contype=0, conaffinity=0, mass=0)
        rod.add_site(name="rod_end", pos=[self.r4, 0, 0], size=[1.2 * rad, 0, 0])

        slider = world.add_body(name="slider", pos=[0.0, 0.0, H])
        slider.add_joint(name="slider", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])
        inertial(slider, self.m5, 0.0, 1e-6)
        slider.add_geom(name="slider_geom", type=mujoco.mjtGeom.mjGEOM_BOX, size=[3 * rad, 1.5 * rad, 1.5 * rad],
                        rgba=col["slider"], contype=0, conaffinity=0, mass=0)
        slider.add_site(name="slider_pin", pos=[0, 0, 0], size=[1.2 * rad, 0, 0])
        slider.add_site(name="trace", pos=[0, 0, 0], size=[1.6 * rad, 0, 0], rgba=[1, 0.8, 0.1, 1])

        solref, solimp = closure_solref(o, h)  # two site connects (base.py: 3·h, impedance 0.9999)
        for nm, s1, s2 in (("slot_closure", "crank_pin", "block_pin"), ("slider_closure", "rod_end", "slider_pin")):
            spec.add_equality(name=nm, type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                              name1=s1, name2=s2, solref=solref, solimp=solimp)
        return spec

    def _x_mid(self):
        return 0.5 * (self._x_start + self._x_end)

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        k = self.kin(float(q0))
        qpos = np.array(model.qpos0, dtype=float)
        qpos[model.joint(INPUT_JOINT).qposadr[0]] = q0
        qpos[model.joint("lever_joint").qposadr[0]] = k["th3"]
        qpos[model.joint("block_slide").qposadr[0]] = k["s21"]
        qpos[model.joint("rod_joint").qposadr[0]] = k["th4"] - k["th3"]
        qpos[model.joint("slider").qposadr[0]] = k["xC"]
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        k = self.kin(float(q0))
        qvel = np.zeros(model.nv)
        qvel[model.joint(INPUT_JOINT).dofadr[0]] = qd0
        qvel[model.joint("lever_joint").dofadr[0]] = k["g1"] * qd0
        qvel[model.joint("block_slide").dofadr[0]] = k["ds21"] * qd0
        qvel[model.joint("rod_joint").dofadr[0]] = (k["g2"] - k["g1"]) * qd0
        qvel[model.joint("slider").dofadr[0]] = k["xd"] * qd0
        return qvel

    def load_form(self, model, data):
        """Cutting force on the slider dof as a law (:func:`cutting_load`): F_x(q) of
        :func:`cutting_force_law` (the law of ``external_torque``).  The backend holds it over one
        integrator step, so it is evaluated at the step's predicted mid-point q + ½·h·q̇ (second
        order for a smooth profile).  None without a cutting force."""
        if not self.has_multibody_load():
            return None
        j = model.joint(INPUT_JOINT)
        P = CutLoadP(data.qpos, data.qvel, data.qfrc_applied, int(j.qposadr[0]), int(j.dofadr[0]),
                     int(model.joint("slider").dofadr[0]), 0.5 * float(model.opt.timestep), self.cut_params())
        return C.Form(cutting_load, P)

    def has_multibody_load(self) -> bool:
        return self.has_external_torque()

    def multibody_load(self, model, data, t: float) -> None:
        """Cutting force on the slider dof (:meth:`load_form`'s law, evaluated once)."""
        f = self.load_form(model, data)
        if f is not None:
            cutting_load(float(t), C.python_view(f.P))

    def _site_ids(self, model):
        return np.array([int(model.site(n).id) for n in ("crank_pin", "block_pin", "rod_end", "slider_pin")],
                        dtype=np.int64)

    def closure_error(self, model, data) -> float:
        """Largest loop-closure gap [m]: |crank pin − block| and |rod end − slider pin| from
        ``data.site_xpos`` (valid after mj_forward / mj_kinematics; :func:`two_gaps`)."""
        a, b, c, d = (int(i) for i in self._site_ids(model))
        return two_gaps(data.site_xpos.reshape(-1), a, b, c, d)

    def closure_form(self, model, data):
        """:meth:`closure_error` as a law (:func:`two_gaps_closure`) on the live ``site_xpos``."""
        return C.Form(two_gaps_closure, GapsP(data.site_xpos.reshape(-1), self._site_ids(model)))

    def linkage_view(self):
        """The same mechanism as a generic :class:`~mjbench.mechanisms.linkage.Linkage` (link lines:
        transmission angles, toggles, velocity ratios for ``mjbench analyze``)."""

        return Linkage(LinkageParams.model_validate(table_from_quickreturn(self)))

    def export_mjcf(self, path, armature: float = 0.0, options=None, q0: float = 0.0):
        """Write the MJCF (XML) of this mechanism to ``path`` atomically, assembled at crank angle
        ``q0`` at rest (qpos0 and the keyframe ``initial``: mjbench/mjcf_export.py)."""

        spec = self.build_spec(armature=armature, options=options)
        model = spec.compile()
        xml = standalone_xml(spec, model, self.initial_qpos(model, q0), self.initial_qvel(model, q0, 0.0),
                             self.input_joint)
        atomic_write(path, lambda f: f.write(xml))
        return path

    def describe(self) -> dict:
        keys = ("r2", "r3", "r4", "a", "b", "m2", "m3", "m4", "m5", "I_G2", "I_G3", "I_G4", "c2", "c3", "c4",
                "m_block", "I_block", "k", "g", "cut_force", "cut_profile", "cut_start", "cut_end")
        return {"type": "quickreturn", **{k: getattr(self, k) for k in keys}}


_KEYS = ("r2", "r3", "r4", "a", "b", "m2", "m3", "m4", "m5", "I_G2", "I_G3", "I_G4", "c2", "c3", "c4",
         "m_block", "I_block", "k", "g", "cut_force", "cut_profile", "cut_start", "cut_end")


# ============================================================================ laws
#: the cutting force's parameters: the geometry (r2, r3, r4, a, b, assembly mode k), the force F0,
#: the profile (0 none, 1 stroke, 2 window, 3 sine), the working stroke (start angle q0, arc, the
#: period 2π, the slider's direction sign, its start and end x), the window's fractions
CutP = namedtuple("CutP", "r2 r3 r4 a b k F0 profile q0 arc period sign x_start x_end c_start c_end")
#: the reduced model: the spline table's parameters and the cutting force's
QRModelP = namedtuple("QRModelP", "table cut slider")
#: largest relative error of the slider's tabulated x_C, dx_C/dq (:meth:`QuickReturn.slider_table`)
SLIDER_TABLE_TOL = 1e-9
#: the MuJoCo cutting load: live qpos, qvel, qfrc_applied, crank qpos/dof, slider dof, h/2, CutP
CutLoadP = namedtuple("CutLoadP", "qpos qvel qfrc qa va vs h2 cut")
#: the loop-closure gaps: live flat site_xpos, site ids (crank pin, block pin, rod end, slider pin)
GapsP = namedtuple("GapsP", "sx ids")


@law
def slider_x(q, P):
    """(x_C, dx_C/dq) of the output slider at crank angle q (module docstring; NaN at a
    non-finite angle)."""
    if not abs(q) < 1e15:
        return math.nan, math.nan
    r2 = P.r2
    r3 = P.r3
    r4 = P.r4
    a = P.a
    sq = math.sin(q)
    cq = math.cos(q)
    Ax = r2 * cq
    Ay = a + r2 * sq
    S2 = Ax * Ax + Ay * Ay
    s21 = math.sqrt(S2)
    s3 = Ay / s21
    c3 = Ax / s21
    sn4 = (a + P.b - r3 * s3) / r4
    cs4 = P.k * math.sqrt(1.0 - sn4 * sn4)
    g1 = (r2 * r2 + a * r2 * sq) / S2
    g2 = -r3 * c3 * g1 / (r4 * cs4)
    xC = r3 * c3 + r4 * cs4
    xd = -r3 * s3 * g1 - r4 * sn4 * g2
    return xC, xd


@law
def cutting_force_law(q, P):
    """Force on the slider along x [N] at crank angle q: −(working direction)·F0·w on the working
    stroke ((q − q0) mod 2π < arc), 0 on the return stroke; w = 1 (stroke), 1 inside the window
    of stroke fractions (window), sin(π·fraction) (sine)."""
    if P.profile == 0:
        return 0.0
    xC = 0.0
    if P.profile != 1:
        xC, xd = slider_x(q, P)
    return cutting_force_at(q, xC, P)


@law
def cutting_force_at(q, xC, P):
    """:func:`cutting_force_law` with the slider position x_C given (window and sine profiles)."""
    if not on_working_stroke(q, P):
        return 0.0
    w = 1.0
    if P.profile != 1:
        frac = (P.x_start - xC) / (P.x_start - P.x_end)
        if P.profile == 2:
            w = 1.0 if (frac >= P.c_start and frac <= P.c_end) else 0.0
        else:
            w = math.sin(math.pi * min(max(frac, 0.0), 1.0))
    return -P.sign * P.F0 * w


@law
def on_working_stroke(q, P):
    """Whether the cut acts at crank angle q: a profile other than none and (q − q0) mod 2π < arc."""
    if P.profile == 0:
        return False
    u = (q - P.q0) % P.period
    return u < P.arc


@law
def cutting_torque(q, P):
    """The cutting force reduced to the crank, Q = F_x(q)·dx_C/dq [N·m] (0 on the return stroke,
    where x_C is not needed: the slider's kinematics are evaluated on the working stroke only)."""
    if not on_working_stroke(q, P):
        return 0.0
    xC, xd = slider_x(q, P)
    return cutting_force_at(q, xC, P) * xd


@law
def tabulated_cutting_torque(q, P, T):
    """:func:`cutting_torque` with x_C and dx_C/dq read from the periodic table T (channels 0 and 1,
    :meth:`QuickReturn.slider_table`) instead of the slider's closed forms (four trigonometric and
    square-root evaluations per call)."""
    if not on_working_stroke(q, P):
        return 0.0
    xC = 0.0
    if P.profile != 1:
        xC = ptable_channel(q, 0, T)
    return cutting_force_at(q, xC, P) * ptable_channel(q, 1, T)


@law
def quickreturn_model(q, qd, t, P):
    """The reduced model law: the spline table's (J, ½J', E_p') and the cutting torque as Q_ext, the
    slider's kinematics tabulated too (:func:`tabulated_cutting_torque`)."""
    J, H, E, Q = table_model(q, qd, t, P.table)
    return J, H, E, Q + tabulated_cutting_torque(q, P.cut, P.slider)


@law
def cutting_load(t, P):
    """The cutting force on the slider dof at the step's predicted mid-point q + ½·h·q̇."""
    q = P.qpos[P.qa] + P.h2 * P.qvel[P.va]
    P.qfrc[P.vs] = cutting_force_law(q, P.cut)


@law
def site_gap(sx, a, b):
    """Distance between sites a and b [m] (``sx`` the flat site_xpos)."""
    dx = sx[3 * a] - sx[3 * b]
    dy = sx[3 * a + 1] - sx[3 * b + 1]
    dz = sx[3 * a + 2] - sx[3 * b + 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


@law
def two_gaps(sx, a, b, c, d):
    """The larger of the gaps |a − b| and |c − d| [m]."""
    e1 = site_gap(sx, a, b)
    e2 = site_gap(sx, c, d)
    return e1 if e1 > e2 else e2


@law
def two_gaps_closure(P, S):
    """The quick-return's loop-closure residual [m] (the MuJoCo plant's P; ``P.closure``: GapsP)."""
    G = P.closure
    return two_gaps(G.sx, G.ids[0], G.ids[1], G.ids[2], G.ids[3])


class QuickReturnParams(Strict):
    """``[mechanism] type = "quickreturn"`` (Yiğit & Şen 2023, Table I; geometry reconstructed
    from Eqs 3-6, docs/quickreturn.md).  Lengths [m], masses [kg], inertias about the mass centres."""

    type: Literal["quickreturn"] = "quickreturn"
    r2: Q("length", gt=0.0, what="a link length") = Field(description="crank")
    r3: Q("length", gt=0.0, what="a link length") = Field(description="slotted lever")
    r4: Q("length", gt=0.0, what="a link length") = Field(description="connecting rod")
    a: Q("length", gt=0.0, what="a link length") = Field(description="|A0B0|: crank pivot above the lever pivot")
    b: Q("length", gt=0.0, what="a link length") = Field(description="slider line height above A0")
    m2: Q("mass", ge=0.0, what="a link mass")
    m3: Q("mass", ge=0.0, what="a link mass")
    m4: Q("mass", ge=0.0, what="a link mass")
    m5: Q("mass", ge=0.0, what="a link mass") = Field(description="output slider")
    I_G2: Q("inertia", ge=0.0, what="a link inertia")
    I_G3: Q("inertia", ge=0.0, what="a link inertia")
    I_G4: Q("inertia", ge=0.0, what="a link inertia")
    c2: OptQ("length", ge=0.0) = Field(None, description="mass-centre distance from the proximal joint (default: mid-length)")
    c3: OptQ("length", ge=0.0) = None
    c4: OptQ("length", ge=0.0) = None
    m_block: Q("mass", ge=0.0) = Field(description="block on the crank pin sliding in the lever slot (> 0 for MuJoCo)")
    I_block: Q("inertia", ge=0.0) = Field(description="its inertia")
    k: Literal[1, -1] = Field(1, description="assembly mode")
    g: Q("acceleration", what="gravity") = Field(G, description="gravity, −y in the plane")
    cut_force: Q("force", ge=0.0) = Field(0.0, description="cutting force on the slider (default: no load)")
    cut_profile: Literal["stroke", "window", "sine", "none"] = "stroke"
    cut_start: float = Field(0.0, ge=0.0, le=1.0, description="window profile: fraction of the working stroke")
    cut_end: float = Field(1.0, ge=0.0, le=1.0)


QuickReturn.Params = QuickReturnParams
register(QuickReturn)
