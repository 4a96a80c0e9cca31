"""Simulator backends: ``multibody`` (MuJoCo) and ``reduced`` (Eksergian ODE), same inputs/outputs.

One run: :func:`simulate` (``multibody.simulate`` / ``reduced.simulate``).  Many runs at once:
:func:`simulate_many` (``batch.simulate`` on ``mujoco.batch`` / ``reduced_batch.simulate``), both
returning a :class:`~mjbench.backends.batch.BatchResult` whose runs equal the single runs."""
from . import multibody, reduced

BACKENDS = {"multibody": multibody.simulate, "reduced": reduced.simulate}
#: the design loops' choices: search on the reduced model, verify on MuJoCo (docs/performance.md)
SEARCH_BACKENDS = ("reduced", "multibody")
#: below this many runs, ``simulate_many`` on MuJoCo runs them one by one: ``mujoco.batch`` with a
#: thread pool for 3 runs cost 1.44 s of CPU where 3 single runs cost 0.6 s (seed 000, 0.5 s)
MB_SINGLES_BELOW = 8


def _merge(results):
    """One BatchResult from single-simulation BatchResults (same columns and record length)."""
    import numpy as np

    from .. import kernel
    from .batch import BatchResult

    recs = [r.record for r in results]
    r0 = recs[0]
    rec = kernel.Record(np.concatenate([r.data for r in recs]), r0.columns,
                        np.concatenate([np.asarray(r.nrows) for r in recs]),
                        np.concatenate([r.diverged for r in recs]), np.concatenate([r.t_diverged for r in recs]),
                        [m for r in recs for m in r.messages], {**r0.meta, "nsim": len(recs)})
    return BatchResult(rec)


def _check(backend):
    if backend not in BACKENDS:
        from ..errors import ParameterError
        raise ParameterError(f"backend = {backend!r}: choose one of {sorted(BACKENDS)}")


def simulate(machine, backend: str, t_end: float, **kw):
    """Run ``machine`` on the named backend; see each backend's ``simulate`` for options."""
    _check(backend)
    return BACKENDS[backend](machine, t_end, **kw)


def simulate_many(machines, backend: str, t_end: float, record_dt: float = 1e-3, options=None, nthread: int = 0,
                  progress=None):
    """Run a list of machines together on the named backend's batch → ``BatchResult``.

    ``options``: the backend's options (``runner.backend_options``); the reduced batch integrates
    with RK4 (a scenario's ``solve_ivp`` method is replaced by RK4 here)."""
    _check(backend)
    if backend == "multibody":
        from . import batch
        machines = list(machines)
        if 1 < len(machines) < MB_SINGLES_BELOW:  # a few runs: single runs cost less (same numbers)
            return _merge([batch.simulate([mc], t_end, record_dt=record_dt, options=options, progress=progress)
                           for mc in machines])
        return batch.simulate(machines, t_end, record_dt=record_dt, options=options, nthread=nthread,
                              progress=progress)
    from . import reduced_batch
    o = {**(options or {}), "method": "rk4"}
    return reduced_batch.simulate(machines, t_end, record_dt=record_dt, options=o, progress=progress)
