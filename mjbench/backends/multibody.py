"""MuJoCo multibody plant: the mechanism's MJCF, stepped by one plain ``mj_step`` per co-step.

The drive's reflected inertia J_eq is the input joint's ``armature`` and its viscous friction z²λ
the joint's ``damping`` (added to the mechanism's own), so MuJoCo integrates both inside the
step; the kernel (:mod:`mjbench.kernel`) writes the held drive torque into
``qfrc_applied[input]`` (then the mechanism's own loads, if any) before each step.  One plain
``mj_step`` per co-step, for a single run and for every run of a batch (N independent runs of the
same loop), so batched runs are identical to single runs and the co-step costs no more MuJoCo work
than a bare step loop.

Integrator choice (``options["integrator"]``): RK4 (default) keeps the loop-closure residual
≈1e-8 m and the passive energy drift ≈1e-6 over 2 s at h = 0.1 ms, where semi-implicit Euler
gives 5e-6 m and 4e-2 (measured, tests/test_fourbar_multibody.py).
"""
from __future__ import annotations

from collections import namedtuple

import mujoco
import numpy as np

from .. import compiled as C
from .. import kernel
from ..errors import ParameterError
from ..mechanisms.interface.forms import SitePairsP, site_pairs_closure  # noqa: F401 - the closure law's old home
from ..trajectory import Trajectory
from .joints import addresses, column_names, joint_list

DEFAULT_OPTIONS = {"integrator": "RK4", "timestep": 1e-4}

#: measured accuracy of the integrators (scripts/fast_multibody_accuracy.py: seed 000, h = 0.1 ms,
#: 2 s, crank speed vs the reduced model with the closed forms, relative to the peak speed; largest
#: loop-closure residual; CPU cost per step relative to RK4 measured by the same script on the CPython
#: loop, 0.39–0.40 (on the compiled loop, where MuJoCo's step is nearly all the cost: 0.27–0.28))
FAST_ACCURACY = {
    "RK4": {"pid": 5.1e-6, "open": 1.3e-5, "closure_m": 1.6e-8, "cost": 1.0},
    "implicitfast": {"pid": 3.6e-3, "open": 8.1e-2, "closure_m": 7.5e-6, "cost": 0.4},
    "Euler": {"pid": 3.6e-3, "open": 8.1e-2, "closure_m": 7.5e-6, "cost": 0.4},
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


def build_model(machine, options=None, native_dcmotor=False, rigid_gears=False):
    """Compile the machine's MuJoCo model (reflected drive inertia and viscous friction on the
    input joint).  With ``native_dcmotor`` the drive is MuJoCo's ``<dcmotor>`` actuator instead; with
    ``rigid_gears`` the mechanism alone (``mechanism_alone``: a compliant gear of a machine with several
    motors taken rigid, the analyses along a prescribed motion)."""
    o = {k: v for k, v in {**DEFAULT_OPTIONS, **(options or {})}.items() if k != "record_joints"}
    mech, drive = machine.mechanism, machine.drive
    if rigid_gears:
        mech = mech.mechanism_alone()
    drives = machine.drives
    if native_dcmotor:
        if len(drives) > 1:
            raise ParameterError("the native <dcmotor> cross-check is one-axis only")
        spec = mech.build_spec(armature=float(drive.J_b), options=o)
        _add_dcmotor(spec, drive, mech.input_joint)
    elif len(drives) > 1:  # one drive per input joint: its reflected inertia and viscous friction (on the
        # joint its torque acts on: a compliant gear's motor hinge)
        spec = mech.build_spec(armature=tuple(float(d.J_eq) for d in drives), options=o)
        for name, d in zip(mech.drive_joints, drives):
            j = spec.joint(name)
            j.damping = [float(j.damping[0]) + float(d.crank_damping), 0.0, 0.0]
    else:
        spec = mech.build_spec(armature=float(drive.J_eq), options=o)
        j = spec.joint(mech.drive_joints[0])  # (the input joint, or a compliant gear's motor hinge)
        # the drive's reflected viscous friction adds to whatever the mechanism put on the joint
        j.damping = [float(j.damping[0]) + float(drive.crank_damping), 0.0, 0.0]
    return spec, spec.compile()


def input_joints(mech) -> tuple:
    """The names of the joints the drives turn, in axis order (one-axis: the input joint)."""
    return tuple(mech.input_joints)


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


def integrator_name(i):
    return {int(mujoco.mjtIntegrator.mjINT_EULER): "Euler", int(mujoco.mjtIntegrator.mjINT_RK4): "RK4",
            int(mujoco.mjtIntegrator.mjINT_IMPLICIT): "implicit",
            int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST): "implicitfast"}.get(int(i), str(i))


