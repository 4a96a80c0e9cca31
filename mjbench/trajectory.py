"""Simulation results: preallocated columns, SI units in the names, written atomically."""
from __future__ import annotations

import numpy as np

from .outputs import atomic_write  # noqa: F401 - the one atomic writer (0644, UTF-8), re-exported

#: columns every backend records, in CSV order (name, meaning)
COLUMNS = (
    ("t_s", "time"),
    ("crank_angle_rad", "input (crank) angle α, unwrapped"),
    ("crank_speed_rad_s", "crank speed α̇"),
    ("crank_accel_rad_s2", "crank acceleration α̈ at the sample's state"),
    ("motor_speed_rad_s", "motor speed φ̇ = z·α̇"),
    ("current_A", "armature current I"),
    ("voltage_V", "armature voltage V_a after the limiter"),
    ("torque_crank_Nm", "drive torque on the crank (Eq 9 without J_eq·α̈)"),
    ("power_mech_W", "mechanical power converted by the motor k_m·I·φ̇"),
    ("power_elec_W", "electrical power V_a·I"),
    ("closure_error_m", "largest loop-closure violation (multibody; 0 for the reduced model)"),
)
NAMES = tuple(c[0] for c in COLUMNS)
INDEX = {n: i for i, n in enumerate(NAMES)}


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

    @classmethod
    def from_record(cls, rec, backend: str, i: int | None = None) -> "Trajectory":
        """Run ``i`` of a :class:`mjbench.kernel.Record` (a view, no copy); ``i=None`` for a single run."""
        tr = cls.__new__(cls)
        tr.columns = tuple(rec.columns)
        tr.index = {c: j for j, c in enumerate(tr.columns)}
        n = int(rec.nrows[0 if i is None else i])
        tr.data = (rec.data if i is None else rec.data[i])[:n]
        tr.n = n
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
        """Write the CSV completely or not at all (temp file + atomic rename)."""
        header = ",".join(self.columns)
        atomic_write(path, lambda f: np.savetxt(f, self.data[: self.n], delimiter=",", header=header,
                                                comments="", fmt="%.10g"))

    @classmethod
    def read_csv(cls, path, backend="csv"):
        with open(path) as f:
            cols = f.readline().strip().split(",")
        arr = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
        tr = cls(len(arr), backend, columns=cols)
        tr.data[:] = arr
        tr.n = len(arr)
        return tr
