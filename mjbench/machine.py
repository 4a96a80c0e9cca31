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
        _check_parts(self)
        # the drive train's mechanical elements (compliant gear, friction) belong to the plant's model
        train = getattr(self.drive, "train", None)
        if train is not None:
            self.mechanism = train.wrap(self.mechanism, self.drive)

    def reset(self):
        self.controller.reset()


def _check_parts(m: Machine) -> None:
    """The parts are objects of the right kinds and the initial state is finite: one error naming the
    argument (a name given instead of an object would otherwise fail deep inside a backend)."""
    import math

    from .drives import Drive
    from .errors import ParameterError

    make = {"mechanism": "mjbench.make_mechanism(...) or mjbench.load(name).machine().mechanism",
            "drive": "mjbench.make_drive(...)", "controller": "mjbench.make_controller(...)"}
    for name, want, ok in (("mechanism", "a Mechanism", isinstance(m.mechanism, Mechanism)),
                           ("drive", "a Drive", isinstance(m.drive, Drive)),
                           ("controller", "a controller (a callable with reset())", m.controller is None  # (a model only)
                            or (callable(m.controller) and callable(getattr(m.controller, "reset", None))))):
        if not ok:
            raise ParameterError(f"Machine({name}={getattr(m, name)!r}): expected {want} object, got "
                                 f"{type(getattr(m, name)).__name__}; build one with {make[name]}")
    for name in ("q0", "qd0", "I0"):
        v = getattr(m, name)
        try:
            ok = not isinstance(v, bool) and math.isfinite(float(v))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ParameterError(f"Machine({name}={v!r}): must be a finite number")
