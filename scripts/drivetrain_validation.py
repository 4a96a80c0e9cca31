#!/usr/bin/env python
"""Validation figures of the drive-train elements (issue 15), one per element, against the
analytic or limit case the tests assert (tests/test_drivetrain.py).

Writes docs/drivetrain_<element>.png (or --out DIR) and prints the numbers shown.
Usage: python scripts/drivetrain_validation.py [--out docs]   (≈ 1 min)
"""
import argparse
import math
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from controllers import PID, ConstantVoltage  # noqa: E402
from controllers.base import Controller  # noqa: E402
from mjbench import plotstyle as ps  # noqa: E402
from mjbench.backends import multibody, reduced  # noqa: E402
from mjbench.drive import DCMotorDrive  # noqa: E402
from mjbench.drivetrain import Amplifier, CurrentLoop, DriveTrain, Friction, Gear, Sensor  # noqa: E402
from mjbench.drivetrain.amplifier import ripple_formula  # noqa: E402
from mjbench.machine import Machine  # noqa: E402
from mjbench.mechanisms.rotor import Rotor  # noqa: E402
from mjbench.plots import save  # noqa: E402

R, L, KM, JM = 2.0, 9e-3, 0.48, 1.3e-3
BACKENDS = {"multibody": multibody, "reduced": reduced}


class Fn(Controller):
    type_name = "validation_fn"

    def __init__(self, f, period=0.0):
        self.f, self.period, self.log = f, period, []

    @classmethod
    def from_params(cls, *a, **k):  # pragma: no cover
        raise NotImplementedError

    def reset(self):
        self.log = []

    def __call__(self, t, y):
        self.log.append((t, y.q, y.qd, y.qdd, y.current))
        return self.f(t)


def drive(z=1.0, lam=0.0, v_max=math.inf, **train):
    d = DCMotorDrive(R=R, L=L, k_m=KM, J_m=JM, J_a=0.0, J_b=0.0, z=z, lam=lam, v_max=v_max)
    d.train = DriveTrain(**train)
    return d


def pwm(out):
    fig, ax = ps.new(1, 2, figsize=(12, 4.2))
    f = 20e3
    m = Machine(Rotor(1e3), drive(pwm=Amplifier("switching", f, 48.0, "unipolar")), ConstantVoltage(24.0))
    tr = reduced.simulate(m, 0.1, dt=2.5e-6, record_dt=2.5e-6)  # resolved: the waveform itself
    k = tr.t > 0.1 - 3 / f
    ax[0].plot(1e6 * (tr.t[k] - tr.t[k][0]), tr.current[k], color="tab:blue", label="switching model, h = T/20")
    mean = (24.0 - KM * tr.qd[-1]) / R
    dI = ripple_formula(48.0, L, f)
    for y, lab in ((mean + dI / 2, "mean ± V_bus/(8Lf)"), (mean - dI / 2, None)):
        ax[0].axhline(y, color="k", ls="--", lw=0.8, label=lab)
    ax[0].set_xlabel(ps.label("time in the last 3 PWM periods", "µs"))
    ax[0].set_ylabel(ps.label("current I", "A"))
    ax[0].set_title(f"unipolar 20 kHz, 50 % duty: ΔI = {np.ptp(tr.current[k]):.5f} A, "
                    f"V_bus/(4Lf) = {dI:.5f} A", fontsize=9)
    ax[0].legend(fontsize=8)
    errs, freqs = [], (10e3, 20e3, 40e3, 80e3, 160e3)
    for fq in freqs:
        o = {}
        for model in ("averaged", "switching"):
            mm = Machine(Rotor(2e-3, damping=0.01), drive(lam=0.08, pwm=Amplifier(model, fq, 48.0)),
                         PID(0.5, 5.0, 0.0, omega0=30.0, v_limit=48.0, period=1e-4))
            o[model] = reduced.simulate(mm, 0.06, dt=1e-4, record_dt=1e-4)
        errs.append(np.max(np.abs(o["switching"]["current_mean_A"][1:] - o["averaged"]["current_mean_A"][1:])))
    ax[1].loglog(np.array(freqs) / 1e3, errs, "o-", label="max |Ī_switching − Ī_averaged| (PID start-up)")
    ax[1].loglog(np.array(freqs) / 1e3, errs[0] * (freqs[0] / np.array(freqs)) ** 2, "k--", lw=0.8, label="∝ 1/f²")
    ax[1].set_xlabel(ps.label("PWM frequency", "kHz"))
    ax[1].set_ylabel(ps.label("step-mean current difference", "A"))
    ax[1].legend(fontsize=8)
    ps.finish(fig, "PWM amplifier: ripple at 50 % duty, and the switching model → averaged model")
    print("pwm: ripple", np.ptp(tr.current[k]), "formula", dI, "| convergence", dict(zip(freqs, errs)))
    return save(fig, out / "drivetrain_pwm.png")


