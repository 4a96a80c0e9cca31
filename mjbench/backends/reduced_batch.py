"""Batched reduced plant: N machines' reduced models advanced together, one NumPy pass per stage.

The co-step is the kernel's (:mod:`mjbench.kernel`) on (nsim,) arrays — the same drive and
controller objects as every other backend, stacked by :func:`~mjbench.backends.batch.stack_drives`
and :func:`~mjbench.backends.batch.stack_objects` — so there is no Python per run per step.  The
plant step is RK4 on the mechanics with the drive torque held, as :class:`ReducedPlant`:

* rigid mechanisms (the four-bar, the quick-return): each simulation's mechanism is tabulated
  (:mod:`mjbench.backends.table`, periodic cubic spline, relative error ≤ 1e-9 measured); the
  tables of the distinct mechanisms are stacked side by side, (4m, M·n), and each RK4 stage is
  one gather (``np.take``) of every simulation's cell coefficients plus a Horner evaluation and
  the acceleration formula on (nsim,) arrays, into preallocated buffers.  These are exactly the
  operations of the single run's scalar path, in the same order: a batch gives the same bits as
  N single ``reduced.simulate`` runs (tests/test_reduced_batch.py).  Per-simulation geometry and
  masses cost nothing extra per step (only memory: ≈ 0.2 MB per distinct mechanism).
  An external torque that is not tabulated (the quick-return's cutting force) is evaluated by the
  mechanism's own method on the arrays, once per group of simulations sharing a mechanism.
* mechanisms with internal coordinates (the platforms) or ``model = "closed"``: the mechanism's
  ``reduced_accel`` on the arrays, once per group of simulations sharing a mechanism.

Divergence: as the multibody batch — flagged per simulation at the record instants, rows stop,
the simulation is frozen (its state zeroed, so its table lookups stay valid) and the others go on.
"""
from __future__ import annotations

import copy

import numpy as np

from .. import kernel
from ..errors import ParameterError, SimulationDiverged
from . import _jit
from . import table as _table
from .batch import BatchResult, stack_drives, stack_objects
from .multibody import _extra_names
from .reduced import ReducedPlant


def _groups(mechs):
    """{key: [indices]} of simulations sharing an equal mechanism (first-seen order)."""
    m0 = mechs[0]
    if all(m is m0 for m in mechs):
        return [(m0, np.arange(len(mechs), dtype=np.intp))]
    out, first = {}, {}
    for i, m in enumerate(mechs):
        k = _table._key(m, 0.0)
        out.setdefault(k, []).append(i)
        first.setdefault(k, m)
    return [(first[k], np.array(v, dtype=np.intp)) for k, v in out.items()]


