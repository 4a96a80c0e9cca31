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
from ..linkage_kin import TWO_PI, ptable_channel
from .loads import load_abscissa, load_force
from .topology import GROUND, _ref

#: the MuJoCo loads' parameters — few arrays: every array a compiled law receives is passed as its
#: whole struct (pointer, shape, strides …) on every call, so the layout is two tables and a work
#: array besides the live MuJoCo arrays and the tables of the load laws:
#:
#: * ``qpos``, ``qvel``, ``qfrc``: live views of the MuJoCo data; ``tab``: the description's
#:   periodic table (:func:`~..linkage_kin.ptable_channel`); ``loads``: the loads
#:   (:func:`~.loads.load_force`);
#: * ``I`` (rows, 4) int64 and ``F`` (rows, 8) float64, one row each: first the *groups* — damped
#:   closures [0, ga), loads on slides only [ga, gc), loads through a chain [gc, gt), torque loads
#:   [gt, ge) — with their entries' rows [I[g, G_START], I[g, G_END]); then those *entries*; then
#:   the ``nd`` touched dofs at rows [rd, rd + nd) (``E_DOF``; their force is f slot i = row − rd);
#: * ``W`` (max(rows, nd, 1), 3): work — each touched dof's force (column W_F, row = f slot) and
#:   each chain element's pivot or slide direction (W_A, W_B, row = the element's row);
#: * ``ina``, ``qina``: the input's dof and qpos address; ``h2`` = h/2.
LinkageLoadP = namedtuple("LinkageLoadP", "qpos qvel qfrc tab loads I F W ina qina h2 ga gc gt ge rd nd")
#: columns of a group's row in ``I`` (its entries' rows, its load, the periodic-table channel of its
#: gate's rate) and in ``F`` (a damped closure's coefficient c or a slide load's s₀; a chain load's
#: point in its link and its direction)
G_START, G_END, G_LOAD, G_KD = range(4)
G_C, G_PT0, G_PT1, G_DX, G_DY = range(5)
#: columns of an entry's row in ``I`` (its f slot, qpos and dof addresses, 1 for a hinge) and in ``F``
#: (a closure entry's sign ±1 or a slide term's gain k; a chain element's p, c, u, φ)
E_SLOT, E_QPOS, E_DOF, E_HINGE = range(4)
E_K, E_P0, E_P1, E_C0, E_C1, E_U0, E_U1, E_PHI = range(8)
#: columns of ``W``
W_F, W_A, W_B = range(3)


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
    W = P.W
    for i in range(P.nd):
        W[i, W_F] = 0.0
    qpos = P.qpos
    qvel = P.qvel
    I = P.I
    F = P.F
    closure_damping_forces(qvel, I, F, W, 0, P.ga)
    q_mid = qpos[P.qina] + P.h2 * qvel[P.ina]
    slide_load_forces(q_mid, qpos, qvel, P.h2, P.tab, P.loads, I, F, W, P.ga, P.gc)
    chain_load_forces(q_mid, qpos, qvel, P.h2, P.tab, P.loads, I, F, W, P.gc, P.gt)
    link_torque_forces(q_mid, P.tab, P.loads, I, W, P.gt, P.ge)
    write_forces(P.qfrc, P.ina, I, W, P.rd, P.nd)


@law
def closure_damping_forces(qvel, I, F, W, g0, g1):
    """Into the forces ``W[:, W_F]``: each damped loop-closing hinge g ∈ [g0, g1)'s torque −c·w on the
    hinges of its two chains (w its relative rate: the plus chain's rates minus the minus chain's)."""
    for g in range(g0, g1):
        e0 = I[g, G_START]
        e1 = I[g, G_END]
        w = 0.0
        for e in range(e0, e1):
            if F[e, E_K] > 0.0:
                w = w + qvel[I[e, E_DOF]]
            else:
                w = w - qvel[I[e, E_DOF]]
        tau = -F[g, G_C] * w
        for e in range(e0, e1):
            i = I[e, E_SLOT]
            if F[e, E_K] > 0.0:
                W[i, W_F] = W[i, W_F] + tau
            else:
                W[i, W_F] = W[i, W_F] - tau


