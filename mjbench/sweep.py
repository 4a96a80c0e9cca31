"""Parameter sweeps on the batched backends: grids and Monte Carlo, local or on Dask.

A sweep is a list of *rows*; each row is the scenario with a few dotted keys overridden (the keys
of ``--set``, aliases included).  Rows come from

* ``grid``: {key: [v1, v2, ...]} — the Cartesian product, first key slowest;
* ``samples`` × ``perturb``: for every grid point, ``samples`` Monte Carlo draws, each perturbed
  key multiplied by (1 + r·u), u uniform in [−1, 1] (a tolerance band ±r, e.g. ``5%``), drawn
  from ``numpy.random.default_rng(seed)`` once for the whole sweep, so a row's values depend only
  on the specification, never on chunking, workers or resumption.

Rows are simulated in *chunks* (``chunk_size`` rows, in row order; default: it follows the
number of rows, :func:`auto_chunk`) by :func:`run_chunk`: one batch of the chunk's machines on the
sweep's ``backend`` — ``reduced`` (default: the batched reduced model,
:mod:`mjbench.backends.reduced_batch`) or ``multibody`` (``mujoco.batch``, per-row models via
``set_models`` where masses or geometry differ) — the same pure function locally and on a Dask
worker, so the table is identical either way (tests/test_sweep.py).  With the reduced backend the
``verify`` best rows (by the summary metric) are then re-run on the multibody backend and
written to ``verify.csv`` with both figures and their difference (:func:`verify_best`).

Output folder: ``sweep.json`` (the specification), ``results.csv`` (one row per simulation:
``row``, the swept keys, ``status`` (ok | diverged | error), the metrics of
:func:`mjbench.metrics.summary` and ``message``), rewritten atomically after every chunk; and
summary plots.  A rerun with the same specification skips the rows already in the table.
"""
from __future__ import annotations

import contextlib
import copy
import csv
import io
import itertools
import json
import math
import os
from dataclasses import asdict, dataclass, field

import numpy as np

from . import metrics as M
from . import outputs
from . import scenario as S
from .errors import MjbenchError, ParameterError, ScenarioError
from .trajectory import atomic_write

RESULTS = "results.csv"
SPEC = "sweep.json"
VERIFY = "verify.csv"
FIXED_COLUMNS = ("row", "status")


@dataclass
class SweepSpec:
    """What to sweep.  ``grid``: {key: [values]}; ``perturb``: {key: relative half-width}."""

    scenario: str
    grid: dict = field(default_factory=dict)
    samples: int = 0
    perturb: dict = field(default_factory=dict)
    seed: int = 0
    mode: str | None = None
    t_end: float | None = None
    overrides: list = field(default_factory=list)  # --set applied to every row
    chunk_size: int | None = None  # None: follows the number of rows (auto_chunk)
    backend: str = "reduced"
    verify: int = 3  # best rows re-run on the multibody backend (reduced backend only)

    def keys(self):
        return list(self.grid) + [k for k in self.perturb if k not in self.grid]

    def to_json(self):
        d = asdict(self)
        d.pop("chunk_size")  # does not change results
        d.pop("verify")
        return d


#: largest chunk per backend: the runs of a chunk are independent (mjbench.kernel.run_many, one run
#: per thread), so a chunk is a unit of memory (its machines, plants and scenarios live together), of
#: progress and of resumption (the table is rewritten after each), not of speed
CHUNK_MAX = {"multibody": 64, "reduced": 256}


def auto_chunk(nrows: int, backend: str, workers: int = 1) -> int:
    """Rows per chunk: all rows in one batch up to CHUNK_MAX, and with ``workers`` Dask workers at
    least two chunks per worker (so that every worker has work) but no fewer than 16 rows."""
    size = min(max(1, nrows), CHUNK_MAX.get(backend, 256))
    if workers > 1:
        size = min(size, max(16, math.ceil(nrows / (2 * workers))))
    return size


