"""Batched multibody plant: N simulations of a machine stepped together by ``mujoco.batch``.

The co-step is the kernel's (:mod:`mjbench.kernel`), on arrays of shape (nsim,) for every signal
and every per-simulation parameter; the plant's step is one ``Batch.step()`` — one plain
``mj_step`` per simulation on MuJoCo's thread pool.  Same operations in the same order on the same
numbers as the single run, so the results equal N ``multibody.simulate`` runs to round-off
(bit-identical in practice; tests/test_batch.py).

Per-simulation parameters: each simulation is a :class:`~mjbench.machine.Machine` (built from
its own scenario).  The drives are stacked into one :class:`DCMotorDrive` with (nsim,) arrays
where they differ, the controllers of one class into one controller with (nsim,) gains
(:func:`stack_objects`).  The MuJoCo model of each simulation is compiled from its own machine
(masses, inertias, lengths, reflected drive inertia J_eq as ``armature``, viscous friction as
``damping``): one shared model if all are equal, otherwise ``Batch.set_models`` with one model per
distinct machine — compiling is what ``multibody.simulate`` does, so the models are the same, and
derived constants (``mj_setConst``) stay consistent, which expanding single fields would not
guarantee (``dof_armature`` is a ``mj_setConst`` input).

A simulation that diverges (the single run raises :class:`SimulationDiverged`) is marked in
``BatchResult.diverged`` with its time and message, its rows stop there, and it is no longer
stepped; the others continue.

Closure column: the largest component of the site-to-site offset of every ``connect`` equality
between sites, from ``site_xpos`` of the last forward evaluation (derived fields lag the state by
one substep in ``mujoco.batch``, as with ``mj_step``); NaN if the model has no such equality.
"""
from __future__ import annotations

import copy
import dataclasses
import numbers

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from .. import kernel
from ..errors import ParameterError
from ..mechanisms.base import Mechanism, connect_site_pairs
from ..trajectory import Trajectory
from .multibody import DEFAULT_OPTIONS, _extra_names, build_model, drive_joint, integrator_name


# ================================================================= stacking per-simulation objects
def _is_num(v):
    return isinstance(v, (numbers.Real, np.number)) and not isinstance(v, (bool, np.bool_))


def stack_objects(objs, path="controller"):
    """One object of the common class whose numeric attributes are (nsim,) arrays where the
    objects differ (scalars where they agree).  Nested objects (a controller's reference) are
    stacked recursively; non-numeric attributes (flags, strings, None) must agree."""
    objs = list(objs)
    first = objs[0]
    if all(o is first for o in objs):
        return first
    cls = type(first)
    if any(type(o) is not cls for o in objs):
        raise ParameterError(f"{path}: simulations of one batch need the same class, got "
                             f"{sorted({type(o).__name__ for o in objs})}")
    if dataclasses.is_dataclass(first):
        kw = {}
        for f in dataclasses.fields(first):
            kw[f.name] = _stack_value([getattr(o, f.name) for o in objs], f"{path}.{f.name}")
        return cls(**kw)
    new = copy.copy(first)
    state = set(getattr(first, "STATE", ()))
    for k in vars(first):
        vals = [vars(o).get(k) for o in objs]
        if k.startswith("_") or k in state:
            continue  # internal state: reset() recreates it
        setattr(new, k, _stack_value(vals, f"{path}.{k}"))
    return new


def _stack_value(vals, path):
    v0 = vals[0]
    if all(_is_num(v) for v in vals):
        if all(v == v0 for v in vals):
            return v0
        return np.array(vals, dtype=float)
    if all(isinstance(v, np.ndarray) for v in vals):
        if all(np.array_equal(v, v0) for v in vals):
            return v0
        return np.stack(vals)
    if all(v is v0 for v in vals):
        return v0
    if isinstance(v0, Mechanism):
        if all(type(v) is type(v0) and v == v0 for v in vals):
            return v0
        return PerSimulation(vals)  # model-based controller, per-simulation mechanisms
    if isinstance(v0, (str, bool, type(None), tuple, list, dict)):
        if all(type(v) is type(v0) and v == v0 for v in vals):
            return v0
        raise ParameterError(f"{path}: must be the same in every simulation of a batch, got "
                             f"{vals[:4]}{' ...' if len(vals) > 4 else ''}")
    if hasattr(v0, "__dict__"):
        return stack_objects(vals, path)
    raise ParameterError(f"{path}: cannot vectorise values of type {type(v0).__name__}")


