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

import math
from collections import namedtuple
from dataclasses import dataclass, field, fields
from typing import Literal

import numpy as np
from pydantic import Field

from .drivetrain.params import (CurrentLoopParams, EncoderParams, FrictionParams, GearParams, PWMParams,
                                SensorParams, SUBTABLES)
from . import compiled as C
from .compiled import clip, sgn
from .drivetrain.amplifier import current_limited_voltage
from .drives import Drive, register
from .drives.datasheet import MotorDatasheet, expand as expand_datasheet
from .errors import ParameterError
from .fields import Q, Strict
from .drivetrain import DriveTrain
from .drivetrain.params import check_against
from .drives.ideal import mode_output_problems


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
    i_rated: Q("current", gt=0.0, finite=False) = Field(
        math.inf, description="the motor's continuous (thermal) current rating, compared with the steady-state RMS "
                              "current (inf: none stated)")
    datasheet: MotorDatasheet | None = Field(None, description="the motor by its catalogue values: R, k_m, lam, L, J_m "
                                                               "(z, gear efficiency, i_rated) derived from them")
    # optional drive-train elements (docs/drivetrain.md); None = ideal
    pwm: PWMParams | None = Field(None, description="PWM H-bridge amplifier (none: ideal voltage source)")
    encoder: EncoderParams | None = Field(None, description="incremental encoder (none: exact angle)")
    sensor: SensorParams | None = Field(None, description="speed estimation, noise, computation delay")
    gear: GearParams | None = Field(None, description="backlash, mesh stiffness, efficiency (none: rigid, lossless)")
    friction: FrictionParams | None = Field(None, description="dry friction on the motor and on joints")
    current_loop: CurrentLoopParams | None = Field(None, description="inner PI current loop (mode output = current reference)")

    @staticmethod
    def expand(raw: dict) -> tuple[dict, list]:
        """The table with the values its ``datasheet`` gives filled in, and the problems
        (:func:`mjbench.drives.datasheet.expand`); validate the result."""
        return expand_datasheet(raw)

    def datasheet_warnings(self) -> list[str]:
        """Redundant datasheet values that disagree (:meth:`MotorDatasheet.consistency`)."""
        return self.datasheet.consistency() if self.datasheet is not None else []

    def build(self) -> "DCMotorDrive":

        d = DCMotorDrive(**{n: getattr(self, n) for n in _scalar_fields(DCMotorDrive)})
        d.train = DriveTrain.from_params(self, d)
        return d

    def model_dump(self, **kw):
        """As pydantic's, without the drive-train tables that are off (manifests stay as before)."""
        out = super().model_dump(**kw)
        for k in SUBTABLES + ("datasheet",):
            if out.get(k, 0) is None:
                del out[k]
        return out

    def check_against(self, scn) -> list[str]:
        """Cross-checks of the drive-train tables against the scenario's modes and step; a mode
        whose output is not a voltage (``type = "constant"``: a torque or a speed) is refused."""

        return check_against(self, scn) + mode_output_problems(scn, "dcmotor")


#: per drive class, its parameter fields (:func:`_scalar_fields`)
_SCALAR_FIELDS: dict = {}


def _scalar_fields(cls) -> tuple:
    """The parameter fields of a drive class (its dataclass fields but the drive train), once per class."""
    names = _SCALAR_FIELDS.get(cls)
    if names is None:
        names = _SCALAR_FIELDS[cls] = tuple(f.name for f in fields(cls) if f.name != "train")
    return names


