"""The linkage's loads on the MuJoCo tree: generalised forces written before each step, as laws.

What the MuJoCo plant applies besides the drive (docs/linkages.md §4): the viscous damping of
loop-closing hinges (a torque pair from their relative rate), point loads through the *tree's own*
point Jacobian at the step's predicted mid-point qpos + ½h·qvel (a point moved by slides only: an
affine special case), and torques on links (+T on every hinge of the link's chain from the frame).
The only input from the description's kinematics is a gated load's stroke (ds/dq or dθ_link/dq
at the input's mid-step angle) and a stroke table's abscissa.

:func:`linkage_load` is the plant's LOAD law; it calls one law per kind of load by name
(:func:`closure_damping_forces`, :func:`slide_load_forces`, :func:`chain_load_forces`,
:func:`link_torque_forces`, :func:`write_forces`): CPython and compiled give the same bits.
:class:`MultibodyLoadsMixin` gives :class:`~.mechanism.Linkage` its ``load_form`` and
``multibody_load``.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ... import compiled as C
from ...compiled import law
from ..linkage_kin import ptable_channel
from .loads import load_abscissa, load_force
from .topology import GROUND, _ref

#: the MuJoCo loads: live qpos, qvel, qfrc_applied, the input's dof and qpos, h/2, the periodic
#: table, the loads; damped closures (coefficient, entries dptr[k]..dptr[k+1]: f slot, dof, sign);
#: loads on slides only (load, s channel… terms aptr[k]..: f slot, qpos, dof, gain); loads through a
#: chain (load, ds/dq channel, elements cptr[k]..cptr[k+1], point in its link, direction; elements:
#: f slot, qpos, dof, hinge, p, c, u, φ); work arrays (per element a, b; f per dof) and the dofs;
#: torque loads (load, dθ/dq channel, the f slots of the link chain's hinges tptr[k]..tptr[k+1])
LinkageLoadP = namedtuple("LinkageLoadP", "qpos qvel qfrc ina qina h2 tab loads dc dptr dslot ddof dsign "
                                          "aload akd as0 aptr ai aqa ada akk cload ckd cptr cpt0 cpt1 cdx cdy "
                                          "ei eqa eda ehinge ep0 ep1 ec0 ec1 eu0 eu1 ephi wa wb f dofs "
                                          "tload tkd tptr tslot")


# ============================================================================ laws
@law
def linkage_load(t, P):
    """The point and torque loads and the damping of loop-closing hinges as generalised forces of
    the MuJoCo tree, before each step (:meth:`MultibodyLoadsMixin.load_form`): closure damping from
    the relative rate at the step's start; a load's point from the tree's own kinematics at the
    predicted mid-point qpos + ½·h·qvel, F(s) through the point Jacobian, its stroke gate from ds/dq
    at the input's mid-step angle (the description's kinematics); a torque T on a link: +T on every
    hinge of the link's chain from the ground (its virtual work T·δθ_link: the link's angle is the
    sum of those hinge angles), T at the input's mid-step angle (an angle table: MuJoCo's own input
    angle; a stroke table's s and the gate's dθ_link/dq: the description's kinematics).  The input
    dof's force (the drive torque) is added to, every other touched dof is set."""
    f = P.f
    for i in range(len(f)):
        f[i] = 0.0
    closure_damping_forces(P)
    q_mid = P.qpos[P.qina] + P.h2 * P.qvel[P.ina]
    slide_load_forces(q_mid, P)
    chain_load_forces(q_mid, P)
    link_torque_forces(q_mid, P)
    write_forces(P)


@law
def closure_damping_forces(P):
    """Into ``P.f``: each damped loop-closing hinge's torque −c·w on the hinges of its two chains
    (w its relative rate: the plus chain's rates minus the minus chain's)."""
    f = P.f
    qvel = P.qvel
    for k in range(len(P.dc)):
        w = 0.0
        for e in range(P.dptr[k], P.dptr[k + 1]):
            if P.dsign[e] > 0.0:
                w = w + qvel[P.ddof[e]]
            else:
                w = w - qvel[P.ddof[e]]
        tau = -P.dc[k] * w
        for e in range(P.dptr[k], P.dptr[k + 1]):
            if P.dsign[e] > 0.0:
                f[P.dslot[e]] = f[P.dslot[e]] + tau
            else:
                f[P.dslot[e]] = f[P.dslot[e]] - tau


