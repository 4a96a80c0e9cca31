"""Scenario tables of the real drive train: ``[drive.pwm]``, ``[drive.encoder]``, ``[drive.sensor]``,
``[drive.gear]``, ``[drive.friction]``, ``[drive.current_loop]`` (sub-tables of ``[drive]``).

Every table is optional; a missing table (``None``) is the ideal element of seed 000 (continuous
voltage source, exact measurement, rigid lossless gear, viscous friction only), so a scenario
without them runs exactly as before.  Physical values take units (``frequency = "20 kHz"``,
``backlash = "0.1 deg"``); bare numbers are SI.  See docs/drivetrain.md.
"""

import math
from typing import Annotated, Literal

from pydantic import BeforeValidator, Field, ValidationInfo, field_validator, model_validator
from pydantic_core import PydanticCustomError

from .. import units as U
from ..fields import Bool, OptQ, Q, Strict, UnitMeta
from ..mechanisms import build as _build


def _torque_or_force(v):
    """A joint friction level: a torque [N·m] (hinge) or a force [N] (slide joint)."""
    try:
        x = U.to_si(v, "torque")
    except U.UnitError:
        try:
            x = U.to_si(v, "force")
        except U.UnitError as e:
            raise PydanticCustomError("mjbench_value", str(e).replace("force", "torque or force")) from None
    if not (math.isfinite(x) and x >= 0):
        raise PydanticCustomError("mjbench_value", "must be a finite value >= 0, got {v!r}", {"v": v})
    return x


#: a joint's friction level: N·m on a hinge, N on a slide joint
TorqueOrForce = Annotated[float, BeforeValidator(_torque_or_force), UnitMeta("torque", plausible=False)]


def _err(msg):
    """A validation error with a ready message (no placeholders)."""
    return PydanticCustomError("mjbench_value", msg.replace("{", "(").replace("}", ")"))


class PWMParams(Strict):
    """``[drive.pwm]``: H-bridge PWM amplifier between the controller and the armature.

    ``model = "averaged"``: the bridge delivers the duty-cycle mean voltage (dead-time error
    included); ``"switching"``: the armature sees the bus voltage levels and the current is
    integrated exactly edge by edge inside every co-simulation step (mechanics held over the step,
    docs/drivetrain.md).  ``scheme = "unipolar"``: sign-magnitude, levels {0, ±v_bus};
    ``"bipolar"``: locked anti-phase, levels ±v_bus.  Centre-aligned carrier.  The amplifier's
    current limit is ``drive.i_max``: the bridge's mean voltage is reduced so that |I| stays
    below it."""

    model: Literal["averaged", "switching"] = "averaged"
    frequency: Q("frequency", gt=0.0, what="a PWM frequency") = Field(description="PWM (carrier) frequency")
    v_bus: Q("voltage", gt=0.0, what="a bus voltage") = Field(description="DC bus voltage of the H-bridge")
    scheme: Literal["unipolar", "bipolar"] = "unipolar"
    dead_time: Q("time", ge=0.0, plausible=False) = Field(0.0, description="dead time at every edge")

    @field_validator("dead_time")
    @classmethod
    def _dead(cls, v, info: ValidationInfo):
        f = info.data.get("frequency")
        if f and v >= 0.5 / f:
            raise _err(f"must be shorter than half a PWM period ({0.5 / f:g} s), got {v:g} s")
        return v


class EncoderParams(Strict):
    """``[drive.encoder]``: incremental encoder; the controller sees the angle quantised to
    2π/(lines·edges) on the encoder's shaft (edges: quadrature decoding ×1, ×2 or ×4)."""

    lines: int = Field(gt=0, description="lines (pulses) per revolution")
    side: Literal["motor", "output"] = Field("motor", description="on the motor shaft or on the output (crank)")
    edges: Literal[1, 2, 4] = Field(4, description="counts per line (quadrature decoding)")


class SensorParams(Strict):
    """``[drive.sensor]``: what the controller sees at each control sample.

    ``speed`` (default: ``"difference"`` with an encoder, ``"true"`` without): ``"difference"``
    (backward difference of the measured angle over the sample period), ``"observer"`` (type-2 tracking observer / PLL of bandwidth ``bandwidth``: zero
    steady error on a constant-speed ramp), ``"mt"`` (M/T method: counts over the time between
    the latest encoder edges, for low speeds; needs an encoder) or ``"true"`` (the exact speed).
    The acceleration (D terms) is the difference of successive speed estimates (the observer's
    own acceleration for ``"observer"``).  Noise (Gaussian, ``seed``) is added on the measured
    shaft (the encoder's side, motor by default).  ``delay``: one-sample computation delay (the
    output computed at sample k is applied at sample k+1)."""

    speed: Literal["difference", "observer", "mt", "true"] | None = Field(
        None, description="speed estimate (default: difference with an encoder, else the exact speed)")
    bandwidth: OptQ("frequency", gt=0.0, plausible=False) = Field(
        None, description="observer natural frequency (default: sample rate / 20)")
    noise_angle: Q("angle", ge=0.0) = Field(0.0, description="angle noise, standard deviation")
    noise_speed: Q("angular_velocity", ge=0.0, plausible=False) = Field(0.0, description="speed noise, standard deviation")
    noise_current: Q("current", ge=0.0, plausible=False) = Field(0.0, description="current noise, standard deviation")
    seed: int = Field(0, ge=0, description="seed of the noise generator")
    delay: Bool = Field(False, description="one-sample computation delay")