#: co-steps from which a single MuJoCo run pays for loading the compiled loop (≈ 0.39 s of start-up
#: against ≈ 2.2 µs saved per co-step, docs/performance.md; the kernel's choose_loop)
MIN_COMPILED_STEPS = 180_000

class MultibodyPlant:
    """One machine's MuJoCo model and data; its compiled form is :meth:`form` (the kernel's plant slot)."""

    nsim = None

    def __init__(self, machine, options=None, model=None):
        o = {**DEFAULT_OPTIONS, **(options or {})}
        self.machine = machine
        self.model = m = model if model is not None else build_model(machine, o)[1]
        self.data = mujoco.MjData(m)
        self.h = float(m.opt.timestep)
        mech = machine.mechanism
        names = input_joints(mech)
        self._qa = np.array([int(m.joint(nm).qposadr[0]) for nm in names], dtype=np.int64)
        self._va = np.array([int(m.joint(nm).dofadr[0]) for nm in names], dtype=np.int64)
        # where each drive's torque acts (a compliant gear: the motor's own hinge)
        self._vd = np.array([int(m.joint(nm).dofadr[0]) for nm in mech.drive_joints], dtype=np.int64)
        # [simulation] record_joints: every hinge/slide's qpos and qvel after the internal coordinates
        self._joints = joint_list(m) if o.get("record_joints") else []
        self.extra_columns = _extra_names(mech) + column_names(self._joints)
        self.meta = {"integrator": integrator_name(m.opt.integrator)}
        if o.get("record_joints"):
            self.meta["joint_columns"] = "MuJoCo's qpos and qvel of every hinge and slide joint"

    def start(self):
        mc, m, d = self.machine, self.model, self.data
        mujoco.mj_resetData(m, d)
        d.qpos[:] = mc.mechanism.initial_qpos(m, mc.q0, mc.x0)
        d.qvel[:] = mc.mechanism.initial_qvel(m, mc.q0, mc.qd0, mc.x0, mc.xd0)
        mujoco.mj_forward(m, d)

    def form(self):
        """The plant's compiled form: the held torque into ``qfrc_applied``, the mechanism's MuJoCo
        loads (its ``load_form``), one ``mj_step`` called through MuJoCo's C address, the state read
        from ``qpos``/``qvel``; the loop closure from the connect sites, MuJoCo's bad-acceleration
        warning, the internal coordinates as recorded columns."""
        m, d, mech = self.model, self.data, self.machine.mechanism
        _OBJECTS[d._address] = (m, d)
        step = _mj_step_address() or 0
        load = mech.load_form(m, d)
        closure = mech.closure_form(m, d)
        motor = np.array(mech.motor_indices(m), dtype=np.int64).reshape(-1, 2)  # compliant gears: motor hinges
        internal = mech.internal_index(m) if mech.internal else np.zeros((0, 5))
        jq, jv = addresses(self._joints)
        P = MujocoP(step, m._address, d._address, d.qpos, d.qvel, d.qfrc_applied, self._qa, self._va,
                    self._vd, np.ascontiguousarray(motor[:, 0]), np.ascontiguousarray(motor[:, 1]),
                    d.warning.number, int(mujoco.mjtWarning.mjWARN_BADQACC),
                    np.ascontiguousarray(internal[:, :4], dtype=np.int64) if internal is not None else None,
                    np.ascontiguousarray(internal[:, 4], dtype=float) if internal is not None else None,
                    C.NO_PARAMS if load is None else load.P, closure.P, jq, jv)
        laws = {"read": mujoco_read, "closure": closure.law, "unstable": mujoco_unstable}
        flags = {"nextra": len(self.extra_columns), "min_steps": MIN_COMPILED_STEPS}
        if mech.internal and internal is None:
            laws["write"] = _python_internal(self)
        elif self._joints:
            laws["write"] = mujoco_write
        elif mech.internal:
            laws["write"] = mujoco_internal
        if load is None:
            f = C.Form(mujoco_step, P, laws=laws, flags=flags, python=python_step(P, m, d))
        else:
            f = C.Form(mujoco_step_load, P, laws=laws, flags=flags, fn_args=(load,), python=python_step(P, m, d, load))
        if not closure.compiled and f.compiled:
            f.compiled, f.reason = False, closure.reason
        if _mj_step_address() is None:
            f.compiled, f.reason = False, "MuJoCo's mj_step not found in its shared library"
        elif not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
            f.compiled = False
            f.reason = ("contacts are on: a MuJoCo error inside a compiled step (arena full) could not become "
                        "a Python exception")
        return f

    def finish(self):
        _OBJECTS.pop(self.data._address, None)


