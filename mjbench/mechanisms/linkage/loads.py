"""The linkage's loads as laws: a force on a point or a torque on a link, and the external torque.

A load's magnitude is a constant or a piecewise-linear table of its abscissa — a point's
coordinate s = P·d along its direction, or for a torque table the input angle reduced into one
turn — optionally gated to one stroke (:class:`~.description.LoadSpec`).  Its generalised force on
the input is F·ds/dq (a point load) or T·dθ_link/dq (a torque load): the reduced model adds
Σ of them and the viscous −D(q)·q̇ to Q_ext (:func:`linkage_torque`, :func:`linkage_model`); the
MuJoCo plant applies the same magnitudes through the tree's own kinematics
(:mod:`.multibody_loads`).  Every function below decorated ``@law`` gives the same bits in
CPython and compiled.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ... import compiled as C
from ..table import table_model
from ...compiled import law
from ..linkage_kin import TWO_PI, ptable_channel
from .description import LoadSpec

#: the loads: ``spec`` one row per load — kind (0 constant F0, 1 table), F0, gate (0 always, +1 on
#: the stroke along its direction, −1 against), the table's start t0 and length tn in ``xf``, the
#: periodic-table channels of s and of the gate's rate g (point: ds/dq; torque: dθ_link/dq), the
#: abscissa (0: s; 1: the input angle reduced into [q₀, q₀ + 2π)) and q₀ —, ``xf`` (2, ·) the
#: tables' abscissae (row 0) and forces or torques (row 1) (few arrays: a law that is not inlined
#: receives every array as its whole struct, pointer, shape and strides).  A torque load's generalised force is T·dθ_link/dq, a
#: point load's F·ds/dq: the same product of the magnitude and the gate's rate.
LoadsP = namedtuple("LoadsP", "spec xf")
#: the external torque: the linkage's periodic table, the loads
LinkageExtP = namedtuple("LinkageExtP", "tab loads")
#: the reduced model: the spline table (mjbench.backends.table), the external torque's parameters
LinkageModelP = namedtuple("LinkageModelP", "table ext")


@law
def load_force(k, s, sd, L):
    """Force [N] of load k at its coordinate s with ds/dq = sd: 0 off its stroke (gate·sd ≤ 0 for a
    gated load), else F0 (constant) or the table F(s), piecewise linear, constant beyond the ends."""
    sp = L.spec
    g = sp[k, 2]
    if g != 0.0 and not (g * sd > 0.0):
        return 0.0
    if sp[k, 0] == 0.0:
        return sp[k, 1]
    a = int(sp[k, 3])
    n = int(sp[k, 4])
    X = L.xf
    if s <= X[0, a]:
        return X[1, a]
    if s >= X[0, a + n - 1]:
        return X[1, a + n - 1]
    lo = 0
    hi = n - 1  # s(lo) <= s < s(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if X[0, a + mid] <= s:
            lo = mid
        else:
            hi = mid
    x0 = X[0, a + lo]
    tt = (s - x0) / (X[0, a + lo + 1] - x0)
    return X[1, a + lo] + tt * (X[1, a + lo + 1] - X[1, a + lo])


@law
def load_abscissa(k, q, L, T):
    """The abscissa of load k's table at input angle q: its point's coordinate s (periodic-table
    channel, ``T``), or for a torque table against the input angle, q reduced into [q₀, q₀ + 2π)
    (q₀ its first angle); NaN at a non-finite angle."""
    sp = L.spec
    if sp[k, 7] == 0.0:
        return ptable_channel(q, int(sp[k, 5]), T)
    q0 = sp[k, 8]
    u = q - q0
    if not abs(u) < 1e15:
        return math.nan
    return q0 + (u - TWO_PI * math.floor(u / TWO_PI))


@law
def linkage_torque(q, qd, P):
    """The external torque on the input [N·m]: −D(q)·q̇ (viscous joints and dampers, table channel
    4) plus Σ F_k(s_k)·ds_k/dq of the point loads and Σ T_k·dθ_k/dq of the torque loads
    (:func:`load_force`, :func:`load_abscissa`)."""
    T = P.tab
    Q = -ptable_channel(q, 4, T) * qd
    L = P.loads
    sp = L.spec
    for k in range(len(sp)):
        s = load_abscissa(k, q, L, T)
        ds = ptable_channel(q, int(sp[k, 6]), T)
        Q = Q + load_force(k, s, ds, L) * ds
    return Q


@law
def linkage_model(q, qd, t, P):
    """The reduced model law: the spline table's (J, ½J', E_p') and :func:`linkage_torque` as Q_ext."""
    J, H, E, Q = table_model(q, qd, t, P.table)
    return J, H, E, Q + linkage_torque(q, qd, P.ext)


def stroke_table(ld: LoadSpec, s_min: float, s_max: float) -> LoadSpec:
    """A point load given over the stroke (``profile``: distance before the end of the active
    stroke; ``profile_fraction``: fraction of the stroke before its end) as the table s/F of the
    point's coordinate, the stroke being [s_min, s_max] over one turn: the end of
    ``stroke_against`` is s_min (the point moves against the direction), of ``stroke_along``
    s_max.  Other loads are returned as they are."""
    rows = ld.profile if ld.profile is not None else ld.profile_fraction
    if rows is None:
        return ld
    scale = (s_max - s_min) if ld.profile is None else 1.0
    if ld.active == "stroke_against":
        pts = sorted((s_min + scale * float(h), float(F)) for h, F in rows)
    else:
        pts = sorted((s_max - scale * float(h), float(F)) for h, F in rows)
    return ld.model_copy(update={"s": [p[0] for p in pts], "F": [p[1] for p in pts], "profile": None,
                                 "profile_fraction": None})


def _loads_params(specs) -> "LoadsP":
    """The parameters of :func:`load_force` and :func:`load_abscissa` for the load descriptions
    ``specs`` (in order; a torque load's magnitude is its torque, its abscissa s or the angle q)."""
    rows, xs, Fs = [], [], []
    for k, ld in enumerate(specs):
        gate = {"always": 0.0, "stroke_along": 1.0, "stroke_against": -1.0}[ld.active]
        const = ld.force if ld.link is None else ld.torque
        angle = ld.link is not None and ld.q is not None
        q0 = float(ld.q[0]) if angle else 0.0
        if const is not None:
            rows.append((0.0, float(const), gate, float(len(xs)), 0.0, 5.0 + 2 * k, 6.0 + 2 * k, 0.0, 0.0))
        else:
            x = ld.q if angle else ld.s
            y = ld.T if ld.link is not None else ld.F
            rows.append((1.0, 0.0, gate, float(len(xs)), float(len(x)), 5.0 + 2 * k, 6.0 + 2 * k, float(angle), q0))
            xs += [float(v) for v in x]
            Fs += [float(v) for v in y]
    return LoadsP(np.array(rows, dtype=float).reshape(-1, 9), np.array([xs, Fs], dtype=float).reshape(2, -1))


def _force_law(ld: LoadSpec, k: int = 0):
    """F(s, ds/dq) [N] of one load (:func:`load_force`; scalars or arrays)."""
    P = _loads_params([ld])
    return lambda s, sd: C.vectorize(lambda a, b: load_force(0, a, b, P), s, sd)
