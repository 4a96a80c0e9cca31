"""The mechanical drive-train elements of a machine with several motors (``[drive.gear]``,
``[drive.friction]`` per axis, ``[drive.friction.joints]``; docs/linkages.md §8.2), in both models of
the machine.

**Compliant gear** (backlash β, mesh stiffness k, contact damping c on an axis; the one-motor law
of :mod:`.gear`, axis by axis): the axis's motor becomes a coordinate of its own, θ_m = q + δ at
the output, carrying J_mo = J_eq − J_b and the drive's viscous z²λ; the input joint keeps J_b; the
mesh torque T_g(δ, δ̇) (:func:`.gear.mesh_torque_law`) couples them.  Default k: the motor
inertia against the lighter output side resonates at ``mesh_frequency`` — the output side being
the axis's smallest inertia with the other axes free, min 1/[(M̄ + diag J)⁻¹]ₖₖ over the input
ranges (J: J_b on a compliant axis, J_eq on a rigid one).

* **Multibody**: per compliant axis a hinge ``drive_motor_<joint>`` on a massless rotor carrying
  J_mo (its armature) and z²λ, and a fixed tendon ``gear_mesh_<joint>`` = θ_m − q with a
  dead-band spring (``springlength = [−β/2, β/2]``, ``stiffness = k``); the drive's torque acts on
  the motor hinge; the contact damping is the tendon's ``damping``, switched on while in contact
  by the load law :func:`axes_load` (state at the step's start; always on if β = 0).
* **Reduced**: the n-input plant integrates (q, q̇, δ, δ̇) by RK4
  (:func:`mjbench.backends.reduced_multi.rk4_axes_gear`, the parameters :class:`AxesGearP`).

**Dry friction on a motor shaft** F(v) = F_C + (F_S − F_C)·exp(−(v/v_S)²) (the one-motor law,
:func:`.gear.friction_level`; F_S = F_C without a Stribeck drop): MuJoCo ``frictionloss`` z·F on the
joint the axis's torque acts on (the input joint, or the motor hinge behind a compliant gear),
``solref_friction = (2h, 1)``, its level set at every step to z·F(|z·v|) at the step's start when
F_S > F_C (:func:`axes_load`) — as for one motor (docs/drivetrain.md §4).  Reduced:
−z·F(|z·v|)·tanh(z·v/v_ε) added to the axis's generalised force — a rigid axis's through the
mechanism's model law at every evaluation (:func:`friction_two`, :func:`friction_multi`), v the
input's speed and v_ε = 2h·F_S·z²/J_k with J_k the axis's smallest inertia as above plus its J_eq
(the one-motor stability bound of the regularisation's slope, per axis); a compliant axis's on its
motor, v = θ̇_m, J_k = J_mo.

**Friction on the mechanism's joints** (``[drive.friction.joints]``, a hinge of the linkage's tree; the
joints of every axis's table together — a joint's friction belongs to the mechanism): MuJoCo
``frictionloss`` F_S on the joint (its level edited per step with a Stribeck drop; a motor's and a
joint's law on one dof add up) and ``damping`` += viscous.  Reduced: joint j's rate u = r_j(q)·q̇,
r_j = ∂θ_j/∂q — tabulated over the two-input model's grid from the position solve (a bicubic table
of 2 channels per joint, :func:`joint_friction_two`), or read from each evaluation's solve when the
model is solved (``reduced_model = 'solve'``, any n: :func:`joint_friction_solved`) —, the
generalised force −r_j·(F(|u|)·tanh(u/v_ε) + visc·u), v_ε = 2h·m·F_S·max|r_j|²/J_min (m joints, J_min
the smallest eigenvalue of M̄ + diag J over the grid).  A slide or a loop-closing joint: one line.
"""
from __future__ import annotations

import copy
import math
from collections import namedtuple

import numpy as np

from .. import compiled as C
from ..errors import ParameterError
from ..mechanisms.linkage.multi import grid2_eval
from ..mechanisms.linkage.multi_solve import solve_joint_rate
from .gear import TERM_COLUMNS, _law, check_mesh, friction_level, friction_term, no_load