class GearParams(Strict):
    """``[drive.gear]``: the reducer's backlash, mesh stiffness and efficiency.

    With ``backlash > 0`` or a ``stiffness`` the gear is *compliant*: the motor is its own
    coordinate, coupled to the output through a dead-zone spring (total play ``backlash`` at the
    output, stiffness and contact damping at the output side) — a MuJoCo fixed tendon with a
    dead-band spring in the multibody model, the same law in the reduced model.  Otherwise the
    gear stays rigid.  ``efficiency`` (motor drives the load) and ``efficiency_back`` (the load
    drives the motor, default = efficiency) scale the motor torque by the direction of the
    power flow."""

    backlash: Q("angle", ge=0.0) = Field(0.0, description="total angular play at the output")
    stiffness: OptQ("rot_stiffness", gt=0.0, plausible=False) = Field(
        None, description="mesh torsional stiffness at the output (default: mesh_frequency)")
    mesh_frequency: Q("frequency", gt=0.0, plausible=False) = Field(
        1000.0, description="mesh resonance (motor against the lighter output side) setting the default stiffness")
    damping: OptQ("rot_damping", ge=0.0) = Field(None, description="mesh contact damping at the output (default: damping_ratio)")
    damping_ratio: float = Field(0.1, ge=0.0, description="mesh contact damping ratio when damping is not given")
    efficiency: float = Field(1.0, gt=0.0, le=1.0, description="forward efficiency (motor drives the load)")
    efficiency_back: float | None = Field(None, gt=0.0, le=1.0, description="back-driving efficiency (default: efficiency)")

    @property
    def compliant(self) -> bool:
        return self.backlash > 0.0 or self.stiffness is not None


class FrictionLaw(Strict):
    """Coulomb + Stribeck (+ viscous) friction of one joint:
    F(v) = F_C + (F_S − F_C)·exp(−(v/v_S)²), opposing the motion, F_S while sticking."""

    coulomb: TorqueOrForce = Field(0.0, description="Coulomb (sliding) level [N·m, N on a slide joint]")
    breakaway: TorqueOrForce | None = Field(None, description="static (breakaway) level, >= coulomb (default: coulomb)")
    stribeck_speed: OptQ("angular_velocity", gt=0.0, plausible=False) = Field(
        None, description="Stribeck speed v_S (needed when breakaway > coulomb) [rad/s, m/s on a slide joint]")

    @field_validator("breakaway")
    @classmethod
    def _breakaway(cls, v, info: ValidationInfo):
        c = info.data.get("coulomb")
        if v is not None and c is not None and v < c:
            raise _err(f"must be >= coulomb = {c:g}, got {v:g}")
        return v

    @field_validator("stribeck_speed")
    @classmethod
    def _stribeck(cls, v, info: ValidationInfo):
        c, b = info.data.get("coulomb"), info.data.get("breakaway")
        if v is None and b is not None and c is not None and b > c:
            raise _err("required when breakaway > coulomb (the speed over which the friction drops to coulomb)")
        return v

    @property
    def static(self) -> float:
        return self.coulomb if self.breakaway is None else self.breakaway


class JointFriction(FrictionLaw):
    """``[drive.friction.joints.NAME]``: friction of a joint of the mechanism's model."""

    viscous: Q("rot_damping", ge=0.0, plausible=False) = Field(0.0, description="viscous coefficient [N·m·s/rad, N·s/m]")


class FrictionParams(FrictionLaw):
    """``[drive.friction]``: dry friction on the motor shaft (motor side; its viscous friction is
    ``drive.lam``) and, in ``joints``, on any joint of the mechanism (MuJoCo ``frictionloss``
    in the multibody model, the same law in the reduced model)."""

    joints: dict[str, JointFriction] = Field(default_factory=dict, description="friction per joint name")


