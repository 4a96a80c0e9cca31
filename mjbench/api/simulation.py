"""Simulating from Python: one machine (:func:`simulate`) or many at once (:func:`simulate_many`),
on the multibody backend (MuJoCo), the reduced J(α) model, or both."""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import ParameterError
from ..control import FunctionController
from ..machine import Machine
from .results import Result, Run
from .scenarios import Scenario, as_scenario, warn
from .. import units as U
from .. import runner
from ..preflight import simulation_errors
from ..errors import ScenarioError
from ..schema import MultibodyOptions, ReducedOptions, format_errors
from ..backends import simulate as run_backend
from ..backends import simulate_many as run_many

#: co-step [s] and record interval [s] of a machine built in code (a scenario's defaults)
MACHINE_DT, MACHINE_RECORD_DT = 1e-4, 1e-3


def seconds(value: float | str, name: str, allow_zero: bool = False) -> float:
    """A time argument [s]: a number (SI) or a string with a unit ("500 ms"), finite and > 0."""

    try:
        x = float(value) if not isinstance(value, str) else _to_seconds(value)
    except (TypeError, ValueError, U.UnitError) as e:
        raise ParameterError(f"{name} = {value!r}: not a time ({e})") from None
    if not (math.isfinite(x) and (x >= 0 if allow_zero else x > 0)):
        raise ParameterError(f"{name} = {value!r}: must be a finite time {'>=' if allow_zero else '>'} 0 [s]")
    return x


def _to_seconds(text: str) -> float:

    try:
        return float(text)
    except ValueError:
        return float(U.to_si(text, "time"))


def simulate(target: Scenario | Machine | str | Any, mode: str | None = None, backend: str | None = None,
             t_end: float | str | None = None, *, record_dt: float | str | None = None,
             dt: float | str | None = None, progress: bool = False, check: bool = True,
             options: Mapping[str, Mapping[str, Any]] | None = None, controller: Any = None) -> Result:
    """Simulate a scenario (or a machine built in code) on one backend or both.

    Parameters
    ----------
    target : Scenario, str, dict or Machine
        A :class:`Scenario` (a name, path or dict is loaded first), or a :class:`Machine`.
    mode : str, optional
        The scenario's ``[modes.NAME]`` to run (default: ``simulation.mode``).
    backend : {"multibody", "reduced", "both"}, optional
        Default: the scenario's ``simulation.backend`` (a machine: ``"both"``).
    t_end : float or str, optional
        Simulated time [s] (``"500 ms"`` accepted); default ``simulation.t_end`` (required for a
        machine).
    record_dt, dt : float or str, optional
        Record interval and co-simulation step [s]; for a scenario they set
        ``simulation.record_dt`` / ``simulation.dt`` (recorded in the manifest).  A machine:
        1 ms and 0.1 ms by default.
    progress : bool
        A progress bar per backend on stderr.
    check : bool
        Build the scenario's machine once first, so that a value it cannot be built with is a
        readable error (the CLI has done it already).
    options : mapping, optional
        A machine's backend options, ``{"multibody": {...}, "reduced": {...}}``: the keys of a
        scenario's ``[multibody]`` (``integrator``, ``iterations``, ``tolerance``, ``solref``,
        ``solimp``) and ``[reduced]`` tables (``model``, ``method``, ``rtol``, ``atol``); their
        defaults are a scenario's.  A scenario has its own tables (set them with :func:`load`).
    controller : callable or controller object, optional
        Replaces the mode's controller (a scenario): a plain function ``f(t, y) -> u`` of the time
        [s] and ``y``, a mapping of the trajectory's column names (``crank_speed_rad_s``,
        ``current_A`` …) and the kernel's signal names to their present values, returning the
        drive's command (volts for a DC motor), called every co-step; or a controller object
        (:func:`make_controller`); several axes: one per axis.  A function runs the CPython loop
        (``Run.meta["loop_reason"]`` says so); the manifest records it (``metrics["controller"]``).

    Returns
    -------
    Result
        ``result["multibody"].time`` [s] shape (n,), ``result["multibody"]["crank_speed_rad_s"]``,
        ``result.metrics`` (metrics.json), ``to_pandas()``, ``plot()``, ``save(dir)``.

    Raises
    ------
    mjbench.errors.ScenarioError, ParameterError
        Bad values, mode or backend (before simulating).
    mjbench.errors.SimulationDiverged
        The run diverged (the message gives the time and state).

    Warns
    -----
    MjbenchWarning
        The backends disagree, the reduced model differs from MuJoCo's, the step is too coarse.
    """
    if isinstance(target, Machine):
        if mode is not None:
            raise ParameterError("simulate: mode is a scenario's; a Machine already holds its controller")
        if t_end is None:
            raise ParameterError("simulate: a Machine needs t_end [s] (a scenario has its own)")
        h = seconds(dt if dt is not None else MACHINE_DT, "dt")
        return _simulate_machine(target, backend or "both", seconds(t_end, "t_end"),
                                 seconds(record_dt if record_dt is not None else MACHINE_RECORD_DT, "record_dt"),
                                 h, progress, machine_options(h, options))
    if options is not None:
        raise ParameterError("simulate: options are a machine's; a scenario has its [multibody] and [reduced] tables")

    scn = _with_times(as_scenario(target), record_dt, dt)
    mode = scn.mode(mode)
    backend = backend or scn.default_backend
    runner.backends_of(backend)  # a bad choice: one message before anything runs
    t = scn.t_end if t_end is None else seconds(t_end, "t_end")
    if check:
        scn.check(mode)
    machine = None if controller is None else with_controller(scn.machine(mode), controller)
    with simulation_errors(scn.spec):
        trajs, metrics = runner.simulate_mode(scn.spec, mode, backend, t, progress, machine=machine)
    if machine is not None:  # what ran instead of the mode's controller (metrics.json, the manifest)
        metrics["controller"] = [c.describe() for c, _ in machine.controllers]
    res = Result({b: Run(tr, metrics["backends"].get(b)) for b, tr in trajs.items()}, metrics, backend, mode, scn)
    warn(res.warnings)
    return res


