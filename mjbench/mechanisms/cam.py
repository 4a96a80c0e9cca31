"""A disc cam driving a translating or oscillating follower, roller or flat-faced (``type = "cam"``).

The input q is the cam's angle θ (counter-clockwise).  The follower's coordinate y (translating: its
lift s [m]; oscillating: the arm's angle Ψ from its base position [rad]) follows the cam's motion
program (:mod:`mjbench.mechanisms.cam_profile`: rise, dwell, return … segments, each a motion law of
:mod:`mjbench.motionlaws`) while the follower stays on the cam.  A spring of rate k with a preload F0
at the base position and a constant load F_L opposing the lift (a process force, the follower's
weight on a vertical stem) hold it there; c is the follower's viscous damping.

**Reduced model** (exact in the program's kinematic coefficients y', y'' — the laws' own closed
forms, no table): with M the follower's mass (oscillating: its inertia about the pivot),

    J(θ) = J_cam + M·y'²,   J'(θ) = 2M·y'·y'',   E_p = ½k·y² + F0·y,   Q_ext = −F_L·y' − c·y'²·θ̇

(the follower held on the cam: a bilateral model, it cannot separate; where it would, the contact
force it needs is negative — :func:`~mjbench.mechanisms.cam_profile.contact_force`, the jump speed
:func:`~mjbench.mechanisms.cam_profile.jump_speed`).

**MuJoCo model** (docs/higher_pairs.md §2 explains the choice): the cam is a body on the hinge
``crank``; the follower rides on a *cam-lift* body whose joint ``cam_lift`` (slide, or hinge at the
pivot) is tied to the cam by a fixed-tendon equality, lift = y(θ), whose polynomial is the program's
Taylor expansion y + y'·Δ + y''/2·Δ² + y'''/6·Δ³ about the cam angle at the start of every step
(the step's Δθ ≈ 1e-3 rad: the truncation is ≈ y⁽⁴⁾·Δθ⁴/24 ≈ 1e-12 m).  The follower is the cam-lift
body's child on the joint ``follower_gap`` (same axis), whose lower limit 0 is MuJoCo's **unilateral
constraint** (the solver's cone-free inequality, the same soft-constraint model as a contact):
it pushes, never pulls, so the follower leaves the cam when the spring cannot hold it, and flies
until it lands again.  The spring, its preload and the follower's damping act on the follower's
absolute coordinate (a fixed tendon cam_lift + follower_gap); the load F_L is applied on it.  The
cam-lift body is a device: its mass is 1e-6 of the follower's (neglected by the reduced model).
Contacts stay off (new_spec); the limit's solref/solimp are the contact parameters (``contact_solref``).
"""
from __future__ import annotations

import math
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from .. import compiled as C
from .. import metrics as M
from .. import units as U
from ..compiled import law
from ..errors import GeometryError, ParameterError
from ..fields import OptQ, Q, Strict
from . import register
from .base import CLOSURE_SOLIMP, HINGE_AXIS, INPUT_JOINT, Mechanism, RenderView, closure_solref, new_spec
from .cam_profile import (LAW_KINDS, TWO_PI, CamProgram, Follower, FollowerLoad, cam_motion, checks, contact_force,
                          geometry, jump_speed)

#: the share of the follower's mass (inertia) carried by the cam-lift device (it rides with the cam;
#: the follower body has the rest, so the two move the whole M while in contact)
LIFT_MASS_RATIO = 1e-3
#: a follower more than this fraction of the lift above the cam is counted as separated
GAP_TOL = 1e-6
#: contact (the follower_gap limit) time constant in co-steps unless ``contact_solref`` says
#: otherwise: 3h, as every loop closure (docs/higher_pairs.md §2.3 measures 1 ms and 20 ms)
CONTACT_TIMECONST_STEPS = 3.0
#: a description's geometry checks and jump speed (:func:`checks`, :func:`jump_speed`), by its content:
#: a command builds its machine more than once (the checks before the run, the run), a sweep once a row
_DERIVED: dict = {}

#: what the follower's quantities are in, by motion: (lift, spring rate, force, damping) kinds
_KINDS = {"translating": ("length", "lin_stiffness", "force", "lin_damping"),
          "oscillating": ("angle", "rot_stiffness", "torque", "rot_damping")}


class CamSegment(Strict):
    """``[[mechanism.program]]``: one segment of the cam's program."""

    kind: Literal["rise", "dwell", "return"]
    angle: Q("angle", gt=0.0) = Field(description="cam angle of the segment")
    law: Literal["345", "cycloidal", "pseudopoly", "bezier"] | None = Field(
        None, description="motion law of a rise or return (mjbench/motionlaws.py)")
    gammas: list[float] | None = Field(None, description="pseudopoly: exponents (seed 001), default [3, 4, 5]")
    m: int | None = Field(None, ge=0, description="bezier: continuity order (seed 003), default 2")
    p: int | None = Field(None, ge=0, description="bezier: free interior ordinates, default 3")
    interior_over_Phi: list[float] | None = Field(None, description="bezier: interior ordinates / lift")
    lift: float | str | None = Field(None, description="this segment's lift (default: mechanism.lift)")

    @model_validator(mode="after")
    def _law(self):
        if self.kind != "dwell" and self.law is None:
            raise PydanticCustomError("mjbench_value", "a {k} needs a law ({l})", {"k": self.kind,
                                                                                   "l": ", ".join(LAW_KINDS)})
        return self


