"""The compiled co-step for the design loops: the kernel's loop, drive, PID and tabulated reduced plant in one numba function.

Why: a single reduced run of the Python kernel costs ≈ 3 µs per co-step, nearly all of it Python
calls (kernel, PID, drive, plant); a batch amortises them only from N ≈ 100.  ``tune``'s local
Nelder–Mead stage is sequential (80 single runs), so the design loop was bound by the Python
per-step cost.  Here the whole loop of one run — measurement, PID at its period, limiter,
divergence check, decimated record, step-mean torque, RK4 step on the table, exact current
update with the amplifier limit — is one compiled function
(:func:`mjbench.backends._jit_kernels.run_pid`): 0.056 µs per co-step measured (scripts/bench.py,
part ``reduced``), 50× less than the Python kernel's single run.

It is not a second model: every line mirrors, operation for operation and in the same order, the
Python code of :func:`mjbench.kernel.run`, :class:`controllers.pid.PID`,
:class:`controllers.openloop.ConstantVoltage`,
:class:`controllers.reference.ConstantSpeed`, :class:`mjbench.drive.DCMotorDrive` and the tabulated
:class:`~mjbench.backends.reduced.ReducedPlant`, without fast-math or fused multiply-add, so its
record is the same bits as the Python kernel's (tests/test_fused.py, over gains, K_p·t ramps and
their bound, anti-windup, voltage and current limits, Coulomb friction, hinge friction, control
periods, open-loop ramps, per-run mechanisms and divergence).  The Python kernel stays the reference and the
path of everything else.

Used, by ``reduced.simulate`` and ``reduced_batch.simulate``, when all of these hold:
* numba is installed (``pip install mjbench[fast]``) and wanted (:func:`mjbench.backends._jit.wanted`:
  numba already loaded, ``MJBENCH_JIT=1``, or a large job — loading numba and the compiled
  function costs ≈ 0.5 s once per process; the design loops load it up front when their planned
  work pays for it, :func:`preload`);
* the drive is ideal (no drive-train elements) with scalar constants;
* the controller is the speed PID with a constant-speed reference (``omega0``) or the open-loop
  voltage (``type = "open"``), scalar parameters;
* the mechanism is rigid and tabulated (:mod:`mjbench.backends.table`) with no untabulated
  external torque; RK4 (``method = "rk4"``, ``model = "table"``); no progress bar.
Anything else runs the Python kernel, with the same numbers; ``MJBENCH_FUSED=0`` always runs the
Python kernel (``MJBENCH_JIT=0`` too, which also turns off the batch's compiled plant step).

**The same loop around MuJoCo** (:func:`run_multibody`): a single multibody run whose plant
passes :func:`supported_multibody` — the same drive and controller, a rigid mechanism without
MuJoCo loads of its own (a four-bar without hinge-C friction, a Watt six-bar, a user MJCF; not the
process loads of the presses or the quick-return's cutting force), loop closures as site
``connect`` equalities, contacts off — runs the same compiled function with its plant step
replaced by MuJoCo's own C ``mj_step`` on the plant's ``MjData`` (called through its address,
:func:`mjbench.backends._jit_kernels._call_pp`), the state read from ``qpos``/``qvel``, the loop
closure from ``site_xpos`` and the instability flag from MuJoCo's warning counter: the same bits
as the Python kernel on :class:`~mjbench.backends.multibody.MultibodyPlant`
(tests/test_fused.py), at ≈ 1.0× a bare ``mj_step`` loop instead of ≈ 1.2× (scripts/bench.py,
``cosim_fused_over_bare_step``, ``multibody_fused_single_over_bare``).  Used by
``multibody.simulate`` and the single-run path of ``batch.simulate`` when numba is loaded,
``MJBENCH_JIT=1`` or the run has ≥ :data:`MIN_RUN_STEPS_MULTIBODY` steps.  A MuJoCo error inside the
compiled loop could not become a Python exception; the one MuJoCo can raise in a step of these
models, an exhausted arena, cannot happen: with contacts off the constraint set is fixed, and a
step uses the same ≈ 2–4 kB of the default 13 MB arena every time (measured on the four-bar, the
six-bar and the user-MJCF four-bar).

A single run that diverges is re-run by the Python kernel, which raises the usual
:class:`~mjbench.errors.SimulationDiverged` with its message; in a batch the diverged run's
message is built from the state the compiled loop stopped at.
"""
from __future__ import annotations

