"""What to sweep: the specification (:class:`SweepSpec`), the grid and perturbation syntax of the
CLI, the chunk size and the row-count limits."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from .. import environment
from .. import scenario as S
from ..errors import ParameterError, ScenarioError
from ..kernel import memory_limit


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
    n = environment.max_sweep_rows()  # (checked: a whole number >= 1, else an error naming it)
    return MAX_ROWS if n is None else n


def check_size(nrows: int, detail: str = "") -> None:
    """Refuse, before anything runs, a sweep of more rows than :func:`max_rows` or than half the
    available memory holds (ROW_BYTES each)."""

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
            raise ScenarioError(f"--perturb {item!r}: the relative half-width must be a finite number >= 0")
        if r >= 1:
            raise ScenarioError(f"--perturb {item!r}: a half-width of {100 * r:g} % can change the value's sign "
                                f"(factor 1 ± r); use less than 100 %")
        out[key] = r
    return out
