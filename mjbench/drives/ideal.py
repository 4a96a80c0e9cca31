"""Ideal drives: a torque source and a stiff speed source on the input joint (no motor electrics).

``[drive] type = "torque"`` (:class:`TorqueDrive`): the controller's output u is the torque [N·m]
applied to the input joint, held over each co-simulation step (as the DC motor's torque is) and
limited to ±``T_max``.  Optional ``J`` (a rotor's inertia on the input, the MuJoCo joint's
armature) and ``damping`` (viscous friction on the input, the joint's damping), both integrated by
the plant inside the step.  There is no gearbox (z = 1: the recorded motor speed is the input
speed), no current, no voltage.

``[drive] type = "speed"`` (:class:`SpeedDrive`): the controller's output u is a commanded input
speed ω* [rad/s] (limited to ±``speed_max``) that a stiff velocity loop makes the input follow:

    T = k_v·(ω* − q̇) + k_i·∫(ω* − q̇) dt

The −k_v·q̇ part is a viscous coefficient on the input joint — integrated by the plant inside the
step like the DC motor's z²λ (MuJoCo joint damping; the same term in the reduced model's RK4) —
and k_v·ω* + k_i·e (e the integral, the drive's state, updated with the step-mean speed) is held
over the step.  It is a model of a real servo's velocity loop, not a prescribed-motion constraint:
the input lags the command by T_load/k_v without the integral (and settles with it), and the loop
is stable for h·k_v/(J_eq + J(q)) below RK4's limit 2.78 (the divergence message says so).  The
recorded ``torque_crank_Nm`` is T, the torque the servo applies (inverse dynamics of the commanded
motion when k_v is large).

Recorded columns of both (:data:`mjbench.trajectory.COLUMNS`): ``current_A``, ``voltage_V`` and
``power_elec_W`` are NaN (not modelled: an ideal source has no electrics); ``torque_crank_Nm`` is
the drive's torque on the input (its viscous part included); ``power_mech_W`` is the power the
source delivers, T·q̇ (for the torque source before its own damping, as the DC motor's k_m·I·φ̇ is
before its friction).  Every law is a :func:`mjbench.compiled.law`: CPython and the compiled loop
give the same bits.
"""

import math
from collections import namedtuple
from dataclasses import dataclass
from typing import Literal

from pydantic import Field

from .. import compiled as C
from ..fields import Q, Strict
from . import Drive, DriveCapabilityError, register

#: controller types whose output is an armature voltage or that model a DC motor (refused on an ideal drive)
VOLTAGE_MODES = {"open": "gives an armature voltage", "smc": "models a DC motor (R, L, k_m: Eq 37)",
                 "servo": "feeds forward through a DC motor's k_m and R"}
#: DC-motor quantities an ideal drive does not have (asking for one is a DriveCapabilityError)
MOTOR_ONLY = ("R", "L", "k_m", "J_m", "J_a", "J_b", "T_0", "lam", "v_max", "i_max")


def mode_output_problems(scn, drive_type: str) -> list[str]:
    """Modes whose output does not fit the drive type: a ``constant`` torque/speed on a DC motor or
    on the other ideal drive, a voltage controller on an ideal drive; and an initial current on
    an ideal drive."""
    out = []
    for name, mp in scn.modes.items():
        typ = getattr(mp, "type", None)
        if typ == "constant":
            kind = "torque" if getattr(mp, "torque", None) is not None else "speed"
            if kind != drive_type:
                fix = ("use type = \"open\" with voltage = …" if drive_type == "dcmotor"
                       else f"give {drive_type} = … instead")
                out.append(f"modes.{name}: type = \"constant\" with {kind} = … needs [drive] type = \"{kind}\"; "
                           f"this drive is type = \"{drive_type}\" ({fix})")
        elif typ == "signal" and getattr(mp, "kind", None) is not None:
            kind = mp.kind
            need = "dcmotor" if kind == "voltage" else kind
            if need != drive_type:
                out.append(f"modes.{name}: type = \"signal\" with {kind} = … needs [drive] type = \"{need}\"; this "
                           f"drive is type = \"{drive_type}\" (give "
                           f"{'voltage' if drive_type == 'dcmotor' else drive_type} = … instead)")
        elif drive_type != "dcmotor" and typ in VOLTAGE_MODES:
            out.append(f"modes.{name}: type = \"{typ}\" {VOLTAGE_MODES[typ]}, but [drive] type = \"{drive_type}\" is an "
                       f"ideal {drive_type} source without motor electrics: use type = \"constant\" with "
                       f"{drive_type} = … (or a pid, whose output is then the {drive_type})")
    if drive_type != "dcmotor" and float(scn.initial.I0) != 0.0:
        out.append(f"initial.I0 = {float(scn.initial.I0):g} A: an ideal {drive_type} source has no current (leave it 0)")
    return out


