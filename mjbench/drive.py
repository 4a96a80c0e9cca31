"""DC motor + gearbox (seed 000, Eqs 6-9), shared by every backend.

State: the armature current I [A].  Inputs: armature voltage V_a [V] and motor speed φ̇ [rad/s].
Output: the torque the drive applies to the mechanism's input coordinate (crank) [N·m]:

    T_c + J_eq·α̈ = z·(k_m·I − T_0·sgn φ̇ − λ·φ̇),   φ̇ = z·α̇          (Eq 9, T_r of Eq 6)

The reflected inertia J_eq = J_b + (J_m + J_a)·z² is *not* part of ``crank_torque``: each backend
adds it to the mechanism's inertia (MuJoCo joint ``armature``; J_eq + J(α) in Eq 11).

Electrical equation (Eq 7):  L·dI/dt = V_a − R·I − k_m·φ̇.

Integration scheme (``current_step``): over one co-simulation step h the voltage is held (ZOH, it
comes from a sampled controller) and φ̇ is taken as the mean of its values at both ends of the
step; the linear ODE is then solved exactly, I₊ = I_ss + (I − I_ss)·exp(−h·R/L), with
I_ss = (V − k_m·φ̇)/R.  The only approximation is the speed's variation within the step, a local
error O(h²·k_m·|φ̈|/L) — second order because the mean speed is used — so the scheme is
unconditionally stable for any h (no stiffness limit from L/R) and accurate to ≈1e-7 A per
0.1 ms step for the seed-000 motor.  L = 0 gives the algebraic current I = I_ss.

Every method accepts scalars or NumPy arrays of shape (nsim,) alike (parameters too).

The real drive train (PWM amplifier, encoder and speed estimation, sampling delay, gear backlash
and efficiency, dry friction, current loop) is optional: sub-tables of ``[drive]``
(:mod:`mjbench.drivetrain`), held in ``DCMotorDrive.train`` (None = the ideal drive above).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Literal

import numpy as np
from pydantic import Field

from .drivetrain.params import (CurrentLoopParams, EncoderParams, FrictionParams, GearParams, PWMParams,
                                SensorParams, SUBTABLES)
from .errors import ParameterError
from .schema import Q, Strict


class DriveParams(Strict):
    """``[drive]``: permanent-magnet DC motor + gear reducer (seed 000 Eqs 6-9), SI units.

    Required: R, L, k_m, J_m, z, lam (a drive is never silently a default motor).  Defaults:
    J_a = J_b = 0 (no gear inertias), T_0 = 0 (no Coulomb friction), v_max = i_max = inf (no
    voltage limiter, no amplifier current limit)."""

    type: Literal["dcmotor"] = "dcmotor"
    R: Q("resistance", gt=0.0, what="an armature resistance") = Field(description="armature resistance")
    L: Q("inductance", ge=0.0, what="an armature inductance") = Field(description="armature inductance (0: algebraic current, multibody only)")
    k_m: Q("motor_constant", gt=0.0, what="a motor constant") = Field(description="torque = back-EMF constant")
    J_m: Q("inertia", ge=0.0, what="a rotor inertia") = Field(description="rotor inertia")
    J_a: Q("inertia", ge=0.0) = Field(0.0, description="pinion on the motor shaft")
    J_b: Q("inertia", ge=0.0) = Field(0.0, description="gear on the input (crank) shaft")
    z: float = Field(gt=0.0, description="gear ratio φ̇/α̇ (motor turns per input turn)")
    T_0: Q("torque", ge=0.0) = Field(0.0, description="constant (Coulomb) friction on the motor shaft")
    lam: Q("rot_damping", ge=0.0) = Field(description="viscous friction λ on the motor shaft")
    v_max: Q("voltage", gt=0.0, finite=False) = Field(math.inf, description="voltage limiter ±v_max (inf: none)")
    i_max: Q("current", gt=0.0, finite=False) = Field(math.inf, description="amplifier current limit ±i_max (inf: none)")
    # optional drive-train elements (docs/drivetrain.md); None = ideal
    pwm: PWMParams | None = Field(None, description="PWM H-bridge amplifier (none: ideal voltage source)")
    encoder: EncoderParams | None = Field(None, description="incremental encoder (none: exact angle)")
    sensor: SensorParams | None = Field(None, description="speed estimation, noise, computation delay")
    gear: GearParams | None = Field(None, description="backlash, mesh stiffness, efficiency (none: rigid, lossless)")
    friction: FrictionParams | None = Field(None, description="dry friction on the motor and on joints")
    current_loop: CurrentLoopParams | None = Field(None, description="inner PI current loop (mode output = current reference)")

    def build(self) -> "DCMotorDrive":
        from .drivetrain import DriveTrain

        d = DCMotorDrive(**{f.name: getattr(self, f.name) for f in fields(DCMotorDrive) if f.name != "train"})
        d.train = DriveTrain.from_params(self, d)
        return d

    def model_dump(self, **kw):
        """As pydantic's, without the drive-train tables that are off (manifests stay as before)."""
        out = super().model_dump(**kw)
        for k in SUBTABLES:
            if out.get(k, 0) is None:
                del out[k]
        return out

    def check_against(self, scn) -> list[str]:
        """Cross-checks of the drive-train tables against the scenario's modes and step."""
        from .drivetrain.params import check_against

        return check_against(self, scn)


