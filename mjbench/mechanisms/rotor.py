"""A flywheel on the drive's output shaft: the motor test bench.

One rigid body turning about a fixed axis: constant inertia J [kg·m²], an optional constant load
torque T_L [N·m] (positive along q) and viscous load c [N·m·s/rad]; no gravity work (vertical
axis).  Reduced model: J(q) = J, E_p = 0, Q_ext = T_L − c·q̇.  MJCF: one hinge ``crank`` with
the body's inertia, the viscous load as joint damping and T_L as an applied generalised force.

Its dynamics have closed forms, which is what the drive's validation needs: the steady speed at
a constant voltage, the current and speed step responses, the breakaway of a dry friction, the
lost motion of a gear backlash (docs/drivetrain.md).
"""
from __future__ import annotations

from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field

from .. import compiled as C
from ..compiled import law
from ..fields import Q, Strict
from . import register
from .base import HINGE_AXIS, INPUT_JOINT, Mechanism, new_spec


class RotorParams(Strict):
    """``[mechanism] type = "rotor"``: a flywheel (constant inertia) with optional loads."""

    type: Literal["rotor"] = "rotor"
    J: Q("inertia", gt=0.0, what="a flywheel inertia") = Field(description="inertia about the shaft")
    load_torque: Q("torque", plausible=False) = Field(0.0, description="constant load torque along +q")
    damping: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous load on the shaft")
    radius: Q("length", gt=0.0) = Field(0.05, description="drawing only")


@register
class Rotor(Mechanism):
    type_name = "rotor"
    Params = RotorParams
    view = "side"

    def __init__(self, J: float, load_torque: float = 0.0, damping: float = 0.0, radius: float = 0.05):
        self.J, self.load_torque, self.damping, self.radius = float(J), float(load_torque), float(damping), float(radius)

    @classmethod
    def from_params(cls, p):
        return cls(p.J, p.load_torque, p.damping, p.radius)

    def reduced(self, q):
        z = 0.0 * q
        return self.J + z, z, z

    def potential_energy(self, q):
        return 0.0 * q

    def law_params(self) -> "RotorP":
        return RotorP(self.J, self.load_torque, self.damping)

    def external_torque(self, q, qd, t):
        """T_L − c·q̇ [N·m] (:func:`rotor_torque`)."""
        P = self.law_params()
        return C.vectorize(lambda v: rotor_torque(v, P), qd) + 0.0 * q

    def model_form(self):
        """The reduced model as a law (:func:`rotor_model`): constant J, no potential, T_L − c·q̇."""
        return C.Form(rotor_model, self.law_params())

    def build_spec(self, armature: float = 0.0, options=None):
        import mujoco

        spec = new_spec("rotor", options, gravity=(0.0, 0.0, 0.0))
        w = spec.worldbody
        w.add_light(pos=[0, -3, 3], dir=[0, 1, -1], diffuse=[0.8, 0.8, 0.8])
        b = w.add_body(name="rotor", pos=[0.0, 0.0, 0.0])
        b.mass = 1.0
        b.ipos = [0.0, 0.0, 0.0]
        b.inertia = [0.6 * self.J, self.J, 0.6 * self.J]
        b.explicitinertial = True
        j = b.add_joint(name=INPUT_JOINT, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(HINGE_AXIS))
        j.armature = float(armature)
        j.damping = [self.damping, 0.0, 0.0]
        r = self.radius
        b.add_geom(name="disc", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[r, 0.1 * r, 0],
                   quat=[0.7071068, 0.7071068, 0, 0], rgba=[0.6, 0.6, 0.65, 1], contype=0, conaffinity=0, mass=0)
        b.add_geom(name="mark", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, -0.12 * r, 0, r, -0.12 * r, 0],
                   size=[0.08 * r, 0, 0], rgba=[0.85, 0.25, 0.2, 1], contype=0, conaffinity=0, mass=0)
        return spec

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        qpos = np.array(model.qpos0, dtype=float)
        qpos[model.joint(INPUT_JOINT).qposadr[0]] = q0
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        qvel = np.zeros(model.nv)
        qvel[model.joint(INPUT_JOINT).dofadr[0]] = qd0
        return qvel

    def load_form(self, model, data):
        """The constant load torque as a law (:func:`rotor_load`; the viscous load is joint damping)."""
        if not self.has_multibody_load():
            return None
        return C.Form(rotor_load, RotorLoadP(data.qfrc_applied, int(model.joint(INPUT_JOINT).dofadr[0]),
                                             self.load_torque))

    def multibody_load(self, model, data, t: float) -> None:
        """The constant load torque (the viscous load is joint damping)."""
        f = self.load_form(model, data)
        if f is not None:
            rotor_load(float(t), C.python_view(f.P))

    def has_multibody_load(self) -> bool:
        return self.load_torque != 0.0

    def points(self, q):
        z = 0.0 * q
        return {"O": (z, z), "P": (self.radius * np.cos(q), self.radius * np.sin(q))}

    def trace_point(self, q):
        return self.radius * np.cos(q), self.radius * np.sin(q)


# ============================================================================ laws
#: the flywheel's parameters: inertia J, load torque T_L, viscous load c
RotorP = namedtuple("RotorP", "J TL c")
#: its MuJoCo load: live qfrc_applied, the shaft's dof, T_L
RotorLoadP = namedtuple("RotorLoadP", "qfrc va TL")


@law
def rotor_torque(qd, P):
    """The load on the shaft, T_L − c·q̇ [N·m]."""
    return P.TL - P.c * qd


@law
def rotor_model(q, qd, t, P):
    """The reduced model: (J, 0, 0, T_L − c·q̇)."""
    return P.J, 0.0, 0.0, rotor_torque(qd, P)


@law
def rotor_load(t, P):
    """The constant load torque T_L added to the drive torque on the shaft."""
    P.qfrc[P.va] += P.TL