# ======================================================================== parsing (CLI)
#: most rows a sweep runs unless ``MJBENCH_MAX_SWEEP_ROWS`` says otherwise: the table is held in
#: memory and rewritten after every chunk; 100 000 rows of a 0.5 s run are ≈ 5e8 co-steps
MAX_ROWS = 100_000
#: memory of one result row held by the sweep [bytes] (measured: ≈ 2.4 kB for the ≈ 20 metrics of
#: a four-bar row in a dict; rounded up)
ROW_BYTES = 4096


def max_rows() -> int:
    """The row limit: ``MJBENCH_MAX_SWEEP_ROWS`` if set, else :data:`MAX_ROWS`."""
    env = os.environ.get("MJBENCH_MAX_SWEEP_ROWS")
    if not env:
        return MAX_ROWS
    try:
        n = int(float(env))
    except ValueError:
        raise ParameterError(f"MJBENCH_MAX_SWEEP_ROWS = {env!r}: must be a whole number of rows") from None
    if n < 1:
        raise ParameterError(f"MJBENCH_MAX_SWEEP_ROWS = {env!r}: must be >= 1")
    return n


def check_size(nrows: int, detail: str = "") -> None:
    """Refuse, before anything runs, a sweep of more rows than :func:`max_rows` or than half the
    available memory holds (ROW_BYTES each)."""
    from .kernel import memory_limit

    lim = max_rows()
    need = nrows * ROW_BYTES
    mem = memory_limit()
    if nrows > lim or need > mem:
        why = (f"more than the limit of {lim:,} rows (MJBENCH_MAX_SWEEP_ROWS overrides)" if nrows > lim else
               f"its table would need {need / 2 ** 20:,.0f} MiB, more than {mem / 2 ** 20:,.0f} MiB (half the "
               f"available memory; MJBENCH_MAX_RECORD_MB overrides)")
        raise ParameterError(f"the sweep has {nrows:,} rows{' (' + detail + ')' if detail else ''}: {why}; use fewer "
                             f"--grid values or --samples, or split it into several sweeps")


def _range_values(item: str, key: str, text: str) -> list:
    """``lo:hi:n`` → n evenly spaced floats (n checked before anything is allocated)."""
    lo_t, hi_t, n_t = text.split(":")
    try:
        lo, hi = float(lo_t), float(hi_t)
        nf = float(n_t)
    except ValueError:
        raise ScenarioError(f"--grid {item!r}: expected {key}=lo:hi:n with numbers lo, hi and a whole number n") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ScenarioError(f"--grid {item!r}: lo and hi must be finite numbers")
    if not (math.isfinite(nf) and nf == int(nf) and nf >= 2):
        raise ScenarioError(f"--grid {item!r}: n = {n_t!r} must be a whole number >= 2 (values from lo to hi)")
    n = int(nf)
    check_size(n, f"--grid {key}: {n:,} values")
    if lo == hi:
        raise ScenarioError(f"--grid {item!r}: lo = hi gives {n} identical rows; give lo < hi or one value")
    return [float(v) for v in np.linspace(lo, hi, n)]


def parse_grid(items) -> dict:
    """``["key=v1,v2", ...]`` → {key: [values]} (values parsed as TOML, like --set);
    ``key=lo:hi:n`` gives n evenly spaced values.  A key given twice, a repeated value or an empty
    list is an error (each would silently drop or repeat rows)."""
    grid, src = {}, {}
    for item in items or ():
        if "=" not in item:
            raise ScenarioError(f"--grid {item!r}: expected key=v1,v2,... or key=lo:hi:n")
        key, text = (s.strip() for s in item.split("=", 1))
        if not key:
            raise ScenarioError(f"--grid {item!r}: no key before '='")
        if key in grid:
            raise ScenarioError(f"--grid {key} is given twice ({src[key]!r} and {item!r}): give all its values in one "
                                f"--grid {key}=V1,V2,...")
        if text.count(":") == 2 and "," not in text:
            vals = _range_values(item, key, text)
        else:
            vals = [S.parse_value(v.strip()) for v in text.split(",") if v.strip()]
        if not vals:
            raise ScenarioError(f"--grid {item!r}: no values")
        seen = []
        for v in vals:
            if any(_same(v, w) for w in seen):
                raise ScenarioError(f"--grid {item!r}: the value {v!r} is repeated (each row would run twice); "
                                    f"give each value once")
            seen.append(v)
        grid[key], src[key] = vals, item
    return grid