class BatchReducedPlant:
    """N reduced models; see the kernel's plant protocol (arrays of shape (nsim,))."""

    def __init__(self, machines, dt: float = 1e-4, model: str = "table", tol: float = _table.TOL, jit: bool = False):
        if model not in ("table", "closed"):
            raise ParameterError(f"reduced.model = {model!r}: choose 'table' or 'closed'")
        self.machines = list(machines)
        self.nsim = N = len(self.machines)
        self.h = float(dt)
        mechs = [mc.mechanism for mc in self.machines]
        m0 = mechs[0]
        if any(type(m) is not type(m0) for m in mechs):
            raise ParameterError("batch: every simulation needs the same mechanism type; run them in separate batches")
        self.groups = _groups(mechs)
        self.shared = len(self.groups) == 1
        drive = stack_drives([mc.drive for mc in self.machines])
        self._Ja, self._c = drive.J_eq, drive.crank_damping
        self._nx = len(m0.internal)
        self.extra_columns = _extra_names(m0)
        self.meta = {"method": "rk4", "model": "closed"}
        self.q, self.qd = np.zeros(N), np.zeros(N)
        self._zeros = np.zeros(N)
        self._false = np.zeros(N, dtype=bool)
        self._dead = None
        self._use_jit = bool(jit) and _jit.AVAILABLE
        self._table = model == "table" and _table.supports(m0)
        if self._table:
            self._setup_tables(tol)
        else:
            self.x = tuple(np.zeros(N) for _ in range(self._nx))
            self.xd = tuple(np.zeros(N) for _ in range(self._nx))

    # ------------------------------------------------------------------ tabulated rigid model
    def _setup_tables(self, tol):
        N = self.nsim
        tabs = [_table.table_for(m, tol) for m, _ in self.groups]
        if len({t.viscous for t in tabs}) > 1:  # some linkages with hinge friction, some without: D = 0
            tabs = [_table.table_for(m, tol, viscous=True) for m, _ in self.groups]
        t0 = tabs[0]
        self.viscous = t0.viscous
        self.m = m = t0.m
        self.meta.update(model="table", table_nodes=sorted({t.n for t in tabs}),
                         table_max_rel_error=max(t.max_rel_error for t in tabs), table_tolerance=tol)
        self._C = t0.coef if self.shared else np.ascontiguousarray(np.concatenate([t.coef for t in tabs], axis=1))
        self._base = None
        if all(t.n == t0.n for t in tabs):
            self._n, self._k = t0.n, t0.k
        else:  # each simulation looks up its own table's grid (the single run's, hence the same bits)
            self._n, self._k = np.empty(N, dtype=np.intp), np.empty(N)
            for t, (_, idx) in zip(tabs, self.groups):
                self._n[idx], self._k[idx] = t.n, t.k
        if not self.shared:
            self._base = np.empty(N, dtype=np.intp)
            off = 0
            for t, (_, idx) in zip(tabs, self.groups):
                self._base[idx] = off
                off += t.n
        mech = self.groups[0][0]
        self._ext = mech.has_external_torque() and not self.viscous
        self._jit = None
        if self._use_jit and not self._ext:  # the compiled step: same operations, same bits
            self._jit = (np.ascontiguousarray(self._C.T),
                         np.zeros(N, dtype=np.int64) if self._base is None else self._base.astype(np.int64),
                         np.broadcast_to(np.asarray(self._n, dtype=np.int64), (N,)).copy(),
                         np.broadcast_to(np.asarray(self._k, dtype=float), (N,)).copy(),
                         np.broadcast_to(np.asarray(self._Ja, dtype=float), (N,)).copy(),
                         np.broadcast_to(np.asarray(self._c, dtype=float), (N,)).copy())
            self.meta["jit"] = "numba"
        # preallocated buffers
        self._u, self._fl = np.empty(N), np.empty(N)
        self._F = np.empty((m, N))
        self._ib = np.empty(N, dtype=np.intp)
        self._G = G = np.empty((4 * m, N))
        self._Gc = [G[j * m:(j + 1) * m] for j in range(4)]
        self._P = P = np.empty((m, N))
        self._J, self._H, self._E = P[0], P[1], P[2]
        self._D = P[3] if self.viscous else None
        self._t1, self._t2, self._t3 = np.empty(N), np.empty(N), np.empty(N)
        self._ev = np.empty(N)
        self._a = [np.empty(N) for _ in range(4)]
        self._vs = [np.empty(N) for _ in range(3)]
        self._qs = np.empty(N)

    def _external(self, q, qd, t, out):
        """The mechanism's (untabulated) external torque into ``out``, per group of simulations."""
        if self.shared:
            out[:] = self.groups[0][0].external_torque(q, qd, t)
            return
        for mech, idx in self.groups:
            out[idx] = mech.external_torque(q[idx], qd[idx], t)

    def _accel(self, q, v, tau, t, out):
        """Same operations, in the same order, as the scalar path (reduced._table_accel)."""
        mul, add, sub = np.multiply, np.add, np.subtract
        u, fl, ib, P, F = self._u, self._fl, self._ib, self._P, self._F
        G0, G1, G2, G3 = self._Gc
        mul(q, self._k, u)
        np.floor(u, fl)
        f = F[0]
        sub(u, fl, f)
        np.copyto(F[1:], f)  # f in every row: the Horner products below run on contiguous (m, N) blocks
        np.copyto(ib, fl, casting="unsafe")
        np.remainder(ib, self._n, ib)
        if self._base is not None:
            add(ib, self._base, ib)
        self._C.take(ib, 1, self._G)
        mul(G3, F, P)
        add(P, G2, P)
        mul(P, F, P)
        add(P, G1, P)
        mul(P, F, P)
        add(P, G0, P)
        t1, t2 = self._t1, self._t2
        if self.viscous:  # tau − (c + D)·v − E − H·v·v
            add(self._c, self._D, t1)
            mul(t1, v, t1)
            sub(tau, t1, t1)
        else:  # tau − c·v [+ ext] − E − H·v·v
            mul(self._c, v, t1)
            sub(tau, t1, t1)
            if self._ext:
                self._external(q, v, t, self._ev)
                add(t1, self._ev, t1)
        sub(t1, self._E, t1)
        mul(self._H, v, t2)
        mul(t2, v, t2)
        sub(t1, t2, t1)
        add(self._Ja, self._J, t2)
        np.divide(t1, t2, out)

    def _advance_table(self, tau, t):
        if self._jit is not None:
            CT, base, nn, kk, Ja, c = self._jit
            tau = np.broadcast_to(np.asarray(tau, dtype=float), self.q.shape)
            _jit.rk4_table(self.q, self.qd, tau, CT, base, nn, kk, Ja, c, self.h, self.m, self.viscous)
            return
        h = self.h
        h2, h6 = 0.5 * h, h / 6.0
        q, v = self.q, self.qd
        a1, a2, a3, a4 = self._a
        v2, v3, v4 = self._vs
        qs, t3 = self._qs, self._t3
        acc = self._accel
        acc(q, v, tau, t, a1)
        np.multiply(h2, a1, out=v2)
        np.add(v, v2, out=v2)                   # v2 = v + h2·a1
        np.multiply(h2, v, out=qs)
        np.add(q, qs, out=qs)
        acc(qs, v2, tau, t + h2, a2)            # a2 = f(q + h2·v, v2)
        np.multiply(h2, a2, out=v3)
        np.add(v, v3, out=v3)
        np.multiply(h2, v2, out=qs)
        np.add(q, qs, out=qs)
        acc(qs, v3, tau, t + h2, a3)            # a3 = f(q + h2·v2, v3)
        np.multiply(h, a3, out=v4)
        np.add(v, v4, out=v4)
        np.multiply(h, v3, out=qs)
        np.add(q, qs, out=qs)
        acc(qs, v4, tau, t + h, a4)             # a4 = f(q + h·v3, v4)
        # q += h6·(v + 2·v2 + 2·v3 + v4);  v += h6·(a1 + 2·a2 + 2·a3 + a4)
        np.multiply(2.0, v2, out=t3)
        np.add(v, t3, out=t3)
        np.multiply(2.0, v3, out=qs)
        np.add(t3, qs, out=t3)
        np.add(t3, v4, out=t3)
        np.multiply(h6, t3, out=t3)
        np.multiply(2.0, a2, out=qs)
        np.add(a1, qs, out=qs)
        np.multiply(2.0, a3, out=v2)
        np.add(qs, v2, out=qs)
        np.add(qs, a4, out=qs)
        np.multiply(h6, qs, out=qs)
        np.add(q, t3, out=q)
        np.add(v, qs, out=v)

    # ------------------------------------------------------------------ closed forms / internal coordinates
    def _accel_closed(self, t, q, qd, x, xd, tau):
        Ja, c = self._Ja, self._c
        if self.shared:
            return self.groups[0][0].reduced_accel(t, q, qd, x, xd, tau, Ja, c)
        N = self.nsim
        qdd = np.empty(N)
        xdd = tuple(np.empty(N) for _ in range(self._nx))

        def part(a, idx):
            return a[idx] if np.ndim(a) else a
        for mech, idx in self.groups:
            a, b = mech.reduced_accel(t, q[idx], qd[idx], tuple(v[idx] for v in x), tuple(v[idx] for v in xd),
                                      part(tau, idx), part(Ja, idx), part(c, idx))
            qdd[idx] = a
            for j in range(self._nx):
                xdd[j][idx] = b[j]
        return qdd, xdd

    def _advance_closed(self, tau, t):
        h = self.h
        h2, h6 = 0.5 * h, h / 6.0
        q, qd, x, xd = self.q, self.qd, self.x, self.xd
        acc = self._accel_closed
        a1, b1 = acc(t, q, qd, x, xd, tau)
        v2, w2 = qd + h2 * a1, tuple(u + h2 * b for u, b in zip(xd, b1))
        a2, b2 = acc(t + h2, q + h2 * qd, v2, tuple(p + h2 * u for p, u in zip(x, xd)), w2, tau)
        v3, w3 = qd + h2 * a2, tuple(u + h2 * b for u, b in zip(xd, b2))
        a3, b3 = acc(t + h2, q + h2 * v2, v3, tuple(p + h2 * u for p, u in zip(x, w2)), w3, tau)
        v4, w4 = qd + h * a3, tuple(u + h * b for u, b in zip(xd, b3))
        a4, b4 = acc(t + h, q + h * v3, v4, tuple(p + h * u for p, u in zip(x, w3)), w4, tau)
        self.q = q + h6 * (qd + 2.0 * v2 + 2.0 * v3 + v4)
        self.qd = qd + h6 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        self.x = tuple(p + h6 * (u + 2.0 * s2 + 2.0 * s3 + s4) for p, u, s2, s3, s4 in zip(x, xd, w2, w3, w4))
        self.xd = tuple(u + h6 * (c1 + 2.0 * c2 + 2.0 * c3 + c4) for u, c1, c2, c3, c4 in zip(xd, b1, b2, b3, b4))

    # ------------------------------------------------------------------ protocol
    def start(self):
        N = self.nsim
        self.q[:] = [float(mc.q0) for mc in self.machines]
        self.qd[:] = [float(mc.qd0) for mc in self.machines]
        if not self._table:
            self.q, self.qd = self.q.copy(), self.qd.copy()
            nx = self._nx
            self.x = tuple(np.array([float((mc.x0 or (0.0,) * nx)[j]) for mc in self.machines]) for j in range(nx))
            self.xd = tuple(np.array([float((mc.xd0 or (0.0,) * nx)[j]) for mc in self.machines]) for j in range(nx))
        self._dead = None
        self._zeros = np.zeros(N)

    def read(self):
        return self.q.copy(), self.qd.copy()

    def advance(self, tau, t):
        if self._table:
            self._advance_table(tau, t)
        else:
            self._advance_closed(tau, t)
        if self._dead is not None:
            self.q[self._dead] = 0.0
            self.qd[self._dead] = 0.0
            for a in getattr(self, "x", ()) + getattr(self, "xd", ()):
                a[self._dead] = 0.0
        return self.q.copy(), self.qd.copy()

    def closure(self):
        return self._zeros

    def unstable(self):
        return self._false

    def extra(self, out):
        k = self._nx
        for j in range(k):
            out[j] = self.x[j]
            out[k + j] = self.xd[j]

    def retire(self, dead):
        self._dead = np.flatnonzero(dead)


