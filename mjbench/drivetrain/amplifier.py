"""PWM H-bridge amplifier: averaged (duty-cycle mean) and switching models.

Bridge (centre-aligned carrier of period T = 1/f, duty d):

* ``bipolar`` (locked anti-phase): levels +V_bus ("on") and −V_bus ("off"), d = (1 + V/V_bus)/2;
* ``unipolar`` (sign-magnitude): levels s·V_bus ("on") and 0 ("off"), s = sgn V, d = |V|/V_bus.

The "on" level is applied during the middle d·T of every period.  Dead time t_d: after every
commanded edge both switches of the leg are off for t_d and the freewheeling diodes set the
voltage by the current's direction (the lower level for I > 0, the upper one for I < 0), so an
edge *towards* the level the current does not pull to is delayed by t_d.  Averaged over a period
this shifts the duty by −σ·t_d·f with σ = sgn I (bipolar; unipolar: sgn I·s): the classic
dead-time voltage error 2·V_bus·t_d·f (bipolar) or V_bus·t_d·f (unipolar).

Averaged model: the armature gets the period-mean voltage; the current update is the drive's
exact one (:class:`mjbench.drive.DCMotorDrive`).

Switching model: inside one co-simulation step [t, t+h] the voltage is piecewise constant
between edges; the current is advanced *exactly* segment by segment,
I ← I_ss + (I − I_ss)·exp(−Δt·R/L) with I_ss = (V_level − k_m·φ̇)/R, with the motor speed held
at its value at the start of the step (the mechanics is held over the step: the plant sees the
step's mean current, the exact time average of the piecewise exponential, as the ideal drive
does).  The end current is then corrected to the mean speed over the step, exactly (the RL
equation is linear in φ̇: I_end(φ̇̄) = I_end(φ̇₀) − k_m(φ̇̄ − φ̇₀)/R·(1 − e^{−hR/L})).  Per step
it also returns the mean bridge voltage and the current's minimum and maximum (extremes of a
piecewise exponential lie at the edges), i.e. the ripple.  An edge delayed past the end of the
step is applied at the step's end (an error ≤ t_d on at most one edge per step).

Current limit (``drive.i_max``): the commanded voltage is first limited to the values that keep
the end-of-step current within ±i_max (exact update, speed held) — the mean-voltage action of a
current-limiting amplifier.
"""
from __future__ import annotations

import math
from collections import namedtuple

from .. import compiled as C
from ..compiled import clip, law
from ..errors import ParameterError

#: the amplifier laws' parameters for one drive and step h: scheme (unipolar), bus voltage, dead
#: time t_d and t_d·f, PWM frequency f and period T, current limit on/off with the drive's
#: R, k_m, decay e^{−hR/L}, limiter gain R/(1 − decay) and i_max, τ = L/R, h and 1/h, and the
#: end-current correction k_m/R·(1 − decay) per unit of mean-speed change
AmpP = namedtuple("AmpP", "uni v_bus td tdf f T lim R k_m decay gain imax tau h inv_h corr")


@law
def current_limited_voltage(I, V, w, k_m, decay, gain, i_max):
    """The armature voltage limited to what keeps the end-of-step current within ±i_max (exact
    update over the step with V and φ̇ = ``w`` held): I_end = I_ss + (I − I_ss)·e^{−hR/L} ≤ i_max
    ⇔ V ≤ R/(1 − e^{−hR/L})·(i_max − I·e^{−hR/L}) + k_m·φ̇ — the mean-voltage action of a
    current-limiting amplifier, so that the step-mean current (the torque) and the end current
    are limited together (i_max = inf: V unchanged)."""
    e = k_m * w
    return clip(V, gain * (-i_max - I * decay) + e, gain * (i_max - I * decay) + e)


@law
def pwm_limit(I, V, w0, P):
    """V limited so that the end-of-step current stays within ±i_max (exact update, speed held):
    the drive's :func:`mjbench.drive.current_limited_voltage`."""
    return current_limited_voltage(I, V, w0, P.k_m, P.decay, P.gain, P.imax)