def _same(a, b) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return float(a) == float(b)
    return a == b


def parse_perturb(items) -> dict:
    """``["key=5%", "key=0.02"]`` → {key: 0.05, key: 0.02} (relative half-widths)."""
    out = {}
    for item in items or ():
        if "=" not in item:
            raise ScenarioError(f"--perturb {item!r}: expected key=5% (relative half-width)")
        key, text = (s.strip() for s in item.split("=", 1))
        if key in out:
            raise ScenarioError(f"--perturb {key} is given twice: give it once")
        try:
            r = float(text[:-1]) / 100 if text.endswith("%") else float(text)
        except ValueError:
            raise ScenarioError(f"--perturb {item!r}: {text!r} is not a number or percentage") from None
        if not (math.isfinite(r) and r >= 0):
            raise ScenarioError(f"--perturb {item!r}: the relative half-width must be >= 0")
        if r >= 1:
            raise ScenarioError(f"--perturb {item!r}: a half-width of {100 * r:g} % can change the value's sign "
                                f"(factor 1 ± r); use less than 100 %")
        out[key] = r
    return out


def check_scheduler(address: str) -> str:
    """A Dask scheduler address, checked for its form: ``tcp://HOST:PORT`` (also tls, ws, wss,
    ucx, inproc; a bare ``HOST:PORT`` means tcp)."""
    from urllib.parse import urlsplit

    text = address.strip()
    full = text if "://" in text else f"tcp://{text}"
    try:
        u = urlsplit(full)
        port = u.port
    except ValueError:
        port, u = None, None
    ok = u is not None and (u.scheme == "inproc" or (u.scheme in ("tcp", "tls", "ws", "wss", "ucx") and u.hostname
                                                       and port is not None and 0 < port < 65536 and u.path in ("", "/")))
    if not ok:
        raise ParameterError(f"--scheduler {address!r}: not a Dask scheduler address; expected tcp://HOST:PORT, e.g. "
                             f"tcp://127.0.0.1:8786 (start one with `dask scheduler`)")
    return full


#: seconds a sweep waits for a Dask scheduler to answer before giving up (``MJBENCH_DASK_TIMEOUT``)
CONNECT_TIMEOUT = 5.0


def connect(address: str):
    """A ``dask.distributed.Client`` of ``address``, or ONE error within :data:`CONNECT_TIMEOUT` s."""
    from dask.distributed import Client

    full = check_scheduler(address)
    try:
        timeout = float(os.environ.get("MJBENCH_DASK_TIMEOUT") or CONNECT_TIMEOUT)
    except ValueError:
        raise ParameterError(f"MJBENCH_DASK_TIMEOUT = {os.environ['MJBENCH_DASK_TIMEOUT']!r}: must be seconds") from None
    try:
        return Client(full, timeout=timeout)
    except (OSError, TimeoutError) as e:
        raise ParameterError(f"--scheduler {address}: no Dask scheduler answered within {timeout:g} s "
                             f"({type(e).__name__}: {str(e).splitlines()[0] if str(e) else 'no answer'}); check the "
                             f"address and that `dask scheduler` runs there") from None
    except ValueError as e:
        raise ParameterError(f"--scheduler {address!r}: {e}") from None


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
        self.fast = None if not any(p.startswith(WHOLE_VALIDATION) for p in self.paths.values()) else False
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


