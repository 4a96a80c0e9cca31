""""What gain do I need": what a coupler-speed reference demands from the drive, before simulating.

For a desired coupler-point speed V_C (or profile V_C(s), Hülako & Çakar Eq 17) the ideal motion
q̇(q) = V_C(s(q))/S(q) is known in closed form along the path (S = |dC/dq|, ``FourBar``).
Following it exactly needs (Incerti 2012 Eq 5 / Hülako & Çakar Eqs 18-20 inverted):

    q̈ = q̇·dq̇/dq,   dq̇/dq = dV_C/ds − V_C·S'/S²
    T_c = (J_eq + J(q))·q̈ + ½·J'(q)·q̇² + E_p'(q) − Q_ext(q, q̇)        crank torque [N·m]
    k_m·I = T_c/z + T_0·sgn(φ̇) + λ·φ̇,  φ̇ = z·q̇                         current [A]
    V = R·I + L·dI/dt + k_m·φ̇                                            voltage [V]

:func:`demand` returns the peaks of these over one lap and flags voltage saturation
(|V| > v_max) and current above ``i_max``.  :func:`predicted_error` adds a linear estimate of the
periodic crank-speed error a PID leaves: the loop of :mod:`mjbench.linear` — the DC motor driving
the lap-mean inertia J̄ with the lap-mean viscous friction c̄ (``linear.rigid_mechanics`` +
``linear.plant``, the kernel's co-step at the control period) closed by the PID of Eq 21 as the
simulation runs it (``linear.pid_controller``: crank-side gains, backward-difference derivative,
integral = angle error) — driven by the feed-forward voltage V_ff the reference needs, entered as
an input disturbance: per harmonic k of the lap, E_k = G_{d→q̇}(e^{jω_k T})·V_ff,k
(= V_ff,k / (C + P⁻¹) at these low frequencies); DC is removed by the integral.
"""
from __future__ import annotations

import math

import numpy as np

from mjbench import linear
from mjbench import scenario as S
from mjbench.errors import ParameterError

H_CONTROL = 1e-4  #: [s] control period of the Hülako & Çakar PID (the scenarios' co-step)


def error_loop(drive, J, c, kp, ki, kd, h=H_CONTROL):
    """The linear loop of :func:`predicted_error` (python-control objects, :class:`linear.Loop`):
    DC motor + constant inertia J [kg·m², drive included] + viscous c, closed by the crank-side
    PID (Eq 21) sampled at h."""
    P = linear.sample(linear.plant(linear.rigid_mechanics(J, c), drive, h=h), 1)
    return linear.loop(P, linear.pid_controller(kp, ki, kd, 1.0, h, h))


def ideal_motion(mechanism, reference, n: int = 4096):
    """Crank angle grid over one lap and the exact-tracking motion: dict of arrays
    q, s, S, vc, qd, qdd, t (time along the lap) [SI]."""
    q = np.linspace(0.0, 2 * np.pi, int(n), endpoint=False)
    S, dS = mechanism.coupler_speed_ratio_derivative(q)
    vc = np.asarray(reference.vc_at(q), dtype=float) + 0.0 * q
    dvds = np.asarray(reference._dvc_ds(q), dtype=float) + 0.0 * q
    if np.any(vc <= 0):
        raise ValueError("the desired coupler speed must be > 0 along the whole path for a lap analysis")
    qd = vc / S
    qd = np.minimum(qd, reference.qd_max)
    dqd_dq = dvds - vc * dS / (S * S)
    qdd = qd * dqd_dq
    dq = q[1] - q[0]
    inv = 1.0 / qd
    # lap time t(q) by the trapezoidal rule (periodic)
    t = np.concatenate(([0.0], np.cumsum(0.5 * dq * (inv[:-1] + inv[1:]))))
    T = t[-1] + 0.5 * dq * (inv[-1] + inv[0])
    return {"q": q, "S": S, "vc": vc, "qd": qd, "qdd": qdd, "t": t, "T": T,
            "s": mechanism.arc_length(q)}


def demand(mechanism, drive, reference, n: int = 4096) -> dict:
    """Peak crank speed/acceleration, crank torque, motor current and voltage demanded by the
    reference over one lap, and saturation flags.  Returns a dict (SI units in the keys)."""
    m = ideal_motion(mechanism, reference, n)
    q, qd, qdd = m["q"], m["qd"], m["qdd"]
    J, dJ, dEp = mechanism.reduced(q)
    Qx = mechanism.external_torque(q, qd, 0.0)
    z = float(drive.z)
    Jeq = float(drive.J_eq)
    Tc = (Jeq + J) * qdd + 0.5 * dJ * qd * qd + dEp - Qx
    om = z * qd
    I = (Tc / z + drive.friction_torque_motor(om)) / drive.k_m
    dq = q[1] - q[0]
    dIdq = (np.roll(I, -1) - np.roll(I, 1)) / (2 * dq)
    V = drive.R * I + drive.L * dIdq * qd + drive.k_m * om
    vmax = float(drive.v_max)
    imax = float(drive.i_max)
    over = np.abs(V) > vmax
    out = {
        "vc_mean_m_s": float(mechanism.path_length() / m["T"]),
        "vc_max_m_s": float(np.max(m["vc"])),
        "path_length_m": float(mechanism.path_length()),
        "lap_time_s": float(m["T"]),
        "crank_speed_min_rad_s": float(qd.min()),
        "crank_speed_max_rad_s": float(qd.max()),
        "crank_accel_max_rad_s2": float(np.abs(qdd).max()),
        "motor_speed_max_rad_s": float(np.abs(om).max()),
        "crank_torque_max_Nm": float(np.abs(Tc).max()),
        "current_max_A": float(np.abs(I).max()),
        "voltage_max_V": float(np.abs(V).max()),
        "voltage_mean_V": float(np.trapezoid(V / qd, q) / m["T"]),
        "back_emf_max_V": float(np.abs(drive.k_m * om).max()),
        "v_max_V": vmax,
        "voltage_saturated": bool(over.any()),
        "saturated_fraction_of_lap_time": float(np.sum(over / qd) / np.sum(1.0 / qd)),
        "current_limited": bool(np.isfinite(imax) and np.abs(I).max() > imax),
        "_arrays": {"q": q, "t": m["t"], "qd": qd, "qdd": qdd, "Tc": Tc, "I": I, "V": V, "S": m["S"]},
    }
    return out