@law
def pwm_averaged(t, I, V, w0, P, S):
    """The kernel's AMP slot, averaged model: the period-mean bridge voltage [V] for the command V
    (current limit, bus clip, dead-time error by the current's sign)."""
    if P.lim:
        V = pwm_limit(I, V, w0, P)
    Vb = P.v_bus
    V = Vb if V > Vb else (-Vb if V < -Vb else V)
    tdf = P.tdf
    if tdf == 0.0 or I == 0.0:
        return V
    if P.uni:
        s = 1.0 if V >= 0 else -1.0
        d = abs(V) / Vb
        if 0.0 < d < 1.0:
            sig = s if I > 0 else -s
            d -= sig * tdf
            d = clip(d, 0.0, 1.0)
        return s * Vb * d
    d = 0.5 * (1.0 + V / Vb)
    if 0.0 < d < 1.0:
        d -= tdf if I > 0 else -tdf
        d = clip(d, 0.0, 1.0)
    return Vb * (2.0 * d - 1.0)


@law
def pwm_segment(I, acc, vacc, imin, imax, level, dt, e, P):
    """The exact RL current over dt at a constant bridge level (speed held: back-EMF e) →
    (I, ∫I dt, ∫V dt, I_min, I_max) accumulated."""
    if dt > 0.0:
        iss = (level - e) / P.R
        ex = math.exp(-dt / P.tau)
        acc += iss * dt + (I - iss) * P.tau * (1.0 - ex)
        vacc += level * dt
        I = iss + (I - iss) * ex
        if I < imin:
            imin = I
        elif I > imax:
            imax = I
    return I, acc, vacc, imin, imax