# ======================================================================== simulation of a chunk
def settings(spec: SweepSpec, scn) -> dict:
    from .backends import SEARCH_BACKENDS

    if spec.backend not in SEARCH_BACKENDS:
        raise ParameterError(f"--backend {spec.backend!r}: choose one of {list(SEARCH_BACKENDS)}")
    mode = scn.mode(spec.mode)
    return {"mode": mode, "t_end_fixed": spec.t_end, "backend": spec.backend,
            **_run_settings(scn, spec.t_end, spec.backend)}


def _run_settings(scn, t_end_fixed, backend="multibody"):
    """Per-row run settings (a sweep may vary simulation.dt, the integrator, the χ window ...)."""
    from .runner import backend_options

    opts = backend_options(scn, backend)
    if backend == "reduced":
        opts["method"] = "rk4"  # the batched reduced model's integrator
    return {"t_end": float(t_end_fixed if t_end_fixed is not None else scn.simulation.t_end),
            "record_dt": scn.simulation.record_dt,
            "options": opts,
            "chi_window": scn.metrics.chi_window,
            "chi_average": scn.metrics.chi_average}


def row_metrics(traj, st) -> dict:
    win = st["chi_window"]
    m = M.summary(traj, chi_window=win, average=st["chi_average"])
    return {k: v for k, v in m.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}


def run_chunk(scn, rows: list, keys: list, st: dict, nthread: int = 0) -> list[dict]:
    """Simulate ``rows`` of the sweep in one batch (per model structure) on ``st["backend"]`` →
    result rows.  Pure: the same input gives the same output locally and on a Dask worker."""
    from .backends import batch, simulate_many

    backend = st.get("backend", "multibody")
    outputs.route_mujoco_log()  # on a Dask worker too: MuJoCo warnings recorded, no ./MUJOCO_LOG.TXT
    out = {r["row"]: dict(r) for r in rows}
    machines, ok_rows, models, sts, sigs, cache = [], [], [], [], [], {}
    scenarios = RowScenarios(scn, keys)
    for r in rows:
        try:
            s = scenarios(r)
            st_r = _run_settings(s, st.get("t_end_fixed"), backend)
            mc = S.make_machine(s, st["mode"])
            if backend == "multibody":
                o = {**batch.DEFAULT_OPTIONS, **st_r["options"]}
                key = batch._model_key(mc, o)
                if key not in cache:
                    cache[key] = batch.build_models([mc], o)[0]
                m = cache[key]
                models.append(m)
                sig = (m.nq, m.nv, m.nbody, m.neq, m.nsite, m.nu, m.na)
            else:
                sig = (type(mc.mechanism).__name__, mc.mechanism.internal)
            machines.append(mc)
            sts.append(st_r)
            sigs.append(sig + (repr(sorted(st_r["options"].items())), st_r["t_end"], st_r["record_dt"]))
            ok_rows.append(r)
        except (MjbenchError, ValueError) as e:  # invalid combination: a row of the table, not a crash
            out[r["row"]].update(status="error", message=str(e))
    groups = {}
    for i, sig in enumerate(sigs):
        groups.setdefault(sig, []).append(i)
    for idx in groups.values():
        st0 = sts[idx[0]]
        try:
            if backend == "multibody":
                o = {**batch.DEFAULT_OPTIONS, **st0["options"]}
                res = batch.simulate([machines[i] for i in idx], st0["t_end"], record_dt=st0["record_dt"],
                                     options=o, nthread=nthread, models=[models[i] for i in idx])
            else:  # metrics computed as each run ends: one record per thread in memory, not the batch's
                res = simulate_many([machines[i] for i in idx], backend, st0["t_end"], record_dt=st0["record_dt"],
                                    options=st0["options"], consume=lambda j, tr: _outcome(tr, sts[idx[j]]))
        except MjbenchError as e:
            for i in idx:
                out[ok_rows[i]["row"]].update(status="error", message=str(e))
            continue
        for j, i in enumerate(idx):
            rr = out[ok_rows[i]["row"]]
            if res.diverged[j]:
                rr.update(status="diverged", message=res.messages[j])
                continue
            rr.update(**(res.results[j] if res.results is not None else _outcome(res.trajectory(j), sts[i])))
    return [out[r["row"]] for r in rows]


