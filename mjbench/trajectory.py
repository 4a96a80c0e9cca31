"""Simulation results: preallocated columns, SI units in the names, written atomically.

CSV files (:meth:`Trajectory.write_csv`) hold every value at full precision: Python's ``repr``
of each float64, the shortest decimal that reads back as the same number (``0.033``, not
``0.033000000000000002``; at most 17 significant digits), so the reduced backend's 1e-9 agreement
with a reference survives the file and :meth:`Trajectory.read_csv` gives back the same bits; NaN
and ±inf are written ``nan``, ``inf``, ``-inf``.
"""
from __future__ import annotations

import numpy as np

from .outputs import atomic_write  # noqa: F401 - the one atomic writer (0644, UTF-8), re-exported

#: columns every backend records, in CSV order (name, meaning).  The drive's five columns depend on
#: its type (``[drive] type``, :mod:`mjbench.drives`): a DC motor records its electrics; the ideal
#: torque and speed sources have none (``current_A``, ``voltage_V``, ``power_elec_W`` are NaN: not
#: modelled) and record the torque they apply and the power they deliver.
COLUMNS = (
    ("t_s", "time"),
    ("crank_angle_rad", "input (crank) angle α, unwrapped"),
    ("crank_speed_rad_s", "crank speed α̇"),
    ("crank_accel_rad_s2", "crank acceleration: the mean α̈ over a step next to the sample — row n ≥ 1 "
                           "the backward difference (α̇_n − α̇_{n−1})/h of the step ending there (what a digital "
                           "controller sees), row 0 (t = 0) the forward difference (α̇_1 − α̇_0)/h of the first step "
                           "(h the co-simulation step; both α̈ + O(h))"),
    ("motor_speed_rad_s", "motor speed φ̇ = z·α̇ (ideal drives: z = 1, the input speed)"),
    ("current_A", "armature current I (ideal drives: NaN)"),
    ("voltage_V", "armature voltage V_a applied by the amplifier, after the limiter (ideal drives: NaN)"),
    ("torque_crank_Nm", "drive torque on the crank without J_eq·α̈, its viscous part included (DC motor: "
                        "Eq 9; torque source: the commanded torque − damping·α̇; speed source: "
                        "k_v·(ω* − α̇) + k_i·∫(ω* − α̇)dt)"),
    ("power_mech_W", "mechanical power converted by the motor k_m·I·φ̇ (ideal drives: the power the source "
                     "delivers, T·α̇, before its own viscous loss)"),
    ("power_elec_W", "electrical power V_a·I (ideal drives: NaN)"),
    ("closure_error_m", "largest loop-closure violation (multibody; 0 for the reduced model)"),
)
# Optional columns follow the core ones, in this order: a plant's internal coordinates
# (``<name>_rad``, ``<name>_rate_rad_s``); with ``[simulation] record_joints`` every MuJoCo joint
# (``joint_<name>_rad`` and ``joint_<name>_rate_rad_s`` for a hinge, ``joint_<name>_m`` and
# ``joint_<name>_rate_m_s`` for a slide: mjbench.backends.joints); then the drive train's
# (``angle_meas_rad``, ``speed_est_rad_s``, ``accel_est_rad_s2``, ``voltage_bridge_V``,
# ``current_mean_A``, ``current_min_A``, ``current_max_A``, ``current_ref_A``: docs/drivetrain.md).
NAMES = tuple(c[0] for c in COLUMNS)
#: axis labels of the core columns: the quantity, its symbol and its unit
LABELS = {
    "t_s": "time t [s]", "crank_angle_rad": "crank angle α [rad]", "crank_speed_rad_s": "crank speed α̇ [rad/s]",
    "crank_accel_rad_s2": "crank acceleration α̈ [rad/s²]", "motor_speed_rad_s": "motor speed φ̇ [rad/s]",
    "current_A": "armature current I [A]", "voltage_V": "armature voltage V_a [V]",
    "torque_crank_Nm": "drive torque on the crank [N·m]", "power_mech_W": "mechanical power k_m·I·φ̇ [W]",
    "power_elec_W": "electrical power V_a·I [W]", "closure_error_m": "loop-closure error [m]",
}
#: column-name suffix → unit, longest first (the SI naming of every column)
UNITS = (("_rad_s2", "rad/s²"), ("_rate_rad_s", "rad/s"), ("_rad_s", "rad/s"), ("_m_s", "m/s"), ("_rad", "rad"),
         ("_Nm", "N·m"), ("_s", "s"), ("_V", "V"), ("_A", "A"), ("_W", "W"), ("_J", "J"), ("_m", "m"), ("_N", "N"))


def column_label(name: str) -> str:
    """An axis label for a column: its quantity and unit ("crank speed α̇ [rad/s]" for
    ``crank_speed_rad_s``; other columns from their SI name: ``joint_B_rate_rad_s`` → "joint B
    rate [rad/s]")."""
    if name in LABELS:
        return LABELS[name]
    if name.startswith("joint_"):  # [simulation] record_joints: a hinge's angle or a slide's position
        for suf, what in (("_rate_rad_s", "rate [rad/s]"), ("_rate_m_s", "speed [m/s]"), ("_rad", "angle [rad]"),
                          ("_m", "position [m]")):
            if name.endswith(suf):
                return f"joint {name[6:-len(suf)]} {what}"
    for suf, unit in UNITS:
        if name.endswith(suf) and len(name) > len(suf):
            stem = name[: -len(suf)] + ("_rate" if suf == "_rate_rad_s" else "")
            return f"{stem.replace('_', ' ')} [{unit}]"
    return name.replace("_", " ")
INDEX = {n: i for i, n in enumerate(NAMES)}
#: rows written per chunk of a CSV file
CSV_CHUNK = 10_000