def sensor(out):
    fig, ax = ps.new(1, 2, figsize=(12, 4.2))
    c = Fn(lambda t: 12.0, period=1e-4)
    m = Machine(Rotor(1e-2, damping=0.01), drive(z=3.0, sensor=Sensor(lines=500, side="motor")), c)
    tr = reduced.simulate(m, 0.2, dt=1e-4, record_dt=1e-4)
    log = np.array(c.log)
    D = 2 * math.pi / 2000
    err = (log[:, 1] - tr.q[: len(log)]) * 3.0 / D
    ax[0].plot(log[:, 0], err, lw=0.6)
    ax[0].axhline(0.5, color="k", ls="--", lw=0.8)
    ax[0].axhline(-0.5, color="k", ls="--", lw=0.8, label="± half a count")
    ax[0].set_xlabel(ps.label("time t", "s"))
    ax[0].set_ylabel("quantisation error [counts]")
    ax[0].set_title(f"500 lines ×4 on the motor (z = 3): max |error| = {np.max(np.abs(err)):.4f} count", fontsize=9)
    ax[0].legend(fontsize=8)
    for method, col in (("difference", "tab:red"), ("observer", "tab:orange"), ("mt", "tab:blue")):
        c = Fn(lambda t: 0.0, period=1e-4)
        d = drive(sensor=Sensor(lines=2000, speed=method, bandwidth=100.0 if method == "observer" else None))
        d.k_m = 1e-12
        reduced.simulate(Machine(Rotor(1e-2), d, c, qd0=20.0), 0.3, dt=1e-4)
        lg = np.array(c.log)
        ax[1].plot(lg[:, 0], lg[:, 2], color=col, lw=0.7,
                   label=f"{method}: mean error over the last 0.1 s {np.mean(lg[-1000:, 2]) - 20:+.2e} rad/s")
    ax[1].axhline(20.0, color="k", ls="--", lw=0.8, label="true speed (constant-speed ramp)")
    ax[1].set_ylim(17, 23)
    ax[1].set_xlabel(ps.label("time t", "s"))
    ax[1].set_ylabel(ps.label("speed estimate", "rad/s"))
    ax[1].legend(fontsize=7)
    ps.finish(fig, "Encoder and speed estimation: bounded quantisation; zero steady error of the observer and M/T")
    print("sensor: max |err| counts", np.max(np.abs(err)))
    return save(fig, out / "drivetrain_sensor.png")