def _outcome(traj, st) -> dict:
    """The result cells of one run that ended: its metrics, or the error computing them."""
    if traj.meta.get("diverged"):
        return {}
    try:
        return {"status": "ok", **row_metrics(traj, st)}
    except MjbenchError as e:
        return {"status": "error", "message": str(e)}


def verify_best(spec: SweepSpec, scn, results: list[dict], keys: list, st: dict, metric: str | None,
                out_dir=None, nthread: int = 0) -> list[dict]:
    """Re-run the ``spec.verify`` best rows (smallest ``metric``) on the multibody backend →
    [{row, keys..., metric, reduced, multibody, difference, relative}], written to verify.csv."""
    metric = metric or default_metric(results)
    ok = [r for r in results if r.get("status") == "ok" and metric in r and np.isfinite(r[metric])]
    best = sorted(ok, key=lambda r: r[metric])[:max(0, int(spec.verify))]
    if not best or metric is None:
        return []
    rows = [{k: r[k] for k in ("row", *keys) if k in r} for r in best]
    mb = run_chunk(scn, rows, keys, {**st, "backend": "multibody"}, nthread)
    out = []
    for r, m in zip(best, mb):
        v = m.get(metric, float("nan")) if m.get("status") == "ok" else float("nan")
        d = {"row": r["row"], **{k: r[k] for k in keys if k in r}, "metric": metric, st["backend"]: r[metric],
             "multibody": v, "difference": v - r[metric],
             "relative": (v - r[metric]) / abs(v) if v else float("nan")}
        out.append(d)
    if out_dir is not None:
        cols = list(out[0])
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(cols)
        for d in out:
            w.writerow([_fmt(d[c]) for c in cols])
        atomic_write(os.path.join(out_dir, VERIFY), lambda f: f.write(buf.getvalue()))
    return out


# ======================================================================== table I/O
def write_table(path, results: list[dict], keys: list):
    """One CSV row per simulation, sorted by ``row``; floats written with full precision (repr)."""
    results = sorted(results, key=lambda r: r["row"])
    extra = ["sample"] if any("sample" in r for r in results) else []
    metric_cols = []
    for r in results:
        for k in r:
            if k not in metric_cols and k not in keys and k not in FIXED_COLUMNS and k not in extra and k != "message":
                metric_cols.append(k)
    cols = ["row", *extra, *keys, "status", *metric_cols, "message"]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in results:
        w.writerow([_fmt(r.get(c, "")) for c in cols])
    atomic_write(path, lambda f: f.write(buf.getvalue()))
    return path


def _fmt(v):
    if isinstance(v, float):
        return repr(v)
    return v


def read_table(path) -> list[dict]:
    """Rows of a results.csv with numbers parsed back (exact: written with repr)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = []
    for r in rows:
        d = {}
        for k, v in r.items():
            if v == "" or v is None:
                continue
            if k in ("status", "message"):
                d[k] = v
                continue
            d[k] = _number(v)
        out.append(d)
    return out


def _number(text: str):
    """A table cell back as written: an integer literal as ``int`` (``n_cycles`` 7, a grid value
    2), anything else ``float`` (written by ``repr``: exact), else the text.  So a resumed row is
    written back byte for byte as a fresh one (never ``7.0`` for ``7``)."""
    t = text.strip()
    if t.lstrip("+-").isdigit():
        return int(t)
    try:
        return float(t)
    except ValueError:
        return text


# ======================================================================== driver
def sweep_metrics(scn) -> dict:
    """The metrics a row of this scenario's sweep can hold ({name: description}): the numeric
    metrics of :func:`mjbench.metrics.summary` (χ in the window only with ``metrics.chi_window``)."""
    return {k: d for k, d in M.SUMMARY_METRICS.items() if k != "chi_window" or scn.metrics.chi_window is not None}


def check_metric(metric, scn):
    """``--metric``: a known metric name of the sweep's rows, or ONE error listing them."""
    if metric is None:
        return None
    known = sweep_metrics(scn)
    if metric not in known:
        import difflib

        near = difflib.get_close_matches(metric, list(known), n=1)
        hint = f"did you mean {near[0]!r}? " if near else ""
        why = (" (it needs metrics.chi_window in the scenario)" if metric == "chi_window" else "")
        raise ParameterError(f"--metric {metric!r} is not a metric of the sweep's rows{why}; {hint}metrics: "
                             f"{', '.join(known)}")
    return metric


