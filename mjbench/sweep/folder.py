"""Running (or resuming) a sweep into its output folder (:func:`run_sweep`)."""
from __future__ import annotations

import contextlib
import json
import os

from .. import outputs
from .. import scenario as S
from ..errors import MjbenchError, ParameterError, ScenarioError
from ..trajectory import atomic_write
from .chunks import run_chunk, settings, verify_best
from .cluster import _run_on_dask, connect
from .plots import summary_plots
from .rows import make_rows
from .spec import RESULTS, SPEC, SweepSpec, auto_chunk
from .table import check_metric, default_metric, read_table, write_table


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
    if metric is None and scn.metrics.chi_window is None and spec.backend != "multibody" and spec.verify > 0:
        # the default ranking is χ in the scenario's window: without one, the "best" rows would be
        # ranked by whatever figure happens to exist (once: the slowest machines, by mean speed)
        raise ParameterError(f"--metric: scenario {scn.name!r} has no metrics.chi_window, so the sweep has no default "
                             f"figure to rank its best rows by before re-running them on MuJoCo; name the figure to "
                             f"minimise, e.g. --metric chi_last_cycle, --metric current_rms_steady_A, --metric "
                             f"torque_output_rms_steady_Nm (or --verify 0)")
    keys = spec.keys()
    st = settings(spec, scn)
    own_client = None
    if client is None and scheduler:
        own_client = client = connect(scheduler)  # one line within a few seconds if nobody answers
    spec_path = os.path.join(out_dir, SPEC)
    table = os.path.join(out_dir, RESULTS)
    spec_json = outputs.dumps(spec.to_json(), sort_keys=True, indent=1)
    results, bar = {}, None
    made = []
    saved = [0]  # rows the table on disk holds (its last complete write): what a failure reports
    try:
        made = outputs._make_parents(outputs.Path(os.path.abspath(out_dir)))
        done = _resume(spec_json, out_dir, spec_path, table)
        pending = [r for r in rows if r["row"] not in done]
        results.update(done)
        saved[0] = len(done)
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=len(rows), initial=len(done), desc="sweep", unit="sim")
        _run_pending(spec, scn, client, pending, keys, st, nthread, results, table, bar, len(rows), len(done), saved)
    except BaseException as e:
        _abandon(e, out_dir, table, spec_path, made, saved[0], len(rows))
        raise
    finally:
        if bar is not None:
            bar.close()
        if own_client is not None:
            own_client.close()
    return _finish(spec, scn, out_dir, table, len(rows), len(pending), keys, st, nthread, metric, plots)


def _resume(spec_json, out_dir, spec_path, table) -> dict:
    """The rows already done in ``out_dir`` ({row: result}) when it holds the same sweep (else a
    ScenarioError); a new folder gets the sweep's specification first."""
    if not os.path.exists(spec_path):
        atomic_write(spec_path, lambda f: f.write(spec_json))
        return {}
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
        return {r["row"]: r for r in read_table(table) if r.get("status") in ("ok", "diverged", "error")}
    return {}


def _run_pending(spec, scn, client, pending, keys, st, nthread, results, table, bar, nrows, ndone, saved) -> None:
    """The pending rows in chunks (locally, or on the Dask cluster), the table rewritten as each
    chunk ends (``saved[0]``: the rows it holds once written)."""
    def collect(chunk_result):
        for r in chunk_result:
            results[r["row"]] = r
        write_table(table, list(results.values()), keys)  # (atomic: all the rows so far, or the old table)
        saved[0] = len(results)
        if bar is not None:
            bar.update(len(chunk_result))

    workers = len(client.scheduler_info().get("workers", {})) if client is not None else 1
    size = max(1, int(spec.chunk_size)) if spec.chunk_size else auto_chunk(len(pending), spec.backend, workers)
    chunks = [pending[i:i + size] for i in range(0, len(pending), size)]
    if client is not None and chunks:
        _run_on_dask(client, scn, chunks, keys, st, nthread, collect, table, nrows, ndone)
    else:
        for ch in chunks:
            collect(run_chunk(scn, ch, keys, st, nthread))
    if not chunks and not os.path.exists(table):
        write_table(table, list(results.values()), keys)


def _abandon(e, out_dir, table, spec_path, made, nsaved, nrows) -> None:
    """After a failure: no folder left behind when nothing was saved; a write error as one
    OutputError saying what is saved (other errors are re-raised by the caller)."""
    if not os.path.exists(table):  # nothing saved yet: leave no folder behind
        if made:
            with contextlib.suppress(OSError):
                os.unlink(spec_path)
        outputs._remove_empty(made)
    if isinstance(e, OSError) and not isinstance(e, MjbenchError):
        saved = f"{nsaved} of {nrows} rows are saved in {table}; the same command resumes" \
            if os.path.exists(table) else "nothing was written"
        raise outputs.OutputError(f"--out {out_dir}: cannot write {os.path.basename(e.filename or '') or 'its files'}"
                                  f" ({e.strerror or e}); {saved}") from None


def _finish(spec, scn, out_dir, table, nrows, nran, keys, st, nthread, metric, plots) -> dict:
    """The sweep's summary: the table, the best rows verified on MuJoCo, the plots, the notes."""
    notes = []
    out = {"table": table, "rows": nrows, "ran": nran, "plots": [], "verified": [], "notes": notes}
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
