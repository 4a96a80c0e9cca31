"""Linear counterparts of control laws, numerically: any controller law is linearised from its
compiled form around an operating point, its state included (python-control's ``linearize`` and
Drake's ``Linearize`` do the same for any system).

A controller sampled at period T is the discrete-time system

    S_{k+1} = f(S_k, y_k),   u_k = g(S_k, y_k)

of its law (:mod:`mjbench.control`): the state S, the signals y it reads.  Around the operating
point (:class:`mjbench.linear.OperatingPoint`) the signals are written in the inputs of a law's
counterpart, input side — q_ref, qd_ref, qdd_ref (the reference: φ_ref = z·q_ref …), q, qd, qd_prev
(the acceleration it reads is the backward difference (q̇ − q̇_prev)/h), I — and a law that reads
what the drive applied (``V``, ``u_held``, ``u``, ``tau``) gets one more state, its previous output
(the applied voltage is the held command while no limit is active).  The Jacobians are central
differences of the law itself (steps 1e-6·max(1, |x|): a law that is affine in its inputs — the
PID, the servo — is reproduced to rounding, tests/test_linearise.py); states that never change or
never matter are dropped.

Assumptions, stated: no limit active at the point (clip, anti-windup); a model-based law's model
terms follow the angle (``angle = "frozen"`` is the hand-written counterparts' option); ``tau`` is
read as z·k_m·I (the DC motor's torque at the mean current).
"""
from __future__ import annotations

import math

import numpy as np

from . import compiled as C
from . import signals as SIG
from .errors import ParameterError
from .signals import call_law, law_signals

#: inputs of a control law's linear counterpart (the reference's outputs, input side, then the measurements)
LAW_INPUTS = ("q_ref", "qd_ref", "qdd_ref", "q", "qd", "qd_prev", "I")

#: how many samples the law runs at the point before it is differentiated (fills "previous sample" states)
SETTLE = 3
#: the signals that read the law's own previous output (through the drive)
APPLIED = ("V", "u_held", "u", "tau")


class _Law:
    """A controller's law at one operating point: ``eval(S, v, u_prev, t)`` → (S', u)."""

    def __init__(self, ctrl, machine, op, T, h):
        form = ctrl.form(T, machine)
        if form is None:
            name = getattr(ctrl, "type_name", "") or type(ctrl).__name__
            raise ParameterError(f"controller {name!r} has no linear counterpart: it has no law to linearise "
                                 f"numerically (write linear(), or write the controller as a law)")
        self.form = form
        self.fn = form.bound()
        self.P = C.python_view(form.P)
        self.S0 = form.state()
        self.names = [SIG.ALIASES.get(n, n) for n in law_signals(form.law, len(form.fn_args))]
        d = machine.drive
        self.z = float(d.z)
        self.km = float(getattr(d, "k_m", 0.0) or 0.0)
        self.h, self.T, self.op = float(h), float(T), op
        self.applied = any(n in APPLIED for n in self.names)
        self.const = {"v_max": float(getattr(d, "v_max", math.inf)), "i_max": float(getattr(d, "i_max", math.inf)),
                      "u_min": -math.inf, "u_max": math.inf, "z": self.z}

    def signals(self, v, t, u_prev) -> dict:
        z = self.z
        s = {"t": t, "q": v[3], "qd": v[4], "qdd": (v[4] - v[5]) / self.h, "I": v[6], "phi_ref": z * v[0],
             "om_ref": z * v[1], "acc_ref": z * v[2], "V": u_prev, "u_held": u_prev, "u": u_prev,
             "tau": z * self.km * v[6]}
        s.update(self.const)
        return s

    def eval(self, S, v, u_prev, t):
        S1 = np.array(S, dtype=float)
        u = call_law(self.fn, self.signals(v, t, u_prev), self.P, memoryview(S1))
        return S1, float(np.asarray(u).reshape(-1)[0])

    def point(self, q_off: float = 0.0):
        """The inputs at the point (the reference through q* + q_off)."""
        op = self.op
        return np.array([op.q + q_off, op.qd, 0.0, op.q, op.qd, op.qd, op.I])

    def settle(self, v, u_prev, n=SETTLE):
        """The state after ``n`` samples at the point (the last one a period before t*), and the last output."""
        S, u = self.S0.copy(), u_prev
        for k in range(n):
            S, u = self.eval(S, v, u, self.op.t - (n - k) * self.T)
        return S, u