def run_sweep(spec: SweepSpec, out_dir, client=None, scheduler: str | None = None, nthread: int = 0,
              progress: bool = True, plots: bool = True, metric: str | None = None) -> dict:
    """Run (or resume) a sweep into ``out_dir``.  ``client``: a ``dask.distributed.Client``, or
    ``scheduler``: its address (tcp://host:port) — chunks then run on the cluster.
    Returns {"table": path, "rows": n, "ran": n_new, "plots": [paths], "verified": [...],
    "notes": [warnings]}.

    Everything is checked before anything is written (keys, values, --metric, the number of rows,
    the scheduler's answer).  A failure before the first row is saved leaves no folder behind; a
    later one leaves the rows saved so far, and the same call resumes."""
    scn = S.load(spec.scenario, spec.overrides)
    metric = check_metric(metric, scn)
    rows = make_rows(spec, scn)
    keys = spec.keys()
    st = settings(spec, scn)
    own_client = None
    if client is None and scheduler:
        own_client = client = connect(scheduler)  # one line within a few seconds if nobody answers
    spec_path = os.path.join(out_dir, SPEC)
    table = os.path.join(out_dir, RESULTS)
    spec_json = outputs.dumps(spec.to_json(), sort_keys=True, indent=1)
    results, bar, notes = {}, None, []
    made = []
    try:
        made = outputs._make_parents(outputs.Path(os.path.abspath(out_dir)))
        done = {}
        if os.path.exists(spec_path):
            with open(spec_path) as f:
                old = f.read()
            try:
                same = json.loads(old) == json.loads(spec_json)
            except ValueError:
                same = False
            if not same:
                raise ScenarioError(f"{out_dir} holds a different sweep ({SPEC} differs); use another --out "
                                    f"or delete the folder")
            if os.path.exists(table):
                done = {r["row"]: r for r in read_table(table) if r.get("status") in ("ok", "diverged", "error")}
        else:
            atomic_write(spec_path, lambda f: f.write(spec_json))
        pending = [r for r in rows if r["row"] not in done]
        results.update(done)
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=len(rows), initial=len(done), desc="sweep", unit="sim")

        def collect(chunk_result):
            for r in chunk_result:
                results[r["row"]] = r
            write_table(table, list(results.values()), keys)
            if bar is not None:
                bar.update(len(chunk_result))

        workers = len(client.scheduler_info().get("workers", {})) if client is not None else 1
        size = max(1, int(spec.chunk_size)) if spec.chunk_size else auto_chunk(len(pending), spec.backend, workers)
        chunks = [pending[i:i + size] for i in range(0, len(pending), size)]
        if client is not None and chunks:
            _run_on_dask(client, scn, chunks, keys, st, nthread, collect, table, len(rows), len(done))
        else:
            for ch in chunks:
                collect(run_chunk(scn, ch, keys, st, nthread))
        if not chunks and not os.path.exists(table):
            write_table(table, list(results.values()), keys)
    except BaseException as e:
        if not os.path.exists(table):  # nothing saved yet: leave no folder behind
            if made:
                with contextlib.suppress(OSError):
                    os.unlink(spec_path)
            outputs._remove_empty(made)
        if isinstance(e, OSError) and not isinstance(e, MjbenchError):
            saved = f"{len(results)} of {len(rows)} rows are saved in {table}; the same command resumes" \
                if os.path.exists(table) else "nothing was written"
            raise outputs.OutputError(f"--out {out_dir}: cannot write {os.path.basename(e.filename or '') or 'its files'}"
                                      f" ({e.strerror or e}); {saved}") from None
        raise
    finally:
        if bar is not None:
            bar.close()
        if own_client is not None:
            own_client.close()
    out = {"table": table, "rows": len(rows), "ran": len(pending), "plots": [], "verified": [], "notes": notes}
    final = read_table(table)
    use = metric or default_metric(final)
    if use is not None and not any(r.get("status") == "ok" and use in r for r in final):
        notes.append(f"no row has the metric {use!r} (every run diverged or failed, or the runs are too short for "
                     f"it: e.g. chi_last_cycle needs a complete crank cycle): no summary plot"
                     + (", no verification on the multibody backend" if spec.backend != "multibody" and spec.verify
                        else ""))
    if spec.backend != "multibody" and spec.verify > 0:
        out["verified"] = verify_best(spec, scn, final, keys, st, use, out_dir, nthread)
    if plots:
        out["plots"] = summary_plots(spec, final, out_dir, metric=use)
    return out


