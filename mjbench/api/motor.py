"""Motor identification from Python: :func:`identify_motor` fits R, L, K, friction and inertia to
a logged voltage/speed(/current) record."""
from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from .. import identify as ID
from ..identify import drive_table
from ..identify import report
from ..identify import plot
from ..outputs import staged_dir, write_json


class MotorFit:
    """The fitted DC-motor parameters with their 95 % confidence intervals.

    Attributes
    ----------
    data : dict
        The fit: ``params`` {name: {value, std, ci95, fixed}}, ``rms`` residuals, ``sigma`` noise
        levels, ``cost``, ``nfev``, ``method``, and the fitted simulation ``omega_fit`` [rad/s],
        ``I_fit`` [A] (arrays, shape (n,)).
    record : dict of numpy.ndarray
        The record fitted: ``t`` [s], ``V`` [V], ``omega`` [rad/s], ``I`` [A] (None without current).
    source : str or None
        The record's file (``identify.json`` ``data``).
    """

    def __init__(self, data: dict[str, Any], record: dict[str, Any], source: str | None = None) -> None:
        self.data, self.record, self.source = data, record, source

    @property
    def params(self) -> dict[str, dict[str, Any]]:
        """{R, L, K, J, b, T_c: {value, std, ci95, fixed}} (SI: Ω, H, V·s/rad, kg·m², N·m·s/rad, N·m)."""
        return dict(self.data["params"])

    @property
    def values(self) -> dict[str, float]:
        """The fitted values {name: value} (SI)."""
        return {k: float(v["value"]) for k, v in self.data["params"].items()}

    @property
    def drive(self) -> dict[str, float]:
        """The values as a scenario's ``[drive]`` keys (R, L, k_m, J_m, lam, T_0)."""

        return dict(drive_table(self.data))

    def report(self, truth: Mapping[str, float] | None = None) -> str:
        """The table ``mjbench identify`` prints (``truth``: known values, their errors shown)."""

        return str(report(self.data, dict(truth) if truth else None))

    def to_dict(self) -> dict[str, Any]:
        """What ``identify.json`` holds."""
        doc = {k: v for k, v in self.data.items() if k not in ("omega_fit", "I_fit")}
        doc["data"] = self.source
        doc["drive"] = self.drive
        return doc

    def save(self, path: str | os.PathLike[str], *, force: bool = False, what: str = "save") -> Path:
        """Write ``identify.json`` and ``identify_fit.png`` into the folder ``path``, whole or not
        at all (``mjbench identify --out``)."""

        with staged_dir(path, force=force, what=what) as out:
            write_json(os.path.join(out, "identify.json"), self.to_dict(), indent=1)
            plot(self.record, self.data, os.path.join(out, "identify_fit.png"))
        return Path(os.path.abspath(os.fspath(path)))


def identify_motor(data: str | os.PathLike[str] | Mapping[str, Any], *, fix: Mapping[str, float] | None = None,
                   guess: Mapping[str, float] | None = None, current: bool = True, omega_s: float = 0.05,
                   source: str | None = None) -> MotorFit:
    """Fit the DC motor's R, L, K, viscous b and Coulomb T_c friction and shaft inertia J to a
    record (output-error least squares, ``scipy.optimize.least_squares``).

    Parameters
    ----------
    data : str, path, mapping or DataFrame
        A CSV file with a header (an mjbench trajectory CSV works), or columns as arrays of
        shape (n,): ``t_s`` [s], ``voltage_V`` [V], ``motor_speed_rad_s`` [rad/s], optional
        ``current_A`` [A] (or ``t``, ``V``, ``omega``, ``I``).  Times must increase; n >= 20.
    fix : mapping, optional
        Parameters held at known values (``{"R": 2.0, "L": 9e-3}``); at least two without
        current.
    guess : mapping, optional
        Starting values.
    current : bool
        Use the current column when there is one.
    omega_s : float
        Speed scale of the smoothed Coulomb friction tanh(ω/ω_s) [rad/s].
    source : str, optional
        The record's file for ``identify.json`` (default: ``data`` when it is a path).

    Returns
    -------
    MotorFit
        ``values``, ``params`` (with CIs), ``drive`` (scenario keys), ``report()``, ``save(dir)``.
    """

    if isinstance(data, (str, os.PathLike)):
        rec = ID.read_record(os.fspath(data), option="data")
        source = source or os.path.abspath(os.fspath(data))
    else:
        rec = _columns(data, ID.COLUMNS, ID.MIN_SAMPLES)
    fixed, start = _values(fix, "fix", ID.PARAMS), _values(guess, "guess", ID.PARAMS)
    if len(fixed) == len(ID.PARAMS):
        raise ParameterError("fix: every parameter is fixed, nothing is left to fit")
    both = sorted(set(fixed) & set(start))
    if both:
        raise ParameterError(f"guess {both[0]}: the parameter is also fixed; a start value of a fixed parameter has "
                             f"no effect")
    if not (math.isfinite(float(omega_s)) and float(omega_s) > 0):
        raise ParameterError(f"omega_s = {omega_s!r}: must be > 0 [rad/s]")
    current_a = rec.get("I") if current else None
    res = ID.fit(rec["t"], rec["V"], rec["omega"], current_a, fixed=fixed, guess=start, omega_s=float(omega_s))
    return MotorFit(res, {**rec, "I": current_a}, source)


def _values(given: Mapping[str, float] | None, what: str, names: tuple[str, ...]) -> dict[str, float]:
    """``fix``/``guess``: names of the fit, finite values, > 0 (>= 0 for the frictions b, T_c)."""
    out = {}
    for k, v in (given or {}).items():
        if k not in names:
            raise ParameterError(f"{what}[{k!r}]: not a parameter of the fit; choose {', '.join(names)}")
        x = float(v)
        if not (math.isfinite(x) and (x >= 0 if k in ("b", "T_c") else x > 0)):
            raise ParameterError(f"{what}[{k!r}] = {v!r}: must be finite and {'>= 0' if k in ('b', 'T_c') else '> 0'}")
        out[k] = x
    return out


def _columns(data: Any, names: Mapping[str, tuple[str, ...]], min_samples: int) -> dict[str, Any]:
    """{t, V, omega[, I]} float arrays from a mapping or DataFrame of columns, checked."""
    rec: dict[str, Any] = {}
    have = list(data.keys())
    for key, cands in names.items():
        col = next((c for c in (key, *cands) if c in have), None)
        if col is None:
            if key == "I":
                continue
            raise ParameterError(f"data: no column for {key} (accepted names: {', '.join(cands)})")
        rec[key] = np.asarray(data[col], dtype=float).reshape(-1)
    n = len(rec["t"])
    for key, arr in rec.items():
        if len(arr) != n:
            raise ParameterError(f"data: column {key} has {len(arr)} samples, t has {n}")
        if not np.all(np.isfinite(arr)):
            raise ParameterError(f"data: column {key} has a non-finite value at sample {int(np.argmin(np.isfinite(arr)))}")
    if n < min_samples:
        raise ParameterError(f"data: {n} samples; the fit needs at least {min_samples}")
    if np.any(np.diff(rec["t"]) <= 0):
        raise ParameterError("data: the times must increase")
    return rec
