"""MuJoCo multibody backend: the mechanism's MJCF co-stepped with the Python drive + controller.

One co-simulation step of length h (default 0.1 ms), state (q, v) in MuJoCo and I in Python:

1. measurement (t_n, α_n, α̇_n, α̈_n) with α̈_n = (α̇_n − α̇_{n−1})/h, the backward difference a
   digital controller sees (the reduced backend uses the same definition);
2. controller → V_n, limiter;
3. ``qfrc_applied[crank] = z·(k_m·Ī − T_0·sgn φ̇)`` with Ī the exact mean current over the step
   (V_n held, φ̇_n); viscous friction z²λ is the crank joint's ``damping`` and J_eq its
   ``armature``, so MuJoCo integrates both inside the step;
4. one plain ``mj_step`` (the same call ``mujoco.batch`` makes, so batched runs are identical,
   and the co-step costs no more MuJoCo work than a bare step loop);
5. I_{n+1} by the exact exponential update with the mean of φ̇_n and φ̇_{n+1} (see drive.py).

Integrator choice (``options["integrator"]``): RK4 (default) keeps the loop-closure residual
≈1e-8 m and the passive energy drift ≈1e-6 over 2 s at h = 0.1 ms, where semi-implicit Euler
gives 5e-6 m and 4e-2 (measured, tests/test_fourbar_multibody.py).
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from controllers.base import Measurement

from ..errors import ParameterError, SimulationDiverged
from ..mechanisms.base import INPUT_JOINT
from ..trajectory import Trajectory

DEFAULT_OPTIONS = {"integrator": "RK4", "timestep": 1e-4}
MAX_SPEED = 1e4  # rad/s: beyond this a crank speed is a diverged simulation, not physics
MAX_CURRENT = 1e5  # A


def build_model(machine, options=None, native_dcmotor=False):
    """Compile the machine's MuJoCo model (reflected drive inertia and viscous friction on the
    crank joint).  With ``native_dcmotor`` the drive is MuJoCo's ``<dcmotor>`` actuator instead."""
    o = {**DEFAULT_OPTIONS, **(options or {})}
    mech, drive = machine.mechanism, machine.drive
    if native_dcmotor:
        spec = mech.build_spec(armature=float(drive.J_b), options=o)
        _add_dcmotor(spec, drive)
    else:
        spec = mech.build_spec(armature=float(drive.J_eq), options=o)
        j = spec.joint(INPUT_JOINT)
        # the drive's reflected viscous friction adds to whatever the mechanism put on the joint
        j.damping = [float(j.damping[0]) + float(drive.crank_damping), 0.0, 0.0]
    return spec, spec.compile()


def _add_dcmotor(spec, drive):
    """MuJoCo ``<dcmotor>`` equivalent of the drive: voltage input, R, K, L, gear z, rotor
    inertia J_m + J_a and viscous friction λ on the motor side (MuJoCo reflects both by z²)."""
    if drive.T_0 != 0:
        raise ParameterError("native <dcmotor> cross-check: drive.T_0 must be 0 (Coulomb friction is "
                             "modelled by LuGre there, not by a constant torque)")
    act = spec.add_actuator(name="dcmotor", trntype=mujoco.mjtTrn.mjTRN_JOINT, target=INPUT_JOINT,
                            gear=[float(drive.z), 0, 0, 0, 0, 0])
    act.set_to_dcmotor(motorconst=[float(drive.k_m), float(drive.k_m)], resistance=float(drive.R),
                       inductance=[float(drive.L), 0.0])
    act.armature = float(drive.J_m + drive.J_a)
    act.damping = [float(drive.lam), 0.0, 0.0]
    return act