#: times Dask re-runs a chunk whose worker died or raised (then the sweep stops cleanly)
DASK_RETRIES = 2


def _run_on_dask(client, scn, chunks, keys, st, nthread, collect, table, nrows, ndone):
    """Submit every chunk (``DASK_RETRIES`` retries each: a chunk whose worker is lost runs again
    elsewhere) and collect them as they complete.  If the cluster still loses a chunk, stop
    cleanly: ONE error saying how many rows are saved and that the same command resumes."""
    from dask.distributed import as_completed

    scn_f = ship_scenario(client, scn)
    futs = [client.submit(run_chunk, scn_f, ch, keys, st, nthread, pure=False, retries=DASK_RETRIES)
            for ch in chunks]
    saved = ndone
    try:
        for fut in as_completed(futs):
            res = fut.result()
            collect(res)
            saved += len(res)
    except (MjbenchError, KeyboardInterrupt):
        raise
    except Exception as e:  # noqa: BLE001 - the cluster's failures: lost workers, cancelled futures, comms
        for f in futs:
            f.cancel()
        first = (str(e).splitlines() or [""])[0][:200]
        raise MjbenchError(f"the Dask cluster lost a chunk of the sweep ({type(e).__name__}: {first}) after "
                           f"{DASK_RETRIES} retries; {saved} of {nrows} rows are saved in {table}: run the same "
                           f"command again to resume") from None


def ship_scenario(client, scn):
    """The scenario on the cluster as the result of ONE task whose input (the scenario itself) is
    held in the task graph by the scheduler, under a key of its own
    (``mjbench-scenario-<content hash>-<random>``).  Unlike scattered data, a task result lost with
    its worker is recomputed by the scheduler, so a worker killed mid-sweep does not cancel the
    chunks that need the scenario (``FutureCancelledError ... lost dependencies``).  The random
    part keeps two clients of one scheduler from sharing the key (see :func:`scatter_scenario`)."""
    import hashlib
    import uuid

    digest = hashlib.sha256(outputs.dumps(scn.resolved(), sort_keys=True, indent=None).encode()).hexdigest()[:16]
    key = f"mjbench-scenario-{digest}-{uuid.uuid4().hex[:12]}"
    return client.submit(_identity, scn, key=key, pure=False, retries=DASK_RETRIES)


def _identity(x):
    return x


def scatter_scenario(client, scn):
    """Ship the scenario to the cluster as ONE object under a key of its own:
    ``mjbench-scenario-<content hash>-<random>``.  (``client.scatter(dict)`` would make one future
    per top-level key — "drive", "modes", ... — which another client on the same scheduler
    scattering its own scenario replaces: its tasks then read the other machine, or lose their
    inputs when it is released.)  The random part keeps two clients from sharing a key."""
    import hashlib
    import uuid

    digest = hashlib.sha256(outputs.dumps(scn.resolved(), sort_keys=True, indent=None).encode()).hexdigest()[:16]
    key = f"mjbench-scenario-{digest}-{uuid.uuid4().hex[:12]}"
    return client.scatter({key: scn}, broadcast=True)[key]