class CamParams(Strict):
    """``[mechanism] type = "cam"``: a disc cam and its follower (docs/higher_pairs.md §2)."""

    type: Literal["cam"] = "cam"
    name: str = "cam"
    follower: Literal["translating", "oscillating"] = "translating"
    contact: Literal["roller", "flat"] = "roller"
    base_radius: Q("length", gt=0.0) = Field(description="base circle radius R_b (the cam surface at zero lift)")
    roller_radius: Q("length", ge=0.0) = Field(0.0, description="roller radius R_r (roller followers)")
    lift: float | str = Field(description="the follower's lift: a length (translating) or an angle (oscillating)")
    program: list[CamSegment] = Field(description="rise, dwell, return … segments over one turn")
    direction: tuple[float, float] = Field((0.0, 1.0), description="translating: the follower's direction")
    offset: Q("length", plausible=False) = Field(0.0, description="translating: offset e of the follower's line "
                                                                  "from the cam centre (to the right of direction)")
    pivot: tuple[Q("length", plausible=False), Q("length", plausible=False)] | None = Field(
        None, description="oscillating: the arm's pivot A")
    arm: OptQ("length", gt=0.0) = Field(None, description="oscillating roller: pivot to roller centre")
    face_offset: Q("length", plausible=False) = Field(0.0, description="oscillating flat face: its distance from the pivot")
    lift_sense: Literal["ccw", "cw"] = Field("ccw", description="oscillating: the arm's sense of rotation as it lifts")
    cam_inertia: Q("inertia", gt=0.0, what="a cam inertia") = Field(description="cam and shaft about the axis")
    follower_mass: OptQ("mass", gt=0.0) = Field(None, description="translating: the follower's moving mass")
    follower_inertia: OptQ("inertia", gt=0.0) = Field(None, description="oscillating: the follower about its pivot")
    spring_rate: float | str = Field(description="return spring's rate (N/m; oscillating N·m/rad)")
    spring_preload: float | str = Field(description="spring force at the base position (N; oscillating N·m)")
    follower_load: float | str = Field(0.0, description="constant load opposing the lift (N; oscillating N·m)")
    follower_damping: float | str = Field(0.0, description="viscous damping of the follower")
    max_pressure_angle: OptQ("angle", gt=0.0, lt=math.pi / 2) = Field(
        None, description="refuse a cam whose pressure angle exceeds this (default: only beyond 80°)")
    contact_solref: tuple[float, float] | None = Field(
        None, description="MuJoCo: the follower-on-cam constraint's (time constant [s], damping ratio); default (3h, 1)")
    contact_solimp: tuple[float, float, float, float, float] | None = Field(
        None, description="MuJoCo: its impedance (default that of the loop closures)")
    phase: Q("angle") = Field(0.0, description="cam angle at which the program starts")

    @model_validator(mode="after")
    def _values(self):
        kinds = _KINDS[self.follower]
        for key, kind in zip(("lift", "spring_rate", "spring_preload", "follower_load", "follower_damping"),
                             (kinds[0], kinds[1], kinds[2], kinds[2], kinds[3])):
            v = getattr(self, key)
            try:
                x = U.to_si(v, kind)
            except U.UnitError as e:
                raise PydanticCustomError("mjbench_value", "{k}: {e} (a {f} follower)",
                                          {"k": key, "e": str(e), "f": self.follower}) from None
            if not math.isfinite(x) or (key == "lift" and not x > 0) or (key != "lift" and x < 0):
                raise PydanticCustomError("mjbench_value", "{k} = {v!r}: must be {w}",
                                          {"k": key, "v": v, "w": "> 0" if key == "lift" else ">= 0 and finite"})
            object.__setattr__(self, key, x)
        for k, s in enumerate(self.program):
            if s.lift is not None:
                try:
                    object.__setattr__(s, "lift", U.to_si(s.lift, kinds[0]))
                except U.UnitError as e:
                    raise PydanticCustomError("mjbench_value", "program[{k}].lift: {e}", {"k": k, "e": str(e)}) from None
        if self.contact == "roller" and not self.roller_radius > 0:
            raise PydanticCustomError("mjbench_value", "roller_radius: a roller follower needs a roller radius > 0")
        if self.contact == "flat" and self.roller_radius > 0:
            raise PydanticCustomError("mjbench_value", "roller_radius: a flat-faced follower has no roller")
        if self.follower == "translating":
            if self.follower_mass is None:
                raise PydanticCustomError("mjbench_value", "follower_mass: required for a translating follower")
            if self.follower_inertia is not None or self.pivot is not None or self.arm is not None:
                raise PydanticCustomError("mjbench_value", "follower_inertia, pivot and arm are for an oscillating "
                                          "follower")
            if not math.hypot(*self.direction) > 0:
                raise PydanticCustomError("mjbench_value", "direction has zero length")
        else:
            if self.follower_inertia is None or self.pivot is None:
                raise PydanticCustomError("mjbench_value", "an oscillating follower needs pivot and follower_inertia")
            if self.contact == "roller" and self.arm is None:
                raise PydanticCustomError("mjbench_value", "arm: required for an oscillating roller follower")
        if self.contact_solref is not None and not (self.contact_solref[0] > 0 and self.contact_solref[1] > 0):
            raise PydanticCustomError("mjbench_value", "contact_solref = {v}: time constant and damping ratio must "
                                      "be > 0", {"v": list(self.contact_solref)})
        return self


