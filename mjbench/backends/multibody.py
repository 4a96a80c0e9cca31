"""MuJoCo multibody plant: the mechanism's MJCF, stepped by one plain ``mj_step`` per co-step.

The drive's reflected inertia J_eq is the input joint's ``armature`` and its viscous friction z²λ
the joint's ``damping`` (added to the mechanism's own), so MuJoCo integrates both inside the
step; the kernel (:mod:`mjbench.kernel`) writes the held drive torque into
``qfrc_applied[input]`` (then the mechanism's own loads, if any) before each step.  One plain
``mj_step`` is the same call ``mujoco.batch`` makes, so batched runs are identical to single runs
and the co-step costs no more MuJoCo work than a bare step loop.

Integrator choice (``options["integrator"]``): RK4 (default) keeps the loop-closure residual
≈1e-8 m and the passive energy drift ≈1e-6 over 2 s at h = 0.1 ms, where semi-implicit Euler
gives 5e-6 m and 4e-2 (measured, tests/test_fourbar_multibody.py).
"""
from __future__ import annotations

import mujoco
import numpy as np

from .. import kernel
from ..errors import ParameterError
from ..trajectory import Trajectory

DEFAULT_OPTIONS = {"integrator": "RK4", "timestep": 1e-4}

#: measured accuracy of the integrators (scripts/fast_multibody_accuracy.py: seed 000, h = 0.1 ms,
#: 2 s, crank speed vs the reduced model with the closed forms, relative to the peak speed; largest
#: loop-closure residual; CPU cost per step relative to RK4, scripts/bench.py --only reduced)
FAST_ACCURACY = {
    "RK4": {"pid": 5.1e-6, "open": 1.3e-5, "closure_m": 1.6e-8, "cost": 1.0},
    "implicitfast": {"pid": 3.6e-3, "open": 8.1e-2, "closure_m": 7.5e-6, "cost": 0.53},
    "Euler": {"pid": 3.6e-3, "open": 8.1e-2, "closure_m": 7.5e-6, "cost": 0.55},
}


def accuracy_note(integrator: str) -> str:
    """One line stating the measured accuracy of a multibody integrator (the fast mode's price)."""
    a, r = FAST_ACCURACY.get(integrator), FAST_ACCURACY["RK4"]
    if a is None:
        return f"integrator {integrator}: accuracy not measured"
    return (f"integrator {integrator} instead of RK4 — cost ≈ {a['cost']:.2g}× RK4 per step; measured on seed 000 "
            f"(0.1 ms, 2 s) against the reduced model: crank-speed error {a['pid']:.2g} of peak with PID "
            f"(RK4 {r['pid']:.2g}), {a['open']:.2g} open loop (RK4 {r['open']:.2g}), loop closure "
            f"{a['closure_m']:.2g} m (RK4 {r['closure_m']:.2g} m)")
MAX_SPEED, MAX_CURRENT = kernel.MAX_SPEED, kernel.MAX_CURRENT


def build_model(machine, options=None, native_dcmotor=False):
    """Compile the machine's MuJoCo model (reflected drive inertia and viscous friction on the
    input joint).  With ``native_dcmotor`` the drive is MuJoCo's ``<dcmotor>`` actuator instead."""
    o = {**DEFAULT_OPTIONS, **(options or {})}
    mech, drive = machine.mechanism, machine.drive
    if native_dcmotor:
        spec = mech.build_spec(armature=float(drive.J_b), options=o)
        _add_dcmotor(spec, drive, mech.input_joint)
    else:
        spec = mech.build_spec(armature=float(drive.J_eq), options=o)
        j = spec.joint(drive_joint(mech))
        # the drive's reflected viscous friction adds to whatever the mechanism put on the joint
        j.damping = [float(j.damping[0]) + float(drive.crank_damping), 0.0, 0.0]
    return spec, spec.compile()


def _add_dcmotor(spec, drive, joint):
    """MuJoCo ``<dcmotor>`` equivalent of the drive: voltage input, R, K, L, gear z, rotor
    inertia J_m + J_a and viscous friction λ on the motor side (MuJoCo reflects both by z²)."""
    if drive.T_0 != 0:
        raise ParameterError("native <dcmotor> cross-check: drive.T_0 must be 0 (Coulomb friction is "
                             "modelled by LuGre there, not by a constant torque)")
    act = spec.add_actuator(name="dcmotor", trntype=mujoco.mjtTrn.mjTRN_JOINT, target=joint,
                            gear=[float(drive.z), 0, 0, 0, 0, 0])
    act.set_to_dcmotor(motorconst=[float(drive.k_m), float(drive.k_m)], resistance=float(drive.R),
                       inductance=[float(drive.L), 0.0])
    act.armature = float(drive.J_m + drive.J_a)
    act.damping = [float(drive.lam), 0.0, 0.0]
    return act


def drive_joint(mech) -> str:
    """The joint the drive torque acts on: the input joint, or the motor's own hinge when the
    drive train has a compliant gear (:mod:`mjbench.drivetrain.gear`)."""
    return getattr(mech, "drive_joint", mech.input_joint)