class PerSimulation:
    """Stands in for one object (a mechanism a controller evaluates) when every simulation has its
    own: a method call is dispatched to each simulation's object with its element of every (nsim,)
    array argument, and the results are stacked ((nsim,) arrays, tuples of them).  Slower than a
    vectorised object (one Python call per simulation), exact per simulation."""

    def __init__(self, objs):
        object.__setattr__(self, "_objs", list(objs))

    def __getattr__(self, name):
        objs = self._objs
        attr0 = getattr(objs[0], name)
        if not callable(attr0):
            return _stack_value([getattr(o, name) for o in objs], f"mechanism.{name}")
        n = len(objs)

        def call(*args, **kw):
            outs = []
            for i, o in enumerate(objs):
                a = [x[i] if isinstance(x, np.ndarray) and x.shape[:1] == (n,) else x for x in args]
                a = [float(x) if isinstance(x, np.floating) else x for x in a]
                k = {key: (x[i] if isinstance(x, np.ndarray) and x.shape[:1] == (n,) else x) for key, x in kw.items()}
                outs.append(getattr(o, name)(*a, **k))
            if isinstance(outs[0], tuple):
                return tuple(np.array(c) for c in zip(*outs))
            return np.array(outs)
        return call


def stack_drives(drives):
    """One drive with (nsim,) parameter arrays where the drives differ."""
    return stack_objects(drives, "drive")


# ================================================================= result
class BatchResult:
    """Samples of N simulations: ``data`` (nsim, nrec, ncol) in ``columns`` order, ``nrows``
    valid rows per simulation, ``diverged`` flags with ``t_diverged`` and ``messages``."""

    def __init__(self, record):
        self.record = record
        self.data, self.columns, self.nrows = record.data, record.columns, record.nrows
        self.diverged, self.t_diverged, self.messages = record.diverged, record.t_diverged, record.messages
        self.meta = record.meta

    @property
    def nsim(self):
        return self.data.shape[0]

    def trajectory(self, i) -> Trajectory:
        """Simulation i as a :class:`Trajectory` (a view, no copy)."""
        return Trajectory.from_record(self.record, "batch", i)

    def trajectories(self):
        return [self.trajectory(i) for i in range(self.nsim)]

    def column(self, name):
        """(nsim, nrec) array of one column (NaN after a divergence)."""
        return self.data[:, :, list(self.columns).index(name)]


# ================================================================= models
def _model_key(machine, o):
    d = machine.drive
    return (repr(machine.mechanism.describe()), float(d.J_eq), float(d.crank_damping),
            repr(sorted(o.items())))


def build_models(machines, options=None):
    """One compiled model per distinct (mechanism, J_eq, damping); list indexed by simulation."""
    o = {**DEFAULT_OPTIONS, **(options or {})}
    cache, models = {}, []
    for mc in machines:
        k = _model_key(mc, o)
        if k not in cache:
            cache[k] = build_model(mc, o)[1]
        models.append(cache[k])
    return models