@register
class Cam(Mechanism):
    """A disc cam and its follower (module docstring)."""

    type_name = "cam"
    Params = CamParams
    #: the MuJoCo load law edits the model (the cam-lift equality's polynomial) every step: a batch
    #: gives every run its own compiled model (backends/batch.py)
    edits_model = True
    #: a video draws the recorded follower (off the cam when it jumps), not the one on the cam at q
    frames_from_joints = True
    reduced_source = "independent: the cam program's kinematic coefficients (the motion laws' closed forms)"

    def __init__(self, p: CamParams):
        self.params = p
        self.name = p.name
        self.motion = p.follower
        self.program = CamProgram(p.program, p.lift)
        self.phase = float(p.phase)
        sense = 1 if p.lift_sense == "ccw" else -1
        try:
            self.fol = Follower(p.follower, p.contact, p.base_radius, p.roller_radius, p.direction, p.offset,
                                p.pivot or (0.0, 0.0), p.arm or 0.0, p.face_offset, sense)
        except GeometryError as e:
            raise GeometryError(f"mechanism: {e}") from None
        self.M = float(p.follower_mass if p.follower == "translating" else p.follower_inertia)
        self.load = FollowerLoad(self.M, p.spring_rate, p.spring_preload, p.follower_load, p.follower_damping)
        self.J_cam = float(p.cam_inertia)
        key = p.model_dump_json()
        hit = _DERIVED.get(key)
        if hit is None:  # (7200 samples of the program and a root search: ≈ 0.5 s, once per description)
            if len(_DERIVED) > 32:
                _DERIVED.clear()
            hit = _DERIVED[key] = (checks(self.fol, _Shifted(self.program, self.phase),
                                          max_pressure_angle=p.max_pressure_angle),
                                   jump_speed(self.load, self.program))
        self.check, self.jump = dict(hit[0]), dict(hit[1])
        self.P = CamModelP(self.program.P, self.phase, self.J_cam, self.M, self.load.k, self.load.F0, self.load.FL,
                           self.load.c)

    @classmethod
    def from_params(cls, p):
        return cls(p)

    # ------------------------------------------------------------------ kinematics
    def follower_motion(self, q):
        """(y, y', y'', y''') of the follower at cam angles q (float or array)."""
        x = q - self.phase
        return self.program(x if isinstance(q, float) else np.asarray(x, float))

    @property
    def lift_unit(self) -> str:
        return "m" if self.motion == "translating" else "rad"

    # ------------------------------------------------------------------ reduced model
    def reduced(self, q):
        """J = J_cam + M·y'², J' = 2M·y'·y'', E_p' = (k·y + F0)·y' [kg·m², kg·m²/rad, N·m]."""
        if isinstance(q, float):
            J, dJh, dEp, _ = cam_model(q, 0.0, 0.0, self.P)
            return J, 2.0 * dJh, dEp
        y, y1, y2, _ = self.follower_motion(np.asarray(q, float))
        return (self.J_cam + self.M * y1 * y1, 2.0 * self.M * y1 * y2, (self.load.k * y + self.load.F0) * y1)

    def potential_energy(self, q):
        """½k·y² + F0·y [J]: the spring (zero at the base position)."""
        y = self.follower_motion(q)[0]
        return 0.5 * self.load.k * y * y + self.load.F0 * y

    def external_torque(self, q, qd, t):
        """−F_L·y' − c·y'²·q̇ [N·m]: the follower's load and damping at the cam."""
        y1 = self.follower_motion(q)[1]
        return -self.load.FL * y1 - self.load.c * y1 * y1 * qd

    def has_external_torque(self) -> bool:
        return self.load.FL != 0.0 or self.load.c != 0.0

    def model_form(self):
        """The reduced model as a law (:func:`cam_model`): the program's own laws at every stage."""
        return C.Form(cam_model, self.P)

    # ------------------------------------------------------------------ MuJoCo
    def _timestep(self, options):
        return float(dict(options or {}).get("timestep", 1e-4))

    def contact_parameters(self, options=None):
        """(solref, solimp) of the follower-on-cam constraint (the follower_gap joint's lower limit)."""
        h = self._timestep(options)
        ref = list(self.params.contact_solref or (CONTACT_TIMECONST_STEPS * h, 1.0))
        imp = list(self.params.contact_solimp or CLOSURE_SOLIMP)
        return ref, imp

    def build_spec(self, armature: float = 0.0, options=None):
        import mujoco

        o = dict(options or {})
        h = self._timestep(o)
        spec = new_spec(self.name, o, gravity=(0.0, 0.0, 0.0))
        w = spec.worldbody
        w.add_light(pos=[0, -3, 3], dir=[0, 1, -1], diffuse=[0.8, 0.8, 0.8])
        fol, p = self.fol, self.params
        size = self._extent()
        rad = 0.012 * size
        # the cam: hinge "crank" at the origin, its profile drawn as a mesh (no collision: contacts are off)
        cam = w.add_body(name="cam", pos=[0.0, 0.0, 0.0])
        cam.mass = 1.0
        cam.ipos = [0.0, 0.0, 0.0]
        cam.inertia = [0.6 * self.J_cam, self.J_cam, 0.6 * self.J_cam]
        cam.explicitinertial = True
        jc = cam.add_joint(name=INPUT_JOINT, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(HINGE_AXIS))
        jc.armature = float(armature)
        self._cam_mesh(spec, cam, rad)
        w.add_geom(name="cam_axis", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[1.5 * rad, 3 * rad, 0],
                   quat=[0.7071068, 0.7071068, 0, 0], rgba=[0.3, 0.3, 0.35, 1], contype=0, conaffinity=0)
        m_lift = LIFT_MASS_RATIO * self.M
        if self.motion == "translating":
            C0 = fol.e * fol.n + fol.d0 * fol.u if fol.contact == "roller" else fol.e * fol.n + fol.Rb * fol.u
            axis = [float(fol.u[0]), 0.0, float(fol.u[1])]
            lifter = w.add_body(name="cam_lift", pos=[float(C0[0]), 0.0, float(C0[1])])
            jl = lifter.add_joint(name="cam_lift", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
            lifter.mass, lifter.inertia = m_lift, [m_lift * 1e-4] * 3
            follower = lifter.add_body(name="follower", pos=[0.0, 0.0, 0.0])
            jf = follower.add_joint(name="follower_gap", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis)
            jf.range = [0.0, 10.0]
            follower.mass = (1.0 - LIFT_MASS_RATIO) * self.M
            follower.inertia = [1e-6, 1e-6, 1e-6]
        else:
            A = fol.A
            ax = list(HINGE_AXIS) if fol.sense > 0 else [-v for v in HINGE_AXIS]
            quat = [math.cos(0.5 * fol.psi0), 0.0, -math.sin(0.5 * fol.psi0), 0.0]  # arm at ψ0 at zero lift
            lifter = w.add_body(name="cam_lift", pos=[float(A[0]), 0.0, float(A[1])], quat=quat)
            jl = lifter.add_joint(name="cam_lift", type=mujoco.mjtJoint.mjJNT_HINGE, axis=ax)
            lifter.mass, lifter.inertia = m_lift, [m_lift] * 3  # about the pivot: I_yy = ε·M
            follower = lifter.add_body(name="follower", pos=[0.0, 0.0, 0.0])
            jf = follower.add_joint(name="follower_gap", type=mujoco.mjtJoint.mjJNT_HINGE, axis=ax)
            jf.range = [0.0, math.pi]
            follower.mass = self.M / max(p.arm or math.hypot(*A), 1e-3) ** 2
            follower.inertia = [(1.0 - LIFT_MASS_RATIO) * self.M] * 3  # about the pivot (its origin)
        for b in (lifter, follower):
            b.ipos = [0.0, 0.0, 0.0]
            b.explicitinertial = True
        solref, solimp = self.contact_parameters(o)
        jf.solref_limit = solref
        jf.solimp_limit = solimp
        self._follower_geoms(mujoco, follower, rad)
        # the cam-lift equality (per step: the program's Taylor polynomial about the step's cam angle)
        spec.add_tendon(name="cam_angle").wrap_joint(INPUT_JOINT, 1.0)
        spec.add_tendon(name="cam_lift").wrap_joint("cam_lift", 1.0)
        y, y1, y2, y3 = self.follower_motion(0.0)
        eq_ref, eq_imp = closure_solref(o, h)
        data = np.zeros(mujoco.mjNEQDATA)
        data[:4] = (y, y1, 0.5 * y2, y3 / 6.0)
        spec.add_equality(name="cam_lift_on_cam", type=mujoco.mjtEq.mjEQ_TENDON, name1="cam_lift", name2="cam_angle",
                          data=data.tolist(), solref=eq_ref, solimp=eq_imp)
        # the spring, its preload and the follower's damping on the follower's absolute coordinate
        ts = spec.add_tendon(name="follower_spring", stiffness=[self.load.k, 0, 0], damping=[self.load.c, 0, 0])
        ts.wrap_joint("cam_lift", 1.0)
        ts.wrap_joint("follower_gap", 1.0)
        y0 = self.load.F0 / self.load.k if self.load.k > 0 else 0.0
        ts.springlength = [-y0, -y0]
        if self.load.k == 0.0 and self.load.F0 != 0.0:
            raise ParameterError("mechanism.spring_rate = 0 with a preload: give the preload as follower_load")
        return spec

    def _extent(self):
        g = geometry(self.fol, self.program, TWO_PI * np.arange(360) / 360)
        r = float(np.max(np.hypot(g["profile"][:, 0], g["profile"][:, 1])))
        return max(r, 1e-3)

    def _cam_mesh(self, spec, cam, rad):
        """The cam's profile as a display mesh (a fan from the centre, extruded along the axis)."""
        import mujoco

        n = 360
        th = TWO_PI * np.arange(n) / n
        prof = geometry(self.fol, _Shifted(self.program, self.phase), th)["profile"]
        t = 2.0 * rad
        verts = [[0.0, -t, 0.0], [0.0, t, 0.0]]
        for x, z in prof:
            verts += [[float(x), -t, float(z)], [float(x), t, float(z)]]
        faces = []
        for i in range(n):
            a, b = 2 + 2 * i, 2 + 2 * ((i + 1) % n)
            faces += [[0, b, a], [1, a + 1, b + 1], [a, b, b + 1], [a, b + 1, a + 1]]
        spec.add_mesh(name="cam_profile", uservert=np.ravel(verts).tolist(), userface=np.ravel(faces).tolist())
        cam.add_geom(name="cam_profile", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="cam_profile",
                     rgba=[0.85, 0.55, 0.2, 1], contype=0, conaffinity=0, mass=0)

    def _follower_geoms(self, mujoco, body, rad):
        fol = self.fol
        col = [0.2, 0.45, 0.8, 1]
        if self.motion == "translating":
            stem_top = 1.2 * self.program.lift + 6 * rad
            if fol.contact == "roller":
                body.add_geom(name="shape_roller", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[fol.Rr, 1.5 * rad, 0],
                              quat=[0.7071068, 0.7071068, 0, 0], rgba=col, contype=0, conaffinity=0, mass=0)
                a = fol.Rr
            else:
                half = max(abs(v) for v in self.check.get("face_contact_range_m", [0.0, 0.0])) + 3 * rad
                u = fol.u
                body.add_geom(name="face", type=mujoco.mjtGeom.mjGEOM_BOX, size=[half, 1.5 * rad, 0.6 * rad],
                              pos=[0.0, 0.0, 0.6 * rad], quat=_quat(math.atan2(u[1], u[0]) - 0.5 * math.pi),
                              rgba=col, contype=0, conaffinity=0, mass=0)
                a = 0.0
            u = fol.u
            body.add_geom(name="stem", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                          fromto=[a * u[0], 0, a * u[1], (a + stem_top) * u[0], 0, (a + stem_top) * u[1]],
                          size=[0.8 * rad, 0, 0], rgba=col, contype=0, conaffinity=0, mass=0)
            return
        # oscillating: in the body frame the arm lies at angle ψ0 (the body is rotated by it): along +x
        if fol.contact == "roller":
            L = fol.arm
            body.add_geom(name="arm", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, L, 0, 0],
                          size=[0.8 * rad, 0, 0], rgba=col, contype=0, conaffinity=0, mass=0)
            body.add_geom(name="shape_roller", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[fol.Rr, 1.5 * rad, 0],
                          pos=[L, 0, 0], quat=[0.7071068, 0.7071068, 0, 0], rgba=col, contype=0, conaffinity=0,
                          mass=0)
        else:
            rng = self.check.get("face_contact_range_m", [0.0, 0.0])
            lo, hi = min(rng[0], 0.0) - 3 * rad, rng[1] + 3 * rad
            # the face: normal along +x of the body (ν at ψ0), at distance f from the pivot
            body.add_geom(name="face", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                          fromto=[fol.f, 0, lo, fol.f, 0, hi] if fol.sense > 0 else [fol.f, 0, -lo, fol.f, 0, -hi],
                          size=[0.6 * rad, 0, 0], rgba=col, contype=0, conaffinity=0, mass=0)
        body.add_geom(name="pivot", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[1.5 * rad, 2 * rad, 0],
                      quat=[0.7071068, 0.7071068, 0, 0], rgba=[0.3, 0.3, 0.35, 1], contype=0, conaffinity=0, mass=0)

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        """The follower on the cam at q0, settled into MuJoCo's soft constraints: the static residual
        r = −R·f/k of the cam-lift equality and of the follower_gap limit under the spring's load
        (a = a* − R·f = 0 with a* = −k·r), so that a run does not start with a jolt (≈ 5e-6 rad on the
        shipped cam; without it the follower's speed starts 6e-4 of its peak off for 1 ms)."""
        import mujoco

        qpos = np.array(model.qpos0, dtype=float)
        ia, il, ig = (int(model.joint(n).qposadr[0]) for n in (INPUT_JOINT, "cam_lift", "follower_gap"))
        qpos[ia] = q0
        y = float(self.follower_motion(float(q0))[0])
        qpos[il], qpos[ig] = y, -1e-12  # in contact (the limit active from the start)
        d = mujoco.MjData(model)
        for _ in range(3):
            d.qpos[:] = qpos
            d.qvel[:] = 0.0
            self.model_at_pose(model, d)
            mujoco.mj_forward(model, d)
            r = {}
            for row in range(d.nefc):
                kinv = _baumgarte_kinv(*self._row_sol(model, d, row))
                r[int(d.efc_type[row])] = -float(d.efc_R[row]) * float(d.efc_force[row]) * kinv
            qpos[il] = y + r.get(int(mujoco.mjtConstraint.mjCNSTR_EQUALITY), 0.0)
            qpos[ig] = min(r.get(int(mujoco.mjtConstraint.mjCNSTR_LIMIT_JOINT), -1e-12), -1e-12)
        return qpos

    def rigid_qpos(self, model, q):
        """The follower exactly on the cam at cam angle q (lift y(θ), no deflection of the soft
        cam-lift equality or of the follower_gap limit): the pose of the reduced model, where the model
        check compares the two (:meth:`initial_qpos` settles it ≈ 5e-6 rad into the constraints, and the
        spring's torque there differs by k·5e-6 rad: 1.8e-5 of the shipped cam's largest E_p')."""
        qpos = self.joint_states(model, [float(q)])[0][0]
        qpos[model.joint("follower_gap").qposadr[0]] = -1e-12  # in contact, as initial_qpos
        return qpos

    @staticmethod
    def _row_sol(model, data, row):
        """(solref, solimp) of a constraint row (the cam-lift equality or the follower_gap limit)."""
        import mujoco

        i = int(data.efc_id[row])
        if int(data.efc_type[row]) == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY):
            return model.eq_solref[i], model.eq_solimp[i]
        return model.jnt_solref[i], model.jnt_solimp[i]

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        qvel = np.zeros(model.nv)
        qvel[model.joint(INPUT_JOINT).dofadr[0]] = qd0
        qvel[model.joint("cam_lift").dofadr[0]] = float(self.follower_motion(float(q0))[1]) * qd0
        return qvel

    def joint_states(self, model, q):
        """(qpos (B, nq), qvel per unit cam speed (B, nv)) at cam angles q: the follower on the cam."""
        q = np.atleast_1d(np.asarray(q, float))
        y, y1, _, _ = self.follower_motion(q)
        qpos = np.tile(np.asarray(model.qpos0, float), (len(q), 1))
        qvel = np.zeros((len(q), model.nv))
        qpos[:, model.joint(INPUT_JOINT).qposadr[0]] = q
        qpos[:, model.joint("cam_lift").qposadr[0]] = y
        qvel[:, model.joint(INPUT_JOINT).dofadr[0]] = 1.0
        qvel[:, model.joint("cam_lift").dofadr[0]] = y1
        return qpos, qvel

    def joint_write_form(self, model):
        """The reduced backend's joint columns as a law (:func:`cam_joints_write`): the cam, the
        cam-lift y(θ) and the gap 0, exact (the program's laws), in the model's joint order."""
        import mujoco

        names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)
                 if int(model.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))]
        k = {n: names.index(n) for n in (INPUT_JOINT, "cam_lift", "follower_gap")}  # the joint columns' order
        return C.Form(cam_joints_write, CamJointsP(k[INPUT_JOINT], k["cam_lift"], k["follower_gap"], self.phase,
                                                   self.program.P))

    def _gap_scale(self):
        """Metres per unit of the follower coordinate at the contact (1; oscillating: the arm)."""
        if self.motion == "translating":
            return 1.0
        return float(self.fol.arm if self.fol.contact == "roller" else math.hypot(*self.fol.A))

    def load_form(self, model, data):
        """The per-step law :func:`cam_load`: the cam-lift equality's polynomial about the step's cam
        angle, and the follower's load on its absolute coordinate."""
        import mujoco

        tc = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TENDON, "cam_angle")
        ie = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, "cam_lift_on_cam")
        P = CamLoadP(data.qpos, data.qvel, data.qfrc_applied, model.tendon_length0, model.eq_data,
                     int(model.joint(INPUT_JOINT).qposadr[0]), int(model.joint(INPUT_JOINT).dofadr[0]), int(tc),
                     int(ie), int(model.joint("cam_lift").dofadr[0]), int(model.joint("follower_gap").dofadr[0]),
                     self.load.FL, _baumgarte_kinv(model.eq_solref[ie], model.eq_solimp[ie]), self.phase,
                     self.program.P)
        return C.Form(cam_load, P)

    def has_multibody_load(self) -> bool:
        return True

    def multibody_load(self, model, data, t: float) -> None:
        cam_load(float(t), C.python_view(self.load_form(model, data).P))

    def model_at_pose(self, model, data) -> None:
        """The cam-lift equality's polynomial about the pose's cam angle (what :func:`cam_load` does
        before every step)."""
        qf = np.array(data.qfrc_applied)
        self.multibody_load(model, data, 0.0)
        data.qfrc_applied[:] = qf

    def closure_error(self, model, data) -> float:
        return cam_closure(_Plant(self.closure_form(model, data).P), None)

    def closure_form(self, model, data):
        """The cam-lift equality's residual [m at the contact] as a law (:func:`cam_closure`)."""
        P = CamClosureP(data.qpos, int(model.joint(INPUT_JOINT).qposadr[0]), int(model.joint("cam_lift").qposadr[0]),
                        self.phase, self._gap_scale(), self.program.P)
        return C.Form(cam_closure, P)

    # ------------------------------------------------------------------ drawings, analysis
    def points(self, q):
        qa = np.asarray(q, float)
        g = geometry(self.fol, self.program, np.atleast_1d(qa - self.phase))
        th = np.atleast_1d(qa)
        C = g["contact_fixed"]
        out = {"O": (np.zeros(th.shape), np.zeros(th.shape)), "contact": (C[:, 0], C[:, 1])}
        r, a = self._tip
        out["cam_tip"] = (r * np.cos(th + a), r * np.sin(th + a))  # the cam's farthest point (framing)
        if self.fol.contact == "roller":
            Rc, _, _, _ = self.fol.roller_centre(g["y"])
            out["roller"] = (Rc[:, 0], Rc[:, 1])
        if self.motion == "oscillating":
            out["pivot"] = (np.full(th.shape, self.fol.A[0]), np.full(th.shape, self.fol.A[1]))
        if qa.ndim == 0:
            return {k: (float(x[0]), float(y[0])) for k, (x, y) in out.items()}
        return out

    def draw_profile(self, ax):
        """The cam surface, its pitch curve and the base circle at θ = 0 on a Matplotlib axis [m]."""
        th = TWO_PI * np.arange(721) / 720
        g = geometry(self.fol, _Shifted(self.program, self.phase), th)
        ax.fill(g["profile"][:, 0], g["profile"][:, 1], color="C1", alpha=0.3, lw=0)
        ax.plot(g["profile"][:, 0], g["profile"][:, 1], color="C1", lw=1.2, label="cam surface")
        if self.fol.contact == "roller":
            ax.plot(g["pitch"][:, 0], g["pitch"][:, 1], color="C0", ls="--", lw=0.9, label="pitch curve")
        ax.plot(self.fol.Rb * np.cos(th), self.fol.Rb * np.sin(th), color="0.5", ls=":", lw=0.8, label="base circle")

    @property
    def _tip(self):
        """(radius, angle at θ = 0) of the cam surface's farthest point."""
        if not hasattr(self, "_tip_cache"):
            g = geometry(self.fol, _Shifted(self.program, self.phase), TWO_PI * np.arange(720) / 720)
            r = np.hypot(g["profile"][:, 0], g["profile"][:, 1])
            k = int(np.argmax(r))
            self._tip_cache = (float(r[k]), float(math.atan2(g["profile"][k, 1], g["profile"][k, 0])))
        return self._tip_cache

    def trace_point(self, q):
        pts = self.points(q)
        return pts.get("roller", pts["contact"])

    def render_view(self) -> RenderView:
        return RenderView("side", label=f"{self.name}: disc cam, {self.motion} {self.params.contact} follower")

    def input_positions(self, n: int):
        return 2.0 * np.pi * np.arange(n) / n, "rad"

    def kinematics(self, q) -> dict:
        """The follower's velocity ratio y', the transmission angle 90° − |pressure angle|, the
        follower's stops (the ends of every rise and return); no toggles."""
        q = np.asarray(q, float)
        g = geometry(self.fol, self.program, q - self.phase)
        label = "follower"
        stops = [float((th + self.phase) % TWO_PI) for k, th in enumerate(self.program.th[:-1])
                 if self.program.laws[k][0] != "dwell" or (k > 0 and self.program.laws[k - 1][0] != "dwell")]
        return {"source": "the cam program's kinematic coefficients (mechanisms/cam_profile.py)",
                "ratios": {label: g["y1"]}, "ratio_units": {label: "m/rad" if self.motion == "translating" else "rad/rad"},
                "transmission": {"cam on follower (90° − pressure angle)": 0.5 * math.pi - np.abs(g["pressure_angle"])},
                "toggles": {}, "limit_positions": {label: sorted(stops)},
                "strokes_m": {label: self.program.lift} if self.motion == "translating" else {},
                "swings_deg": {label: math.degrees(self.program.lift)} if self.motion == "oscillating" else {},
                "unavailable": {}}

    def describe(self) -> dict:
        return self.params.to_dict()

    # ------------------------------------------------------------------ the cam designer's rows
    def analysis_rows(self, speeds, n: int = 720) -> dict:
        """What ``mjbench analyze`` adds for a cam (``analysis.json["cam"]``; ``jump_speed_rad_s`` also
        at the top level): the predicted jump speed, the program, the geometry checks (pressure angle,
        curvature, undercut), the spring and, per speed and at the jump speed, the contact force along
        the cycle; the curves the figures draw (cam_plots.py)."""
        th = TWO_PI * np.arange(n) / n
        g = geometry(self.fol, self.program, th)
        unit = 1000.0 if self.motion == "translating" else 180.0 / math.pi  # mm or degrees in the text
        ustr = "mm" if self.motion == "translating" else "°"
        curves = {"theta": th + self.phase, "y": g["y"], "y1": g["y1"], "y2": g["y2"], "y3": g["y3"],
                  "pressure_angle": g["pressure_angle"], "rho_pitch": g["rho_pitch"], "rho_cam": g["rho_cam"],
                  "profile_x": g["profile"][:, 0], "profile_y": g["profile"][:, 1],
                  "pitch_x": g["pitch"][:, 0], "pitch_y": g["pitch"][:, 1]}
        wj = self.jump["speed_rad_s"]
        rows, flags = [], []
        all_speeds = [float(w) for w in speeds] + ([wj] if wj else [])
        for i, w in enumerate(all_speeds):
            N = contact_force(self.load, g, w)
            key = f"N@{w:g}"
            curves[key] = N
            k = int(np.argmin(N))
            row = {"cam_speed_rad_s": w, "cam_speed_rpm": w * 30.0 / math.pi,
                   "is_jump_speed": bool(wj) and i == len(all_speeds) - 1,
                   "speed_over_jump_speed": (w / wj) if wj else None,
                   "contact_force_N": {"min": float(N[k]), "max": float(np.max(N))},
                   "theta_at_min_force_deg": float(math.degrees(th[k] + self.phase) % 360.0),
                   "follower_leaves_cam": bool(N[k] < 0.0), "curve": key}
            rows.append(row)
            if not row["is_jump_speed"] and wj and w >= wj:
                flags.append({"kind": "jump", "where": f"{w:g} rad/s",
                              "text": f"at {w:.4g} rad/s the follower leaves the cam (jump speed {wj:.4g} rad/s): the "
                                      f"contact force would reach {N[k]:.3g} N at cam angle "
                                      f"{row['theta_at_min_force_deg']:.1f}°"})
        ck = self.check
        summary = [f"cam program: " + ", ".join(f"{r['kind']} {r['end_deg'] - r['start_deg']:.0f}°"
                                                + (f" ({r['law']})" if r["law"] else "") for r in self.program.segment_table())
                   + f"; lift {self.program.lift * unit:.4g} {ustr}",
                   f"pressure angle ≤ {ck['max_pressure_angle_deg']:.2f}° (at cam angle "
                   f"{ck['theta_at_max_pressure_angle_deg']:.1f}°); smallest radius of curvature of the cam surface "
                   + (f"{1000 * ck['min_convex_radius_of_curvature_m']:.3g} mm (convex)"
                      if ck["min_convex_radius_of_curvature_m"] else "—")
                   + (f", {1000 * ck['min_concave_radius_of_curvature_m']:.3g} mm (concave)"
                      if ck["min_concave_radius_of_curvature_m"] else "") + "; no undercut",
                   (f"jump speed {wj:.4g} rad/s ({wj * 30 / math.pi:.4g} rpm) at cam angle {self.jump['theta_deg']:.1f}°"
                    if wj else "the follower never decelerates towards the cam: no jump speed")]
        for r in rows:
            if not r["is_jump_speed"]:
                summary.append(f"at {r['cam_speed_rad_s']:.4g} rad/s: contact force {r['contact_force_N']['min']:.3g} … "
                               f"{r['contact_force_N']['max']:.3g} N"
                               + (f" ({r['speed_over_jump_speed']:.3f} of the jump speed)" if wj else ""))
        return {"top": {"jump_speed_rad_s": wj, "jump_speed_rpm": (wj * 30.0 / math.pi) if wj else None,
                        "jump_cam_angle_deg": self.jump["theta_deg"]},
                "flags": flags, "summary": summary,
                "follower": self.motion, "contact": self.params.contact, "lift": self.program.lift,
                "lift_unit": self.lift_unit, "follower_geometry": self.fol.describe(),
                "program": self.program.segment_table(), "jump": self.jump,
                "checks": {**ck, "pressure_angle_limit_deg": (math.degrees(self.params.max_pressure_angle)
                                                              if self.params.max_pressure_angle else None)},
                "spring": {"rate": self.load.k, "preload": self.load.F0, "load": self.load.FL,
                           "damping": self.load.c, "moving_mass_or_inertia": self.M},
                "speeds": rows, "curves": curves}

    # ------------------------------------------------------------------ metrics of a run
    def metrics(self, traj, machine, config) -> dict:
        """The follower's family (:data:`mjbench.metrics.FOLLOWER_METRICS`): the measured separation
        (the joint ``follower_gap`` more than GAP_TOL of the lift above the cam — on the reduced backend
        always 0: it holds the follower on): ``follower_separation_fraction`` of the last complete cam
        cycle's travel, ``follower_first_separation_s`` (None: never) with the cam's speed and angle
        then, the largest gap [m at the contact]; the follower's peak speed and its largest distance
        from the program at the recorded cam angle; the predicted jump speed.  Needs ``[simulation]
        record_joints`` (the follower's joints)."""
        out = {"follower_jump_speed_rad_s": self.jump["speed_rad_s"]}
        t = traj.t
        q = traj.q
        cols = traj.columns
        stem = "_m" if self.motion == "translating" else "_rad"
        rate = "_rate_m_s" if self.motion == "translating" else "_rate_rad_s"
        lift_c, gap_c = f"joint_cam_lift{stem}", f"joint_follower_gap{stem}"
        y, y1, _, _ = self.follower_motion(q)
        if lift_c not in cols:
            out["follower_separation_fraction"] = None
            out["follower_first_separation_s"] = None
            out["follower_note"] = "the follower's joints were not recorded ([simulation] record_joints = true)"
            return out
        lift = traj.data[:traj.n, cols.index(lift_c)]
        gap = traj.data[:traj.n, cols.index(gap_c)]
        v = traj.data[:traj.n, cols.index(f"joint_cam_lift{rate}")] + traj.data[:traj.n, cols.index(f"joint_follower_gap{rate}")]
        tol = GAP_TOL * self.program.lift
        sep = gap > tol
        first = float(t[int(np.argmax(sep))]) if sep.any() else None
        u = "m" if self.motion == "translating" else "rad"
        out.update({"follower_first_separation_s": first,
                    "follower_max_gap_m": max(float(np.max(gap)), 0.0) * self._gap_scale(),
                    f"follower_peak_speed_{u}_s": float(np.max(np.abs(v))),
                    f"follower_vs_program_max_{u}": float(np.max(np.abs(lift + gap - y))),
                    "follower_gap_tolerance_m": tol * self._gap_scale()})
        turns = M.cycles(t, q)
        if len(turns):
            a, b = turns[-1]
            win = (t >= a) & (t <= b)
            dq = np.diff(q[win])
            out["follower_separation_fraction"] = float(np.sum(dq * sep[win][1:]) / max(np.sum(dq), 1e-300))
        else:
            out["follower_separation_fraction"] = float(np.mean(sep))
            out["follower_note"] = "less than one complete cam turn: the fraction is over the whole run"
        if sep.any():
            out["backends_differ_by_design"] = (
                f"the follower left the cam on MuJoCo (first at t = {first:.4g} s; the predicted jump speed is "
                f"{self.jump['speed_rad_s']:.4g} rad/s) while the reduced model holds it on the cam")
            i = int(np.argmax(sep))
            out["follower_first_separation_cam_speed_rad_s"] = float(traj.qd[i])
            out["follower_first_separation_cam_angle_deg"] = float(math.degrees(q[i] - self.phase) % 360.0)
        return out


