"""A machine: mechanism + drive + controller, wired as in seed 000 Fig. 3 (the 'diagram').

Every backend takes a :class:`Machine` and returns a :class:`~mjbench.trajectory.Trajectory`.
The kernel sees a machine through :attr:`Machine.drives` (one per axis, i.e. per input coordinate)
and :attr:`Machine.controllers` (each with the axis whose signals it reads by default).

A machine with several motors (a mechanism with ``n_inputs`` > 1) takes a sequence of drives (one
per input, in the mechanism's input order), one controller per axis (a sequence) or one controller
for all axes, and q0, qd0, I0 as sequences.  What is one-axis only says so in one line when asked
(``machine.drive.R`` on a two-motor machine: :class:`OneAxisOnly`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .drive import DCMotorDrive
from .drives import Drive
from .drivetrain.axes import with_axes_train
from .errors import OneAxisOnly, ParameterError, one_axis_only  # noqa: F401 - (one_axis_only: re-exported)
from .mechanisms.base import Mechanism


class PerAxis(list):
    """The drives (or controllers) of a machine with several axes, in axis order: a list; asking it
    for one drive's attribute (``machine.drive.z``) is a one-line error naming the axes."""

    kind = "drives"

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        raise OneAxisOnly(f"{self.kind}.{name}: the machine has {len(self)} axes, each with its own "
                          f"{self.kind[:-1]}; this is one-axis only (use machine.{self.kind}[k])")


class PerAxisControllers(PerAxis):
    kind = "controllers"


@dataclass
class Machine:
    """Plant and controller.  q0 [rad], qd0 [rad/s]: initial input angle and speed; I0 [A];
    x0, xd0: initial internal (elastic) coordinates and rates (None: at rest, undeflected).
    Several axes: ``drive`` and ``controller`` sequences (or one controller for all axes), q0, qd0,
    I0 sequences (module docstring)."""

    mechanism: Mechanism
    drive: DCMotorDrive
    controller: object
    q0: float = 0.0
    qd0: float = 0.0
    I0: float = 0.0
    x0: tuple | None = None
    xd0: tuple | None = None

    def __post_init__(self):
        if not isinstance(self.mechanism, Mechanism):
            raise ParameterError(f"Machine(mechanism={self.mechanism!r}): expected a Mechanism object, got "
                                 f"{type(self.mechanism).__name__}; build one with {_MAKE['mechanism']}")
        n = self.mechanism.n_inputs
        if isinstance(self.drive, (list, tuple)):
            if len(self.drive) != n:
                raise ParameterError(f"machine: {len(self.drive)} drives for a mechanism with {n} input(s)")
            self.drive = PerAxis(self.drive) if n > 1 else self.drive[0]
        elif n > 1:
            self.drive = PerAxis([self.drive] * n)
        if isinstance(self.controller, (list, tuple)) and n > 1:
            if len(self.controller) != n:
                raise ParameterError(f"machine: {len(self.controller)} controllers for {n} axes (one per axis, or "
                                     f"one controller for all axes)")
            for k, c in enumerate(self.controller):
                c.axis = k
            self.controller = PerAxisControllers(self.controller)
        elif isinstance(self.controller, (list, tuple)):
            self.controller = self.controller[0]
        if n > 1:
            for name in ("q0", "qd0", "I0"):
                v = getattr(self, name)
                if type(v) is float or type(v) is int:  # (the common cases, without NumPy: the same floats)
                    setattr(self, name, (float(v),) * n)
                    continue
                if type(v) is tuple and len(v) == n and all(type(x) is float for x in v):
                    continue
                arr = np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy() if np.ndim(v) == 0 else \
                    np.asarray(v, dtype=float)
                if arr.shape != (n,):
                    raise ParameterError(f"machine.{name} = {v!r}: give {n} values (one per axis)")
                setattr(self, name, tuple(float(x) for x in arr))
        _check_parts(self)
        # the drive train's mechanical elements (compliant gear, friction) belong to the plant's model
        train = getattr(self.drive, "train", None) if n == 1 else None
        if n > 1:  # the electrical elements are per axis in the kernel; gears and friction join the plant
            self.mechanism = with_axes_train(self.mechanism, self.drives, self.axis_labels)
        if train is not None:
            self.mechanism = train.wrap(self.mechanism, self.drive)

    def reset(self):
        for c, _ in self.controllers:
            c.reset()

    def require_one_axis(self, what: str, why: str = "") -> None:
        """One line when ``what`` (a command, an analysis) is asked of a machine with several axes."""
        if self.naxes > 1:
            raise one_axis_only(what, self.axis_labels, why)

    # ------------------------------------------------------------------ what the kernel reads
    @property
    def naxes(self) -> int:
        return len(self.drives)

    @property
    def drives(self) -> list:
        """The drive of each axis (one axis: the machine's drive)."""
        return list(self.drive) if isinstance(self.drive, PerAxis) else [self.drive]

    @property
    def controllers(self) -> list:
        """(controller, axis) pairs: each controller and the axis its unsuffixed signals name."""
        if isinstance(self.controller, PerAxisControllers):
            return [(c, k) for k, c in enumerate(self.controller)]
        return [(self.controller, int(getattr(self.controller, "axis", 0) or 0))]

    @property
    def axis_labels(self) -> tuple:
        """Names of the axes (the input joints)."""
        return tuple(self.mechanism.input_joints)

    def input_inertia(self, n: int = 16) -> tuple[float, float]:
        """(smallest, largest) inertia at an input, J_eq + J(q) over n angles of one period [kg·m²]
        (several axes: the diagonal of J_eq + M̄(q) at the initial pose)."""
        mech = self.mechanism
        if self.naxes > 1:
            M = mech.reduced_table(np.atleast_2d(self.q0))[0][0]
            d = [float(M[k, k]) + float(dr.J_eq) for k, dr in enumerate(self.drives)]
            return min(d), max(d)
        drive = self.drive
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


#: how to build each part (named in the error when a part is of the wrong kind)
_MAKE = {"mechanism": "mjbench.make_mechanism(...) or mjbench.load(name).machine().mechanism",
         "drive": "mjbench.make_drive(...)", "controller": "mjbench.make_controller(...)"}


def _check_parts(m: Machine) -> None:
    """The parts are objects of the right kinds and the initial state is finite: one error naming the
    argument (a name given instead of an object would otherwise fail deep inside a backend)."""
    ctrls = [c for c, _ in m.controllers] if m.controller is not None else [None]
    for name, obj, want, ok in (
            [("drive", d, "a Drive", isinstance(d, Drive)) for d in m.drives]
            + [("controller", c, "a controller (a callable with reset())", c is None  # (a model only)
                or (callable(c) and callable(getattr(c, "reset", None)))) for c in ctrls]):
        if not ok:
            raise ParameterError(f"Machine({name}={obj!r}): expected {want} object, got {type(obj).__name__}; "
                                 f"build one with {_MAKE[name]}")
    for name in ("q0", "qd0", "I0"):
        v = getattr(m, name)
        if type(v) is tuple and all(type(x) is float for x in v):  # (several axes, as __post_init__ leaves them)
            if all(math.isfinite(x) for x in v):
                continue
        try:
            ok = all(not isinstance(x, bool) and math.isfinite(float(x)) for x in np.atleast_1d(np.asarray(v, dtype=object)))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ParameterError(f"Machine({name}={v!r}): must be a finite number (several axes: one per axis)")
