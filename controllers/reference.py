"""Motor-side references φ_ref(t), φ̇_ref(t), φ̈_ref(t) for speed controllers.

A reference is any object with ``reset()`` and ``__call__(t, y) -> (phi_ref, omega_ref,
omega_dot_ref)`` on the motor shaft [rad, rad/s, rad/s²].  It may use the measurement y (seed
002's on-line reference); its state, if any, is in public attributes listed in ``STATE``.
"""
from __future__ import annotations


class ConstantSpeed:
    """Incerti 2012 §II-D: φ̇_ref = ω₀, φ_ref = φ₀ + ω₀·t, φ̈_ref = 0.

    ``phi0`` [rad] (motor side): the reference angle at t = 0; ``None`` (default) starts it from the
    first measurement (φ_ref = φ at the first sample), so a machine started at q0 ≠ 0 has no
    initial position error (the integral term K_i·(φ_ref − φ) starts at zero; for q0 = 0 this is
    the paper's φ_ref = ω₀·t)."""

    STATE = ("phi_start",)

    def __init__(self, omega0: float, phi0: float | None = None):
        self.omega0 = omega0
        self.phi0 = phi0
        self.reset()

    def reset(self):
        self.phi_start = self.phi0

    def __call__(self, t, y=None):
        if self.phi_start is None:
            self.phi_start = (y.phi if y is not None else 0.0) - self.omega0 * t
        return self.phi_start + self.omega0 * t, self.omega0, 0.0 * self.omega0