class _Shifted:
    """A program read at cam angles shifted by the phase (checks and drawings in cam-angle terms)."""

    def __init__(self, prog, phase):
        self.prog, self.phase, self.P = prog, phase, prog.P

    def __call__(self, th):
        return self.prog(np.asarray(th, float) - self.phase)


class _Plant:
    """The MuJoCo plant's parameters seen by a closure law from Python (``P.closure``)."""

    def __init__(self, closure):
        self.closure = C.python_view(closure)


def _baumgarte_kinv(solref, solimp) -> float:
    """1/k of MuJoCo's reference a* = −b·ṙ − k·r for a positive solref (τ, ζ) and a constant
    impedance d = solimp[0] = solimp[1]: k = d/(d_max²·τ²·ζ²) (MuJoCo's documentation, "Computation")."""
    tau, zeta = float(solref[0]), float(solref[1])
    d, dmax = float(solimp[0]), float(solimp[1])
    return dmax * dmax * tau * tau * zeta * zeta / d


def _quat(ang):
    return [math.cos(0.5 * ang), 0.0, -math.sin(0.5 * ang), 0.0]


# ============================================================================ laws
#: the reduced model's parameters: the program, its phase, J_cam, M, k, F0, F_L, c
CamModelP = namedtuple("CamModelP", "prog phase J M k F0 FL c")
#: the MuJoCo load's parameters: live qpos, qfrc_applied, tendon_length0, eq_data; the cam's qpos
#: address, the cam-angle tendon, the equality, the lift and gap dofs, F_L, phase, program
CamLoadP = namedtuple("CamLoadP", "qpos qvel qfrc len0 eq qa va tc ie vl vf FL kinv phase prog")
#: the reduced backend's joint columns: the column pairs of the cam, the lift and the gap; phase, program
CamJointsP = namedtuple("CamJointsP", "kc kl kg phase prog")
#: the closure residual's parameters: live qpos, the cam's and the lift's addresses, phase, scale, program
CamClosureP = namedtuple("CamClosureP", "qpos qa ql phase scale prog")


