"""Scenarios from Python: :func:`load` (a built-in name, a TOML file, a run's manifest.json or a
dict, with overrides that take units) and the :class:`Scenario` it returns."""
from __future__ import annotations

import contextlib
import json
import math
import os
import re
import warnings
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any, Union

from .. import api  # the API's face: its functions are loaded on first use (mjbench/api/__init__.py)
from ..errors import ParameterError
from .. import scenario as S
from ..outputs import OutputError
from ..scenario import parse_value
from ..preflight import check_machine

if TYPE_CHECKING:
    from ..machine import Machine
    from ..schema import Scenario as ScenarioSpec
    from .analysis import Analysis, LinearResult
    from .design_loops import SweepResult, TuneResult
    from .results import Result

#: what :func:`load` accepts as its source
Source = Union[str, "os.PathLike[str]", Mapping[str, Any], "Scenario", "ScenarioSpec"]


class MjbenchWarning(UserWarning):
    """A value or a result to look at before trusting the numbers: a value far outside its
    plausible range (a likely unit slip), the two backends disagreeing, a step too coarse.  The
    CLI prints the same text as ``mjbench: warning: ...``."""


def warn(lines: Iterable[str], stacklevel: int = 3) -> None:
    """Emit each line as a :class:`MjbenchWarning`."""
    for line in lines:
        warnings.warn(line, MjbenchWarning, stacklevel=stacklevel)


class Scenario:
    """A validated scenario: every parameter of a machine, typed, in SI units.

    Made by :func:`load`.  The validated tables are ``spec`` (a :class:`mjbench.schema.Scenario`:
    ``spec.drive.R`` [Ω], ``spec.mechanism``, ``spec.modes["pid"]`` ...); :meth:`get` reads a
    dotted key.  A scenario loaded from a run's ``manifest.json`` repeats that run: its mode,
    backend and run length are the defaults of :meth:`simulate`.
    """

    def __init__(self, spec: ScenarioSpec, defaults: Mapping[str, Any] | None = None) -> None:
        self.spec = spec
        self._defaults = dict(defaults or {})

    # ------------------------------------------------------------------ what it is
    @property
    def name(self) -> str:
        """The scenario's name (``[scenario] name``)."""
        return str(self.spec.name)

    @property
    def title(self) -> str:
        """The scenario's title (``[scenario] title``), may be empty."""
        return str(self.spec.scenario.title)

    @property
    def source(self) -> str:
        """Where it came from: ``builtin:NAME``, an absolute file path, or ``""`` for a dict."""
        return str(self.spec.source)

    @property
    def overrides(self) -> list[str]:
        """The overrides applied, as ``key=value`` text (what ``manifest.json`` records)."""
        return list(self.spec.overrides)

    @property
    def warnings(self) -> list[str]:
        """Values accepted with a warning (outside their plausible range: a likely unit slip)."""
        return list(self.spec.warnings)

    @property
    def modes(self) -> list[str]:
        """Names of the ``[modes.*]`` tables (controllers), sorted."""
        return sorted(self.spec.modes)

    @property
    def default_backend(self) -> str:
        """``multibody``, ``reduced`` or ``both``: a manifest's backend, else ``simulation.backend``."""
        return str(self._defaults.get("backend") or self.spec.simulation.backend)

    @property
    def t_end(self) -> float:
        """Default run length [s]: a manifest's, else ``simulation.t_end``."""
        t = self._defaults.get("t_end")
        return float(t if t is not None else self.spec.simulation.t_end)

    def mode(self, mode: str | None = None) -> str:
        """The mode a run uses: ``mode``, else a manifest's, else the scenario's default (checked:
        an unknown mode raises :class:`~mjbench.errors.ScenarioError` listing the modes)."""
        return str(self.spec.mode(mode or self._defaults.get("mode")))

    def get(self, key: str, default: Any = None) -> Any:
        """The validated value at a dotted key (``"drive.R"`` → 2.0 [Ω]; aliases resolved)."""
        return self.spec.get(key, default)

    def resolved(self) -> dict[str, Any]:
        """Every value, SI, defaults filled in (what ``manifest.json`` holds under ``scenario``)."""
        return dict(self.spec.resolved())

    def to_toml(self, path: str | os.PathLike[str] | None = None, *, force: bool = False) -> str:
        """The scenario as a TOML file that :func:`load` reads back as the same scenario.

        The tables as given (units kept as written) with every override applied, file paths
        (an MJCF model) absolute.  ``path`` (optional): write it there, whole or not at all; an
        existing file is replaced only with ``force=True``.  Returns the TOML text.

        The loaded file gives the same validated values (``resolved()``) and the same runs; it
        records no overrides (they are in its values) and the file as its source.
        """
        text = toml_text(self.spec.raw, header=f"scenario {self.name!r} written by mjbench (Scenario.to_toml)"
                         + (f"; overrides applied: {', '.join(self.overrides)}" if self.overrides else ""))
        if path is not None:
            write_text(path, text, force=force)
        return text

    def __repr__(self) -> str:
        extra = f", overrides={self.overrides!r}" if self.overrides else ""
        return f"<mjbench.Scenario {self.name!r} modes={self.modes}{extra}>"

    # ------------------------------------------------------------------ new scenarios, machines
    def with_values(self, overrides: Iterable[str] | str = (), /, **values: Any) -> Scenario:
        """A new scenario with more overrides (same rules as :func:`load`)."""
        return load(self, overrides, **values)

    def machine(self, mode: str | None = None) -> Machine:
        """The :class:`~mjbench.Machine` (mechanism + drive + controller) of ``mode``."""

        machine: Machine = S.make_machine(self.spec, self.mode(mode))
        return machine

    def check(self, mode: str | None = None) -> None:
        """Build the machine of ``mode`` once (milliseconds): a geometry that cannot assemble or a
        controller that cannot be built raises a readable :class:`~mjbench.errors.MjbenchError`."""

        check_machine(self.spec, self.mode(mode))

    # ------------------------------------------------------------------ runs and studies
    def simulate(self, mode: str | None = None, backend: str | None = None, t_end: float | str | None = None,
                 **kw: Any) -> Result:
        """Simulate this scenario: :func:`mjbench.simulate` (same arguments)."""
        return api.simulate(self, mode, backend, t_end, **kw)

    def sweep(self, grid: Mapping[str, Any] | None = None, **kw: Any) -> SweepResult:
        """Sweep scenario keys: :func:`mjbench.parameter_sweep` (same arguments)."""
        return api.parameter_sweep(self, grid, **kw)

    def tune(self, controller: str = "pid-tv", objective: str = "chi", **kw: Any) -> TuneResult:
        """Tune the controller's gains: :func:`mjbench.tune_gains` (same arguments)."""
        return api.tune_gains(self, controller, objective, **kw)

    def linearize(self, mode: str | None = None, **kw: Any) -> LinearResult:
        """Linear model, loop and margins: :func:`mjbench.linearize` (same arguments)."""
        return api.linearize(self, mode, **kw)

    def analyze(self, speeds: Iterable[float | str] | None = None, **kw: Any) -> Analysis:
        """Revolution analysis of the mechanism: :func:`mjbench.analyze_mechanism`."""
        return api.analyze_mechanism(self, speeds, **kw)

    def render(self, path: str | os.PathLike[str], **kw: Any) -> dict[str, Any]:
        """Video of a multibody run: :func:`mjbench.render_video` (same arguments)."""
        return api.render_video(self, path, **kw)


