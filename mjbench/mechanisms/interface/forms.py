"""Compiled forms of the mechanism interface: the laws the kernel's slots compose (:mod:`mjbench.compiled`).

:class:`CompiledForms` gives a mechanism its default forms — the reduced model (the periodic spline
table of :mod:`mjbench.mechanisms.table`, or a Python adapter of the closed forms), the rigid
acceleration law (:func:`rigid_accel`), the MuJoCo loads, the loop-closure residual from the
connect sites (:func:`site_pairs_closure`) — and :func:`accel_call` evaluates an acceleration law
at one state.  These laws belong to the mechanisms: the plants (:mod:`mjbench.backends`) call them.
"""
from __future__ import annotations

import abc
from collections import namedtuple

import numpy as np

from ... import compiled as C
from .. import table


@C.law
def rigid_accel(MODEL, t, S, iy, ia, tau, Ja, c, P):
    """The rigid Eksergian acceleration as an acceleration law (the inner mechanism of a compliant
    gear): q̈ = [τ − c·q̇ + Q_ext − E_p' − ½J'·q̇²] / (J_eq + J) at (q, q̇) = (S[iy], S[iy+1]) into
    S[ia]; MODEL(q, q̇, t, P) its model law.  → q̈."""
    q = S[iy]
    qd = S[iy + 1]
    J, H, E, Q = MODEL(q, qd, t, P)
    qdd = (tau - c * qd + Q - E - H * qd * qd) / (Ja + J)
    S[ia] = qdd
    return qdd


@C.law
def site_pairs_closure(P, S):
    """The loop-closure residual [m]: the largest |component| of the offsets between the two sites
    of every ``connect`` equality (``P.closure.sx`` the flat ``site_xpos``, ``.pairs`` flat index
    pairs; ``P``: the MuJoCo plant's parameters)."""
    r = 0.0
    sx = P.closure.sx
    pairs = P.closure.pairs
    for p in range(len(pairs)):
        v = abs(sx[pairs[p, 0]] - sx[pairs[p, 1]])
        if v > r:
            r = v
    return r


SitePairsP = namedtuple("SitePairsP", "sx pairs")


