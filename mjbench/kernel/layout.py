"""The kernel's data layout, declared once: its state between chunks, the record's columns, the
interval statistics and the signal array's indices, as the named constants the loop reads.

A machine has ``naxes`` axes (input coordinates, each with its drive).  Each layout is a global
part and one block per axis; the loop (:mod:`mjbench.kernel.loop`) reads every offset from the
constants :func:`constants` returns (numba folds them; CPython looks them up), so a name below is
the only place a position is written.

Record of one sample (``out`` row, :data:`mjbench.trajectory.COLUMNS` for one axis)::

    t | per axis: q, q̇, q̈, φ̇, drive's 5 columns | closure | plant columns | per axis: drive-train columns

Interval statistics (``stats`` row, one per record row, never written to CSV): per axis and for
each of :data:`STAT_SIGNALS`, the largest and smallest value over the co-steps since the previous
row and when they occurred.  Extremum metrics (χ, peaks) are computed from them, so they do not
depend on how densely a run is recorded (:func:`mjbench.metrics.window_extrema`).
"""
from __future__ import annotations

from .. import signals as SIG
from ..trajectory import NAMES

#: kernel state of the whole run between chunks (float64 ``ks``): the next record row
KS_GLOBAL = ("k",)
#: per axis: the state (q, q̇, the previous q̇, I), the held command u, the compliant gear's deflection
#: and rate, the applied voltage over the last step, its mean current, the current's extremes over the
#: step (switching PWM), the measurement, the delayed command, the current loop's output, the torque
#: applied over the last step; then the interval statistics' accumulators (:data:`STAT_FIELDS`)
KS_AXIS_STATE = ("q", "qd", "qd_prev", "I", "u", "dm", "dmd", "Vb", "Ibar", "ilo", "ihi", "qm", "qdm", "qddm",
                 "pend", "V", "tq")
#: the recorded signals whose extremes every co-step updates: the motor speed φ̇ = z·(q̇ + δ̇), the current,
#: the voltage and the torque applied over each step (record names in :data:`STAT_COLUMNS`)
STAT_SIGNALS = ("w", "I", "Vb", "tq")
STAT_COLUMNS = {"w": "motor_speed_rad_s", "I": "current_A", "Vb": "voltage_applied_V", "tq": "torque_applied_Nm"}
#: per statistic signal: its largest value, when, its smallest value, when
STAT_FIELDS = ("max", "t_max", "min", "t_min")
KS_AXIS = KS_AXIS_STATE + tuple(f"{s}_{f}" for s in STAT_SIGNALS for f in STAT_FIELDS)

#: the divergence record: flag, time, then q, q̇, I, u of the axis that diverged, and its index
DIV_FIELDS = ("flag", "t", "q", "qd", "I", "u", "axis")

#: one axis's core record block (offsets from the block's start): the first four, then the drive's five
REC_AXIS = ("q", "qd", "qdd", "w")
NDRIVE_COLS = 5
#: the core columns of one axis in trajectory.COLUMNS (after t_s, before closure_error_m)
CORE_AXIS_NAMES = NAMES[1:10]


def ks_size(naxes: int) -> int:
    return len(KS_GLOBAL) + naxes * len(KS_AXIS)


def ks_index(name: str, axis: int = 0) -> int:
    """Index of a kernel-state entry (a global one, or ``name`` of ``axis``)."""
    if name in KS_GLOBAL:
        return KS_GLOBAL.index(name)
    return len(KS_GLOBAL) + axis * len(KS_AXIS) + KS_AXIS.index(name)


#: the kernel state a run starts from, per axis: these entries (:class:`mjbench.kernel.running.Stepper`
#: gives each its value by name), the rest zero; their indices in axis 0's block (axis a: + a·len(KS_AXIS))
KS_START = ("q", "qd", "qd_prev", "I", "dm", "dmd", "qm", "qdm", "w_max", "w_min", "w_t_max", "w_t_min", "I_max",
            "I_min", "I_t_max", "I_t_min", "Vb_max", "Vb_min", "tq_max", "tq_min", "Vb_t_max", "Vb_t_min",
            "tq_t_max", "tq_t_min")
KS_START_INDEX = tuple(ks_index(n, 0) for n in KS_START)


def stat_names(naxes: int, labels=None) -> tuple:
    """Names of the statistics columns: ``<record column>:<field>`` per axis (one axis: unlabelled)."""
    out = []
    for a in range(naxes):
        for s in STAT_SIGNALS:
            col = axis_column(STAT_COLUMNS[s], a, naxes, labels)
            out += [f"{col}:{f}" for f in STAT_FIELDS]
    return tuple(out)


def axis_column(name: str, axis: int, naxes: int, labels=None) -> str:
    """The record name of an axis's column: the one-axis name itself, or ``<label>:<name>`` with the
    axis's label (its input joint) on a machine with several axes."""
    if naxes == 1:
        return name
    lab = labels[axis] if labels else str(axis)
    return f"{lab}:{name}"


class RecordLayout:
    """Where each column of a record row is: the core columns, the plant's, each axis's drive-train
    columns; the names in order (:attr:`columns`)."""

    def __init__(self, naxes: int, plant_columns=(), train_columns=None, labels=None):
        self.naxes = naxes
        cols = ["t_s"]
        self.axis_offset = []
        for a in range(naxes):
            self.axis_offset.append(len(cols))
            cols += [axis_column(n, a, naxes, labels) for n in CORE_AXIS_NAMES]
        self.closure = len(cols)
        cols.append("closure_error_m")
        self.extra = len(cols)
        cols += list(plant_columns)
        self.train_offset = []
        for a in range(naxes):
            self.train_offset.append(len(cols))
            cols += [axis_column(n, a, naxes, labels) for n in (train_columns[a] if train_columns else ())]
        self.columns = tuple(cols)
        self.stats = stat_names(naxes, labels)


def constants(naxes: int, nctrl: int, layout: RecordLayout) -> dict:
    """The loop's layout constants for a composition (globals of the loop's module)."""
    c = {"KS_K": ks_index("k"), "C_T": 0, "C_CLOSURE": layout.closure, "C_EXTRA": layout.extra,
         "C_Q": 0, "C_QD": 1, "C_QDD": 2, "C_W": 3, "C_DRV": 4, "SI_T": SIG.index("t"),
         "NSTAT_AXIS": len(STAT_SIGNALS) * len(STAT_FIELDS)}
    for i, name in enumerate(KS_AXIS):
        c["KS_" + name.upper()] = i
    for a in range(naxes):
        c[f"KA_{a}"] = ks_index(KS_AXIS[0], a)
        c[f"CA_{a}"] = layout.axis_offset[a]
        c[f"CT_{a}"] = layout.train_offset[a]
        c[f"SA_{a}"] = a * c["NSTAT_AXIS"]
        for sig, const in (("q", "SQ"), ("qd", "SQD"), ("qdd", "SQDD"), ("I", "SI"), ("V", "SV"), ("tau", "STAU"),
                           ("u_held", "SUH"), ("u", "SU"), ("u_min", "SUMIN"), ("u_max", "SUMAX")):
            c[f"{const}_{a}"] = SIG.index(sig, a)
    return c


__all__ = ["KS_GLOBAL", "KS_AXIS", "KS_START", "KS_START_INDEX", "KS_AXIS_STATE", "STAT_SIGNALS", "STAT_COLUMNS", "STAT_FIELDS", "DIV_FIELDS",
           "ks_size", "ks_index", "stat_names", "axis_column", "RecordLayout", "constants", "NDRIVE_COLS"]