@dataclass
class DCMotorDrive:
    """Permanent-magnet DC motor with a gear reducer (seed 000 notation, SI units).

    R [Ω], L [H], k_m [N·m/A = V·s/rad] (torque = back-EMF constant), J_m, J_a, J_b [kg·m²]
    (motor, pinion on the motor shaft, gear on the crank shaft), z = φ̇/α̇ (gear ratio, motor
    turns per crank turn), T_0 [N·m] constant and λ [N·m·s/rad] viscous friction on the motor
    shaft (Eq 6), v_max [V] voltage limiter (symmetric, ``inf`` = none), i_max [A] optional
    current limit of the amplifier (``inf`` = none; the current is clipped after each step).
    """

    R: float = 1.0
    L: float = 9e-3
    k_m: float = 0.48
    J_m: float = 13e-4
    J_a: float = 9.8e-5
    J_b: float = 9.8e-5
    z: float = 1.0
    T_0: float = 0.0
    lam: float = 0.08
    v_max: float = math.inf
    i_max: float = math.inf
    #: optional drive-train elements (:class:`mjbench.drivetrain.DriveTrain`), None = ideal
    train: object = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        self.validate()
        self._h = None
        self._flags()

    def _flags(self):
        """Hot-path flags (scalar 'no limit' tests), refreshed by prepare() at every run start."""
        self._no_vlimit = bool(np.ndim(self.v_max) == 0 and self.v_max == math.inf)
        self._no_ilimit = bool(np.ndim(self.i_max) == 0 and self.i_max == math.inf)

    # ---------------------------------------------------------------- parameters
    def validate(self):
        def bad(name, why):
            raise ParameterError(f"drive.{name} = {getattr(self, name)!r}: {why}")

        for f in fields(self):
            if f.name == "train":
                continue
            v = np.asarray(getattr(self, f.name), dtype=float)
            if not np.all(np.isfinite(v)) and f.name not in ("v_max", "i_max"):
                bad(f.name, "must be finite")
            if np.any(np.isnan(v)):
                bad(f.name, "must not be NaN")
        for name in ("R", "k_m", "z", "v_max", "i_max"):
            if np.any(np.asarray(getattr(self, name)) <= 0):
                bad(name, "must be > 0")
        for name in ("L", "J_m", "J_a", "J_b", "T_0", "lam"):
            if np.any(np.asarray(getattr(self, name)) < 0):
                bad(name, "must be >= 0")

    @property
    def J_eq(self):
        """Drive inertia reflected on the crank, J_eq = J_b + (J_m + J_a)·z² [kg·m²] (Eq 9)."""
        return self.J_b + (self.J_m + self.J_a) * self.z ** 2

    @property
    def tau_e(self):
        """Electrical time constant L/R [s]."""
        return self.L / self.R

    # ---------------------------------------------------------------- equations
    def limit(self, V):
        """Voltage limiter of Fig. 3: clip to ±v_max."""
        if self._no_vlimit:
            return V
        if isinstance(V, float):
            return -self.v_max if V < -self.v_max else (self.v_max if V > self.v_max else V)
        return np.minimum(np.maximum(V, -self.v_max), self.v_max)  # = np.clip, several times faster

    def step_limit(self, scalar: bool):
        """The kernel's per-sample limiter: None when there is no limit (v_max = inf), else
        :meth:`limit` — for a single run (``scalar``) as a closure with ±v_max bound, the same
        comparisons (0.07 µs less per co-step)."""
        if self._no_vlimit:
            return None
        if not (scalar and np.ndim(self.v_max) == 0):
            return self.limit
        vm = float(self.v_max)
        nvm = -vm

        def limit(V):
            return nvm if V < nvm else (vm if V > vm else V)
        return limit

    def di_dt(self, I, V, omega_m):
        """dI/dt of Eq 7 [A/s] for motor speed ``omega_m`` = φ̇ [rad/s]."""
        return (V - self.R * I - self.k_m * omega_m) / self.L

    def prepare(self, h: float):
        """Cache the step-dependent constants for a fixed step h [s] (decay and mean weights)."""
        self._h = h
        self._flags()
        L, R = np.asarray(self.L, dtype=float), np.asarray(self.R, dtype=float)
        if np.all(L > 0):
            x = h * R / L
            decay = np.exp(-x)
            w = (1.0 - decay) / x  # mean of exp(-s/tau) over [0, h]
        elif np.any(L > 0):  # (nsim,) parameters, some with L = 0 (algebraic current)
            L, R = np.broadcast_arrays(L, R)
            x = h * R / np.where(L > 0, L, 1.0)
            decay = np.where(L > 0, np.exp(-x), 0.0)
            w = np.where(L > 0, (1.0 - decay) / x, 0.0)
        else:
            decay, w = np.zeros_like(R), np.zeros_like(R)
        self._decay = float(decay) if decay.ndim == 0 else decay
        self._w = float(w) if w.ndim == 0 else w
        return self

    def current_mean(self, I, V, omega_m, h: float):
        """Time average of the exact current over a step h (V and φ̇ held) [A]: the constant
        current whose torque impulse over the step equals the true one."""
        if h != self._h:
            self.prepare(h)
        i_ss = (V - self.k_m * omega_m) / self.R
        return i_ss + (I - i_ss) * self._w

    def current_step(self, I, V, omega_m_mean, h: float):
        """Exact current update over a step h with V held and φ̇ = ``omega_m_mean`` (see module doc)."""
        if h != self._h:
            self.prepare(h)
        i_ss = (V - self.k_m * omega_m_mean) / self.R
        I_new = i_ss + (I - i_ss) * self._decay
        if not self._no_ilimit:
            im = self.i_max
            if isinstance(I_new, float) and isinstance(im, float):  # scalar hot path (np.clip costs ~25 µs)
                I_new = -im if I_new < -im else (im if I_new > im else I_new)
            else:
                I_new = np.minimum(np.maximum(I_new, -im), im)
                if I_new.ndim == 0:
                    I_new = float(I_new)
        return I_new

    def step_torque(self, h: float, scalar: bool):
        """The kernel's per-step torque call for a fixed step h [s]: ``torque(I, V, qd)`` =
        ``crank_torque(current_mean(I, V, z·qd, h), qd, viscous=False)``, the crank torque of the
        exact step-mean current (V held, crank speed qd at the step start).

        ``scalar`` (a single run, float signals): a closure with the constants bound as locals —
        the same operations in the same order as the two methods (a batch, which calls the
        methods, stays bit-identical to single runs), at half their cost (0.12 vs 0.24 µs per
        co-step; the current update gains nothing this way and stays :meth:`current_step`)."""
        self.prepare(h)
        z = self.z
        if not (scalar and all(np.ndim(v) == 0 for v in (self.R, self.L, self.k_m, z, self.T_0))):
            torque_m, mean_m = self.crank_torque, self.current_mean

            def torque(I, V, qd):
                return torque_m(mean_m(I, V, z * qd, h), qd, False)
            return torque
        R, T_0, w, z, k_m = float(self.R), float(self.T_0), float(self._w), float(z), float(self.k_m)
        if T_0 == 0.0:
            def torque(I, V, qd):
                i_ss = (V - k_m * (z * qd)) / R
                return z * (k_m * (i_ss + (I - i_ss) * w))
        else:
            def torque(I, V, qd):
                i_ss = (V - k_m * (z * qd)) / R
                s = z * qd
                return z * (k_m * (i_ss + (I - i_ss) * w) - T_0 * (1.0 if s > 0 else (-1.0 if s < 0 else 0.0)))
        return torque

    def step_current(self, h: float, scalar: bool):
        """The kernel's per-step current update for a fixed step h [s]: ``current(I, V, omega_m_mean)``
        = :meth:`current_step` (exact exponential, amplifier limit); for a single run (``scalar``)
        a closure with the constants bound, the same operations in the same order."""
        self.prepare(h)
        if not (scalar and all(np.ndim(v) == 0 for v in (self.R, self.L, self.k_m, self.i_max))):
            cs = self.current_step

            def current(I, V, om):
                return cs(I, V, om, h)
            return current
        R, k_m, decay = float(self.R), float(self.k_m), float(self._decay)
        if self._no_ilimit:
            def current(I, V, om):
                i_ss = (V - k_m * om) / R
                return i_ss + (I - i_ss) * decay
            return current
        im = float(self.i_max)
        nim = -im

        def current(I, V, om):
            i_ss = (V - k_m * om) / R
            I_new = i_ss + (I - i_ss) * decay
            return nim if I_new < nim else (im if I_new > im else I_new)
        return current

    def torque_function(self, scalar: bool):
        """``torque(I, crank_speed)`` = :meth:`crank_torque` (viscous part included), for a single
        run (``scalar``) as a closure with the constants bound: the same operations in the same order."""
        if not (scalar and all(np.ndim(v) == 0 for v in (self.z, self.k_m, self.T_0, self.lam))):
            return self.crank_torque
        z, k_m, T_0, lam = float(self.z), float(self.k_m), float(self.T_0), float(self.lam)

        def torque(I, crank_speed):
            om = z * crank_speed
            return z * (k_m * I - (T_0 * (1.0 if om > 0 else (-1.0 if om < 0 else 0.0)) + lam * om))
        return torque

    def friction_torque_motor(self, omega_m):
        """T_r = T_0·sgn φ̇ + λ·φ̇ on the motor shaft [N·m] (Eq 6; T_0 opposes the motion)."""
        return self.T_0 * _sign(omega_m) + self.lam * omega_m

    def crank_torque(self, I, crank_speed, viscous=True):
        """Drive torque on the crank, z·(k_m·I − T_r(z·α̇)) [N·m] (Eq 9 without the J_eq·α̈ term).

        ``viscous=False`` leaves out the viscous part −z²·λ·α̇, for a backend that models it as
        joint damping (``crank_damping``; MuJoCo then integrates it within every step)."""
        if viscous:
            return self.z * (self.k_m * I - self.friction_torque_motor(self.z * crank_speed))
        return self.z * (self.k_m * I - self.T_0 * _sign(self.z * crank_speed))

    @property
    def crank_damping(self):
        """Viscous friction reflected on the crank, z²·λ [N·m·s/rad]."""
        return self.z ** 2 * self.lam

    def power_elec(self, V, I):
        """Electrical power at the armature terminals, V_a·I [W] (Fig. 4h)."""
        return V * I

    def power_mech(self, I, omega_m):
        """Mechanical power converted by the motor, T_m·φ̇ = k_m·I·φ̇ [W] (Fig. 4g)."""
        return self.k_m * I * omega_m

    def as_dict(self):
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "train"}
        if self.train is not None:
            d["train"] = self.train.describe()
        return d


def _sign(x):
    """sgn x for a float (fast path) or an array."""
    if isinstance(x, float):
        return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)
    return np.sign(x)
