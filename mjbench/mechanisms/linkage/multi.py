"""A planar linkage with several input joints (``inputs = ["A", "E"]``): one motor per input.

The description is the linkage's (:mod:`.description`) with ``inputs``, ``input_angles`` and
optionally ``input_ranges``.  Its kinematics are :class:`.multi_kin.MultiPlanarSystem` (one driving
row per input); its mobility is counted at the stated pose (the rank of the joints' constraint
Jacobian: it must equal the number of inputs, else one line says how many motors the linkage
needs); a serial chain (no loop) is the same system without closing joints.

**Reduced model** (n inputs, q ∈ ℝⁿ; docs/linkages.md §8):

    M̄(q) q̈ + c̄(q, q̇) + ḡ(q) + D̄(q) q̇ = τ        (τ: the drives' torques on the inputs)

with M̄ = VᵀMV, c̄ = Vᵀ M w(q̇) (:mod:`.multi_kin`), ḡ = Vᵀ ∂E_p/∂z (gravity, springs) and D̄ the
joints' and dampers' viscous friction projected the same way.  Exact values come from the position
solve at any q (:meth:`MultiCompiled.exact_model`); the simulation reads them from a tensor-product
cubic-spline table over the input ranges (periodic over a full turn, else over the stated range),
refined until the interpolation error measured at every cell centre against the exact solve is
below :data:`TABLE_TARGET` (``table_info``).  The multibody model is the linkage's MJCF, the
drive's reflected inertia on every input joint.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ... import compiled as C
from ...errors import GeometryError, ParameterError
from ..base import Mechanism
from ..linkage_kin import TWO_PI, SolveError
from .kinematics import _deg
from .model import _Compiled
from .multi_kin import MultiPlanarSystem
from .multi_solve import NEWTON_TOL, solve_params
from .topology import GROUND, _ref, _rot2

TABLE_NODES = (32, 64, 128, 256, 512)  #: nodes per input (a full turn; proportionally fewer over a range)
#: target relative interpolation error of M̄, c̄'s coefficients and ḡ (each against its largest value):
#: far below what separates the backends (≈ 1e-6 of the peak speed), at a table of a few MB
TABLE_TARGET = 1e-6
COND_TOL = 1e-9


def _pairs(n):
    return [(j, k) for j in range(n) for k in range(j, n)]


class MultiCompiled(_Compiled):
    """The compiled description of a linkage with several inputs: assembly, mobility, the grid of
    configurations over the input ranges and the reduced model's table."""

    def __init__(self, p):
        super().__init__(p)
        self.inputs = list(p.input_list)
        self.ninputs = n = len(self.inputs)
        drivers = []
        for name in self.inputs:
            j = p.joints[self.jindex[name]]
            (la, _), (lb, _) = _ref(j.at[0]), _ref(j.at[1])
            drivers.append((self.index[la], self.index[lb]))
        self.drivers = drivers
        self.sys = MultiPlanarSystem(self.n, self.kjoints, drivers, self.L)
        self.q_ref = np.array(p.input_angles if p.input_angles is not None else [0.0] * n, dtype=float)
        if p.loads:
            raise GeometryError(f"linkage {p.name!r}: loads on a machine with several inputs are not supported yet "
                                f"(springs and joint damping are)")
        pr = _pairs(n)
        self.layout = {"M": len(pr), "G": n * len(pr), "g": n, "D": len(pr), "Ep": 1}

    # ------------------------------------------------------------------ assembly
    def guess_n(self, q):
        """Rough configuration from the stated link angles, with every input at its value."""
        z = np.zeros(3 * self.n)
        pose = {GROUND: (np.zeros(2), 0.0)}
        inp = {self.p.joints[self.jindex[nm]].name: k for k, nm in enumerate(self.inputs)}
        for e in self.edges:
            oP, thP = pose[e.parent]
            AP = _rot2(thP)
            if e.kind == "R":
                k = inp.get(e.name)
                if k is not None:
                    th = thP + float(q[k]) if e.parent != GROUND else float(q[k])
                else:
                    th = float(self.p.links[e.child].angle)
            else:
                th = thP + e.phi
            o = oP + AP @ e.p - _rot2(th) @ e.c
            pose[e.child] = (o, th)
            b = self.index[e.child]
            z[3 * b:3 * b + 2] = o + _rot2(th) @ self.com[b]
            z[3 * b + 2] = th
        return z

    def build(self):
        p, sysm = self.p, self.sys
        q0 = self.q_ref
        self._mobility_n(self._assemble_free(self.guess_n(q0)))
        z, res = sysm.assemble(self.guess_n(q0), q0)
        if not res < 1e-9:
            raise GeometryError(f"linkage {p.name!r} cannot be assembled at the stated pose (inputs "
                                f"{', '.join(_deg(x) for x in q0)}): the closest assembly leaves a residual "
                                f"{res * self.L:.3g} m")
        self.z_ref = z
        self._grid()
        self.model_kind = p.reduced_model or ("table" if self.ninputs <= 2 else "solve")
        if self.model_kind == "table":
            if self.ninputs > 2:
                raise GeometryError(f"linkage {p.name!r}: reduced_model = 'table' takes 1 or 2 inputs ({self.ninputs} "
                                    f"here): use reduced_model = 'solve' (the loops solved each step)")
            self._tables_n()
        else:  # the loops solved at every evaluation (multi_solve.py): no table
            self.solve_P = solve_params(self)
            self.table_n = None
            self.table_info = {"model": "solve", "newton_tol": NEWTON_TOL}
        return self

    def model_channels(self, Q):
        """The reduced model's channels (B, k) at inputs Q (B, n) as the simulation evaluates them: from
        the table, or solved exactly (``reduced_model = 'solve'``: the simulation solves the loops too)."""
        return self.table_n(Q) if self.table_n is not None else self.exact_model(Q)

    def _assemble_free(self, z0):
        """The joints closed near z0 with every input free (the mobility is counted there)."""
        from scipy.optimize import least_squares

        sysm = self.sys
        nj = 2 * len(sysm.joints)
        if nj == 0:
            return z0
        R, Cs = sysm.row_scale[:nj], sysm.col_scale
        zero = np.zeros((1, self.ninputs))

        def f(x):
            return sysm.phi((x / Cs)[None], zero)[0][:nj] * R

        def jac(x):
            return sysm.jac((x / Cs)[None])[0][:nj] * R[:, None] / Cs[None, :]

        x = least_squares(f, z0 * Cs, jac=jac, method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000).x
        return x / Cs

    def _mobility_n(self, z):
        p, sysm = self.p, self.sys
        n = self.ninputs
        Jm = sysm.jac(z[None])[0] * sysm.row_scale[:, None] / sysm.col_scale[None, :]
        sv = np.linalg.svd(Jm[:-n], compute_uv=False)
        rank = int(np.sum(sv > 1e-9 * max(sv[0], 1e-300))) if len(sv) else 0
        dof = sysm.nz - rank
        if dof != n:
            raise GeometryError(f"linkage {p.name!r} has {dof} degree{'s' if dof != 1 else ''} of freedom at the "
                                f"stated pose (3·{self.n} link coordinates − rank {rank} of the joint constraints) but "
                                f"{n} inputs ({', '.join(self.inputs)}): it needs exactly {dof} motor"
                                f"{'s' if dof != 1 else ''} (one per degree of freedom)")
        full = np.linalg.svd(Jm, compute_uv=False)
        if full[-1] < COND_TOL * full[0]:
            raise GeometryError(f"linkage {p.name!r}: the stated pose is a singular configuration of its inputs "
                                f"(the inputs {', '.join(self.inputs)} do not fix the linkage there)")

    def has_damping(self) -> bool:
        """Whether the reduced model has a viscous part (damped joints or dampers)."""
        return bool(self.damped or any(s.damping > 0 for _, _, s in self.springs))

    def ranges(self):
        """[(lo, hi, periodic)] per input."""
        rs = self.p.input_ranges
        out = []
        for k in range(self.ninputs):
            if rs is None:
                out.append((float(self.q_ref[k]), float(self.q_ref[k]) + TWO_PI, True))
            else:
                lo, hi = float(rs[k][0]), float(rs[k][1])
                if not lo <= self.q_ref[k] <= hi:
                    raise GeometryError(f"linkage {self.p.name!r}: input_ranges[{k}] = [{_deg(lo)}, {_deg(hi)}] does "
                                        f"not contain the stated input angle {_deg(self.q_ref[k])}")
                out.append((lo, hi, False))
        return out

    def _nodes(self, N):
        """The grid's nodes per input for a full turn of N nodes (a range: proportionally, ≥ 8)."""
        out = []
        for lo, hi, per in self.ranges():
            if per:
                out.append(lo + TWO_PI * np.arange(N) / N)
            else:
                m = max(8, int(math.ceil(N * (hi - lo) / TWO_PI)))
                out.append(np.linspace(lo, hi, m + 1))
        return out

    def _grid(self):
        """Coarse configurations on a grid of every input's range (the branch of the stated pose,
        followed by continuation): the starting guesses of every later solve."""
        self.coarse_nodes = self._nodes(TABLE_NODES[0])
        self.coarse_z = self.solve_grid(self.coarse_nodes, None)

    def solve_grid(self, nodes, guess_fn):
        """Configurations (N0, N1, …, 3n) at every node of the grid ``nodes`` (one array per input),
        on the stated pose's branch: by continuation from the stated pose (coarse grid) or from
        ``guess_fn(q (B, n)) → z`` and Newton.  GeometryError naming the inputs where it cannot close."""
        shape = tuple(len(x) for x in nodes)
        Q = np.stack(np.meshgrid(*nodes, indexing="ij"), axis=-1).reshape(-1, self.ninputs)
        if guess_fn is not None:
            z, ok = self.sys.newton(guess_fn(Q), Q)
            if not ok.all():
                self._no_close(Q[~ok][0])
            return z.reshape(shape + (-1,))
        # walk from the stated pose along input 0 to each of its nodes, then with every such
        # configuration at once (a batch) along input 1 to each of its nodes, and so on
        Z = np.array([self.z_ref])  # (B, 3n): the configurations reached so far
        Qc = np.array([self.q_ref])
        for d in range(self.ninputs):
            x = nodes[d]
            out_z = np.empty((len(x),) + Z.shape)
            out_q = np.empty((len(x),) + Qc.shape)
            prev = {}
            for i in self._walk_order(x, self.q_ref[d]):
                src = prev.get(i - 1 if x[i] > self.q_ref[d] else i + 1)
                Zs, Qs = (Z, Qc) if src is None else src
                Qt = Qs.copy()
                Qt[:, d] = x[i]
                try:
                    Zt = self.sys.move_batch(Zs, Qs, Qt)
                except SolveError as e:
                    self._no_close(np.asarray(e.q))
                prev[i] = (Zt, Qt)
                out_z[i], out_q[i] = Zt, Qt
            # the grid so far, inputs 0 … d in order (the new input last)
            Z = np.moveaxis(out_z, 0, 1).reshape(-1, self.sys.nz)
            Qc = np.moveaxis(out_q, 0, 1).reshape(-1, self.ninputs)
        return Z.reshape(shape + (self.sys.nz,))

    @staticmethod
    def _walk_order(x, x0):
        """Node indices outward from the one nearest x0 (up first, then down)."""
        i0 = int(np.argmin(np.abs(x - x0)))
        return list(range(i0, len(x))) + list(range(i0 - 1, -1, -1))

    def _move(self, z, q_from, q_to):
        try:
            return self.sys.move(z, q_from, q_to)
        except SolveError as e:
            self._no_close(np.asarray(e.q if e.q is not None else q_to))

    def _no_close(self, q):
        raise GeometryError(f"linkage {self.p.name!r}: the linkage cannot be followed on its branch to the inputs "
                            f"({', '.join(_deg(x) for x in np.atleast_1d(q))}) inside input_ranges (a loop cannot "
                            f"close, or a singular configuration lies in the way): narrow input_ranges")

    def guess_at(self, Q):
        """Starting configurations (B, 3n) for inputs Q (B, n): the nearest coarse grid node's."""
        Q = np.atleast_2d(Q)
        idx = []
        for k, (lo, hi, per) in enumerate(self.ranges()):
            x = self.coarse_nodes[k]
            if per:
                h = x[1] - x[0]
                i = np.mod(np.round((Q[:, k] - x[0]) / h).astype(int), len(x))
            else:
                i = np.clip(np.round((Q[:, k] - x[0]) / (x[1] - x[0])).astype(int), 0, len(x) - 1)
            idx.append(i)
        z = self.coarse_z[tuple(idx)].copy()
        # the angles of a periodic input: the windings of the node's turn
        return z

    def exact_z(self, Q):
        """Configurations solved at inputs Q (B, n) from the coarse grid's guesses."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        z, ok = self.sys.newton(self.guess_at(Q), Q)
        if not ok.all():
            self._no_close(Q[~ok][0])
        return z

    # ------------------------------------------------------------------ the reduced model
    def exact_model(self, Q, z=None):
        """Channels (B, k) at inputs Q: M̄ (upper triangle, row-major), G (per input i, the pairs j ≤ k),
        ḡ, D̄ (upper triangle), E_p — solved exactly (no table)."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        z = self.exact_z(Q) if z is None else z
        return self.channels_n(z)

    def channels_n(self, z):
        z = np.atleast_2d(z)
        B, n, nb = z.shape[0], self.ninputs, self.n
        sysm = self.sys
        V = sysm.vmatrix(z)  # (B, 3nb, n)
        mdiag = np.repeat(np.stack([self.mass, self.mass, self.inertia], axis=1), 1, axis=0).reshape(-1)
        MV = mdiag[None, :, None] * V
        Mbar = np.einsum("bzi,bzj->bij", V, MV)
        pr = _pairs(n)
        cols = [Mbar[:, j, k] for j, k in pr]
        # c̄ by polarisation: c̄(e_j + e_k) − c̄(e_j) − c̄(e_k) = 2·(cross term)
        cbar = {}
        for j in range(n):
            e = np.zeros((B, n))
            e[:, j] = 1.0
            cbar[(j, j)] = np.einsum("bzi,bz->bi", MV, sysm.accel_terms(z, V, e))
        for j, k in pr:
            if j == k:
                continue
            e = np.zeros((B, n))
            e[:, j] = e[:, k] = 1.0
            cbar[(j, k)] = np.einsum("bzi,bz->bi", MV, sysm.accel_terms(z, V, e)) - cbar[(j, j)] - cbar[(k, k)]
        for i in range(n):
            cols += [cbar[(j, k)][:, i] for j, k in pr]
        # gravity and springs: ḡ = Vᵀ ∂E_p/∂z; E_p
        gx, gy = self.g
        Z = z.reshape(B, nb, 3)
        dEdz = np.zeros((B, nb, 3))
        dEdz[..., 0] = -self.mass * gx
        dEdz[..., 1] = -self.mass * gy
        gbar = np.einsum("bzi,bz->bi", V, dEdz.reshape(B, -1))
        Ep = -(self.mass * (gx * Z[..., 0] + gy * Z[..., 1])).sum(axis=1)
        Dbar = np.zeros((B, n, n))
        if self.damped:
            R = np.stack([self.joint_rates(z, V[:, :, i]) for i in range(n)], axis=-1)  # (B, nj, n)
            for k in self.damped:
                c = self.p.joints[k].damping
                Dbar += c * np.einsum("bi,bj->bij", R[:, k], R[:, k])
        for (ba, pa), (bb, pb), s in self.springs:
            d = sysm.point(z, bb, pb) - sysm.point(z, ba, pa)
            ell = np.linalg.norm(d, axis=1)
            safe = np.where(ell > 0, ell, 1.0)
            dl = np.stack([np.einsum("bk,bk->b", d, sysm.point_vel(z, V[:, :, i], bb, pb)
                                     - sysm.point_vel(z, V[:, :, i], ba, pa)) / safe for i in range(n)], axis=-1)
            if s.stiffness > 0:
                Ep = Ep + 0.5 * s.stiffness * (ell - s.length) ** 2
                gbar = gbar + s.stiffness * (ell - s.length)[:, None] * dl
            if s.damping > 0:
                Dbar += s.damping * np.einsum("bi,bj->bij", dl, dl)
        cols += [gbar[:, i] for i in range(n)]
        cols += [Dbar[:, j, k] for j, k in pr]
        cols.append(Ep)
        return np.stack(cols, axis=1)

    def _tables_n(self):
        """The table: at a first grid size, then (spline error ∝ h⁴) directly at the size its measured
        error asks for, up to the largest of :data:`TABLE_NODES` (the error reached is stated)."""
        if self.p.table_nodes:
            self.table_n, self.table_info = self._table_at(int(self.p.table_nodes))
            return
        N = 64
        tab, info = self._table_at(N)
        err = max(info["rel_error_M"], info["rel_error_c"], info["rel_error_g"])
        if err > TABLE_TARGET:
            want = N * (err / TABLE_TARGET) ** 0.25 * 1.2
            N2 = min(TABLE_NODES[-1], int(2 ** math.ceil(math.log2(want))))
            if N2 > N:
                tab, info = self._table_at(N2)
        self.table_n, self.table_info = tab, info

    def _table_at(self, N):
        nM, nG, ng = self.layout["M"], self.layout["G"], self.layout["g"]
        nodes = self._nodes(N)
        periodic = [r[2] for r in self.ranges()]
        Z = self.solve_grid(nodes, self.guess_at)
        shape = Z.shape[:-1]
        flat = Z.reshape(-1, Z.shape[-1])
        ch = self.channels_n(flat).reshape(shape + (-1,))
        sv = self.sys.singular_values(flat)
        npair = self.layout["M"]
        kloop = npair + self.layout["G"] + self.layout["g"] + (self.layout["D"] if self.has_damping() else 0)
        tab = GridTable(nodes, periodic, ch, kloop)
        # the error at every cell centre against the exact solve
        mids = [x + 0.5 * (x[1] - x[0]) if per else x[:-1] + 0.5 * np.diff(x) for x, per in zip(nodes, periodic)]
        Qm = np.stack(np.meshgrid(*mids, indexing="ij"), axis=-1).reshape(-1, self.ninputs)
        exact = self.exact_model(Qm)
        est = tab(Qm)
        # each group relative to its own largest value (ḡ: at least max|M̄|·1 rad/s², finite without gravity)
        err = np.abs(est - exact)
        sM = max(float(np.max(np.abs(exact[:, :nM]))), 1e-300)
        sG = max(float(np.max(np.abs(exact[:, nM:nM + nG]))), 1e-9 * sM)
        sg = max(float(np.max(np.abs(exact[:, nM + nG:nM + nG + ng]))), sM)
        info = {"nodes": [len(x) for x in nodes], "rel_error_M": float(np.max(err[:, :nM]) / sM),
                "rel_error_c": float(np.max(err[:, nM:nM + nG]) / sG),
                "rel_error_g": float(np.max(err[:, nM + nG:nM + nG + ng]) / sg),
                "min_sigma_ratio": float(np.min(sv[:, -1] / sv[:, 0])), "target": TABLE_TARGET}
        return tab, info


