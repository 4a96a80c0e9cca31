"""Motor-side references φ_ref(t), φ̇_ref(t), φ̈_ref(t) for speed controllers.

A reference is any object with ``reset()`` and ``__call__(t, y) -> (phi_ref, omega_ref,
omega_dot_ref)`` on the motor shaft [rad, rad/s, rad/s²].  It may use the measurement y (seed
002's on-line reference); its state, if any, is in public attributes listed in ``STATE``.
"""
from __future__ import annotations


class ConstantSpeed:
    """Seed 000 §II-D: φ̇_ref = ω₀, φ_ref = ω₀·t (+φ₀), φ̈_ref = 0."""

    STATE = ()

    def __init__(self, omega0: float, phi0: float = 0.0):
        self.omega0 = omega0
        self.phi0 = phi0

    def reset(self):
        pass

    def __call__(self, t, y=None):
        return self.phi0 + self.omega0 * t, self.omega0, 0.0 * self.omega0
