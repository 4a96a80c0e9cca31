"""Gearbox (backlash, mesh stiffness, efficiency) and dry friction, in both backends.

**Compliant gear** (``backlash > 0`` or a ``stiffness``): the motor is its own coordinate θ_m
(expressed at the output, θ_m = φ/z, so the drive's reflected inertia and torque keep their
units), coupled to the crank α through the mesh deflection δ = θ_m − α:

    T_g = k·(δ − sgn δ·β/2) + c·δ̇   for |δ| > β/2 (contact),   T_g = 0 inside the play

on the crank (+T_g) and the motor (−T_g).  β: total play at the output; k: mesh stiffness at the
output (default: the motor inertia against the lighter output side resonates at
``mesh_frequency``, 1 kHz); c: contact damping (default from ``damping_ratio`` 0.1 of that
mode).  Multibody: a hinge ``drive_motor`` carrying the motor inertia (J_m + J_a)·z² and z²λ, and
a MuJoCo fixed tendon L = θ_m − α with a **dead-band spring** (``springlength = [−β/2, β/2]``,
``stiffness = k``); the contact damping is the tendon's ``damping``, switched on while in contact
(state at the start of the step; always on if β = 0).  In a batch the per-step edits reach each
simulation's own model through the single-run ``multibody_load`` (``describe()`` makes the models
distinct, so the batch calls it per simulation).  Reduced model: the same law in the
right-hand side (the internal coordinate ``gear_deflection``), contact evaluated at every RK4
stage.  The crank keeps J_b.

**Efficiency** (rigid or compliant gear): the motor's net torque T_m (electromagnetic minus the
held Coulomb T_0) is scaled by η (T_m·φ̇ ≥ 0: the motor drives the load) or 1/η_back (the load
drives the motor) before it reaches the gear — exact for the mesh power at constant speed; the
rotor's own inertial torque is not charged with the loss (docs/drivetrain.md).

**Dry friction** (motor shaft, any joint): F(v) = F_C + (F_S − F_C)·exp(−(v/v_S)²) opposing the
motion, up to F_S while sticking.  Multibody: MuJoCo ``frictionloss`` on the joint (a soft
constraint: true stick, ``solref_friction = (2h, 1)``), its level updated at every step to
F(v at the start of the step) when F_S > F_C (Stribeck); the motor's friction sits on the
crank joint (×z, rigid gear) or on ``drive_motor`` (compliant).  Reduced model: the same law,
regularised as −F(|v|)·tanh(v/v_ε) with v_ε = 2·h·n·F_S·g²/J_min (g: the joint's speed ratio,
n: number of friction terms on the coordinate) so that the stick slope stays within RK4's
stability for any h; friction on a joint other than the crank is reduced to the crank through
the joint's speed ratio r_j(q) (tabulated once from the MuJoCo kinematics, rigid crank
mechanisms).
"""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from ..mechanisms.base import Mechanism

MOTOR_JOINT = "drive_motor"       #: the motor's hinge in a compliant-gear multibody model
MESH_TENDON = "gear_mesh"         #: the fixed tendon θ_m − α carrying the mesh spring
DEFLECTION = "gear_deflection"    #: the internal coordinate δ = θ_m − α