@law
def pwm_edge(j, k0, a, b, T):
    """Time of the j-th commanded edge from period k0 on: even j the rising one ((k + a)·T), odd j
    the falling one ((k + b)·T) of period k = k0 + j // 2."""
    return (k0 + j // 2 + (a if j % 2 == 0 else b)) * T


@law
def pwm_switching(t, I, V, w0, P, S):
    """The kernel's AMP slot, switching model: the current inside [t, t + h] resolved edge by edge
    (speed held at φ̇₀) → (mean current Ī, end current, mean bridge voltage, I_min, I_max)."""
    if P.lim:
        V = pwm_limit(I, V, w0, P)
    Vb = P.v_bus
    V = Vb if V > Vb else (-Vb if V < -Vb else V)
    if P.uni:
        on = Vb if V >= 0 else -Vb
        off = 0.0
        d = abs(V) / Vb
    else:
        on = Vb
        off = -Vb
        d = 0.5 * (1.0 + V / Vb)
    lower_on = on < off  # the "on" level is the lower one (unipolar, V < 0)
    e = P.k_m * w0
    f = P.f
    T = P.T
    td = P.td
    t1 = t + P.h
    a = 0.5 * (1.0 - d)  # on during [a, b) of each period (phase)
    b = 0.5 * (1.0 + d)
    k0 = math.floor(t * f + 1e-9)
    ph = t * f - k0
    level = on if a <= ph < b else off
    cur = t
    acc = 0.0
    vacc = 0.0
    imin = I
    imax = I
    if 0.0 < d < 1.0:
        # the commanded edges strictly inside (t, t1), in time order (a contiguous run of j)
        ne = 2 * (math.floor(t1 * f + 1e-9) - k0 + 1)
        for j in range(ne):
            te = pwm_edge(j, k0, a, b, T)
            if not (t < te < t1):
                continue
            lv = on if j % 2 == 0 else off
            if lv == level:
                continue
            I, acc, vacc, imin, imax = pwm_segment(I, acc, vacc, imin, imax, level, te - cur, e, P)
            cur = te
            # dead time: the diodes hold the lower level for I > 0, the upper one for I < 0; if that
            # is the old level, the edge is delayed by t_d (at most to the next edge or the step end)
            if td != 0.0 and I != 0.0 and (I > 0.0) == ((level == on) == lower_on):
                nxt = t1
                if j + 1 < ne:
                    tn = pwm_edge(j + 1, k0, a, b, T)
                    if tn < t1:
                        nxt = tn
                te2 = te + td
                if te2 > nxt:
                    te2 = nxt
                I, acc, vacc, imin, imax = pwm_segment(I, acc, vacc, imin, imax, level, te2 - cur, e, P)
                if te2 - cur > 0.0:
                    cur = te2
            level = lv
    I, acc, vacc, imin, imax = pwm_segment(I, acc, vacc, imin, imax, level, t1 - cur, e, P)
    return acc * P.inv_h, I, vacc * P.inv_h, imin, imax


@law
def pwm_end_current(Iend, w0, wm, P):
    """The kernel's AMP_END slot: the switching model's end current (at φ̇₀) corrected to the step's
    mean speed, exactly (the RL equation is linear in φ̇), within ±i_max."""
    return clip(Iend - P.corr * (wm - w0), -P.imax, P.imax)


class Amplifier:
    """H-bridge PWM amplifier (see the module docstring).  ``model``: "averaged" | "switching";
    ``frequency`` [Hz], ``v_bus`` [V], ``scheme``: "unipolar" | "bipolar", ``dead_time`` [s].

    Its laws: :func:`pwm_averaged`, or :func:`pwm_switching` with :func:`pwm_end_current` (the
    kernel's AMP and AMP_END slots, :meth:`form`); :meth:`bridge_voltage`, :meth:`switching_step`
    and :meth:`end_current` run the same laws from Python."""

    def __init__(self, model="averaged", frequency=20e3, v_bus=48.0, scheme="unipolar", dead_time=0.0):
        if model not in ("averaged", "switching"):
            raise ParameterError(f"drive.pwm.model = {model!r}: choose 'averaged' or 'switching'")
        if scheme not in ("unipolar", "bipolar"):
            raise ParameterError(f"drive.pwm.scheme = {scheme!r}: choose 'unipolar' or 'bipolar'")
        self.model, self.scheme = model, scheme
        self.frequency, self.v_bus, self.dead_time = float(frequency), float(v_bus), float(dead_time)
        for name in ("frequency", "v_bus"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError(f"drive.pwm.{name} = {v!r}: must be > 0")
        if not (self.dead_time >= 0 and self.dead_time * self.frequency < 0.5):
            raise ParameterError(f"drive.pwm.dead_time = {dead_time!r}: must be in [0, half a PWM period)")

    @property
    def switching(self) -> bool:
        return self.model == "switching"

    def describe(self) -> dict:
        return {"model": self.model, "frequency_Hz": self.frequency, "v_bus_V": self.v_bus,
                "scheme": self.scheme, "dead_time_s": self.dead_time}

    # ------------------------------------------------------------------ the laws' form
    def params(self, drive, h: float) -> AmpP:
        """The laws' parameters for ``drive`` at the co-simulation step h [s]."""
        sp = drive.step_params(h)  # the drive's own constants at this step (decay e^{−hR/L})
        R, k_m, decay, imax = sp.R, sp.k_m, sp.decay, sp.i_max
        L = float(drive.L)
        if self.switching and not L > 0:
            raise ParameterError("drive.pwm.model = 'switching' needs an armature inductance drive.L > 0")
        f = self.frequency
        return AmpP(self.scheme == "unipolar", self.v_bus, self.dead_time, self.dead_time * f, f, 1.0 / f,
                    math.isfinite(imax), R, k_m, decay, R / (1.0 - decay) if decay < 1.0 else R, imax,
                    L / R, float(h), 1.0 / h, k_m / R * (1.0 - decay))

    def form(self, drive, h: float) -> C.Form:
        """The kernel's AMP form (switching: flagged, with its AMP_END law)."""
        P = self.params(drive, h)
        if self.switching:
            return C.Form(pwm_switching, P, laws={"end": pwm_end_current}, flags={"switching": True})
        return C.Form(pwm_averaged, P)

    # ------------------------------------------------------------------ Python use of the laws
    def bridge_voltage(self, I, V, w0, drive, h: float):
        """Averaged model: the period-mean bridge voltage [V] for current I, command V, motor speed
        φ̇₀ (scalars or arrays, elementwise)."""
        P = self.params(drive, h)
        return C.vectorize(lambda i, v, w: pwm_averaged(0.0, i, v, w, P, C.NO_STATE), I, V, w0)

    def switching_step(self, t, I, V, w0, drive, h: float):
        """Switching model over [t, t + h] (speed held) → (Ī, I_end, mean bridge voltage, I_min, I_max)."""
        return pwm_switching(float(t), float(I), float(V), float(w0), self.params(drive, h), C.NO_STATE)

    def end_current(self, Iend, w0, wm, drive, h: float):
        """The switching step's end current corrected from φ̇₀ to the mean speed φ̇̄ (clipped to ±i_max)."""
        return pwm_end_current(float(Iend), float(w0), float(wm), self.params(drive, h))


def ripple_formula(v_bus, L, f, scheme="unipolar"):
    """Peak-to-peak current ripple at 50 % duty for T ≪ L/R [A]: V_bus/(4·L·f) (unipolar,
    levels {0, V_bus}), V_bus/(2·L·f) (bipolar, levels ±V_bus)."""
    return v_bus / ((4.0 if scheme == "unipolar" else 2.0) * L * f)

