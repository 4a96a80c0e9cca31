"""The co-step kernel: the one loop that runs a machine — on every backend.

A *plant* says how the mechanics advance one step h under a held input torque; everything else
happens here, once, in this order, for a single run (Python floats) or a batch of N runs
((nsim,) arrays, one Python iteration per step for all of them):

1. measurement: t_n, q_n, q̇_n from the plant, q̈_n = (q̇_n − q̇_{n−1})/h (the backward difference a
   digital controller sees; 0 at the first sample), I_n — filled into one :class:`Measurement`;
2. controller, at its own sample period (``controller.period``, a multiple of h; 0 = every
   step), output held in between, then the drive's voltage limiter → V;
3. divergence check and recording, every ``record_dt`` (preallocated arrays, no allocation);
4. input torque τ = z·(k_m·Ī − T_0·sgn φ̇) with Ī the exact mean current over the step (V held,
   φ̇_n) (:meth:`DCMotorDrive.current_mean`, through :meth:`DCMotorDrive.step_torque`); the viscous z²λ and the reflected inertia J_eq are
   the plant's (joint damping and armature in MuJoCo, the same terms in the reduced model), so
   they are integrated inside the step;
5. one plant step (``plant.advance``);
6. I_{n+1} by the drive's exact exponential update with the mean of φ̇_n and φ̇_{n+1}
   (:meth:`DCMotorDrive.current_step`, amplifier current limit included).

Drive-train hooks: when the drive has optional drive-train elements (``drive.train``, see
:mod:`mjbench.drivetrain`: PWM, encoder/sensor, delay, gear, current loop) the train binds, before
the loop, up to three functions that replace steps 1-2 (``sample``: sensor → controller → limiter
→ delay), 4-6 (``step``: current loop → amplifier → torque → plant step → current) and add its
recorded columns (``write``).  A hook the elements do not need is None and the kernel runs the
inline code above, so the ideal drive costs exactly what it did.

Plants (``mjbench.backends``): ``MultibodyPlant`` (one ``mj_step``), ``BatchMultibodyPlant``
(``mujoco.batch``), ``ReducedPlant`` (RK4 or ``solve_ivp`` on the reduced model, rigid or with
internal elastic coordinates).  Because the drive, the controller and the order of operations
are the same, the difference between backends is the mechanics alone, and a batch of N runs is
bit-identical to N single runs.  The common case (ideal drive, speed PID or open-loop voltage,
rigid mechanism) also exists compiled, line for line, on the tabulated reduced plant and around
MuJoCo's own ``mj_step`` (:mod:`mjbench.backends.fused`): the same bits, used once numba is loaded
or for long jobs; this loop stays the reference.

Plant protocol (duck-typed, all arrays preallocated by the plant):
``nsim`` (None for a single run), ``h`` [s], ``start()``, ``read() -> (q, q̇)``,
``advance(tau, t) -> (q, q̇)`` (one step; returns the state at its end — a batch plant returns
copies, as ``read``), ``closure()`` [m], ``unstable()`` (the
engine's own instability flag, e.g. MuJoCo's bad-qacc warning), ``extra_columns`` (names of
plant-specific recorded columns) and ``extra(out)`` writing them, ``retire(mask)`` (batch: stop
stepping diverged runs).
"""
from __future__ import annotations

import math

import numpy as np

from controllers.base import Measurement

from .errors import ParameterError, SimulationDiverged
from .trajectory import NAMES

MAX_SPEED = 1e4  #: rad/s: beyond this an input speed is a diverged simulation, not physics
MAX_CURRENT = 1e5  #: A
NCORE = len(NAMES)


def check_times(t_end, h, record_dt):
    if not (np.isfinite(t_end) and t_end > 0):
        raise ParameterError(f"t_end = {t_end!r}: must be a finite time > 0 [s]")
    if not (np.isfinite(h) and 0 < h <= 0.01):
        raise ParameterError(f"simulation.dt = {h!r}: must be in (0, 0.01] s")
    if not (np.isfinite(record_dt) and record_dt > 0):
        raise ParameterError(f"simulation.record_dt = {record_dt!r}: must be > 0 [s]")


