"""The generic linkage with several input joints as a mechanism (``inputs = ["A", "E"]``).

One axis per input joint: the kernel drives each with its own drive and controller
(:attr:`~mjbench.machine.Machine.drives`).  The reduced model is the n×n one of
:mod:`.multi` (tabulated, exact values by the position solve); the MJCF is the linkage's own (every
input joint a tree joint carrying its drive's reflected inertia).
"""
from __future__ import annotations

import math

import numpy as np

from ... import compiled as C
from ...errors import GeometryError, ParameterError
from .mechanism import Linkage
from .model import built
from .multi import GridTable, MultiCompiled, MultiModelP, multi_model, two_model
from .multi_solve import NEWTON_TOL, scratch_size, solve_model, solve_two
from .topology import _ref
_CACHE: dict = {}


def compiled_multi(p) -> MultiCompiled:
    """The built multi-input description, cached in memory and in the user cache like a one-input
    linkage (:func:`.model.built`): a second command reads its grid tables back."""
    return built(p, MultiCompiled, _CACHE, limit=16, kind="multi-linkage")


class MultiLinkage(Linkage):
    """A planar linkage driven at several input joints (one motor each)."""

    reduced_source = "independent: own loop-closure kinematics (Newton + constraint Jacobian), n×n model V^T M V"
    reduced_period = None

    @classmethod
    def accepts(cls, p) -> bool:
        return p.inputs is not None

    @classmethod
    def from_params(cls, p):
        return cls(p)

    def content_key(self) -> str:
        """The key of the description this linkage was built from (a hash of its parameters' JSON: the
        compiled description's cache key), for :func:`mjbench.mechanisms.table.mechanism_key` — the
        linkage runs that description whatever later happens to ``params``."""
        return self.c.content_key

    @property
    def input_joints(self) -> tuple:
        """The driven joints (the description's ``inputs``), one per axis."""
        return self._inputs

    def __init__(self, params):
        self.params = params
        self.name = params.name
        self._inputs = tuple(params.inputs)
        self.input_joint = self._inputs[0]
        self.c = c = compiled_multi(params)
        for k in c.closures:
            if params.joints[k].damping > 0:
                raise GeometryError(f"linkage {params.name!r}: joint {params.joints[k].name!r} closes a loop and has "
                                    f"damping; a machine with several inputs takes damping on its tree joints only "
                                    f"({', '.join(params.joints[e.k].name for e in c.edges)})")
        self.table_info = dict(c.table_info)
        self._has_ext = False
        self._loads = []
        self._mb = None

    def check_friction_joint(self, name: str) -> None:
        """ParameterError unless ``name`` is a hinge of the linkage's tree (a joint MuJoCo carries as a
        joint: friction on it, ``[drive.friction.joints]``, is modelled in both models)."""
        c = self.c
        k = c.jindex.get(name)
        if k is None:
            raise ParameterError(f"drive.friction.joints.{name}: no joint {name!r} in linkage {self.name!r} (joints: "
                                 f"{', '.join(j.name for j in self.params.joints)})")
        if self.params.joints[k].type != "revolute" or k in c.closures:
            tree = ", ".join(self.params.joints[e.k].name for e in c.edges if e.kind == "R")
            raise ParameterError(f"drive.friction.joints.{name}: friction is modelled on the hinges of the linkage's "
                                 f"tree ({tree}); {name!r} is "
                                 f"{'a slide' if self.params.joints[k].type != 'revolute' else 'a loop closure'}")

    def hinge_rates(self, names: tuple):
        """(a grid table of the hinges' speed ratios r_j = ∂θ_j/∂q — channels r_j0, r_j1 per hinge — over
        the two-input model table's grid, or None when the model is solved at every evaluation (the
        law reads V there: :func:`.multi_solve.solve_joint_rate`); max Σ_a |r_ja| per hinge; the grid's
        inputs (B, n)), from the position solve (the table's grid, or the coarse grid of the input
        ranges); kept with the compiled description (every machine built from it shares it)."""
        c = self.c
        cache = c.__dict__.setdefault("_hinge_rates", {})
        got = cache.get(names)
        if got is not None:
            return got
        tab = c.table_n
        if tab is not None:
            nodes = [x0 + h * np.arange(nc + (0 if per else 1)) for x0, h, nc, per in
                     zip(tab.x0, tab.h, tab.ncell, tab.periodic)]
            Z = c.solve_grid(nodes, c.guess_at)
        else:
            nodes, Z = c.coarse_nodes, c.coarse_z
        n = self.n_inputs
        flat = Z.reshape(-1, Z.shape[-1])
        V = c.sys.vmatrix(flat)
        cols = []
        for name in names:
            i, j = self.hinge_bodies(name)
            r = V[:, 3 * j + 2, :] - (V[:, 3 * i + 2, :] if i >= 0 else 0.0)
            cols += [r[:, a] for a in range(n)]
        R = np.stack(cols, axis=1)
        rmax = [float(np.max(np.sum(np.abs(R[:, n * k:n * (k + 1)]), axis=1))) or 1.0 for k in range(len(names))]
        Q = np.stack(np.meshgrid(*nodes, indexing="ij"), axis=-1).reshape(-1, n)
        grid = GridTable(nodes, tab.periodic, R.reshape(Z.shape[:-1] + (-1,))) if tab is not None else None
        got = cache[names] = (grid, rmax, Q)
        return got

    def hinge_bodies(self, name: str) -> tuple:
        """(body a, body b) of hinge ``name`` in the configuration z (−1: the ground): its angle θ_b − θ_a."""
        c = self.c
        jt = self.params.joints[c.jindex[name]]
        (la, _), (lb, _) = _ref(jt.at[0]), _ref(jt.at[1])
        return c.index[la], c.index[lb]

    @property
    def stated_inputs(self) -> tuple:
        """The inputs' values in the stated pose (``input_angles``)."""
        return tuple(float(x) for x in self.c.q_ref)

    # ------------------------------------------------------------------ reduced model
    def reduced(self, q):
        raise ParameterError(f"linkage {self.name!r} has {self.n_inputs} inputs: its reduced model is the n×n "
                             f"M̄(q) (reduced_n), not a J(q); this analysis is one-axis only")

    def reduced_n(self, q):
        """(M̄ (B, n, n), G (B, n, npairs), ḡ (B, n), D̄ (B, n, n)) at inputs q (B, n), solved exactly;
        c̄_i(q, q̇) = Σ_{j≤k} G[i, (j, k)] q̇_j q̇_k."""
        ch = self.c.exact_model(q)
        return unpack(ch, self.n_inputs)

    def bias_n(self, q, qd):
        """c̄(q, q̇) + ḡ(q) + D̄(q)·q̇ (B, n) solved exactly: every generalised force on the inputs
        besides the drives' and M̄·q̈."""
        _, G, g, D = self.reduced_n(q)
        qd = np.atleast_2d(np.asarray(qd, float))
        return cbar(G, qd) + g + np.einsum("bij,bj->bi", D, qd)

    def reduced_table(self, q):
        """The same from the table (what the reduced backend integrates)."""
        return unpack(self.c.model_channels(np.atleast_2d(q)), self.n_inputs)

    def potential_energy(self, q):
        """E_p(q) [J] (gravity, springs) at inputs q (…, n), from the table."""
        q = np.asarray(q, float)
        v = self.c.model_channels(q.reshape(-1, self.n_inputs))[:, -1]
        return v.reshape(q.shape[:-1]) if q.ndim > 1 else float(v[0])

    def kinetic_energy(self, q, qd):
        M = self.reduced_table(np.atleast_2d(q))[0]
        qd = np.atleast_2d(qd)
        return 0.5 * np.einsum("bi,bij,bj->b", qd, M, qd)

    def external_torque(self, q, qd, t):
        return 0.0 * np.asarray(q, float)

    def has_external_torque(self) -> bool:
        return False

    def model_form(self):
        """The n-input model law: on the grid table :func:`.multi.multi_model`, for two inputs the scalar
        :func:`.multi.two_model` (the reduced plant's two-input RK4 calls it so); with
        ``reduced_model = 'solve'`` :func:`.multi_solve.solve_model` (two inputs: :func:`.multi_solve.solve_two`),
        the loops solved at every evaluation."""
        c = self.c
        if c.table_n is None:
            law = solve_two if self.n_inputs == 2 else solve_model
            P = c.solve_P
            return C.Form(law, P, flags={"table": {"model": "solve", "newton_tol": NEWTON_TOL},
                                         "channels": scratch_size(P.n, P.nz), "min_steps": 0})
        tab = c.table_n
        law = two_model if self.n_inputs == 2 else multi_model
        return C.Form(law, MultiModelP(self.n_inputs, tab.P, bool(c.has_damping())),
                      flags={"table": {"model": "table", "table_nodes": self.table_info.get("nodes"),
                                       "table_rel_error_M": self.table_info.get("rel_error_M"),
                                       "table_rel_error_c": self.table_info.get("rel_error_c"),
                                       "table_rel_error_g": self.table_info.get("rel_error_g")},
                             "channels": tab.scratch,
                             # its CPython evaluation (the bicubic table's lanes, ≈ 85 µs a call) costs more
                             # than numba's start-up within the first co-steps: a run that evaluates it compiles
                             "min_steps": 0})

    def divergence_hint(self, t: float, q) -> str:
        """The likely cause of a reduced run that diverged, from its last recorded inputs q (n) at t:
        an input beyond the table's range, or inputs just ahead where the loops cannot be solved."""
        c = self.c
        lab = ", ".join(f"{a} = {math.degrees(float(x)):.4g}°" for a, x in zip(self.input_joints, q))
        if c.table_n is not None:
            for k, (lo, hi, per) in enumerate(c.ranges()):
                if not per and not lo - 1e-9 <= float(q[k]) <= hi + 1e-9:
                    return (f" Likely cause: axis {self.input_joints[k]} left its input_ranges[{k}] = "
                            f"[{math.degrees(lo):.4g}°, {math.degrees(hi):.4g}°] (the table of the reduced model ends "
                            f"there; last recorded at t = {t:.4g} s: {lab}): keep the motion inside or widen the range")
            return ""
        return (f" Likely cause: the linkage reached inputs where its loops cannot be solved (a singular "
                f"configuration, or the loops cannot close) just after t = {t:.4g} s ({lab})")

    def has_multibody_load(self) -> bool:
        return False

    def load_form(self, model, data):
        return None

    # ------------------------------------------------------------------ configurations
    def _stated_z(self):
        return self.c.z_ref[None]

    def _drawing_z(self, n: int):
        """The coarse grid's configurations over the input ranges (display sizes)."""
        Z = self.c.coarse_z.reshape(-1, self.c.sys.nz)
        return Z[:: max(1, len(Z) // n)]

    def _q(self, q):
        q = np.asarray(q, dtype=float)
        if q.shape[-1:] != (self.n_inputs,):
            raise ParameterError(f"linkage {self.name!r}: input angles {q.tolist()} — give {self.n_inputs} values "
                                 f"({', '.join(self.input_joints)})")
        return q

    def initial_qpos(self, model, q0, x0=None) -> np.ndarray:
        q = self._q(q0)
        z = self.c.exact_z(q[None])
        vals, _ = self._tree_values(z)
        qpos = np.array(model.qpos0, dtype=float)
        for name, val in vals.items():
            qpos[model.joint(name).qposadr[0]] = val
        return qpos

    def initial_qvel(self, model, q0, qd0, x0=None, xd0=None) -> np.ndarray:
        q = self._q(q0)
        qd = self._q(qd0)
        z = self.c.exact_z(q[None])
        V = self.c.sys.vmatrix(z)[0]
        v = V @ qd
        _, rates = self._tree_values(z, v[None])
        qvel = np.zeros(model.nv)
        for name, r in rates.items():
            qvel[model.joint(name).dofadr[0]] = r
        return qvel

    def jacobian_inputs(self, q):
        """V = ∂z/∂q (B, 3·nbody, n) at inputs q (B, n)."""
        z = self.c.exact_z(np.atleast_2d(q))
        return z, self.c.sys.vmatrix(z)

    # ------------------------------------------------------------------ the task space
    def point_ref(self, point: str):
        """(body, local point relative to its mass centre) of "link.point"."""
        link, pt = _ref(point)
        if link not in self.c.pts or pt not in self.c.pts[link]:
            raise ParameterError(f"path.point = {point!r}: no such point (links: {', '.join(self.c.links)})")
        return self.c._body_point(link, pt)

    def inverse_kinematics(self, point: str, X, Vx, Ax, times=None, tol=1e-6):
        """Inputs q, q̇, q̈ (B, n) that put ``point`` at X (B, 2) with velocity Vx and acceleration Ax,
        following the stated pose's assembly branch from the first sample: sequential Newton on a
        coarse subsequence (each from the previous solution), then every sample at once from the
        interpolated coarse solutions.  GeometryError naming the time and the point where the path
        meets a singular configuration: the inverse kinematics' (the point cannot move in some
        direction) or the machine's own (the inputs do not fix the linkage)."""
        if self.n_inputs != 2:
            raise ParameterError(f"a task-space path (a point in the plane) needs 2 inputs; {self.name!r} has "
                                 f"{self.n_inputs}")
        c, sysm = self.c, self.c.sys
        b, sp = self.point_ref(point)
        nj = 2 * len(sysm.joints)
        X, Vx, Ax = (np.atleast_2d(np.asarray(a, float)) for a in (X, Vx, Ax))
        B = len(X)
        times = np.arange(B, dtype=float) if times is None else np.asarray(times, float)
        scale = np.concatenate([sysm.row_scale[:nj], [1.0 / c.L, 1.0 / c.L]])
        zero_q = np.zeros((1, self.n_inputs))

        def psi(Z, Xt):
            F = sysm.phi(Z, np.broadcast_to(zero_q, (len(Z), self.n_inputs)))[:, :nj]
            return np.concatenate([F, sysm.point(Z, b, sp) - Xt], axis=1)

        def jac(Z):
            J = sysm.jac(Z)[:, :nj]
            Jp = np.zeros((len(Z), 2, sysm.nz))
            if b >= 0:
                th = Z[:, 3 * b + 2]
                cth, sth = np.cos(th), np.sin(th)
                Jp[:, 0, 3 * b] = Jp[:, 1, 3 * b + 1] = 1.0
                Jp[:, 0, 3 * b + 2] = -sth * sp[0] - cth * sp[1]
                Jp[:, 1, 3 * b + 2] = cth * sp[0] - sth * sp[1]
            return np.concatenate([J, Jp], axis=1)

        def newton(Z, Xt, maxit=30):
            Z = np.array(Z, float)
            for _ in range(maxit):
                F = psi(Z, Xt)
                err = np.max(np.abs(F * scale[None, :]), axis=1)
                if np.all(err < 1e-12):
                    return Z, np.ones(len(Z), bool)
                with np.errstate(all="ignore"):
                    Z = Z - np.linalg.solve(jac(Z), F[..., None])[..., 0]
            err = np.max(np.abs(psi(Z, Xt) * scale[None, :]), axis=1)
            return Z, np.isfinite(err) & (err < 1e-10)

        def where(k):
            return f"t = {float(times[k]):.4g} s, point ({X[k, 0]:.6g}, {X[k, 1]:.6g}) m"

        # coarse: sequential from the stated pose (the branch), every `step` samples
        step = max(1, B // 200)
        ic = list(range(0, B, step)) + ([B - 1] if (B - 1) % step else [])
        Zc = np.empty((len(ic), sysm.nz))
        z = self.c.z_ref.copy()
        for m, k in enumerate(ic):
            zz, ok = newton(z[None], X[k:k + 1])
            if not ok[0]:
                raise GeometryError(f"linkage {self.name!r}: the path cannot be followed at {where(k)} (the inverse "
                                    f"kinematics does not converge there: outside the workspace?)")
            z = Zc[m] = zz[0]
        # every sample from the interpolated coarse solutions
        Z0 = np.stack([np.interp(np.arange(B), ic, Zc[:, j]) for j in range(sysm.nz)], axis=1)
        Z, ok = newton(Z0, X)
        if not ok.all():
            k = int(np.flatnonzero(~ok)[0])
            raise GeometryError(f"linkage {self.name!r}: the path cannot be followed at {where(k)}")
        Jz = jac(Z)
        sv = np.linalg.svd(Jz * scale[None, :, None] / sysm.col_scale[None, None, :], compute_uv=False)
        bad = sv[:, -1] < tol * sv[:, 0]
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise GeometryError(f"linkage {self.name!r}: the path meets a singular configuration of the inverse "
                                f"kinematics at {where(k)} (the point cannot move in some direction there)")
        sv2 = sysm.singular_values(Z)
        bad = sv2[:, -1] < tol * sv2[:, 0]
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise GeometryError(f"linkage {self.name!r}: the path meets a singular configuration of the machine "
                                f"at {where(k)} (the inputs do not fix the linkage there)")
        rhs = np.concatenate([np.zeros((B, nj)), Vx], axis=1)
        Zd = np.linalg.solve(Jz, rhs[..., None])[..., 0]
        g = sysm.gamma(Z, Zd)[:, :nj]
        if b >= 0:
            th, w = Z[:, 3 * b + 2], Zd[:, 3 * b + 2]
            cth, sth = np.cos(th), np.sin(th)
            gp = np.stack([cth * sp[0] - sth * sp[1], sth * sp[0] + cth * sp[1]], axis=1) * (w * w)[:, None]
        else:
            gp = np.zeros((B, 2))
        Zdd = np.linalg.solve(Jz, np.concatenate([g, Ax + gp], axis=1)[..., None])[..., 0]
        Q, Qd, Qdd = (np.empty((B, self.n_inputs)) for _ in range(3))
        for m, (i, j) in enumerate(c.drivers):
            for out, arr in ((Q, Z), (Qd, Zd), (Qdd, Zdd)):
                out[:, m] = arr[:, 3 * j + 2] - (arr[:, 3 * i + 2] if i >= 0 else 0.0)
        return Q, Qd, Qdd

    def points(self, q):
        q = np.asarray(q, dtype=float)
        shape = q.shape[:-1]
        z = self.c.exact_z(q.reshape(-1, self.n_inputs))
        pts = self.c.world_points(z)
        return {k: (x.reshape(shape), y.reshape(shape)) if shape else (float(x[0]), float(y[0]))
                for k, (x, y) in pts.items()}

    def trace_point(self, q):
        ref = self.params.trace
        return None if ref is None else self.points(q)[ref]

    def linkage_view(self):
        return None

    def kinematics(self, q):
        why = f"linkage {self.name!r} has {self.n_inputs} inputs: the one-input kinematic analysis does not apply"
        return {"source": "not available for a machine with several inputs", "ratios": {}, "ratio_units": {},
                "transmission": {}, "toggles": {}, "limit_positions": {},
                "unavailable": {"velocity_ratios": why, "transmission_angles": why, "toggles": why,
                                "limit_positions": why}}

    def input_positions(self, n: int):
        raise ParameterError(f"linkage {self.name!r} has {self.n_inputs} inputs: no single input turn to sample")

    def joint_states(self, model, q):
        raise ParameterError(f"linkage {self.name!r}: record_joints on the reduced backend is one-input only")


def unpack(ch, n):
    """(M̄ (B, n, n), G (B, n, npairs), ḡ (B, n), D̄ (B, n, n)) from the table's channels (B, k)."""
    ch = np.atleast_2d(ch)
    B = ch.shape[0]
    pr = [(j, k) for j in range(n) for k in range(j, n)]
    npair = len(pr)
    M = np.zeros((B, n, n))
    D = np.zeros((B, n, n))
    for m, (j, k) in enumerate(pr):
        M[:, j, k] = M[:, k, j] = ch[:, m]
        D[:, j, k] = D[:, k, j] = ch[:, npair + n * npair + n + m]
    G = ch[:, npair:npair + n * npair].reshape(B, n, npair)
    g = ch[:, npair + n * npair:npair + n * npair + n]
    return M, G, g, D


def cbar(G, qd):
    """c̄(q, q̇) (B, n) from the coefficients G (B, n, npairs) and the rates qd (B, n)."""
    n = qd.shape[-1]
    pr = [(j, k) for j in range(n) for k in range(j, n)]
    prod = np.stack([qd[:, j] * qd[:, k] for j, k in pr], axis=-1)
    return np.einsum("bip,bp->bi", G, prod)


__all__ = ["MultiLinkage", "compiled_multi", "unpack", "cbar"]
