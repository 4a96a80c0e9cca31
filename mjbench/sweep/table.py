"""``results.csv``: written atomically with exact numbers, read back, and the metric a sweep
summarises."""
from __future__ import annotations

import csv
import io

from .. import metrics as M
from ..errors import ParameterError
from ..trajectory import atomic_write
from .spec import FIXED_COLUMNS


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
    metrics of :func:`mjbench.metrics.summary` (χ in the window only with ``metrics.chi_window``).
    Several motors: each axis's (``A:peak_current_A`` …) and the end effector's tracking error."""
    inputs = scn.axes
    if inputs:
        out = {f"{lab}:{k}": f"axis {lab}: {d}" for lab in inputs for k, d in M.SUMMARY_METRICS.items()
               if k != "chi_window"}
        out.update(MULTI_AXIS_METRICS)
        return out
    out = {k: d for k, d in M.SUMMARY_METRICS.items() if k != "chi_window" or scn.metrics.chi_window is not None}
    out["change_points_passed"] = ("how many change points of the mechanism (branches of its assembly meeting) the run "
                                   "passed; only for a mechanism that has any")
    return out


#: the machine-wide metrics of a sweep row of a machine with several motors (a path tracked)
MULTI_AXIS_METRICS = {"end_effector_max_error_m": "largest distance of the end effector from its path [m]",
                      "end_effector_rms_error_m": "RMS distance of the end effector from its path [m]",
                      "end_effector_max_error_last_cycle_m": "largest distance over the last cycle of the path [m]"}


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


# ======================================================================== plots
def plot_metric(results):
    """What the summary plots show when no row has a χ: the mean motor speed (a picture of the
    grid; never a ranking: :func:`default_metric`)."""
    return "mean_motor_speed_rad_s" if any("mean_motor_speed_rad_s" in r for r in results) else None


def default_metric(results):
    """The figure the best rows are ranked by (the smallest) when none is named: a χ, or on a
    machine with several motors the end effector's RMS distance from its path (never a speed,
    which nothing minimises)."""
    for k in ("chi_window", "chi_last_cycle", "chi_steady_mean", "end_effector_rms_error_m"):
        if any(k in r for r in results):
            return k
    return None
