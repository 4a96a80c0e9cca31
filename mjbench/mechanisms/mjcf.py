"""A user's own MJCF model as the mechanism (``[mechanism] type = "mjcf"``).

The file holds any MuJoCo model whose driven joint is one hinge or slide (``input_joint``); closed
loops are equality constraints (``connect``, ``weld``, joint equalities ...).  mjbench drives that
joint with its motor model and controllers (``qfrc_applied``, the drive's reflected inertia as
``armature`` and its viscous friction as ``damping``), exactly as the built-in mechanisms.

The reduced (Eksergian) model is **derived from MuJoCo itself**, so it is *not* an independent
check of the multibody run (every output says so, see :attr:`MjcfMechanism.reduced_source`):

* position: Newton on the equality residuals ``efc_pos`` with the input held (least squares on
  MuJoCo's constraint Jacobian ``efc_J``, steps applied with ``mj_integratePos``), the branch
  followed by continuation from the stated pose (a keyframe) over the input's travel;
* velocity coefficients v = dqvel/dq̇_in: the null space of ``efc_J`` with v_in = 1;
* J(q) = vᵀMv (``mj_fullM``); E_p'(q) = vᵀ(qfrc_bias − qfrc_spring) at zero velocity (gravity and
  springs; ``mj_fwdVelocity``); viscous friction D(q) = −vᵀ·qfrc_damper(v) (joint and tendon
  damping of the file); E_p(q) from ``mj_energyPos``;
* J'(q): 4th-order central differences of J along the constraint manifold,
  [8(J(q+δ) − J(q−δ)) − (J(q+2δ) − J(q−2δ))]/(12δ), δ = 2e-3 rad (or m·1e-3 of the travel);
  its error is estimated at every node from the same formula with 2δ (stored in ``table_info``).

A hinge input is tabulated over one turn (periodic splines, like the generic linkage); a slide
input over its ``range`` in the file (the reduced model refuses positions outside it).

Drawing: bodies and sites projected on MuJoCo's x-z plane (:func:`~mjbench.mechanisms.base.mj_to_plane`,
the plane convention of ``mechanisms/base.py``; the camera of ``mjbench render`` looks along +y), the
traced point is the site ``trace`` names.
"""
from __future__ import annotations

import hashlib
import math
import os
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field

from ..compiled import law
from ..errors import GeometryError, ParameterError
from ..fields import Bool, OptQ, Strict
from . import register
from .base import PLANE_INDEX, Mechanism, closure_solref, set_solver_options
from .linkage_kin import TWO_PI, PeriodicTable
from .. import compiled as C
from .linkage.view import _roots


class MjcfParams(Strict):
    """``[mechanism] type = "mjcf"``: a MuJoCo model file with one driven hinge or slide joint."""

    type: Literal["mjcf"] = "mjcf"
    file: str = Field(description="MJCF file (a relative path is relative to the scenario file)")
    input_joint: str = Field(description="name of the driven hinge or slide joint")
    keyframe: str | None = Field(None, description="keyframe with the stated pose (assembly branch); "
                                                   "default: the first keyframe, else qpos0")
    input_angle: OptQ("angle") = Field(None, description="input position of the stated pose "
                                                         "(default: the keyframe's)")
    trace: str | None = Field(None, description="site traced in videos")
    contacts: Bool = Field(False, description="keep the file's contacts (default: off, as every mjbench model)")
    keep_solref: Bool = Field(False, description="keep the file's equality solref/solimp (default: "
                                                 "nearly hard, as the built-in mechanisms)")
    table_nodes: int = Field(1024, ge=64, le=16384, description="nodes of the reduced-model table")


def resolve_path(path: str, source: str = "") -> str:
    """A model path relative to the scenario file (``source``; built-ins: the package's scenarios)."""
    if os.path.isabs(path):
        return path
    if source.startswith("builtin:"):
        import importlib.resources

        return str(importlib.resources.files("mjbench").joinpath("scenarios", path))
    if source and os.path.exists(source):
        return os.path.normpath(os.path.join(os.path.dirname(source), path))
    return os.path.abspath(path)


