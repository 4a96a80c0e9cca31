"""A machine: mechanism + drive + controller, wired as in seed 000 Fig. 3 (the 'diagram').

Every backend takes a :class:`Machine` and returns a :class:`~mjbench.trajectory.Trajectory`.
The kernel sees a machine through :attr:`Machine.drives` (one per axis, i.e. per input coordinate)
and :attr:`Machine.controllers` (each with the axis whose signals it reads by default).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .drive import DCMotorDrive
from .mechanisms.base import Mechanism


@dataclass
class Machine:
    """Plant and controller.  q0 [rad], qd0 [rad/s]: initial input angle and speed; I0 [A];
    x0, xd0: initial internal (elastic) coordinates and rates (None: at rest, undeflected)."""

    mechanism: Mechanism
    drive: DCMotorDrive
    controller: object
    q0: float = 0.0
    qd0: float = 0.0
    I0: float = 0.0
    x0: tuple | None = None
    xd0: tuple | None = None

    def __post_init__(self):
        # the drive train's mechanical elements (compliant gear, friction) belong to the plant's model
        train = getattr(self.drive, "train", None)
        if train is not None:
            self.mechanism = train.wrap(self.mechanism, self.drive)

    def reset(self):
        self.controller.reset()

    # ------------------------------------------------------------------ what the kernel reads
    @property
    def drives(self) -> list:
        """The drive of each axis (one axis: the machine's drive)."""
        return [self.drive]

    @property
    def controllers(self) -> list:
        """(controller, axis) pairs: each controller and the axis its unsuffixed signals name."""
        return [(self.controller, int(getattr(self.controller, "axis", 0) or 0))]

    @property
    def axis_labels(self) -> tuple:
        """Names of the axes (the input joints), for a machine with several."""
        return (getattr(self.mechanism, "input_joint", "0"),)

    def input_inertia(self, n: int = 16) -> tuple[float, float]:
        """(smallest, largest) inertia at the input coordinate, J_eq + J(q) over n angles of one
        period [kg·m²] (the mechanism's closed forms; the drive's reflected J_eq)."""
        mech, drive = self.mechanism, self.drive
        period = getattr(mech, "reduced_period", None) or 2.0 * math.pi
        J = []
        for q in np.linspace(0.0, period, n, endpoint=False):
            try:
                J.append(float(mech.reduced(float(q))[0]))
            except Exception:  # noqa: BLE001 - a pose the linkage cannot take: skip it
                continue
        Jeq = float(drive.J_eq)
        if not J:
            return Jeq, Jeq
        return Jeq + min(J), Jeq + max(J)