import math
import os

import numpy as np

from .. import kernel
from . import _jit
from . import table as _table

#: below this many run-steps (N × steps) the compiled loop is not worth loading numba for
#: (≈ 0.5 s of loading against ≈ 3 µs saved per run-step)
MIN_RUN_STEPS = 200_000
#: the same for a single multibody run: ≈ 3 µs saved per step (the Python part of the co-step and
#: of the binding's call) against ≈ 0.27 s of loading, break-even ≈ 10⁵ steps (10 s at 0.1 ms)
MIN_RUN_STEPS_MULTIBODY = 200_000


def preload(run_steps: float) -> bool:
    """Load numba and the compiled loop now when a design loop plans ``run_steps`` (N × steps
    over all its simulations) and that pays for the loading; returns whether it is loaded."""
    if _jit.wanted(run_steps, MIN_RUN_STEPS):
        _jit.fused_kernel()
        return True
    return False


def supported(machine, h: float) -> bool:
    """Whether ``machine`` can run on the compiled loop at step h on the tabulated reduced plant
    (see the module doc)."""
    mech = machine.mechanism
    if not _drive_and_controller_supported(machine, h):
        return False
    if mech.internal or not _table.supports(mech):
        return False
    if mech.has_external_torque() and mech.reduced_viscous(0.0) is None:  # an untabulated torque
        return False
    return True


def _drive_and_controller_supported(machine, h: float) -> bool:
    """The ideal drive and the PID / open-loop controller with scalar parameters, a valid period."""
    drive, ctrl = machine.drive, machine.controller
    kind = _kind(ctrl)
    if getattr(drive, "train", None) is not None or kind is None:
        return False
    scal = (drive.R, drive.L, drive.k_m, drive.J_m, drive.J_a, drive.J_b, drive.z, drive.T_0, drive.lam,
            drive.v_max, drive.i_max, machine.q0, machine.qd0, machine.I0)
    if kind == 0:
        scal += (ctrl.kp, ctrl.ki, ctrl.kd, ctrl.t_ramp_max, ctrl.reference.omega0,
                 0.0 if ctrl.v_limit is None else ctrl.v_limit, 0.0 if ctrl.reference.phi0 is None else ctrl.reference.phi0)
        if ctrl.reference.phi0 is not None and math.isnan(ctrl.reference.phi0):
            return False
    else:
        scal += (ctrl.voltage, ctrl.t_ramp)
    if any(np.ndim(v) != 0 for v in scal) or machine.x0 or machine.xd0:
        return False
    try:
        kernel.control_every(ctrl, h)
    except Exception:  # the Python kernel raises the readable error
        return False
    return True


def _kind(ctrl):
    """0: the speed PID with a constant-speed reference, 1: the open-loop voltage, None: other."""
    from controllers.openloop import ConstantVoltage
    from controllers.pid import PID
    from controllers.reference import ConstantSpeed

    if type(ctrl) is PID and type(ctrl.reference) is ConstantSpeed:
        return 0
    if type(ctrl) is ConstantVoltage:
        return 1
    return None


def usable(machines, h: float, t_end: float, progress=None) -> bool:
    """Whether these runs go to the compiled loop (installed, wanted, supported)."""
    if progress is not None or not _jit.AVAILABLE or os.environ.get("MJBENCH_FUSED", "") == "0":
        return False
    if not _jit.wanted(len(machines) * t_end / h, MIN_RUN_STEPS):
        return False
    return all(supported(mc, h) for mc in machines)


class _NoPID:  # the PID columns of an open-loop run (unused by the compiled loop)
    kp = ki = kd = 0.0
    kp_ramp = False
    t_ramp_max = math.inf
    v_limit = None

    class reference:
        omega0 = 0.0
        phi0 = None


_NO_PID = _NoPID()


