"""Design loops from Python: parameter sweeps (:func:`parameter_sweep`) and gain tuning
(:func:`tune_gains`), searched on the batched reduced model and verified on MuJoCo."""
from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import MjbenchError, ParameterError
from .results import require_pandas
from .scenarios import Scenario, as_scenario, source_name
from .simulation import seconds
from .. import sweep as SW
from .. import tune as T
from .. import plots as P
from ..plotstyle import new
from ..tune import Problem
from ..tune import constraint_status
from ..tune import report
from ..outputs import staged_dir, write_json

if TYPE_CHECKING:
    import pandas


# ====================================================================== sweeps
@dataclass
class SweepResult:
    """A sweep's table: one row per simulation.

    Attributes
    ----------
    rows : list of dict
        ``row``, the swept keys, ``status`` (``ok``, ``diverged``, ``error``), the metrics of
        :func:`mjbench.metrics.summary` (SI names) and ``message`` — ``results.csv``.
    keys : list of str
        The swept keys (grid first, then perturbed).
    ran : int
        Rows simulated by this call (the others were resumed from ``out``).
    verified : list of dict
        The best rows re-run on the multibody backend (``verify.csv``): the metric on both
        backends and their difference.
    notes : list of str
        Warnings (e.g. no row has the metric).
    out : pathlib.Path or None
        The sweep's folder (None: a temporary folder, removed).
    plots : list of str
        Summary figures written into ``out``.
    """

    rows: list[dict[str, Any]]
    keys: list[str]
    ran: int
    verified: list[dict[str, Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    out: Path | None = None
    plots: list[str] = field(default_factory=list)

    @property
    def table(self) -> Path | None:
        """Path of ``results.csv`` (None without ``out``)."""
        return None if self.out is None else self.out / "results.csv"

    def to_pandas(self) -> pandas.DataFrame:
        """The table as a DataFrame (one row per simulation)."""
        return require_pandas().DataFrame(self.rows)


def parameter_sweep(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any], grid: Mapping[str, Any] | None = None, *,
                    samples: int = 0, perturb: Mapping[str, float | str] | None = None, seed: int = 0,
                    mode: str | None = None, t_end: float | str | None = None, overrides: Iterable[str] = (),
                    backend: str = "reduced", verify: int = 3, metric: str | None = None,
                    out: str | os.PathLike[str] | None = None, chunk: int | None = None, threads: int = 0,
                    scheduler: str | None = None, progress: bool = False) -> SweepResult:
    """Simulate a scenario for every combination of grid values and/or Monte Carlo draws.

    Parameters
    ----------
    scenario : Scenario, str, path or dict
        A built-in name, a TOML file, or a :class:`Scenario` (its overrides are applied to every
        row).  A scenario with no file behind it (made from a dict) is written into the sweep's
        folder as ``scenario.toml`` (:meth:`Scenario.to_toml`), the file the rows re-load (and a
        Dask cluster is sent).
    grid : mapping of str to sequence or str
        Dotted key (or alias) → values (``{"drive.R": [1.5, 2.0, 2.5]}``; units allowed as
        strings), or the CLI's text (``"1.5,2,2.5"``, ``"1:3:5"`` = 5 values from 1 to 3).
    samples : int
        Monte Carlo draws per grid point of the ``perturb`` keys.
    perturb : mapping of str to float or str
        Key → relative half-width (0.05 or ``"5%"``): value × (1 + r·u), u uniform in [−1, 1].
    seed : int
        Seed of the draws.
    mode, t_end
        The mode and run length [s] of every row (default: the scenario's).
    overrides : iterable of str
        ``key=value`` items applied to every row.
    backend : {"reduced", "multibody"}
        The batch the rows run on; with ``reduced`` the ``verify`` best rows by ``metric`` are
        re-run on the multibody backend.
    metric : str, optional
        Metric of the verification and the plots (default ``chi_window``, else
        ``chi_last_cycle``).
    out : str or path, optional
        The sweep's folder (``results.csv``, ``sweep.json``, ``verify.csv``, plots), resumable:
        the same call again skips the finished rows.  None: a temporary folder, no plots.
    chunk, threads, scheduler, progress
        Rows per batch, MuJoCo threads, a Dask scheduler address (``tcp://host:port``,
        ``pip install 'mjbench[dask]'``), a progress bar.

    Returns
    -------
    SweepResult
    """

    if isinstance(scenario, Mapping):
        scenario = as_scenario(scenario)
    written: Scenario | None = None
    if isinstance(scenario, Scenario):
        name, base = source_name(scenario), scenario.overrides
        if name is None:  # a scenario with no file behind it (a dict): the sweep writes its TOML
            written, base = scenario, []
    else:
        name, base = os.fspath(scenario), []
    if scheduler:
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise ParameterError("scheduler: a Dask scheduler needs Dask: pip install 'mjbench[dask]'") from None
        SW.check_scheduler(scheduler)
    def make_spec(name: str) -> Any:
        return SW.SweepSpec(scenario=name, grid=_grid(grid or {}), samples=int(samples),
                            perturb=_perturb(perturb or {}), seed=int(seed), mode=mode,
                            t_end=None if t_end is None else seconds(t_end, "t_end"),
                            overrides=[*base, *([overrides] if isinstance(overrides, str) else overrides)],
                            chunk_size=chunk, backend=backend, verify=int(verify))

    spec = make_spec(name or "")
    if not spec.grid and not spec.samples:
        raise ParameterError("parameter_sweep: give a grid {key: values} or samples with perturb {key: r}")
    with _folder(out) as folder:
        made = None
        if written is not None:
            made, path = _scenario_file(written, folder)
            spec = make_spec(path)
        try:
            res = SW.run_sweep(spec, folder, scheduler=scheduler, nthread=threads, progress=progress,
                               plots=out is not None, metric=metric)
        except BaseException:
            if made and not os.path.exists(os.path.join(folder, SW.RESULTS)):  # nothing saved: no folder left
                with contextlib.suppress(OSError):
                    os.unlink(os.path.join(folder, SCENARIO_FILE))
                    os.rmdir(folder)
            raise
        rows = SW.read_table(res["table"])
    return SweepResult(rows, spec.keys(), int(res["ran"]), list(res.get("verified") or []), list(res.get("notes") or []),
                       None if out is None else Path(os.path.abspath(os.fspath(out))), list(res.get("plots") or []))


#: the file a sweep of a scenario without a file (a dict) writes into its folder and re-reads
SCENARIO_FILE = "scenario.toml"


def _scenario_file(scn: Scenario, folder: str) -> tuple[bool, str]:
    """Write ``scn`` as ``folder/scenario.toml`` (:meth:`Scenario.to_toml`), the file the sweep's
    rows re-load; a folder that holds another scenario's file is refused.  → (folder made, path)."""
    made = not os.path.isdir(folder)
    path = os.path.abspath(os.path.join(folder, SCENARIO_FILE))
    text = scn.to_toml()
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            if f.read() != text:
                raise ParameterError(f"{folder} holds a sweep of another scenario ({SCENARIO_FILE} differs); use another "
                                     f"out folder or delete it")
        return made, path
    os.makedirs(folder, exist_ok=True)
    scn.to_toml(path)
    return made, path


@contextlib.contextmanager
def _folder(out: str | os.PathLike[str] | None) -> Any:
    if out is not None:
        yield os.fspath(out)
        return
    with tempfile.TemporaryDirectory(prefix="mjbench-sweep-") as tmp:
        yield os.path.join(tmp, "sweep")


def _grid(grid: Mapping[str, Any]) -> dict[str, list[Any]]:
    """{key: values} with the CLI's checks (text values parsed as ``--grid``)."""

    out: dict[str, list[Any]] = {}
    if not isinstance(grid, Mapping):
        raise ParameterError(f"grid = {grid!r}: expected a mapping {{key: [values]}}, e.g. {{'drive.R': [1.5, 2.0]}}")
    for key, vals in grid.items():
        if not isinstance(key, str):
            raise ParameterError(f"grid key {key!r}: expected a dotted scenario key (str), e.g. 'drive.R'")
        if isinstance(vals, str):
            out.update(SW.parse_grid([f"{key}={vals}"]))
            continue
        if isinstance(vals, Mapping) or not hasattr(vals, "__iter__"):
            raise ParameterError(f"grid[{key!r}] = {vals!r}: expected a list of values, e.g. [{vals!r}] for one "
                                 f"value, or the CLI's text '1.5,2,2.5'")
        vals = list(vals.tolist() if hasattr(vals, "tolist") else vals)
        if not vals:
            raise ParameterError(f"grid[{key!r}]: no values")
        for i, v in enumerate(vals):
            if any(_same(v, w) for w in vals[:i]):
                raise ParameterError(f"grid[{key!r}]: the value {v!r} is repeated (each row would run twice)")
        out[key] = vals
    return out


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return float(a) == float(b)
    return bool(a == b)


def _perturb(perturb: Mapping[str, float | str]) -> dict[str, float]:

    if not isinstance(perturb, Mapping):
        raise ParameterError(f"perturb = {perturb!r}: expected a mapping {{key: relative half-width}}, e.g. "
                             f"{{'drive.R': 0.05}}")
    for k, v in perturb.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, str)):
            raise ParameterError(f"perturb[{k!r}] = {v!r}: expected a relative half-width (0.05 or '5%')")
    return dict(SW.parse_perturb([f"{k}={v if isinstance(v, str) else repr(float(v))}" for k, v in perturb.items()]))