# ====================================================================== loading
def load(source: Source, overrides: Iterable[str] | str = (), /, **values: Any) -> Scenario:
    """Load and validate a scenario.

    Parameters
    ----------
    source : str, path, dict or Scenario
        A built-in name (:func:`list_scenarios`), a TOML file, a run's ``manifest.json`` (the
        run's mode, backend and length become the defaults), a dict of tables as TOML would give
        them (``{"scenario": {"name": ...}, "mechanism": {...}, "drive": {...}, ...}``), or a
        :class:`Scenario` to derive a new one from.
    overrides : iterable of str, positional only
        ``"key=value"`` items exactly as ``mjbench run --set`` takes them (the value is read as
        TOML, else as text: ``"drive.L=9 mH"``).
    **values
        Dotted keys (or ``[aliases]``) set to Python values: a number is SI, a string may carry a
        unit (``**{"drive.R": "2.2 ohm", "mechanism.a": "60 mm"}``), booleans and lists as in
        TOML.

    Returns
    -------
    Scenario

    Raises
    ------
    mjbench.errors.ScenarioError
        ONE error listing every problem (unknown key, wrong unit, non-physical value), each with
        its dotted path and the allowed range.

    Warns
    -----
    MjbenchWarning
        For each value outside its plausible range (a likely unit slip).
    """

    items = [overrides] if isinstance(overrides, str) else list(overrides)
    items += [f"{k}={set_text(k, v)}" for k, v in values.items()]
    defaults: dict[str, Any] = {}
    before: list[str] = []
    if isinstance(source, Scenario):
        defaults, source = dict(source._defaults), source.spec
    if isinstance(source, Mapping):
        raw, src = dict(source), ""
    elif isinstance(source, (str, os.PathLike)):
        path = os.fspath(source)
        raw, src = S.read_raw(path)
        if path.endswith(".json"):
            defaults = _manifest_defaults(path)
    elif hasattr(source, "raw") and hasattr(source, "overrides"):  # a validated mjbench.schema.Scenario
        raw, src, before = source.raw, source.source, list(source.overrides)
    else:
        raise ParameterError(f"load: source must be a scenario name, a file path, a dict of tables or a Scenario, "
                             f"not {type(source).__name__}")
    spec = S.from_raw(raw, src, items)
    if before:
        spec.overrides = before + list(spec.overrides)
    warn(spec.warnings)
    return Scenario(spec, defaults)