def backlash(out):
    beta = math.radians(1.0)
    fig, ax = ps.new(1, 2, figsize=(12, 4.2))
    for b, mod in BACKENDS.items():
        m = Machine(Rotor(1e-4, damping=0.01), drive(gear=Gear(backlash=beta)),
                    Fn(lambda t: 2.0 * math.sin(2 * math.pi * 0.5 * t)))
        tr = mod.simulate(m, 2.2, dt=1e-4, record_dt=1e-3)
        dl = tr["gear_deflection_rad"]
        ax[0].plot(tr.t, np.degrees(dl), **ps.backend_style(b, label=f"δ = θ_motor/z − α ({b})"))
        mv = np.abs(tr.qd) > 2.0
        lag = (dl * np.sign(tr.qd) - 0.01 * np.abs(tr.qd) / m.mechanism.k)[mv]
        print(f"backlash {b}: lag/(β/2) = {lag.min() / (beta / 2):.6f} … {lag.max() / (beta / 2):.6f}")
        k = (tr.t > 0.6) & (tr.t < 1.5)  # around the first reversal (input at its maximum)
        ax[1].plot(np.degrees(tr.q + dl)[k], np.degrees(tr.q)[k], **ps.backend_style(b, lw=1.0))
    for y in (0.5, -0.5):
        ax[0].axhline(y, color="k", ls="--", lw=0.8)
    ax2 = ax[0].twinx()
    ax2.plot(tr.t, tr.qd, color="0.6", lw=0.7)
    ax2.set_ylabel(ps.label("crank speed (grey)", "rad/s"))
    ax[0].set_xlabel(ps.label("time t", "s"))
    ax[0].set_ylabel(ps.label("mesh deflection δ", "deg"))
    ax[0].set_title("1° play, slow sine voltage: the output lags by ±β/2 = ±0.5°", fontsize=9)
    ax[0].legend(fontsize=8, loc="lower left")
    ax[1].set_xlabel(ps.label("input: motor angle / z", "deg"))
    ax[1].set_ylabel(ps.label("output angle α", "deg"))
    ax[1].set_title("around the reversal: the output waits while the input crosses the 1° play", fontsize=9)
    ax[1].legend(fontsize=8)
    ps.finish(fig, "Gear backlash: dead zone with its two contact states, both backends")
    return save(fig, out / "drivetrain_backlash.png")


def efficiency(out):
    z, eta, eta_b, cL = 2.0, 0.8, 0.6, 0.02
    fig, ax = ps.new(1, 2, figsize=(12, 4.2))
    Vs = np.linspace(2, 24, 8)
    for b, mod in BACKENDS.items():
        ws = []
        for V in Vs:
            m = Machine(Rotor(1e-3, damping=cL), drive(z=z, gear=Gear(efficiency=eta, efficiency_back=eta_b)),
                        ConstantVoltage(float(V)))
            tr = mod.simulate(m, 1.0, dt=1e-4, record_dt=1e-3)
            ws.append(cL * tr.qd[-1] ** 2 / (KM * tr.current[-1] * z * tr.qd[-1]))
        ax[0].plot(Vs, ws, "o", **ps.backend_style(b, label=f"P_load / P_motor ({b})"))
    ax[0].axhline(eta, color="k", ls="--", lw=0.8, label="η = 0.8")
    ax[0].set_ylim(0.7, 0.9)
    ax[0].set_xlabel(ps.label("armature voltage", "V"))
    ax[0].set_ylabel("power ratio at steady state")
    ax[0].legend(fontsize=8)
    J = 1e-3 + z * z * JM
    for b, mod in BACKENDS.items():
        m = Machine(Rotor(1e-3), drive(z=z, gear=Gear(efficiency=eta, efficiency_back=eta_b)), ConstantVoltage(0.0),
                    qd0=50.0)
        tr = mod.simulate(m, 0.03, dt=1e-4, record_dt=1e-4)
        given = -J * tr.qd * np.gradient(tr.qd, tr.t)
        got = -KM * tr.current * z * tr.qd
        k = (tr.t > 3e-3) & (tr.qd > 1)
        ax[1].plot(tr.t[k], got[k] / given[k], **ps.backend_style(b, label=f"received / given ({b})"))
    ax[1].axhline(eta_b, color="k", ls="--", lw=0.8, label="η_back = 0.6")
    ax[1].set_ylim(0.5, 0.7)
    ax[1].set_xlabel(ps.label("time t (spinning load braking on the short-circuited motor)", "s"))
    ax[1].set_ylabel("power ratio")
    ax[1].legend(fontsize=8)
    ps.finish(fig, "Gear efficiency: forward η and back-driving η_back, both backends")
    return save(fig, out / "drivetrain_efficiency.png")