#: the friction of every axis (T: (n, TERM_COLUMNS) — one term, a row, per axis) and the mechanism's
#: own model law's parameters
AxesFrictionP = namedtuple("AxesFrictionP", "T inner")
#: friction on the mechanism's joints: rows (F_C, F_S, v_S, v_ε, viscous) one per joint, the joints'
#: speed-ratio table (a 2-input grid table's parameters, channels r_j0, r_j1 per joint), the offset of
#: its channels after the inner model's scratch, the inner model law's parameters
JointFrictionP = namedtuple("JointFrictionP", "T R o inner")
#: friction on the mechanism's joints of a model solved at every evaluation: rows as
#: :class:`JointFrictionP`'s, each hinge's bodies (i, j; −1: the ground), the solve's parameters, the
#: inner model law's parameters
JointSolvedP = namedtuple("JointSolvedP", "T bi bj solve inner")
#: the axes' compliant gears (arrays n, one entry per axis): whether the axis's gear is compliant
#: (int), mesh stiffness k [N·m/rad], contact damping c [N·m·s/rad], half the play β/2 [rad] (all at
#: the output), the crank-side inertia J_b and the motor's J_mo = J_eq − J_b [kg·m²]; the motors'
#: friction terms (n rows, TERM_COLUMNS, on the motor coordinate; ``friction``: whether any); the
#: compliant axes' indices (the recorded deflections' order)
AxesGearP = namedtuple("AxesGearP", "comp k c hb Jb Jm T friction axes")
#: the per-step model edits of a machine with several motors: the tendon damping switched per step
#: (arrays over the axes with play and damping: the motor's and the input's qpos, the tendon, c, β/2),
#: the friction level of each dof with a Stribeck drop (its dof, its laws sptr[i]..sptr[i+1] as rows
#: F_C, F_S, v_S, g_F, g_v: every law on that dof); qpos, qvel, tendon_damping and dof_frictionloss
#: live; the inner loads' parameters
AxesLoadP = namedtuple("AxesLoadP", "qpos qvel qm qc tendon c hb tdamp sdof sptr sterms floss inner")
MOTOR_JOINT = "drive_motor_{}"       #: an axis's motor hinge (its input joint's name filled in)
MESH_TENDON = "gear_mesh_{}"         #: an axis's mesh tendon θ_m − q
DEFLECTION = "{}:gear_deflection"    #: an axis's internal coordinate δ = θ_m − q (its label filled in: the
#: recorded column ``A:gear_deflection_rad`` is the one-axis ``gear_deflection_rad`` of ``Trajectory.axis("A")``)
#: configurations sampled for each axis's smallest inertia
INERTIA_SAMPLES = 1024


@C.law
def friction_two(MODEL, q0, q1, v0, v1, t, P, W, ic):
    """The two-input model law MODEL with each axis's motor friction in its generalised force (it
    lowers τ − bias: the bias grows by −friction)."""
    m00, m01, m11, b0, b1 = MODEL(q0, q1, v0, v1, t, P.inner, W, ic)
    return m00, m01, m11, b0 - friction_term(0.0, v0, P.T, 0), b1 - friction_term(0.0, v1, P.T, 1)


@C.law
def friction_multi(MODEL, S, iy, t, P, W, iw):
    """The n-input model law MODEL (M̄ and the bias into W[iw:]) with each axis's motor friction."""
    MODEL(S, iy, t, P.inner, W, iw)
    n = P.T.shape[0]
    for k in range(n):
        W[iw + n * n + k] -= friction_term(0.0, S[iy + n + k], P.T, k)


@C.law
def joint_force(u, T, m):
    """The friction force of joint m (row m of T: F_C, F_S, v_S, v_ε, viscous) at its rate u: the
    regularised dry friction F(|u|)·tanh(u/v_ε) plus the viscous visc·u (opposing u)."""
    return friction_level(abs(u), T[m, 0], T[m, 1], T[m, 2]) * math.tanh(u / T[m, 3]) + T[m, 4] * u