class _Table:
    """Uniform cubic-spline table over a finite range [lo, hi] (slide input)."""

    def __init__(self, lo, hi, values):
        from scipy.interpolate import CubicSpline

        self.lo, self.hi = float(lo), float(hi)
        x = np.linspace(lo, hi, len(values))
        self.sp = CubicSpline(x, np.asarray(values), axis=0)
        c = self.sp.c  # (4, n − 1, k): powers 3, 2, 1, 0 of (q − x_i)
        n = len(x)
        rows = np.ascontiguousarray(c.transpose(1, 2, 0).reshape(n - 1, -1))
        self.P = RangeTableP(np.ascontiguousarray(x, dtype=float), rows, self.lo, self.hi,
                             (n - 1) / (self.hi - self.lo), n, False)

    def _check(self, q):
        qa = np.asarray(q, float)
        if np.any(qa < self.lo - 1e-12) or np.any(qa > self.hi + 1e-12):
            raise GeometryError(f"mjcf input position {np.ravel(qa)[0]:.6g} m is outside the slide range "
                                f"[{self.lo:.6g}, {self.hi:.6g}] m of the model file")

    def __call__(self, q, channels=None):
        self._check(q)
        v = self.sp(np.asarray(q, float))
        return v if channels is None else v[..., channels]

    def scalar3(self, q):
        """Channels 0, 1, 2 at a float q (:func:`range_channel`; GeometryError outside the range)."""
        self._check(q)
        P = self.P
        return range_channel(q, 0, P), range_channel(q, 1, P), range_channel(q, 2, P)

    def scalar(self, q, ch):
        self._check(q)
        return range_channel(q, ch, self.P)


