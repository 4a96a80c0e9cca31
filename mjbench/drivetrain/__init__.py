"""The real drive train: PWM amplifier, encoder and speed estimation, sampling delay, gear
backlash/stiffness/efficiency, dry friction, inner current loop (docs/drivetrain.md).

Every element is optional (``[drive.pwm]``, ``[drive.encoder]``, ``[drive.sensor]``,
``[drive.gear]``, ``[drive.friction]``, ``[drive.current_loop]``); without them the drive is the
ideal one of seed 000 and ``DCMotorDrive.train`` is None.  With them, each element is a *law*
(:mod:`mjbench.compiled`) in a slot of the kernel's one loop (:mod:`mjbench.kernel`), declared by
:meth:`DriveTrain.forms`:

* ``sense``: the sensor (:func:`~mjbench.drivetrain.sensor.sensor_law`: quantisation, speed
  estimate, noise) at each control sample, before the controller; ``delay``: the one-sample
  computation delay (the kernel's own); ``limit``: ±i_max when a current loop makes the
  controller's output a current reference (±v_max otherwise);
* ``cloop``: the PI current loop (:func:`~mjbench.drivetrain.currentloop.current_loop_law`) at
  every co-step, at its own period;
* ``amp``: the PWM bridge (:func:`~mjbench.drivetrain.amplifier.pwm_averaged`, or
  :func:`~mjbench.drivetrain.amplifier.pwm_switching` with its end-current law);
* ``eff``: the gear efficiency (:func:`~mjbench.drivetrain.gear.gear_efficiency`).

An element that is off leaves its slot switched off by a constant flag (no work in the loop).
The Python objects (:class:`Amplifier`, :class:`Sensor`, :class:`CurrentLoop`, :class:`Gear`)
call the same laws.  The mechanical elements (compliant gear, friction) live in the plant's
model: :meth:`DriveTrain.wrap` returns the mechanism wrapped in a
:class:`~mjbench.drivetrain.gear.DrivenMechanism`, built into both the MuJoCo and the reduced
model (:class:`mjbench.machine.Machine` does it).  Parameters are scalars: a batch is N runs,
each with its own objects.
"""
from __future__ import annotations

from .amplifier import Amplifier
from .currentloop import CurrentLoop
from .gear import DEFLECTION, DrivenMechanism, Friction, Gear
from .sensor import Sensor

__all__ = ["DriveTrain", "Amplifier", "Sensor", "Gear", "Friction", "CurrentLoop", "DrivenMechanism",
           "DEFLECTION"]


class DriveTrain:
    """The optional drive-train elements of one drive (each None = ideal)."""

    def __init__(self, pwm=None, sensor=None, gear=None, friction=None, current_loop=None):
        self.pwm, self.sensor, self.gear, self.friction, self.current_loop = pwm, sensor, gear, friction, current_loop

    @classmethod
    def from_params(cls, p, drive) -> "DriveTrain | None":
        """From a validated :class:`~mjbench.drive.DriveParams` (None if it has no sub-table)."""
        pwm = sensor = gear = friction = cl = None
        if p.pwm is not None:
            w = p.pwm
            pwm = Amplifier(w.model, w.frequency, w.v_bus, w.scheme, w.dead_time)
        if p.encoder is not None or p.sensor is not None:
            e, s = p.encoder, p.sensor
            kw = {}
            if e is not None:
                kw.update(lines=e.lines, side=e.side, edges=e.edges)
            kw["speed"] = (s.speed if s is not None else None) or ("difference" if e is not None else "true")
            if s is not None:
                kw.update(bandwidth=s.bandwidth, noise_angle=s.noise_angle, noise_speed=s.noise_speed,
                          noise_current=s.noise_current, seed=s.seed, delay=s.delay)
            sensor = Sensor(**kw)
        if p.gear is not None:
            g = p.gear
            gear = Gear(g.backlash, g.stiffness, g.mesh_frequency, g.damping, g.damping_ratio, g.efficiency,
                        g.efficiency_back)
        if p.friction is not None:
            f = p.friction
            friction = Friction(f.coulomb, f.breakaway, f.stribeck_speed,
                                {k: v.model_dump() for k, v in f.joints.items()})
        if p.current_loop is not None:
            c = p.current_loop
            if c.bandwidth is not None:
                cl = CurrentLoop.from_bandwidth(c.bandwidth, drive.L, drive.R, c.period)
            else:
                cl = CurrentLoop(c.kp, c.ki, c.period)
        if all(v is None for v in (pwm, sensor, gear, friction, cl)):
            return None
        return cls(pwm, sensor, gear, friction, cl)

    def describe(self) -> dict:
        return {k: v.describe() for k, v in (("pwm", self.pwm), ("sensor", self.sensor), ("gear", self.gear),
                                            ("friction", self.friction), ("current_loop", self.current_loop))
                if v is not None}

    # ------------------------------------------------------------------ mechanics
    @property
    def mechanical(self) -> bool:
        """Whether the plant's model changes (compliant gear or friction)."""
        return (self.gear is not None and self.gear.compliant) or self.friction is not None

    def wrap(self, mechanism, drive):
        """The mechanism with the compliant gear / friction built in (itself if none)."""
        if not self.mechanical or isinstance(mechanism, DrivenMechanism):
            return mechanism
        gear = self.gear if (self.gear is not None and self.gear.compliant) else None
        return DrivenMechanism(mechanism, drive, gear, self.friction)

    # ------------------------------------------------------------------ compiled forms
    @property
    def compliant(self) -> bool:
        return self.gear is not None and self.gear.compliant

    def forms(self, drive, h, every, plant=None) -> dict:
        """The elements' forms for the kernel's slots at co-step h [s], the controller sampled every
        ``every`` steps (see :meth:`mjbench.kernel.Program.build` and the module docstring)."""
        out = {}
        sen, cl, amp = self.sensor, self.current_loop, self.pwm
        if sen is not None:
            if sen.needs_law(self.compliant):
                out["sense"] = sen.form(float(drive.z), every * h, self.compliant)
            else:  # only the delay: record the exact values the controller saw
                out["sense_cols"] = True
            if sen.delay:
                out["delay"] = True
        if cl is not None:
            imax = float(drive.i_max)
            out["limit"] = (-imax, imax)  # the controller's output is a current reference
            vmax = float(drive.v_max)
            if amp is not None:
                vmax = min(vmax, amp.v_bus)
            nc, seed = (sen.noise_current, sen.seed) if sen is not None else (0.0, 0)
            out["cloop"] = cl.form(h, vmax, nc, seed)
        if amp is not None:
            out["amp"] = amp.form(drive, h)
        if self.gear is not None:
            eff = self.gear.efficiency_form()
            if eff is not None:
                out["eff"] = eff
        return out