def friction(out):
    a, fc, fs, vs, Jr = 1.0, 0.05, 0.08, 1.0, 1e-2
    tau = L / R
    tb = brentq(lambda t: KM * (a / R) * (t - tau * (1 - math.exp(-t / tau))) - fs, 1e-3, 10.0)
    Ib = (a / R) * (tb - tau * (1 - math.exp(-tb / tau)))
    J = Jr + JM
    ref = solve_ivp(lambda t, y: [(KM * y[1] - (fc + (fs - fc) * math.exp(-(y[0] / vs) ** 2))) / J,
                                  (a * t - R * y[1] - KM * y[0]) / L], (tb, tb + 1), [0.0, Ib],
                    rtol=1e-10, atol=1e-12, dense_output=True)
    fig, ax = ps.new(1, 2, figsize=(12, 4.2))
    for b, mod in BACKENDS.items():
        m = Machine(Rotor(Jr), drive(friction=Friction(fc, fs, vs)), Fn(lambda t: a * t))
        tr = mod.simulate(m, tb + 0.35, dt=1e-4, record_dt=1e-4)
        ax[0].plot(tr.t, tr.qd, **ps.backend_style(b))
        ax[1].semilogy(tr.t, np.abs(tr.q) + 1e-9, **ps.backend_style(b, label=f"|α| ({b})"))
    tt = np.linspace(tb, tb + 0.35, 400)
    ax[0].plot(np.r_[0, tb, tt], np.r_[0, 0, ref.sol(tt)[0]], "k:", lw=1.2, label="reference: stick, then Stribeck slip")
    for a_ in ax:
        a_.axvline(tb, color="0.5", ls="--", lw=0.8)
    ax[0].set_xlabel(ps.label("time t (voltage ramp 1 V/s)", "s"))
    ax[0].set_ylabel(ps.label("speed", "rad/s"))
    ax[0].set_title(f"breakaway at k_m·I = F_S = {fs} N·m: t_b = {tb:.4f} s", fontsize=9)
    ax[0].legend(fontsize=8)
    ax[1].set_xlabel(ps.label("time t", "s"))
    ax[1].set_ylabel(ps.label("angle moved", "rad"))
    ax[1].set_title("stick phase: MuJoCo frictionloss (multibody), regularised law (reduced)", fontsize=9)
    ax[1].legend(fontsize=8)
    ps.finish(fig, "Dry friction (Coulomb 0.05 + Stribeck 0.08 N·m at 1 rad/s) on the motor, both backends")
    return save(fig, out / "drivetrain_friction.png")


def current_loop(out):
    fig, ax = ps.new(1, 2, figsize=(12, 4.2))
    wc = 2 * math.pi * 500.0
    for h, col in ((1e-5, "tab:blue"), (1e-4, "tab:red")):
        m = Machine(Rotor(1e4), drive(v_max=48.0, current_loop=CurrentLoop.from_bandwidth(500.0, L, R)),
                    ConstantVoltage(1.0))
        tr = reduced.simulate(m, 0.005, dt=h, record_dt=h)
        ax[0].plot(1e3 * tr.t, tr.current, color=col, marker="." if h > 5e-5 else None, ms=3, lw=0.9,
                   label=f"PI current loop, step h = {1e3 * h:g} ms")
    t = np.linspace(0, 0.005, 300)
    ax[0].plot(1e3 * t, 1 - np.exp(-wc * t), "k--", lw=0.9, label="1 − exp(−ω_c t), f_c = 500 Hz")
    ax[0].set_xlabel(ps.label("time t (locked rotor, 1 A reference step)", "ms"))
    ax[0].set_ylabel(ps.label("current I", "A"))
    ax[0].legend(fontsize=8)
    for b, mod in BACKENDS.items():
        m = Machine(Rotor(1e-2, damping=0.02), drive(lam=0.01, v_max=48.0,
                                                   current_loop=CurrentLoop.from_bandwidth(500.0, L, R)),
                    PID(0.5, 5.0, 0.0, omega0=30.0))
        tr = mod.simulate(m, 1.0, dt=1e-4, record_dt=1e-3)
        ax[1].plot(tr.t, tr.omega, **ps.backend_style(b, label=f"speed PI → current loop ({b})"))
    ax[1].axhline(30.0, color="k", ls="--", lw=0.8, label="set-point")
    ax[1].set_xlabel(ps.label("time t", "s"))
    ax[1].set_ylabel(ps.label("motor speed", "rad/s"))
    ax[1].legend(fontsize=8)
    ps.finish(fig, "Inner PI current loop (bandwidth design kp = Lω_c, ki = Rω_c) and the cascade")
    return save(fig, out / "drivetrain_current_loop.png")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with ps.context():
        for f in (pwm, sensor, backlash, efficiency, friction, current_loop):
            print("wrote", f(out))


if __name__ == "__main__":
    main()