class _Model:
    """The file's model with mjbench's options, and its reduced model (cached per file + params)."""

    def __init__(self, p: MjcfParams, path: str):
        import mujoco

        self.p, self.path = p, path
        if not os.path.isfile(path):
            raise ParameterError(f"mechanism.file = {p.file!r}: no such file ({path})")
        try:
            spec = mujoco.MjSpec.from_file(path)
            spec.compile()
        except Exception as e:  # MuJoCo's parser/compiler errors
            raise ParameterError(f"mechanism.file = {p.file!r}: MuJoCo cannot load it: {e}") from None
        try:
            jnt = spec.joint(p.input_joint)
        except Exception:
            jnt = None
        names = [j.name for j in spec.joints]
        if jnt is None:
            raise ParameterError(f"mechanism.input_joint = {p.input_joint!r}: no joint of that name in {p.file} "
                                 f"(joints: {', '.join(n for n in names if n) or 'none named'})")
        if jnt.type not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
            raise ParameterError(f"mechanism.input_joint = {p.input_joint!r}: must be a hinge or slide joint")
        self.hinge = jnt.type == mujoco.mjtJoint.mjJNT_HINGE
        for a in list(spec.actuators):
            if a.trntype == mujoco.mjtTrn.mjTRN_JOINT and a.target == p.input_joint:
                spec.delete(a)  # mjbench's drive replaces the file's actuator on the input joint
            else:
                raise ParameterError(f"mechanism.file = {p.file!r}: actuator {a.name or '(unnamed)'!r} acts on "
                                     f"{a.target!r}; mjbench drives only input_joint {p.input_joint!r} "
                                     f"(remove the other actuators)")
        self.spec = spec
        self.model = self.compile({"timestep": 1e-4})
        m = self.model
        self.jin = m.joint(p.input_joint)
        self.qa, self.va = int(self.jin.qposadr[0]), int(self.jin.dofadr[0])
        if self.hinge and m.jnt_limited[self.jin.id]:
            # MuJoCo would stop the multibody run at the limit while the reduced model turns freely
            lo, hi = (float(v) for v in m.jnt_range[self.jin.id])
            raise ParameterError(f"mechanism.input_joint = {p.input_joint!r}: the hinge has a range [{lo:.6g}, {hi:.6g}] "
                                 f"rad in {p.file} (a joint limit): mjbench drives the input through full turns and "
                                 f"the reduced model has no limit; remove range/limited from the input joint")
        if p.trace is not None:
            sites = [m.site(i).name for i in range(m.nsite)] + [m.body(i).name for i in range(1, m.nbody)]
            if p.trace not in sites:
                raise ParameterError(f"mechanism.trace = {p.trace!r}: no site or body of that name in {p.file} "
                                     f"(sites and bodies: {', '.join(n for n in sites if n) or 'none named'})")
        if m.neq == 0:
            raise GeometryError(f"mechanism.file = {p.file!r}: the model has no equality constraint, so the input "
                                f"joint {p.input_joint!r} is not in a closed loop (an open chain has as many "
                                f"degrees of freedom as joints)")
        self.data = mujoco.MjData(m)
        self._start()
        self._tabulate()

    # ------------------------------------------------------------------ model with our options
    def compile(self, options, armature=0.0):
        return self.build_spec(options, armature).compile()

    def build_spec(self, options=None, armature=0.0):
        import mujoco

        o = dict(options or {})
        spec = self.spec.copy()
        opt = set_solver_options(spec.option, o)
        if not self.p.contacts:
            opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
        if not self.p.keep_solref:
            h = opt.timestep
            solref, solimp = closure_solref(o, h)
            for eq in spec.equalities:
                eq.solref = solref
                eq.solimp = solimp
        g = spec.visual.global_
        g.offwidth, g.offheight = max(int(g.offwidth), 1920), max(int(g.offheight), 1080)
        j = spec.joint(self.p.input_joint)
        j.armature = float(j.armature) + float(armature)
        return spec

    # ------------------------------------------------------------------ constraint solves
    def _eq(self, qpos):
        """(equality residual, its Jacobian (ne, nv)) at qpos."""
        import mujoco

        m, d = self.model, self.data
        d.qpos[:] = qpos
        mujoco.mj_fwdPosition(m, d)
        ne = d.ne
        if ne == 0:
            return np.zeros(0), np.zeros((0, m.nv))
        Jc = np.asarray(d.efc_J).reshape(-1)[:ne * m.nv].reshape(ne, m.nv).copy()
        return d.efc_pos[:ne].copy(), Jc

    def project(self, qpos, q, tol=1e-13, maxit=60):
        """Damped Newton (Gauss-Newton with step halving) with the input held at q: the closest
        assembly to qpos.  Returns (qpos, residual)."""
        import mujoco

        m = self.model
        x = np.array(qpos, float)
        x[self.qa] = q
        others = np.array([i for i in range(m.nv) if i != self.va])
        r, Jc = self._eq(x)
        res = float(np.max(np.abs(r))) if len(r) else 0.0
        for _ in range(maxit):
            if res < tol:
                break
            dv = np.zeros(m.nv)
            dv[others] = np.linalg.lstsq(Jc[:, others], -r, rcond=None)[0]
            step, nrm = 1.0, float(np.linalg.norm(r))
            for _ in range(30):
                y = x.copy()
                mujoco.mj_integratePos(m, y, dv, step)
                y[self.qa] = q
                r2, J2 = self._eq(y)
                if np.linalg.norm(r2) < nrm or step < 1e-6:
                    break
                step *= 0.5
            x, r, Jc = y, r2, J2
            res = float(np.max(np.abs(r))) if len(r) else 0.0
        return x, res

    def velocity(self, qpos):
        """Velocity coefficients v (nv,) with v_in = 1, and the rank of the constraint Jacobian."""
        _, Jc = self._eq(qpos)
        m = self.model
        others = [i for i in range(m.nv) if i != self.va]
        v = np.zeros(m.nv)
        v[self.va] = 1.0
        v[others] = np.linalg.lstsq(Jc[:, others], -Jc[:, self.va], rcond=None)[0]
        return v, Jc

    def dynamics(self, qpos, v):
        """(J, E_p', E_p, D) at a configuration for velocity coefficients v."""
        import mujoco

        m, d = self.model, self.data
        d.qpos[:] = qpos
        d.qvel[:] = 0.0
        mujoco.mj_fwdPosition(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        J = float(v @ M @ v)
        mujoco.mj_fwdVelocity(m, d)
        dEp = float(v @ (d.qfrc_bias - d.qfrc_spring))
        mujoco.mj_energyPos(m, d)
        Ep = float(d.energy[0])
        d.qvel[:] = v
        mujoco.mj_fwdVelocity(m, d)
        D = float(-(v @ d.qfrc_damper))
        d.qvel[:] = 0.0
        return J, dEp, Ep, D

    def _start(self):
        """The stated pose: keyframe (or qpos0) projected on the constraints; mobility check."""
        p, m = self.p, self.model
        if p.keyframe is not None:
            try:
                key = m.keyframe(p.keyframe)
            except KeyError:
                raise ParameterError(f"mechanism.keyframe = {p.keyframe!r}: no keyframe of that name in {p.file}") from None
            q0pos = np.array(key.qpos, float)
        elif m.nkey > 0:
            q0pos = np.array(m.key_qpos[0], float)
        else:
            q0pos = np.array(m.qpos0, float)
        q0 = float(p.input_angle) if p.input_angle is not None else float(q0pos[self.qa])
        x, res = self.project(q0pos, q0)
        if not res < 1e-9:
            raise GeometryError(f"mechanism.file = {p.file!r}: the loops cannot be closed at input position "
                                f"{q0:.6g} from the stated pose (residual {res:.3g}); give a keyframe near an "
                                f"assembled pose")
        v, Jc = self.velocity(x)
        sv = np.linalg.svd(Jc, compute_uv=False) if Jc.size else np.zeros(0)
        rank = int(np.sum(sv > 1e-9 * max(sv[0] if len(sv) else 1.0, 1e-300)))
        dof = m.nv - rank
        if dof != 1:
            names = self._moving(Jc) if dof > 1 else []
            raise GeometryError(
                f"mechanism.file = {p.file!r}: the model has {dof} degrees of freedom at the stated pose "
                f"({m.nv} joint dofs − rank {rank} of the equality constraints)"
                + (f"; with {p.input_joint!r} held, joints {', '.join(names)} can still move" if names else
                   "; it is a rigid structure")
                + ": a single-input machine needs exactly 1")
        others = [i for i in range(m.nv) if i != self.va]
        sv2 = np.linalg.svd(Jc[:, others], compute_uv=False)
        if sv2[-1] < 1e-9 * sv2[0]:
            raise GeometryError(f"mechanism.file = {p.file!r}: the input joint {p.input_joint!r} does not drive the "
                                f"linkage at the stated pose (dead centre, or the input is not in the loop)")
        self.q0, self.x0 = q0, x

    def _moving(self, Jc):
        m = self.model
        others = [i for i in range(m.nv) if i != self.va]
        _, S, Vt = np.linalg.svd(Jc[:, others])
        rank = int(np.sum(S > 1e-9 * S[0]))
        null = Vt[rank:]
        mv = np.zeros(m.nv)
        mv[others] = np.abs(null).max(axis=0)
        names = []
        for j in range(m.njnt):
            adr = int(m.jnt_dofadr[j])
            if mv[adr] > 1e-6:
                names.append(m.joint(j).name or f"joint{j}")
        return names

    def _tabulate(self):
        p, m = self.p, self.model
        N = int(p.table_nodes)
        if self.hinge:
            lo, span = self.q0, TWO_PI
            qs = lo + span * np.arange(N) / N
            delta = 2e-3
        else:
            if not m.jnt_limited[self.jin.id]:
                raise ParameterError(f"mechanism.input_joint = {p.input_joint!r}: a slide input needs a range "
                                     f"(limited=\"true\" range=\"lo hi\") in the file: the reduced model covers it")
            lo, hi = (float(v) for v in m.jnt_range[self.jin.id])
            qs = np.linspace(lo, hi, N)
            delta = 1e-3 * (hi - lo)
        # march from the stated pose to every node (a slide: both ways from the node nearest to it)
        X = np.empty((len(qs), m.nq))

        def run(indices):
            x, qprev = self.x0.copy(), self.q0
            for i in indices:
                x = self._march(x, qprev, qs[i])
                X[i], qprev = x, qs[i]
            return x, qprev

        if self.hinge:
            x, prev_q = run(range(len(qs)))
        else:
            i0 = int(np.argmin(np.abs(qs - self.q0)))
            run(range(i0, len(qs)))
            run(range(i0 - 1, -1, -1))
        if self.hinge:
            xe = self._march(x, prev_q, self.q0 + TWO_PI)
            diff = xe - self.x0
            hadr = [int(m.jnt_qposadr[j]) for j in range(m.njnt) if m.jnt_type[j] == 3]
            w = np.zeros(m.nq)
            w[hadr] = np.round(diff[hadr] / TWO_PI)
            err = np.max(np.abs(diff - TWO_PI * w))
            if err > 1e-6:
                raise GeometryError(f"mechanism.file = {p.file!r}: after one input turn the model arrives in a different "
                                    f"assembly (gap {err:.3g}); the branch passes a branch point")
            self.w = w
        ch = np.empty((len(qs), 5))
        for i in range(len(qs)):
            ch[i, 0], ch[i, 2], ch[i, 3], ch[i, 4] = self.dynamics(X[i], self.velocity(X[i])[0])
        check = np.unique(np.linspace(0, len(qs) - 1, 16).astype(int))
        if self.hinge:
            # J' by spectral differentiation of the periodic J table (exact values at the nodes)
            N = len(qs)
            k = np.fft.rfftfreq(N, d=1.0 / N)
            Jh = np.fft.rfft(ch[:, 0])
            Jh *= 1j * k
            if N % 2 == 0:
                Jh[-1] = 0.0
            ch[:, 1] = np.fft.irfft(Jh, n=N)
            fd = np.array([self._fd_dJ(X[i], qs[i], delta) for i in check])
            err = np.max(np.abs(fd - ch[check, 1]))
            scheme = "spectral derivative of the periodic J table; checked against 4th-order central differences"
        else:
            for i in range(len(qs)):
                ch[i, 1] = self._fd_dJ(X[i], qs[i], delta)
            err = max(abs(self._fd_dJ(X[i], qs[i], delta) - self._fd_dJ(X[i], qs[i], 2 * delta)) / 15.0
                      for i in check)
            scheme = "4th-order central differences along the manifold (error: Richardson estimate)"
        self.X, self.qs, self.delta = X, qs, delta
        self.damped = bool(np.any(ch[:, 4] != 0.0))
        if self.hinge:
            Xp = X.copy()
            u = qs - self.q0
            Xp -= self.w[None, :] * u[:, None]
            self.table = PeriodicTable(self.q0, np.hstack([ch, Xp]))
        else:
            self.table = _Table(qs[0], qs[-1], np.hstack([ch, X]))
        sc = np.max(np.abs(ch[:, 1])) or 1.0
        self.table_info = {"nodes": len(qs), "dJ_scheme": scheme, "delta": delta,
                           "dJ_rel_error_estimate": float(err / sc)}

    def _fd_dJ(self, x, q, delta):
        """[8(J(q+δ) − J(q−δ)) − (J(q+2δ) − J(q−2δ))]/(12δ), J on the constraint manifold."""
        Jv = {}
        for k in (-2, -1, 1, 2):
            xk, _ = self.project(self._guess(x, q, q + k * delta), q + k * delta)
            Jv[k] = self.dynamics(xk, self.velocity(xk)[0])[0]
        return (8 * (Jv[1] - Jv[-1]) - (Jv[2] - Jv[-2])) / (12 * delta)

    def _guess(self, x, q_from, q_to):
        v = self.velocity(x)[0]
        import mujoco

        y = x.copy()
        mujoco.mj_integratePos(self.model, y, v * (q_to - q_from), 1.0)
        return y

    def _march(self, x, q_from, q_to, nsub=1):
        """Follow the branch from (x, q_from) to q_to (predictor-corrector, subdivided if needed)."""
        for _ in range(12):
            ok = True
            y, qa = x, q_from
            hstep = (q_to - q_from) / nsub
            for k in range(nsub):
                qb = q_from + (k + 1) * hstep
                y, res = self.project(self._guess(y, qa, qb), qb)
                if not res < 1e-11:
                    ok = False
                    break
                qa = qb
            if ok:
                return y
            nsub *= 2
        raise GeometryError(f"mechanism.file = {self.p.file!r}: the loops cannot be closed beyond input position "
                            f"{q_from:.6g} (towards {q_to:.6g}): dead centre or the loop cannot close there")

    def qpos_at(self, q):
        """Exact configuration at input position q (scalar): table guess + projection."""
        q = float(q)
        g = self.table(np.array([q]))[0, 5:].copy()
        if self.hinge:
            g += self.w * (q - self.q0)
        x, res = self.project(g, q)
        if not res < 1e-9:
            raise GeometryError(f"mechanism.file = {self.p.file!r}: no assembly found at input position {q:.6g}")
        return x


_CACHE: dict = {}


#: a spline table over a finite range (slide input): breakpoints xs (n), rows (n − 1, 4k) — cell
#: i's coefficients of (q − xs[i])³, ², ¹, ⁰ of channel 0, then 1, … —, the range, (n − 1)/(hi − lo),
#: n, whether channel 4 (viscous D) is non-zero
RangeTableP = namedtuple("RangeTableP", "xs rows lo hi inv_dx n damped")


@law
def range_channel(q, ch, T):
    """Channel ``ch`` of a :class:`_Table` at q (NaN outside its range: a slide beyond the file's
    range, or a diverged run)."""
    if not (q >= T.lo - 1e-12 and q <= T.hi + 1e-12):
        return math.nan
    i = int(math.floor((q - T.lo) * T.inv_dx))
    if i < 0:
        i = 0
    if i > T.n - 2:
        i = T.n - 2
    xs = T.xs
    if q < xs[i] and i > 0:
        i -= 1
    elif i < T.n - 2 and q >= xs[i + 1]:
        i += 1
    t = q - xs[i]
    b = 4 * ch
    R = T.rows
    return ((R[i, b] * t + R[i, b + 1]) * t + R[i, b + 2]) * t + R[i, b + 3]


@law
def range_table_model(q, qd, t, P):
    """The reduced model of a slide input from its table: (J, ½J', E_p', −D·q̇)."""
    J = range_channel(q, 0, P)
    H = 0.5 * range_channel(q, 1, P)
    E = range_channel(q, 2, P)
    if P.damped:
        return J, H, E, -range_channel(q, 4, P) * qd
    return J, H, E, 0.0


@register
class MjcfMechanism(Mechanism):
    """A MuJoCo model file with one driven joint; reduced model derived from MuJoCo (see module doc)."""

    type_name = "mjcf"
    Params = MjcfParams
    reduced_source = ("MuJoCo-derived: mass matrix and constraint Jacobian of the model file "
                      "(not an independent check of the multibody run)")

    def __init__(self, params: MjcfParams, source: str = ""):
        self.params = params
        path = resolve_path(params.file, source)
        with open(path, "rb") if os.path.isfile(path) else open(os.devnull, "rb") as f:
            digest = hashlib.sha1(f.read() + params.model_dump_json().encode()).hexdigest()
        mdl = _CACHE.get((path, digest))
        if mdl is None:
            mdl = _Model(params, path)
            if len(_CACHE) > 16:
                _CACHE.clear()
            _CACHE[(path, digest)] = mdl
        self._m = mdl
        self.name = os.path.splitext(os.path.basename(path))[0]
        self.input_joint = params.input_joint
        self.table_info = dict(mdl.table_info)
        t = mdl.table
        self._tab3, self._tab1, self._tab = t.scalar3, t.scalar, t
        self._damped = mdl.damped
        if not mdl.hinge:  # a slide input is not periodic: the reduced backends use our table directly
            self.reduced_period = None

    @classmethod
    def from_params(cls, p):
        return cls(p)

    @classmethod
    def resolve_paths(cls, table: dict, source: str) -> None:
        """Make ``file`` absolute (relative to the scenario file) before validation."""
        f = table.get("file")
        if isinstance(f, str) and f and not os.path.isabs(f):
            table["file"] = resolve_path(f, source)

    def reduced(self, q):
        if isinstance(q, float):
            return self._tab3(q)
        v = self._tab(q, [0, 1, 2])
        return v[..., 0], v[..., 1], v[..., 2]

    def potential_energy(self, q):
        if isinstance(q, float):
            return self._tab1(q, 3)
        return self._tab(q, [3])[..., 0]

    def model_form(self):
        """The reduced model as a law: a hinge input the periodic spline table (the default); a
        slide input this model's own spline over the slide range (:func:`range_table_model`;
        outside the range a NaN, i.e. a diverged run)."""
        if self._m.hinge:
            return super().model_form()

        P = self._tab.P._replace(damped=bool(self._damped))
        info = {"model": "table", "table_nodes": int(P.n), "table_range": [P.lo, P.hi]}
        return C.Form(range_table_model, P, flags={"table": info})

    def reduced_viscous(self, q):
        """D(q): the file's viscous joint and tendon damping reduced to the input."""
        return self._tab1(q, 4) if isinstance(q, float) else self._tab(q, [4])[..., 0]

    def external_torque(self, q, qd, t):
        """Viscous friction of the file's joints and tendons reduced to the input, −D(q)·q̇."""
        if not self._damped:
            return 0.0 * q
        D = self._tab1(q, 4) if isinstance(q, float) else self._tab(q, [4])[..., 0]
        return -D * qd

    def build_spec(self, armature: float = 0.0, options=None):
        return self._m.build_spec(options, armature)

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        return self._m.qpos_at(q0)

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        x = self._m.qpos_at(q0)
        return self._m.velocity(x)[0] * qd0

    def _positions(self, q):
        import mujoco

        mdl = self._m
        m, d = mdl.model, mdl.data
        qa = np.ravel(np.asarray(q, float))
        pts = {}
        for k, qq in enumerate(qa):
            g = mdl.table(np.array([qq]))[0, 5:].copy()
            if mdl.hinge:
                g += mdl.w * (qq - mdl.q0)
            d.qpos[:] = g
            mujoco.mj_kinematics(m, d)
            for b in range(1, m.nbody):
                pts.setdefault(m.body(b).name or f"body{b}", np.empty((len(qa), 2)))[k] = d.xpos[b, PLANE_INDEX]
            for s in range(m.nsite):
                pts.setdefault(m.site(s).name or f"site{s}", np.empty((len(qa), 2)))[k] = d.site_xpos[s, PLANE_INDEX]
        shape = np.shape(q)
        return {n: (v[:, 0].reshape(shape), v[:, 1].reshape(shape)) if shape else (float(v[0, 0]), float(v[0, 1]))
                for n, v in pts.items()}

    def points(self, q):
        return self._positions(q)

    def trace_point(self, q):
        if not self.params.trace:
            return None
        pts = self._positions(q)
        if self.params.trace not in pts:
            raise ParameterError(f"mechanism.trace = {self.params.trace!r}: no site or body of that name")
        return pts[self.params.trace]

    def joint_rates(self, q):
        """{joint name: dq_joint/dq_in} over input positions q (hinge/slide joints of the file)."""
        mdl = self._m
        m = mdl.model
        out = {}
        for k, qq in enumerate(np.ravel(np.asarray(q, float))):
            v = mdl.velocity(mdl.qpos_at(qq))[0]
            for j in range(m.njnt):
                if m.jnt_type[j] in (2, 3):
                    out.setdefault(m.joint(j).name or f"joint{j}", []).append(v[int(m.jnt_dofadr[j])])
        return {k: np.array(v) for k, v in out.items()}

    def describe(self) -> dict:
        return {**self.params.to_dict(), "path": self._m.path, "reduced_source": self.reduced_source}

    def input_positions(self, n: int):
        """A hinge: n angles over one turn from the stated pose; a slide: n positions over its range."""
        tab = self._tab
        if not self._m.hinge:
            return np.linspace(tab.lo, tab.hi, n), "m"
        return float(tab.q0) + 2.0 * np.pi * np.arange(n) / n, "rad"

    def kinematics(self, q) -> dict:
        """Velocity ratios of the file's joints (constraint Jacobian null space) and their limit
        positions; a MuJoCo model has no link lines, so no transmission angles or toggles."""

        ratios = {k: v for k, v in self.joint_rates(q).items() if k != self.input_joint}
        lim = {k: [float(x) for x in _roots(q, v)] for k, v in ratios.items()} if self._m.hinge else {}
        why = "an MJCF model has no link lines (bodies and equality constraints only)"
        unavailable = {"transmission_angles": why, "toggles": why}
        if not self._m.hinge:
            unavailable["limit_positions"] = "a slide input is not periodic: its range ends are the file's limits"
        return {"source": "MuJoCo model (constraint Jacobian null space); no link lines: no transmission angles",
                "ratios": ratios, "ratio_units": {}, "transmission": {}, "toggles": {}, "limit_positions": lim,
                "unavailable": unavailable}