@law
def slide_load_forces(q_mid, qpos, qvel, h2, tab, loads, I, F, W, g0, g1):
    """Into the forces ``W[:, W_F]``: the loads g ∈ [g0, g1) on points moved by slides only,
    s = s₀ + Σ k_i·(slide i at mid-step), force F(s)·k_i on slide i; the gate from ds/dq at the
    input's mid-step angle ``q_mid``."""
    for g in range(g0, g1):
        e0 = I[g, G_START]
        e1 = I[g, G_END]
        sv = F[g, G_C]
        for e in range(e0, e1):
            sv = sv + F[e, E_K] * (qpos[I[e, E_QPOS]] + h2 * qvel[I[e, E_DOF]])
        sp = ptable_channel(q_mid, I[g, G_KD], tab)
        Fs = load_force(I[g, G_LOAD], sv, sp, loads)
        for e in range(e0, e1):
            i = I[e, E_SLOT]
            W[i, W_F] = W[i, W_F] + Fs * F[e, E_K]


@law
def chain_load_forces(q_mid, qpos, qvel, h2, tab, loads, I, F, W, g0, g1):
    """Into the forces ``W[:, W_F]``: the loads g ∈ [g0, g1) on points reached through hinges: the
    point walked down its chain at the mid-step qpos (each element's pivot, or slide direction, kept
    in ``W[e, W_A]``, ``W[e, W_B]``), then F(s) through the point Jacobian: (P − pivot) × d on a hinge, u·d on a slide."""
    for g in range(g0, g1):
        e0 = I[g, G_START]
        e1 = I[g, G_END]
        th = 0.0
        cP = 1.0
        sP = 0.0
        ox = 0.0
        oy = 0.0
        for e in range(e0, e1):
            val = qpos[I[e, E_QPOS]] + h2 * qvel[I[e, E_DOF]]
            px = ox + cP * F[e, E_P0] - sP * F[e, E_P1]
            py = oy + sP * F[e, E_P0] + cP * F[e, E_P1]
            if I[e, E_HINGE] != 0:
                W[e, W_A] = px
                W[e, W_B] = py
                th = th + val
            else:
                ux = cP * F[e, E_U0] - sP * F[e, E_U1]
                uy = sP * F[e, E_U0] + cP * F[e, E_U1]
                px = px + val * ux
                py = py + val * uy
                W[e, W_A] = ux
                W[e, W_B] = uy
                th = th + F[e, E_PHI]
            cP = math.cos(th)
            sP = math.sin(th)
            ox = px - (cP * F[e, E_C0] - sP * F[e, E_C1])
            oy = py - (sP * F[e, E_C0] + cP * F[e, E_C1])
        x = ox + cP * F[g, G_PT0] - sP * F[g, G_PT1]
        y = oy + sP * F[g, G_PT0] + cP * F[g, G_PT1]
        dx = F[g, G_DX]
        dy = F[g, G_DY]
        sp = ptable_channel(q_mid, I[g, G_KD], tab)
        Fs = load_force(I[g, G_LOAD], x * dx + y * dy, sp, loads)
        for e in range(e0, e1):
            i = I[e, E_SLOT]
            if I[e, E_HINGE] != 0:
                W[i, W_F] = W[i, W_F] + Fs * ((W[e, W_B] - y) * dx + (x - W[e, W_A]) * dy)
            else:
                W[i, W_F] = W[i, W_F] + Fs * (W[e, W_A] * dx + W[e, W_B] * dy)


@law
def link_torque_forces(q_mid, tab, loads, I, W, g0, g1):
    """Into the forces ``W[:, W_F]``: each torque load g ∈ [g0, g1) (its magnitude T at the input's
    mid-step angle) on every hinge of its link's chain from the ground."""
    for g in range(g0, g1):
        k = I[g, G_LOAD]
        T = load_force(k, load_abscissa(k, q_mid, loads, tab), ptable_channel(q_mid, I[g, G_KD], tab), loads)
        for e in range(I[g, G_START], I[g, G_END]):
            i = I[e, E_SLOT]
            W[i, W_F] = W[i, W_F] + T


