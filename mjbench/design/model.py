"""The sizing model: a mechanism's reduced model tabulated over one input turn, and the drive.

:class:`LoadModel` holds J(q), J'(q), E_p'(q) and the external torque split into a position part
and a viscous part, Q_ext(q, q̇) = Q_pos(q) − D(q)·q̇ (exact for every shipped mechanism: point
loads gated by the stroke, viscous joint and guide friction), all from the mechanism's *own*
``reduced(q)`` and ``external_torque`` (no MuJoCo).  The split is measured at three speeds and
checked (``affine_error``).  Periodic linear interpolation on ``n`` nodes (default 8192: error
≈ 1e-8 of the curvature).

:class:`DriveModel` is the drive as mjbench's kernel runs it (mjbench/drive.py, the ``EFF`` slot of
mjbench/kernel.py): the crank sees (J(q) + J_eq)·q̈ + ½J'q̇² + E_p' − Q_ext + z²λ·q̇ = z·EFF(T_m)
with J_eq = J_b + (J_m + J_a)·z², T_m = k_m·I − T_0·sgn φ̇ and EFF(T_m) = η·T_m when the motor
drives the load (T_m·φ̇ ≥ 0), T_m/η_back when the load drives the motor; L·İ = V − R·I − k_m·φ̇.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * math.pi


class LoadModel:
    """Tabulated reduced model of a rigid mechanism over one input turn (see the module doc)."""

    def __init__(self, mech, speed: float, n: int = 8192, q0: float = 0.0):
        self.mech = mech
        self.n = int(n)
        self.q0 = float(q0)
        q = self.q0 + TWO_PI * np.arange(self.n) / self.n
        J, dJ, dEp = (np.asarray(x, float) * np.ones_like(q) for x in mech.reduced(q))
        w = float(speed)
        Q1 = np.asarray(mech.external_torque(q, w + 0.0 * q, 0.0), float) * np.ones_like(q)
        Q2 = np.asarray(mech.external_torque(q, 2.0 * w + 0.0 * q, 0.0), float) * np.ones_like(q)
        Q3 = np.asarray(mech.external_torque(q, 0.5 * w + 0.0 * q, 0.0), float) * np.ones_like(q)
        D = (Q1 - Q2) / w
        Qpos = Q1 + D * w
        scale = max(float(np.max(np.abs(Q1))), 1e-300)
        self.affine_error = float(np.max(np.abs(Qpos - 0.5 * w * D - Q3)) / scale) if np.any(Q1) else 0.0
        self.q = q
        self.tab = np.vstack([J, dJ, dEp, Qpos, D])
        self.J_mean = float(np.mean(J))
        self.J_ptp = float(np.ptp(J))

    def __call__(self, q):
        """(J, J', E_p', Q_pos, D) at angles q (any shape), periodic linear interpolation."""
        q = np.asarray(q, float)
        u = (q - self.q0) % TWO_PI * (self.n / TWO_PI)
        i = np.floor(u).astype(np.int64)
        f = u - i
        i %= self.n
        j = (i + 1) % self.n
        T = self.tab
        return (1.0 - f) * T[:, i] + f * T[:, j]

    def load_torque(self, q, qd, qdd=0.0):
        """Torque the input must supply to the mechanism alone [N·m]: J q̈ + ½J'q̇² + E_p' − Q_ext."""
        J, dJ, dEp, Qp, D = self(q)
        return J * qdd + 0.5 * dJ * qd * qd + dEp - (Qp - D * qd)


@dataclass
class DriveModel:
    """Motor + gearbox (+ flywheel on the crank) as the kernel runs it; SI units."""

    z: float
    k_m: float
    R: float
    L: float
    J_m: float              #: motor rotor [kg·m²]
    J_a: float = 0.0        #: gearbox input side (pinion), motor side [kg·m²]
    J_b: float = 0.0        #: on the crank shaft (gear wheel + flywheel) [kg·m²]
    lam: float = 0.0        #: viscous friction on the motor shaft [N·m·s/rad]
    T0: float = 0.0         #: Coulomb friction on the motor shaft [N·m]
    eta: float = 1.0
    eta_back: float = 1.0

    @property
    def J_rotor(self) -> float:
        return self.J_m + self.J_a

    @property
    def J_eq(self) -> float:
        return self.J_b + self.J_rotor * self.z ** 2

    @property
    def c_v(self) -> float:
        return self.z ** 2 * self.lam

    def motor_torque(self, T_crank, w_motor):
        """T_m = k_m·I − ... the motor must produce for the crank-side torque ``T_crank`` (which
        includes the rotor inertia and viscous terms: the kernel puts them on the crank side),
        inverting EFF; plus T_0·sgn φ̇: the electromagnetic torque k_m·I [N·m]."""
        X = np.asarray(T_crank, float) / self.z
        w = np.asarray(w_motor, float)
        Tm = np.where(X * w >= 0.0, X / self.eta, X * self.eta_back)
        return Tm + self.T0 * np.sign(w)

    def gear_output(self, T_crank, qd, qdd):
        """Torque the gearbox output passes to the crank shaft [N·m] (docs/design.md §3, the
        convention): the crank-side torque of the model, ``T_crank`` = z·EFF(T_m) (the motor's
        k_m·I − T_0·sgn φ̇ through the efficiency), less what the kernel's plant keeps on the motor
        side without loss — the rotor's and pinion's inertia (J_m + J_a)·z²·q̈ and the viscous
        z²·λ·q̇.  It is what the mechanism and the crank-shaft inertia J_b receive:
        (J + J_b)·q̈ + ½J'q̇² + E_p' − Q_ext."""
        return (np.asarray(T_crank, float) - self.J_rotor * self.z ** 2 * np.asarray(qdd, float)
                - self.c_v * np.asarray(qd, float))

    def gear_output_of_run(self, I, w_motor, qdd):
        """:meth:`gear_output` from a run's recorded current, motor speed and crank acceleration, as
        the kernel applies it: z·EFF(k_m·I − T_0·sgn φ̇) − (J_m + J_a)·z²·q̈ − z²·λ·q̇ [N·m]."""
        w = np.asarray(w_motor, float)
        Tm = self.k_m * np.asarray(I, float) - self.T0 * np.sign(w)
        Tc = self.z * np.where(Tm * w >= 0.0, Tm * self.eta, Tm / self.eta_back)
        return self.gear_output(Tc, w / self.z, qdd)

    def as_drive_table(self, v_max=None, i_max=None) -> dict:
        """The scenario's ``[drive]`` table (mjbench.drive.DriveParams)."""
        d = {"R": self.R, "L": self.L, "k_m": self.k_m, "J_m": self.J_m, "J_a": self.J_a, "J_b": self.J_b,
             "z": self.z, "T_0": self.T0, "lam": self.lam}
        if v_max is not None:
            d["v_max"] = v_max
        if i_max is not None:
            d["i_max"] = i_max
        if self.eta < 1.0 or self.eta_back < 1.0:
            d["gear"] = {"efficiency": self.eta, "efficiency_back": self.eta_back}
        return d
