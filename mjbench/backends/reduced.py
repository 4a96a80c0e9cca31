"""Reduced plant: the mechanism's Eksergian model (seed 000 Eqs 10-13), advanced one co-step.

Rigid mechanisms, state (α, α̇):

    α̈ = [τ − c·α̇ + Q_ext(α, α̇, t) − E_p'(α) − ½·J'(α)·α̇²] / (J_eq + J(α))

with τ the drive torque the kernel holds over the step (:mod:`mjbench.kernel`), J_eq the drive's
reflected inertia and c = z²λ its viscous friction — the same split as the multibody plant
(armature and joint damping), so both backends run the *same* drive, controller and current
update and differ by the mechanics alone.  Mechanisms with internal (elastic) coordinates x
(the platforms) supply their accelerations through ``Mechanism.reduced_accel``.

Methods (``[reduced] method``):
* ``rk4`` (default): classical RK4 with step = the co-simulation step h (0.1 ms by default).
  Local error O(h⁵).
* ``solve_ivp``: adaptive ``scipy.integrate.solve_ivp`` (DOP853, rtol/atol settable) over every
  step with τ held — a reference to check the fixed-step run against.
The drive's current update and limits are the kernel's, so every method applies the same limits.

Model of a rigid mechanism (``[reduced] model``):
* ``table`` (default for RK4): J, J'/2, E_p' (and a viscous external D) from the mechanism's
  periodic cubic-spline table (:mod:`mjbench.backends.table`; relative interpolation error
  measured ≤ 1e-9, recorded in the trajectory's meta) — plain float arithmetic, no trigonometry,
  ≈ 10× cheaper per step than the closed forms, and the same operations as the batched reduced
  plant (:mod:`mjbench.backends.reduced_batch`), which therefore gives the same bits;
* ``closed``: the mechanism's closed forms at every stage (the reference; 2.8 µs per four-bar
  evaluation).
Mechanisms with internal coordinates (the platforms) and ``solve_ivp`` always use the closed forms.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .. import compiled as C
from .. import kernel
from ..drivetrain.gear import DEFLECTION
from ..errors import ParameterError, SimulationDiverged
from . import table as _table
from ..trajectory import Trajectory
from .multibody import _extra_names


class ReducedPlant:
    """The reduced model of one machine; see the kernel's plant protocol."""

    nsim = None

    def __init__(self, machine, dt: float = 1e-4, method: str = "rk4", rtol: float = 1e-10, atol: float = 1e-12,
                 model: str = "table"):
        if method not in ("rk4", "solve_ivp"):
            raise ParameterError(f"reduced.method = {method!r}: choose 'rk4' or 'solve_ivp'")
        if model not in ("table", "closed"):
            raise ParameterError(f"reduced.model = {model!r}: choose 'table' or 'closed'")
        self.machine = machine
        self.h = float(dt)
        self.method, self.rtol, self.atol = method, rtol, atol
        mech, drive = machine.mechanism, machine.drive
        self._mech = mech
        self._Ja = float(drive.J_eq) if np.ndim(drive.J_eq) == 0 else drive.J_eq
        self._c = float(drive.crank_damping) if np.ndim(drive.crank_damping) == 0 else drive.crank_damping
        self._nx = len(mech.internal)
        self.extra_columns = _extra_names(mech)
        self.meta = {"method": method, "model": "closed"}
        self._accel = self._rigid_accel() if self._nx == 0 else None
        self._table = None
        if model == "table" and method == "rk4" and _table.supports(mech):
            self._table = tab = _table.table_for(mech)
            self.meta.update(tab.describe())
            # the step as one generated function (no call per RK4 stage: 28 % cheaper), bound per instance
            self.advance = _table_advance(self, tab, self._Ja, self._c,
                                          mech.external_torque if (mech.has_external_torque() and not tab.viscous)
                                          else None)

    def _rigid_accel(self):
        reduced, ext = self._mech.reduced, self._mech.external_torque
        Ja, c = self._Ja, self._c

        def accel(t, q, qd, tau):
            J, dJ, dEp = reduced(q)
            return (tau - c * qd + ext(q, qd, t) - dEp - 0.5 * dJ * qd * qd) / (Ja + J)

        return accel

    # ------------------------------------------------------------------ protocol
    def start(self):
        mc = self.machine
        self.q, self.qd = float(mc.q0), float(mc.qd0)
        nx = self._nx
        self.x = tuple(float(v) for v in (mc.x0 or (0.0,) * nx))
        self.xd = tuple(float(v) for v in (mc.xd0 or (0.0,) * nx))

    def form(self):
        """The plant's compiled form: RK4 on the mechanism's reduced model (its ``model_form``, the
        spline table for a rigid crank mechanism); anything else (internal coordinates without a
        law, ``model = "closed"``, ``solve_ivp``) is a Python adapter of :meth:`advance`."""
        mech = self._mech
        flags = {"nextra": len(self.extra_columns)}
        if self.method == "rk4" and self._nx == 0 and self._table is not None:
            model = mech.model_form()
            P = RigidP(self.h, float(self._Ja), float(self._c), model.P)
            S0 = np.array([float(self.machine.q0), float(self.machine.qd0)])
            return C.Form(rk4_rigid, P, S0, laws={"read": reduced_read}, flags=flags, fn_args=(model,))
        return self._python_form(flags)

    def _python_form(self, flags):
        plant = self
        compliant = bool(self._nx) and self._mech.internal[-1] == DEFLECTION

        def offset():
            return (plant.x[-1], plant.xd[-1]) if compliant else (0.0, 0.0)

        def step(tau, t, P, S):
            q, qd = plant.advance(tau, t)
            return (q, qd, *offset())

        def read(P, S):
            return (plant.q, plant.qd, *offset())

        def write(out, b, P, S):
            n = plant._nx
            for i in range(n):
                out[b + i] = plant.x[i]
                out[b + n + i] = plant.xd[i]

        why = ("solve_ivp" if self.method == "solve_ivp" else
               "reduced.model = 'closed' (closed forms in Python)" if self._table is None and self._nx == 0 else
               f"{type(self._mech).__name__} has internal coordinates and no compiled reduced model")
        return C.python_form(step, why, laws={"read": read, "write": write}, flags=flags)

    def read(self):
        return self.q, self.qd

    def closure(self):
        return 0.0

    def unstable(self):
        return False

    def extra(self, out):
        k = self._nx
        out[:k] = self.x
        out[k:] = self.xd

    def retire(self, mask):  # pragma: no cover - single run: never called
        pass

    def advance(self, tau, t):
        if self.method == "solve_ivp":
            return self._advance_ivp(tau, t)
        h = self.h
        h2, h6 = 0.5 * h, h / 6.0
        q, qd = self.q, self.qd
        if self._nx == 0:
            f = self._accel
            try:
                a1 = f(t, q, qd, tau)
                v2 = qd + h2 * a1
                a2 = f(t + h2, q + h2 * qd, v2, tau)
                v3 = qd + h2 * a2
                a3 = f(t + h2, q + h2 * v2, v3, tau)
                v4 = qd + h * a3
                a4 = f(t + h, q + h * v3, v4, tau)
            except (ValueError, OverflowError):  # table lookup at a non-finite angle: diverged
                self.q = self.qd = math.nan
                return self.q, self.qd
            self.q = q + h6 * (qd + 2.0 * v2 + 2.0 * v3 + v4)
            self.qd = qd + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
            return self.q, self.qd
        acc = self._mech.reduced_accel
        Ja, c = self._Ja, self._c
        x, xd = self.x, self.xd
        a1, b1 = acc(t, q, qd, x, xd, tau, Ja, c)
        v2, w2 = qd + h2 * a1, tuple(u + h2 * b for u, b in zip(xd, b1))
        a2, b2 = acc(t + h2, q + h2 * qd, v2, tuple(p + h2 * u for p, u in zip(x, xd)), w2, tau, Ja, c)
        v3, w3 = qd + h2 * a2, tuple(u + h2 * b for u, b in zip(xd, b2))
        a3, b3 = acc(t + h2, q + h2 * v2, v3, tuple(p + h2 * u for p, u in zip(x, w2)), w3, tau, Ja, c)
        v4, w4 = qd + h * a3, tuple(u + h * b for u, b in zip(xd, b3))
        a4, b4 = acc(t + h, q + h * v3, v4, tuple(p + h * u for p, u in zip(x, w3)), w4, tau, Ja, c)
        self.q = q + h6 * (qd + 2.0 * v2 + 2.0 * v3 + v4)
        self.qd = qd + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        self.x = tuple(p + h6 * (u + 2.0 * s2 + 2.0 * s3 + s4) for p, u, s2, s3, s4 in zip(x, xd, w2, w3, w4))
        self.xd = tuple(u + h6 * (c1 + 2.0 * c2 + 2.0 * c3 + c4) for u, c1, c2, c3, c4 in zip(xd, b1, b2, b3, b4))
        return self.q, self.qd

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