class CompiledForms(abc.ABC):
    """The kernel's slots of a mechanism (a part of :class:`~mjbench.mechanisms.base.Mechanism`)."""

    def model_form(self):
        """The reduced model as a law ``MODEL(q, q̇, t, P) → (J, ½J', E_p', Q_ext)`` (a
        :class:`~mjbench.compiled.Form`), for the rigid reduced plant and model-based controllers.

        Default: the periodic spline table of J, ½J', E_p' and a viscous D
        (:func:`mjbench.mechanisms.table.table_model`).  A mechanism whose external torque is not
        viscous overrides this with a law that adds it (e.g. the quick-return's cutting force);
        without one, a Python adapter of the closed forms (the run is then not compiled)."""
        if table.supports(self) and not (self.has_external_torque() and self.reduced_viscous(0.0) is None):
            return table_form(self)
        why = ("its external torque is not viscous and has no law (override model_form)"
               if table.supports(self) else "its reduced model cannot be tabulated")
        return C.python_form(_closed_model(self), f"{type(self).__name__}: {why}")

    def accel_form(self):
        """The reduced model's accelerations as a law ``ACCEL(t, S, iy, ia, τ, J_eq, c, P) → q̈``
        (a :class:`~mjbench.compiled.Form`) for the reduced plant with internal coordinates
        (:func:`mjbench.backends.reduced.rk4_internal`): it reads the state (q, q̇, x₁, ẋ₁, …) at
        ``S[iy:]`` and writes (q̈, ẍ₁, …) to ``S[ia:]``; τ is the input torque, J_eq and c the
        drive's inertia and viscous coefficient on q.

        Default: a rigid mechanism's model law (:meth:`model_form`) through
        :func:`rigid_accel`; a mechanism with internal coordinates
        overrides it (its :meth:`reduced_accel` must call the same law, :func:`accel_call`),
        else a Python adapter of :meth:`reduced_accel` (the run is then not compiled)."""
        if not self.internal:
            m = self.model_form()
            return C.Form(rigid_accel, m.P, fn_args=(m,), flags=dict(m.flags))
        mech = self
        n = len(self.internal)

        def adapter(t, S, iy, ia, tau, Ja, c, P):
            x = tuple(S[iy + 2 + 2 * i] for i in range(n))
            xd = tuple(S[iy + 3 + 2 * i] for i in range(n))
            qdd, xdd = mech.reduced_accel(t, S[iy], S[iy + 1], x, xd, tau, Ja, c)
            S[ia] = float(qdd)
            for i in range(n):
                S[ia + 1 + i] = float(xdd[i])
            return float(qdd)
        return C.python_form(adapter, f"{type(self).__name__} has internal coordinates and no acceleration law "
                                      f"(override accel_form)")

    def load_form(self, model, data):
        """The MuJoCo loads as a law ``LOAD(t, P)`` writing ``qfrc_applied`` (a Form), or None when
        the mechanism has none.  Default: a Python adapter of :meth:`multibody_load` (the run is
        then not compiled); mechanisms with loads override it."""
        if not self.has_multibody_load():
            return None
        load = self.multibody_load

        def adapter(t, P):
            load(model, data, t)
        return C.python_form(adapter, f"{type(self).__name__}.multibody_load has no law (override load_form)")

    def closure_form(self, model, data):
        """The loop-closure residual as a law ``CLOSURE(P, S) → m`` (a Form whose ``P`` becomes the
        MuJoCo plant's ``P.closure``; the law gets the plant's P): the connect sites' offsets when
        every equality is a site ``connect``
        (:meth:`closure_site_index`), else a Python adapter of :meth:`closure_error`."""
        idx = self.closure_site_index(model)
        if idx is not None:
            pairs = np.array(idx, dtype=np.int64).reshape(-1, 2)
            return C.Form(site_pairs_closure, SitePairsP(data.site_xpos.reshape(-1), pairs))
        err = self.closure_error

        def adapter(P, S):
            return err(model, data)
        return C.python_form(adapter, f"{type(self).__name__}.closure_error has no law")

    def joint_write_form(self, model):
        """The reduced backend's joint columns as the mechanism's own law (a Form whose law
        ``write(out, b, P, S)`` reads the plant's state S = (q, q̇) and its parameters as ``P.joints``),
        or None (default): the joints are then tabulated from the kinematics
        (:func:`mjbench.backends.joints.reduced_table`)."""
        return None

    def motor_index(self, model):
        """(qpos, dof) of the motor's own hinge when the drive acts through a compliant gear, else None."""
        return None

    def motor_indices(self, model) -> tuple:
        """Per axis, (qpos, dof) of the motor's own hinge, (−1, −1) where the drive acts on the input
        joint itself (one axis: :meth:`motor_index`; several axes with compliant gears:
        :mod:`mjbench.drivetrain.axes`)."""
        if self.n_inputs == 1:
            m = self.motor_index(model)
            return ((-1, -1),) if m is None else ((int(m[0]), int(m[1])),)
        return ((-1, -1),) * self.n_inputs

    def axes_gear(self):
        """The compliant gears of a machine with several motors (:class:`mjbench.drivetrain.axes.AxesGearP`:
        the reduced plant integrates each motor as a coordinate of its own), or None (default: every
        axis's gear is rigid)."""
        return None

    def mechanism_alone(self):
        """The mechanism without the drive train's mechanical elements: what the model check
        compares with MuJoCo (default itself)."""
        return self

    def internal_index(self, model):
        """The internal coordinates in the MuJoCo model as rows (qpos a, qpos b, dof a, dof b, c):
        x = q_a − c·q_b (an (n, 5) array), or None if they are not of that form (a Python adapter of
        :meth:`internal_state` then records them)."""
        return None


def table_form(mech):
    """The periodic spline table of a rigid mechanism as a model law (:func:`table_model`), its
    description in ``flags["table"]`` (the run's meta)."""
    tab = table.table_for(mech)
    return C.Form(table.table_model, table.table_params(tab), flags={"table": tab.describe()})


def accel_call(form, t, q, qd, x, xd, tau, J_add, c_add):
    """(q̈, (ẍ₁, …)) of an acceleration law (:meth:`Mechanism.accel_form`) at one state: what a
    mechanism's :meth:`~Mechanism.reduced_accel` returns, computed by the law itself."""
    n = len(x)
    m = 2 * n + 2
    S = [0.0] * (m + n + 1)
    S[0], S[1] = float(q), float(qd)
    for i in range(n):
        S[2 + 2 * i] = float(x[i])
        S[3 + 2 * i] = float(xd[i])
    form.bound()(float(t), S, 0, m, float(tau), float(J_add), float(c_add), C.python_view(form.P))
    return S[m], tuple(S[m + 1:])


def _closed_model(mech):
    """MODEL(q, q̇, t, P) from the closed forms (Python only)."""
    def model_law(q, qd, t, P):
        J, dJ, dEp = mech.reduced(q)
        return float(J), 0.5 * float(dJ), float(dEp), float(mech.external_torque(q, qd, t))
    return model_law


