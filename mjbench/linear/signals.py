"""Constants and signal names shared by the linear analysis (finite-difference steps, the
inputs and outputs of plant, controller and reference counterparts); python-control on demand."""
from __future__ import annotations




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


#: inputs of a control law's counterpart (the reference's outputs, then the measurements)
LAW_INPUTS = ("q_ref", "qd_ref", "qdd_ref", "q", "qd", "qd_prev", "I")


#: inputs and outputs of a reference's counterpart
REF_INPUTS = ("q_set", "qd_set", "q", "qd")


REF_OUTPUTS = ("q_ref", "qd_ref", "qdd_ref")