@law
def write_forces(qfrc, ina, I, W, rd, nd):
    """The forces ``W[:nd, W_F]`` into ``qfrc_applied`` at the touched dofs (rows rd … rd + nd of
    ``I``): added on the input dof ``ina`` (it holds the drive torque), set on every other."""
    for i in range(nd):
        d = I[rd + i, E_DOF]
        if d == ina:
            qfrc[d] += W[i, W_F]
        else:
            qfrc[d] = W[i, W_F]


# ============================================================================ the CPython twin
def python_twin(P):
    """:func:`linkage_load`'s CPython twin for these parameters (:attr:`mjbench.compiled.Form.python`):
    the same operations in the same order — every group and entry unrolled, the constants of ``I``,
    ``F``, the loads' table and the periodic table's position written into the code, the forces kept
    in locals — reading ``qpos``/``qvel`` and writing ``qfrc`` through memoryviews, as the law does
    in the CPython loop.  The same bits (tests/test_linkage_cache.py's twin test, tests/test_digests.py)."""
    I, F, spec, xf, tab = np.asarray(P.I), np.asarray(P.F), np.asarray(P.loads.spec), np.asarray(P.loads.xf), P.tab
    env = {"math": math, "nan": math.nan, "qpos": memoryview(P.qpos), "qvel": memoryview(P.qvel),
           "qfrc": memoryview(P.qfrc)}
    r = repr
    out = ["def linkage_load_twin(t, _P):"]
    add = out.append
    for i in range(P.nd):
        add(f"    w{i} = 0.0")

    def channel(target, q, ch, ind):
        """:func:`~..linkage_kin.ptable_channel` (channel ``ch``) of ``q`` into ``target``."""
        env[f"R{ch}"] = memoryview(np.ascontiguousarray(tab.rows[ch]))
        cell = f"(i & {int(tab.M)})" if int(tab.M) >= 0 else f"(i % {int(tab.N)})"
        add(f"{ind}u = ({q} - {r(float(tab.q0))}) * {r(float(tab.inv_h))}")
        add(f"{ind}if not abs(u) < 1e15:")
        add(f"{ind}    {target} = nan")
        add(f"{ind}else:")
        add(f"{ind}    i = math.floor(u)")
        add(f"{ind}    tt = u - i")
        add(f"{ind}    b = 4 * {cell}")
        add(f"{ind}    {target} = ((R{ch}[b] * tt + R{ch}[b + 1]) * tt + R{ch}[b + 2]) * tt + R{ch}[b + 3]")

    def force(target, k, s, sd, ind):
        """:func:`~.loads.load_force` of load ``k`` at ``s`` with ds/dq ``sd`` into ``target``."""
        g = float(spec[k, 2])
        body = ind
        if g != 0.0:
            add(f"{ind}if not ({r(g)} * {sd} > 0.0):")
            add(f"{ind}    {target} = 0.0")
            add(f"{ind}else:")
            body = ind + "    "
        if float(spec[k, 0]) == 0.0:
            add(f"{body}{target} = {r(float(spec[k, 1]))}")
            return
        a, n = int(spec[k, 3]), int(spec[k, 4])
        xs, ys = tuple(float(v) for v in xf[0, a:a + n]), tuple(float(v) for v in xf[1, a:a + n])
        env[f"X{k}"], env[f"Y{k}"] = xs, ys
        add(f"{body}if {s} <= {r(xs[0])}:")
        add(f"{body}    {target} = {r(ys[0])}")
        add(f"{body}elif {s} >= {r(xs[-1])}:")
        add(f"{body}    {target} = {r(ys[-1])}")
        add(f"{body}else:")
        add(f"{body}    lo = 0")
        add(f"{body}    hi = {n - 1}")
        add(f"{body}    while hi - lo > 1:")
        add(f"{body}        mid = (lo + hi) // 2")
        add(f"{body}        if X{k}[mid] <= {s}:")
        add(f"{body}            lo = mid")
        add(f"{body}        else:")
        add(f"{body}            hi = mid")
        add(f"{body}    x0 = X{k}[lo]")
        add(f"{body}    tt = ({s} - x0) / (X{k}[lo + 1] - x0)")
        add(f"{body}    {target} = Y{k}[lo] + tt * (Y{k}[lo + 1] - Y{k}[lo])")

    def entries(g):
        return range(int(I[g, G_START]), int(I[g, G_END]))

    for g in range(0, P.ga):  # closure_damping_forces
        add("    w = 0.0")
        for e in entries(g):
            add(f"    w = w {'+' if F[e, E_K] > 0.0 else '-'} qvel[{int(I[e, E_DOF])}]")
        add(f"    tau = -{r(float(F[g, G_C]))} * w")
        for e in entries(g):
            i = int(I[e, E_SLOT])
            add(f"    w{i} = w{i} {'+' if F[e, E_K] > 0.0 else '-'} tau")
    h2 = r(float(P.h2))
    add(f"    q_mid = qpos[{int(P.qina)}] + {h2} * qvel[{int(P.ina)}]")
    for g in range(P.ga, P.gc):  # slide_load_forces
        add(f"    sv = {r(float(F[g, G_C]))}")
        for e in entries(g):
            add(f"    sv = sv + {r(float(F[e, E_K]))} * (qpos[{int(I[e, E_QPOS])}] + {h2} * qvel[{int(I[e, E_DOF])}])")
        channel("sp", "q_mid", int(I[g, G_KD]), "    ")
        force("Fs", int(I[g, G_LOAD]), "sv", "sp", "    ")
        for e in entries(g):
            i = int(I[e, E_SLOT])
            add(f"    w{i} = w{i} + Fs * {r(float(F[e, E_K]))}")
    for g in range(P.gc, P.gt):  # chain_load_forces
        add("    th = 0.0")
        add("    cP = 1.0")
        add("    sP = 0.0")
        add("    ox = 0.0")
        add("    oy = 0.0")
        for e in entries(g):
            p0, p1, c0, c1 = (r(float(F[e, j])) for j in (E_P0, E_P1, E_C0, E_C1))
            add(f"    val = qpos[{int(I[e, E_QPOS])}] + {h2} * qvel[{int(I[e, E_DOF])}]")
            add(f"    px = ox + cP * {p0} - sP * {p1}")
            add(f"    py = oy + sP * {p0} + cP * {p1}")
            if int(I[e, E_HINGE]) != 0:
                add(f"    a{e} = px")
                add(f"    b{e} = py")
                add("    th = th + val")
            else:
                u0, u1 = r(float(F[e, E_U0])), r(float(F[e, E_U1]))
                add(f"    ux = cP * {u0} - sP * {u1}")
                add(f"    uy = sP * {u0} + cP * {u1}")
                add("    px = px + val * ux")
                add("    py = py + val * uy")
                add(f"    a{e} = ux")
                add(f"    b{e} = uy")
                add(f"    th = th + {r(float(F[e, E_PHI]))}")
            add("    cP = math.cos(th)")
            add("    sP = math.sin(th)")
            add(f"    ox = px - (cP * {c0} - sP * {c1})")
            add(f"    oy = py - (sP * {c0} + cP * {c1})")
        pt0, pt1, dx, dy = (r(float(F[g, j])) for j in (G_PT0, G_PT1, G_DX, G_DY))
        add(f"    x = ox + cP * {pt0} - sP * {pt1}")
        add(f"    y = oy + sP * {pt0} + cP * {pt1}")
        channel("sp", "q_mid", int(I[g, G_KD]), "    ")
        add(f"    s = x * {dx} + y * {dy}")
        force("Fs", int(I[g, G_LOAD]), "s", "sp", "    ")
        for e in entries(g):
            i = int(I[e, E_SLOT])
            if int(I[e, E_HINGE]) != 0:
                add(f"    w{i} = w{i} + Fs * ((b{e} - y) * {dx} + (x - a{e}) * {dy})")
            else:
                add(f"    w{i} = w{i} + Fs * (a{e} * {dx} + b{e} * {dy})")
    for g in range(P.gt, P.ge):  # link_torque_forces
        k = int(I[g, G_LOAD])
        if float(spec[k, 7]) == 0.0:  # load_abscissa: the periodic table's channel
            channel("s", "q_mid", int(spec[k, 5]), "    ")
        else:
            q0 = r(float(spec[k, 8]))
            add(f"    u = q_mid - {q0}")
            add("    if not abs(u) < 1e15:")
            add("        s = nan")
            add("    else:")
            add(f"        s = {q0} + (u - {r(TWO_PI)} * math.floor(u / {r(TWO_PI)}))")
        channel("sp", "q_mid", int(I[g, G_KD]), "    ")
        force("T", k, "s", "sp", "    ")
        for e in entries(g):
            i = int(I[e, E_SLOT])
            add(f"    w{i} = w{i} + T")
    for i in range(P.nd):  # write_forces
        d = int(I[P.rd + i, E_DOF])
        add(f"    qfrc[{d}] {'+=' if d == int(P.ina) else '='} w{i}")
    src = "\n".join(out) + "\n"
    exec(compile(src, "<mjbench linkage load twin>", "exec"), env)  # noqa: S102 - our own generated source
    fn = env["linkage_load_twin"]
    fn.source = src
    return fn


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
        # the groups in order — (I row, F row, entries) — and each entry's (I row, F row): a damped
        # closure's hinges (f slot, dof; sign ±1), its plus chain then its minus chain; a slide load's
        # terms (f slot, qpos, dof; gain k); a chain load's elements (f slot, qpos, dof, hinge; p, c,
        # u, φ); a torque load's hinges (f slot)
        groups = [((0, 0, 0, 0), (cd,), [((i, 0, d, 0), (1.0,)) for i, d in plus]
                   + [((i, 0, d, 0), (-1.0,)) for i, d in minus]) for cd, plus, minus in damp]
        groups += [((0, 0, k, kd), (s0,), [((i, qa, da, 0), (kk,)) for i, qa, da, kk in terms])
                   for kd, s0, terms, k in affine]
        groups += [((0, 0, k, kd), (0.0, pt0, pt1, dx, dy), [((i, qa, da, int(hinge)), (0.0,) + tuple(geo))
                                                             for i, qa, da, hinge, *geo in chain])
                   for kd, chain, pt0, pt1, dx, dy, k in loads]
        groups += [((0, 0, k, kd), (), [((i, 0, 0, 0), ()) for i in slots]) for k, kd, slots in torques]
        ng = len(groups)
        ne = sum(len(ents) for _, _, ents in groups)
        rows = ng + ne + len(dofs)
        Ii = np.zeros((rows, 4), dtype=np.int64)
        Ff = np.zeros((rows, 8))
        r = ng
        for g, (gi, gf, ents) in enumerate(groups):
            Ii[g] = gi
            Ii[g, G_START], Ii[g, G_END] = r, r + len(ents)
            Ff[g, :len(gf)] = gf
            for ei, ef in ents:
                Ii[r], Ff[r, :len(ef)] = ei, ef
                r += 1
        Ii[r:, E_DOF] = dofs  # the touched dofs: f slot i is dof Ii[ng + ne + i, E_DOF]
        ga = len(damp)
        gc = ga + len(affine)
        gt = gc + len(loads)
        P = LinkageLoadP(data.qpos, data.qvel, data.qfrc_applied, self.c.table.P, self.loads_P, Ii, Ff,
                         np.zeros((max(rows, 1), 3)), ina, qina, h2, ga, gc, gt, ng, ng + ne, len(dofs))
        return C.Form(linkage_load, P, python=python_twin(P))

    def multibody_load(self, model, data, t: float) -> None:
        """Point and torque loads and the viscous friction of loop-closing hinges as generalised forces
        of the MuJoCo tree (:func:`linkage_load`, evaluated once)."""
        f = self.load_form(model, data)
        if f is not None:
            linkage_load(float(t), C.python_view(f.P))