# ====================================================================== tuning
@dataclass
class TuneResult:
    """Tuned controller gains, verified on MuJoCo.

    Attributes
    ----------
    scenario : Scenario
    result : mjbench.tune.TuneResult
        Everything the search computed (``history``: every candidate and score).
    margin_mode : str
        ``penalty`` or ``constraint`` (how the ``margins`` were applied).
    """

    scenario: Scenario
    result: Any
    margin_mode: str = "penalty"

    @property
    def best(self) -> dict[str, float]:
        """The tuned gains {name: value}."""
        return dict(self.result.best)

    @property
    def baseline(self) -> dict[str, float]:
        """The scenario's own gains."""
        return dict(self.result.baseline)

    @property
    def validation(self) -> dict[str, Any]:
        """{"tuned": metrics, "baseline": metrics} of single multibody runs."""
        return dict(self.result.validation)

    @property
    def improvement(self) -> float:
        """Relative reduction of the objective against the scenario's gains (multibody)."""
        return float(self.result.improvement)

    @property
    def violated(self) -> list[str]:
        """The ``margins`` the tuned gains violate (one text each), empty when feasible."""

        return list(constraint_status(self.result)[0])

    @property
    def limits_exceeded(self) -> list[str]:
        """The peak-voltage/current limits the tuned gains exceed (a penalty, not a hard limit)."""

        return list(constraint_status(self.result)[1])

    @property
    def feasible(self) -> bool:
        """True when no margin is violated."""
        return not self.violated

    def report(self) -> str:
        """The text ``mjbench tune`` prints."""

        return str(report(self.result))

    def to_dict(self) -> dict[str, Any]:
        """What ``tune.json`` holds."""
        r = self.result
        return {"scenario": self.scenario.name, "controller": r.controller, "mode": r.mode,
                "objective": r.objective, "tuned": r.best, "scenario_gains": r.baseline,
                "limits": r.limits, "margins": [f"{k}{op}{v:g}" for k, op, v in r.margins],
                "margin_mode": self.margin_mode, "feasible": self.feasible, "violated": self.violated,
                "limits_exceeded": self.limits_exceeded, "validation": r.validation, "improvement": r.improvement,
                "search_backend": r.backend, "search": r.search, "verified": r.verified, "history": r.history}

    def save(self, path: str | os.PathLike[str], *, force: bool = False, what: str = "save") -> Path:
        """Write ``tune.json`` and ``tune_speed.png`` (scenario vs tuned gains, multibody) into the
        folder ``path``, whole or not at all (``mjbench tune --out``)."""

        with staged_dir(path, force=force, what=what) as out:
            write_json(os.path.join(out, "tune.json"), self.to_dict(), indent=1)
            speed_figure(self, os.path.join(out, "tune_speed.png"))
        return Path(os.path.abspath(os.fspath(path)))