@law
def cam_model(q, qd, t, P):
    """(J, ½J', E_p', Q_ext) of the cam with its follower held on it: J_cam + M·y'², M·y'·y'',
    (k·y + F0)·y', −F_L·y' − c·y'²·q̇."""
    y, y1, y2, y3 = cam_motion(q - P.phase, P.prog)
    return P.J + P.M * y1 * y1, P.M * y1 * y2, (P.k * y + P.F0) * y1, -P.FL * y1 - P.c * y1 * y1 * qd


@law
def cam_load(t, P):
    """Before each MuJoCo step: the cam-lift equality's polynomial, lift − 0 = y + y'·Δ + y''/2·Δ² +
    y'''/6·Δ³ with Δ = θ − θ_n (θ_n the cam angle now: the cam-angle tendon's reference length), and
    the load −F_L on the follower's absolute coordinate (both its joints).

    MuJoCo's constraint acceleration is J·q̈ without the velocity product J̇·q̇ = −y''·θ̇², which its
    Baumgarte reference a* = −b·ṙ − k·r then balances with a steady residual r = −y''·θ̇²/k (2.6e-5 rad
    on the shipped cam at 3h): the target is moved by y''·θ̇²/k (``kinv`` = 1/k) so that the true
    residual obeys r̈ + b·ṙ + k·r = 0 (docs/higher_pairs.md §2.2)."""
    th = P.qpos[P.qa]
    w = P.qvel[P.va]
    y, y1, y2, y3 = cam_motion(th - P.phase, P.prog)
    P.len0[P.tc] = th
    P.eq[P.ie, 0] = y + y2 * w * w * P.kinv
    P.eq[P.ie, 1] = y1
    P.eq[P.ie, 2] = 0.5 * y2
    P.eq[P.ie, 3] = y3 / 6.0
    P.eq[P.ie, 4] = 0.0
    P.qfrc[P.vl] = -P.FL
    P.qfrc[P.vf] = -P.FL


@law
def cam_joints_write(out, b, P, S):
    """The joint columns of the reduced backend at its state S = (θ, θ̇): the cam's angle and rate,
    the cam-lift y(θ) and y'(θ)·θ̇, the gap 0 (the follower held on the cam)."""
    J = P.joints
    q = S[0]
    qd = S[1]
    y, y1, y2, y3 = cam_motion(q - J.phase, J.prog)
    out[b + 2 * J.kc] = q
    out[b + 2 * J.kc + 1] = qd
    out[b + 2 * J.kl] = y
    out[b + 2 * J.kl + 1] = y1 * qd
    out[b + 2 * J.kg] = 0.0
    out[b + 2 * J.kg + 1] = 0.0


@law
def cam_closure(P, S):
    """|lift − y(θ)|·scale [m]: how far the cam-lift device is from the program (the equality's residual)."""
    C = P.closure
    y, y1, y2, y3 = cam_motion(C.qpos[C.qa] - C.phase, C.prog)
    return abs(C.qpos[C.ql] - y) * C.scale
