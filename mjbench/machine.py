"""A machine: mechanism + drive + controller, wired as in seed 000 Fig. 3 (the 'diagram').

Both backends take a :class:`Machine` and return a :class:`~mjbench.trajectory.Trajectory`.
"""
from __future__ import annotations

from dataclasses import dataclass

from .drive import DCMotorDrive
from .mechanisms.base import Mechanism


@dataclass
class Machine:
    """Plant and controller.  q0 [rad], qd0 [rad/s]: initial crank angle and speed; I0 [A]."""

    mechanism: Mechanism
    drive: DCMotorDrive
    controller: object
    q0: float = 0.0
    qd0: float = 0.0
    I0: float = 0.0

    def reset(self):
        self.controller.reset()