# ================================================================= the plant
class BatchMultibodyPlant:
    """N machines on ``mujoco.batch``; see the kernel's plant protocol (arrays of shape (nsim,))."""

    def __init__(self, machines, models, nthread=0, closure=True):
        self.machines = list(machines)
        self.nsim = n = len(self.machines)
        distinct = list({id(m): m for m in models}.values())
        m0 = self.model = distinct[0]
        self.models = models
        self.h = float(m0.opt.timestep)
        self.b = b = mjbatch.Batch(m0, n, nthread)
        if len(distinct) > 1:
            b.set_models(models)
        mech = self.machines[0].mechanism
        self.mechs = [mc.mechanism for mc in self.machines]
        jnt = m0.joint(mech.input_joint)
        self._qa, self._va = int(jnt.qposadr[0]), int(jnt.dofadr[0])
        self._vd = int(m0.joint(drive_joint(mech)).dofadr[0])  # where the drive torque acts
        self._load = _load_function(self.mechs, models)
        self._pairs = connect_site_pairs(m0) if closure else []
        self._internal = mech.internal_state if mech.internal else None
        self.extra_columns = _extra_names(mech)
        self._bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
        self._ids = None
        self._alive = np.ones(n, dtype=bool)
        self._nan = np.full(n, np.nan)
        self.meta = {"integrator": integrator_name(m0.opt.integrator), "nthread": b.nthread}

    def start(self):
        b = self.b
        b.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)
        self._qpos, self._qvel, self._qfrc = b.bind("qpos"), b.bind("qvel"), b.bind("qfrc_applied")
        self._site_xpos = b.bind("site_xpos") if self._pairs else None
        self._warn = b.warning
        for i, (mc, m) in enumerate(zip(self.machines, self.models)):
            self._qpos[i] = mc.mechanism.initial_qpos(m, mc.q0, mc.x0)
            self._qvel[i] = mc.mechanism.initial_qvel(m, mc.q0, mc.qd0, mc.x0, mc.xd0)
        b.forward()
        self._ids = None
        self._alive[:] = True

    def read(self):
        return self._qpos[:, self._qa].copy(), self._qvel[:, self._va].copy()

    def speed(self):
        return self._qvel[:, self._va]

    def advance(self, tau, t):
        self._qfrc[:, self._vd] = tau
        if self._load is not None:
            self._load(self._qpos, self._qvel, self._qfrc, t, self._alive)
        self.b.step(self._ids)
        return self._qpos[:, self._qa].copy(), self._qvel[:, self._va].copy()

    def closure(self):
        if not self._pairs:
            return self._nan
        sx = self._site_xpos
        return np.max([np.max(np.abs(sx[:, a] - sx[:, c]), axis=1) for a, c in self._pairs], axis=0)

    def unstable(self):
        return self._warn[:, self._bad, 1] > 0

    def extra(self, out):
        x, xd = self._internal(self.model, self._qpos, self._qvel)
        k = len(x)
        for j in range(k):
            out[j] = x[j]
            out[k + j] = xd[j]

    def retire(self, dead):
        self._alive[:] = ~dead
        self._ids = np.flatnonzero(self._alive).astype(np.int32)


# ================================================================= simulation
def simulate(machines, t_end: float, dt: float | None = None, record_dt: float = 1e-3,
             options: dict | None = None, nthread: int = 0, models=None, progress=None,
             closure: bool = True, single_fast_path: bool = True) -> BatchResult:
    """Co-simulate the machines (a list, one per simulation) together for ``t_end`` seconds.

    ``nthread``: MuJoCo batch threads (0: all CPUs).  ``models``: compiled models per simulation
    (default: :func:`build_models`).  Returns a :class:`BatchResult`; use ``.trajectory(i)``.

    One simulation (``nsim == 1``) goes through the single-run plant of ``multibody`` (same
    numbers; scalar floats cost a fifth of 1-element arrays) unless ``single_fast_path`` is
    False; a divergence there leaves no rows (the single run raises before returning them)."""
    machines = list(machines)
    nsim = len(machines)
    if nsim == 0:
        raise ParameterError("batch: no simulations")
    o = {**DEFAULT_OPTIONS, **(options or {})}
    if dt is not None:
        o["timestep"] = dt
    h = float(o["timestep"])
    kernel.check_times(t_end, h, record_dt)
    if models is None:
        models = build_models(machines, o)
    distinct = list({id(m): m for m in models}.values())
    m0 = distinct[0]
    for m in distinct[1:]:
        if (m.nq, m.nv, m.nbody, m.neq, m.nsite, m.nu, m.na) != (m0.nq, m0.nv, m0.nbody, m0.neq, m0.nsite, m0.nu, m0.na):
            raise ParameterError("batch: the simulations' models differ in structure (number of bodies, "
                                 "joints, equalities ...); run them in separate batches")
        if m.opt.timestep != m0.opt.timestep:
            raise ParameterError("batch: every simulation needs the same time step")
    if nsim == 1 and single_fast_path:
        return _single(machines[0], t_end, record_dt, o, models[0], progress)
    drive = stack_drives([mc.drive for mc in machines])
    ctrl = stack_objects([mc.controller for mc in machines])
    if ctrl is machines[0].controller and nsim > 1:
        ctrl = copy.copy(ctrl)  # same object in every machine: one vectorised copy
    plant = BatchMultibodyPlant(machines, models, nthread, closure)
    I0 = np.array([float(mc.I0) for mc in machines])
    rec = kernel.run(plant, drive, ctrl, t_end, record_dt, I0, progress, backend="")
    return BatchResult(rec)


