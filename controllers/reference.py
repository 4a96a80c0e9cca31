"""Motor-side references φ_ref(t), φ̇_ref(t), φ̈_ref(t) for speed controllers.

A reference is any object with ``reset()`` and ``__call__(t, y) -> (phi_ref, omega_ref,
omega_dot_ref)`` on the motor shaft [rad, rad/s, rad/s²].  It may use the measurement y (seed
002's on-line reference); its state, if any, is in public attributes listed in ``STATE``.
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
    """Base of the references: a law ``law(t, q, q̇, q̈, I, P, S) → (φ_ref, φ̇_ref, φ̈_ref)`` with
    :meth:`parameters` and :meth:`initial_state`; ``__call__(t, y)`` runs it from Python."""

    law = None
    STATE: tuple = ()

    def parameters(self, T, z):
        raise NotImplementedError

    def initial_state(self):
        return np.zeros(len(self.STATE))

    def form(self, T, z):
        from mjbench import compiled as C

        return C.Form(type(self).law, self.parameters(T, z), self.initial_state())

    def reset(self):
        self._S = self.initial_state()
        self._P = self._P_z = None

    def __call__(self, t, y):
        if getattr(self, "_S", None) is None:
            self.reset()
        z = getattr(y, "z", 1.0) if y is not None else 1.0
        if self._P is None or self._P_z != z:
            self._P, self._P_z = self.parameters(getattr(self, "period", 0.0), z), z
        if y is None:
            return type(self).law(t, 0.0, 0.0, 0.0, 0.0, self._P, self._S)
        return type(self).law(t, y.q, y.qd, y.qdd, y.current, self._P, self._S)

    def state(self) -> dict:
        if getattr(self, "_S", None) is None:
            self.reset()
        return {k: float(self._S[i]) for i, k in enumerate(self.STATE)}


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