@register
@dataclass
class DCMotorDrive(Drive):
    """Permanent-magnet DC motor with a gear reducer (seed 000 notation, SI units).

    R [Ω], L [H], k_m [N·m/A = V·s/rad] (torque = back-EMF constant), J_m, J_a, J_b [kg·m²]
    (motor, pinion on the motor shaft, gear on the crank shaft), z = φ̇/α̇ (gear ratio, motor
    turns per crank turn), T_0 [N·m] constant and λ [N·m·s/rad] viscous friction on the motor
    shaft (Eq 6), v_max [V] voltage limiter (symmetric, ``inf`` = none), i_max [A] optional
    current limit of the amplifier (``inf`` = none; the current is clipped after each step),
    i_rated [A] the motor's continuous current rating (``inf`` = none stated; the duty figures
    compare the steady-state RMS current with it, nothing in the loop uses it).
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
    i_rated: float = math.inf
    #: optional drive-train elements (:class:`mjbench.drivetrain.DriveTrain`), None = ideal
    train: object = field(default=None, compare=False, repr=False)
    #: ``[drive] type`` of this class (mjbench.drives) and its table
    type_name = "dcmotor"
    Params = DriveParams

    def __post_init__(self):
        self.validate()
        self._h = None
        self._flags()

    def _flags(self):
        """Hot-path flags (scalar 'no limit' tests), refreshed by prepare() at every run start."""
        v, i = self.v_max, self.i_max
        self._no_vlimit = v == math.inf if type(v) is float else bool(np.ndim(v) == 0 and v == math.inf)
        self._no_ilimit = i == math.inf if type(i) is float else bool(np.ndim(i) == 0 and i == math.inf)

    # ---------------------------------------------------------------- parameters
    def validate(self):
        def bad(name, why):
            raise ParameterError(f"drive.{name} = {getattr(self, name)!r}: {why}")

        if self._validate_scalars(bad):
            return
        for f in fields(self):
            if f.name == "train":
                continue
            v = np.asarray(getattr(self, f.name), dtype=float)
            if not np.all(np.isfinite(v)) and f.name not in ("v_max", "i_max", "i_rated"):
                bad(f.name, "must be finite")
            if np.any(np.isnan(v)):
                bad(f.name, "must not be NaN")
        for name in ("R", "k_m", "z", "v_max", "i_max", "i_rated"):
            if np.any(np.asarray(getattr(self, name)) <= 0):
                bad(name, "must be > 0")
        for name in ("L", "J_m", "J_a", "J_b", "T_0", "lam"):
            if np.any(np.asarray(getattr(self, name)) < 0):
                bad(name, "must be >= 0")

    def _validate_scalars(self, bad) -> bool:
        """:meth:`validate` for a drive whose parameters are all plain numbers (every scenario's):
        the same checks in the same order without NumPy (≈ 80 µs per run otherwise); False (not
        checked) if any is an array."""
        names = _scalar_fields(type(self))
        vals = [getattr(self, n) for n in names]
        if not all(isinstance(v, (float, int)) for v in vals):
            return False
        for n, v in zip(names, vals):
            x = float(v)
            if not math.isfinite(x) and n not in ("v_max", "i_max", "i_rated"):
                bad(n, "must be finite")
            if math.isnan(x):
                bad(n, "must not be NaN")
        for n in ("R", "k_m", "z", "v_max", "i_max", "i_rated"):
            if float(getattr(self, n)) <= 0:
                bad(n, "must be > 0")
        for n in ("L", "J_m", "J_a", "J_b", "T_0", "lam"):
            if float(getattr(self, n)) < 0:
                bad(n, "must be >= 0")
        return True

    @property
    def J_eq(self):
        """Drive inertia reflected on the crank, J_eq = J_b + (J_m + J_a)·z² [kg·m²] (Eq 9)."""
        return self.J_b + (self.J_m + self.J_a) * self.z ** 2

    # ---------------------------------------------------------------- equations
    def step_params(self, h: float) -> "DriveStep":
        """The parameters of the drive's laws for a fixed co-simulation step h [s]."""
        self.prepare(h)
        d = float(self._decay)
        return DriveStep(float(self.R), float(self.k_m), float(self.z), float(self.T_0), float(self.lam),
                         float(self._w), d, float(self.i_max), float(self.R) / (1.0 - d) if d < 1.0 else float(self.R))

    def form(self, h: float) -> "C.Form":
        """The drive's compiled form for the kernel: its parameters at step h and its laws
        (``mean``: :func:`current_mean`, ``torque``: :func:`motor_torque`, ``step``:
        :func:`current_step`, ``record``: :func:`dc_record`, ``limit``: :func:`drive_voltage`)."""
        return C.Form(current_mean, self.step_params(h), laws={"mean": current_mean, "torque": motor_torque,
                                                               "step": current_step, "record": dc_record,
                                                               "limit": drive_voltage})

    def forms(self, h: float, every: int, plant) -> dict:
        """The compiled forms of the drive-train elements for the kernel's slots ({} = ideal)."""
        if self.train is None:
            return {}
        return self.train.forms(self, h, every, plant)

    def limit(self, V):
        """Voltage limiter of Fig. 3: clip to ±v_max."""
        return C.vectorize(lambda v: clip(v, -float(self.v_max), float(self.v_max)), V)

    def di_dt(self, I, V, omega_m):
        """dI/dt of Eq 7 [A/s] for motor speed ``omega_m`` = φ̇ [rad/s]."""
        return (V - self.R * I - self.k_m * omega_m) / self.L

    def prepare(self, h: float):
        """Cache the step-dependent constants for a fixed step h [s] (decay and mean weights)."""
        self._h = h
        self._flags()
        L, R = float(self.L), float(self.R)
        if L > 0:
            x = h * R / L
            decay = math.exp(-x)
            w = (1.0 - decay) / x  # mean of exp(-s/tau) over [0, h]
        else:
            decay = w = 0.0
        self._decay, self._w = decay, w
        return self

    def current_mean(self, I, V, omega_m, h: float):
        """Time average of the exact current over a step h (V and φ̇ held) [A]: the constant
        current whose torque impulse over the step equals the true one (:func:`current_mean`)."""
        P = self.step_params(h)
        return C.vectorize(lambda i, v, w: current_mean(i, v, w, P), I, V, omega_m)

    def current_step(self, I, V, omega_m_mean, h: float):
        """Exact current update over a step h with V held and φ̇ = ``omega_m_mean`` (:func:`current_step`)."""
        P = self.step_params(h)
        return C.vectorize(lambda i, v, w: current_step(i, v, w, P), I, V, omega_m_mean)

    def friction_torque_motor(self, omega_m):
        """T_r = T_0·sgn φ̇ + λ·φ̇ on the motor shaft [N·m] (Eq 6; T_0 opposes the motion)."""
        return self.T_0 * np.sign(omega_m) + self.lam * omega_m

    def crank_torque(self, I, crank_speed, viscous=True):
        """Drive torque on the crank, z·(k_m·I − T_r(z·α̇)) [N·m] (Eq 9 without the J_eq·α̈ term,
        :func:`drive_torque`).  ``viscous=False`` leaves out the viscous part −z²·λ·α̇ (the plant's
        joint damping): z·(k_m·I − T_0·sgn φ̇) (:func:`motor_torque` × z)."""
        P = self.step_params(self._h or 1e-4)
        z = P.z
        if viscous:
            return C.vectorize(lambda i, q: drive_torque(i, z * q, P), I, crank_speed)
        return C.vectorize(lambda i, q: z * motor_torque(i, z * q, P), I, crank_speed)

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


#: the drive's parameters for its laws at one step h (``w``, ``decay``: the step's mean weight
#: (1 − e^{−hR/L})/(hR/L) and decay e^{−hR/L}, 0 for L = 0; ``gain`` = R/(1 − decay))
DriveStep = namedtuple("DriveStep", "R k_m z T_0 lam w decay i_max gain")


@C.law
def drive_voltage(I, V, w, P):
    """The voltage the drive's (ideal) amplifier applies for the command V: limited to what keeps the
    end-of-step current within ±i_max (:func:`mjbench.drivetrain.amplifier.current_limited_voltage`)."""
    return current_limited_voltage(I, V, w, P.k_m, P.decay, P.gain, P.i_max)


@C.law
def current_mean(I, V, w, P):
    """Ī = I_ss + (I − I_ss)·(1 − e^{−hR/L})/(hR/L), I_ss = (V − k_m·φ̇)/R: the exact time average
    of the current over a step with V and φ̇ = ``w`` held (Eq 7 solved exactly)."""
    i_ss = (V - P.k_m * w) / P.R
    return i_ss + (I - i_ss) * P.w


@C.law
def current_step(I, V, w_mean, P):
    """I₊ = I_ss + (I − I_ss)·e^{−hR/L} with φ̇ = ``w_mean`` (the mean over the step), clipped to
    the amplifier's ±i_max (inf: no limit)."""
    i_ss = (V - P.k_m * w_mean) / P.R
    return clip(i_ss + (I - i_ss) * P.decay, -P.i_max, P.i_max)


@C.law
def motor_torque(I, w, P):
    """Net motor torque on the motor shaft without the viscous part, k_m·I − T_0·sgn φ̇ [N·m]
    (the viscous −λ·φ̇ is the plant's joint damping)."""
    return P.k_m * I - P.T_0 * sgn(w)


@C.law
def drive_torque(I, w, P):
    """Drive torque on the crank, z·(k_m·I − (T_0·sgn φ̇ + λ·φ̇)) [N·m] (Eq 9 without J_eq·α̈),
    for motor speed φ̇ = ``w``: the recorded ``torque_crank_Nm``."""
    return P.z * (P.k_m * I - (P.T_0 * sgn(w) + P.lam * w))


@C.law
def dc_record(out, b, I, V, w, P):
    """The drive's recorded columns of one sample into ``out[b:b+5]``: the current I [A], the
    applied voltage V [V], the drive torque on the crank (:func:`drive_torque`), the mechanical
    power k_m·I·φ̇ and the electrical power V·I [W] (φ̇ = ``w``, the motor speed)."""
    out[b] = I
    out[b + 1] = V
    out[b + 2] = drive_torque(I, w, P)
    out[b + 3] = P.k_m * I * w
    out[b + 4] = V * I
