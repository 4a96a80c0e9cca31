"""Results of simulations: arrays with SI names, metrics, ``to_pandas()``, ``plot()`` and
``save(dir)`` (exactly the files ``mjbench run`` writes).  Modelled on python-control's
``TimeResponseData`` (``.time``, ``.outputs``, ``.to_pandas()``, ``.plot()``)."""
from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ParameterError
from ..plotstyle import backend_style, finish, new
from ..plausibility import warnings_of
from ..runner import summary_text
from .. import runner
from ..outputs import staged_dir, write_json
from ..trajectory import NAMES as COLUMN_NAMES
from ..trajectory import column_label

if TYPE_CHECKING:
    import pandas
    from matplotlib.figure import Figure

    from ..machine import Machine
    from ..trajectory import Trajectory
    from .scenarios import Scenario

#: columns :meth:`Result.plot` draws by default
PLOT_COLUMNS = ("motor_speed_rad_s", "voltage_V", "current_A")
#: the recorded columns that are the machine's inputs (:attr:`Run.inputs`)
INPUT_COLUMNS = ("voltage_V",)



def require_pandas() -> Any:
    """The pandas module, or an ImportError saying how to install it (pandas is optional)."""
    try:
        import pandas
    except ImportError as e:
        raise ImportError("to_pandas() needs pandas, an optional dependency of mjbench: pip install pandas "
                          "(or pip install 'mjbench[pandas]')") from e
    return pandas


class Run:
    """The record of one simulation on one backend.

    Attributes
    ----------
    backend : str
        ``"multibody"`` (MuJoCo) or ``"reduced"`` (the J(α) model).
    columns : tuple of str
        Column names with their SI unit: ``t_s``, ``crank_angle_rad``, ``crank_speed_rad_s``,
        ``crank_accel_rad_s2``, ``motor_speed_rad_s``, ``current_A``, ``voltage_V``,
        ``torque_crank_Nm``, ``power_mech_W``, ``power_elec_W``, ``closure_error_m``, then any
        machine-specific ones (a platform's ``deflection_rad``, a drive train's columns).
    data : numpy.ndarray, shape (n, len(columns))
        One row per recorded sample (every ``simulation.record_dt``).
    metrics : dict
        This backend's metrics (``metrics.json`` ``backends[backend]``).
    meta : dict
        How it ran: co-step ``dt`` [s], ``record_dt`` [s], the loop (compiled or CPython) and why.
    """

    def __init__(self, trajectory: Trajectory, metrics: dict[str, Any] | None = None) -> None:
        self.trajectory = trajectory
        self.backend = str(trajectory.backend)
        self.metrics = dict(metrics or {})

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(self.trajectory.columns)

    @property
    def data(self) -> np.ndarray:
        return np.asarray(self.trajectory.data[: self.trajectory.n])

    @property
    def meta(self) -> dict[str, Any]:
        return dict(self.trajectory.meta)

    @property
    def time(self) -> np.ndarray:
        """Sample times [s], shape (n,)."""
        return self["t_s"]

    @property
    def outputs(self) -> np.ndarray:
        """Every column but the time, shape (len(columns) - 1, n) (python-control's layout)."""
        return np.asarray(self.data[:, 1:].T)

    @property
    def output_labels(self) -> list[str]:
        """Names of the rows of :attr:`outputs`."""
        return list(self.columns[1:])

    @property
    def input_labels(self) -> list[str]:
        """Names of the rows of :attr:`inputs`: ``["voltage_V"]``, the armature voltage the
        amplifier applied (after the limiter), for a DC motor; ``[]`` for an ideal torque or speed
        source, whose command is not a recorded column."""
        return [c for c in INPUT_COLUMNS if c in self.columns and not np.all(np.isnan(self[c]))]

    @property
    def inputs(self) -> np.ndarray:
        """The machine's input signals, shape (len(input_labels), n) (python-control's layout)."""
        return self._rows(self.input_labels)

    @property
    def state_labels(self) -> list[str]:
        """Names of the rows of :attr:`states`: the mechanism's coordinate and rate
        (``crank_angle_rad``, ``crank_speed_rad_s``), its internal coordinates and rates when it has
        any (a platform's ``deflection_rad``, ``deflection_rate_rad_s``), and the DC motor's armature
        current ``current_A`` (not for an ideal drive, which has no electrical state).  A
        controller's own state is not recorded."""
        cols = list(self.columns)
        core = set(COLUMN_NAMES)
        internal = [c for c in cols[len(COLUMN_NAMES):] if c not in core and not c.startswith("joint_")
                    and (c.endswith("_rate_rad_s") and c[:-len("_rate_rad_s")] + "_rad" in cols
                         or c.endswith("_rad") and c[:-len("_rad")] + "_rate_rad_s" in cols)]
        out = ["crank_angle_rad", "crank_speed_rad_s"] + internal
        if "current_A" in cols and not np.all(np.isnan(self["current_A"])):
            out.append("current_A")
        return out

    @property
    def states(self) -> np.ndarray:
        """The machine's recorded states, shape (len(state_labels), n) (python-control's layout)."""
        return self._rows(self.state_labels)

    def _rows(self, labels: list[str]) -> np.ndarray:
        if not labels:
            return np.empty((0, len(self)))
        return np.vstack([self[c] for c in labels])

    def __getitem__(self, name: str) -> np.ndarray:
        """Column ``name`` (e.g. ``"crank_speed_rad_s"``), shape (n,); KeyError lists the columns."""
        return np.asarray(self.trajectory[name])

    def __len__(self) -> int:
        return int(self.trajectory.n)

    def __repr__(self) -> str:
        return f"<mjbench.Run {self.backend}: {len(self)} samples × {len(self.columns)} columns>"

    def to_pandas(self) -> pandas.DataFrame:
        """The samples as a DataFrame: one row per recorded sample, the SI column names."""
        pd = require_pandas()
        return pd.DataFrame(self.data, columns=list(self.columns))

    def plot(self, columns: Sequence[str] = PLOT_COLUMNS) -> Figure:
        """One panel per column against time, labelled with its quantity and unit; returns the
        matplotlib Figure (:class:`mjbench.plotstyle.Figure`: not pyplot's, so a notebook shows it
        once and the user's matplotlib backend is left alone; ``fig.savefig(path)`` saves it).
        Several motors: a one-axis name draws every axis's column in its panel."""
        return plot_runs([self], columns)


