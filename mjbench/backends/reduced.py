"""Reduced plant: the mechanism's Eksergian model (seed 000 Eqs 10-13), advanced one co-step.

Rigid mechanisms, state (α, α̇):

    α̈ = [τ − c·α̇ + Q_ext(α, α̇, t) − E_p'(α) − ½·J'(α)·α̇²] / (J_eq + J(α))

with τ the drive torque the kernel holds over the step (:mod:`mjbench.kernel`), J_eq the drive's
reflected inertia and c = z²λ its viscous friction — the same split as the multibody plant
(armature and joint damping), so both backends run the *same* drive, controller and current
update and differ by the mechanics alone.  Mechanisms with internal (elastic) coordinates x
(the platforms, a compliant gear) supply their accelerations as a law (``Mechanism.accel_form``).

Methods (``[reduced] method``):
* ``rk4`` (default): classical RK4 with step = the co-simulation step h (0.1 ms by default).
  Local error O(h⁵).  One law each, compiled with the kernel's loop: :func:`rk4_rigid` (the
  model law ``MODEL(q, q̇, t, P) → (J, ½J', E_p', Q_ext)``, ``Mechanism.model_form``) and
  :func:`rk4_internal` (the acceleration law ``ACCEL(t, S, iy, ia, τ, J_eq, c, P)``,
  ``Mechanism.accel_form``, over the state (q, q̇, x₁, ẋ₁, …)).
* ``solve_ivp``: adaptive ``scipy.integrate.solve_ivp`` (DOP853, rtol/atol settable) over every
  step with τ held — a reference to check the fixed-step run against (CPython loop).
The drive's current update and limits are the kernel's, so every method applies the same limits.

Model of a rigid mechanism (``[reduced] model``):
* ``table`` (default for RK4): the mechanism's ``model_form`` — J, J'/2, E_p' (and a viscous
  external D) from its periodic cubic-spline table (:mod:`mjbench.backends.table`; relative
  interpolation error measured ≤ 1e-9, recorded in the trajectory's meta) plus the laws of its
  other external torques (cutting force, point loads, friction), plain float arithmetic;
* ``closed``: the mechanism's closed forms at every stage (the reference; Python, CPython loop).

The plant returns (q, q̇, δ, δ̇) with δ the compliant gear's deflection (motor = crank + δ, the
last internal coordinate ``gear_deflection``), else 0; the internal coordinates and their rates
are recorded as ``<name>_rad`` and ``<name>_rate_rad_s``.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .. import compiled as C
from .. import kernel
from ..drivetrain.gear import DEFLECTION
from ..errors import ParameterError, SimulationDiverged
from ..mechanisms.interface.forms import rigid_accel  # noqa: F401 - the law's old home
from ..trajectory import Trajectory
from .multibody import _extra_names
from .reduced_multi import (GearPlantP, MultiP, axes_gear_read, axes_gear_write, gear_state_size, gear_work,
                            multi_read, multi_state_size, multi_work, rk4_axes_gear, rk4_multi, rk4_two, two_as_multi)
from .table import composing
from .joints import reduced_table
from .multibody import build_model
from ..mechanisms.base import _closed_model


#: co-steps from which a reduced run pays for loading the compiled loop (≈ 0.21 s of start-up against
#: ≈ 4.8 µs saved per co-step, docs/performance.md; the kernel's choose_loop)
MIN_COMPILED_STEPS = 45_000

class ReducedPlant:
    """The reduced model of one machine; its compiled form is :meth:`form` (the kernel's plant slot)."""

    nsim = None

    def __init__(self, machine, dt: float = 1e-4, method: str = "rk4", rtol: float = 1e-10, atol: float = 1e-12,
                 model: str = "table", record_joints: bool = False):
        if method not in ("rk4", "solve_ivp"):
            raise ParameterError(f"reduced.method = {method!r}: choose 'rk4' or 'solve_ivp'")
        if model not in ("table", "closed"):
            raise ParameterError(f"reduced.model = {model!r}: choose 'table' or 'closed'")
        self.machine = machine
        self.h = float(dt)
        self.method, self.rtol, self.atol, self.model = method, rtol, atol, model
        mech, drive = machine.mechanism, machine.drive
        self._mech = mech
        set_step = getattr(mech, "set_step", None)
        if set_step is not None:  # step-dependent parts of the model (friction regularisation)
            set_step(self.h)
        self._n = len(machine.drives)
        self._Ja = float(drive.J_eq) if self._n == 1 else np.array([float(d.J_eq) for d in machine.drives])
        self._c = float(drive.crank_damping) if self._n == 1 else np.array([float(d.crank_damping)
                                                                             for d in machine.drives])
        self._nx = len(mech.internal)
        self.extra_columns = _extra_names(mech)
        self.meta = {"method": method, "model": "closed"}
        self._joints = None  # [simulation] record_joints: the mechanism's own joint table (joints.py)
        self._joint_note = {}
        if record_joints:
            self._joints, names, info = _joint_table(machine, self.h)
            self.extra_columns += names
            self._joint_note = {"joint_columns": info if self._joints is not None else f"not provided: {info}"}
            self.meta.update(self._joint_note)

    # ------------------------------------------------------------------ protocol
    def start(self):
        mc = self.machine
        if self._n > 1:
            self.q = np.asarray(mc.q0, dtype=float).reshape(self._n)
            self.qd = np.asarray(mc.qd0, dtype=float).reshape(self._n) + 0.0 * self.q
            self.x, self.xd = (), ()
            return
        self.q, self.qd = float(mc.q0), float(mc.qd0)
        nx = self._nx
        self.x = tuple(float(v) for v in (mc.x0 or (0.0,) * nx))
        self.xd = tuple(float(v) for v in (mc.xd0 or (0.0,) * nx))

    def _state0(self):
        y = [self.q, self.qd]
        for x, xd in zip(self.x, self.xd):
            y += [x, xd]
        return y

    def form(self):
        """The plant's compiled form: RK4 on the mechanism's reduced model — :func:`rk4_rigid` with
        its ``model_form`` (rigid) or :func:`rk4_internal` with its ``accel_form`` (internal
        coordinates).  A model without a law runs the same RK4 law with a Python adapter of the
        closed forms (CPython loop); ``solve_ivp`` is a Python adapter."""
        mech = self._mech
        flags = {"nextra": len(self.extra_columns), "min_steps": MIN_COMPILED_STEPS}
        if self._n > 1:
            return self._multi_form(flags)
        if self.method == "solve_ivp":
            return self._ivp_form(flags)
        if self._nx == 0:
            if self.model == "table":
                model = mech.model_form()
            else:

                model = C.python_form(_closed_model(mech), "reduced.model = 'closed' (closed forms in Python)")
            self._meta_from(model)
            jP = C.NO_PARAMS if self._joints is None else self._joints.P  # (joints.reduced_table: a law)
            P = RigidP(self.h, self._Ja, self._c, model.P, jP)
            laws = {"read": reduced_read}
            if self._joints is not None:
                laws["write"] = self._joints.law
            return C.Form(rk4_rigid, P, np.array(self._state0()), laws=laws, flags=flags, fn_args=(model,))
        acc = mech.accel_form()
        self._meta_from(acc)
        n = self._nx
        idefl = n - 1 if mech.internal[-1] == DEFLECTION else -1
        P = InternalP(self.h, self._Ja, self._c, n, idefl, acc.P)
        S0 = np.zeros(internal_state_size(n))
        S0[:2 + 2 * n] = self._state0()
        return C.Form(rk4_internal, P, S0, laws={"read": internal_read, "write": internal_write}, flags=flags,
                      fn_args=(acc,))

    def _multi_form(self, flags):
        """n inputs: RK4 on M̄(q) q̈ + c̄ + ḡ + D̄ q̇ = τ − c·q̇ (:func:`rk4_multi`) with the mechanism's
        n-input model law (``model_form``)."""
        if self.method != "rk4" or self.model != "table" or self._joints is not None:
            raise ParameterError("a machine with several inputs: the reduced backend integrates with RK4 on the "
                                 "tabulated model (reduced.method = 'rk4', reduced.model = 'table', no record_joints)")
        model = self._mech.model_form()
        self._meta_from(model)
        n = self._n
        k = int(model.flags.get("channels", 0))
        gear = self._mech.axes_gear()
        if gear is not None:  # compliant gears: each such motor a coordinate of its own (rk4_axes_gear)
            if n == 2:
                model = C.Form(two_as_multi, model.P, fn_args=(model,), flags=dict(model.flags))
            S0 = np.zeros(gear_state_size(n, k))
            S0[:n] = self.q
            S0[n:2 * n] = self.qd
            P = GearPlantP(self.h, n, np.ascontiguousarray(self._Ja), np.ascontiguousarray(self._c), gear, model.P,
                           gear_work(n), k)
            return C.Form(rk4_axes_gear, P, S0, laws={"read": axes_gear_read, "write": axes_gear_write},
                          flags=flags, fn_args=(model,))
        size = multi_state_size(n, k)
        S0 = np.zeros(size)
        S0[:n] = self.q
        S0[n:2 * n] = self.qd
        P = MultiP(self.h, n, np.ascontiguousarray(self._Ja), np.ascontiguousarray(self._c), model.P,
                   multi_work(n), k)
        law = rk4_two if n == 2 else rk4_multi  # (two inputs: the model law is scalar, two_model)
        return C.Form(law, P, S0, laws={"read": multi_read}, flags=flags, fn_args=(model,))

    def _meta_from(self, form):
        tab = form.flags.get("table")
        self.meta = {"method": self.method, **(tab if tab else {"model": "closed"}), **self._joint_note}

    def _ivp_form(self, flags):
        plant = self
        compliant = bool(self._nx) and self._mech.internal[-1] == DEFLECTION

        def offset():
            return (plant.x[-1], plant.xd[-1]) if compliant else (0.0, 0.0)

        def read(P, S, QO):
            QO[0], QO[1] = plant.q, plant.qd
            QO[2], QO[3] = offset()

        def step(TAU, t, P, S, QO):
            plant._advance_ivp(TAU[0], t)
            read(P, S, QO)

        def write(out, b, P, S):
            n = plant._nx
            for i in range(n):
                out[b + i] = plant.x[i]
                out[b + n + i] = plant.xd[i]
            if plant._joints is not None:
                plant._joints.law(out, b + 2 * n, RigidP(0.0, 0.0, 0.0, None, C.python_view(plant._joints.P)),
                                  [plant.q, plant.qd])

        return C.python_form(step, "reduced.method = 'solve_ivp' (scipy, in Python)",
                             laws={"read": read, "write": write}, flags=flags)

    def _advance_ivp(self, tau, t):
        nx = self._nx
        mech, Ja, c = self._mech, self._Ja, self._c

        def rhs(tt, u):
            q, qd = u[0], u[1]
            x, xd = tuple(u[2:2 + nx]), tuple(u[2 + nx:])
            qdd, xdd = mech.reduced_accel(tt, q, qd, x, xd, tau, Ja, c)
            return (qd, qdd, *xd, *xdd)

        y0 = (self.q, self.qd, *self.x, *self.xd)
        from scipy.integrate import solve_ivp

        sol = solve_ivp(rhs, (t, t + self.h), y0, method="DOP853", rtol=self.rtol, atol=self.atol)
        if not sol.success:
            raise SimulationDiverged(f"reduced simulation (solve_ivp) failed at t = {t:.6g} s: {sol.message}", t=t)
        u = sol.y[:, -1]
        self.q, self.qd = float(u[0]), float(u[1])
        self.x = tuple(float(v) for v in u[2:2 + nx])
        self.xd = tuple(float(v) for v in u[2 + nx:])
        return self.q, self.qd


def simulate(machine, t_end: float, dt: float = 1e-4, record_dt: float = 1e-3,
             method: str = "rk4", rtol: float = 1e-10, atol: float = 1e-12, progress=None,
             options=None, model: str = "table", loop=None) -> Trajectory:
    """Run the reduced model of ``machine`` for ``t_end`` s (co-simulation step ``dt``)."""
    if options:
        dt = float(options.get("timestep", dt))
        method = options.get("method", method)
        rtol = float(options.get("rtol", rtol))
        atol = float(options.get("atol", atol))
        model = options.get("model", model)

    with composing():  # the mechanism's description key: once for the table and the machine check
        plant = ReducedPlant(machine, dt, method, rtol, atol, model, bool((options or {}).get("record_joints")))
        rec = kernel.run(plant, machine, t_end, record_dt, progress, backend="reduced", loop=loop)
    return Trajectory.from_record(rec, "reduced")


# ============================================================================ laws
#: the rigid reduced plant's parameters: step, drive inertia J_eq and viscous z²λ, the model's
#: parameters, the joint table's (``record_joints``, :mod:`mjbench.backends.joints`; else empty)
RigidP = namedtuple("RigidP", "h Ja c model joints")
#: the reduced plant with internal coordinates: step, J_eq, z²λ, number n of internal coordinates,
#: index of the compliant gear's deflection among them (−1: none), the acceleration law's parameters
InternalP = namedtuple("InternalP", "h Ja c n idefl acc")


@C.law
def rk4_rigid(MODEL, TAU, t, P, S, QO):
    """One classical RK4 step of α̈ = [τ − c·α̇ + Q_ext − E_p' − ½J'·α̇²] / (J_eq + J) with τ = TAU[0]
    held (S = [α, α̇]); MODEL(q, q̇, t, P.model) → (J, ½J', E_p', Q_ext).  (α, α̇, 0, 0) into QO."""
    tau = TAU[0]
    h = P.h
    h2 = 0.5 * h
    h6 = h / 6.0
    Ja = P.Ja
    c = P.c
    M = P.model
    q = S[0]
    qd = S[1]
    J, H, E, Q = MODEL(q, qd, t, M)
    a1 = (tau - c * qd + Q - E - H * qd * qd) / (Ja + J)
    v2 = qd + h2 * a1
    J, H, E, Q = MODEL(q + h2 * qd, v2, t + h2, M)
    a2 = (tau - c * v2 + Q - E - H * v2 * v2) / (Ja + J)
    v3 = qd + h2 * a2
    J, H, E, Q = MODEL(q + h2 * v2, v3, t + h2, M)
    a3 = (tau - c * v3 + Q - E - H * v3 * v3) / (Ja + J)
    v4 = qd + h * a3
    J, H, E, Q = MODEL(q + h * v3, v4, t + h, M)
    a4 = (tau - c * v4 + Q - E - H * v4 * v4) / (Ja + J)
    q1 = q + h6 * (qd + 2.0 * v2 + 2.0 * v3 + v4)
    qd1 = qd + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    S[0] = q1
    S[1] = qd1
    QO[0] = q1
    QO[1] = qd1
    QO[2] = 0.0
    QO[3] = 0.0


@C.law
def reduced_read(P, S, QO):
    QO[0] = S[0]
    QO[1] = S[1]
    QO[2] = 0.0
    QO[3] = 0.0


_JOINT_TABLES: dict = {}


def _joint_table(machine, h):
    """(the joints' write law (a Form) or None, column names, info or why not) of the machine's mechanism from its q0
    (cached by mechanism and q0)."""

    mech = machine.mechanism
    try:
        key = (type(mech).__name__, repr(sorted(mech.describe().items())), float(machine.q0))
    except Exception:  # noqa: BLE001 - a description that cannot be keyed: no cache
        key = None
    hit = _JOINT_TABLES.get(key) if key is not None else None
    if hit is None:
        model = build_model(machine, {"timestep": h})[1]
        hit = reduced_table(mech, model, float(machine.q0))
        if key is not None:
            if len(_JOINT_TABLES) > 16:
                _JOINT_TABLES.clear()
            _JOINT_TABLES[key] = hit
    return hit


def internal_state_size(n: int) -> int:
    """Length of :func:`rk4_internal`'s state array for n internal coordinates: the state y =
    (q, q̇, x₁, ẋ₁, …) (m = 2n + 2), one stage state (m), four stage accelerations and three stage
    velocities (n + 1 each)."""
    return 2 * (2 * n + 2) + 7 * (n + 1)


@C.law
def rk4_internal(ACCEL, TAU, t, P, S, QO):
    """One classical RK4 step of a mechanism with n = P.n internal coordinates, τ held.

    State S[0:m] = (q, q̇, x₁, ẋ₁, …, xₙ, ẋₙ) (m = 2n + 2; coordinate j at S[2j], its rate at
    S[2j+1]); the rest of S is the step's work space (:func:`internal_state_size`).  ACCEL(t, S, iy,
    ia, τ, J_eq, c, P.acc) reads a state at S[iy:iy+m] and writes the accelerations (q̈, ẍ₁, …, ẍₙ)
    to S[ia:ia+n+1].  (q, q̇, δ, δ̇) at the step's end into QO (δ: the compliant gear's deflection,
    coordinate P.idefl, else 0); τ = TAU[0]."""
    tau = TAU[0]
    h = P.h
    h2 = 0.5 * h
    h6 = h / 6.0
    Ja = P.Ja
    c = P.c
    A = P.acc
    n1 = P.n + 1
    m = 2 * n1
    ys = m
    a1 = 2 * m
    a2 = a1 + n1
    a3 = a2 + n1
    a4 = a3 + n1
    u2 = a4 + n1
    u3 = u2 + n1
    u4 = u3 + n1
    ACCEL(t, S, 0, a1, tau, Ja, c, A)
    for j in range(n1):
        S[u2 + j] = S[2 * j + 1] + h2 * S[a1 + j]
        S[ys + 2 * j] = S[2 * j] + h2 * S[2 * j + 1]
        S[ys + 2 * j + 1] = S[u2 + j]
    ACCEL(t + h2, S, ys, a2, tau, Ja, c, A)
    for j in range(n1):
        S[u3 + j] = S[2 * j + 1] + h2 * S[a2 + j]
        S[ys + 2 * j] = S[2 * j] + h2 * S[u2 + j]
        S[ys + 2 * j + 1] = S[u3 + j]
    ACCEL(t + h2, S, ys, a3, tau, Ja, c, A)
    for j in range(n1):
        S[u4 + j] = S[2 * j + 1] + h * S[a3 + j]
        S[ys + 2 * j] = S[2 * j] + h * S[u3 + j]
        S[ys + 2 * j + 1] = S[u4 + j]
    ACCEL(t + h, S, ys, a4, tau, Ja, c, A)
    for j in range(n1):
        p = S[2 * j]
        v = S[2 * j + 1]
        S[2 * j] = p + h6 * (v + 2.0 * S[u2 + j] + 2.0 * S[u3 + j] + S[u4 + j])
        S[2 * j + 1] = v + h6 * (S[a1 + j] + 2.0 * S[a2 + j] + 2.0 * S[a3 + j] + S[a4 + j])
    internal_read(P, S, QO)


@C.law
def internal_read(P, S, QO):
    """(q, q̇, δ, δ̇) of :func:`rk4_internal`'s state into QO (δ = 0 without a compliant gear)."""
    QO[0] = S[0]
    QO[1] = S[1]
    if P.idefl < 0:
        QO[2] = 0.0
        QO[3] = 0.0
    else:
        k = 2 + 2 * P.idefl
        QO[2] = S[k]
        QO[3] = S[k + 1]


@C.law
def internal_write(out, b, P, S):
    """The internal coordinates x_i, then their rates ẋ_i into ``out[b:]``."""
    n = P.n
    for i in range(n):
        out[b + i] = S[2 + 2 * i]
        out[b + n + i] = S[3 + 2 * i]