def tune_gains(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any], controller: str = "pid-tv",
               objective: str = "chi", *, limits: Mapping[str, float] | None = None,
               bounds: Mapping[str, Sequence[float]] | None = None, span: float = 10.0, margins: Iterable[str] = (),
               margin_mode: str = "penalty", margin_angles: int = 12, n_global: int = 64, starts: int = 1,
               maxfev: int = 80, t_end: float | str | None = None, backend: str = "reduced", verify: int = 3,
               seed: int = 0, threads: int = 0, log: Callable[[str], Any] | None = None) -> TuneResult:
    """Tune the gains of the scenario's controller: a batched global search (Sobol), local
    Nelder–Mead refinement, then the ``verify`` best candidates re-run on MuJoCo.

    Parameters
    ----------
    scenario : Scenario, str, path or dict
    controller : str
        A controller type whose class declares its tunable gains (``Controller.TUNABLE``; plugins
        too, :func:`mjbench.tune.tunable_controllers`).  Built in: ``pid``: constant K_p;
        ``pid-tv``: K_p·t (Incerti 2012 Eq 15); ``smc``: λ, K; ``servo``: the cascade servo tracking
        a motion law (K_pp, K_vp, K_vi; its feed-forward kept).
    objective : {"chi", "chi_cycle", "ise", "iae", "itae", "tracking_rms", "tracking_peak"}
        χ on ``metrics.chi_window`` or the last crank cycle, a speed-error integral, or the RMS /
        peak crank-angle error [rad] to a motion-law reference (a law repeated per cycle too) over
        ``metrics.chi_window`` (else the whole run).
    limits : mapping, optional
        ``{"voltage": V, "current": A}`` allowed peaks (default: those of the scenario's gains);
        an excess is penalised.
    bounds : mapping, optional
        ``{gain: (lo, hi)}`` search intervals (default: the scenario's gain ×/÷ ``span``).
    margins : iterable of str
        Robustness bounds on the linear model at the worst frozen angle: ``"pm>=45"`` [deg],
        ``"gm>=6"`` [dB], ``"ms<=2"``, ``"bw>=50"`` [rad/s]; applied as a ``penalty`` or a
        ``constraint`` (``margin_mode``) over ``margin_angles`` angles.
    n_global, starts, maxfev
        Global candidates, local refinements, simulations per refinement.
    t_end : float or str, optional
        Run length per candidate [s] (default: the end of the χ window).
    backend : {"reduced", "multibody"}
        The search backend.
    verify, seed, threads
        Candidates re-run on MuJoCo, Sobol seed, MuJoCo threads.
    log : callable, optional
        Called with one line per stage (``print`` shows the progress); default: silent.

    Returns
    -------
    TuneResult
        ``best`` gains, ``validation`` metrics, ``feasible``, ``report()``, ``save(dir)``.
    """

    scn = as_scenario(scenario)
    _check_tune_args(T, controller, objective, limits, bounds, margin_mode)
    scn.check()
    res = T.tune(scn.spec, controller, objective, limits=dict(limits or {}), n_global=n_global, starts=starts,
                 maxfev=maxfev, span=span, bounds={k: tuple(v) for k, v in (bounds or {}).items()}, seed=seed,
                 t_end=None if t_end is None else seconds(t_end, "t_end"), nthread=threads,
                 log=log or (lambda *a: None), backend=backend, verify=verify, margins=list(margins),
                 margin_mode=margin_mode, margin_angles=margin_angles)
    return TuneResult(scn, res, margin_mode)