class CurrentLoopParams(Strict):
    """``[drive.current_loop]``: inner PI current controller.  The mode's controller output is
    then a current reference [A] (clipped to ±i_max), and the PI sets the armature voltage.
    Give ``bandwidth`` (kp = L·ω_c, ki = R·ω_c: the PI zero cancels the armature pole, closed
    loop ≈ first order at ω_c) or ``kp`` and ``ki``."""

    bandwidth: OptQ("frequency", gt=0.0, plausible=False) = Field(None, description="closed-loop bandwidth f_c")
    kp: OptQ("gain_v_per_a", ge=0.0) = Field(None, description="proportional gain [V/A]")
    ki: OptQ("gain_v_per_a_s", ge=0.0) = Field(None, description="integral gain [V/(A·s)]")
    period: Q("time", ge=0.0, plausible=False) = Field(0.0, description="current-loop period (0: every co-simulation step)")

    @model_validator(mode="after")
    def _gains(self):
        if (self.bandwidth is None) == (self.kp is None and self.ki is None):
            raise _err("give either bandwidth, or kp and ki")
        if self.bandwidth is None and (self.kp is None or self.ki is None):
            raise _err("give both kp and ki (or a bandwidth)")
        return self


#: the optional sub-tables of [drive], in the order they act
SUBTABLES = ("pwm", "encoder", "sensor", "gear", "friction", "current_loop")


def control_rate(mode_params, dt: float) -> tuple[float, float]:
    """(rate [Hz], period [s]) at which a mode's controller updates its output."""
    p = getattr(mode_params, "period", None)
    if p is None:
        p = getattr(mode_params, "Ts", None)
    p = float(p or 0.0)
    if p <= 0.0:
        p = float(dt)
    return 1.0 / p, p


def check_against(drive, scn) -> list[str]:
    """Cross-table checks of the drive train against the scenario (paths relative to the root)."""
    problems = []
    dt = float(scn.simulation.dt)
    pwm, sensor, enc, cl = drive.pwm, drive.sensor, drive.encoder, drive.current_loop
    if pwm is not None:
        for name, mp in scn.modes.items():
            rate, per = control_rate(mp, dt)
            if pwm.frequency < rate * (1 - 1e-9):
                problems.append(f"drive.pwm.frequency: {pwm.frequency:g} Hz is below the control rate {rate:g} Hz "
                                f"of modes.{name} (sample period {per:g} s): the duty cycle cannot change faster "
                                f"than the PWM period")
        if cl is not None:
            per = float(cl.period) if cl.period > 0 else dt
            if pwm.frequency < (1.0 / per) * (1 - 1e-9):
                problems.append(f"drive.pwm.frequency: {pwm.frequency:g} Hz is below the current-loop rate "
                                f"{1 / per:g} Hz (drive.current_loop.period {per:g} s)")
        if pwm.model == "switching" and drive.L <= 0:
            problems.append("drive.pwm.model: 'switching' needs an armature inductance drive.L > 0")
    if sensor is not None and sensor.speed == "mt" and enc is None:
        problems.append("drive.sensor.speed: 'mt' (M/T method) needs an encoder ([drive.encoder] lines = ...)")
    if sensor is not None and sensor.speed == "observer" and sensor.bandwidth is not None:
        for name, mp in scn.modes.items():
            _, per = control_rate(mp, dt)
            w = 2 * math.pi * sensor.bandwidth * per
            a, b = 2.0 * w, w * w  # α-β gains of the discrete observer (critically damped)
            if not (a < 2.0 and b < 4.0 - 2.0 * a):
                problems.append(f"drive.sensor.bandwidth: {sensor.bandwidth:g} Hz is too high for the sample period "
                                f"{per:g} s of modes.{name} (the discrete observer is unstable; keep "
                                f"2π·f·T < {_max_wT():.3g})")
    if cl is not None and cl.period > 0:
        k = cl.period / dt
        if abs(k - round(k)) > 1e-6 * max(1.0, k) or round(k) < 1:
            problems.append(f"drive.current_loop.period: {cl.period:g} s must be a whole multiple of simulation.dt = {dt:g} s")
    fr = drive.friction
    if fr is not None and fr.joints:
        try:

            mech = _build(scn.mechanism)
            spec = mech.build_spec(0.0, {"timestep": dt})
            names = {j.name for j in spec.joints}
        except Exception:  # noqa: BLE001 - reported by the mechanism's own validation
            names = None
        if names is not None:
            for jn in fr.joints:
                if jn not in names:
                    problems.append(f"drive.friction.joints.{jn}: the mechanism's model has no joint {jn!r}; "
                                    f"joints: {', '.join(sorted(names))}")
    return problems


def _max_wT() -> float:
    """Largest ω_n·T of a stable critically damped α-β observer (α = 2ω_nT, β = (ω_nT)²)."""
    # α < 2 ⇒ wT < 1; β < 4 − 2α ⇒ w² + 4w − 4 < 0 ⇒ w < −2 + 2√2 ≈ 0.828
    return -2.0 + 2.0 * math.sqrt(2.0)