class _Ideal(Drive):
    """What the ideal drives share: no gearbox, no drive train, DC-motor quantities refused."""

    z = 1.0
    train = None
    type_name = ""

    def __getattr__(self, name):
        if name in MOTOR_ONLY:
            raise DriveCapabilityError(
                f"drive.{name}: [drive] type = \"{self.type_name}\" is an ideal {self.type_name} source without motor "
                f"electrics or gearbox (no {name}); this analysis needs a DC motor ([drive] type = \"dcmotor\")")
        raise AttributeError(name)

    def forms(self, h: float, every: int, plant) -> dict:
        """No drive-train elements; the controller output's clip (the command limit)."""
        return {"limit": (-float(self.limit_value), float(self.limit_value))}

    def as_dict(self) -> dict:
        return {"type": self.type_name, **{k: getattr(self, k) for k in self.FIELDS}}


# ============================================================================ torque source
class TorqueDriveParams(Strict):
    """``[drive] type = "torque"``: an ideal torque source on the input joint (no electrics, z = 1).
    The mode's output is the input torque [N·m]."""

    type: Literal["torque"] = "torque"
    J: Q("inertia", ge=0.0, what="a rotor inertia") = Field(0.0, description="inertia the source adds on the input (armature)")
    damping: Q("rot_damping", ge=0.0) = Field(0.0, description="viscous friction of the source on the input")
    T_max: Q("torque", gt=0.0, finite=False) = Field(math.inf, description="limit ±T_max of the commanded torque (inf: none)")

    @property
    def z(self) -> float:
        return 1.0

    def build(self) -> "TorqueDrive":
        return TorqueDrive(J=float(self.J), damping=float(self.damping), T_max=float(self.T_max))

    def check_against(self, scn) -> list[str]:
        return mode_output_problems(scn, "torque")


@register
@dataclass
class TorqueDrive(_Ideal):
    """Ideal torque source: u [N·m] on the input joint, held over the step; J [kg·m²] and damping
    [N·m·s/rad] on the input joint (the plant's armature and damping); T_max the command limit."""

    J: float = 0.0
    damping: float = 0.0
    T_max: float = math.inf
    FIELDS = ("J", "damping", "T_max")
    type_name = "torque"
    Params = TorqueDriveParams

    def __post_init__(self):
        for name in ("J", "damping"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0.0):
                raise DriveCapabilityError(f"drive.{name} = {v!r}: must be finite and >= 0")
        if not float(self.T_max) > 0.0:
            raise DriveCapabilityError(f"drive.T_max = {self.T_max!r}: must be > 0")

    @property
    def J_eq(self) -> float:
        return float(self.J)

    @property
    def crank_damping(self) -> float:
        return float(self.damping)

    @property
    def limit_value(self) -> float:
        return float(self.T_max)

    def form(self, h: float) -> C.Form:
        """The torque source's laws: the held command is the torque (:func:`torque_mean`), no state."""
        return C.Form(torque_mean, TorqueP(1.0, float(self.damping)),
                      laws={"limit": command_pass, "mean": torque_mean, "torque": torque_pass, "step": no_state,
                            "record": torque_record})

    def diagnose(self, machine, h: float) -> str:
        return ""


#: the torque source's law parameters: gear ratio (1) and its viscous coefficient on the input
TorqueP = namedtuple("TorqueP", "z damping")


@C.law
def command_pass(I, V, w, P):
    """The applied command: the controller's output as clipped by the kernel (±T_max, ±speed_max)."""
    return V


@C.law
def torque_mean(I, V, w, P):
    """The torque held over the step: the command."""
    return V


@C.law
def torque_pass(T, w, P):
    """The input torque: the held torque itself (the viscous part is the plant's damping)."""
    return T


@C.law
def no_state(I, V, w_mean, P):
    """No electrical state: the kernel's current stays 0."""
    return 0.0


@C.law
def torque_record(out, b, I, V, w, P):
    """Recorded columns of a torque source: current, voltage NaN (none); torque on the input
    T − c·q̇ (c its damping); delivered power T·q̇; electrical power NaN."""
    out[b] = math.nan
    out[b + 1] = math.nan
    out[b + 2] = V - P.damping * w
    out[b + 3] = V * w
    out[b + 4] = math.nan


