"""The linear model checked on the nonlinear machine: where a controller holds the machine at rest
(:func:`hold_point`) and set-point steps from an operating point, simulated and predicted
(:func:`step_check`; docs/linear.md §6)."""
from __future__ import annotations

import copy
import dataclasses
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ParameterError
from ..machine import Machine
from .results import require_pandas
from .scenarios import Scenario, as_scenario
from .simulation import MACHINE_DT, machine_options, seconds
from .. import runner
from ..linear import StepReference
from ..linear import operating_point
from .. import linear as LN
from ..plotstyle import new

if TYPE_CHECKING:
    import pandas
    from matplotlib.figure import Figure

Target = Scenario | Machine | str | os.PathLike[str] | Mapping[str, Any]


# ====================================================================== the machine of a target
def _machine(target: Target, mode: str | None, dt: float | str | None,
             options: Mapping[str, Mapping[str, Any]] | None) -> tuple[Machine, float, dict[str, dict[str, Any]]]:
    """(machine, co-step h [s], backend options {backend: {...}}) of a scenario's mode or a machine."""
    if isinstance(target, Machine):
        if mode is not None:
            raise ParameterError("mode is a scenario's; a Machine already holds its controller")
        h = seconds(dt if dt is not None else MACHINE_DT, "dt")
        return target, h, machine_options(h, options)
    if options is not None:
        raise ParameterError("options are a machine's; a scenario has its [multibody] and [reduced] tables")

    scn = as_scenario(target)
    if dt is not None:
        scn = scn.with_values(**{"simulation.dt": seconds(dt, "dt")})
    mode = scn.mode(mode)
    scn.check(mode)
    opts = {b: dict(runner.backend_options(scn.spec, b)) for b in ("multibody", "reduced")}
    return scn.machine(mode), float(scn.spec.simulation.dt), opts


def _hold_offset(machine: Machine, op: Any) -> float:
    fn = getattr(machine.controller, "hold_offset", None)
    if fn is None:
        raise ParameterError(f"controller {type(machine.controller).__name__} cannot say which reference holds a point "
                             f"(capability hold_offset(machine, op); the PID and the servo have it)")
    return float(fn(machine, op))


def _held_machine(machine: Machine, op: Any, q_ref: float, h: float) -> Machine:
    """``machine`` at rest at the operating point, its controller's reference fixed at ``q_ref``
    (input side, speed 0): the controller holds it there."""

    ctrl: Any = copy.copy(machine.controller)
    ctrl.reference = StepReference(float(machine.drive.z), q_ref, 0.0, 0.0, 0.0, 0.0, h)
    return dataclasses.replace(machine, controller=ctrl, q0=op.q, qd0=0.0, I0=op.I,
                               x0=op.x or None, xd0=op.xd or None)


# ====================================================================== hold point
@dataclass(frozen=True)
class HoldPoint:
    """Where the controller holds the machine at rest (an equilibrium; its stability is the
    linear model's: :func:`mjbench.linearize` at ``q``, ``qd=0``).

    Attributes
    ----------
    q : float
        Input angle [rad].
    I, V : float
        The current that holds it against gravity, springs and loads [A] and the voltage R·I [V].
    q_ref : float
        The controller's reference angle [rad, input side] (its speed set-point 0).
    offset : float
        ``q_ref − q`` [rad]: the error the controller needs to give V (its integral term, or a
        servo's position loop).
    operating_point : mjbench.linear.OperatingPoint
        ``q``, ``qd = 0``, ``I``, ``V``, the drive torque, ``t``.
    machine : mjbench.Machine
        The machine started there at rest with the holding current, its controller's reference
        fixed at ``q_ref``: :func:`mjbench.simulate` keeps it there (a copy: the original is
        unchanged).
    """

    q: float
    I: float
    V: float
    q_ref: float
    offset: float
    operating_point: Any
    machine: Machine


