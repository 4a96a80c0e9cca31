"""Constants and signal names shared by the linear analysis (finite-difference steps, the
inputs and outputs of plant, controller and reference counterparts); python-control on demand."""
from __future__ import annotations

# one definition each, re-exported here: the inputs of a control law's counterpart (the reference's
# outputs, then the measurements) are mjbench.linearise's; a reference counterpart's are mjbench.control's
from ..control import REF_INPUTS, REF_OUTPUTS  # noqa: F401 - (re-exported)
from ..linearise import LAW_INPUTS  # noqa: F401 - (re-exported)


FD_Q = 1e-6  #: [rad] central-difference step for second derivatives in q


FD_MB = 1e-6  #: finite-difference epsilon handed to mjd_transitionFD


LOCK_FACTOR = 1e12  #: locked-input limit: the input inertia multiplied by this


MEAS = ("q", "qd", "qd_prev", "I")  #: measurement signals a controller counterpart may use


SETPOINTS = ("q_set", "qd_set")


def _ct():
    import control
    return control


def _sgn(v):
    return 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)