@C.law
def joint_friction_two(MODEL, q0, q1, v0, v1, t, P, W, ic):
    """The two-input model law MODEL with the friction of the mechanism's joints in its bias: joint j's
    rate u = r_j·q̇ (r_j = ∂θ_j/∂q from the speed-ratio table P.R, its channels at W[ic + P.o:]), its
    force f = F(|u|)·tanh(u/v_ε) + visc·u, the generalised force −r_j·f (the bias grows by r_j·f)."""
    m00, m01, m11, b0, b1 = MODEL(q0, q1, v0, v1, t, P.inner, W, ic)
    o = ic + P.o
    grid2_eval(q0, q1, P.R, W, o)
    T = P.T
    for i in range(T.shape[0]):
        r0 = W[o + 2 * i]
        r1 = W[o + 2 * i + 1]
        u = r0 * v0 + r1 * v1
        f = joint_force(u, T, i)
        b0 += r0 * f
        b1 += r1 * f
    return m00, m01, m11, b0, b1


@C.law
def solved_joint_force(P, W, ic, m):
    """Joint m's friction force (:func:`joint_force`) at the rate the solve's last evaluation (scratch at
    W[ic:]) gives it, and its bodies (f, i, j)."""
    i = P.bi[m]
    j = P.bj[m]
    return joint_force(solve_joint_rate(P.solve, W, ic, i, j, -1), P.T, m), i, j


@C.law
def joint_friction_solved(MODEL, S, iy, t, P, W, iw):
    """:func:`joint_friction_two` for a model solved at every evaluation (n inputs, the n-input
    interface): the hinges' rates and speed ratios read from the solve's last evaluation
    (:func:`..mechanisms.linkage.multi_solve.solve_joint_rate`; P.solve its parameters)."""
    MODEL(S, iy, t, P.inner, W, iw)
    n = P.solve.n
    ic = iw + n * n + n
    for m in range(P.T.shape[0]):
        f, i, j = solved_joint_force(P, W, ic, m)
        for a in range(n):
            W[iw + n * n + a] += f * solve_joint_rate(P.solve, W, ic, i, j, a)


@C.law
def joint_friction_solved_two(MODEL, q0, q1, v0, v1, t, P, W, ic):
    """:func:`joint_friction_solved` with the two-input interface (its solve's scratch at W[ic:])."""
    m00, m01, m11, b0, b1 = MODEL(q0, q1, v0, v1, t, P.inner, W, ic)
    for m in range(P.T.shape[0]):
        f, i, j = solved_joint_force(P, W, ic, m)
        b0 += f * solve_joint_rate(P.solve, W, ic, i, j, 0)
        b1 += f * solve_joint_rate(P.solve, W, ic, i, j, 1)
    return m00, m01, m11, b0, b1


@C.law
def axes_load(INNER, t, P):
    """The MuJoCo loads of a machine with several motors' drive trains, before each step: the inner
    mechanism's loads, then the per-step model edits from the state at the step's start (the one-motor
    edits of :func:`.gear.driven_load`, per axis) — each mesh's contact damping on while in contact
    (|δ| > β/2), each Stribeck axis's friction level g_F·F(|g_v·v|) on its dof."""
    INNER(t, P.inner)
    for i in range(len(P.tendon)):
        d = P.qpos[P.qm[i]] - P.qpos[P.qc[i]]
        P.tdamp[P.tendon[i]] = P.c[i] if abs(d) > P.hb[i] else 0.0
    W = P.sterms
    for i in range(len(P.sdof)):
        dof = P.sdof[i]
        v = P.qvel[dof]
        F = 0.0
        for r in range(P.sptr[i], P.sptr[i + 1]):
            F += W[r, 3] * friction_level(abs(W[r, 4] * v), W[r, 0], W[r, 1], W[r, 2])
        P.floss[dof] = F