def predicted_error(mechanism, drive, reference, kp, ki, kd, n: int = 4096, harmonics: int = 200) -> dict:
    """Linear estimate of the periodic crank-speed error left by a crank-side PID (Eq 21) when
    tracking the reference exactly would need the feed-forward voltage of :func:`demand`."""
    d = demand(mechanism, drive, reference, n)
    a = d["_arrays"]
    T = d["lap_time_s"]
    # resample on a uniform time grid over one lap
    tt = np.linspace(0.0, T, 4096, endpoint=False)
    V = np.interp(tt, a["t"], a["V"], period=T)
    Sg = np.interp(tt, a["t"], a["S"], period=T)
    J, _, _ = mechanism.reduced(a["q"])
    Jbar = float(drive.J_eq + np.mean(J))
    cbar = float(drive.z ** 2 * drive.lam + np.mean(mechanism.hinge_damping_factor(a["q"]))
                 if hasattr(mechanism, "hinge_damping_factor") else drive.z ** 2 * drive.lam)
    F = np.fft.rfft(V) / len(V)
    k = np.arange(len(F))
    w = 2 * np.pi * k / T
    lp = error_loop(drive, Jbar, cbar, kp, ki, kd)
    E = np.zeros(len(F), dtype=complex)
    kk = np.arange(1, min(harmonics, len(F) - 1) + 1)
    E[kk] = linear.response(lp.closed, w[kk], "qd", "d") * F[kk]
    E[0] = 0.0
    E[harmonics + 1:] = 0.0
    e = np.fft.irfft(E * len(V), n=len(V))
    return {**{kk: v for kk, v in d.items() if kk != "_arrays"},
            "pred_crank_error_max_rad_s": float(np.abs(e).max()),
            "pred_coupler_dev_max_m_s": float(np.abs(Sg * e).max()),
            "J_mean_kgm2": Jbar, "c_mean_Nms": cbar}


def from_scenario(scn, mode: str | None = None, n: int = 4096) -> dict:
    """Demand report for a scenario (built through scenario.make_machine)."""

    mach = S.make_machine(scn, mode)
    ctrl = mach.controller
    ref = getattr(ctrl, "reference", None)
    if ref is None or not hasattr(ref, "vc_at"):
        raise ParameterError("the scenario's controller has no coupler_speed reference")
    z = float(mach.drive.z)
    if hasattr(ctrl, "kp"):
        # PID gains are motor-side in the object: back to crank side (× z)
        return predicted_error(mach.mechanism, mach.drive, ref, ctrl.kp * z, ctrl.ki * z, ctrl.kd * z, n)
    d = demand(mach.mechanism, mach.drive, ref, n)
    d.pop("_arrays")
    return d


def format_report(r: dict) -> str:
    lines = []
    units = [("vc_mean_m_s", "mean coupler speed", "m/s"), ("path_length_m", "coupler path length", "m"),
             ("lap_time_s", "lap time", "s"), ("crank_speed_min_rad_s", "crank speed min", "rad/s"),
             ("crank_speed_max_rad_s", "crank speed max", "rad/s"),
             ("crank_accel_max_rad_s2", "crank acceleration max |q̈|", "rad/s²"),
             ("motor_speed_max_rad_s", "motor speed max", "rad/s"),
             ("crank_torque_max_Nm", "crank torque max |T_c|", "N·m"),
             ("current_max_A", "current max |I|", "A"), ("back_emf_max_V", "back-EMF max", "V"),
             ("voltage_max_V", "voltage max |V|", "V"), ("voltage_mean_V", "voltage mean", "V"),
             ("v_max_V", "supply limit v_max", "V"),
             ("pred_crank_error_max_rad_s", "predicted PID crank-speed error (periodic)", "rad/s"),
             ("pred_coupler_dev_max_m_s", "predicted coupler-speed deviation", "m/s")]
    for key, label, u in units:
        if key in r:
            lines.append(f"  {label:<44s} {r[key]:>11.4g} {u}")
    if r.get("voltage_saturated"):
        lines.append(f"WARNING: voltage saturation — the reference needs up to {r['voltage_max_V']:.3g} V "
                     f"> v_max = {r['v_max_V']:.3g} V during {100 * r['saturated_fraction_of_lap_time']:.1f} % "
                     f"of the lap: the motor cannot follow it; lower V_C or raise the supply.")
    elif math.isfinite(r.get("v_max_V", math.inf)):
        lines.append(f"ok: peak voltage {r['voltage_max_V']:.3g} V is {100 * r['voltage_max_V'] / r['v_max_V']:.0f} % "
                     f"of v_max = {r['v_max_V']:.3g} V")
    if r.get("current_limited"):
        lines.append("WARNING: the current demand exceeds the drive's i_max.")
    return "\n".join(lines)