@law
def slide_load_forces(q_mid, P):
    """Into ``P.f``: the loads on points moved by slides only, s = s₀ + Σ k_i·(slide i at mid-step),
    force F(s)·k_i on slide i; the gate from ds/dq at the input's mid-step angle ``q_mid``."""
    f = P.f
    qpos = P.qpos
    qvel = P.qvel
    h2 = P.h2
    for k in range(len(P.aload)):
        sv = P.as0[k]
        for e in range(P.aptr[k], P.aptr[k + 1]):
            sv = sv + P.akk[e] * (qpos[P.aqa[e]] + h2 * qvel[P.ada[e]])
        sp = ptable_channel(q_mid, P.akd[k], P.tab)
        F = load_force(P.aload[k], sv, sp, P.loads)
        for e in range(P.aptr[k], P.aptr[k + 1]):
            f[P.ai[e]] = f[P.ai[e]] + F * P.akk[e]


@law
def chain_load_forces(q_mid, P):
    """Into ``P.f``: the loads on points reached through hinges: the point walked down its chain
    at the mid-step qpos (each element's pivot, or slide direction, kept in ``P.wa``, ``P.wb``),
    then F(s) through the point Jacobian: (P − pivot) × d on a hinge, u·d on a slide."""
    f = P.f
    qpos = P.qpos
    qvel = P.qvel
    h2 = P.h2
    for k in range(len(P.cload)):
        th = 0.0
        cP = 1.0
        sP = 0.0
        ox = 0.0
        oy = 0.0
        for e in range(P.cptr[k], P.cptr[k + 1]):
            val = qpos[P.eqa[e]] + h2 * qvel[P.eda[e]]
            px = ox + cP * P.ep0[e] - sP * P.ep1[e]
            py = oy + sP * P.ep0[e] + cP * P.ep1[e]
            if P.ehinge[e] != 0.0:
                P.wa[e] = px
                P.wb[e] = py
                th = th + val
            else:
                ux = cP * P.eu0[e] - sP * P.eu1[e]
                uy = sP * P.eu0[e] + cP * P.eu1[e]
                px = px + val * ux
                py = py + val * uy
                P.wa[e] = ux
                P.wb[e] = uy
                th = th + P.ephi[e]
            cP = math.cos(th)
            sP = math.sin(th)
            ox = px - (cP * P.ec0[e] - sP * P.ec1[e])
            oy = py - (sP * P.ec0[e] + cP * P.ec1[e])
        x = ox + cP * P.cpt0[k] - sP * P.cpt1[k]
        y = oy + sP * P.cpt0[k] + cP * P.cpt1[k]
        dx = P.cdx[k]
        dy = P.cdy[k]
        sp = ptable_channel(q_mid, P.ckd[k], P.tab)
        F = load_force(P.cload[k], x * dx + y * dy, sp, P.loads)
        for e in range(P.cptr[k], P.cptr[k + 1]):
            if P.ehinge[e] != 0.0:
                f[P.ei[e]] = f[P.ei[e]] + F * ((P.wb[e] - y) * dx + (x - P.wa[e]) * dy)
            else:
                f[P.ei[e]] = f[P.ei[e]] + F * (P.wa[e] * dx + P.wb[e] * dy)


@law
def link_torque_forces(q_mid, P):
    """Into ``P.f``: each torque load T (at the input's mid-step angle) on every hinge of its
    link's chain from the ground."""
    f = P.f
    for k in range(len(P.tload)):
        i = P.tload[k]
        T = load_force(i, load_abscissa(i, q_mid, P.loads, P.tab), ptable_channel(q_mid, P.tkd[k], P.tab), P.loads)
        for e in range(P.tptr[k], P.tptr[k + 1]):
            f[P.tslot[e]] = f[P.tslot[e]] + T