def with_controller(machine: Machine, controller: Any) -> Machine:
    """``machine`` with its controller replaced by ``controller`` (:func:`simulate`): a function
    ``f(t, y) -> u`` becomes a :class:`~mjbench.control.FunctionController`; a controller object is
    used as it is; several axes take a sequence, one per axis."""
    many = isinstance(controller, (list, tuple))
    items = list(controller) if many else [controller]
    if machine.naxes > 1 and (not many or len(items) != machine.naxes):
        raise ParameterError(f"simulate: controller = {controller!r}: the machine has {machine.naxes} axes "
                             f"({', '.join(machine.axis_labels)}); give one controller per axis (a list)")
    if machine.naxes == 1 and many:
        raise ParameterError(f"simulate: controller = a list of {len(items)}: the machine has one axis; give one "
                             f"function or controller")
    built = [c if callable(getattr(c, "reset", None)) and callable(c) else FunctionController(c) for c in items]
    return dataclasses.replace(machine, controller=built if many else built[0])


def _with_times(scn: Scenario, record_dt: float | str | None, dt: float | str | None) -> Scenario:
    values = {}
    if record_dt is not None:
        values["simulation.record_dt"] = seconds(record_dt, "record_dt")
    if dt is not None:
        values["simulation.dt"] = seconds(dt, "dt")
    return scn.with_values(**values) if values else scn


def machine_options(dt: float, options: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, dict[str, Any]]:
    """Backend options of a machine built in code: a scenario's defaults (``[multibody]``,
    ``[reduced]``) with ``options`` {backend: {key: value}} validated by the same schema."""
    from pydantic import ValidationError


    given = dict(options or {})
    for b in given:
        if b not in ("multibody", "reduced"):
            raise ParameterError(f"options[{b!r}]: the backends are multibody and reduced")
    try:
        mb = MultibodyOptions.model_validate(dict(given.get("multibody") or {}))
        red = ReducedOptions.model_validate(dict(given.get("reduced") or {}))
    except ValidationError as e:
        lines = format_errors(e, ("options",))
        raise ScenarioError("invalid backend options:\n  " + "\n  ".join(lines), problems=lines) from None
    return {"multibody": mb.as_options(dt),
            "reduced": {"timestep": dt, "method": red.method, "rtol": red.rtol, "atol": red.atol, "model": red.model}}