# ================================================================= simulation
#: below this many simulations, N single runs (scalar floats) cost less than one batch of N
#: ((nsim,) arrays: ≈ 100 NumPy calls per step whatever N); same numbers either way
SINGLES_BELOW = 16


def simulate(machines, t_end: float, dt: float | None = None, record_dt: float = 1e-3, options: dict | None = None,
             progress=None, model: str | None = None, single_fast_path: bool = True, **_ignored) -> BatchResult:
    """Co-simulate the machines' reduced models together for ``t_end`` s → :class:`BatchResult`
    (the multibody batch's result type: ``.trajectory(i)``, ``diverged``, ``messages``).

    ``options``: the reduced backend's (``timestep``, ``method`` — RK4 only —, ``model``).  Fewer
    than :data:`SINGLES_BELOW` simulations run one after the other through the single-run plant
    (the same numbers, cheaper at small N; a diverged run then keeps no rows) unless
    ``single_fast_path`` is False."""
    machines = list(machines)
    if not machines:
        raise ParameterError("batch: no simulations")
    o = dict(options or {})
    h = float(dt if dt is not None else o.get("timestep", 1e-4))
    if o.get("method", "rk4") != "rk4":
        raise ParameterError(f"reduced.method = {o['method']!r}: the batched reduced backend integrates with RK4 "
                             "(solve_ivp: run the simulations one by one)")
    model = model or o.get("model", "table")
    kernel.check_times(t_end, h, record_dt)
    if model == "table":
        from . import fused
        if fused.usable(machines, h, t_end, progress):  # the compiled loop: the same bits, every N
            return BatchResult(fused.run(machines, t_end, h, record_dt))
    if len(machines) < SINGLES_BELOW and single_fast_path:
        return _singles(machines, t_end, h, record_dt, model, progress)
    drive = stack_drives([mc.drive for mc in machines])
    ctrl = stack_objects([mc.controller for mc in machines])
    if ctrl is machines[0].controller:
        ctrl = copy.copy(ctrl)  # same object in every machine: one vectorised copy
    jit = _jit.wanted(len(machines) * t_end / h)  # the compiled step pays off on large batches only
    plant = BatchReducedPlant(machines, h, model, jit=jit)
    I0 = np.array([float(mc.I0) for mc in machines])
    rec = kernel.run(plant, drive, ctrl, t_end, record_dt, I0, progress, backend="reduced")
    return BatchResult(rec)