class Result:
    """One simulation of a machine, on one backend or both.

    Made by :func:`mjbench.simulate` (or :meth:`Scenario.simulate`).

    Attributes
    ----------
    runs : dict of str to Run
        ``{"multibody": Run, "reduced": Run}`` (the backends that ran, in that order).
    metrics : dict
        What ``metrics.json`` holds: per backend (``metrics["backends"]["multibody"]``) χ, mean
        speeds, peaks, energies ...; ``multibody_vs_reduced`` and ``plausibility`` when both ran;
        the paper's figures with their verdicts (``paper``).
    mode : str or None
        The scenario mode that ran (None for a machine built in code).
    backend : str
        What was asked: ``"multibody"``, ``"reduced"`` or ``"both"``.
    scenario : Scenario or None
        The scenario it ran (None for a machine built in code).
    """

    def __init__(self, runs: dict[str, Run], metrics: dict[str, Any], backend: str, mode: str | None = None,
                 scenario: Scenario | None = None, machine: Machine | None = None) -> None:
        self.runs = runs
        self.metrics = metrics
        self.backend = backend
        self.mode = mode
        self.scenario = scenario
        self.machine = machine

    @property
    def backends(self) -> tuple[str, ...]:
        """The backends that ran."""
        return tuple(self.runs)

    @property
    def primary(self) -> Run:
        """The multibody run when it ran, else the reduced one."""
        return self.runs.get("multibody") or next(iter(self.runs.values()))

    @property
    def time(self) -> np.ndarray:
        """Sample times [s] of :attr:`primary`, shape (n,) (both backends record the same times)."""
        return self.primary.time

    # python-control's TimeResponseData names, of the primary run (the multibody one when it ran)
    outputs = property(lambda self: self.primary.outputs, doc="outputs of :attr:`primary`, shape (ncols - 1, n)")
    output_labels = property(lambda self: self.primary.output_labels, doc="names of the rows of outputs")
    inputs = property(lambda self: self.primary.inputs, doc="inputs of :attr:`primary` (:attr:`Run.inputs`)")
    input_labels = property(lambda self: self.primary.input_labels, doc="names of the rows of inputs")
    states = property(lambda self: self.primary.states, doc="states of :attr:`primary` (:attr:`Run.states`)")
    state_labels = property(lambda self: self.primary.state_labels, doc="names of the rows of states")

    def column(self, name: str, backend: str | None = None) -> np.ndarray:
        """Column ``name`` of ``backend`` (default :attr:`primary`), shape (n,)."""
        return self[backend][name] if backend else self.primary[name]

    def __getitem__(self, backend: str) -> Run:
        """The :class:`Run` of ``backend`` (``res["multibody"]``)."""
        try:
            return self.runs[backend]
        except KeyError:
            raise KeyError(f"no {backend!r} run in this result; backends: {', '.join(self.runs)}") from None

    @property
    def warnings(self) -> list[str]:
        """The plausibility warnings ``mjbench run`` prints (backends disagree, reduced model
        differs from MuJoCo's, step too coarse); empty when the run is plausible."""

        return list(warnings_of(self.metrics))

    def summary(self) -> str:
        """The text ``mjbench run`` prints: mean speed, χ, peaks, backend difference, verdicts.
        A machine built in code is named by what it is made of (its first line)."""

        text = str(summary_text({"scenario": self.scenario.name if self.scenario else "(machine)",
                                 "mode": self.mode, **self.metrics}))
        if self.scenario is not None:
            return text
        first, _, rest = text.partition("\n")
        return self.describe() + ("\n" + rest if rest else "")

    def describe(self) -> str:
        """One line: the scenario and mode that ran, or a machine's parts; the backends and the
        simulated time."""
        t_end = float(self.primary.time[-1]) if len(self.primary) else 0.0
        runs = f"{', '.join(self.runs)}, {t_end:.6g} s"
        if self.scenario is not None:
            return f"scenario {self.scenario.name}, mode {self.mode} ({runs})"
        return f"{machine_label(self.machine)} ({runs})"

    def __repr__(self) -> str:
        name = f"{self.scenario.name} mode={self.mode}" if self.scenario else machine_label(self.machine)
        return f"<mjbench.Result {name} backends={list(self.runs)} samples={len(self.primary)}>"

    def to_pandas(self) -> pandas.DataFrame:
        """Every backend's samples in one DataFrame: a ``backend`` column, then the SI columns;
        one row per recorded sample and backend (``df[df.backend == "multibody"]``)."""
        pd = require_pandas()
        frames = []
        for b, run in self.runs.items():
            df = run.to_pandas()
            df.insert(0, "backend", b)
            frames.append(df)
        return pd.concat(frames, ignore_index=True)

    def plot(self, columns: Sequence[str] = PLOT_COLUMNS) -> Figure:
        """One panel per column against time, every backend drawn (multibody solid, reduced
        dashed), labelled with its quantity and unit; returns the matplotlib Figure
        (:class:`mjbench.plotstyle.Figure`: shown once in a notebook, the backend left alone).
        A machine with several motors: a one-axis name (``"current_A"``) draws every axis's
        column (``A:current_A``, ``E:current_A``) in its panel, an axis's own name
        (``"A:current_A"``) that axis only."""
        return plot_runs(list(self.runs.values()), columns,
                         title=f"{self.scenario.name} — {self.mode}" if self.scenario else machine_label(self.machine))

    def save(self, path: str | os.PathLike[str], *, force: bool = False, figure: bool = True,
             argv: Sequence[str] | None = None, what: str = "save") -> Path:
        """Write the files ``mjbench run`` writes into the folder ``path``.

        ``trajectory.csv`` (or ``trajectory_multibody.csv`` and ``trajectory_reduced.csv``),
        ``metrics.json``, ``manifest.json`` (its ``command``: ``argv``, default ``sys.argv``),
        ``fig4.png`` (``figure=False``: none) and a copy of the model file of an ``mjcf``
        mechanism.  The folder is written whole or not at all; a non-empty folder is replaced
        only with ``force=True`` (docs/outputs.md); ``what`` names the folder in error messages
        (the CLI: ``--out``).  A machine built in code has no scenario: its folder holds the
        trajectories and metrics.json only.

        Returns
        -------
        pathlib.Path
            The folder.

        Raises
        ------
        mjbench.outputs.OutputError
            The folder cannot be used or written (the message names it).
        """

        with staged_dir(path, force=force, what=what) as tmp:
            if self.scenario is not None and self.mode is not None:
                runner.write_run(self.scenario.spec, tmp, self.mode, self.backend,
                                 {b: r.trajectory for b, r in self.runs.items()}, self.metrics,
                                 argv=None if argv is None else list(argv), figure=figure)
            else:
                for b, r in self.runs.items():
                    r.trajectory.write_csv(Path(tmp) / ("trajectory.csv" if len(self.runs) == 1
                                                        else f"trajectory_{b}.csv"))
                write_json(Path(tmp) / "metrics.json", self.metrics)
        return Path(os.path.abspath(os.fspath(path)))


