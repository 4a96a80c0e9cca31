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

import numpy as np
from scipy.integrate import solve_ivp

from .. import kernel
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
             options=None, model: str = "table") -> Trajectory:
    """Run the reduced model of ``machine`` for ``t_end`` s (co-simulation step ``dt``)."""
    if options:
        dt = float(options.get("timestep", dt))
        method = options.get("method", method)
        rtol = float(options.get("rtol", rtol))
        atol = float(options.get("atol", atol))
        model = options.get("model", model)
    if method == "rk4" and model == "table":
        from . import fused
        if fused.usable([machine], float(dt), t_end, progress):  # the compiled loop: the same bits
            meta = {"method": method, "model": "closed", **_table.table_for(machine.mechanism).describe()}
            rec = fused.run([machine], t_end, float(dt), record_dt, meta=meta)
            if not rec.diverged[0]:
                meta = {k: v for k, v in rec.meta.items() if k != "nsim"}
                return Trajectory.from_record(kernel.Record(rec.data[0], rec.columns, rec.nrows, rec.diverged,
                                                            rec.t_diverged, rec.messages, meta), "reduced")
            # diverged: the Python kernel below raises SimulationDiverged with its message
    plant = ReducedPlant(machine, dt, method, rtol, atol, model)
    rec = kernel.run(plant, machine.drive, machine.controller, t_end, record_dt, machine.I0, progress,
                     backend="reduced")
    return Trajectory.from_record(rec, "reduced")
