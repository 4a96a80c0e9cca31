"""Dry friction on the motor shafts of a machine with several motors (``[drive.friction]`` per axis,
docs/linkages.md §8.2): each axis's Coulomb friction F_C, seen through its rigid gearbox, in both
models of the machine.

* **Multibody**: MuJoCo ``frictionloss`` z·F_C on the axis's input joint, ``solref_friction =
  (2h, 1)`` — as for one motor (docs/drivetrain.md §4).
* **Reduced**: the mechanism's model law with −z·F_C·tanh(z·q̇ₖ/v_ε) added to axis k's generalised
  force at every evaluation (:func:`friction_two`, :func:`friction_multi`; the law
  :func:`.gear.friction_terms` of one motor), v_ε = 2h·F_C·z²/J_k, J_k the smallest inertia the
  axis sees with the other axes free, 1/[(M̄ + J_eq)⁻¹]ₖₖ over the input ranges (the one-motor
  stability bound of the regularisation's slope, per axis).

What stays one-axis (one line, naming the axis): a compliant gear (backlash, stiffness: the motor
becomes a coordinate of its own), a Stribeck drop (breakaway > coulomb: MuJoCo's friction level is
edited at every step) and friction on the mechanism's joints (``[drive.friction.joints]``).
"""
from __future__ import annotations

import copy
import math
from collections import namedtuple

import numpy as np

from .. import compiled as C
from ..errors import ParameterError
from .gear import TERM_COLUMNS, friction_term

#: the friction of every axis (T: (n, TERM_COLUMNS) — one term, a row, per axis) and the mechanism's
#: own model law's parameters
AxesFrictionP = namedtuple("AxesFrictionP", "T inner")
#: configurations sampled for each axis's smallest inertia
INERTIA_SAMPLES = 1024


@C.law
def friction_two(MODEL, q0, q1, v0, v1, t, P, W, ic):
    """The two-input model law MODEL with each axis's motor friction in its generalised force (it
    lowers τ − bias: the bias grows by −friction)."""
    m00, m01, m11, b0, b1 = MODEL(q0, q1, v0, v1, t, P.inner, W, ic)
    return m00, m01, m11, b0 - friction_term(0.0, v0, P.T, 0), b1 - friction_term(0.0, v1, P.T, 1)


@C.law
def friction_multi(MODEL, S, iy, t, P, W, iw):
    """The n-input model law MODEL (M̄ and the bias into W[iw:]) with each axis's motor friction."""
    MODEL(S, iy, t, P.inner, W, iw)
    n = P.T.shape[0]
    for k in range(n):
        W[iw + n * n + k] -= friction_term(0.0, S[iy + n + k], P.T, k)


class AxesFrictionMixin:
    """The mechanism of a machine with several motors with its axes' motor friction (module
    docstring): a copy of the mechanism whose class also derives from this one (:func:`with_axes_friction`)."""

    _axes_friction: tuple = ()  #: per axis (label, z, F_C, J_eq)
    _h = 1e-4

    def set_step(self, h):
        """The co-simulation step the regularisation is sized for."""
        self._h = float(h)

    def _terms(self) -> np.ndarray:
        fr = self._axes_friction
        J = self._axis_inertia()
        rows = []
        for k, (_, z, fc, _) in enumerate(fr):
            veps = 2.0 * self._h * fc * z * z / J[k] if fc > 0 else 1.0
            rows.append([fc, fc, math.inf, z, z, max(veps, 1e-12), 0.0])
        return np.ascontiguousarray(np.array(rows, dtype=float).reshape(len(fr), len(TERM_COLUMNS)))

    def _axis_inertia(self) -> np.ndarray:
        """Each axis's smallest inertia with the other axes free, 1/[(M̄ + J_eq)⁻¹]ₖₖ, over the coarse
        grid of the input ranges (at most :data:`INERTIA_SAMPLES` configurations)."""
        got = self.__dict__.get("_inertia")
        if got is not None:
            return got
        nodes = getattr(getattr(self, "c", None), "coarse_nodes", None)  # (a generic linkage's grid)
        if nodes is None:
            Q = np.array([self.stated_inputs], dtype=float)
        else:
            Q = np.stack(np.meshgrid(*nodes, indexing="ij"), axis=-1).reshape(-1, len(nodes))
            Q = Q[:: max(1, len(Q) // INERTIA_SAMPLES)]
        M = self.reduced_n(Q)[0] + np.diag([ja for *_, ja in self._axes_friction])[None]
        out = 1.0 / np.max(np.diagonal(np.linalg.inv(M), axis1=1, axis2=2), axis=0)
        self._inertia = out
        return out

    def model_form(self):
        inner = super().model_form()
        law = friction_two if self.n_inputs == 2 else friction_multi
        return C.Form(law, AxesFrictionP(self._terms(), inner.P), fn_args=(inner,), flags=dict(inner.flags))

    def build_spec(self, armature=0.0, options=None):
        spec = super().build_spec(armature, options)
        h = float(dict(options or {}).get("timestep", 1e-4))
        for joint, (_, z, fc, _) in zip(self.input_joints, self._axes_friction):
            if fc > 0:
                j = spec.joint(joint)
                j.frictionloss = float(z * fc)
                j.solref_friction = [2.0 * h, 1.0]
        return spec

    def describe(self) -> dict:
        d = dict(super().describe())
        d["drivetrain"] = {lab: {"friction": {"coulomb_Nm": fc, "z": z}} for lab, z, fc, _ in self._axes_friction}
        return d


_CLASSES: dict = {}


def with_axes_friction(mech, drives, labels):
    """``mech`` (several inputs) with its axes' motor friction, or ``mech`` itself when no axis has
    any; ParameterError naming the axis for what stays one-axis (module docstring)."""
    axes = []
    for lab, d in zip(labels, drives):
        tr = getattr(d, "train", None)
        fr = tr.friction if tr is not None else None
        if tr is not None and tr.compliant:
            raise ParameterError(f"drives.{lab}: a compliant gear ([drive.gear] backlash, stiffness) is one-axis only "
                                 f"so far (the motor becomes a coordinate of its own); PWM, encoder, sensor, current "
                                 f"loop, gear efficiency and Coulomb friction work per axis")
        if fr is not None and fr.joints:
            raise ParameterError(f"drives.{lab}: friction on the mechanism's joints ([drive.friction.joints]) is "
                                 f"one-axis only so far; the motor's own [drive.friction] coulomb works per axis")
        if fr is not None and fr.breakaway > fr.coulomb:
            raise ParameterError(f"drives.{lab}: a Stribeck drop (drive.friction.breakaway > coulomb) is one-axis only "
                                 f"so far; give the axis's coulomb alone")
        fc = float(fr.coulomb) if fr is not None else 0.0
        axes.append((lab, float(d.z), fc, float(d.J_eq)))
    if not any(fc > 0 for _, _, fc, _ in axes):
        return mech
    base = type(mech)
    cls = _CLASSES.get(base)
    if cls is None:
        cls = _CLASSES[base] = type(f"{base.__name__}WithAxesFriction", (AxesFrictionMixin, base), {})
    out = copy.copy(mech)
    out.__class__ = cls
    out._axes_friction = tuple(axes)
    out.__dict__.pop("_inertia", None)
    return out


__all__ = ["AxesFrictionP", "friction_two", "friction_multi", "with_axes_friction", "AxesFrictionMixin"]
