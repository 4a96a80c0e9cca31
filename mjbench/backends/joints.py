"""Joint columns: every joint coordinate of the mechanism in the trajectory (``[simulation] record_joints``).

With ``record_joints`` the plants record, after the core columns and a platform's internal
coordinates, one coordinate and one rate column per joint of the machine's MuJoCo model (hinges
and slides, in the model's joint order):

* ``joint_<name>_rad`` and ``joint_<name>_rate_rad_s`` for a hinge, ``joint_<name>_m`` and
  ``joint_<name>_rate_m_s`` for a slide — MuJoCo's own joint value (a hinge's angle of its body
  relative to the parent body, unwrapped; a slide's displacement) and its rate.

On the **multibody** backend they are MuJoCo's ``qpos``/``qvel`` at the sample (:func:`write_mujoco`,
one law with the internal coordinates).  On the **reduced** backend they come from the mechanism's
own kinematics — its closed forms (four-bar, quick-return), its loop-closure solver (generic
linkage) — expressed in the same MuJoCo joint coordinates: ``Mechanism.initial_qpos`` /
``initial_qvel`` (the assembled configuration and velocity at an input angle, what starts every
MuJoCo run) tabulated once over one input turn from the run's q0 as periodic cubic splines (the
hinges' whole turns per input turn removed, :class:`~mjbench.mechanisms.linkage_kin.PeriodicTable`),
the interpolation error measured at every interval midpoint against the mechanism itself (≤ 1e-9 of
the column's range; ``meta["joint_table"]``), evaluated by the law :func:`table_joints` at the
sample's (q, q̇).  So both backends' columns have the same names and meaning, and a mechanism
described once is compared joint by joint (a multibody-vs-reduced check beyond the input).

Not provided on the reduced backend (``meta["joint_columns"]`` says why): mechanisms with internal
coordinates (a platform's deflection, a compliant gear: the joints depend on more than q) and
inputs that are not periodic over one turn (an MJCF slide input).
"""
from __future__ import annotations

import math
import re
from collections import namedtuple

import mujoco
import numpy as np

from .. import compiled as C
from ..mechanisms.linkage_kin import PeriodicTable, ptable_channel

TWO_PI = 2.0 * math.pi
N0, NMAX = 1024, 16384  #: grid sizes of the reduced joint table (doubled until TOL is met)
TOL = 1e-9  #: interpolation error / range of each column


def joint_list(model) -> list:
    """[(column stem, kind "hinge" | "slide", qpos address, dof address)] of the model's hinge and
    slide joints in the model's order (ball and free joints have no single coordinate: skipped)."""
    out, seen = [], set()
    for j in range(model.njnt):
        typ = int(model.jnt_type[j])
        if typ == int(mujoco.mjtJoint.mjJNT_HINGE):
            kind = "hinge"
        elif typ == int(mujoco.mjtJoint.mjJNT_SLIDE):
            kind = "slide"
        else:
            continue
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"{j}"
        stem = "joint_" + re.sub(r"[^A-Za-z0-9_.\-]", "_", name)
        while stem in seen:
            stem += "_"
        seen.add(stem)
        out.append((stem, kind, int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j])))
    return out


def column_names(joints) -> tuple:
    """``joint_<name>_rad``, ``joint_<name>_rate_rad_s`` (hinge) or ``_m``, ``_rate_m_s`` (slide) per joint."""
    out = []
    for stem, kind, _, _ in joints:
        out += [f"{stem}_rad", f"{stem}_rate_rad_s"] if kind == "hinge" else [f"{stem}_m", f"{stem}_rate_m_s"]
    return tuple(out)


def addresses(joints):
    """(qpos addresses, dof addresses) as int64 arrays for the multibody write law."""
    return (np.array([j[2] for j in joints], dtype=np.int64), np.array([j[3] for j in joints], dtype=np.int64))


# ============================================================================ reduced: the mechanism's own kinematics
#: the reduced joint table's parameters: the periodic table (channels 2k: value − slope·(q − q0),
#: 2k+1: rate per unit q̇), the hinges' slope (whole turns per input turn × 1) per joint, the count
JointsP = namedtuple("JointsP", "tab slope n")


@C.law
def table_joints(out, b, q, qd, P):
    """Joint k's coordinate and rate at input angle q and speed q̇ into out[b+2k], out[b+2k+1]: the
    periodic table's channel plus the hinge's whole turns, slope·(q − q0); the rate per unit q̇ × q̇."""
    T = P.tab
    for k in range(P.n):
        out[b + 2 * k] = ptable_channel(q, 2 * k, T) + P.slope[k] * (q - T.q0)
        out[b + 2 * k + 1] = ptable_channel(q, 2 * k + 1, T) * qd


