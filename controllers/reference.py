"""Motor-side references φ_ref(t), φ̇_ref(t), φ̈_ref(t) for speed controllers.

A reference is a *law* (:mod:`mjbench.compiled`)::

    law(t, q, q̇, q̈, I, P, S) → (φ_ref, φ̇_ref, φ̈_ref)        [rad, rad/s, rad/s², motor side]

of the crank-side measurement (it may use it: seed 002's on-line reference), with parameters ``P``
(:meth:`Reference.parameters`, computed once per run) and state ``S`` (:meth:`Reference.initial_state`,
laid out as ``STATE``).  The kernel calls it in its REF slot (compiled or in CPython); the object's
``__call__(t, y)`` runs the same law from Python.  A reference whose law takes other laws as
leading arguments (a motion law, a speed profile) overrides :meth:`Reference.form` and lists
them in ``Form.fn_args``.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from mjbench.compiled import law


ConstantSpeedP = namedtuple("ConstantSpeedP", "omega0 z")


@law
def constant_speed_law(t, q, qd, qdd, I, P, S):
    """φ_ref = φ_start + ω₀·t, φ̇_ref = ω₀, φ̈_ref = 0 (motor side).  S[0] = φ_start (NaN: taken
    from the first measurement, φ_start = z·q − ω₀·t)."""
    if math.isnan(S[0]):
        S[0] = P.z * q - P.omega0 * t
    return S[0] + P.omega0 * t, P.omega0, 0.0 * P.omega0


class Reference:
    """Base of the references (see the module docstring).

    Subclasses set ``law`` and ``STATE`` and define :meth:`parameters` (and :meth:`initial_state`
    when the state does not start at zeros).  ``__call__(t, y)`` runs the law from Python with the
    object's own state (``reset()`` clears it); the kernel runs it from :meth:`form` with a fresh
    state per run."""

    law = None
    STATE: tuple = ()
    #: sample period the Python calls assume [s] (the kernel passes the controller's)
    period = 0.0

    def parameters(self, T, z):
        """The law's parameter tuple for control period T [s] and gear ratio z (motor per crank)."""
        raise NotImplementedError(f"{type(self).__name__} has a law but no parameters()")

    def initial_state(self):
        return np.zeros(len(self.STATE))

    def form(self, T, z):
        """The reference's compiled form (:class:`mjbench.compiled.Form`) for period T and ratio z."""
        from mjbench import compiled as C

        return C.Form(type(self).law, self.parameters(T, z), self.initial_state())

    def reset(self):
        """Fresh state for the Python calls (the kernel starts every run from :meth:`initial_state`)."""
        self._S = self.initial_state()
        self._fn = self._P = self._z = None

    def _prepare(self, z):
        f = self.form(float(getattr(self, "period", 0.0) or 0.0), z)
        self._fn, self._P, self._z = f.bound(), f.P, z

    def __call__(self, t, y=None):
        """(φ_ref, φ̇_ref, φ̈_ref) at time t [s] for the measurement y (None: zeros, z = 1)."""
        if getattr(self, "_S", None) is None:
            self.reset()
        z = float(getattr(y, "z", 1.0)) if y is not None else 1.0
        if self._fn is None or self._z != z:
            self._prepare(z)
        if y is None:
            return self._fn(float(t), 0.0, 0.0, 0.0, 0.0, self._P, self._S)
        return self._fn(float(t), float(y.q), float(y.qd), float(y.qdd), float(y.current), self._P, self._S)

    def state(self) -> dict:
        if getattr(self, "_S", None) is None:
            self.reset()
        return {k: float(self._S[i]) for i, k in enumerate(self.STATE)}

    # ------------------------------------------------------------------ capabilities
    def linear(self, machine, op, T, h, feedback=True):
        """The reference's linear counterpart (python-control, discrete time at period T): inputs
        q_set, qd_set, q, qd → q_ref, qd_ref, qdd_ref (input side).  Default, for a reference of
        time only (it does not read the measurement): q_ref = q_set + Σ T·qd_set (exactly ω₀·t
        for a step), q̇_ref = qd_set, q̈_ref = 0 (a set-point step is not differentiated).  A
        reference that reads the measured angle overrides this (``CouplerSpeed``)."""
        from mjbench import linear as LN

        return LN.setpoint_reference(T)

    def crank_speed_at(self, machine, q):
        """The input speed [rad/s] this reference asks for at angle q (linear analysis' running
        point); None when it has no single answer."""
        return None


class ConstantSpeed(Reference):
    """Incerti 2012 §II-D: φ̇_ref = ω₀, φ_ref = φ₀ + ω₀·t, φ̈_ref = 0.

    ``phi0`` [rad] (motor side): the reference angle at t = 0; ``None`` (default) starts it from the
    first measurement (φ_ref = φ at the first sample), so a machine started at q0 ≠ 0 has no
    initial position error (the integral term K_i·(φ_ref − φ) starts at zero; for q0 = 0 this is
    the paper's φ_ref = ω₀·t)."""

    STATE = ("phi_start",)
    law = constant_speed_law

    def __init__(self, omega0: float, phi0: float | None = None):
        self.omega0 = omega0
        self.phi0 = phi0
        self.reset()

    def parameters(self, T, z):
        return ConstantSpeedP(float(self.omega0), float(z))

    def initial_state(self):
        return np.array([math.nan if self.phi0 is None else float(self.phi0)])

    def crank_speed_at(self, machine, q):
        return float(self.omega0) / float(machine.drive.z)

    @property
    def phi_start(self):
        """φ_start [rad] of the Python calls (state; None before the first call)."""
        v = self.state()["phi_start"]
        return None if math.isnan(v) else v