class Gear:
    """Backlash β [rad], stiffness k [N·m/rad] (None: from ``mesh_frequency`` [Hz]), contact
    damping c [N·m·s/rad] (None: from ``damping_ratio``), efficiencies η, η_back."""

    def __init__(self, backlash=0.0, stiffness=None, mesh_frequency=1000.0, damping=None,
                 damping_ratio=0.1, efficiency=1.0, efficiency_back=None):
        self.backlash, self.stiffness, self.mesh_frequency = backlash, stiffness, mesh_frequency
        self.damping, self.damping_ratio = damping, damping_ratio
        self.efficiency = efficiency
        self.efficiency_back = efficiency if efficiency_back is None else efficiency_back
        for name in ("efficiency", "efficiency_back"):
            v = np.asarray(getattr(self, name), dtype=float)
            if not np.all((v > 0) & (v <= 1)):
                raise ParameterError(f"drive.gear.{name} = {getattr(self, name)!r}: must be in (0, 1]")
        if np.any(np.asarray(backlash) < 0):
            raise ParameterError(f"drive.gear.backlash = {backlash!r}: must be >= 0")

    @property
    def compliant(self) -> bool:
        return bool(np.any(np.asarray(self.backlash) > 0)) or self.stiffness is not None

    @property
    def lossy(self) -> bool:
        return bool(np.any(np.asarray(self.efficiency) < 1) or np.any(np.asarray(self.efficiency_back) < 1))

    def describe(self) -> dict:
        return {"backlash_rad": _plain(self.backlash), "stiffness_Nm_rad": _plain(self.stiffness),
                "mesh_frequency_Hz": _plain(self.mesh_frequency), "damping_Nms_rad": _plain(self.damping),
                "damping_ratio": _plain(self.damping_ratio), "efficiency": _plain(self.efficiency),
                "efficiency_back": _plain(self.efficiency_back)}

    def efficiency_function(self, batch):
        """T_m, φ̇ ↦ the torque passed to the gear (η·T_m forward, T_m/η_back back-driven); None if lossless."""
        if not self.lossy:
            return None
        ef, eb = self.efficiency, self.efficiency_back
        if not batch:
            ef, ieb = float(ef), 1.0 / float(eb)

            def eff(Tm, w):
                return Tm * ef if Tm * w >= 0.0 else Tm * ieb
            return eff

        def eff_a(Tm, w):
            return np.where(Tm * w >= 0.0, Tm * ef, Tm / eb)
        return eff_a


class Friction:
    """Dry friction: on the motor shaft (``coulomb``, ``breakaway``, ``stribeck_speed``, motor
    side) and per joint (``joints``: {name: {coulomb, breakaway, stribeck_speed, viscous}})."""

    def __init__(self, coulomb=0.0, breakaway=None, stribeck_speed=None, joints=None):
        self.coulomb = coulomb
        self.breakaway = coulomb if breakaway is None else breakaway
        self.stribeck_speed = stribeck_speed
        self.joints = {k: dict(v) for k, v in (joints or {}).items()}
        for name, law in [("motor", {"coulomb": self.coulomb, "breakaway": self.breakaway,
                                     "stribeck_speed": stribeck_speed})] + list(self.joints.items()):
            fc, fs = float(law.get("coulomb", 0.0)), law.get("breakaway")
            fs = fc if fs is None else float(fs)
            if fc < 0 or fs < fc:
                raise ParameterError(f"drive.friction {name}: need 0 <= coulomb <= breakaway, got {fc:g}, {fs:g}")
            if fs > fc and not law.get("stribeck_speed"):
                raise ParameterError(f"drive.friction {name}: breakaway > coulomb needs a stribeck_speed")

    def describe(self) -> dict:
        return {"coulomb_Nm": _plain(self.coulomb), "breakaway_Nm": _plain(self.breakaway),
                "stribeck_speed_rad_s": _plain(self.stribeck_speed), "joints": self.joints}


def _law(d):
    """(F_C, F_S, v_S) of a law dict (v_S = inf when there is no Stribeck drop)."""
    fc = float(d.get("coulomb", 0.0) or 0.0)
    fs = d.get("breakaway")
    fs = fc if fs is None else float(fs)
    vs = d.get("stribeck_speed")
    return fc, fs, (float(vs) if vs else math.inf)


def level(v, fc, fs, vs):
    """Friction level F(|v|) = F_C + (F_S − F_C)·exp(−(v/v_S)²)."""
    if fs == fc:
        return fc if isinstance(v, float) else fc + 0.0 * v
    if isinstance(v, float):
        return fc + (fs - fc) * math.exp(-(v / vs) ** 2)
    return fc + (fs - fc) * np.exp(-(v / vs) ** 2)