# ============================================================================ speed source
class SpeedDriveParams(Strict):
    """``[drive] type = "speed"``: a stiff velocity loop makes the input follow the mode's output, a
    commanded input speed [rad/s] (no electrics, z = 1; see the module doc for the model)."""

    type: Literal["speed"] = "speed"
    k_v: Q("rot_damping", gt=0.0, what="a velocity-loop gain") = Field(
        description="velocity-loop gain: torque per speed error [N·m·s/rad]")
    k_i: Q("rot_stiffness", ge=0.0, plausible=False) = Field(
        0.0, description="integral gain: torque per integrated speed error [N·m/rad] (0: proportional loop)")
    J: Q("inertia", ge=0.0, what="a rotor inertia") = Field(0.0, description="inertia the servo adds on the input (armature)")
    speed_max: Q("angular_velocity", gt=0.0, finite=False, plausible=False) = Field(
        math.inf, description="limit ±speed_max of the commanded speed (inf: none)")

    @property
    def z(self) -> float:
        return 1.0

    def build(self) -> "SpeedDrive":
        return SpeedDrive(k_v=float(self.k_v), k_i=float(self.k_i), J=float(self.J), speed_max=float(self.speed_max))

    def check_against(self, scn) -> list[str]:
        return mode_output_problems(scn, "speed")


@register
@dataclass
class SpeedDrive(_Ideal):
    """Stiff speed source: T = k_v·(ω* − q̇) + k_i·∫(ω* − q̇)dt on the input joint, −k_v·q̇ as the
    joint's damping (integrated inside the step), the rest held; J [kg·m²] its rotor on the input."""

    k_v: float = 1.0
    k_i: float = 0.0
    J: float = 0.0
    speed_max: float = math.inf
    FIELDS = ("k_v", "k_i", "J", "speed_max")
    type_name = "speed"
    Params = SpeedDriveParams

    def __post_init__(self):
        if not (math.isfinite(float(self.k_v)) and float(self.k_v) > 0.0):
            raise DriveCapabilityError(f"drive.k_v = {self.k_v!r}: must be finite and > 0")
        for name in ("k_i", "J"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0.0):
                raise DriveCapabilityError(f"drive.{name} = {v!r}: must be finite and >= 0")
        if not float(self.speed_max) > 0.0:
            raise DriveCapabilityError(f"drive.speed_max = {self.speed_max!r}: must be > 0")

    @property
    def J_eq(self) -> float:
        return float(self.J)

    @property
    def crank_damping(self) -> float:
        """The loop's proportional part on the measured speed, k_v [N·m·s/rad] (the plant's damping)."""
        return float(self.k_v)

    @property
    def limit_value(self) -> float:
        return float(self.speed_max)

    def form(self, h: float) -> C.Form:
        """The speed loop's laws: held torque k_v·ω* + k_i·e (:func:`speed_held`), e updated with
        the step-mean speed (:func:`speed_integral`)."""
        return C.Form(speed_held, SpeedP(1.0, float(h), float(self.k_v), float(self.k_i)),
                      laws={"limit": command_pass, "mean": speed_held, "torque": torque_pass, "step": speed_integral,
                            "record": speed_record})

    def diagnose(self, machine, h: float) -> str:
        """A loop too stiff for the step: h·k_v/J_min beyond RK4's stability limit on the real axis."""
        jmin, _ = machine.input_inertia()
        x = h * float(self.k_v) / jmin if jmin > 0 else math.inf
        if x > 2.5:
            return (f" Likely cause: the speed loop is too stiff for the step: h·k_v/(J_eq + J(q)) = {x:.3g} "
                    f"(k_v = {float(self.k_v):g} N·m·s/rad, smallest input inertia {jmin:.3g} kg·m², h = {h:g} s) "
                    f"is near or beyond RK4's stability limit 2.78; lower drive.k_v or simulation.dt.")
        return ""


#: the speed loop's law parameters: gear ratio (1), step h, gains k_v, k_i
SpeedP = namedtuple("SpeedP", "z h k_v k_i")


@C.law
def speed_held(I, V, w, P):
    """The held part of the loop's torque over the step: k_v·ω* + k_i·e (e = ``I``, the integral)."""
    return P.k_v * V + P.k_i * I


@C.law
def speed_integral(I, V, w_mean, P):
    """e₊ = e + h·(ω* − q̇̄): the integral of the speed error with the step-mean speed."""
    return I + P.h * (V - w_mean)


@C.law
def speed_record(out, b, I, V, w, P):
    """Recorded columns of a speed source: current, voltage NaN (none); torque on the input
    k_v·(ω* − q̇) + k_i·e; delivered power T·q̇; electrical power NaN."""
    T = P.k_v * (V - w) + P.k_i * I
    out[b] = math.nan
    out[b + 1] = math.nan
    out[b + 2] = T
    out[b + 3] = T * w
    out[b + 4] = math.nan
