"""Reduced (Eksergian) dynamics: the mechanism interface's model of the input coordinate.

seed 000 Eq 5, rigid part: ½ J'(q) q̇² + J(q) q̈ + E_p'(q) = T_c + Q_ext(q, q̇, t); internal (elastic)
coordinates add their own accelerations (:meth:`ReducedDynamics.reduced_accel`).
"""
from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np


class ReducedDynamics(abc.ABC):
    """The reduced model of a mechanism (a part of :class:`~mjbench.mechanisms.base.Mechanism`)."""

    #: internal (elastic) coordinates of the reduced model besides q, e.g. ("deflection",)
    internal: ClassVar[tuple[str, ...]] = ()
    #: period [rad] of the reduced model's J(q), J'(q), E_p'(q) in the input coordinate (a crank:
    #: one turn, 2π); the reduced backends tabulate rigid mechanisms over it.  None: not periodic
    #: (the closed forms are evaluated at every step).
    reduced_period: ClassVar[float | None] = 2.0 * np.pi
    #: where the reduced model comes from; printed next to every multibody-vs-reduced figure.  A
    #: model derived from the MJCF itself (``mjcf``) must start with "MuJoCo-derived".
    reduced_source: ClassVar[str] = "independent: hand-derived closed form"

    def change_points(self) -> tuple:
        """Input angles [rad] over one period where the mechanism passes a change point — branches of
        its assembly meet (a parallelogram's flat positions) and the reduced model follows the branch
        by continuity of velocity; a run reports each one it passes (``change_points`` in
        metrics.json).  Default: none."""
        return ()

    @abc.abstractmethod
    def reduced(self, q):
        """Return ``(J, dJ_dq, dEp_dq)``: equivalent inertia about q [kg·m²] (rigid transmission),
        its derivative [kg·m²/rad] and the derivative of the potential energy [N·m] (seed 000 Eqs 2-5)."""

    @abc.abstractmethod
    def potential_energy(self, q):
        """Gravitational (and elastic, rigid part) potential energy E_p(q) [J]."""

    def kinetic_energy(self, q, qd):
        """E_k = ½ J(q) q̇² [J] (seed 000 Eq 2), mechanism only (no drive inertia)."""
        J, _, _ = self.reduced(q)
        return 0.5 * J * qd * qd

    def external_torque(self, q, qd, t):
        """Generalised external force on q [N·m] besides gravity and the drive (default 0)."""
        return 0.0 * q

    def has_external_torque(self) -> bool:
        """Whether :meth:`external_torque` can be non-zero (the reduced backends skip it if not)."""
        return type(self).external_torque is not ReducedDynamics.external_torque

    def reduced_viscous(self, q):
        """D(q) [N·m·s/rad] if :meth:`external_torque` is exactly −D(q)·q̇ (viscous friction
        reduced to the input, smooth and periodic in q like J); None if it is anything else (the
        tabulated reduced model then calls :meth:`external_torque` itself).  Default: None."""
        return None

    def reduced_accel(self, t, q, qd, x, xd, tau, J_add, c_add):
        """Accelerations (q̈, ẍ) of the reduced model under the input torque ``tau`` [N·m] (drive
        torque without its viscous part), with the drive inertia ``J_add`` [kg·m²] and viscous
        coefficient ``c_add`` [N·m·s/rad] on q.  ``x``, ``xd``: internal coordinates (tuples, empty
        for rigid mechanisms).  Default: the rigid Eksergian model (seed 000 Eqs 10-13)."""
        J, dJ, dEp = self.reduced(q)
        qdd = (tau - c_add * qd + self.external_torque(q, qd, t) - dEp - 0.5 * dJ * qd * qd) / (J_add + J)
        return qdd, ()

