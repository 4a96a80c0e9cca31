"""The real drive train: PWM amplifier, encoder and speed estimation, sampling delay, gear
backlash/stiffness/efficiency, dry friction, inner current loop (docs/drivetrain.md).

Every element is optional (``[drive.pwm]``, ``[drive.encoder]``, ``[drive.sensor]``,
``[drive.gear]``, ``[drive.friction]``, ``[drive.current_loop]``); without them the drive is the
ideal one of seed 000 and the kernel runs its own inline code, unchanged.  With them,
``DCMotorDrive.train`` is a :class:`DriveTrain` and the kernel calls three hooks bound once before
the loop (:meth:`DriveTrain.bind`):

* ``sample(t, q, q̇, q̈, I) → u``: at each control sample — sensor (quantisation, speed
  estimate, noise) → controller → limiter (voltage, or current reference with a current loop) →
  one-sample delay;
* ``step(t, I, u, q̇) → I₊``: at each co-simulation step — current loop → amplifier (averaged or
  switching PWM) → motor torque (Coulomb T_0, efficiency) → ``plant.advance`` → current update;
* ``write(row)``: at each recorded sample — the drive train's columns (and the motor-side core
  columns when the gear is compliant).

Hooks that an element set does not need are ``None`` (the kernel then runs its inline ideal
code): e.g. an encoder alone binds only ``sample``.  The mechanical elements (compliant gear,
friction) live in the plant's model: :meth:`DriveTrain.wrap` returns the mechanism wrapped in a
:class:`~mjbench.drivetrain.gear.DrivenMechanism`, built into both the MuJoCo and the reduced
model (:class:`mjbench.machine.Machine` does it).  Scalars or (nsim,) arrays, like the drive.
"""
from __future__ import annotations

import numpy as np

from .amplifier import Amplifier
from .currentloop import CurrentLoop
from .gear import DEFLECTION, DrivenMechanism, Friction, Gear
from .sensor import Sensor

__all__ = ["DriveTrain", "Amplifier", "Sensor", "Gear", "Friction", "CurrentLoop", "DrivenMechanism", "Hooks",
           "DEFLECTION"]


