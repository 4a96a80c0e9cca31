"""Simulator backends: ``multibody`` (MuJoCo) and ``reduced`` (Eksergian ODE), same inputs/outputs."""
from . import multibody, reduced

BACKENDS = {"multibody": multibody.simulate, "reduced": reduced.simulate}


def simulate(machine, backend: str, t_end: float, **kw):
    """Run ``machine`` on the named backend; see each backend's ``simulate`` for options."""
    try:
        fn = BACKENDS[backend]
    except KeyError:
        from ..errors import ParameterError
        raise ParameterError(f"backend = {backend!r}: choose one of {sorted(BACKENDS)}") from None
    return fn(machine, t_end, **kw)