def hold_point(target: Target, mode: str | None = None, *, q: float | None = None, q_ref: float | None = None,
               t: float = 0.0, search: Sequence[float] = (-math.pi, math.pi), dt: float | str | None = None,
               options: Mapping[str, Mapping[str, Any]] | None = None) -> HoldPoint:
    """The rest position where the controller holds the machine, or the reference that holds it at ``q``.

    The controller keeps its gains; its reference is a fixed angle (speed set-point 0).  At rest
    the machine needs the current I*(q) that balances gravity, springs and loads (q̈ = 0), i.e.
    the voltage V* = R·I*; the controller gives it from an error q_ref − q (the PID's integral:
    K_i·z·(q_ref − q) = V*; the servo's position loop: K_vp·K_pp·z·(q_ref − q) = V*).

    Parameters
    ----------
    target : Scenario, str, path, dict or Machine
    mode : str, optional
        The scenario's controller mode (default: the scenario's).
    q : float, optional
        Hold the machine at this input angle [rad]: the reference angle that does it is computed.
    q_ref : float, optional
        Instead of ``q``: the reference angle [rad] (default 0, where a run started at q0 = 0 puts
        the PID's reference); the equilibrium q is the root of q + offset(q) = q_ref nearest to
        ``q_ref`` in ``search``.
    t : float
        Time of the controller's gains [s] (K_p·t: use a constant K_p).
    search : (float, float)
        The angles [rad] searched for the equilibrium (73 samples, then Brent's method).
    dt : float or str, optional
        Co-step [s] of the returned machine's runs (default: the scenario's ``simulation.dt``; a
        machine: 0.1 ms).
    options : mapping, optional
        A machine's backend options (as :func:`mjbench.simulate` takes them).

    Returns
    -------
    HoldPoint
        ``q``, ``I``, ``V``, ``q_ref``, ``offset``, ``operating_point``, ``machine``.

    Raises
    ------
    mjbench.errors.ParameterError
        Both or a wrong ``q``/``q_ref``; a controller that cannot hold a point (no integral or
        position loop); no equilibrium in ``search``.
    """
    from scipy.optimize import brentq


    if q is not None and q_ref is not None:
        raise ParameterError("hold_point: give q (the angle to hold) or q_ref (the reference angle), not both")
    machine, h, _ = _machine(target, mode, dt, options)
    if machine.mechanism.internal:
        raise ParameterError("hold_point: a machine with internal elastic coordinates has no single rest angle "
                             "per reference here; linearize it instead")
    t = float(t)

    def offset(qq: float) -> float:
        return _hold_offset(machine, operating_point(machine, qq, 0.0, t=t))

    if q is None:
        target_ref = 0.0 if q_ref is None else float(q_ref)
        lo, hi = (float(v) for v in search)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ParameterError(f"hold_point: search = {tuple(search)!r} must be finite angles lo < hi [rad]")
        grid = np.linspace(lo, hi, 73)
        f = np.array([g + offset(float(g)) - target_ref for g in grid])
        roots = [float(g) for g, v in zip(grid, f) if v == 0.0]
        for k in np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0):
            roots.append(float(brentq(lambda x: x + offset(x) - target_ref, grid[k], grid[k + 1], xtol=1e-14,
                                      rtol=4 * np.finfo(float).eps)))
        if not roots:
            raise ParameterError(f"hold_point: no angle in [{lo:.4g}, {hi:.4g}] rad where the controller holds the "
                                 f"machine with its reference at q_ref = {target_ref:.4g} rad (widen search, or give "
                                 f"q: the reference that holds the machine there is computed)")
        q = min(roots, key=lambda r: abs(r - target_ref))
        op = operating_point(machine, q, 0.0, t=t)
        return HoldPoint(q, float(op.I), float(op.V), target_ref, target_ref - q, op,
                         _held_machine(machine, op, target_ref, h))
    q = float(q)
    if not math.isfinite(q):
        raise ParameterError(f"hold_point: q = {q!r} must be finite")
    op = operating_point(machine, q, 0.0, t=t)
    off = _hold_offset(machine, op)
    return HoldPoint(q, float(op.I), float(op.V), q + off, off, op, _held_machine(machine, op, q + off, h))


# ====================================================================== step check
@dataclass(frozen=True)
class StepCheck:
    """Set-point steps on the nonlinear machine against the linear closed loop's prediction.

    Attributes
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times [s] (every controller period).
    q_sim, q_lin, qd_sim, qd_lin : numpy.ndarray, shape (n,)
        Deviations from the operating point of the input angle [rad] and speed [rad/s]:
        simulated (from the pre-step state) and predicted by the linear closed loop.
    q_rel_error, qd_rel_error : float
        max |simulated − predicted| / max |predicted|.
    operating_point : mjbench.linear.OperatingPoint
    backend : str
        The backend that simulated (``multibody`` or ``reduced``).
    """

    t: np.ndarray
    q_sim: np.ndarray
    q_lin: np.ndarray
    qd_sim: np.ndarray
    qd_lin: np.ndarray
    q_rel_error: float
    qd_rel_error: float
    operating_point: Any
    backend: str

    def summary(self) -> str:
        op = self.operating_point
        return (f"step check at q* = {op.q:.4g} rad, q̇* = {op.qd:.4g} rad/s ({self.backend}): simulated vs linear, "
                f"angle {self.q_rel_error:.3g}, speed {self.qd_rel_error:.3g} of the predicted response")

    def to_pandas(self) -> pandas.DataFrame:
        """The responses as a DataFrame: ``t_s``, ``q_sim_rad``, ``q_lin_rad``, ``qd_sim_rad_s``, ``qd_lin_rad_s``."""
        return require_pandas().DataFrame({"t_s": self.t, "q_sim_rad": self.q_sim, "q_lin_rad": self.q_lin,
                                           "qd_sim_rad_s": self.qd_sim, "qd_lin_rad_s": self.qd_lin})

    def plot(self) -> Figure:
        """Angle and speed deviations, simulated (solid) and linear (dashed); returns the Figure."""
        fig: Figure
        fig, ax = new(2, 1, sharex=True, figsize=(7, 5))
        for a, sim, lin, name in ((ax[0], self.q_sim, self.q_lin, "crank angle deviation δq [rad]"),
                                  (ax[1], self.qd_sim, self.qd_lin, "crank speed deviation δq̇ [rad/s]")):
            a.plot(self.t, sim, label=f"simulated ({self.backend})")
            a.plot(self.t, lin, "--", label="linear closed loop")
            a.set_ylabel(name)
            a.grid(True, alpha=0.3)
        ax[0].legend(fontsize=8)
        ax[1].set_xlabel("time t [s]")
        return fig


