"""Reduced backend: the 3-state Eksergian model of seed 000 Eq 21, u = (α, α̇, I).

    α̈ = F(α, α̇, I) = [A(α̇, I) + Q_ext − B(α, α̇)] / (J_eq + J(α))              (Eqs 10-13)
    A = drive.crank_torque(I, α̇) = z·(k_m·I − T_0 − z·λ·α̇),  B = dE_p/dα + ½·dJ/dα·α̇²
    L·dI/dt = V_a − R·I − k_m·z·α̇                                                 (Eq 7)

The controller is the same object the multibody backend runs, called once per control step
(sampled, voltage held): the paper's Eq 21 puts V_a inside the ODE instead; at 0.1 ms the two
readings differ by < 1e-5 in crank speed (tests/test_reduced.py).

Methods:
* ``rk4`` (default): classical fixed-step RK4 with step = control period h (default 0.1 ms;
  the paper uses 1 ms).  Local error O(h⁵): with τ_e = L/R ≈ 4.5 ms, ≈1e-9 per 0.1 ms step.
* ``solve_ivp``: adaptive ``scipy.integrate.solve_ivp`` (DOP853, rtol/atol settable) over every
  control period with the voltage held — a reference to check the fixed-step run against.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from controllers.base import Measurement

from ..errors import ParameterError, SimulationDiverged
from ..trajectory import Trajectory
from .multibody import MAX_CURRENT, MAX_SPEED, _check_times, _hint


def make_rhs(machine):
    """f(t, α, α̇, I, V) → (α̇, α̈, dI/dt) for the machine (scalars or arrays)."""
    mech, drive = machine.mechanism, machine.drive
    J_eq, z = drive.J_eq, drive.z
    reduced, ext, torque, di_dt = mech.reduced, mech.external_torque, drive.crank_torque, drive.di_dt

    def rhs(t, q, qd, I, V):
        J, dJ, dEp = reduced(q)
        qdd = (torque(I, qd) + ext(q, qd, t) - dEp - 0.5 * dJ * qd * qd) / (J_eq + J)
        return qd, qdd, di_dt(I, V, z * qd)

    return rhs


def simulate(machine, t_end: float, dt: float = 1e-4, record_dt: float = 1e-3,
             method: str = "rk4", rtol: float = 1e-10, atol: float = 1e-12, progress=None,
             options=None):
    """Integrate the reduced model for ``t_end`` s with control period ``dt``; Trajectory out."""
    if options:
        dt = float(options.get("timestep", dt))
        method = options.get("method", method)
    h = float(dt)
    _check_times(t_end, h, record_dt)
    if method not in ("rk4", "solve_ivp"):
        raise ParameterError(f"reduced.method = {method!r}: choose 'rk4' or 'solve_ivp'")
    drive, ctrl = machine.drive, machine.controller
    if np.any(np.asarray(drive.L) <= 0):
        raise ParameterError(f"drive.L = {drive.L!r}: the reduced backend integrates the current as a state "
                             f"and needs L > 0 (the multibody backend accepts L = 0, algebraic current)")
    ctrl.reset()
    drive.prepare(h)
    i_lim = None if drive._no_ilimit else float(drive.i_max)
    rhs = make_rhs(machine)
    z = drive.z
    y = Measurement(z=z)
    limit = drive.limit
    torque = drive.crank_torque
    k_m = drive.k_m
    nsteps = int(round(t_end / h))
    decim = max(1, int(round(record_dt / h)))
    traj = Trajectory(nsteps // decim + 1, "reduced", meta={"dt": h, "record_dt": decim * h, "method": method})
    q, qd, I = float(machine.q0), float(machine.qd0), float(machine.I0)
    tick = progress.update if progress is not None else None
    h2, h6 = 0.5 * h, h / 6.0
    inv_h = 1.0 / h
    qd_prev = qd

    for n in range(nsteps + 1):
        t = n * h
        qdd = (qd - qd_prev) * inv_h  # backward difference, as in the multibody backend
        V = limit(ctrl(t, y.set(t, q, qd, qdd, I)))
        if n % decim == 0:
            if not (abs(qd) < MAX_SPEED and abs(I) < MAX_CURRENT and math.isfinite(V) and math.isfinite(q)):
                _diverged(t, q, qd, I, V, _hint(ctrl, t, h))
            r = traj.row()
            om = z * qd
            r[0] = t; r[1] = q; r[2] = qd; r[3] = qdd; r[4] = om; r[5] = I; r[6] = V
            r[7] = torque(I, qd); r[8] = k_m * I * om; r[9] = V * I; r[10] = 0.0
            if tick is not None:
                tick(decim)
        if n == nsteps:
            break
        qd_prev = qd
        if method == "rk4":
            k1q, k1v, k1i = rhs(t, q, qd, I, V)
            k2q, k2v, k2i = rhs(t + h2, q + h2 * k1q, qd + h2 * k1v, I + h2 * k1i, V)
            k3q, k3v, k3i = rhs(t + h2, q + h2 * k2q, qd + h2 * k2v, I + h2 * k2i, V)
            k4q, k4v, k4i = rhs(t + h, q + h * k3q, qd + h * k3v, I + h * k3i, V)
            q += h6 * (k1q + 2 * k2q + 2 * k3q + k4q)
            qd += h6 * (k1v + 2 * k2v + 2 * k3v + k4v)
            I += h6 * (k1i + 2 * k2i + 2 * k3i + k4i)
            if i_lim is not None:  # amplifier current limit, as drive.current_step applies it
                I = -i_lim if I < -i_lim else (i_lim if I > i_lim else I)
        else:
            sol = solve_ivp(lambda tt, u: rhs(tt, u[0], u[1], u[2], V), (t, t + h), (q, qd, I),
                            method="DOP853", rtol=rtol, atol=atol)
            if not sol.success:
                _diverged(t, q, qd, I, V, _hint(ctrl, t, h))
            q, qd, I = (float(v) for v in sol.y[:, -1])
    return traj.trim()


def _diverged(t, q, qd, I, V, hint=""):
    raise SimulationDiverged(
        f"reduced simulation diverged at t = {t:.6g} s: crank angle = {q:.6g} rad, crank speed = "
        f"{qd:.6g} rad/s, current = {I:.6g} A, voltage = {V:.6g} V (limits |α̇| < {MAX_SPEED:g} rad/s, "
        f"|I| < {MAX_CURRENT:g} A, finite values). Reduce the time step (RK4 is only conditionally "
        f"stable) or check gains/parameters." + hint, t=t, state={"q": q, "qd": qd, "I": I, "V": V})
