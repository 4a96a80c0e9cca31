"""Many reduced-model simulations at once: N machines, each on its own reduced plant, one kernel.

A batch is N independent runs of :func:`mjbench.kernel.run_many` on
:class:`~mjbench.backends.reduced.ReducedPlant` (RK4 on the tabulated reduced model for rigid
crank mechanisms): the same bits as N single ``reduced.simulate`` runs, each with its own
geometry, masses, drive and gains (tests/test_batch.py).  The kernel compiles the loop once for
the batch's composition (:mod:`mjbench.compiled`) and runs the simulations on it.

Divergence: flagged per simulation (time and message), its rows stop there, the others go on.
"""
from __future__ import annotations

from .. import kernel
from ..errors import ParameterError
from .batch import BatchResult, consumer
from .reduced import ReducedPlant
from .table import composing


def simulate(machines, t_end: float, dt: float | None = None, record_dt: float = 1e-3, options: dict | None = None,
             progress=None, model: str | None = None, loop=None, consume=None, **_ignored) -> BatchResult:
    """Co-simulate the machines' reduced models for ``t_end`` s → :class:`BatchResult`
    (``.trajectory(i)``, ``diverged``, ``messages``).  ``options``: the reduced backend's
    (``timestep``, ``method`` — RK4 only —, ``model``)."""
    machines = list(machines)
    if not machines:
        raise ParameterError("batch: no simulations")
    o = dict(options or {})
    h = float(dt if dt is not None else o.get("timestep", 1e-4))
    if o.get("method", "rk4") != "rk4":
        raise ParameterError(f"reduced.method = {o['method']!r}: the batched reduced backend integrates with RK4 "
                             "(solve_ivp: run the simulations one by one)")
    model = model or o.get("model", "table")
    kernel.check_times(t_end, h, record_dt)

    with composing():  # each mechanism's description key: once for its table and the machine check
        plants = [ReducedPlant(mc, h, "rk4", model=model, record_joints=bool(o.get("record_joints"))) for mc in machines]
        rec = kernel.run_many(plants, machines, t_end, record_dt, progress, backend="reduced", loop=loop,
                              consume=consumer(consume, "reduced"))
    rec.meta.pop("div_state", None)
    return BatchResult(rec)


__all__ = ["simulate"]