def _check_tune_args(T: Any, controller: str, objective: str, limits: Mapping[str, float] | None,
                     bounds: Mapping[str, Sequence[float]] | None, margin_mode: str) -> None:
    """Names and values :func:`tune_gains` takes (one ParameterError naming the argument)."""
    gains = T.tune_spec(controller).params  # (an unknown or untunable controller: one message)
    if objective not in T.OBJECTIVES:
        raise ParameterError(f"objective = {objective!r}: choose one of {', '.join(T.OBJECTIVES)}")
    if margin_mode not in ("penalty", "constraint"):
        raise ParameterError(f"margin_mode = {margin_mode!r}: choose penalty or constraint")
    for k, v in (limits or {}).items():
        if k not in ("voltage", "current") or not float(v) > 0:
            raise ParameterError(f"limits[{k!r}] = {v!r}: give voltage [V] and/or current [A], each > 0")
    for k in bounds or {}:
        if k not in gains:
            raise ParameterError(f"bounds[{k!r}]: not a gain of the {controller} controller; its gains are "
                                 f"{', '.join(gains)}")


def speed_figure(res: TuneResult, path: str) -> None:
    """Motor speed, voltage and current of the scenario's and the tuned gains (multibody)."""
    import numpy as np


    r = res.result
    prob = Problem(res.scenario.spec, r.controller, r.objective, r.limits)  # (no margins: only the runs are drawn)
    fig, axes = new(3, 1, figsize=(7, 8), sharex=True)
    for label, gains, st in (("scenario controller", r.baseline, dict(color="tab:gray")),
                             (f"tuned {r.controller}", r.best, dict(color="tab:blue"))):
        try:
            _, tr = prob.validate(np.array([gains[p] for p in prob.params]), baseline=gains is r.baseline)
        except MjbenchError:  # (a diverging closest candidate: drawn without it)
            continue
        axes[0].plot(tr.t, tr.omega, label=label, **st)
        axes[1].plot(tr.t, tr.voltage, **st)
        axes[2].plot(tr.t, tr.current, **st)
    if prob.window:
        for ax in axes:
            ax.axvspan(*prob.window, color="tab:orange", alpha=0.12)
    axes[0].set_ylabel("motor speed φ̇ [rad/s]")
    axes[1].set_ylabel("armature voltage V_a [V]")
    axes[2].set_ylabel("armature current I [A]")
    axes[2].set_xlabel("time t [s]")
    axes[0].legend()
    axes[0].set_title(f"{r.controller}: {r.objective} {r.validation['baseline']['objective']:.4g} → "
                      f"{r.validation['tuned']['objective']:.4g}")
    P.save(fig, path)