@law
def write_forces(P):
    """``P.f`` into ``qfrc_applied``: added on the input dof (it holds the drive torque), set on
    every other touched dof."""
    f = P.f
    for i in range(len(P.dofs)):
        d = P.dofs[i]
        if d == P.ina:
            P.qfrc[d] += f[i]
        else:
            P.qfrc[d] = f[i]


# ============================================================================ the mechanism's side
def _affine_terms(cc, pt, d):
    """A point moved by slides only (a ram on its guide): s is affine in the slide values,
    s = s0 + Σ k_i·d_i, and the generalised force on slide i is F·k_i (k_i = its world direction ·
    load direction) → (s0, terms (f slot, qpos, dof, k_i))."""
    th, s0, terms = 0.0, 0.0, []
    ox = oy = 0.0
    for i, qa, da, _, p0, p1, c0, c1, u0, u1, phi in cc:
        cP, sP = math.cos(th), math.sin(th)
        ox, oy = ox + cP * p0 - sP * p1, oy + sP * p0 + cP * p1
        terms.append((i, qa, da, (cP * u0 - sP * u1) * d[0] + (sP * u0 + cP * u1) * d[1]))
        th += phi
        cc_, ss_ = math.cos(th), math.sin(th)
        ox, oy = ox - (cc_ * c0 - ss_ * c1), oy - (ss_ * c0 + cc_ * c1)
    cc_, ss_ = math.cos(th), math.sin(th)
    s0 = (ox + cc_ * pt[0] - ss_ * pt[1]) * d[0] + (oy + ss_ * pt[0] + cc_ * pt[1]) * d[1]
    return float(s0), tuple(terms)


def _csr(groups):
    """(pointers, flat entries) of a list of lists (pointers[k]..pointers[k+1]: group k)."""
    ptr, flat = [0], []
    for g in groups:
        flat += list(g)
        ptr.append(len(flat))
    return ptr, flat