def control_every(controller, h) -> int:
    """Co-simulation steps per control sample (``controller.period`` must be a multiple of h)."""
    p = float(getattr(controller, "period", 0.0) or 0.0)
    if p <= 0.0:
        return 1
    k = p / h
    n = int(round(k))
    if n < 1 or abs(k - n) > 1e-6 * max(1.0, k):
        raise ParameterError(f"controller period = {p:g} s must be a whole multiple of the co-simulation step "
                             f"simulation.dt = {h:g} s")
    return n


class Record:
    """Samples of one run (``data`` (nrec, ncol)) or of N runs (``data`` (nsim, nrec, ncol)) in
    ``columns`` order; ``nrows`` valid rows per run; divergence flags, times and messages."""

    def __init__(self, data, columns, nrows, diverged, t_diverged, messages, meta):
        self.data, self.columns, self.nrows = data, columns, nrows
        self.diverged, self.t_diverged, self.messages, self.meta = diverged, t_diverged, messages, meta


def run(plant, drive, controller, t_end: float, record_dt: float = 1e-3, I0=0.0, progress=None,
        backend: str = "") -> Record:
    """Co-simulate ``plant`` + ``drive`` + ``controller`` for ``t_end`` s; see the module doc.

    A single run raises :class:`SimulationDiverged` (time and state in the message); in a batch a
    diverged run is flagged, its rows stop there and it is no longer stepped."""
    h = float(plant.h)
    check_times(t_end, h, record_dt)
    batch = plant.nsim is not None
    nsim = plant.nsim if batch else 1
    every = control_every(controller, h)
    controller.reset()
    drive.prepare(h)
    plant.start()
    z = drive.z
    y = Measurement(z=z)
    # drive-train hooks (None: the ideal drive's inline code below)
    train = getattr(drive, "train", None)
    hooks = train.bind(plant, drive, controller, h, every, plant.nsim, y) if train is not None else None
    sample = hooks.sample if hooks is not None else None
    dstep = hooks.step if hooks is not None else None
    dwrite = hooks.write if hooks is not None else None

    nsteps = int(round(t_end / h))
    decim = max(1, int(round(record_dt / h)))
    nrec = nsteps // decim + 1
    extra_cols = tuple(plant.extra_columns)
    columns = NAMES + extra_cols + (hooks.columns if hooks is not None else ())
    ncol = len(columns)
    data = np.full((nsim, nrec, ncol) if batch else (nrec, ncol), np.nan)
    flat = None if batch else memoryview(data.reshape(-1))  # a view of data (C-contiguous)
    torque = drive.crank_torque if batch else drive.torque_function(scalar=True)  # recorded τ (viscous part included)
    step_torque = drive.step_torque(h, scalar=not batch)
    vlimit = drive.step_limit(scalar=not batch)  # None: no voltage limit
    step_current = drive.step_current(h, scalar=not batch)
    k_m = drive.k_m
    read, advance = plant.read, plant.advance
    closure, unstable, extra = plant.closure, plant.unstable, plant.extra
    hint = getattr(controller, "divergence_hint", None)
    tick = progress.update if progress is not None else None
    inv_h = 1.0 / h
    I = (np.array(I0, dtype=float) + np.zeros(nsim)) if batch else float(I0)
    q, qd = read()
    qd_prev = qd.copy() if batch else qd
    V = 0.0
    k = 0

    # per-run bookkeeping of a batch
    nrows = np.zeros(nsim, dtype=int)
    diverged = np.zeros(nsim, dtype=bool)
    t_div = np.full(nsim, np.nan)
    messages = [""] * nsim
    alive = np.ones(nsim, dtype=bool)
    any_dead = False
    zeros = np.zeros(nsim) if batch else 0.0

    with np.errstate(all="ignore"):
        for n in range(nsteps + 1):
            t = n * h  # q, qd: the plant's state at t (read before the loop, then returned by each step)
            qdd = (qd - qd_prev) * inv_h  # backward difference, as a digital controller sees it
            if n % every == 0:
                if sample is None:
                    V = controller(t, y.set(t, q, qd, qdd, I))
                    if vlimit is not None:
                        V = vlimit(V)
                else:
                    V = sample(t, q, qd, qdd, I)
                if batch and np.ndim(V) == 0:
                    V = zeros + V
            if n % decim == 0:
                # ---- divergence check (once, for every backend)
                if batch:
                    bad = ~((np.abs(qd) < MAX_SPEED) & (np.abs(I) < MAX_CURRENT) & np.isfinite(V)
                            & np.isfinite(q)) | unstable()
                    new = bad & alive
                    if new.any():
                        for i in np.flatnonzero(new):
                            diverged[i], t_div[i] = True, t
                            messages[i] = _message(backend, t, q[i], qd[i], I[i], V[i],
                                                   hint(t, h) if hint is not None else "")
                        alive &= ~new
                        any_dead = True
                        plant.retire(~alive)
                        if not alive.any():
                            break
                elif not (abs(qd) < MAX_SPEED and abs(I) < MAX_CURRENT and math.isfinite(V)
                          and math.isfinite(q)) or unstable():
                    raise SimulationDiverged(
                        _message(backend, t, q, qd, I, V, hint(t, h) if hint is not None else ""),
                        t=t, state={"q": q, "qd": qd, "I": I, "V": V})
                # ---- record
                om = z * qd
                if batch:
                    r = data[:, k]
                    r[:, 0] = t; r[:, 1] = q; r[:, 2] = qd; r[:, 3] = qdd; r[:, 4] = om; r[:, 5] = I  # noqa: E702
                    r[:, 6] = V; r[:, 7] = torque(I, qd); r[:, 8] = k_m * I * om; r[:, 9] = V * I  # noqa: E702
                    r[:, 10] = closure()
                    if extra_cols:
                        extra(r[:, NCORE:].T)
                    if dwrite is not None:
                        dwrite(r)
                    if any_dead:
                        r[~alive] = np.nan
                    nrows[alive] = k + 1
                else:  # through a flat memoryview of the record: no NumPy row or scalar per sample
                    b = k * ncol
                    flat[b] = t; flat[b + 1] = q; flat[b + 2] = qd; flat[b + 3] = qdd  # noqa: E702
                    flat[b + 4] = om; flat[b + 5] = I; flat[b + 6] = V; flat[b + 7] = torque(I, qd)  # noqa: E702
                    flat[b + 8] = k_m * I * om; flat[b + 9] = V * I; flat[b + 10] = closure()  # noqa: E702
                    if extra_cols or dwrite is not None:
                        r = data[k]
                        if extra_cols:
                            extra(r[NCORE:])
                        if dwrite is not None:
                            dwrite(r)
                k += 1
                if tick is not None:
                    tick(decim)
            if n == nsteps:
                break
            # ---- drive torque over the step, plant step, current update
            if dstep is None:
                q, qd1 = advance(step_torque(I, V, qd), t)
                qd_prev = qd
                I = step_current(I, V, 0.5 * z * (qd + qd1))
                qd = qd1
            else:
                I = dstep(t, I, V, qd)
                qd_prev = qd
                q, qd = read()

    if not batch:
        nrows[0] = k
    meta = {"dt": h, "record_dt": decim * h, "control_period": every * h, **plant.meta}
    if train is not None:
        meta["drivetrain"] = train.describe()
    if batch:
        meta["nsim"] = nsim
    return Record(data, columns, nrows, diverged, t_div, messages, meta)


def _message(backend, t, q, qd, I, V, hint=""):
    return (f"{backend + ' ' if backend else ''}simulation diverged at t = {t:.6g} s: input angle = {q:.6g} rad, "
            f"input speed = {qd:.6g} rad/s, current = {I:.6g} A, voltage = {V:.6g} V (limits |q̇| < "
            f"{MAX_SPEED:g} rad/s, |I| < {MAX_CURRENT:g} A, finite values). Reduce the time step or check "
            f"gains/parameters." + hint)