class Hooks:
    """The kernel's drive-train hooks of one run (see the module docstring); None = ideal."""

    def __init__(self, sample=None, step=None, write=None, columns=()):
        self.sample, self.step, self.write, self.columns = sample, step, write, tuple(columns)


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
    def forms(self, drive, h, every, plant) -> dict:
        """The elements' forms for the kernel's slots (see :mod:`mjbench.kernel`)."""
        raise NotImplementedError("drive-train elements are being ported to the compiled kernel")

    # ------------------------------------------------------------------ kernel hooks
    def bind(self, plant, drive, controller, h, every, nsim, y) -> Hooks:
        """The hooks of one run (called by the kernel after ``plant.start()``).  ``every``: co-steps per
        control sample; ``nsim``: None for a single run; ``y``: the kernel's Measurement."""
        batch = nsim is not None
        T = every * h
        z = drive.z
        machines = getattr(plant, "machines", None) or [getattr(plant, "machine", None)]
        mechs = [mc.mechanism for mc in machines if mc is not None]
        for m in mechs:
            if isinstance(m, DrivenMechanism):
                m.set_step(h)
        mech = mechs[0] if mechs else None
        compliant = isinstance(mech, DrivenMechanism) and mech.compliant
        rates = None
        nx = len(mech.internal) if mech is not None else 0
        if compliant:
            rates = _rates_reader(plant, mech, nx, nsim)

        columns = []
        cl, amp, sen = self.current_loop, self.pwm, self.sensor
        # ---------------------------------------------------------- sample
        sample = None
        measure = None
        if sen is not None:
            measure = sen.bind(z, T, nsim, rates if compliant else None)
            columns += ["angle_meas_rad", "speed_est_rad_s", "accel_est_rad_s2"]
            if sen.exact and not compliant:  # only the delay: the exact measurement, as the kernel's
                measure = None
        if cl is not None:
            imax = drive.i_max
            if drive._no_ilimit:
                def ulimit(u):
                    return u
            elif batch:
                def ulimit(u):
                    return np.minimum(np.maximum(u, -imax), imax)
            else:
                im = float(imax)

                def ulimit(u):
                    return im if u > im else (-im if u < -im else u)
        else:
            ulimit = drive.limit
        delay = sen is not None and sen.delay
        if measure is not None or cl is not None or delay:
            pend = [0.0 if not batch else np.zeros(nsim)]

            def sample(t, q, qd, qdd, I):
                yy = measure(y, t, q, qd, qdd, I) if measure is not None else y.set(t, q, qd, qdd, I)
                u = ulimit(controller(t, yy))
                if delay:
                    u, pend[0] = pend[0], u
                return u

        # ---------------------------------------------------------- step
        step = None
        eff = self.gear.efficiency_function(batch) if self.gear is not None else None
        last = {"V": 0.0, "imin": 0.0, "imax": 0.0, "imean": 0.0}
        if amp is not None or cl is not None or eff is not None or compliant:
            step = self._step(plant, drive, h, nsim, compliant, rates, eff, last, columns)
        if cl is not None:
            columns.append("current_ref_A")

        # ---------------------------------------------------------- write
        write = None
        if columns or compliant:
            write = self._writer(drive, nx, compliant, last, columns, batch, y)
        return Hooks(sample, step, write, columns)

    def _step(self, plant, drive, h, nsim, compliant, rates, eff, last, columns):
        batch = nsim is not None
        z, k_m, R = drive.z, drive.k_m, drive.R
        T0 = drive.T_0
        has_T0 = bool(np.any(np.asarray(T0) != 0))
        advance = plant.advance  # one step; returns the input angle and speed at its end
        cm, cs = drive.current_mean, drive.current_step
        amp, cl = self.pwm, self.current_loop
        avg = sw = None
        if amp is not None:
            if amp.switching:
                sw = amp.bind_switching(drive, h, batch)
                columns += ["voltage_bridge_V", "current_mean_A", "current_min_A", "current_max_A"]
            else:
                avg = amp.bind_averaged(drive, h, batch)
                columns += ["voltage_bridge_V", "current_mean_A"]
        loop = None
        if cl is not None:
            vmax = drive.v_max
            if amp is not None:
                vmax = np.minimum(vmax, amp.v_bus)
            meas = self.sensor.measure_current if self.sensor is not None and \
                bool(np.any(np.asarray(self.sensor.noise_current) > 0)) else None
            loop = cl.bind(h, vmax, nsim, meas)
        corr = k_m / R * (1.0 - drive._decay)  # end-current change per unit of mean-speed change
        no_ilimit = drive._no_ilimit
        imax = drive.i_max
        sign = np.sign if batch else _sign

        def step(t, I, u, qd):
            V = loop(u, I) if loop is not None else u
            if compliant:
                w0 = z * (qd + rates()[1])
            else:
                w0 = z * qd
            if sw is not None:
                Ibar, Iend, Vb, i_lo, i_hi = sw(t, I, V, w0)
                last["imin"], last["imax"], last["imean"] = i_lo, i_hi, Ibar
            else:
                if avg is not None:
                    Vb = V = avg(I, V, w0)
                else:
                    Vb = V
                Ibar = cm(I, V, w0, h)
                last["imean"] = Ibar
            last["V"] = Vb
            Tm = k_m * Ibar
            if has_T0:
                Tm = Tm - T0 * sign(w0)
            if eff is not None:
                Tm = eff(Tm, w0)
            qd1 = advance(z * Tm, t)[1]
            if compliant:
                w1 = z * (qd1 + rates()[1])
            else:
                w1 = z * qd1
            wm = 0.5 * (w0 + w1)
            if sw is not None:
                I = Iend - corr * (wm - w0)
                if not no_ilimit:
                    I = np.clip(I, -imax, imax)
                    if not batch:
                        I = float(I)
                return I
            return cs(I, V, wm, h)

        return step

    def _writer(self, drive, nx, compliant, last, columns, batch, yv):
        from ..trajectory import NAMES

        z, k_m, lam, T0 = drive.z, drive.k_m, drive.lam, drive.T_0
        sign = np.sign if batch else _sign
        base = len(NAMES) + 2 * nx  # drive-train columns follow the core and the plant's columns
        iv = len(NAMES) + 2 * nx - 1 if compliant else None
        names = list(columns)
        sen = self.sensor
        exact = sen is not None and sen.exact and not compliant
        cl = self.current_loop is not None
        idx = {n: base + i for i, n in enumerate(names)}

        def write(r):
            I = r[..., 5]
            if compliant:
                w = z * (r[..., 2] + r[..., iv])
                r[..., 4] = w
                r[..., 7] = z * (k_m * I - T0 * sign(w) - lam * w)
                r[..., 8] = k_m * I * w
            if sen is not None:
                if exact:  # what the controller saw: the kernel's exact measurement
                    r[..., idx["angle_meas_rad"]] = yv.q
                    r[..., idx["speed_est_rad_s"]] = yv.qd
                    r[..., idx["accel_est_rad_s2"]] = yv.qdd
                else:
                    lv = sen.last
                    r[..., idx["angle_meas_rad"]] = lv[0]
                    r[..., idx["speed_est_rad_s"]] = lv[1]
                    r[..., idx["accel_est_rad_s2"]] = lv[2]
            if "voltage_bridge_V" in idx:
                r[..., idx["voltage_bridge_V"]] = last["V"]
            if "current_mean_A" in idx:
                r[..., idx["current_mean_A"]] = last["imean"]
            if "current_min_A" in idx:
                r[..., idx["current_min_A"]] = last["imin"]
                r[..., idx["current_max_A"]] = last["imax"]
            if cl:
                r[..., idx["current_ref_A"]] = r[..., 6]
                r[..., 6] = last["V"]
                r[..., 9] = last["V"] * I
        return write


def _sign(x):
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


def _rates_reader(plant, mech, nx, nsim):
    """() → (δ, δ̇): the compliant gear's deflection and rate in the plant's current state.

    Direct reads for the built-in plants (MuJoCo data / the reduced state), else the generic
    plant protocol (``extra``: every internal coordinate)."""
    from ..backends.multibody import MultibodyPlant
    from ..backends.reduced import ReducedPlant

    if type(plant) is MultibodyPlant:
        ids = mech._ids(plant.model)
        qpos, qvel = plant.data.qpos, plant.data.qvel
        qm, qc, vm, vc = ids["qm"], ids["qc"], ids["vm"], ids["vc"]

        def rates():
            return float(qpos[qm] - qpos[qc]), float(qvel[vm] - qvel[vc])
        return rates
    if type(plant) is ReducedPlant and nsim is None:
        def rates():
            return plant.x[-1], plant.xd[-1]
        return rates
    buf = np.zeros((2 * nx, nsim)) if nsim is not None else np.zeros(2 * nx)
    extra = plant.extra
    ix, iv = nx - 1, 2 * nx - 1
    if nsim is not None:
        def rates():
            extra(buf)
            return buf[ix].copy(), buf[iv].copy()
    else:
        def rates():
            extra(buf)
            return float(buf[ix]), float(buf[iv])
    return rates