#: the MuJoCo plant's parameters: mj_step's address, model and data addresses, live views of
#: qpos, qvel, qfrc_applied, each input joint's qpos/dof and each drive's dof, each axis's motor hinge
#: behind a compliant gear (qpos, dof; −1: none), the warning counters and the bad-qacc index, the internal coordinates
#: (rows qpos a, qpos b, dof a, dof b; x = q_a − c·q_b), the loads' and the closure's parameters, the
#: recorded joints' qpos and dof addresses (``record_joints``; empty: none)
MujocoP = namedtuple("MujocoP", "step m d qpos qvel qfrc qa va vd qm vm warn bad xi xc load closure jq jv")
#: data address → (model, data): the CPython side of :func:`mj_step_at`
_OBJECTS: dict = {}


@C.bridge("call_c_pp")
def mj_step_at(fn, m, d):
    """MuJoCo's ``mj_step`` on the model and data at these addresses (CPython: through the Python
    bindings; compiled: a direct C call to the function at address ``fn``)."""
    model, data = _OBJECTS[d]
    mujoco.mj_step(model, data)


@C.law
def _motor_offset(P, a, q, qd):
    """Axis a's motor offset from its input (δ, δ̇): 0 unless the axis has a compliant gear."""
    qm = P.qm[a]
    if qm < 0:
        return 0.0, 0.0
    return P.qpos[qm] - q, P.qvel[P.vm[a]] - qd


@C.law
def mujoco_read(P, S, QO):
    """The state (q, q̇, δ, δ̇) of every input coordinate into ``QO[4a:4a+4]`` (δ: a compliant
    gear's motor offset, else 0)."""
    for a in range(len(P.qa)):
        q = P.qpos[P.qa[a]]
        qd = P.qvel[P.va[a]]
        dm, dmd = _motor_offset(P, a, q, qd)
        QO[4 * a] = q
        QO[4 * a + 1] = qd
        QO[4 * a + 2] = dm
        QO[4 * a + 3] = dmd


@C.law
def mujoco_step(TAU, t, P, S, QO):
    """Every axis's held drive torque on its dof, one ``mj_step``; the state at the step's end into ``QO``."""
    for a in range(len(P.vd)):
        P.qfrc[P.vd[a]] = TAU[a]
    mj_step_at(P.step, P.m, P.d)
    mujoco_read(P, S, QO)


@C.law
def mujoco_step_load(LOAD, TAU, t, P, S, QO):
    """:func:`mujoco_step` with the mechanism's own loads written first (``LOAD(t, P_load)``, which
    adds to the drive torque on the input dof)."""
    for a in range(len(P.vd)):
        P.qfrc[P.vd[a]] = TAU[a]
    LOAD(t, P.load)
    mj_step_at(P.step, P.m, P.d)
    mujoco_read(P, S, QO)


def python_step(P, model, data, load=None):
    """:func:`mujoco_step` (:func:`mujoco_step_load` with the load's slot function) as a CPython twin
    (:attr:`mjbench.compiled.Form.python`): the same writes, the load, ``mujoco.mj_step`` on this
    model and data and the same reads (:func:`mujoco_read`), the addresses written into the code."""
    env = {"qfrc": memoryview(P.qfrc), "qpos": memoryview(P.qpos), "qvel": memoryview(P.qvel),
           "mj_step": mujoco.mj_step, "model": model, "data": data,
           "LOAD": load.bound() if load is not None else None}
    lines = ["def mujoco_step_twin(TAU, t, P, S, QO):"]
    lines += [f"    qfrc[{int(v)}] = TAU[{a}]" for a, v in enumerate(P.vd)]
    if load is not None:
        lines.append("    LOAD(t, P.load)")
    lines.append("    mj_step(model, data)")
    for a, (qa, va) in enumerate(zip(P.qa, P.va)):
        lines += [f"    q = qpos[{int(qa)}]", f"    qd = qvel[{int(va)}]"]
        if P.qm[a] < 0:
            lines += ["    dm = 0.0", "    dmd = 0.0"]
        else:
            lines += [f"    dm = qpos[{int(P.qm[a])}] - q", f"    dmd = qvel[{int(P.vm[a])}] - qd"]
        lines += [f"    QO[{4 * a}] = q", f"    QO[{4 * a + 1}] = qd", f"    QO[{4 * a + 2}] = dm", f"    QO[{4 * a + 3}] = dmd"]
    src = "\n".join(lines) + "\n"
    exec(compile(src, "<mjbench MuJoCo step twin>", "exec"), env)  # noqa: S102 - our own generated source
    env["mujoco_step_twin"].source = src  # (what mjbench/kernel/inline.py reads)
    return env["mujoco_step_twin"]


