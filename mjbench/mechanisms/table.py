"""Tabulated reduced model: J, J'/2, E_p' (and a viscous D) of a rigid mechanism over one period.

The reduced (Eksergian) model of a rigid mechanism needs, at every RK4 stage, J(q), J'(q) and
E_p'(q) (seed 000 Eqs 10-13) — closed forms full of trigonometry and square roots (2.8 µs per
four-bar evaluation in Python).  They depend on the input coordinate only and are periodic in it
(one crank turn, ``Mechanism.reduced_period``), so we tabulate them once per mechanism:

* a periodic cubic spline (:func:`mjbench.spline.periodic_cubic`, the spline of
  ``scipy.interpolate.CubicSpline(bc_type="periodic")`` solved by one FFT on the uniform nodes) of each
  quantity on a uniform grid of n nodes over the period; its coefficients are stored per cell in
  the cell's local coordinate f ∈ [0, 1) so that a lookup is ``i = ⌊q·n/P⌋ mod n``,
  ``f = q·n/P − ⌊q·n/P⌋`` and one Horner evaluation ``((c₃f + c₂)f + c₁)f + c₀`` per quantity —
  only +, −, ×, ⌊·⌋: the scalar (Python float) and the array (NumPy, one row per simulation) paths
  perform the same IEEE operations in the same order and give the same bits;
* accuracy measured, not assumed: n starts at ``N0`` and doubles until the largest error against
  the closed forms at 3 interior points of every cell (f = ¼, ½, ¾, where a cubic spline's error
  peaks), relative to the quantity's largest magnitude over the period (½J': not below
  ½``DJ_FLOOR``·J), is ≤ ``tol`` (default 1e-9); the table records that error (``max_rel_error``)
  and its node count.  A spline's error
  falls as h⁴ (×16 per doubling): the seed-000 four-bar needs 2048 nodes (7e-11; docs/performance.md).
* the mechanism's viscous external torque −D(q)·q̇ (``Mechanism.reduced_viscous``, e.g. the
  four-bar's hinge friction) is tabulated as a fourth quantity; any other external torque
  (the quick-return's cutting force, discontinuous; a linkage's point loads; friction) is the
  mechanism's own law, added to the table's at each stage (``Mechanism.model_form``) — those laws
  read the smooth kinematics they need from periodic tables of their own (the quick-return's
  x_C(q), dx_C/dq: ``QuickReturn.slider_table``; a linkage's loads: its ``PeriodicTable``).

Layout: ``coef`` is (4·m, n) — rows c₀ of the m quantities, then c₁, c₂, c₃ — evaluated for
arrays by :meth:`ReducedTable.__call__`; the law :func:`table_model` reads the same coefficients
transposed (``TableP.C``, one row per cell) with the same operations.
Tables are cached by the mechanism's parameters (``describe()``): a batch of gain candidates
shares one table, a calibration builds one per candidate linkage (≈ 2–5 ms).
"""
from __future__ import annotations

import math
import threading
from collections import OrderedDict, namedtuple
from contextlib import contextmanager

import numpy as np

from ..spline import periodic_cubic

from ..compiled import law
from ..errors import ParameterError

N0 = 1024         #: first grid size tried (doubled until the tolerance is met)
NMAX = 1 << 16    #: largest grid tried
TOL = 1e-9        #: default relative interpolation tolerance
#: J' errors are measured against max(|J'|, DJ_FLOOR·J) [per rad] (½J': half of both): a J that hardly
#: varies (a parallelogram's J' ≡ 0 but for the solve's rounding near its change points) is judged by
#: the torque ½J'q̇² it could make next to J·q̈, not by its own rounding.  The shipped mechanisms have
#: |J'|max ≥ 0.47·J_max: the floor is never reached for them.
DJ_FLOOR = 0.2
_CACHE: OrderedDict = OrderedDict()
_CACHE_MAX = 256  #: tables kept (≈ 0.2 MB each, ≈ 1 MB once used by a single run)


def supports(mech) -> bool:
    """Whether the mechanism's reduced model can be tabulated (rigid, periodic in q)."""
    return not mech.internal and getattr(mech, "reduced_period", None)