def _sample(mech, model, joints, q):
    """(values (B, n), rates per unit input speed (B, n)) of the joints at input angles q (array):
    the mechanism's own ``joint_states`` if it has a batched one, else its initial_qpos/initial_qvel."""
    qa, va = addresses(joints)
    fn = getattr(mech, "joint_states", None)
    if fn is not None:
        qpos, qvel = fn(model, q)
        return qpos[:, qa], qvel[:, va]
    P = np.empty((len(q), len(joints)))
    V = np.empty_like(P)
    for i, x in enumerate(q):
        P[i] = np.asarray(mech.initial_qpos(model, float(x)), float)[qa]
        V[i] = np.asarray(mech.initial_qvel(model, float(x), 1.0), float)[va]
    return P, V


def reduced_table(mech, model, q0: float):
    """The reduced backend's joints from the mechanism's kinematics (module doc) → (Form, names,
    info) or (None, (), why-not): the Form's law ``write(out, b, P, S)`` reads the plant's state
    S = (q, q̇) and the Form's parameters as ``P.joints`` — the mechanism's own joint law
    (``joint_write_form(model)``) when it has one, else :func:`table_joints_write` on a table."""
    if mech.internal:
        return None, (), f"{type(mech).__name__} has internal coordinates: its joints depend on more than q"
    form = mech.joint_write_form(model)
    if form is not None:  # the mechanism's own law for its joints (exact: e.g. a cam's program)
        return form, column_names(joint_list(model)), {
            "source": f"{type(mech).__name__}'s own kinematics at every sample (its law {form.law.__name__})"}
    period = getattr(mech, "reduced_period", None)
    if period is None or abs(float(period) - TWO_PI) > 1e-12:
        return None, (), f"{type(mech).__name__}: its input is not periodic over one turn"
    joints = joint_list(model)
    if not joints:
        return None, (), "the MuJoCo model has no hinge or slide joint"
    hinge = np.array([k == "hinge" for _, k, _, _ in joints])
    N = N0
    while True:
        u = TWO_PI * np.arange(N + 1) / N
        P, V = _sample(mech, model, joints, q0 + u)
        P[:, hinge] = np.unwrap(P[:, hinge], axis=0)  # closed forms may give angles modulo 2π
        turns = (P[-1] - P[0]) / TWO_PI
        w = np.where(hinge, np.round(turns), 0.0)
        gap = np.abs(P[-1] - P[0] - TWO_PI * w)
        span = np.maximum(np.ptp(P, axis=0), 1e-12)
        if np.any(gap > 1e-7 * np.maximum(span, 1.0)):
            bad = [joints[k][0] for k in np.flatnonzero(gap > 1e-7 * np.maximum(span, 1.0))]
            return None, (), f"joints {', '.join(bad)} do not return to their start after one input turn"
        vals = np.empty((N, 2 * len(joints)))
        vals[:, 0::2] = P[:-1] - w[None, :] * u[:-1, None]
        vals[:, 1::2] = V[:-1]
        tab = PeriodicTable(q0, vals)
        um = u[:-1] + 0.5 * TWO_PI / N
        Pm, Vm = _sample(mech, model, joints, q0 + um)
        Pm[:, hinge] = np.unwrap(Pm[:, hinge], axis=0)
        # the same whole turns as the grid (a midpoint is within half a cell of its node)
        Pm[:, hinge] += TWO_PI * np.round((P[:-1, hinge] - Pm[:, hinge]) / TWO_PI)
        est = tab(q0 + um)
        ev = est[:, 0::2] + w[None, :] * um[:, None]
        er = est[:, 1::2]
        err_p = np.max(np.abs(ev - Pm), axis=0) / span
        err_v = np.max(np.abs(er - Vm), axis=0) / np.maximum(np.max(np.abs(V), axis=0), 1e-12)
        err = float(max(err_p.max(), err_v.max()))
        if err <= TOL or N >= NMAX:
            break
        N *= 2
    info = {"nodes": N, "max_rel_error": err, "tolerance": TOL,
            "source": f"{type(mech).__name__}'s own kinematics at every input angle (initial_qpos/initial_qvel)"}
    if err > TOL:
        return None, (), f"the joint table misses its tolerance {TOL:g} with {N} nodes (error {err:.3g})"
    return (C.Form(table_joints_write, JointsP(tab.P, np.ascontiguousarray(w, dtype=float), len(joints))),
            column_names(joints), info)


@C.law
def table_joints_write(out, b, P, S):
    """Every joint's coordinate and rate from the joint table at the reduced plant's state (q, q̇)
    (:func:`table_joints`; the plant's parameters hold the table as ``P.joints``)."""
    table_joints(out, b, S[0], S[1], P.joints)