#: how :func:`machine_label` names the drive types
DRIVE_NAMES = {"dcmotor": "DC motor", "torque": "ideal torque source", "speed": "ideal speed source"}


def machine_label(machine: Machine | None) -> str:
    """What a machine built in code is: "machine built in code: fourbar mechanism, DC motor
    (z = 1, v_max 48 V), pid controller"."""
    if machine is None:
        return "machine built in code"
    mech = getattr(machine.mechanism, "type_name", type(machine.mechanism).__name__)
    drives = [_drive_label(d) for d in machine.drives]
    ctrls = sorted({str(getattr(c, "type_name", None) or type(c).__name__) for c, _ in machine.controllers})
    if len(drives) == 1:
        return f"machine built in code: {mech} mechanism, {drives[0]}, {ctrls[0]} controller"
    axes = "; ".join(f"{lab}: {d}" for lab, d in zip(machine.axis_labels, drives))
    return (f"machine built in code: {mech} mechanism, {len(drives)} axes ({axes}), "
            f"{' / '.join(ctrls)} controller{'s' if len(machine.controllers) > 1 else ''}")


def _drive_label(d: Any) -> str:
    """"DC motor (z = 1, v_max 48 V)"."""
    parts = [f"z = {float(getattr(d, 'z', 1.0)):g}"]
    vmax = float(getattr(d, "v_max", float("inf")))
    if np.isfinite(vmax):
        parts.append(f"v_max {vmax:g} V")
    kind = str(getattr(d, "type_name", "") or "dcmotor")
    return f"{DRIVE_NAMES.get(kind, kind + ' drive')} ({', '.join(parts)})"