class ReducedTable:
    """Periodic cubic-spline table of one rigid mechanism (see the module docstring).

    Attributes: ``n`` nodes, ``period`` [rad], ``k`` = n/period [1/rad], ``m`` quantities
    (J, J'/2, E_p' and, if ``viscous``, D), ``coef`` (4m, n), ``max_rel_error`` (measured, per
    quantity in ``errors``)."""

    def __init__(self, mech, tol: float = TOL, n0: int = N0, nmax: int = NMAX, viscous: bool | None = None):
        if not supports(mech):
            raise ParameterError(f"{mech.type_name}: the reduced model cannot be tabulated (internal coordinates "
                                 "or not periodic in the input coordinate); use [reduced] model = \"closed\"")
        self.period = P = float(mech.reduced_period)
        self.viscous = (mech.reduced_viscous(0.0) is not None) if viscous is None else bool(viscous)
        names = ["J", "dJ_half", "dEp"] + (["D"] if self.viscous else [])
        self.names, self.m = tuple(names), len(names)
        n = int(n0)
        if n <= 0 or n & (n - 1):  # the laws find a cell with a bit mask (table_model)
            raise ParameterError(f"tabulated reduced model: n0 = {n0!r} nodes must be a power of two")
        while True:
            q = np.arange(n) * (P / n)
            y = _quantities(mech, q, self.viscous)
            c = periodic_cubic(y)  # (4, n, m): c₀…c₃ of each cell in f = (q − q_i)·n/P (periodic: y_n = y_0)
            # check at 3 interior points of every cell, against the closed forms
            fq = np.array([0.25, 0.5, 0.75])
            qc = (np.arange(n)[:, None] + fq[None, :]).ravel() * (P / n)
            exact = _quantities(mech, qc, self.viscous)
            f = fq[None, :, None]
            approx = (((c[3][:, None] * f + c[2][:, None]) * f + c[1][:, None]) * f + c[0][:, None]).reshape(-1, self.m)
            scale = np.maximum(np.max(np.abs(y), axis=0), 1e-300)
            scale[1] = max(scale[1], 0.5 * DJ_FLOOR * scale[0])  # ½J' of a J that hardly varies: against J
            err = np.max(np.abs(approx - exact), axis=0) / scale
            if np.all(err <= tol) or n >= nmax:
                break
            n *= 2
        self.n = n
        self.k = n / P
        self.errors = dict(zip(names, map(float, err)))
        self.max_rel_error = float(np.max(err))
        self.tol = tol
        if self.max_rel_error > tol:
            raise ParameterError(f"{mech.type_name}: tabulated reduced model misses the tolerance {tol:g} with "
                                 f"{n} nodes (relative error {self.max_rel_error:.3g}: a near-singular linkage?); "
                                 "use [reduced] model = \"closed\"")
        coef = np.empty((4 * self.m, n))
        for j in range(4):  # c_j (power j of f)
            coef[j * self.m:(j + 1) * self.m] = c[j].T
        self.coef = np.ascontiguousarray(coef)

    def describe(self) -> dict:
        return {"model": "table", "table_nodes": self.n, "table_max_rel_error": self.max_rel_error,
                "table_tolerance": self.tol}

    # ---------------------------------------------------------------- evaluation (checks, plots)
    def __call__(self, q):
        """(J, J'/2, E_p'[, D]) at q (float or array), by the same arithmetic as the plants."""
        q = np.asarray(q, dtype=float)
        u = q * self.k
        fl = np.floor(u)
        f = u - fl
        i = np.remainder(fl.astype(np.intp), self.n)
        g = self.coef[:, i]
        m = self.m
        out = []
        for j in range(m):
            out.append(((g[3 * m + j] * f + g[2 * m + j]) * f + g[m + j]) * f + g[j])
        return tuple(out)


def _quantities(mech, q, viscous):
    J, dJ, dEp = mech.reduced(q)
    cols = [np.asarray(J + 0.0 * q, float), 0.5 * np.asarray(dJ + 0.0 * q, float), np.asarray(dEp + 0.0 * q, float)]
    if viscous:
        D = mech.reduced_viscous(q)
        cols.append(np.asarray((0.0 if D is None else D) + 0.0 * q, float))
    return np.stack(cols, axis=1)


def _key(mech, tol, viscous=None):
    return (type(mech).__name__, mechanism_key(mech), float(tol), viscous)