def integrator_name(i):
    return {int(mujoco.mjtIntegrator.mjINT_EULER): "Euler", int(mujoco.mjtIntegrator.mjINT_RK4): "RK4",
            int(mujoco.mjtIntegrator.mjINT_IMPLICIT): "implicit",
            int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): "implicitfast"}.get(int(i), str(i))


class MultibodyPlant:
    """One machine's MuJoCo model and data; see the kernel's plant protocol."""

    nsim = None

    def __init__(self, machine, options=None, model=None):
        o = {**DEFAULT_OPTIONS, **(options or {})}
        self.machine = machine
        self.model = m = model if model is not None else build_model(machine, o)[1]
        self.data = d = mujoco.MjData(m)
        self.h = float(m.opt.timestep)
        mech = machine.mechanism
        jnt = m.joint(mech.input_joint)
        self._qa, self._va = int(jnt.qposadr[0]), int(jnt.dofadr[0])
        self._vd = int(m.joint(drive_joint(mech)).dofadr[0])  # where the drive torque acts
        self._qpos, self._qvel, self._qfrc = d.qpos, d.qvel, d.qfrc_applied
        self._load = mech.multibody_load if mech.has_multibody_load() else None
        self._bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
        self._internal = mech.internal_state if mech.internal else None
        self.closure = mech.closure_reader(m, d)  # closure() → the loop-closure residual [m]
        self.extra_columns = _extra_names(mech)
        self.meta = {"integrator": integrator_name(m.opt.integrator)}

    def start(self):
        mc, m, d = self.machine, self.model, self.data
        mujoco.mj_resetData(m, d)
        d.qpos[:] = mc.mechanism.initial_qpos(m, mc.q0, mc.x0)
        d.qvel[:] = mc.mechanism.initial_qvel(m, mc.q0, mc.qd0, mc.x0, mc.xd0)
        mujoco.mj_forward(m, d)
        # hot-path functions with everything bound as locals (no attribute lookups per step)
        # memoryviews of MuJoCo's arrays: an element reads as a Python float and is written from one
        # without a NumPy scalar (≈ 0.1 µs less per access than ndarray indexing)
        qpos, qvel, qfrc = memoryview(self._qpos), memoryview(self._qvel), memoryview(self._qfrc)
        qa, va, vd = self._qa, self._va, self._vd
        load, step = self._load, mujoco.mj_step

        def read():
            return qpos[qa], qvel[va]

        if load is None:
            def advance(tau, t):
                qfrc[vd] = tau
                step(m, d)
                return qpos[qa], qvel[va]
        else:
            def advance(tau, t):
                qfrc[vd] = tau
                load(m, d, t)
                step(m, d)
                return qpos[qa], qvel[va]

        self.read, self.advance = read, advance
        warn = d.warning[self._bad]  # a live view of MuJoCo's counter

        def unstable():
            return warn.number != 0

        self.unstable = unstable

    def extra(self, out):
        x, xd = self._internal(self.model, self.data.qpos, self.data.qvel)
        k = len(x)
        out[:k] = x
        out[k:] = xd

    def retire(self, mask):  # pragma: no cover - single run: never called
        pass


def _extra_names(mech):
    """Recorded columns of a mechanism's internal coordinates: <name>_rad and <name>_rate_rad_s."""
    names = tuple(mech.internal)
    return tuple(f"{n}_rad" for n in names) + tuple(f"{n}_rate_rad_s" for n in names)


def simulate(machine, t_end: float, dt: float | None = None, record_dt: float = 1e-3,
             options: dict | None = None, model=None, progress=None) -> Trajectory:
    """Co-simulate ``machine`` on its MuJoCo model for ``t_end`` seconds; returns a Trajectory
    sampled every ``record_dt``.  ``dt`` overrides ``options['timestep']`` (default 1e-4 s)."""
    o = {**DEFAULT_OPTIONS, **(options or {})}
    if dt is not None:
        o["timestep"] = dt
    kernel.check_times(t_end, float(o["timestep"]), record_dt)
    if model is not None and abs(model.opt.timestep - float(o["timestep"])) > 1e-15:
        raise ParameterError(f"model timestep {model.opt.timestep:g} s differs from the requested {o['timestep']:g} s")
    from . import fused

    plant = MultibodyPlant(machine, o, model)
    rec = fused.try_multibody(plant, t_end, record_dt, progress)  # the compiled loop around mj_step: the same bits
    if rec is None:
        rec = kernel.run(plant, machine.drive, machine.controller, t_end, record_dt, machine.I0, progress,
                         backend="multibody")
    return Trajectory.from_record(rec, "multibody")


def simulate_native_dcmotor(machine, t_end: float, voltage: float, dt: float = 1e-4,
                            record_dt: float = 1e-3, options=None):
    """Cross-check run: the same mechanism driven by MuJoCo's native ``<dcmotor>`` at a constant
    ``voltage`` [V] (no Python drive).  Returns (t, input speed, current) arrays."""
    o = {**DEFAULT_OPTIONS, **(options or {}), "timestep": dt}
    _, m = build_model(machine, o, native_dcmotor=True)
    d = mujoco.MjData(m)
    mech = machine.mechanism
    d.qpos[:] = mech.initial_qpos(m, machine.q0)
    d.qvel[:] = mech.initial_qvel(m, machine.q0, machine.qd0)
    va = int(m.joint(mech.input_joint).dofadr[0])
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
