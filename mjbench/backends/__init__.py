"""Simulator backends: ``multibody`` (MuJoCo) and ``reduced`` (Eksergian ODE), same inputs/outputs.

One run: :func:`simulate` (``multibody.simulate`` / ``reduced.simulate``).  Many runs at once:
:func:`simulate_many` (``batch.simulate`` / ``reduced_batch.simulate``), both returning a
:class:`~mjbench.backends.batch.BatchResult` whose runs equal the single runs."""
from . import multibody, reduced
from ..errors import ParameterError
from . import batch, reduced_batch

BACKENDS = {"multibody": multibody.simulate, "reduced": reduced.simulate}
#: the design loops' choices: search on the reduced model, verify on MuJoCo (docs/performance.md)
SEARCH_BACKENDS = ("reduced", "multibody")


def _check(backend):
    if backend not in BACKENDS:
        raise ParameterError(f"backend = {backend!r}: choose one of {sorted(BACKENDS)}")


def simulate(machine, backend: str, t_end: float, **kw):
    """Run ``machine`` on the named backend; see each backend's ``simulate`` for options."""
    _check(backend)
    return BACKENDS[backend](machine, t_end, **kw)


def simulate_many(machines, backend: str, t_end: float, record_dt: float = 1e-3, options=None, nthread: int = 0,
                  progress=None, loop=None, consume=None):
    """Run a list of machines on the named backend → ``BatchResult`` (each run equals its single run).

    ``options``: the backend's options (``runner.backend_options``); the reduced batch integrates
    with RK4 (a scenario's ``solve_ivp`` method is replaced by RK4 here).  ``consume(i, trajectory)``:
    called with each run's :class:`~mjbench.trajectory.Trajectory` as soon as the run ends, the
    records are then not kept (``BatchResult.results`` holds what it returned; the trajectory's
    arrays may be reused by the next run: ``consume`` copies what it keeps)."""
    _check(backend)
    if backend == "multibody":
        return batch.simulate(list(machines), t_end, record_dt=record_dt, options=options, progress=progress,
                              loop=loop, consume=consume)
    o = {**(options or {}), "method": "rk4"}
    return reduced_batch.simulate(machines, t_end, record_dt=record_dt, options=o, progress=progress, loop=loop,
                                  consume=consume)