def _manifest_defaults(path: str) -> dict[str, Any]:
    """The run a manifest describes: its mode, backend and run length [s]."""
    with open(path, encoding="utf-8") as f:
        man = json.load(f)
    return {"mode": man.get("mode"), "backend": man.get("backend"), "t_end": man.get("t_end_s")}


def list_scenarios() -> list[str]:
    """Names of the scenarios shipped with mjbench (``mjbench list`` shows their modes)."""

    return list(S.builtin_names())


def as_scenario(target: Any) -> Scenario:
    """A :class:`Scenario` from a Scenario, a name, a path or a dict (helper of the studies)."""
    return target if isinstance(target, Scenario) else load(target)


def source_name(scn: Scenario) -> str | None:
    """What ``mjbench sweep`` would be given for this scenario: its built-in name or its file;
    None for a scenario with no file behind it (a dict: :meth:`Scenario.to_toml` writes one)."""
    src = scn.source
    if src.startswith("builtin:"):
        return src[len("builtin:"):]
    if src and os.path.isfile(src):
        return src
    return None


# ====================================================================== TOML out
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def _toml_key(k: Any) -> str:
    k = str(k)
    return k if _BARE_KEY.fullmatch(k) else json.dumps(k, ensure_ascii=False)


def _toml_value(v: Any) -> str:
    """A TOML value: scalars, arrays, and tables inline (inside arrays and deep nests)."""
    v = _plain(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # JSON string escapes are TOML basic-string escapes
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if v is None:
        raise ParameterError("to_toml: TOML has no null value (a key set to None)")
    raise ParameterError(f"to_toml: {v!r} ({type(v).__name__}) is not a TOML value")


def toml_text(doc: Mapping[str, Any], header: str = "") -> str:
    """``doc`` (nested dicts as TOML would give them) as TOML text: top-level and nested dicts as
    [tables], lists of dicts as [[arrays of tables]], anything inside those inline.  Read back by
    ``tomllib`` it is equal to ``doc``."""
    lines = [f"# {x}" for x in header.splitlines()] if header else []

    def table(path: list[str], d: Mapping[str, Any]) -> None:
        scal = [(k, v) for k, v in d.items() if not isinstance(v, Mapping) and not _table_list(v)]
        subs = [(k, v) for k, v in d.items() if isinstance(v, Mapping)]
        arrs = [(k, v) for k, v in d.items() if _table_list(v)]
        if path and (scal or not (subs or arrs)):
            lines.extend(["", f"[{'.'.join(_toml_key(p) for p in path)}]"])
        lines.extend(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in scal)
        for k, v in subs:
            table(path + [str(k)], v)
        for k, v in arrs:
            for item in v:
                lines.extend(["", f"[[{'.'.join(_toml_key(p) for p in path + [str(k)])}]]"])
                lines.extend(f"{_toml_key(kk)} = {_toml_value(vv)}" for kk, vv in item.items())

    scal = [k for k, v in doc.items() if not isinstance(v, Mapping) and not _table_list(v)]
    if scal:
        raise ParameterError(f"to_toml: a scenario is made of tables; {', '.join(scal)} are not")
    table([], doc)
    return "\n".join(lines).lstrip("\n") + "\n"


def _table_list(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, Mapping) for x in v)


def write_text(path: str | os.PathLike[str], text: str, force: bool = False) -> None:
    """Write a text file whole (a temporary file renamed over it); refuse to replace one unless
    ``force``."""

    p = os.fspath(path)
    if os.path.isdir(p):
        raise OutputError(f"{p} is a folder; give a file name (e.g. scenario.toml)")
    if os.path.exists(p) and not force:
        raise OutputError(f"{p} exists; pass force=True to replace it")
    d = os.path.dirname(os.path.abspath(p))
    if not os.path.isdir(d):
        raise OutputError(f"{p}: the folder {d} does not exist")
    tmp = f"{p}.tmp-{os.getpid()}"
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, p)
    except OSError as e:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise OutputError(f"{p}: cannot write ({e.strerror or e})") from None


# ====================================================================== values as --set text
def set_text(key: str, value: Any) -> str:
    """``value`` as the ``--set`` text that reads back as the same value (so that a scenario's
    ``overrides`` and ``manifest.json`` record keyword values exactly like ``--set`` items)."""

    text = _toml(value, top=True)
    want = _plain(value)
    if isinstance(want, float) and math.isnan(want):
        return text
    if parse_value(text) != want:
        raise ParameterError(f"{key} = {value!r}: not a value a scenario key takes (a number, a string with a "
                             f"unit, a boolean, or a list or table of those)")
    return text


def _plain(value: Any) -> Any:
    if hasattr(value, "tolist"):  # NumPy scalars and arrays
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    return value


def _toml(value: Any, top: bool = False) -> str:

    value = _plain(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ("nan" if math.isnan(value) else ("inf" if value > 0 else "-inf"))
    if isinstance(value, str):
        if top and value == value.strip() and parse_value(value) == value:
            return value  # plain text ("2.2 ohm"), as --set takes it
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in value.items()) + "}"
    raise ParameterError(f"{value!r} ({type(value).__name__}) is not a value a scenario key takes")

