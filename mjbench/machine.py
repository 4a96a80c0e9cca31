"""A machine: mechanism + drive + controller, wired as in seed 000 Fig. 3 (the 'diagram').

Every backend takes a :class:`Machine` and returns a :class:`~mjbench.trajectory.Trajectory`.
"""
from __future__ import annotations

from dataclasses import dataclass

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
