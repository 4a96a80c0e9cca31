"""Many simulations at once: N machines, each on its own plant, through the one kernel.

A batch is N independent runs of :func:`mjbench.kernel.run_many` (bit-identical to N single runs,
tests/test_batch.py): each simulation is a :class:`~mjbench.machine.Machine` (built from its own
scenario) with its own MuJoCo data (one compiled model per distinct machine: compiling is what
``multibody.simulate`` does, so the models are the same and derived constants stay consistent)
or its own reduced plant.  The kernel compiles the loop once for the batch's composition and runs
the simulations on it, on threads when compiled (the loop releases the GIL; each run's bits are the
same at any thread count), else one after the other.

A simulation that diverges is marked in ``BatchResult.diverged`` with its time and message, its
rows stop there; the others continue.
"""
from __future__ import annotations

import numpy as np

from .. import kernel
from ..errors import ParameterError, SimulationDiverged
from ..trajectory import Trajectory
from .multibody import DEFAULT_OPTIONS, MultibodyPlant, build_model


# ================================================================= result
class BatchResult:
    """Samples of N simulations: ``data`` (nsim, nrec, ncol) in ``columns`` order, ``nrows``
    valid rows per simulation, ``diverged`` flags with ``t_diverged`` and ``messages``."""

    def __init__(self, record):
        self.record = record
        self.results = getattr(record, "results", None)  # what a consumer returned per run (records not kept)
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


def consumer(consume, backend: str):
    """The kernel's per-run consumer for ``consume(i, trajectory)`` (None passes through)."""
    if consume is None:
        return None

    def on_run(i, rec):
        tr = Trajectory.from_record(rec, backend)  # the run's own record: a view, freed after the call
        tr.meta["sim"] = i
        if rec.diverged[0]:
            tr.meta["diverged"] = rec.messages[0]
        return consume(i, tr)
    return on_run


# ================================================================= models
def _model_key(machine, o):
    """What makes two machines' models the same: the mechanism, every axis's J_eq and z²λ, the options."""
    return (repr(machine.mechanism.describe()), tuple((float(d.J_eq), float(d.crank_damping)) for d in machine.drives),
            repr(sorted(o.items())))


def build_models(machines, options=None):
    """One compiled model per distinct (mechanism, J_eq, damping); list indexed by simulation."""
    o = {**DEFAULT_OPTIONS, **(options or {})}
    cache, models = {}, []
    for i, mc in enumerate(machines):
        k = _model_key(mc, o)
        if mc.mechanism.edits_model:  # per-step model edits (a cam): a model per run
            k = k + (i,)
        if k not in cache:
            cache[k] = build_model(mc, o)[1]
        models.append(cache[k])
    return models


# ================================================================= simulation
def simulate(machines, t_end: float, dt: float | None = None, record_dt: float = 1e-3,
             options: dict | None = None, nthread: int = 0, models=None, progress=None, loop=None,
             consume=None) -> BatchResult:
    """Co-simulate the machines (a list, one per simulation) on MuJoCo for ``t_end`` seconds.

    ``models``: compiled models per simulation (default: :func:`build_models`).  Returns a
    :class:`BatchResult`; use ``.trajectory(i)``.  ``nthread`` is accepted for compatibility."""
    machines = list(machines)
    if not machines:
        raise ParameterError("batch: no simulations")
    o = {**DEFAULT_OPTIONS, **(options or {})}
    if dt is not None:
        o["timestep"] = dt
    kernel.check_times(t_end, float(o["timestep"]), record_dt)
    if models is None:
        models = build_models(machines, o)
    plants = [MultibodyPlant(mc, o, m) for mc, m in zip(machines, models)]
    try:
        rec = kernel.run_many(plants, machines, t_end, record_dt, progress, backend="", loop=loop,
                              consume=consumer(consume, "batch"))
    finally:
        for pl in plants:
            pl.finish()
    rec.meta.pop("div_state", None)
    return BatchResult(rec)


def simulate_one(machine, t_end, **kw) -> Trajectory:
    """Convenience: one machine through the batch (raises like the single run on divergence)."""
    res = simulate([machine], t_end, **kw)
    if res.diverged[0]:
        raise SimulationDiverged("batch " + res.messages[0], t=float(res.t_diverged[0]))
    return res.trajectory(0)


__all__ = ["simulate", "simulate_one", "build_models", "BatchResult"]