# ======================================================================== plots
def default_metric(results):
    for k in ("chi_window", "chi_last_cycle", "chi_steady_mean", "mean_motor_speed_rad_s"):
        if any(k in r for r in results):
            return k
    return None


def summary_plots(spec: SweepSpec, results: list[dict], out_dir, metric: str | None = None) -> list:
    """Heat map (two grid keys), line (one grid key) and, for Monte Carlo, histograms."""
    from . import plots as P
    import matplotlib.pyplot as plt

    metric = metric or default_metric(results)
    if metric is None:
        return []
    paths = []
    gk = list(spec.grid)
    ok = [r for r in results if r.get("status") == "ok" and metric in r]
    if not spec.samples and len(gk) == 2:
        xs, ys = spec.grid[gk[0]], spec.grid[gk[1]]
        Z = np.full((len(ys), len(xs)), np.nan)
        for r in ok:
            try:
                Z[ys.index(_match(ys, r[gk[1]])), xs.index(_match(xs, r[gk[0]]))] = r[metric]
            except ValueError:
                pass
        fig, ax = plt.subplots(figsize=(6.4, 5))
        im = ax.imshow(Z, origin="lower", aspect="auto", cmap="viridis")
        ax.set_xlabel(gk[0])
        ax.set_ylabel(gk[1])
        if len(xs) <= LABELLED_CELLS and len(ys) <= LABELLED_CELLS:  # values written only where they can be read
            for (iy, ix), v in np.ndenumerate(Z):
                if np.isfinite(v):
                    ax.text(ix, iy, f"{v:.3g}", ha="center", va="center", fontsize=7, color="w")
        step = max(1, len(xs) // LABELLED_CELLS), max(1, len(ys) // LABELLED_CELLS)  # readable tick labels
        ax.set_xticks(range(0, len(xs), step[0]), [_tick(v) for v in xs[::step[0]]], rotation=45)
        ax.set_yticks(range(0, len(ys), step[1]), [_tick(v) for v in ys[::step[1]]])
        fig.colorbar(im, ax=ax, label=metric)
        ax.set_title(f"{metric} (blank: diverged/error)")
        paths.append(P.save(fig, os.path.join(out_dir, f"heatmap_{metric}.png")))
    elif not spec.samples and len(gk) == 1:
        xs = [r[gk[0]] for r in ok]
        fig, ax = plt.subplots(figsize=(6.4, 4))
        ax.plot(xs, [r[metric] for r in ok], "o-")
        ax.set_xlabel(gk[0])
        ax.set_ylabel(metric)
        ax.grid(alpha=0.3)
        paths.append(P.save(fig, os.path.join(out_dir, f"line_{metric}.png")))
    if spec.samples:
        vals = np.array([r[metric] for r in ok])
        fig, ax = plt.subplots(figsize=(6.4, 4))
        if len(vals):
            ax.hist(vals, bins=max(5, min(40, len(vals) // 4)), color="tab:blue", alpha=0.8)
            q = np.percentile(vals, [5, 50, 95])
            for v, ls in zip(q, (":", "-", ":")):
                ax.axvline(v, color="k", ls=ls, lw=1)
            ax.set_title(f"{metric}: median {q[1]:.4g}, 5–95 % [{q[0]:.4g}, {q[2]:.4g}], n = {len(vals)} "
                         f"({len(results) - len(ok)} failed)", fontsize=9)
        ax.set_xlabel(metric)
        ax.set_ylabel("simulations")
        paths.append(P.save(fig, os.path.join(out_dir, f"distribution_{metric}.png")))
    return paths


#: the heat map writes each cell's value (and every tick label) only up to this many cells per axis
LABELLED_CELLS = 16


def _tick(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _match(values, v):
    for x in values:
        if x == v or (isinstance(x, (int, float)) and isinstance(v, (int, float)) and math.isclose(x, v, rel_tol=1e-12)):
            return x
    raise ValueError(v)