def _simulate_machine(machine: Machine, backend: str, t_end: float, record_dt: float, dt: float,
                      progress: bool, options: dict[str, dict[str, Any]]) -> Result:

    trajs = {}
    for b in runner.backends_of(backend):
        with _bar(progress, t_end / dt, b) as bar:
            trajs[b] = run_backend(machine, b, t_end, record_dt=record_dt, options=options[b], progress=bar)
    metrics = machine_metrics(trajs, machine, options.get("multibody"))
    res = Result({b: Run(tr, metrics["backends"].get(b)) for b, tr in trajs.items()}, metrics, backend,
                 machine=machine)
    warn(res.warnings)
    return res


def machine_metrics(trajs: dict[str, Any], machine: Machine, options: dict[str, Any] | None = None) -> dict[str, Any]:
    """Metrics of runs of a machine built in code: the one metrics path of scenarios
    (:func:`mjbench.runner.run_metrics`: the controller's families and the reduced-model check
    included) with the default ``[metrics]`` settings."""

    return runner.run_metrics(machine, trajs, None, options)


class _bar:
    """A tqdm bar of ``steps`` co-steps when ``on`` (else None), closed on exit."""

    def __init__(self, on: bool, steps: float, desc: str) -> None:
        self.on, self.steps, self.desc, self.bar = on, steps, desc, None

    def __enter__(self) -> Any:
        if self.on:
            from tqdm import tqdm

            self.bar = tqdm(total=int(round(self.steps)), desc=self.desc, unit="step", unit_scale=True, leave=False,
                            mininterval=0.5)
        return self.bar

    def __exit__(self, *exc: object) -> None:
        if self.bar is not None:
            self.bar.close()


# ====================================================================== many at once
def simulate_many(targets: Sequence[Scenario | Machine | str | Any], backend: str = "reduced",
                  t_end: float | str | None = None, *, mode: str | None = None, record_dt: float | str | None = None,
                  dt: float | str | None = None, threads: int = 0, progress: bool = False) -> list[Result]:
    """Simulate many machines at once: one batch per backend, each run equal to its single run.

    Parameters
    ----------
    targets : sequence of Scenario (or name, path, dict) or of Machine
        Scenarios must share ``simulation.dt``, ``record_dt`` and the backend options (one
        batch); machines share ``dt`` and ``record_dt`` given here.
    backend : {"reduced", "multibody", "both"}
        ``reduced``: N reduced models; ``multibody``: N MuJoCo models (N independent runs of the one
        compiled loop, on threads: :mod:`mjbench.backends.batch`).
    t_end : float or str, optional
        Simulated time [s]; default the first scenario's ``simulation.t_end`` (required for
        machines).
    mode : str, optional
        The mode of every scenario (default: each scenario's).
    record_dt, dt : float or str, optional
        Machines only: record interval and co-step [s] (1 ms, 0.1 ms).
    threads : int
        MuJoCo batch threads (0: all CPUs).
    progress : bool
        A progress bar per backend.

    Returns
    -------
    list of Result
        In the order of ``targets``.  A run that diverged does not stop the others: its
        ``Result.metrics["diverged"]`` holds {backend: message} and its record ends there.
    """

    if not targets:
        raise ParameterError("simulate_many: no targets")
    backends = runner.backends_of(backend)
    if all(isinstance(t, Machine) for t in targets):
        if t_end is None:
            raise ParameterError("simulate_many: machines need t_end [s]")
        return _many_machines([t for t in targets if isinstance(t, Machine)], backends, backend, seconds(t_end, "t_end"),
                              seconds(record_dt if record_dt is not None else MACHINE_RECORD_DT, "record_dt"),
                              seconds(dt if dt is not None else MACHINE_DT, "dt"), threads, progress)
    if any(isinstance(t, Machine) for t in targets):
        raise ParameterError("simulate_many: give scenarios or machines, not both")
    if record_dt is not None or dt is not None:
        raise ParameterError("simulate_many: record_dt and dt of scenarios are their simulation.record_dt and "
                             "simulation.dt (load them with those values)")
    scns = [as_scenario(t) for t in targets]
    return _many_scenarios(scns, backends, backend, mode, t_end, threads, progress)


