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

import numpy as np

from ..errors import ParameterError


class Amplifier:
    """H-bridge PWM amplifier (see the module docstring).  ``model``: "averaged" | "switching";
    ``frequency`` [Hz], ``v_bus`` [V], ``scheme``: "unipolar" | "bipolar", ``dead_time`` [s]."""

    def __init__(self, model="averaged", frequency=20e3, v_bus=48.0, scheme="unipolar", dead_time=0.0):
        if model not in ("averaged", "switching"):
            raise ParameterError(f"drive.pwm.model = {model!r}: choose 'averaged' or 'switching'")
        if scheme not in ("unipolar", "bipolar"):
            raise ParameterError(f"drive.pwm.scheme = {scheme!r}: choose 'unipolar' or 'bipolar'")
        self.model, self.scheme = model, scheme
        self.frequency, self.v_bus, self.dead_time = frequency, v_bus, dead_time
        for name in ("frequency", "v_bus"):
            if not np.all(np.asarray(getattr(self, name), dtype=float) > 0):
                raise ParameterError(f"drive.pwm.{name} = {getattr(self, name)!r}: must be > 0")
        if np.any(np.asarray(dead_time) < 0) or np.any(np.asarray(dead_time) * np.asarray(frequency) >= 0.5):
            raise ParameterError(f"drive.pwm.dead_time = {dead_time!r}: must be in [0, half a PWM period)")

    @property
    def switching(self) -> bool:
        return self.model == "switching"

    def describe(self) -> dict:
        return {"model": self.model, "frequency_Hz": _plain(self.frequency), "v_bus_V": _plain(self.v_bus),
                "scheme": self.scheme, "dead_time_s": _plain(self.dead_time)}

    # ------------------------------------------------------------------ current limit
    def _limiter(self, drive, h, batch):
        """V ↦ V limited so that |I_end| ≤ i_max (exact update over h, speed held); None if no limit."""
        if drive._no_ilimit:
            return None
        decay = drive._decay
        R, k_m, imax = drive.R, drive.k_m, drive.i_max
        gain = R / (1.0 - decay) if np.all(np.asarray(decay) < 1.0) else R

        if not batch:
            decay, R, k_m, imax, gain = float(decay), float(R), float(k_m), float(imax), float(gain)

            def lim(I, V, w0):
                e = k_m * w0
                hi = gain * (imax - I * decay) + e
                lo = gain * (-imax - I * decay) + e
                return hi if V > hi else (lo if V < lo else V)
            return lim

        def lim_a(I, V, w0):
            e = k_m * w0
            return np.minimum(np.maximum(V, gain * (-imax - I * decay) + e), gain * (imax - I * decay) + e)
        return lim_a

    # ------------------------------------------------------------------ averaged
    def bind_averaged(self, drive, h, batch):
        """(I, V, φ̇₀) ↦ the period-mean bridge voltage [V] (bus clip, dead time, current limit)."""
        lim = self._limiter(drive, h, batch)
        uni = self.scheme == "unipolar"
        Vb, td, f = self.v_bus, self.dead_time, self.frequency
        tdf = td * f
        if not batch:
            Vb, tdf = float(Vb), float(tdf)

            def avg(I, V, w0):
                if lim is not None:
                    V = lim(I, V, w0)
                V = Vb if V > Vb else (-Vb if V < -Vb else V)
                if tdf == 0.0 or I == 0.0:
                    return V
                if uni:
                    s = 1.0 if V >= 0 else -1.0
                    d = abs(V) / Vb
                    if 0.0 < d < 1.0:
                        sig = s if I > 0 else -s
                        d -= sig * tdf
                        d = 0.0 if d < 0.0 else (1.0 if d > 1.0 else d)
                    return s * Vb * d
                d = 0.5 * (1.0 + V / Vb)
                if 0.0 < d < 1.0:
                    d -= tdf if I > 0 else -tdf
                    d = 0.0 if d < 0.0 else (1.0 if d > 1.0 else d)
                return Vb * (2.0 * d - 1.0)
            return avg

        def avg_a(I, V, w0):
            if lim is not None:
                V = lim(I, V, w0)
            V = np.minimum(np.maximum(V, -Vb), Vb)
            if np.all(np.asarray(tdf) == 0.0):
                return V
            sI = np.sign(I)
            if uni:
                s = np.where(V >= 0, 1.0, -1.0)
                d = np.abs(V) / Vb
                edges = (d > 0.0) & (d < 1.0)
                d = np.where(edges, np.clip(d - s * sI * tdf, 0.0, 1.0), d)
                return s * Vb * d
            d = 0.5 * (1.0 + V / Vb)
            edges = (d > 0.0) & (d < 1.0)
            d = np.where(edges, np.clip(d - sI * tdf, 0.0, 1.0), d)
            return Vb * (2.0 * d - 1.0)
        return avg_a

    # ------------------------------------------------------------------ switching
    def bind_switching(self, drive, h, batch):
        """(t, I, V, φ̇₀) ↦ (Ī, I_end at φ̇₀, mean bridge voltage, I_min, I_max) over [t, t+h]."""
        lim = self._limiter(drive, h, batch)
        if np.any(np.asarray(drive.L) <= 0):
            raise ParameterError("drive.pwm.model = 'switching' needs an armature inductance drive.L > 0")
        if np.ndim(self.frequency):
            raise ParameterError("drive.pwm.frequency: the switching model needs one PWM frequency for every "
                                 "simulation of a batch")
        uni = self.scheme == "unipolar"
        f = float(self.frequency)
        T = 1.0 / f
        if not batch:
            return self._switching_scalar(drive, h, lim, uni, f, T)
        return self._switching_array(drive, h, lim, uni, f, T)

    def _switching_scalar(self, drive, h, lim, uni, f, T):
        R, L, k_m = float(drive.R), float(drive.L), float(drive.k_m)
        tau = L / R
        Vb, td = float(self.v_bus), float(self.dead_time)
        inv_h = 1.0 / h
        exp, floor = math.exp, math.floor

        def sw(t, I, V, w0):
            if lim is not None:
                V = lim(I, V, w0)
            V = Vb if V > Vb else (-Vb if V < -Vb else V)
            if uni:
                on = Vb if V >= 0 else -Vb
                off = 0.0
                d = abs(V) / Vb
            else:
                on, off = Vb, -Vb
                d = 0.5 * (1.0 + V / Vb)
            lower_on = on < off  # the "on" level is the lower one (unipolar, V < 0)
            e = k_m * w0
            t1 = t + h
            a, b = 0.5 * (1.0 - d), 0.5 * (1.0 + d)  # on during [a, b) of each period (phase)
            k0 = floor(t * f + 1e-9)
            ph = t * f - k0
            level = on if a <= ph < b else off
            # commanded edges strictly inside (t, t1), in time order
            edges = []
            if 0.0 < d < 1.0:
                for k in range(k0, floor(t1 * f + 1e-9) + 1):
                    for ph_e, lv in ((a, on), (b, off)):
                        te = (k + ph_e) * T
                        if t < te < t1:
                            edges.append((te, lv))
            cur = t
            acc = vacc = 0.0
            imin = imax = I
            ne = len(edges)
            for i in range(ne + 1):
                if i < ne:
                    te, lv = edges[i]
                    if lv == level:
                        continue
                else:
                    te, lv = t1, level
                for rep in range(2):  # up to the commanded edge, then through a dead time that delays it
                    dt = te - cur
                    if dt > 0.0:
                        iss = (level - e) / R
                        ex = exp(-dt / tau)
                        acc += iss * dt + (I - iss) * tau * (1.0 - ex)
                        vacc += level * dt
                        I = iss + (I - iss) * ex
                        if I < imin:
                            imin = I
                        elif I > imax:
                            imax = I
                        cur = te
                    if rep or i == ne or td == 0.0 or I == 0.0:
                        break
                    # dead time: the diodes hold the lower level for I > 0, the upper one for I < 0;
                    # if that is the old level, the edge is delayed by t_d
                    if (I > 0.0) != ((level == on) == lower_on):
                        break
                    nxt = edges[i + 1][0] if i + 1 < ne else t1
                    te = te + td
                    if te > nxt:
                        te = nxt
                level = lv
            return acc * inv_h, I, vacc * inv_h, imin, imax

        return sw

    def _switching_array(self, drive, h, lim, uni, f, T):
        R, L, k_m = drive.R, drive.L, drive.k_m
        tau = L / R
        Vb, td = self.v_bus, self.dead_time
        has_td = bool(np.any(np.asarray(td) > 0))
        inv_h = 1.0 / h

        def sw(t, I, V, w0):
            if lim is not None:
                V = lim(I, V, w0)
            V = np.minimum(np.maximum(V, -Vb), Vb)
            if uni:
                on = np.where(V >= 0, 1.0, -1.0) * Vb
                off = np.zeros_like(on)
                d = np.abs(V) / Vb
            else:
                on = np.zeros_like(V) + Vb
                off = -on
                d = 0.5 * (1.0 + V / Vb)
            lower_on = on < off
            e = k_m * w0
            t1 = t + h
            a, b = 0.5 * (1.0 - d), 0.5 * (1.0 + d)
            k0 = math.floor(t * f + 1e-9)
            ph = t * f - k0
            level = np.where((a <= ph) & (ph < b), on, off)
            has_edges = (d > 0.0) & (d < 1.0)
            edges = []
            for k in range(k0, math.floor(t1 * f + 1e-9) + 1):
                edges.append(((k + a) * T, on))
                edges.append(((k + b) * T, off))
            cur = np.full_like(V, t)
            acc = np.zeros_like(V)
            vacc = np.zeros_like(V)
            I = np.array(I, dtype=float, copy=True)
            imin, imax = I.copy(), I.copy()
            ne = len(edges)

            def segment(I, acc, vacc, level, dt):
                iss = (level - e) / R
                ex = np.exp(-dt / tau)
                acc = acc + iss * dt + (I - iss) * tau * (1.0 - ex)
                vacc = vacc + level * dt
                return iss + (I - iss) * ex, acc, vacc

            for i in range(ne):
                te, lv = edges[i]
                inside = has_edges & (te > t) & (te < t1) & (lv != level)
                te_eff = np.where(inside, te, cur)
                I, acc, vacc = segment(I, acc, vacc, level, np.maximum(te_eff - cur, 0.0))
                imin, imax = np.minimum(imin, I), np.maximum(imax, I)
                cur = te_eff
                if has_td:
                    level_is_lower = (level == on) == lower_on
                    delayed = inside & (I != 0.0) & ((I > 0.0) == level_is_lower)
                    nxt = np.minimum(edges[i + 1][0], t1) if i + 1 < ne else t1
                    te2 = np.where(delayed, np.minimum(te_eff + td, nxt), cur)
                    I, acc, vacc = segment(I, acc, vacc, level, np.maximum(te2 - cur, 0.0))
                    imin, imax = np.minimum(imin, I), np.maximum(imax, I)
                    cur = te2
                level = np.where(inside, lv, level)
            I, acc, vacc = segment(I, acc, vacc, level, np.maximum(t1 - cur, 0.0))
            imin, imax = np.minimum(imin, I), np.maximum(imax, I)
            return acc * inv_h, I, vacc * inv_h, imin, imax

        return sw


def ripple_formula(v_bus, L, f, scheme="unipolar"):
    """Peak-to-peak current ripple at 50 % duty for T ≪ L/R [A]: V_bus/(4·L·f) (unipolar,
    levels {0, V_bus}), V_bus/(2·L·f) (bipolar, levels ±V_bus)."""
    return v_bus / ((4.0 if scheme == "unipolar" else 2.0) * L * f)


def _plain(v):
    return v.tolist() if isinstance(v, np.ndarray) else float(v)