_MEMO = threading.local()


def mechanism_key(mech) -> str:
    """The mechanism's parameters as a cache key: its ``content_key()`` if it has one (a key of the
    description it was built from, kept since), else ``repr(sorted(mech.describe().items()))``;
    computed once per mechanism object while a job is composed (:func:`composing`: the machine
    check and the table both need it, and a description can cost ≈ 25–100 µs)."""
    memo = getattr(_MEMO, "keys", None)
    if memo is not None:
        hit = memo.get(id(mech))
        if hit is not None and hit[0] is mech:
            return hit[1]
    own = getattr(mech, "content_key", None)  # a mechanism that keeps its description's key
    k = own() if own is not None else repr(sorted(mech.describe().items()))
    if memo is not None:
        memo[id(mech)] = (mech, k)
    return k


@contextmanager
def composing():
    """Within this block (the kernel composing one job's runs, no mechanism changes its parameters)
    :func:`mechanism_key` is computed once per mechanism object."""
    if getattr(_MEMO, "keys", None) is not None:
        yield
        return
    _MEMO.keys = {}
    try:
        yield
    finally:
        _MEMO.keys = None


def table_for(mech, tol: float = TOL, viscous: bool | None = None) -> ReducedTable:
    """The (cached) table of a mechanism (``viscous=True``: with a D column, 0 if it has none)."""
    key = _key(mech, tol, viscous)
    t = _CACHE.get(key)
    if t is None:
        t = ReducedTable(mech, tol, viscous=viscous)
        _CACHE[key] = t
        while len(_CACHE) > _CACHE_MAX:
            _CACHE.popitem(last=False)
    else:
        _CACHE.move_to_end(key)
    return t


def floor(x):
    """⌊x⌋ as a float for a Python float (``math.floor`` raises on inf/NaN: those give NaN)."""
    try:
        return float(math.floor(x))
    except (ValueError, OverflowError):
        return math.nan


# ----------------------------------------------------------------------------- the table as a law
#: the table's parameters for :func:`table_model`: coefficients (n, 4m) (row j: c₀ of the m
#: quantities, then c₁, c₂, c₃ of cell j), n cells, k = n/period, m quantities, viscous (4th = D),
#: ``mask`` = n − 1 (n is a power of two: the cell i mod n is i & mask, the same index without an
#: integer division on the lookup's path)
TableP = namedtuple("TableP", "C n k m viscous mask")


def table_params(tab: "ReducedTable") -> TableP:
    """The parameters of :func:`table_model` for a table (one per table: the runs that share a
    mechanism share its coefficients, read-only)."""
    P = getattr(tab, "_params", None)
    if P is None:
        C = np.ascontiguousarray(tab.coef.T)
        C.flags.writeable = False
        n = int(tab.n)
        if n <= 0 or n & (n - 1):
            raise ParameterError(f"table of {n} nodes: the node count must be a power of two")
        P = tab._params = TableP(C, n, float(tab.k), int(tab.m), bool(tab.viscous), n - 1)
    return P


@law
def table_model(q, qd, t, P):
    """(J, ½J', E_p', Q_ext) at input angle q and speed q̇ from the periodic spline table: one
    Horner evaluation per quantity in the cell's local coordinate; Q_ext = −D(q)·q̇ when the table
    carries the viscous D, else 0.  NaN for an angle that is not finite (a diverged run)."""
    u = q * P.k
    if not abs(u) < 1e15:
        return math.nan, math.nan, math.nan, math.nan
    fl = math.floor(u)
    f = u - fl
    j = fl & P.mask  # = fl mod n (n a power of two)
    C = P.C
    m = P.m
    J = ((C[j, 3 * m] * f + C[j, 2 * m]) * f + C[j, m]) * f + C[j, 0]
    H = ((C[j, 3 * m + 1] * f + C[j, 2 * m + 1]) * f + C[j, m + 1]) * f + C[j, 1]
    E = ((C[j, 3 * m + 2] * f + C[j, 2 * m + 2]) * f + C[j, m + 2]) * f + C[j, 2]
    if P.viscous:
        D = ((C[j, 3 * m + 3] * f + C[j, 2 * m + 3]) * f + C[j, m + 3]) * f + C[j, 3]
        return J, H, E, -D * qd
    return J, H, E, 0.0