def _many_scenarios(scns: list[Scenario], backends: tuple, backend: str, mode: str | None,
                    t_end: float | str | None, threads: int, progress: bool) -> list[Result]:

    first = scns[0]
    t = first.t_end if t_end is None else seconds(t_end, "t_end")
    modes = [s.mode(mode) for s in scns]
    for b in backends:
        ref = (first.spec.simulation.record_dt, runner.backend_options(first.spec, b))
        for s in scns[1:]:
            if (s.spec.simulation.record_dt, runner.backend_options(s.spec, b)) != ref:
                raise ParameterError(f"simulate_many: scenario {s.name!r} has other {b} options or record_dt than "
                                     f"{first.name!r}; one batch runs with one step, record interval and options")
    for s, m in zip(scns, modes):
        s.check(m)
    runs: list[dict[str, Any]] = [{} for _ in scns]
    for b in backends:
        opts = runner.backend_options(first.spec, b)
        machines = [s.machine(m) for s, m in zip(scns, modes)]
        with simulation_errors(first.spec):
            trs = _batch(machines, b, t, first.spec.simulation.record_dt, opts, threads, progress)
        for i, tr in enumerate(trs):
            runs[i][b] = tr
    out = []
    for s, m, trajs in zip(scns, modes, runs):
        metrics = _guarded(lambda s=s, m=m, trajs=trajs: {**runner.mode_metrics(s.spec, m, trajs),
                                                           "scenario": s.name}, trajs, m)
        out.append(Result({b: Run(tr, metrics["backends"].get(b)) for b, tr in trajs.items()}, metrics, backend,
                          m, s))
    warn(w for r in out for w in r.warnings)
    return out


def _many_machines(machines: list[Machine], backends: tuple, backend: str, t_end: float, record_dt: float,
                   dt: float, threads: int, progress: bool) -> list[Result]:
    runs: list[dict[str, Any]] = [{} for _ in machines]
    for b in backends:
        opts = machine_options(dt)[b]
        for i, tr in enumerate(_batch(machines, b, t_end, record_dt, opts, threads, progress)):
            runs[i][b] = tr
    out = []
    for mach, trajs in zip(machines, runs):
        metrics = _guarded(lambda trajs=trajs, mach=mach: machine_metrics(trajs, mach, machine_options(dt)["multibody"]),
                           trajs, None)
        out.append(Result({b: Run(tr, metrics["backends"].get(b)) for b, tr in trajs.items()}, metrics, backend,
                          machine=mach))
    warn(w for r in out for w in r.warnings)
    return out


def _batch(machines: list[Machine], backend: str, t_end: float, record_dt: float, options: dict[str, Any],
           threads: int, progress: bool) -> list[Any]:
    """The trajectories of one batch on ``backend`` (each labelled with it)."""

    with _bar(progress, t_end / float(options.get("timestep", MACHINE_DT)), f"{backend} ×{len(machines)}") as bar:
        res = run_many(machines, backend, t_end, record_dt=record_dt, options=options, nthread=threads, progress=bar)
    trs: list[Any] = res.trajectories()
    for tr in trs:
        tr.backend = backend
    return trs


def _guarded(make: Any, trajs: dict[str, Any], mode: str | None) -> dict[str, Any]:
    """Metrics of a batch run; a diverged run gets ``diverged`` {backend: message} (and the
    metrics its partial record gives, when it gives any)."""
    div = {b: tr.meta["diverged"] for b, tr in trajs.items() if tr.meta.get("diverged")}
    try:
        m: dict[str, Any] = make()
    except (ValueError, ArithmeticError, IndexError) as e:
        if not div:
            raise
        m = {"mode": mode, "backends": {b: {} for b in trajs}, "note": f"no metrics: {type(e).__name__}: {e}"}
    if div:
        m["diverged"] = div
    return m
