"""Exceptions raised by mjbench.  Every message names the parameter, or the time and state."""


class MjbenchError(Exception):
    """Base class of every error mjbench raises on purpose."""


class ParameterError(MjbenchError, ValueError):
    """A parameter is missing, non-physical or of the wrong type (the message names it)."""


class GeometryError(MjbenchError, ValueError):
    """A mechanism cannot be assembled, or its input link cannot make the full turn."""


class SimulationDiverged(MjbenchError, RuntimeError):
    """A simulation produced a non-finite or runaway state (the message gives time and state)."""

    def __init__(self, message, t=None, state=None):
        super().__init__(message)
        self.t = t
        self.state = state


class RunFailed(MjbenchError, RuntimeError):
    """A component failed during a run — an FMU's step, a cluster that lost its workers (the message
    names the component and, where there is one, the time ``t`` [s])."""

    def __init__(self, message, t=None):
        super().__init__(message)
        self.t = t


class ScenarioError(MjbenchError, ValueError):
    """A scenario file or a --set override is malformed or names an unknown key.  ``problems``:
    one line per problem (``path: message``) when the scenario failed validation."""

    def __init__(self, message, problems=None):
        super().__init__(message)
        self.problems = list(problems or [])