def plot_runs(runs: Sequence[Run], columns: Sequence[str], title: str = "") -> Figure:
    """Panels of ``columns`` against time for every run (the backends' line styles)."""

    if isinstance(columns, str):
        columns = [columns]
    labels = runs[0].trajectory.axes  # several motors: the axes' labels
    panels = []
    for c in columns:
        if c in runs[0].columns:
            panels.append((c, [c]))
        elif labels and all(f"{lab}:{c}" in runs[0].columns for lab in labels):
            panels.append((c, [f"{lab}:{c}" for lab in labels]))
        else:
            raise ParameterError(f"plot: {c!r} is not a column; columns: {', '.join(runs[0].columns)}")
    fig, axes = new(len(columns), 1, sharex=True, figsize=(7, 1.0 + 2.0 * len(columns)), squeeze=False)
    for ax, (c, cols) in zip(axes[:, 0], panels):
        for r in runs:
            style = backend_style(r.backend, len(cols) > 1)
            for k, col in enumerate(cols):
                kw = dict(style)
                if len(cols) > 1:  # one colour per axis, the backend's line style
                    kw.update(color=f"C{k}", label=f"{col.split(':', 1)[0]}: {style.get('label', r.backend)}")
                ax.plot(r.time, r[col], **kw)
        ax.set_ylabel(column_label(c))
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel(column_label("t_s"))
    out: Figure = finish(fig, title)
    return out
