"""Scotch yoke: a crank of radius r drives, through a pin sliding in a vertical slot, a yoke that
translates horizontally: x_yoke = r·cos q.

Reduced model (crank inertia J_c about the pivot, crank centre of mass at l_c, pin block mass m_b
at radius r, yoke mass m_y, gravity g along −y):

    J(q)   = J_c + m_b·r² + m_y·r²·sin²q,   J'(q) = m_y·r²·sin 2q,
    E_p(q) = (m_c·l_c + m_b·r)·g·sin q.

MJCF (the plane convention of ``mjbench.mechanisms.base``: plane (x, y) → MuJoCo (x, 0, y), hinges
about ``HINGE_AXIS``): the crank hinge, the yoke's slide along x, the pin block's slide along the
slot (z), and one site ``connect`` between the crank pin and the block, built with
``closure_solref`` (the closure then runs on the kernel's fast, compiled path).
"""
from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from mjbench.fields import Q, Strict
from mjbench.mechanisms.base import HINGE_AXIS, Mechanism, closure_solref, new_spec, plane_to_mj


class ScotchYokeParams(Strict):
    type: Literal["scotch-yoke"] = "scotch-yoke"
    r: Q("length", gt=0.0) = Field(description="crank radius (pin circle)")
    m_c: Q("mass", gt=0.0) = Field(description="crank mass")
    l_c: Q("length", ge=0.0) = Field(description="pivot to the crank's centre of mass")
    J_c: Q("inertia", gt=0.0) = Field(description="crank inertia about the pivot")
    m_b: Q("mass", gt=0.0) = Field(description="pin block mass")
    m_y: Q("mass", gt=0.0) = Field(description="yoke mass")
    g: Q("acceleration") = 9.81


class ScotchYoke(Mechanism):
    type_name = "scotch-yoke"
    Params = ScotchYokeParams

    def __init__(self, r, m_c, l_c, J_c, m_b, m_y, g=9.81):
        self.r, self.m_c, self.l_c, self.J_c, self.m_b, self.m_y, self.g = r, m_c, l_c, J_c, m_b, m_y, g

    @classmethod
    def from_params(cls, p):
        return cls(p.r, p.m_c, p.l_c, p.J_c, p.m_b, p.m_y, p.g)

    def reduced(self, q):
        r2 = self.r ** 2
        J = self.J_c + self.m_b * r2 + self.m_y * r2 * np.sin(q) ** 2
        return J, self.m_y * r2 * np.sin(2 * q), (self.m_c * self.l_c + self.m_b * self.r) * self.g * np.cos(q)

    def potential_energy(self, q):
        return (self.m_c * self.l_c + self.m_b * self.r) * self.g * np.sin(q)

    def build_spec(self, armature=0.0, options=None):
        import mujoco

        o = dict(options or {})
        spec = new_spec("scotch_yoke", o, gravity=(0.0, 0.0, -self.g))
        w, r, rad = spec.worldbody, self.r, 0.05 * self.r
        crank = w.add_body(name="crank", pos=[0, 0, 0])
        crank.add_joint(name=self.input_joint, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(HINGE_AXIS),
                        armature=float(armature))
        crank.mass, crank.ipos = self.m_c, plane_to_mj(self.l_c, 0.0)
        Ig = max(self.J_c - self.m_c * self.l_c ** 2, 1e-9)  # about the centre of mass
        crank.inertia, crank.explicitinertial = [Ig, Ig, Ig], True
        crank.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, *plane_to_mj(r, 0.0)], size=[rad, 0, 0],
                       contype=0, conaffinity=0, mass=0)
        crank.add_site(name="pin", pos=plane_to_mj(r, 0.0))
        yoke = w.add_body(name="yoke", pos=[0, 0, 0])
        yoke.add_joint(name="yoke_slide", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
        yoke.mass, yoke.ipos, yoke.inertia, yoke.explicitinertial = self.m_y, [0, 0, 0], [1e-6] * 3, True
        yoke.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, -1.2 * r, 0, 0, 1.2 * r], size=[rad, 0, 0],
                      contype=0, conaffinity=0, mass=0)
        block = yoke.add_body(name="block", pos=[0, 0, 0])
        block.add_joint(name="block_slide", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
        block.mass, block.ipos, block.inertia, block.explicitinertial = self.m_b, [0, 0, 0], [1e-6] * 3, True
        block.add_site(name="slot", pos=[0, 0, 0])
        solref, solimp = closure_solref(o, float(o.get("timestep", 1e-4)))
        spec.add_equality(name="pin_in_slot", type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                          name1="pin", name2="slot", solref=solref, solimp=solimp)
        return spec

    def initial_qpos(self, model, q0, x0=None):
        return np.array([q0, self.r * np.cos(q0), self.r * np.sin(q0)])

    def initial_qvel(self, model, q0, qd0, x0=None, xd0=None):
        return np.array([qd0, -self.r * np.sin(q0) * qd0, self.r * np.cos(q0) * qd0])

    def points(self, q):
        return {"O": (0.0 * q, 0.0 * q), "P": (self.r * np.cos(q), self.r * np.sin(q)),
                "Y": (self.r * np.cos(q), 0.0 * q)}

    def trace_point(self, q):
        return self.points(q)["Y"]