def hold_offset(ctrl, machine, op) -> float:
    """The reference offset q_off [rad, input side] at which the law, from its initial state, outputs
    the operating point's voltage V* (a constant-speed reference through q* + q_off): Newton on the
    law's own output (affine laws: one step)."""
    L = _Law(ctrl, machine, op, _period(ctrl, 1e-4), 1e-4)
    V = float(op.V)

    def u_at(x):
        return L.eval(L.S0.copy(), L.point(x), V, op.t)[1]

    x, e = 0.0, 1e-3
    for _ in range(20):
        u0 = u_at(x)
        r = u0 - V
        if abs(r) <= 1e-10 * max(1.0, abs(V)):
            return x
        slope = (u_at(x + e) - u_at(x - e)) / (2 * e)
        if not (math.isfinite(slope) and abs(slope) > 1e-12):
            name = getattr(ctrl, "type_name", "") or type(ctrl).__name__
            raise ParameterError(f"controller {name!r}: its output does not depend on the angle error, so no "
                                 f"reference offset holds the operating point (V* = {V:.4g} V); define hold_offset()")
        x -= r / slope
    return x


def _period(ctrl, h):
    p = float(getattr(ctrl, "period", 0.0) or 0.0)
    return p if p > 0 else h


def law_counterpart(ctrl, machine, op, T: float, h: float, angle: str = "state"):
    """The controller's law linearised at ``op`` (module docstring): a discrete-time
    ``control.StateSpace`` at period T, inputs :data:`mjbench.control.LAW_INPUTS`, output ``V``,
    states named after the law's ``STATE`` (and ``u_prev``)."""
    import control as ct

    L = _Law(ctrl, machine, op, T, h)
    try:
        q_off = hold_offset(ctrl, machine, op)
    except ParameterError:
        q_off = 0.0
    v0 = L.point(q_off)
    S, u_star = L.settle(v0, float(op.V))
    names = list(getattr(ctrl, "STATE", ()) or ())
    names += [f"s{i}" for i in range(len(names), len(S))]
    idx = [i for i in range(len(S)) if math.isfinite(S[i])]
    nx = len(idx) + (1 if L.applied else 0)

    def F(x, v):
        S1 = S.copy()
        S1[idx] = x[:len(idx)]
        up = x[-1] if L.applied else u_star
        Sn, u = L.eval(S1, v, up, op.t)
        xn = list(Sn[idx]) + ([u] if L.applied else [])
        return np.array(xn, dtype=float), u

    x0 = np.array(list(S[idx]) + ([u_star] if L.applied else []), dtype=float)
    A = np.zeros((nx, nx))
    B = np.zeros((nx, len(LAW_INPUTS)))
    Cm = np.zeros((1, nx))
    D = np.zeros((1, len(LAW_INPUTS)))
    for j in range(nx):
        e = 1e-6 * max(1.0, abs(x0[j]))
        xp, xm = x0.copy(), x0.copy()
        xp[j] += e
        xm[j] -= e
        (sp, up), (sm, um) = F(xp, v0), F(xm, v0)
        A[:, j] = (sp - sm) / (2 * e)
        Cm[0, j] = (up - um) / (2 * e)
    for j in range(len(LAW_INPUTS)):
        e = 1e-6 * max(1.0, abs(v0[j]))
        vp, vm = v0.copy(), v0.copy()
        vp[j] += e
        vm[j] -= e
        (sp, up), (sm, um) = F(x0, vp), F(x0, vm)
        B[:, j] = (sp - sm) / (2 * e)
        D[0, j] = (up - um) / (2 * e)
    snames = [names[i] for i in idx] + (["u_prev"] if L.applied else [])
    keep = _relevant(A, B, Cm)
    A, B, Cm = A[np.ix_(keep, keep)], B[keep], Cm[:, keep]
    snames = [snames[i] for i in keep]
    name = getattr(ctrl, "type_name", "") or type(ctrl).__name__
    if not len(keep):
        return ct.ss(np.zeros((0, 0)), np.zeros((0, len(LAW_INPUTS))), np.zeros((1, 0)), D, T,
                     inputs=list(LAW_INPUTS), outputs=["V"], name=name)
    return ct.ss(A, B, Cm, D, T, inputs=list(LAW_INPUTS), outputs=["V"], states=snames, name=name)


def _relevant(A, B, Cm, tol=1e-12) -> list:
    """The states the inputs reach (directly or through other states) and that reach the output
    (directly or through other states); the others never move from the point or never matter."""
    keep = list(range(A.shape[0]))
    changed = True
    while changed:
        changed = False
        for i in list(keep):
            others = [j for j in keep if j != i]
            driven = np.any(np.abs(B[i]) > tol) or np.any(np.abs(A[i, others]) > tol)
            seen = abs(Cm[0, i]) > tol or np.any(np.abs(A[others, i]) > tol)
            if not (driven and seen):
                keep.remove(i)
                changed = True
    return keep


__all__ = ["law_counterpart", "hold_offset", "SETTLE"]