def run(machines, t_end: float, h: float, record_dt: float, backend: str = "reduced", meta=None) -> kernel.Record:
    """Run the machines on the compiled loop → the (N, nrec, ncol) :class:`~mjbench.kernel.Record`
    of ``kernel.run`` on the batched reduced plant (same columns, rows and flags; ``meta``: the
    plant's meta to report instead of the batched plant's)."""
    from .reduced_batch import BatchReducedPlant

    kernel.check_times(t_end, h, record_dt)
    machines = list(machines)
    plant = BatchReducedPlant(machines, h, "table", jit=True)  # the stacked tables of the compiled step
    plant.start()
    CT, base, nn, kk, Ja, c = plant._jit
    ctrls = [mc.controller for mc in machines]
    if len(machines) > 1:  # the Python batch's rules: the same machines are accepted (or refused) with or without numba
        from .batch import stack_objects
        kernel.control_every(stack_objects(ctrls), h)
    table = (plant.q.copy(), plant.qd.copy(), _col([float(mc.I0) for mc in machines]), CT, base, nn, kk, Ja, c,
             int(plant.m), bool(plant.viscous))
    return _run(machines, table, _NO_MUJOCO, t_end, h, record_dt, backend, plant.meta if meta is None else meta)


def run_multibody(plant, t_end: float, record_dt: float) -> kernel.Record:
    """Run a :class:`~mjbench.backends.multibody.MultibodyPlant` whose machine passes
    :func:`supported_multibody` on the compiled loop (MuJoCo's own ``mj_step`` called from it) →
    the single-run :class:`~mjbench.kernel.Record` of ``kernel.run`` on that plant, the same bits."""
    import mujoco

    h = plant.h
    kernel.check_times(t_end, h, record_dt)
    mc = plant.machine
    plant.start()
    q, qd = plant.read()
    m, d = plant.model, plant.data
    idx = mc.mechanism.closure_site_index(m)
    table = (_col([q]), _col([qd]), _col([float(mc.I0)]), np.zeros((1, 4)), np.zeros(1, np.int64),
             np.ones(1, np.int64), _col([0.0]), _col([0.0]), _col([0.0]), 1, False)  # no table (never read)
    mj = (True, _mj_step_address(), m._address, d._address, d.qpos, d.qvel, d.qfrc_applied, plant._qa, plant._va,
          plant._vd, d.site_xpos.reshape(-1), np.array(idx, dtype=np.int64).reshape(-1, 2), d.warning.number,
          int(mujoco.mjtWarning.mjWARN_BADQACC))
    rec = _run([mc], table, mj, t_end, h, record_dt, "multibody", plant.meta)
    meta = {k: v for k, v in rec.meta.items() if k != "nsim"}
    return kernel.Record(rec.data[0], rec.columns, rec.nrows, rec.diverged, rec.t_diverged, rec.messages, meta)


def try_multibody(plant, t_end: float, record_dt: float, progress=None):
    """The record of :func:`run_multibody` when this run goes to the compiled loop
    (:func:`usable_multibody`) and does not diverge; None otherwise: the caller runs the Python
    kernel, which raises (or flags) a divergence with its own message."""
    if not usable_multibody(plant, t_end, progress):
        return None
    rec = run_multibody(plant, t_end, record_dt)
    return None if rec.diverged[0] else rec


def supported_multibody(plant) -> bool:
    """Whether a single-run :class:`~mjbench.backends.multibody.MultibodyPlant` can run on the
    compiled loop: the drive and controller of :func:`supported`, a rigid mechanism without its own
    MuJoCo loads whose loop closure is read from connect sites, contacts off (a fixed set of
    constraints: see the module doc), MuJoCo's ``mj_step`` found in its shared library."""
    import mujoco

    mech, m = plant.machine.mechanism, plant.model
    if not _drive_and_controller_supported(plant.machine, plant.h) or mech.internal or mech.has_multibody_load():
        return False
    if not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        return False
    return mech.closure_site_index(m) is not None and _mj_step_address() is not None


def usable_multibody(plant, t_end: float, progress=None) -> bool:
    """Whether this single multibody run goes to the compiled loop (installed, wanted: numba
    loaded, ``MJBENCH_JIT=1`` or ≥ :data:`MIN_RUN_STEPS_MULTIBODY` steps; supported)."""
    if progress is not None or not _jit.AVAILABLE or os.environ.get("MJBENCH_FUSED", "") == "0":
        return False
    return _jit.wanted(t_end / plant.h, MIN_RUN_STEPS_MULTIBODY) and supported_multibody(plant)