def _single(machine, t_end, record_dt, o, model, progress):
    from . import fused
    from .multibody import MultibodyPlant

    plant = MultibodyPlant(machine, o, model)
    rec = fused.try_multibody(plant, t_end, record_dt, progress)  # the compiled loop around mj_step: the same bits
    try:
        if rec is None:
            rec = kernel.run(plant, machine.drive, machine.controller, t_end, record_dt, machine.I0, progress,
                             backend="")
    except kernel.SimulationDiverged as e:
        nrec = int(round(t_end / plant.h)) // max(1, int(round(record_dt / plant.h))) + 1
        cols = kernel.NAMES + plant.extra_columns
        rec = kernel.Record(np.full((nrec, len(cols)), np.nan), cols, np.zeros(1, dtype=int), None, None, None,
                            {"dt": plant.h, **plant.meta})
        rec.diverged, rec.t_diverged, rec.messages = np.array([True]), np.array([e.t if e.t is not None else np.nan]), [str(e)]
    else:
        rec.diverged, rec.t_diverged, rec.messages = np.array([False]), np.array([np.nan]), [""]
    rec.data = rec.data[None]
    rec.meta = {**rec.meta, "nsim": 1, "nthread": 1}
    return BatchResult(rec)


class _RowsView:
    """Stands in for an MjData in ``multibody_load``: ``qpos``, ``qvel``, ``qfrc_applied`` are the
    transposed state rows, so ``data.qvel[dof]`` is the (nsim,) column and writes go to the rows."""

    def __init__(self, qpos, qvel, qfrc, t):
        self.qpos, self.qvel, self.qfrc_applied, self.time = qpos.T, qvel.T, qfrc.T, t


def _load_function(mechs, models):
    """Vectorised external loads (``Mechanism.multibody_load``), in order of preference:
    the single-run ``multibody_load`` called once on the (nv, nsim) columns of the state rows
    (:class:`_RowsView`) when every simulation has the same mechanism and the load is written with
    elementwise arithmetic (probed on the first step); else ``multibody_load`` per simulation on a
    scratch MjData holding qpos, qvel, qfrc_applied and time (a load that reads other, derived,
    fields is not supported by the batch)."""
    mech = mechs[0]
    if not mech.has_multibody_load():
        return None
    scratch = [mujoco.MjData(m) for m in models]

    def per_sim(qpos, qvel, qfrc, t, alive):
        for i in np.flatnonzero(alive):
            d = scratch[i]
            d.qpos[:] = qpos[i]
            d.qvel[:] = qvel[i]
            d.qfrc_applied[:] = qfrc[i]
            d.time = t
            mechs[i].multibody_load(models[i], d, t)
            qfrc[i] = d.qfrc_applied

    same = all(m is mech for m in mechs) or len({repr(m.describe()) for m in mechs}) == 1
    if not same:
        return per_sim
    state = {"f": None}

    def columns(qpos, qvel, qfrc, t, alive):
        mech.multibody_load(models[0], _RowsView(qpos, qvel, qfrc, t), t)

    def probe(qpos, qvel, qfrc, t, alive):
        if state["f"] is None:
            q2, v2, f2 = qpos.copy(), qvel.copy(), qfrc.copy()
            f3 = qfrc.copy()
            try:
                columns(q2, v2, f2, t, alive)
                per_sim(qpos.copy(), qvel.copy(), f3, t, alive)
                ok = np.array_equal(f2, f3)
            except (TypeError, ValueError, IndexError):
                ok = False
            state["f"] = columns if ok else per_sim
        state["f"](qpos, qvel, qfrc, t, alive)
    return probe


def simulate_one(machine, t_end, **kw) -> Trajectory:
    """Convenience: one machine through the batch (raises like the single run on divergence)."""
    res = simulate([machine], t_end, **kw)
    if res.diverged[0]:
        from ..errors import SimulationDiverged
        raise SimulationDiverged("batch " + res.messages[0], t=float(res.t_diverged[0]))
    return res.trajectory(0)


__all__ = ["simulate", "simulate_one", "stack_objects", "stack_drives", "build_models", "BatchResult",
           "PerSimulation"]