class DrivenMechanism(Mechanism):
    """A mechanism with the drive train's mechanical elements (compliant gear, friction) added to
    both of its models.  Everything else is the wrapped mechanism's (``inner``)."""

    Params = None

    def __init__(self, inner, drive, gear=None, friction=None):
        self.inner = inner
        self.type_name = inner.type_name
        self.input_joint = inner.input_joint
        self.view = inner.view
        self.gear, self.friction = gear, friction
        self.compliant = gear is not None and gear.compliant
        self.drive_joint = MOTOR_JOINT if self.compliant else inner.input_joint
        self.internal = tuple(inner.internal) + ((DEFLECTION,) if self.compliant else ())
        # the tabulated reduced model (mjbench.backends.table) tabulates J, J', E_p' (periodic in q) and
        # calls external_torque (the friction law) at every stage; no viscous-only D (reduced_viscous: None)
        self.reduced_period = getattr(inner, "reduced_period", None)
        self.z = float(drive.z)
        self.J_b = float(drive.J_b)
        self.J_mo = float(drive.J_eq) - self.J_b  # motor + pinion inertia at the output
        self._Jmin_mech = _min_inertia(inner)
        if self.compliant:
            if self.J_mo <= 0:
                raise ParameterError("drive.gear: a compliant gear (backlash or stiffness) needs a motor inertia "
                                     "drive.J_m + drive.J_a > 0 (the motor becomes its own coordinate)")
            self.beta = float(gear.backlash)
            Jc = self.J_b + self._Jmin_mech
            Jr = self.J_mo * Jc / (self.J_mo + Jc)
            w = 2.0 * math.pi * float(gear.mesh_frequency)
            self.k = float(gear.stiffness) if gear.stiffness is not None else Jr * w * w
            self.c = float(gear.damping) if gear.damping is not None else \
                2.0 * float(gear.damping_ratio) * math.sqrt(self.k * Jr)
        else:
            self.beta = self.k = self.c = 0.0
        # friction laws: motor (at the motor shaft) and joints
        self._motor_law = None
        self._joint_laws = {}
        if friction is not None:
            m = _law({"coulomb": friction.coulomb, "breakaway": friction.breakaway,
                      "stribeck_speed": friction.stribeck_speed})
            if m[1] > 0:
                self._motor_law = m
            for name, d in friction.joints.items():
                law = _law(d)
                visc = float(d.get("viscous", 0.0) or 0.0)
                if law[1] > 0 or visc > 0:
                    self._joint_laws[name] = (*law, visc)
        self._h = None
        self._mj = {}

    # ------------------------------------------------------------------ delegation
    def __getattr__(self, name):
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    @classmethod
    def from_params(cls, params):  # pragma: no cover - built by the drive train, not from a table
        raise TypeError("DrivenMechanism wraps a mechanism; build it with DriveTrain.wrap")

    def reduced(self, q):
        return self.inner.reduced(q)

    def potential_energy(self, q):
        return self.inner.potential_energy(q)

    def kinetic_energy(self, q, qd):
        return self.inner.kinetic_energy(q, qd)

    def points(self, q):
        return self.inner.points(q)

    def trace_point(self, q):
        return self.inner.trace_point(q)

    def closure_error(self, model, data):
        return self.inner.closure_error(model, data)

    def describe(self) -> dict:
        d = dict(self.inner.describe())
        dt = {}
        if self.gear is not None:
            dt["gear"] = {**self.gear.describe(), "stiffness_used_Nm_rad": self.k, "damping_used_Nms_rad": self.c}
        if self.friction is not None:
            dt["friction"] = self.friction.describe()
        if self.needs_model_edits:
            dt["instance"] = id(self)  # per-step model edits: one compiled model per simulation in a batch
        d["drivetrain"] = dt
        return d

    @property
    def has_stribeck(self) -> bool:
        laws = ([self._motor_law] if self._motor_law else []) + list(self._joint_laws.values())
        return any(law[1] > law[0] for law in laws)

    @property
    def toggles_damping(self) -> bool:
        return self.compliant and self.beta > 0 and self.c > 0

    @property
    def needs_model_edits(self) -> bool:
        return self.has_stribeck or self.toggles_damping

    # ------------------------------------------------------------------ step-size dependent set-up
    def set_step(self, h):
        """Prepare the reduced model's friction regularisation for co-simulation step h [s]."""
        if self._h == h:
            return
        self._h = float(h)
        crank_terms, motor_terms, others = [], [], []
        z = self.z
        if self._motor_law is not None:
            (motor_terms if self.compliant else crank_terms).append((self._motor_law, z, z))
        for name, (fc, fs, vs, visc) in self._joint_laws.items():
            if name == self.input_joint:
                crank_terms.append(((fc, fs, vs), 1.0, 1.0, visc))
            elif name == MOTOR_JOINT:
                raise ParameterError("drive.friction.joints.drive_motor: use [drive.friction] (the motor shaft)")
            else:
                others.append((name, (fc, fs, vs), visc))
        J_crank = (self.J_b if self.compliant else self.J_b + self.J_mo) + self._Jmin_mech
        table = self._speed_ratios([n for n, _, _ in others]) if others else {}
        n_c = len(crank_terms) + len(others)
        self._crank_terms = []
        for term in crank_terms:
            (fc, fs, vs), gF, gv = term[:3]
            visc = term[3] if len(term) > 3 else 0.0
            veps = 2.0 * h * max(n_c, 1) * fs * gF * gv / J_crank if fs > 0 else 1.0
            self._crank_terms.append((fc, fs, vs, gF, gv, max(veps, 1e-12), visc))
        self._other_terms = []
        for name, (fc, fs, vs), visc in others:
            qg, r = table[name]
            rmax = float(np.max(np.abs(r))) or 1.0
            veps = 2.0 * h * max(n_c, 1) * fs * rmax * rmax / J_crank if fs > 0 else 1.0
            self._other_terms.append((fc, fs, vs, qg, r, max(veps / rmax, 1e-12), visc))
        self._motor_terms = []
        for (fc, fs, vs), gF, gv in motor_terms:
            veps = 2.0 * h * fs * gF * gv / self.J_mo if fs > 0 else 1.0
            self._motor_terms.append((fc, fs, vs, gF, gv, max(veps, 1e-12), 0.0))
        self._has_crank_friction = bool(self._crank_terms or self._other_terms)

    def _speed_ratios(self, names):
        """{joint: (q grid, dθ_j/dq on it)} over one crank turn, from the MuJoCo kinematics."""
        if self.inner.internal:
            raise ParameterError(f"drive.friction.joints: friction on {', '.join(names)} needs a rigid mechanism in "
                                 f"the reduced model ({self.inner.type_name} has internal coordinates); use the "
                                 f"multibody backend or friction on the input joint")
        spec = self.inner.build_spec(0.0, {"timestep": self._h})
        m = spec.compile()
        qg = np.linspace(0.0, 2.0 * math.pi, 1025)
        out = {}
        for n in names:
            try:
                dof = int(m.joint(n).dofadr[0])
            except KeyError:
                raise ParameterError(f"drive.friction.joints.{n}: no joint {n!r} in the mechanism's model") from None
            out[n] = (qg, np.array([self.inner.initial_qvel(m, float(q), 1.0)[dof] for q in qg]))
        return out

    # ------------------------------------------------------------------ reduced model
    def _terms_torque(self, terms, v):
        """Σ −g_F·F(|g_v·v|)·tanh(g_v·v/v_ε) − visc·v over one coordinate's friction terms."""
        out = 0.0 * v
        scalar = isinstance(v, float)
        for fc, fs, vs, gF, gv, veps, visc in terms:
            u = gv * v
            th = math.tanh(u / veps) if scalar else np.tanh(u / veps)
            out = out - gF * level(abs(u) if scalar else np.abs(u), fc, fs, vs) * th - visc * v
        return out

    def _crank_friction(self, q, qd):
        if self._h is None:
            self.set_step(1e-4)
        tq = self._terms_torque(self._crank_terms, qd)
        scalar = isinstance(qd, float)
        for fc, fs, vs, qg, r, veps, visc in self._other_terms:
            rq = np.interp(q, qg, r, period=2.0 * math.pi)
            if scalar:
                rq = float(rq)
                u = rq * qd
                tq -= rq * (level(abs(u), fc, fs, vs) * math.tanh(u / veps) + visc * u)
            else:
                u = rq * qd
                tq = tq - rq * (level(np.abs(u), fc, fs, vs) * np.tanh(u / veps) + visc * u)
        return tq

    def external_torque(self, q, qd, t):
        ext = self.inner.external_torque(q, qd, t)
        if not self.compliant and (self._motor_law is not None or self._joint_laws):
            if self._h is None:
                self.set_step(1e-4)
            if self._has_crank_friction:
                ext = ext + self._crank_friction(q, qd)
        return ext

    def mesh_torque(self, d, dd):
        """Mesh torque on the crank [N·m] for deflection δ [rad] and rate δ̇ [rad/s] (output side)."""
        k, c, hb = self.k, self.c, 0.5 * self.beta
        if hb == 0.0:
            return k * d + c * dd
        if isinstance(d, float):
            if d > hb:
                return k * (d - hb) + c * dd
            if d < -hb:
                return k * (d + hb) + c * dd
            return 0.0
        e = d - np.clip(d, -hb, hb)
        return k * e + np.where(e != 0.0, c * dd, 0.0)

    def reduced_accel(self, t, q, qd, x, xd, tau, J_add, c_add):
        inner = self.inner
        if not self.compliant:
            if self._h is None:
                self.set_step(1e-4)
            if self._has_crank_friction:
                tau = tau + self._crank_friction(q, qd)
            return inner.reduced_accel(t, q, qd, x, xd, tau, J_add, c_add)
        if self._h is None:
            self.set_step(1e-4)
        d, dd = x[-1], xd[-1]
        Tg = self.mesh_torque(d, dd)
        Tc = Tg + self._crank_friction(q, qd) if self._has_crank_friction else Tg
        qdd, xdd = inner.reduced_accel(t, q, qd, tuple(x[:-1]), tuple(xd[:-1]), Tc, self.J_b, 0.0)
        wm = qd + dd
        Tm = tau - c_add * wm - Tg
        if self._motor_terms:
            Tm = Tm + self._terms_torque(self._motor_terms, wm)
        thdd = Tm / (J_add - self.J_b)
        return qdd, (*xdd, thdd - qdd)

    # ------------------------------------------------------------------ multibody model
    def build_spec(self, armature: float = 0.0, options=None):
        import mujoco

        o = dict(options or {})
        h = float(o.get("timestep", 1e-4))
        inner = self.inner
        if self.compliant:
            spec = inner.build_spec(armature=self.J_b, options=options)
            axis = [float(a) for a in spec.joint(self.input_joint).axis]
            rotor = spec.worldbody.add_body(name="drive_motor_rotor", pos=[0.0, 0.0, 0.0])
            rotor.mass = 1e-9
            rotor.ipos = [0.0, 0.0, 0.0]
            rotor.inertia = [1e-12, 1e-12, 1e-12]
            rotor.explicitinertial = True
            j = rotor.add_joint(name=MOTOR_JOINT, type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis)
            j.armature = float(armature) - self.J_b
            t = spec.add_tendon(name=MESH_TENDON)
            t.wrap_joint(MOTOR_JOINT, 1.0)
            t.wrap_joint(self.input_joint, -1.0)
            t.stiffness = [self.k, 0.0, 0.0]
            t.springlength = [-0.5 * self.beta, 0.5 * self.beta]
            t.damping = [self.c if self.beta == 0.0 else 0.0, 0.0, 0.0]
        else:
            spec = inner.build_spec(armature=armature, options=options)
        levels = {}
        if self._motor_law is not None:
            levels[self.drive_joint] = levels.get(self.drive_joint, 0.0) + self.z * self._motor_law[1]
        for name, (fc, fs, vs, visc) in self._joint_laws.items():
            try:
                j = spec.joint(name)
            except Exception:  # noqa: BLE001
                j = None
            if j is None:
                raise ParameterError(f"drive.friction.joints.{name}: no joint {name!r} in the mechanism's model")
            if fs > 0:
                levels[name] = levels.get(name, 0.0) + fs
            if visc > 0:
                j.damping = [float(j.damping[0]) + visc, 0.0, 0.0]
        for name, F in levels.items():
            j = spec.joint(name)
            j.frictionloss = float(F)
            j.solref_friction = [2.0 * h, 1.0]
        return spec

    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        xi = tuple(x0[:-1]) if (x0 and self.compliant) else x0
        qpos = self.inner.initial_qpos(model, q0, xi or None)
        if self.compliant:
            qpos[model.joint(MOTOR_JOINT).qposadr[0]] = q0 + (float(x0[-1]) if x0 else 0.0)
        return qpos

    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        xi = tuple(x0[:-1]) if (x0 and self.compliant) else x0
        xdi = tuple(xd0[:-1]) if (xd0 and self.compliant) else xd0
        qvel = self.inner.initial_qvel(model, q0, qd0, xi or None, xdi or None)
        if self.compliant:
            qvel[model.joint(MOTOR_JOINT).dofadr[0]] = qd0 + (float(xd0[-1]) if xd0 else 0.0)
        return qvel

    def internal_state(self, model, qpos, qvel):
        x, xd = self.inner.internal_state(model, qpos, qvel)
        if not self.compliant:
            return x, xd
        ids = self._ids(model)
        return ((*x, qpos[..., ids["qm"]] - qpos[..., ids["qc"]]),
                (*xd, qvel[..., ids["vm"]] - qvel[..., ids["vc"]]))

    def _ids(self, model):
        key = id(model)
        ids = self._mj.get(key)
        if ids is not None:
            return ids
        jc = model.joint(self.input_joint)
        ids = {"qc": int(jc.qposadr[0]), "vc": int(jc.dofadr[0])}
        if self.compliant:
            jm = model.joint(MOTOR_JOINT)
            ids.update(qm=int(jm.qposadr[0]), vm=int(jm.dofadr[0]), tendon=int(model.tendon(MESH_TENDON).id))
        # Stribeck: per dof, the laws whose level is updated every step (gain on force, gain on speed)
        strib = {}
        if self._motor_law is not None and self._motor_law[1] > self._motor_law[0]:
            strib.setdefault(int(model.joint(self.drive_joint).dofadr[0]), []).append((self._motor_law, self.z, self.z))
        for name, (fc, fs, vs, visc) in self._joint_laws.items():
            dof = int(model.joint(name).dofadr[0])
            strib.setdefault(dof, []).append(((fc, fs, vs), 1.0, 1.0))
        # a dof is updated if one of its laws has a Stribeck drop (the others' levels are constant)
        ids["stribeck"] = [(dof, laws) for dof, laws in strib.items() if any(lw[0][1] > lw[0][0] for lw in laws)]
        self._mj[key] = ids
        return ids

    def has_multibody_load(self) -> bool:
        return self.compliant or self.inner.has_multibody_load() or self.needs_model_edits

    def _edit_model(self, model, qpos, qvel):
        """Per-step model edits of one simulation: contact damping on/off, Stribeck levels."""
        ids = self._ids(model)
        if self.toggles_damping:
            d = qpos[ids["qm"]] - qpos[ids["qc"]]
            model.tendon_damping[ids["tendon"]] = self.c if abs(d) > 0.5 * self.beta else 0.0
        for dof, laws in ids["stribeck"]:
            v = float(qvel[dof])
            F = 0.0
            for (fc, fs, vs), gF, gv in laws:
                F += gF * level(abs(gv * v), fc, fs, vs)
            model.dof_frictionloss[dof] = F

    def multibody_load(self, model, data, t: float) -> None:
        if self.compliant:
            data.qfrc_applied[self._ids(model)["vc"]] = 0.0  # the drive torque is on drive_motor
        if self.inner.has_multibody_load():
            self.inner.multibody_load(model, data, t)
        if self.needs_model_edits:
            self._edit_model(model, data.qpos, data.qvel)


def _min_inertia(mech) -> float:
    """Smallest rigid inertia J(q) of the mechanism over one input turn [kg·m²]."""
    q = np.linspace(0.0, 2.0 * math.pi, 721)
    try:
        J = np.asarray(mech.reduced(q)[0], dtype=float)
        if J.shape != q.shape:
            J = np.broadcast_to(J, q.shape)
    except Exception:  # noqa: BLE001 - a mechanism whose reduced() only takes floats
        J = np.array([float(mech.reduced(float(v))[0]) for v in q])
    return float(np.min(J))


def _plain(v):
    if v is None:
        return None
    return v.tolist() if isinstance(v, np.ndarray) else float(v)