class MultibodyLoadsMixin:
    """The MuJoCo loads of :class:`~.mechanism.Linkage` (``self.c``: the compiled description,
    ``self._loads``: the loads' table channels, ``self.loads_P``: their parameters)."""

    def has_multibody_load(self) -> bool:
        c = self.c
        return bool(c.loads or any(self.params.joints[k].damping > 0 for k in c.closures))

    def _chain(self, model, link):
        """The tree joints from the ground to ``link``: [(edge, qpos address, dof address)]."""
        by_child = {e.child: e for e in self.c.edges}
        out = []
        while link != GROUND:
            e = by_child[link]
            jn = model.joint(e.name)
            out.append((e, int(jn.qposadr[0]), int(jn.dofadr[0])))
            link = e.parent
        return out[::-1]

    def _mb_setup(self, model):
        """Per-model addresses: tree chains of the load points and of the damped closures."""
        hit = self._mb
        if hit is not None and hit[0] is model:
            return hit[1]
        c, p = self.c, self.params
        damp = []
        for k in c.closures:
            j = p.joints[k]
            if j.damping <= 0:
                continue
            l1, _, l2, _ = c.jlinks[k]
            h1 = {d for e, _, d in self._chain(model, l1) if e.kind == "R"} if l1 != GROUND else set()
            h2 = {d for e, _, d in self._chain(model, l2) if e.kind == "R"} if l2 != GROUND else set()
            damp.append((float(j.damping), sorted(h2 - h1), sorted(h1 - h2)))
        raw_loads, raw_torques = [], []
        for k, ld in enumerate(p.loads):
            if ld.link is not None:  # a torque on a link: T on every hinge of its chain from the ground
                raw_torques.append((k, [da for e, _, da in self._chain(model, ld.link) if e.kind == "R"]))
                continue
            lk, pt = _ref(ld.point)
            d = np.array(ld.direction, float) / math.hypot(*ld.direction)
            raw_loads.append((k, self._chain(model, lk) if lk != GROUND else [], c.pts[lk][pt], d))
        dofs = sorted({dd for _, a, b in damp for dd in a + b} | {da for _, ch, _, _ in raw_loads for _, _, da in ch}
                      | {da for _, hs in raw_torques for da in hs})
        idx = {d: i for i, d in enumerate(dofs)}
        torques = [(k, self._loads[k][1], [idx[d] for d in hs]) for k, hs in raw_torques]
        damp = [(cd, [(idx[d], d) for d in a], [(idx[d], d) for d in b]) for cd, a, b in damp]
        loads, affine = [], []
        for k, ch, pt, d in raw_loads:
            cc = tuple((idx[da], qa, da, e.kind == "R", float(e.p[0]), float(e.p[1]), float(e.c[0]), float(e.c[1]),
                        float(e.u[0]) if e.u is not None else 0.0, float(e.u[1]) if e.u is not None else 0.0,
                        float(e.phi)) for e, qa, da in ch)
            if all(not el[3] for el in cc):
                s0, terms = _affine_terms(cc, pt, d)
                affine.append((self._loads[k][1], s0, terms, k))
                continue
            loads.append((self._loads[k][1], cc, float(pt[0]), float(pt[1]), float(d[0]), float(d[1]), k))
        jin = model.joint(self.input_joint)
        setup = (damp, loads, affine, dofs, int(jin.dofadr[0]), int(jin.qposadr[0]), 0.5 * float(model.opt.timestep),
                 torques)
        self._mb = (model, setup)
        return setup

    def load_form(self, model, data):
        """Point and torque loads and the viscous friction of loop-closing hinges as a law (:func:`linkage_load`)."""
        if not self.has_multibody_load():
            return None
        damp, loads, affine, dofs, ina, qina, h2, torques = self._mb_setup(model)
        tptr, tslot = _csr(slots for _, _, slots in torques)  # torque loads: +T on the f slots of the link's hinges
        # damped closures: entries (f slot, dof, ±1) of each, in order (plus, then minus)
        dptr, dent = _csr([(i, d, 1.0) for i, d in plus] + [(i, d, -1.0) for i, d in minus] for _, plus, minus in damp)
        aptr, at = _csr(terms for _, _, terms, _ in affine)  # loads on slides only: s = s0 + Σ kk·(slide value)
        cptr, ce = _csr(ch for _, ch, *_ in loads)  # loads through the tree's chain of hinges and slides
        i64 = (lambda v: np.array(v, dtype=np.int64))
        f64 = (lambda v: np.array(v, dtype=float))
        dcols = list(zip(*dent)) if dent else [()] * 3
        acols = list(zip(*at)) if at else [()] * 4
        cols = list(zip(*ce)) if ce else [()] * 11
        P = LinkageLoadP(
            data.qpos, data.qvel, data.qfrc_applied, ina, qina, h2, self.c.table.P, self.loads_P,
            f64([cd for cd, _, _ in damp]), i64(dptr), i64(dcols[0]), i64(dcols[1]), f64(dcols[2]),
            i64([law for _, _, _, law in affine]), i64([kd for kd, _, _, _ in affine]),
            f64([s0 for _, s0, _, _ in affine]), i64(aptr), i64(acols[0]), i64(acols[1]), i64(acols[2]),
            f64(acols[3]),
            i64([ld[-1] for ld in loads]), i64([ld[0] for ld in loads]), i64(cptr),
            f64([ld[2] for ld in loads]), f64([ld[3] for ld in loads]), f64([ld[4] for ld in loads]),
            f64([ld[5] for ld in loads]),
            i64(cols[0]), i64(cols[1]), i64(cols[2]), f64(cols[3]), f64(cols[4]), f64(cols[5]), f64(cols[6]),
            f64(cols[7]), f64(cols[8]), f64(cols[9]), f64(cols[10]),
            np.zeros(max(len(ce), 1)), np.zeros(max(len(ce), 1)), np.zeros(max(len(dofs), 1)), i64(dofs),
            i64([k for k, _, _ in torques]), i64([kd for _, kd, _ in torques]), i64(tptr), i64(tslot))
        return C.Form(linkage_load, P)

    def multibody_load(self, model, data, t: float) -> None:
        """Point and torque loads and the viscous friction of loop-closing hinges as generalised forces
        of the MuJoCo tree (:func:`linkage_load`, evaluated once)."""
        f = self.load_form(model, data)
        if f is not None:
            linkage_load(float(t), C.python_view(f.P))