def _mj_step_address():
    """The C address of MuJoCo's ``mj_step`` in the library the Python bindings loaded (the file
    beside the package, which the bindings link to), or None where it cannot be found."""
    global _MJ_STEP
    if _MJ_STEP is None:
        import ctypes
        import glob

        import mujoco

        here = os.path.dirname(mujoco.__file__)
        libs = sorted(f for pattern in ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll")
                      for f in glob.glob(os.path.join(here, pattern)))
        try:
            _MJ_STEP = ctypes.cast(ctypes.CDLL(libs[0]).mj_step, ctypes.c_void_p).value if libs else 0
        except (OSError, AttributeError):  # pragma: no cover - a wheel without the shared library
            _MJ_STEP = 0
    return _MJ_STEP or None


_MJ_STEP = None
#: the plant arguments of a reduced run (no MuJoCo model; never read)
_NO_MUJOCO = (False, 0, 0, 0, np.zeros(1), np.zeros(1), np.zeros(1), 0, 0, 0, np.zeros(1), np.zeros((0, 2), np.int64),
              np.zeros(4, np.int32)[::2], 0)


def _col(vals, dtype=np.float64):
    return np.array(vals, dtype=dtype)


def _run(machines, table, mj, t_end, h, record_dt, backend, plant_meta):
    """The compiled loop over ``machines`` on the table plant arguments or the MuJoCo ones."""
    N = len(machines)
    drives = [mc.drive for mc in machines]
    for d in drives:
        d.prepare(h)
    ctrls = [mc.controller for mc in machines]
    for ct in ctrls:
        ct.reset()
    inf = math.inf
    kinds = [_kind(ct) for ct in ctrls]
    pids = [ct if k == 0 else _NO_PID for ct, k in zip(ctrls, kinds)]
    every = _col([kernel.control_every(ct, h) for ct in ctrls], np.int64)
    args = (*table,
            _col([d.R for d in drives]), _col([d.k_m for d in drives]), _col([d.z for d in drives]),
            _col([d.T_0 for d in drives]), _col([d.lam for d in drives]), _col([d._w for d in drives]),
            _col([d._decay for d in drives]), _col([d.v_max for d in drives]), _col([d.i_max for d in drives]),
            _col(kinds, np.int64), _col([p.kp for p in pids]), _col([p.ki for p in pids]), _col([p.kd for p in pids]),
            _col([p.kp_ramp for p in pids], np.bool_), _col([p.t_ramp_max for p in pids]),
            _col([inf if p.v_limit is None else p.v_limit for p in pids]),
            _col([p.reference.omega0 for p in pids]),
            _col([math.nan if p.reference.phi0 is None else p.reference.phi0 for p in pids]),
            _col([getattr(ct, "voltage", 0.0) for ct in ctrls]), _col([getattr(ct, "t_ramp", 0.0) for ct in ctrls]),
            every, *mj)
    nsteps = int(round(t_end / h))
    decim = max(1, int(round(record_dt / h)))
    nrec = nsteps // decim + 1
    data = np.full((N, nrec, kernel.NCORE), np.nan)
    nrows = np.zeros(N, dtype=np.int64)
    t_div = np.full(N, np.nan)
    state = np.zeros((N, 4))
    _jit.fused_kernel()(*args, h, nsteps, decim, kernel.MAX_SPEED, kernel.MAX_CURRENT, data, nrows, t_div, state)
    diverged = ~np.isnan(t_div)
    messages = [""] * N
    for i in np.flatnonzero(diverged):
        q, qd, I, V = state[i]
        hint_fn = getattr(ctrls[i], "divergence_hint", None)
        hint = hint_fn(float(t_div[i]), h) if hint_fn is not None else ""
        messages[i] = kernel._message(backend, float(t_div[i]), q, qd, I, V, hint)
    meta = {"dt": h, "record_dt": decim * h, "control_period": int(every[0]) * h, **plant_meta, "jit": "numba-fused"}
    meta["nsim"] = N
    return kernel.Record(data, kernel.NAMES, nrows.astype(int), diverged, t_div, messages, meta)