# ============================================================================ the grid table
#: a grid table's parameters: coefficient rows, one per cell, so one evaluation reads one contiguous
#: block — 1 input: (cells, k·4), a channel's 4 coefficients side by side; 2 inputs: (cells, 16·L),
#: coefficient m = 4a + b of every channel side by side (m·L + channel), the simulation's channels
#: padded to L = 4·nvec lanes (at most :data:`LANES`) —, the channels the simulation reads (the first ``kloop``), per input: the
#: first node, 1/h, the number of cells, periodic (1) or not (0); the number of inputs; 2 inputs: the
#: 4-lane registers a coefficient's channels fill (lanes = 4·nvec; 1 input: 0)
GridTableP = namedtuple("GridTableP", "rows kloop x0 inv_h ncell periodic n nvec")
#: a 2-input table's compiled channels at most: the simulation's (M̄, the Christoffel symbols, ḡ: 11;
#: + D̄: 14), padded to whole 4-wide SIMD registers (12 or 16 lanes: :func:`bicubic_lanes`)
LANES = 16
#: the slots after a 2-input table's lanes where :func:`grid2_eval` keeps the cell it evaluated last
CELL_SLOTS = 2


def _aligned(a, align: int = 64):
    """A C-contiguous float64 copy of ``a`` whose data start on an ``align``-byte boundary (``a``
    itself if it does): a 2-input table's rows are 16·4·nvec·8 bytes, a whole number of cache lines,
    so each 4-lane load of :func:`bicubic_lanes` then lies within one line (NumPy aligns to 16 bytes:
    half the loads would straddle two; ≈ 2 % of the five-bar's reduced co-step)."""
    a = np.ascontiguousarray(a, dtype=float)
    if a.ctypes.data % align == 0:
        return a
    buf = np.empty(a.size + align // 8, dtype=float)
    k = (-buf.ctypes.data % align) // 8
    out = buf[k:k + a.size].reshape(a.shape)
    out[...] = a
    return out


class GridTable:
    """A tensor-product cubic spline of k channels over a grid of 1 or 2 inputs (each periodic over
    a full turn, or over a range with not-a-knot ends): values at any q, and the coefficient rows of
    the compiled evaluation (:func:`grid2_eval`)."""

    def __init__(self, nodes, periodic, values, kloop=None):
        from scipy.interpolate import CubicSpline

        self.n = len(nodes)
        if self.n not in (1, 2):
            raise ParameterError(f"a tabulated reduced model of {self.n} inputs: only 1 or 2 are tabulated")
        v = np.asarray(values, float)
        k = v.shape[-1]
        self.x0 = [float(x[0]) for x in nodes]
        self.h = [float(x[1] - x[0]) for x in nodes]
        self.periodic = [bool(p) for p in periodic]

        def spline(x, arr, axis, per, h):
            """Cell coefficients (4, cells, …) along ``axis``: descending powers of s = (x − x_i)/h."""
            if per:
                xs = np.concatenate([x, [x[0] + TWO_PI]])
                arr = np.concatenate([arr, np.take(arr, [0], axis=axis)], axis=axis)
                cs = CubicSpline(xs, arr, axis=axis, bc_type="periodic")
            else:
                cs = CubicSpline(x, arr, axis=axis, bc_type="not-a-knot")
            c = cs.c
            return c * np.array([h ** 3, h ** 2, h, 1.0]).reshape((4,) + (1,) * (c.ndim - 1))

        c0 = spline(nodes[0], v, 0, self.periodic[0], self.h[0])  # (4₀, C0, [N1,] k)
        if self.n == 1:
            self.ncell = [int(c0.shape[1])]
            rows = np.transpose(c0, (1, 2, 0)).reshape(c0.shape[1], -1)  # [i, 4·ch + a]
            self.width = 4
            self.coef = rows.reshape(rows.shape[0], k, 4)
        else:
            c = spline(nodes[1], c0, 2, self.periodic[1], self.h[1])  # (4₁, C1, 4₀, C0, k)
            self.ncell = [int(c.shape[3]), int(c.shape[1])]
            cells = c.shape[3] * c.shape[1]
            coef = np.transpose(c, (3, 1, 2, 0, 4)).reshape(cells, 16, k)  # [i·C1 + j, 4·a + b, ch]
            self.width = 16
            self.coef = np.ascontiguousarray(np.transpose(coef, (0, 2, 1)))  # [cell, ch, 4·a + b]
        self.k = k
        self.kloop = int(k if kloop is None else kloop)
        #: the slots the compiled evaluation writes its channels to (2 inputs: the channels padded to
        #: whole 4-lane registers, the padding zeros); ``scratch``: all it uses (2 inputs: and the
        #: last cell, :data:`CELL_SLOTS`)
        self.slots = self.kloop
        nvec = 0
        if self.n == 2:
            if self.kloop > LANES:
                raise ParameterError(f"a 2-input table of {self.kloop} channels: at most {LANES} are evaluated")
            nvec = (self.kloop + 3) // 4
            lanes = 4 * nvec
            rows = np.zeros((cells, 16, lanes))
            rows[:, :, :self.kloop] = coef[:, :, :self.kloop]
            rows = rows.reshape(cells, 16 * lanes)  # [i·C1 + j, lanes·(4·a + b) + ch]
            self.slots = lanes
        self.scratch = self.slots + (CELL_SLOTS if self.n == 2 else 0)
        self.P = GridTableP(_aligned(rows), self.kloop, np.array(self.x0), 1.0 / np.array(self.h),
                            np.array(self.ncell, dtype=np.int64), np.array(self.periodic, dtype=np.int64), self.n,
                            nvec)

    def __setstate__(self, state):
        """(Read back from the user cache: the rows aligned again, :func:`_aligned`.)"""
        self.__dict__.update(state)
        self.P = self.P._replace(rows=_aligned(self.P.rows))

    def _cells(self, q, d):
        u = (np.asarray(q, float) - self.x0[d]) / self.h[d]
        i = np.floor(u)
        s = u - i
        nc = self.ncell[d]
        if self.periodic[d]:
            i = np.mod(i, nc)
            bad = ~np.isfinite(u)
        else:
            last = i == nc
            i = np.where(last, nc - 1, i)
            s = np.where(last, 1.0, s)
            bad = ~np.isfinite(u) | (i < 0) | (i > nc - 1)
        return np.where(bad, 0, i).astype(np.int64), s, bad

    def __call__(self, Q):
        """Channels (B, k) at inputs Q (B, n), NaN outside the ranges (NumPy, vectorised: the same
        cells and Horner order as the compiled laws :func:`grid1_eval`, :func:`grid2_eval`)."""
        Q = np.atleast_2d(np.asarray(Q, float))
        R = self.coef
        i, s, bad = self._cells(Q[:, 0], 0)
        if self.n == 1:
            c = np.moveaxis(R[i], 1, 0)  # (k, B, 4)
            s = s[None, :]
            out = ((c[..., 0] * s + c[..., 1]) * s + c[..., 2]) * s + c[..., 3]
        else:
            j, t, bad1 = self._cells(Q[:, 1], 1)
            bad = bad | bad1
            c = np.moveaxis(R[i * self.ncell[1] + j], 1, 0)  # (k, B, 16)
            s, t = s[None, :], t[None, :]
            a = [((c[..., 4 * m] * t + c[..., 4 * m + 1]) * t + c[..., 4 * m + 2]) * t + c[..., 4 * m + 3]
                 for m in range(4)]
            out = ((a[0] * s + a[1]) * s + a[2]) * s + a[3]
        out = out.T.copy()
        out[bad] = np.nan
        return out


@C.law
def grid_cell(q, d, T):
    """(cell, s) of input q along dimension d of a grid table (s ∈ [0, 1) in the cell; cell −1:
    outside a non-periodic range)."""
    u = (q - T.x0[d]) * T.inv_h[d]
    if not abs(u) < 1e15:
        return -1, 0.0
    i = math.floor(u)
    s = u - i
    nc = T.ncell[d]
    if T.periodic[d] != 0:
        i = i % nc
    elif i < 0 or i > nc:
        return -1, 0.0
    elif i == nc:  # the last node itself
        i = nc - 1
        s = 1.0
    return int(i), s


@C.law
def grid1_eval(q, T, out, o):
    """The simulation's channels (the first ``T.kloop``) of a 1-input grid table at q into
    out[o:o+kloop] (NaN outside its range)."""
    i, s = grid_cell(q, 0, T)
    R = T.rows
    k = T.kloop
    if i < 0:
        for c in range(k):
            out[o + c] = math.nan
        return
    for c in range(k):
        b = 4 * c
        out[o + c] = ((R[i, b] * s + R[i, b + 1]) * s + R[i, b + 2]) * s + R[i, b + 3]


@C.law
def grid2_eval(q0, q1, T, out, o):
    """The simulation's channels of a 2-input grid table at (q0, q1) into out[o:o+4·T.nvec] (the
    first ``T.kloop``; the rest 0.  NaN outside its ranges): :func:`bicubic_lanes` on the cell's row.

    The cell (i, j) of the last evaluation inside the ranges is kept, as floats, in the two slots
    after the lanes, out[o+4·nvec : o+4·nvec+2] (:data:`CELL_SLOTS`; the table's ``scratch`` counts
    them; any values are safe: a cell outside the table is not used).  While (q0, q1) stays in that
    cell — nearly every RK4 stage of a run — its row is known before the point is: the coefficients'
    loads no longer wait for the floor and index arithmetic of :func:`grid_cell`, which were ≈ 15 % of
    the five-bar's reduced co-step (docs/performance.md §8).  The cell coordinates are the same
    differences u − i as :func:`grid_cell`'s (i = ⌊u⌋ exactly): the same bits."""
    L = 4 * T.nvec
    if o < 0 or o + L + CELL_SLOTS > out.shape[0]:  # (the compiled evaluation writes without bounds checks)
        raise IndexError("grid2_eval: the table's channels do not fit the output array")
    fi = out[o + L]
    fj = out[o + L + 1]
    s = (q0 - T.x0[0]) * T.inv_h[0] - fi
    t = (q1 - T.x0[1]) * T.inv_h[1] - fj
    if 0.0 <= s < 1.0 and 0.0 <= t < 1.0 and 0.0 <= fi < T.ncell[0] and 0.0 <= fj < T.ncell[1]:
        bicubic_lanes(T.rows, int(fi) * T.ncell[1] + int(fj), s, t, out, o, T.nvec)
        return
    i, s = grid_cell(q0, 0, T)
    j, t = grid_cell(q1, 1, T)
    if i < 0 or j < 0:
        for c in range(T.kloop):
            out[o + c] = math.nan
        return
    out[o + L] = float(i)
    out[o + L + 1] = float(j)
    bicubic_lanes(T.rows, i * T.ncell[1] + j, s, t, out, o, T.nvec)


@C.bridge("bicubic_lanes")
def bicubic_lanes(R, r, s, t, out, o, nvec):
    """The L = 4·nvec channels of row ``r`` of a 2-input table at the cell coordinates (s, t) into
    out[o:o+L]: Horner in t for each power of s, then in s.  The row holds the 16 coefficients one
    after the other, each with its L channels side by side (R[r, L·m + c]).

    Compiled, :func:`mjbench.compiled._numba.bicubic_lanes` evaluates 4 channels at a time in SIMD
    registers: the same multiplications and additions per channel in the same order (the same bits),
    written as one short loop over the registers.  LLVM's own vectorisation of this loop needed 16
    channels (a loop of 12 stayed scalar) and unrolled them into ≈ 1 KB of code per evaluation, four
    times per RK4 step: the co-step's code then no longer fits the decoded-instruction cache, and the
    loop ran at the speed of instruction fetch (docs/performance.md §8)."""
    L = 4 * nvec
    for c in range(L):
        a0 = ((R[r, c] * t + R[r, L + c]) * t + R[r, 2 * L + c]) * t + R[r, 3 * L + c]
        a1 = ((R[r, 4 * L + c] * t + R[r, 5 * L + c]) * t + R[r, 6 * L + c]) * t + R[r, 7 * L + c]
        a2 = ((R[r, 8 * L + c] * t + R[r, 9 * L + c]) * t + R[r, 10 * L + c]) * t + R[r, 11 * L + c]
        a3 = ((R[r, 12 * L + c] * t + R[r, 13 * L + c]) * t + R[r, 14 * L + c]) * t + R[r, 15 * L + c]
        out[o + c] = ((a0 * s + a1) * s + a2) * s + a3


__all__ = ["MultiCompiled", "GridTable", "GridTableP", "grid1_eval", "grid2_eval", "bicubic_lanes", "grid_cell",
           "LANES", "CELL_SLOTS", "TABLE_TARGET"]


# ============================================================================ the model law
#: the n-input model law's parameters: the number of inputs, the grid table's
MultiModelP = namedtuple("MultiModelP", "n table damped")


@C.law
def put_two(W, iw, m00, m01, m11, b0, b1):
    """A two-input model's M̄ (row-major, symmetric) and bias into W[iw:iw+6] (the n-input layout)."""
    W[iw] = m00
    W[iw + 1] = m01
    W[iw + 2] = m01
    W[iw + 3] = m11
    W[iw + 4] = b0
    W[iw + 5] = b1


@C.law
def multi_model(S, iy, t, P, W, iw):
    """The reduced model of a linkage with n = P.n inputs at the state (q, q̇) = S[iy:iy+2n]: the mass
    matrix M̄ (n×n, row-major) into W[iw:iw+n²] and the bias c̄(q, q̇) + ḡ(q) + D̄(q)·q̇ into
    W[iw+n²:iw+n²+n]; the table's channels go to W[iw+n²+n:] (scratch)."""
    n = P.n
    ic = iw + n * n + n
    if n == 2:  # (two_model evaluates the table itself: once)
        m00, m01, m11, b0, b1 = two_model(S[iy], S[iy + 1], S[iy + 2], S[iy + 3], t, P, W, ic)
        put_two(W, iw, m00, m01, m11, b0, b1)
        return
    if n == 1:
        grid1_eval(S[iy], P.table, W, ic)
    else:
        grid2_eval(S[iy], S[iy + 1], P.table, W, ic)
    npair = n * (n + 1) // 2
    m = 0
    for j in range(n):
        for k in range(j, n):
            W[iw + j * n + k] = W[ic + m]
            W[iw + k * n + j] = W[ic + m]
            m += 1
    ig = ic + npair + n * npair
    idd = ig + n
    for i in range(n):
        b = W[ig + i]
        m = 0
        for j in range(n):
            for k in range(j, n):
                b += W[ic + npair + i * npair + m] * S[iy + n + j] * S[iy + n + k]
                m += 1
        if P.damped:
            for j in range(n):
                jj = i if i < j else j
                kk = j if i < j else i
                b += W[idd + jj * n - (jj * (jj - 1)) // 2 + (kk - jj)] * S[iy + n + j]
        W[iw + n * n + i] = b


@C.law
def two_model(q0, q1, v0, v1, t, P, W, ic):
    """The reduced model of a linkage with two inputs at q = (q0, q1), q̇ = (v0, v1): (M̄₀₀, M̄₀₁, M̄₁₁,
    bias₀, bias₁), the bias c̄(q, q̇) + ḡ(q) + D̄(q)·q̇; the table's channels go to W[ic:ic+4·nvec]
    (scratch).  :func:`multi_model`'s loops written out for n = 2 (the same operations in the same
    order), and the model law of the two-input RK4 (:func:`mjbench.backends.reduced.rk4_two`)."""
    grid2_eval(q0, q1, P.table, W, ic)
    b0 = W[ic + 9]
    b0 += W[ic + 3] * v0 * v0
    b0 += W[ic + 4] * v0 * v1
    b0 += W[ic + 5] * v1 * v1
    b1 = W[ic + 10]
    b1 += W[ic + 6] * v0 * v0
    b1 += W[ic + 7] * v0 * v1
    b1 += W[ic + 8] * v1 * v1
    if P.damped:
        b0 += W[ic + 11] * v0
        b0 += W[ic + 12] * v1
        b1 += W[ic + 12] * v0
        b1 += W[ic + 13] * v1
    return W[ic], W[ic + 1], W[ic + 2], b0, b1


class MultiLinkageMixin:
    """What a linkage with several inputs offers besides the linkage's MJCF builder."""

    def _stated_z(self):
        return self.c.z_ref[None]


__all__ += ["MultiModelP", "multi_model", "two_model", "MultiLinkageMixin"]