def step_check(target: Target, mode: str | None = None, *, q: float | None = None, qd: float = 0.0,
               I: float | None = None, t: float = 0.0, dq: float = 0.0, dqd: float = 0.0,
               t_step: float | str = 0.05, t_end: float | str = 0.3, backend: str = "multibody",
               dt: float | str | None = None, options: Mapping[str, Mapping[str, Any]] | None = None) -> StepCheck:
    """Start the machine at an operating point held by its controller, step the set-points, and
    compare the response with the linear closed loop's (:func:`mjbench.linear.step_check`).

    The controller keeps its gains; its reference becomes a constant speed ``qd`` from the angle
    that holds the point (:func:`hold_point`'s offset), with steps ``dq`` [rad] and ``dqd``
    [rad/s] at ``t_step``.  A point the machine can stay at is needed for a clean comparison: at
    rest against gravity, or a machine whose running point is steady (a linkage running at
    constant speed has none: its speed fluctuates with the angle).

    Parameters
    ----------
    target : Scenario, str, path, dict or Machine
    mode : str, optional
    q, qd, I, t : float
        The operating point: input angle [rad] (default: the initial angle), input speed
        [rad/s], current [A] (default: the one that holds q̈ = 0 / sustains the speed), time of the
        gains [s].
    dq, dqd : float
        Steps of the angle [rad] and the speed [rad/s] set-points (input side).
    t_step, t_end : float or str
        When the steps are applied and how long the run is [s].
    backend : {"multibody", "reduced"}
        The nonlinear machine simulated (the linear model: MuJoCo's or the reduced one).
    dt, options
        Co-step [s] and a machine's backend options (as for :func:`mjbench.simulate`).

    Returns
    -------
    StepCheck
        ``t``, ``q_sim``, ``q_lin``, ``qd_sim``, ``qd_lin``, ``q_rel_error``, ``qd_rel_error``,
        ``summary()``, ``to_pandas()``, ``plot()``.
    """

    if backend not in ("multibody", "reduced"):
        raise ParameterError(f"step_check: backend = {backend!r}: choose multibody or reduced")
    if not (dq or dqd):
        raise ParameterError("step_check: give a step dq [rad] and/or dqd [rad/s]")
    ts, te = seconds(t_step, "t_step", allow_zero=True), seconds(t_end, "t_end")
    if not ts < te:
        raise ParameterError(f"step_check: t_step = {ts:g} s must come before t_end = {te:g} s")
    machine, h, opts = _machine(target, mode, dt, options)
    q = float(machine.q0) if q is None else float(q)
    for name, v in (("q", q), ("qd", qd), ("t", t), ("dq", dq), ("dqd", dqd)):
        if not math.isfinite(float(v)):
            raise ParameterError(f"step_check: {name} = {v!r} must be finite")
    op = LN.operating_point(machine, q, float(qd), I, float(t))
    _hold_offset(machine, op)  # a controller that cannot hold a point: one message before simulating
    r = LN.step_check(machine, op, h, dq=float(dq), dqd=float(dqd), t_step=ts, t_end=te, backend=backend,
                      options=opts["multibody"] if backend == "multibody" else None)
    return StepCheck(np.asarray(r["t"]), np.asarray(r["q_sim"]), np.asarray(r["q_lin"]), np.asarray(r["qd_sim"]),
                     np.asarray(r["qd_lin"]), float(r["q_rel_error"]), float(r["qd_rel_error"]), op, backend)