def simulate(machine, t_end: float, dt: float | None = None, record_dt: float = 1e-3,
             options: dict | None = None, model=None, progress=None):
    """Co-simulate ``machine`` for ``t_end`` seconds; returns a Trajectory sampled every
    ``record_dt``.  ``dt`` overrides ``options['timestep']`` (default 1e-4 s)."""
    o = {**DEFAULT_OPTIONS, **(options or {})}
    if dt is not None:
        o["timestep"] = dt
    h = float(o["timestep"])
    _check_times(t_end, h, record_dt)
    mech, drive, ctrl = machine.mechanism, machine.drive, machine.controller
    if model is None:
        _, model = build_model(machine, o)
    m = model
    d = mujoco.MjData(m)
    d.qpos[:] = mech.initial_qpos(m, machine.q0)
    if hasattr(mech, "initial_qvel"):
        d.qvel[:] = mech.initial_qvel(m, machine.q0, machine.qd0)
    ctrl.reset()
    drive.prepare(h)

    integ = m.opt.integrator
    jnt = m.joint(INPUT_JOINT)
    qa, va = int(jnt.qposadr[0]), int(jnt.dofadr[0])
    qpos, qvel, qfrc = d.qpos, d.qvel, d.qfrc_applied
    z = float(drive.z) if np.ndim(drive.z) == 0 else drive.z
    y = Measurement(z=z)
    nsteps = int(round(t_end / h))
    decim = max(1, int(round(record_dt / h)))
    traj = Trajectory(nsteps // decim + 1, "multibody",
                      meta={"dt": h, "record_dt": decim * h, "integrator": _integ_name(integ)})
    torque = drive.crank_torque
    cur_mean, cur_step, limit = drive.current_mean, drive.current_step, drive.limit
    load = mech.multibody_load
    has_load = type(mech).multibody_load is not _base_load()
    closure = mech.closure_error
    k_m = drive.k_m
    I = float(machine.I0)
    bad_qacc = int(mujoco.mjtWarning.mjWARN_BADQACC)
    tick = progress.update if progress is not None else None
    step = mujoco.mj_step
    inv_h = 1.0 / h
    mujoco.mj_forward(m, d)
    qd_prev = float(qvel[va])

    for n in range(nsteps + 1):
        t = n * h
        q, qd = float(qpos[qa]), float(qvel[va])
        qdd = (qd - qd_prev) * inv_h  # backward difference, as a digital controller sees it
        V = limit(ctrl(t, y.set(t, q, qd, qdd, I)))
        if n % decim == 0:
            if not (abs(qd) < MAX_SPEED and abs(I) < MAX_CURRENT and math.isfinite(V)) \
                    or d.warning[bad_qacc].number:
                _diverged("multibody", t, q, qd, I, V, _hint(ctrl, t, h))
            r = traj.row()
            om = z * qd
            r[0] = t; r[1] = q; r[2] = qd; r[3] = qdd; r[4] = om; r[5] = I; r[6] = V
            r[7] = torque(I, qd); r[8] = k_m * I * om; r[9] = V * I; r[10] = closure(m, d)
            if tick is not None:
                tick(decim)
        if n == nsteps:
            break
        qfrc[va] = torque(cur_mean(I, V, z * qd, h), qd, False)
        if has_load:
            load(m, d, t)
        step(m, d)
        qd_prev = qd
        I = cur_step(I, V, 0.5 * z * (qd + float(qvel[va])), h)
    return traj.trim()


def _base_load():
    from ..mechanisms.base import Mechanism
    return Mechanism.multibody_load


def _integ_name(i):
    return {int(mujoco.mjtIntegrator.mjINT_EULER): "Euler", int(mujoco.mjtIntegrator.mjINT_RK4): "RK4",
            int(mujoco.mjtIntegrator.mjINT_IMPLICIT): "implicit",
            int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): "implicitfast"}.get(int(i), str(i))


def _check_times(t_end, h, record_dt):
    if not (np.isfinite(t_end) and t_end > 0):
        raise ParameterError(f"t_end = {t_end!r}: must be a finite time > 0 [s]")
    if not (np.isfinite(h) and 0 < h <= 0.01):
        raise ParameterError(f"timestep = {h!r}: must be in (0, 0.01] s")
    if not (np.isfinite(record_dt) and record_dt > 0):
        raise ParameterError(f"record_dt = {record_dt!r}: must be > 0 [s]")


def _hint(ctrl, t, h):
    fn = getattr(ctrl, "divergence_hint", None)
    return fn(t, h) if fn is not None else ""


def _diverged(backend, t, q, qd, I, V, hint=""):
    raise SimulationDiverged(
        f"{backend} simulation diverged at t = {t:.6g} s: crank angle = {q:.6g} rad, crank speed = "
        f"{qd:.6g} rad/s, current = {I:.6g} A, voltage = {V:.6g} V (limits |α̇| < {MAX_SPEED:g} rad/s, "
        f"|I| < {MAX_CURRENT:g} A, finite values). Reduce the time step or check gains/parameters." + hint,
        t=t, state={"q": q, "qd": qd, "I": I, "V": V})


def simulate_native_dcmotor(machine, t_end: float, voltage: float, dt: float = 1e-4,
                            record_dt: float = 1e-3, options=None):
    """Cross-check run: the same mechanism driven by MuJoCo's native ``<dcmotor>`` at a constant
    ``voltage`` [V] (no Python drive).  Returns (t, crank speed, current) arrays."""
    o = {**DEFAULT_OPTIONS, **(options or {}), "timestep": dt}
    _, m = build_model(machine, o, native_dcmotor=True)
    d = mujoco.MjData(m)
    mech = machine.mechanism
    d.qpos[:] = mech.initial_qpos(m, machine.q0)
    if hasattr(mech, "initial_qvel"):
        d.qvel[:] = mech.initial_qvel(m, machine.q0, machine.qd0)
    va = int(m.joint(INPUT_JOINT).dofadr[0])
    d.ctrl[0] = voltage
    nsteps = int(round(t_end / dt))
    decim = max(1, int(round(record_dt / dt)))
    out = np.empty((nsteps // decim + 1, 3))
    k = 0
    act_adr = int(m.actuator_actadr[0]) if m.na else -1
    for n in range(nsteps + 1):
        if n % decim == 0:
            mujoco.mj_forward(m, d)
            out[k] = (d.time, d.qvel[va], d.act[act_adr] if act_adr >= 0 else np.nan)
            k += 1
        if n < nsteps:
            mujoco.mj_step(m, d)
    return out[:k, 0], out[:k, 1], out[:k, 2]