def _table_advance(plant, tab, Ja, c, ext):
    """One RK4 step of the tabulated rigid model on Python floats, as a function ``advance(tau, t)``
    generated for the table's variant (with or without the viscous D, with the mechanism's
    untabulated external torque ``ext`` or none): the four stages written out, so a step costs no
    Python call per stage.  The batched plant performs the same operations in the same order
    (same bits; tests/test_reduced_batch.py)."""
    names = ["J", "H", "E"] + (["D"] if tab.viscous else [])
    unpack = ", ".join(f"{x}{j}" for j in range(4) for x in names)

    def poly(x):
        return f"((({x}3 * f + {x}2) * f + {x}1) * f + {x}0)"

    def stage(i, q, v, t):
        if tab.viscous:
            num = f"tau - (c + {poly('D')}) * {v} - {poly('E')} - {poly('H')} * {v} * {v}"
        elif ext is not None:
            num = f"tau - c * {v} + ext(qs, {v}, {t}) - {poly('E')} - {poly('H')} * {v} * {v}"
        else:
            num = f"tau - c * {v} - {poly('E')} - {poly('H')} * {v} * {v}"
        return (f"        qs = {q}\n        u = qs * k\n        fl = floor(u)\n        f = u - fl\n"
                f"        {unpack} = rows[fl % n]\n        a{i} = ({num}) / (Ja + {poly('J')})\n")

    src = ("def advance(tau, t):\n    q, qd = P.q, P.qd\n    try:\n"
           + stage(1, "q", "qd", "t") + "        v2 = qd + h2 * a1\n"
           + stage(2, "q + h2 * qd", "v2", "t + h2") + "        v3 = qd + h2 * a2\n"
           + stage(3, "q + h2 * v2", "v3", "t + h2") + "        v4 = qd + h * a3\n"
           + stage(4, "q + h * v3", "v4", "t + h")
           + "    except (ValueError, OverflowError):  # table lookup at a non-finite angle: diverged\n"
             "        P.q = P.qd = nan\n        return nan, nan\n"
             "    P.q = q1 = q + h6 * (qd + 2.0 * v2 + 2.0 * v3 + v4)\n"
             "    P.qd = qd1 = qd + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)\n    return q1, qd1\n")
    h = plant.h
    env = {"P": plant, "rows": tab.rows, "n": tab.n, "k": tab.k, "Ja": Ja, "c": c, "ext": ext, "floor": math.floor,
           "nan": math.nan, "h": h, "h2": 0.5 * h, "h6": h / 6.0}
    exec(compile(src, f"<reduced table step {tab.names}>", "exec"), env)  # noqa: S102 - our own template
    return env["advance"]


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
    plant = ReducedPlant(machine, dt, method, rtol, atol, model)
    rec = kernel.run(plant, machine, t_end, record_dt, progress, backend="reduced", loop=loop)
    return Trajectory.from_record(rec, "reduced")


#: the rigid reduced plant's parameters: step, drive inertia J_eq and viscous z²λ, the model's parameters
RigidP = namedtuple("RigidP", "h Ja c model")


@C.law
def rk4_rigid(MODEL, tau, t, P, S):
    """One classical RK4 step of α̈ = [τ − c·α̇ + Q_ext − E_p' − ½J'·α̇²] / (J_eq + J) with τ held
    (S = [α, α̇]); MODEL(q, q̇, t, P.model) → (J, ½J', E_p', Q_ext).  → (α, α̇, 0, 0)."""
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
    return q1, qd1, 0.0, 0.0


@C.law
def reduced_read(P, S):
    return S[0], S[1], 0.0, 0.0