class Trajectory:
    """Decimated samples of one simulation: ``data`` is (n, ncol) in ``columns`` order (the core
    :data:`NAMES`, then any plant-specific columns such as a platform's deflection); columns by
    name (``traj["current_A"]``) or attribute (``traj.current``)."""

    def __init__(self, n: int, backend: str, meta: dict | None = None, columns=NAMES):
        self.columns = tuple(columns)
        self.index = {c: i for i, c in enumerate(self.columns)}
        self.data = np.full((n, len(self.columns)), np.nan)
        self.n = 0
        self.backend = backend
        self.meta = dict(meta or {})
        self.stats, self.stat_columns = None, ()

    @classmethod
    def from_record(cls, rec, backend: str, i: int | None = None) -> "Trajectory":
        """Run ``i`` of a :class:`mjbench.kernel.Record` (a view, no copy); ``i=None`` for a single run."""
        tr = cls.__new__(cls)
        tr.columns = tuple(rec.columns)
        tr.index = {c: j for j, c in enumerate(tr.columns)}
        n = int(rec.nrows[0 if i is None else i])
        tr.data = (rec.data if i is None else rec.data[i])[:n]
        tr.n = n
        st = getattr(rec, "stats", None)
        tr.stats = None if st is None else (st if i is None else st[i])[:n]
        tr.stat_columns = tuple(getattr(rec, "stat_columns", ()))
        tr.backend = backend
        tr.meta = dict(rec.meta)
        if i is not None:
            tr.meta["sim"] = int(i)
            if rec.diverged[i]:
                tr.meta["diverged"] = rec.messages[i]
        return tr

    # buffer access used by the backends' loops
    def row(self):
        r = self.data[self.n]
        self.n += 1
        return r

    def trim(self):
        self.data = self.data[: self.n]
        return self

    def __getitem__(self, name):
        try:
            return self.data[: self.n, self.index[name]]
        except KeyError:
            raise KeyError(f"trajectory has no column {name!r}; columns: {', '.join(self.columns)}") from None

    def has(self, name) -> bool:
        return name in self.index

    @property
    def axes(self) -> tuple:
        """The axis labels of a run of a machine with several motors (columns ``label:name``); ()
        for one axis."""
        return tuple(self.meta.get("axes") or ())

    def axis(self, label: str) -> "Trajectory":
        """One axis of a multi-axis run as a one-axis trajectory (a view: its ``label:`` columns under
        their one-axis names, with t_s and the closure; its statistics likewise)."""
        pre = f"{label}:"
        if not any(c.startswith(pre) for c in self.columns):
            raise KeyError(f"trajectory has no axis {label!r}; axes: {', '.join(self.axes) or 'one (unlabelled)'}")
        keep = [i for i, c in enumerate(self.columns) if c.startswith(pre) or ":" not in c]
        tr = Trajectory.__new__(Trajectory)
        tr.columns = tuple(self.columns[i][len(pre):] if self.columns[i].startswith(pre) else self.columns[i]
                           for i in keep)
        tr.index = {c: j for j, c in enumerate(tr.columns)}
        tr.data = self.data[:self.n][:, keep]
        tr.n, tr.backend = self.n, self.backend
        tr.meta = {k: v for k, v in self.meta.items() if k not in ("axes",)}
        zs = self.meta.get("z_axes")
        if zs is not None and label in self.axes:
            tr.meta["z"] = zs[self.axes.index(label)]
        if self.stats is not None:
            sk = [i for i, c in enumerate(self.stat_columns) if c.startswith(pre)]
            tr.stats = self.stats[:self.n][:, sk]
            tr.stat_columns = tuple(self.stat_columns[i][len(pre):] for i in sk)
        else:
            tr.stats, tr.stat_columns = None, ()
        return tr

    def stat(self, name):
        """A column of the interval statistics (``"crank_speed_rad_s:max"`` …; :mod:`mjbench.kernel.layout`):
        per record row, the extreme over every co-step since the previous row.  None when the run
        has none (a trajectory read from CSV)."""
        if self.stats is None or name not in self.stat_columns:
            return None
        return self.stats[: self.n, self.stat_columns.index(name)]

    t = property(lambda s: s["t_s"])
    q = property(lambda s: s["crank_angle_rad"])
    qd = property(lambda s: s["crank_speed_rad_s"])
    qdd = property(lambda s: s["crank_accel_rad_s2"])
    omega = property(lambda s: s["motor_speed_rad_s"])
    current = property(lambda s: s["current_A"])
    voltage = property(lambda s: s["voltage_V"])
    p_mech = property(lambda s: s["power_mech_W"])
    p_elec = property(lambda s: s["power_elec_W"])
    closure = property(lambda s: s["closure_error_m"])

    def write_csv(self, path):
        """Write the CSV completely or not at all (temp file + atomic rename), every value at full
        precision (the shortest ``repr`` that round-trips: re-reading gives the same float64 bits)."""
        rows = np.asarray(self.data[: self.n], dtype=np.float64).tolist()

        def write(f):
            f.write(",".join(self.columns) + "\n")
            for i in range(0, len(rows), CSV_CHUNK):
                f.write("".join(",".join(map(repr, r)) + "\n" for r in rows[i:i + CSV_CHUNK]))
        atomic_write(path, write)

    @classmethod
    def read_csv(cls, path, backend="csv"):
        """A trajectory CSV written by :meth:`write_csv` (the same floats, bit for bit)."""
        with open(path) as f:
            cols = f.readline().strip().split(",")
        arr = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=np.float64)
        tr = cls(len(arr), backend, columns=cols)
        tr.data[:] = arr
        tr.n = len(arr)
        return tr