def _singles(machines, t_end, h, record_dt, model, progress):
    """N single runs assembled as one batch record."""
    nsim = len(machines)
    nrec = int(round(t_end / h)) // max(1, int(round(record_dt / h))) + 1
    data, nrows = None, np.zeros(nsim, dtype=int)
    diverged, t_div, messages = np.zeros(nsim, dtype=bool), np.full(nsim, np.nan), [""] * nsim
    meta = {}
    for i, mc in enumerate(machines):
        plant = ReducedPlant(mc, h, "rk4", model=model)
        if data is None:
            cols = kernel.NAMES + plant.extra_columns
            data = np.full((nsim, nrec, len(cols)), np.nan)
        try:
            rec = kernel.run(plant, mc.drive, mc.controller, t_end, record_dt, mc.I0, progress, backend="reduced")
        except SimulationDiverged as e:
            diverged[i], t_div[i], messages[i] = True, (e.t if e.t is not None else np.nan), str(e)
            meta = meta or {"dt": h, **plant.meta}
            continue
        k = int(rec.nrows[0])
        data[i, :k] = rec.data[:k]
        nrows[i] = k
        meta = rec.meta
    rec = kernel.Record(data, cols, nrows, diverged, t_div, messages, {**meta, "nsim": nsim})
    return BatchResult(rec)


__all__ = ["simulate", "BatchReducedPlant"]