@C.law
def mujoco_unstable(P, S):
    """MuJoCo's bad-acceleration warning was raised."""
    return P.warn[P.bad] != 0


@C.law
def mujoco_internal(out, b, P, S):
    """The internal coordinates x_i = q_a − c·q_b and their rates into ``out[b:]``."""
    n = len(P.xc)
    for i in range(n):
        out[b + i] = P.qpos[P.xi[i, 0]] - P.xc[i] * P.qpos[P.xi[i, 1]]
        out[b + n + i] = P.qvel[P.xi[i, 2]] - P.xc[i] * P.qvel[P.xi[i, 3]]


@C.law
def mujoco_write(out, b, P, S):
    """The internal coordinates and their rates (:func:`mujoco_internal`), then every recorded
    joint's coordinate and rate, qpos and qvel (``joint_<name>_…``, :mod:`mjbench.backends.joints`)."""
    mujoco_internal(out, b, P, S)
    c = b + 2 * len(P.xc)
    for k in range(len(P.jq)):
        out[c + 2 * k] = P.qpos[P.jq[k]]
        out[c + 2 * k + 1] = P.qvel[P.jv[k]]




def _python_internal(plant):
    mech, m, d = plant.machine.mechanism, plant.model, plant.data
    joints = plant._joints

    def write(out, b, P, S):
        x, xd = mech.internal_state(m, d.qpos, d.qvel)
        n = len(x)
        for i in range(n):
            out[b + i] = float(x[i])
            out[b + n + i] = float(xd[i])
        c = b + 2 * n
        for k, (_, _, qa, va) in enumerate(joints):
            out[c + 2 * k] = float(d.qpos[qa])
            out[c + 2 * k + 1] = float(d.qvel[va])
    return write


_MJ_STEP = None


def _mj_step_address():
    """The C address of MuJoCo's ``mj_step`` in the library the Python bindings loaded (the file
    beside the package, which the bindings link to), or None where it cannot be found."""
    global _MJ_STEP
    if _MJ_STEP is None:
        import ctypes
        import glob
        import os

        here = os.path.dirname(mujoco.__file__)
        libs = sorted(f for pattern in ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll")
                      for f in glob.glob(os.path.join(here, pattern)))
        try:
            _MJ_STEP = ctypes.cast(ctypes.CDLL(libs[0]).mj_step, ctypes.c_void_p).value if libs else 0
        except (OSError, AttributeError):  # pragma: no cover - a wheel without the shared library
            _MJ_STEP = 0
    return _MJ_STEP or None


def _extra_names(mech):
    """Recorded columns of a mechanism's internal coordinates: <name>_rad and <name>_rate_rad_s."""
    names = tuple(mech.internal)
    return tuple(f"{n}_rad" for n in names) + tuple(f"{n}_rate_rad_s" for n in names)


def simulate(machine, t_end: float, dt: float | None = None, record_dt: float = 1e-3,
             options: dict | None = None, model=None, progress=None, loop=None) -> Trajectory:
    """Co-simulate ``machine`` on its MuJoCo model for ``t_end`` seconds; returns a Trajectory
    sampled every ``record_dt``.  ``dt`` overrides ``options['timestep']`` (default 1e-4 s)."""
    o = {**DEFAULT_OPTIONS, **(options or {})}
    if dt is not None:
        o["timestep"] = dt
    kernel.check_times(t_end, float(o["timestep"]), record_dt)
    if model is not None and abs(model.opt.timestep - float(o["timestep"])) > 1e-15:
        raise ParameterError(f"model timestep {model.opt.timestep:g} s differs from the requested {o['timestep']:g} s")
    plant = MultibodyPlant(machine, o, model)
    try:
        rec = kernel.run(plant, machine, t_end, record_dt, progress, backend="multibody", loop=loop)
    finally:
        plant.finish()
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
