"""Measurement-dependent references for speed controllers (``[modes.X.reference] type = ...``).

Each module here provides ``from_params(params, drive=None, mechanism=None)`` returning an object
with ``reset()`` and ``__call__(t, y) -> (phi_ref, omega_ref, omega_dot_ref)`` on the MOTOR shaft
[rad, rad/s, rad/s²] (see :mod:`controllers.reference`).  ``controllers.pid.from_params`` imports
``controllers.references.<type>`` for a ``reference`` sub-table.

* :mod:`controllers.references.coupler_speed` — seed 002 Eq 17: crank-speed reference for a
  prescribed coupler-point speed V_C (constant, piecewise-constant or tabulated V_C(s)).
"""