class AxesTrainMixin:
    """The mechanism of a machine with several motors with its axes' mechanical drive-train elements
    (module docstring): a copy of the mechanism whose class also derives from this one
    (:func:`with_axes_train`)."""

    #: per axis, its :class:`Axis`
    _axes: tuple = ()
    #: the mechanism's joints with friction: {name: (F_C, F_S, v_S, viscous)}
    _joints: dict = {}
    _h = 1e-4

    def set_step(self, h):
        """The co-simulation step the friction's regularisation is sized for (and the meshes checked
        against, :meth:`_check_mesh`)."""
        self._h = float(h)
        self._check_mesh(self._h)

    def _check_mesh(self, h: float) -> None:
        """ParameterError naming the axis when a mesh resonates too fast for RK4 at step h
        (:func:`.gear.check_mesh`; the output side: the axis's lightest, :meth:`_axis_inertia`)."""
        mesh = self._mesh()
        J = self._axis_inertia() if self._compliant else None
        for k in self._compliant:
            ax = self._axes[k]
            check_mesh(f"drives.{ax.label}", mesh[k][0], ax.J_eq - ax.J_b, float(J[k]), h)

    # ------------------------------------------------------------------ the axes
    @property
    def _compliant(self) -> list:
        return [k for k, a in enumerate(self._axes) if a.gear is not None]

    @property
    def internal(self) -> tuple:
        """The compliant axes' deflections δ = θ_m − q (recorded as ``<axis>:gear_deflection_rad``)."""
        return tuple(DEFLECTION.format(self._axes[k].label) for k in self._compliant)

    @property
    def drive_joints(self) -> tuple:
        return tuple(MOTOR_JOINT.format(a.joint) if a.gear is not None else a.joint for a in self._axes)

    def _side(self) -> np.ndarray:
        """The inertia each input joint carries besides the mechanism's: J_b behind a compliant gear,
        J_eq behind a rigid one."""
        return np.array([a.J_b if a.gear is not None else a.J_eq for a in self._axes], dtype=float)

    def _axis_inertia(self) -> np.ndarray:
        """Each axis's smallest inertia with the other axes free, 1/[(M̄ + diag J)⁻¹]ₖₖ (J: :meth:`_side`),
        over the coarse grid of the input ranges (at most :data:`INERTIA_SAMPLES` configurations)."""
        got = self.__dict__.get("_inertia")
        if got is not None:
            return got
        nodes = getattr(getattr(self, "c", None), "coarse_nodes", None)  # (a generic linkage's grid)
        if nodes is None:
            Q = np.array([self.stated_inputs], dtype=float)
        else:
            Q = np.stack(np.meshgrid(*nodes, indexing="ij"), axis=-1).reshape(-1, len(nodes))
            Q = Q[:: max(1, len(Q) // INERTIA_SAMPLES)]
        M = self.reduced_table(Q)[0] + np.diag(self._side())[None]  # (what the simulation integrates)
        out = 1.0 / np.max(np.diagonal(np.linalg.inv(M), axis1=1, axis2=2), axis=0)
        self._inertia = out
        return out

    def _mesh(self) -> list:
        """Per axis (k, c, β) of its compliant gear (module docstring; None on a rigid axis)."""
        got = self.__dict__.get("_mesh_kc")
        if got is not None:
            return got
        J = self._axis_inertia() if self._compliant else None
        out = []
        for k, a in enumerate(self._axes):
            g = a.gear
            if g is None:
                out.append(None)
                continue
            jm, jc = a.J_eq - a.J_b, float(J[k])
            jr = jm * jc / (jm + jc)
            w = 2.0 * math.pi * float(g.mesh_frequency)
            kk = float(g.stiffness) if g.stiffness is not None else jr * w * w
            cc = float(g.damping) if g.damping is not None else 2.0 * float(g.damping_ratio) * math.sqrt(kk * jr)
            out.append((kk, cc, float(g.backlash)))
        self._mesh_kc = out
        return out

    def _terms(self, motor: bool) -> np.ndarray:
        """The friction rows (TERM_COLUMNS), one per axis: of the rigid axes (``motor`` False: in the
        model law) or of the compliant axes' motors (``motor`` True); zero rows elsewhere."""
        rows = []
        J = None
        for k, a in enumerate(self._axes):
            z = a.z
            if a.fs > 0 and (a.gear is not None) == motor:
                if motor:
                    jk = a.J_eq - a.J_b
                else:
                    J = self._axis_inertia() if J is None else J
                    jk = float(J[k])
                veps = 2.0 * self._h * a.fs * z * z / jk  # (the slope at the breakaway level: the one-motor v_ε)
                rows.append([a.fc, a.fs, a.vs, z, z, max(veps, 1e-12), 0.0])
            else:
                rows.append([0.0, 0.0, math.inf, z, z, 1.0, 0.0])
        return np.ascontiguousarray(np.array(rows, dtype=float).reshape(len(self._axes), len(TERM_COLUMNS)))

    # ------------------------------------------------------------------ reduced model
    def model_form(self):
        out = super().model_form()
        if any(a.fs > 0 and a.gear is None for a in self._axes):
            law = friction_two if self.n_inputs == 2 else friction_multi
            out = C.Form(law, AxesFrictionP(self._terms(False), out.P), fn_args=(out,), flags=dict(out.flags))
        if self._joints:
            T, tab = self._joint_terms()
            flags = dict(out.flags)
            if tab is None:  # the model solved at every evaluation: V read from its scratch
                ij = np.array([self.hinge_bodies(nm) for nm in self._joints], dtype=np.int64).reshape(-1, 2)
                law = joint_friction_solved_two if self.n_inputs == 2 else joint_friction_solved
                return C.Form(law, JointSolvedP(T, np.ascontiguousarray(ij[:, 0]), np.ascontiguousarray(ij[:, 1]),
                                                self.c.solve_P, out.P), fn_args=(out,), flags=flags)
            o = int(flags.get("channels", 0))
            flags["channels"] = o + tab.scratch
            out = C.Form(joint_friction_two, JointFrictionP(T, tab.P, o, out.P), fn_args=(out,), flags=flags)
        return out

    def _joint_terms(self):
        """(the rows of :class:`JointFrictionP`, the speed-ratio table or None) of the joints with friction
        (:meth:`~mjbench.mechanisms.linkage.MultiLinkage.hinge_rates`: r_j = ∂θ_j/∂q over the model's
        grid), v_ε = 2h·m·F_S·max(Σ_a|r_ja|)²/J_min (m joints, J_min the smallest eigenvalue of M̄ + diag J
        over the grid: the one-motor bound, each joint's slope on the stiffest direction)."""
        key = ("_jf", self._h)
        got = self.__dict__.get("_jf")
        if got is not None and got[0] == key:
            return got[1], got[2]
        rtab, rmax, Q = self.hinge_rates(tuple(self._joints))
        M = self.reduced_table(Q[:: max(1, len(Q) // INERTIA_SAMPLES)])[0] + np.diag(self._side())[None]
        jmin = float(np.min(np.linalg.eigvalsh(M)))
        m = len(self._joints)
        rows = []
        for k, (name, (fc, fs, vs, visc)) in enumerate(self._joints.items()):
            veps = 2.0 * self._h * m * fs * rmax[k] * rmax[k] / jmin if fs > 0 else 1.0
            rows.append([fc, fs, vs, max(veps, 1e-12), visc])
        T = np.ascontiguousarray(np.array(rows, dtype=float).reshape(-1, 5))
        self._jf = (key, T, rtab)
        return T, rtab


    def axes_gear(self):
        comp = self._compliant
        if not comp:
            return None
        mesh = [m or (0.0, 0.0, 0.0) for m in self._mesh()]
        T = self._terms(True)
        return AxesGearP(np.array([int(a.gear is not None) for a in self._axes], dtype=np.int64),
                         np.array([m[0] for m in mesh]), np.array([m[1] for m in mesh]),
                         np.array([0.5 * m[2] for m in mesh]),
                         np.array([a.J_b for a in self._axes], dtype=float),
                         np.array([a.J_eq - a.J_b if a.gear is not None else 1.0 for a in self._axes], dtype=float),
                         T, bool(np.any(T[:, 0] > 0)), np.array(comp, dtype=np.int64))

    def mechanism_alone(self):
        out = copy.copy(self)
        out.__class__ = self._alone
        return out

    # ------------------------------------------------------------------ multibody model
    def build_spec(self, armature=0.0, options=None):
        import mujoco

        spec = super().build_spec(armature, options)
        h = float(dict(options or {}).get("timestep", 1e-4))
        self._check_mesh(h)
        arm = np.broadcast_to(np.asarray(armature, dtype=float), (len(self._axes),))
        mesh = self._mesh()
        for k, a in enumerate(self._axes):
            joint, jb, g = a.joint, a.J_b, a.gear
            jf = spec.joint(joint)
            if g is not None:  # the motor on a hinge of its own, the input joint keeps J_b (as for one motor)
                kk, cc, beta = mesh[k]
                jm = float(arm[k]) - jb
                jf.armature = float(jf.armature) - jm
                rotor = spec.worldbody.add_body(name=f"drive_motor_rotor_{joint}", pos=[0.0, 0.0, 0.0])
                rotor.mass = 1e-9
                rotor.ipos = [0.0, 0.0, 0.0]
                rotor.inertia = [1e-12, 1e-12, 1e-12]
                rotor.explicitinertial = True
                jf = rotor.add_joint(name=MOTOR_JOINT.format(joint), type=mujoco.mjtJoint.mjJNT_HINGE,
                                     axis=[float(a) for a in spec.joint(joint).axis])
                jf.armature = jm
                t = spec.add_tendon(name=MESH_TENDON.format(joint))
                t.wrap_joint(MOTOR_JOINT.format(joint), 1.0)
                t.wrap_joint(joint, -1.0)
                t.stiffness = [kk, 0.0, 0.0]
                t.springlength = [-0.5 * beta, 0.5 * beta]
                t.damping = [cc if beta == 0.0 else 0.0, 0.0, 0.0]
            if a.fs > 0:  # (at rest: the breakaway level; a Stribeck axis's is edited every step, load_form)
                jf.frictionloss = float(a.z * a.fs)
                jf.solref_friction = [2.0 * h, 1.0]
        for name, (fc, fs, vs, visc) in self._joints.items():  # the mechanism's joints (tree hinges)
            j = spec.joint(name)
            if fs > 0:
                j.frictionloss = float(j.frictionloss) + fs
                j.solref_friction = [2.0 * h, 1.0]
            if visc > 0:
                j.damping = [float(j.damping[0]) + visc, 0.0, 0.0]
        return spec

    def initial_qpos(self, model, q0, x0=None) -> np.ndarray:
        qpos = super().initial_qpos(model, q0, None)
        q = np.broadcast_to(np.asarray(q0, dtype=float), (len(self._axes),))
        for k in self._compliant:
            qpos[model.joint(MOTOR_JOINT.format(self._axes[k].joint)).qposadr[0]] = q[k]
        return qpos

    def initial_qvel(self, model, q0, qd0, x0=None, xd0=None) -> np.ndarray:
        qvel = super().initial_qvel(model, q0, qd0, None, None)
        qd = np.broadcast_to(np.asarray(qd0, dtype=float), (len(self._axes),))
        for k in self._compliant:
            qvel[model.joint(MOTOR_JOINT.format(self._axes[k].joint)).dofadr[0]] = qd[k]
        return qvel

    def _rows(self, model) -> list:
        """Per compliant axis (motor qpos, input qpos, motor dof, input dof, tendon id)."""
        out = []
        for k in self._compliant:
            joint = self._axes[k].joint
            jm, jc = model.joint(MOTOR_JOINT.format(joint)), model.joint(joint)
            out.append((int(jm.qposadr[0]), int(jc.qposadr[0]), int(jm.dofadr[0]), int(jc.dofadr[0]),
                        int(model.tendon(MESH_TENDON.format(joint)).id)))
        return out

    def motor_indices(self, model) -> tuple:
        rows = iter(self._rows(model))
        return tuple((r[0], r[2]) for r in (next(rows) if a.gear is not None else (-1, -1, -1, -1, -1)
                                           for a in self._axes))

    def internal_state(self, model, qpos, qvel):
        rows = self._rows(model)
        return (tuple(qpos[..., a] - qpos[..., b] for a, b, _, _, _ in rows),
                tuple(qvel[..., c] - qvel[..., d] for _, _, c, d, _ in rows))

    def internal_index(self, model):
        """Each compliant axis's deflection δ = θ_m − q as a row (qpos a, qpos b, dof a, dof b, 1)."""
        return np.array([[a, b, c, d, 1.0] for a, b, c, d, _ in self._rows(model)], dtype=float).reshape(-1, 5)

    def _toggles(self) -> list:
        """The compliant axes whose mesh damping is switched per step (play and damping)."""
        mesh = self._mesh()
        return [k for k in self._compliant if mesh[k][2] > 0 and mesh[k][1] > 0]

    def _stribeck(self) -> list:
        """The axes whose motor friction has a Stribeck drop (its level edited per step in MuJoCo)."""
        return [k for k, a in enumerate(self._axes) if a.fs > a.fc]

    def _stribeck_joints(self) -> list:
        """The mechanism's joints whose friction has a Stribeck drop."""
        return [nm for nm, (fc, fs, _, _) in self._joints.items() if fs > fc]

    def _stribeck_dofs(self, model):
        """(dofs, pointers, rows F_C, F_S, v_S, g_F, g_v) of every dof carrying a law with a Stribeck drop:
        each such dof with all its laws (a motor's and a joint's on one input joint add up)."""
        laws: dict = {}
        for a, joint in zip(self._axes, self.drive_joints):
            if a.fs > 0:
                laws.setdefault(int(model.joint(joint).dofadr[0]), []).append((a.fc, a.fs, a.vs, a.z, a.z))
        for name, (fc, fs, vs, _) in self._joints.items():
            if fs > 0:
                laws.setdefault(int(model.joint(name).dofadr[0]), []).append((fc, fs, vs, 1.0, 1.0))
        sdof, sptr, rows = [], [0], []
        for dof, lw in laws.items():
            if any(r[1] > r[0] for r in lw):
                sdof.append(dof)
                rows += lw
                sptr.append(len(rows))
        return (np.array(sdof, dtype=np.int64), np.array(sptr, dtype=np.int64),
                np.array(rows, dtype=float).reshape(-1, 5))

    def has_multibody_load(self) -> bool:
        return bool(self._toggles() or self._stribeck() or self._stribeck_joints()) or super().has_multibody_load()

    def load_form(self, model, data):
        """The per-step model edits (:func:`axes_load`) around the inner mechanism's loads, through live
        views of ``model.tendon_damping`` and ``model.dof_frictionloss``."""
        if not self.has_multibody_load():
            return None
        inner = super().load_form(model, data) if super().has_multibody_load() else C.Form(no_load)
        tog = self._toggles()
        rows = dict(zip(self._compliant, self._rows(model)))
        mesh = self._mesh()
        sdof, sptr, sterms = self._stribeck_dofs(model)
        P = AxesLoadP(data.qpos, data.qvel, np.array([rows[k][0] for k in tog], dtype=np.int64),
                      np.array([rows[k][1] for k in tog], dtype=np.int64),
                      np.array([rows[k][4] for k in tog], dtype=np.int64),
                      np.array([mesh[k][1] for k in tog], dtype=float),
                      np.array([0.5 * mesh[k][2] for k in tog], dtype=float), model.tendon_damping,
                      sdof, sptr, sterms,
                      model.dof_frictionloss, inner.P)
        return C.Form(axes_load, P, fn_args=(inner,), flags=dict(inner.flags))

    def describe(self) -> dict:
        d = dict(super().describe())
        mesh = self._mesh()
        edits = set(self._toggles()) | set(self._stribeck())
        dt = {}
        for k, a in enumerate(self._axes):
            e = {}
            if a.fs > 0:
                e["friction"] = {"coulomb_Nm": a.fc, "breakaway_Nm": a.fs,
                                 "stribeck_speed_rad_s": a.vs if math.isfinite(a.vs) else None, "z": a.z}
            if a.gear is not None:
                e["gear"] = {**a.gear.describe(), "stiffness_used_Nm_rad": mesh[k][0],
                             "damping_used_Nms_rad": mesh[k][1]}
            if k in edits:
                e["instance"] = id(self)  # per-step model edits: one compiled model per simulation in a batch
            if e:
                dt[a.label] = e
        if self._joints:
            dt["joints"] = {nm: {"coulomb_Nm": fc, "breakaway_Nm": fs, "stribeck_speed_rad_s": vs if math.isfinite(vs)
                                 else None, "viscous_Nms_rad": visc} for nm, (fc, fs, vs, visc) in self._joints.items()}
            if self._stribeck_joints():
                dt["joints"]["instance"] = id(self)
        d["drivetrain"] = dt
        return d


#: one axis of a machine with several motors: its label and input joint, gear ratio z, the motor's
#: friction F_C, F_S [N·m at the motor shaft], v_S [rad/s of the motor] (v_S = inf: no Stribeck drop),
#: the drive's J_eq and crank-side J_b [kg·m²], its compliant gear (:class:`.gear.Gear`) or None
Axis = namedtuple("Axis", "label joint z fc fs vs J_eq J_b gear")
_CLASSES: dict = {}


def with_axes_train(mech, drives, labels):
    """``mech`` (several inputs) with its axes' compliant gears and motor friction, or ``mech`` itself
    when no axis has any; ParameterError naming the axis for what stays one-axis (module docstring)."""
    axes = []
    joints: dict = {}
    for lab, joint, d in zip(labels, mech.input_joints, drives):
        tr = getattr(d, "train", None)
        fr = tr.friction if tr is not None else None
        gear = tr.gear if (tr is not None and tr.compliant) else None
        for name, law in (fr.joints.items() if fr is not None else ()):
            got = (*_law(law), float(law.get("viscous", 0.0) or 0.0))
            if joints.setdefault(name, got) != got:
                raise ParameterError(f"drives.{lab}.friction.joints.{name}: differs from another axis's; a joint's "
                                     f"friction belongs to the mechanism: give it once ([drive.friction.joints])")
        if gear is not None and not float(d.J_eq) - float(d.J_b) > 0:  # (a DC motor: trains are its own)
            raise ParameterError(f"drives.{lab}: a compliant gear (backlash or stiffness) needs a motor inertia "
                                 f"J_m + J_a > 0 (the motor becomes its own coordinate)")
        fc, fs, vs = _law({"coulomb": fr.coulomb, "breakaway": fr.breakaway, "stribeck_speed": fr.stribeck_speed}) \
            if fr is not None else (0.0, 0.0, math.inf)
        axes.append(Axis(lab, joint, float(d.z), fc, fs, vs, float(d.J_eq),
                         float(d.J_b) if gear is not None else 0.0, gear))
    joints = {nm: law for nm, law in joints.items() if law[1] > 0 or law[3] > 0}
    for name in joints:
        mech.check_friction_joint(name)
    if not joints and not any(a.fs > 0 or a.gear is not None for a in axes):
        return mech
    base = type(mech)
    cls = _CLASSES.get(base)
    if cls is None:
        cls = _CLASSES[base] = type(f"{base.__name__}WithAxesTrain", (AxesTrainMixin, base), {"_alone": base})
    out = copy.copy(mech)
    out.__class__ = cls
    out._axes = tuple(axes)
    out._joints = joints
    for key in ("_inertia", "_mesh_kc", "_jf"):
        out.__dict__.pop(key, None)
    return out


__all__ = ["AxesFrictionP", "AxesGearP", "AxesLoadP", "Axis", "JointFrictionP", "JointSolvedP", "friction_two",
           "friction_multi", "joint_friction_two", "joint_friction_solved", "joint_friction_solved_two", "axes_load",
           "with_axes_train", "AxesTrainMixin"]
