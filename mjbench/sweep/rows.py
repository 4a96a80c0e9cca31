"""The rows of a sweep: grid points × Monte Carlo draws, each the scenario with a few keys
substituted (each swept value validated once, :class:`RowScenarios`)."""
from __future__ import annotations

import itertools
import math

import numpy as np

from .. import scenario as S
from ..errors import ParameterError
from .spec import SweepSpec, check_size


# ======================================================================== rows
def _resolve(scn, key):
    return scn.aliases.get(key, key)


def make_rows(spec: SweepSpec, scn) -> list[dict]:
    """All rows of the sweep: [{"row": i, key: value, ...}] (deterministic)."""
    if int(spec.samples) < 0:
        raise ParameterError(f"--samples {spec.samples}: must be >= 0 (Monte Carlo draws per grid point)")
    nsamp = int(spec.samples)
    pkeys = list(spec.perturb)
    if nsamp and not pkeys:
        raise ParameterError(f"--samples {nsamp} needs at least one --perturb KEY=R% (the keys to draw)")
    if pkeys and not nsamp:
        raise ParameterError(f"--perturb {pkeys[0]} needs --samples N (how many draws)")
    first = {}
    for key in list(spec.grid) + pkeys:  # one scenario key given twice under two names (an alias)
        k = _resolve(scn, key)
        if k in first and first[k] != key:
            raise ParameterError(f"--grid/--perturb {key} and {first[k]} are the same scenario key {k}: give it once")
        first.setdefault(k, key)
    nrows = math.prod(len(v) for v in spec.grid.values()) * max(nsamp, 1)
    check_size(nrows, " × ".join([f"{len(v)} {k}" for k, v in spec.grid.items()] + ([f"{nsamp} samples"] if nsamp else [])))
    for key in spec.keys():  # fail early on a typo or an invalid value, naming the key
        vals = spec.grid.get(key) or [S.get(scn, _resolve(scn, key))]
        for v in _probe(vals):
            S.with_values(scn, {_resolve(scn, key): v})
    grid_keys = list(spec.grid)
    points = list(itertools.product(*[spec.grid[k] for k in grid_keys])) if grid_keys else [()]
    rng = np.random.default_rng(spec.seed)
    u = rng.uniform(-1.0, 1.0, size=(len(points) * max(nsamp, 1), len(pkeys)))
    rows = []
    for gi, pt in enumerate(points):
        base = dict(zip(grid_keys, pt))
        for si in range(max(nsamp, 1)):
            i = gi * max(nsamp, 1) + si
            row = {"row": i, **base}
            if nsamp:
                row["sample"] = si
                for j, k in enumerate(pkeys):
                    nominal = base.get(k, S.get(scn, _resolve(scn, k)))
                    if not isinstance(nominal, (int, float)) or isinstance(nominal, bool):
                        raise ParameterError(f"--perturb {k}: nominal value {nominal!r} is not a number")
                    row[k] = float(nominal) * (1.0 + spec.perturb[k] * float(u[i, j]))
            rows.append(row)
    return rows


def _probe(vals, n=64):
    """The values checked before running: all of up to ``n``, else the extremes and an even spread
    (every row is validated again when it runs; an invalid one is then an error row)."""
    if len(vals) <= n:
        return vals
    nums = [v for v in vals if isinstance(v, (int, float)) and not isinstance(v, bool)]
    idx = np.linspace(0, len(vals) - 1, n).astype(int)
    return ([min(nums), max(nums)] if nums else []) + [vals[i] for i in idx]


def row_scenario(scn, row: dict, keys):
    """The validated scenario of one row (its keys set, through the schema)."""
    return S.with_values(scn, {_resolve(scn, k): row[k] for k in keys})


#: scenario tables whose values take part in cross-field checks: a row that sweeps them is
#: validated whole (the other rows substitute values validated once each, :class:`RowScenarios`)
WHOLE_VALIDATION = ("simulation.", "aliases", "paper", "metrics.", "law.", "optimize.", "check.",
                    "drive.pwm", "drive.encoder", "drive.sensor", "drive.gear", "drive.friction", "drive.current_loop")


class RowScenarios:
    """The scenarios of a sweep's rows, each validated once per distinct value instead of once per row.

    Every value of every swept key is validated by the schema on its own (the scenario with that
    key set: units, ranges, types — an invalid value makes its rows error rows, as a full
    validation would); a row's scenario is then the sweep's scenario with the validated values
    substituted along their paths.  That is the scenario the schema gives for the whole row unless
    keys interact in a cross-field check, so rows of keys in :data:`WHOLE_VALIDATION` are validated
    whole, and the first row of every sweep is compared with its whole validation (any difference:
    every row validated whole).  ``raw`` stays the sweep's (rows keep their values in ``overrides``)."""

    def __init__(self, scn, keys):
        self.scn, self.keys = scn, list(keys)
        self.paths = {k: _resolve(scn, k) for k in self.keys}
        # (an axis's own mode table, [modes.NAME.axes.JOINT], is merged over its mode's at validation)
        self.fast = None if not any(p.startswith(WHOLE_VALIDATION) or (p.startswith("modes.") and ".axes." in p)
                                    for p in self.paths.values()) else False
        self._values = {}

    def __call__(self, row: dict):
        if self.fast is False:
            return row_scenario(self.scn, row, self.keys)
        vals = {self.paths[k]: self._validated(self.paths[k], row[k]) for k in self.keys}
        s = self.scn
        for path, v in vals.items():
            s = _substituted(s, path.split("."), v)
        s = s.model_copy(update={"overrides": list(self.scn.overrides) + [f"{p}={row[k]!r}"
                                                                             for k, p in self.paths.items()]})
        if self.fast is None:  # the first row: the substitution must equal the whole validation
            whole = row_scenario(self.scn, row, self.keys)
            self.fast = s.model_dump() == whole.model_dump()
            return whole
        return s

    def _validated(self, path, value):
        k = (path, repr(value))
        if k not in self._values:
            self._values[k] = S.get(S.with_values(self.scn, {path: value}), path)  # ScenarioError: an error row
        return self._values[k]


def _substituted(obj, parts, value):
    """``obj`` (a pydantic model or dict) with the value at the dotted path ``parts`` replaced
    (shallow copies along the path; the rest shared)."""
    head = parts[0]
    if len(parts) == 1:
        new = value
    else:
        new = _substituted(obj[head] if isinstance(obj, dict) else getattr(obj, head), parts[1:], value)
    if isinstance(obj, dict):
        return {**obj, head: new}
    return obj.model_copy(update={head: new})
