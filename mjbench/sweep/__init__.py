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
:mod:`mjbench.backends.reduced_batch`) or ``multibody`` (:mod:`mjbench.backends.batch`: one MuJoCo model per
distinct row where masses or geometry differ) — the same pure function locally and on a Dask
worker, so the table is identical either way (tests/test_sweep.py).  With the reduced backend the
``verify`` best rows (by the summary metric) are then re-run on the multibody backend and
written to ``verify.csv`` with both figures and their difference (:func:`verify_best`).

Output folder: ``sweep.json`` (the specification), ``results.csv`` (one row per simulation:
``row``, the swept keys, ``status`` (ok | diverged | error), the metrics of
:func:`mjbench.metrics.summary` and ``message``), rewritten atomically after every chunk; and
summary plots.  A rerun with the same specification skips the rows already in the table.

Layout (every public name importable from ``mjbench.sweep``): ``spec`` (the specification and its
limits), ``rows`` (rows and their scenarios), ``chunks`` (running a chunk; verification),
``table`` (results.csv), ``cluster`` (Dask), ``plots`` (summary plots), ``folder``
(:func:`run_sweep`: the output folder, resumption).
"""
from __future__ import annotations

from .spec import (
    RESULTS, SPEC, VERIFY, FIXED_COLUMNS, SweepSpec, CHUNK_MAX, auto_chunk, MAX_ROWS, ROW_BYTES, max_rows,
    check_size, parse_grid, parse_perturb)
from .rows import make_rows, row_scenario, WHOLE_VALIDATION, RowScenarios
from .table import write_table, read_table, sweep_metrics, check_metric, default_metric
from .chunks import settings, row_metrics, run_chunk, verify_best
from .cluster import check_scheduler, CONNECT_TIMEOUT, connect, DASK_RETRIES, ship_scenario, scatter_scenario
from .plots import summary_plots, LABELLED_CELLS
from .folder import run_sweep

__all__ = [
    "RESULTS", "SPEC", "VERIFY", "FIXED_COLUMNS", "SweepSpec", "CHUNK_MAX", "auto_chunk", "MAX_ROWS",
    "ROW_BYTES", "max_rows", "check_size", "parse_grid", "parse_perturb", "make_rows", "row_scenario",
    "WHOLE_VALIDATION", "RowScenarios", "write_table", "read_table", "sweep_metrics", "check_metric",
    "default_metric", "settings", "row_metrics", "run_chunk", "verify_best", "check_scheduler",
    "CONNECT_TIMEOUT", "connect", "DASK_RETRIES", "ship_scenario", "scatter_scenario", "summary_plots",
    "LABELLED_CELLS", "run_sweep"]
