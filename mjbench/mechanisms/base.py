"""The one interface every mechanism offers (seed 000 notation generalised).

A mechanism has one driven degree of freedom, the *input coordinate* ``q`` (the crank angle α of
seed 000, the motor angle of the platforms of seeds 001/003 ...), driven through the gearbox by
the drive.  Rigid linkages have no other state; elastic machines also have *internal*
coordinates (the platforms' transmission deflection ψ), listed in :attr:`Mechanism.internal`.

What a subclass implements (abstract, checked when the class is instantiated):

* reduced (Eksergian) dynamics, seed 000 Eq 5, rigid part:
      ½ J'(q) q̇² + J(q) q̈ + E_p'(q) = T_c + Q_ext(q, q̇, t)
  :meth:`reduced` → (J, dJ/dq, dE_p/dq), :meth:`potential_energy`;
* the MJCF model (:meth:`build_spec`, an ``MjSpec`` whose driven joint is :attr:`input_joint`
  and carries the reflected drive inertia as ``armature``), the assembled configuration and
  velocity at an input angle/speed (:meth:`initial_qpos`, :meth:`initial_qvel`);
* drawing: named points in the mechanism's plane (:meth:`points`);
* :meth:`from_params`, building the mechanism from its validated ``Params`` (pydantic model of the
  scenario's ``[mechanism]`` table, class attribute :attr:`Params`, ``type = type_name``).

Optional, with defaults: external generalised force (:meth:`external_torque`, e.g. a process
load), the matching multibody load (:meth:`multibody_load`), loop-closure residual
(:meth:`closure_error`), traced point (:meth:`trace_point`), internal dynamics
(:meth:`reduced_accel` for mechanisms with internal coordinates), how a video shows it
(:meth:`render_view`), its kinematics for ``mjbench analyze`` (:meth:`linkage_view`,
:meth:`kinematics`).

Compiled forms (:mod:`mjbench.compiled`; the kernel's loop composes them, the Python methods call
the same laws): :meth:`model_form` (the reduced model law), :meth:`accel_form` (the accelerations
with internal coordinates), :meth:`load_form` (the MuJoCo loads), :meth:`closure_form`,
:meth:`internal_index`, :meth:`motor_index`.  A mechanism whose external torque is viscous only
needs none of them; without a law for a non-viscous part the run says why it is not compiled.

A new mechanism = one module defining the subclass and decorating it with
``@mjbench.mechanisms.register``; ``[mechanism] type = "<type_name>"`` then runs on every backend
with every controller, metric, plot, video and sweep.  All kinematic functions accept scalars or
NumPy arrays.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

INPUT_JOINT = "crank"  #: default name of the driven joint in the generated MJCF models

# ---------------------------------------------------------------------------- plane convention
# The ONE declaration of the plane of every generated MJCF model.  A planar mechanism is described
# in its plane (x, y), y up (``points``, link lengths, angles counter-clockwise from +x).  Its MJCF
# lies in MuJoCo's x–z plane: plane (x, y) → MuJoCo (x, 0, y) (:func:`plane_to_mj`), gravity along
# −z (plane −y), and every hinge turns about HINGE_AXIS = −y, so that a positive joint angle is
# counter-clockwise in the plane: a body rotated by q about −y maps (1, 0, 0) to (cos q, 0, sin q).
# ``mjbench render`` looks along +y at that plane (SIDE_CAMERA: plane x → right, plane y → up).
HINGE_AXIS = (0.0, -1.0, 0.0)  #: hinge axis of a planar mechanism's joints in MuJoCo
PLANE_INDEX = (0, 2)  #: MuJoCo coordinates holding the plane's x and y
SIDE_CAMERA = {"azimuth": 90.0, "elevation": 0.0}  #: free camera looking along +y at the x–z plane


def plane_to_mj(x, y) -> list:
    """MuJoCo position [x, 0, y] of the plane point (x, y) [m] (the plane convention above)."""
    return [x, 0.0, y]


def mj_to_plane(p) -> tuple:
    """Plane point (x, y) [m] of a MuJoCo position (its x and z; the plane convention above)."""
    return (p[PLANE_INDEX[0]], p[PLANE_INDEX[1]])

INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast")


def integrator_enum(name):
    """MuJoCo integrator enum from its name (case-insensitive); ParameterError otherwise."""
    import mujoco

    from ..errors import ParameterError

    table = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4,
             "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
             "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}
    try:
        return table[str(name).lower()]
    except KeyError:
        raise ParameterError(f"multibody.integrator = {name!r}: choose one of {list(INTEGRATORS)}") from None


# Loop-closure equalities of every built-in MJCF (four-bar, quick-return, generic linkage, a
# user's MJCF): solref = (timeconst, dampratio) with timeconst = CLOSURE_TIMECONST_STEPS · h and
# impedance 0.9999 (MuJoCo's maximum).  The constraint acceleration is the Baumgarte reference
# a* = −b·ṙ − k·r.  3·h, not MuJoCo's floor 2·h: measured multibody-vs-reduced crank speed (max/peak,
# RK4, h = 0.1 ms) at 2h / 3h / 4h: seed-000 four-bar open loop 4.9e-5 / 1.3e-5 / 5.1e-6, PID 1.9e-5 /
# 5.1e-6 / 2.0e-6; the other machines stay ≤ 1.5e-6 at 3h (sixbar 7.1e-7 → 1.5e-6, toggle press
# 3.0e-7 → 5.9e-7) while 4h lets the toggle press's closure exceed 1e-7 m.  3h minimises the worst
# case with every closure ≤ 6.3e-8 m.  A scenario's ``multibody.solref`` overrides it.
CLOSURE_TIMECONST_STEPS = 3.0
CLOSURE_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)


def closure_solref(options, h):
    """Loop-closure (solref, solimp) for step ``h`` [s]: the options' ``solref``/``solimp`` when given
    (a negative time constant means the default), else (CLOSURE_TIMECONST_STEPS·h, 1) and CLOSURE_SOLIMP."""
    solref = list(options.get("solref") or (-1.0, 0.0))
    if solref[0] < 0:
        solref = [CLOSURE_TIMECONST_STEPS * h, 1.0]
    return solref, list(options.get("solimp") or CLOSURE_SOLIMP)


def new_spec(name, options=None, gravity=(0.0, 0.0, -9.81), offscreen=(1920, 1080)):
    """An MjSpec with the options every mjbench model shares.

    ``options``: ``timestep`` [s] (default 1e-4), ``integrator`` (default RK4), ``iterations``,
    ``tolerance``.  Always: Newton solver, contacts off, energy computed, explicit inertials.  The
    constraint Jacobian is MuJoCo's default (``auto``: dense below 60 DOFs, i.e. every mjbench
    model); the forced dense Jacobian of MuJoCo 4.0.0 (sparse-Cholesky bug on closed chains,
    upstream issue 3767) was dropped on 4.0.1 by test (tests/test_mujoco_version.py).
    """
    import mujoco

    o = dict(options or {})
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = True
    opt = spec.option
    opt.timestep = float(o.get("timestep", 1e-4))
    opt.integrator = integrator_enum(o.get("integrator", "RK4"))
    opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    opt.iterations = int(o.get("iterations", 100))
    opt.tolerance = float(o.get("tolerance", 1e-12))
    opt.gravity = list(gravity)
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    spec.visual.global_.offwidth, spec.visual.global_.offheight = offscreen
    return spec


@dataclass(frozen=True)
class RenderView:
    """How a video shows a mechanism (:mod:`mjbench.render`), declared by its class
    (:meth:`Mechanism.render_view`).

    ``kind``: "side" — the linkage in its plane, camera along +y, the pose of every frame from
    ``initial_qpos`` of the recorded input, the path of ``trace_point``; or "top" — a rotary table
    seen from above: the hinge ``output_joint`` of the body ``output_body`` turns ρ·q + x with
    ρ = ``ratio`` and x the internal coordinate ``deflection`` (recorded as ``<deflection>_rad``),
    drawn as two needles (rigid ρ·q, and ρ·q + gain·x); ``label`` names the machine in the overlay."""

    kind: str = "side"
    output_joint: str = ""
    output_body: str = ""
    ratio: float = 1.0
    deflection: str = ""
    label: str = ""


class Mechanism(abc.ABC):
    """Abstract single-input mechanism driven at its input coordinate q [rad]."""

    #: scenario ``[mechanism] type`` of this class (set by subclasses)
    type_name: ClassVar[str] = ""
    #: pydantic model of the ``[mechanism]`` table (a :class:`mjbench.schema.Strict` subclass)
    Params: ClassVar[type | None] = None
    #: name of the driven joint in the MJCF model
    input_joint: ClassVar[str] = INPUT_JOINT
    #: internal (elastic) coordinates of the reduced model besides q, e.g. ("deflection",)
    internal: ClassVar[tuple[str, ...]] = ()
    #: how a video shows it: "side" (linkage in its plane x-y) or "top" (rotary table from above)
    view: ClassVar[str] = "side"
    #: period [rad] of the reduced model's J(q), J'(q), E_p'(q) in the input coordinate (a crank:
    #: one turn, 2π); the reduced backends tabulate rigid mechanisms over it.  None: not periodic
    #: (the closed forms are evaluated at every step).
    reduced_period: ClassVar[float | None] = 2.0 * np.pi
    #: where the reduced model comes from; printed next to every multibody-vs-reduced figure.  A
    #: model derived from the MJCF itself (``mjcf``) must start with "MuJoCo-derived".
    reduced_source: ClassVar[str] = "independent: hand-derived closed form"

    # --- construction ------------------------------------------------------------------------
    @classmethod
    @abc.abstractmethod
    def from_params(cls, params) -> "Mechanism":
        """Build the mechanism from its validated ``Params`` object."""

    @classmethod
    def params_for(cls, raw: dict):
        """The Params model that validates the raw ``[mechanism]`` table (a class with variants,
        e.g. a notation or a platform variant, picks one from ``raw``)."""
        return cls.Params

    # --- reduced dynamics --------------------------------------------------------------------
    @abc.abstractmethod
    def reduced(self, q):
        """Return ``(J, dJ_dq, dEp_dq)``: equivalent inertia about q [kg·m²] (rigid transmission),
        its derivative [kg·m²/rad] and the derivative of the potential energy [N·m] (seed 000 Eqs 2-5)."""

    @abc.abstractmethod
    def potential_energy(self, q):
        """Gravitational (and elastic, rigid part) potential energy E_p(q) [J]."""

    def kinetic_energy(self, q, qd):
        """E_k = ½ J(q) q̇² [J] (seed 000 Eq 2), mechanism only (no drive inertia)."""
        J, _, _ = self.reduced(q)
        return 0.5 * J * qd * qd

    def external_torque(self, q, qd, t):
        """Generalised external force on q [N·m] besides gravity and the drive (default 0)."""
        return 0.0 * q

    def has_external_torque(self) -> bool:
        """Whether :meth:`external_torque` can be non-zero (the reduced backends skip it if not)."""
        return type(self).external_torque is not Mechanism.external_torque

    def reduced_viscous(self, q):
        """D(q) [N·m·s/rad] if :meth:`external_torque` is exactly −D(q)·q̇ (viscous friction
        reduced to the input, smooth and periodic in q like J); None if it is anything else (the
        tabulated reduced model then calls :meth:`external_torque` itself).  Default: None."""
        return None

    def reduced_accel(self, t, q, qd, x, xd, tau, J_add, c_add):
        """Accelerations (q̈, ẍ) of the reduced model under the input torque ``tau`` [N·m] (drive
        torque without its viscous part), with the drive inertia ``J_add`` [kg·m²] and viscous
        coefficient ``c_add`` [N·m·s/rad] on q.  ``x``, ``xd``: internal coordinates (tuples, empty
        for rigid mechanisms).  Default: the rigid Eksergian model (seed 000 Eqs 10-13)."""
        J, dJ, dEp = self.reduced(q)
        qdd = (tau - c_add * qd + self.external_torque(q, qd, t) - dEp - 0.5 * dJ * qd * qd) / (J_add + J)
        return qdd, ()

    # --- multibody ---------------------------------------------------------------------------
    @abc.abstractmethod
    def build_spec(self, armature: float = 0.0, options=None):
        """Return a ``mujoco.MjSpec`` of the mechanism.  The driven joint is named
        :attr:`input_joint`; ``armature`` [kg·m²] is added to it (reflected drive inertia J_eq)."""

    @abc.abstractmethod
    def initial_qpos(self, model, q0: float, x0=None) -> np.ndarray:
        """Full ``qpos`` of ``model`` with the loop assembled at input angle q0 (internal
        coordinates ``x0``, default at rest/undeflected)."""

    @abc.abstractmethod
    def initial_qvel(self, model, q0: float, qd0: float, x0=None, xd0=None) -> np.ndarray:
        """Full ``qvel`` of ``model`` consistent with the constraints at (q0, q̇0)."""

    def internal_state(self, model, qpos, qvel):
        """Internal coordinates and their rates ``(x, xd)`` (tuples) from a multibody state."""
        return (), ()

    def closure_error(self, model, data) -> float:
        """Largest loop-closure violation [m] in the multibody state: the equality-constraint
        residuals, which MuJoCo stores first (rows 0..ne-1) in ``efc_pos``."""
        ne = data.ne  # (a handful of rows, read every record: Python's max is 2.5x cheaper than NumPy's)
        return max(map(abs, data.efc_pos[:ne].tolist())) if ne else 0.0

    def closure_site_index(self, model):
        """The loop-closure residual as site coordinates: pairs (i, j) of indices into the flat
        ``site_xpos`` whose largest |difference| is :meth:`closure_error` (x, y, z of each connect
        pair; empty without equalities) — or None when it is not that (the mechanism defines its own
        residual, or an equality is not a site ``connect``)."""
        pairs = connect_site_pairs(model)
        if type(self).closure_error is not Mechanism.closure_error or len(pairs) != model.neq:
            return None
        return tuple((3 * a + j, 3 * c + j) for a, c in pairs for j in range(3))

    # --- compiled forms (the kernel's slots; mjbench.compiled) ---------------------------------
    def model_form(self):
        """The reduced model as a law ``MODEL(q, q̇, t, P) → (J, ½J', E_p', Q_ext)`` (a
        :class:`~mjbench.compiled.Form`), for the rigid reduced plant and model-based controllers.

        Default: the periodic spline table of J, ½J', E_p' and a viscous D
        (:func:`mjbench.backends.table.table_model`).  A mechanism whose external torque is not
        viscous overrides this with a law that adds it (e.g. the quick-return's cutting force);
        without one, a Python adapter of the closed forms (the run is then not compiled)."""
        from .. import compiled as C
        from ..backends import table

        if table.supports(self) and not (self.has_external_torque() and self.reduced_viscous(0.0) is None):
            return table_form(self)
        why = ("its external torque is not viscous and has no law (override model_form)"
               if table.supports(self) else "its reduced model cannot be tabulated")
        return C.python_form(_closed_model(self), f"{type(self).__name__}: {why}")

    def accel_form(self):
        """The reduced model's accelerations as a law ``ACCEL(t, S, iy, ia, τ, J_eq, c, P) → q̈``
        (a :class:`~mjbench.compiled.Form`) for the reduced plant with internal coordinates
        (:func:`mjbench.backends.reduced.rk4_internal`): it reads the state (q, q̇, x₁, ẋ₁, …) at
        ``S[iy:]`` and writes (q̈, ẍ₁, …) to ``S[ia:]``; τ is the input torque, J_eq and c the
        drive's inertia and viscous coefficient on q.

        Default: a rigid mechanism's model law (:meth:`model_form`) through
        :func:`~mjbench.backends.reduced.rigid_accel`; a mechanism with internal coordinates
        overrides it (its :meth:`reduced_accel` must call the same law, :func:`accel_call`),
        else a Python adapter of :meth:`reduced_accel` (the run is then not compiled)."""
        from .. import compiled as C
        from ..backends.reduced import rigid_accel

        if not self.internal:
            m = self.model_form()
            return C.Form(rigid_accel, m.P, fn_args=(m,), flags=dict(m.flags))
        mech = self
        n = len(self.internal)

        def adapter(t, S, iy, ia, tau, Ja, c, P):
            x = tuple(S[iy + 2 + 2 * i] for i in range(n))
            xd = tuple(S[iy + 3 + 2 * i] for i in range(n))
            qdd, xdd = mech.reduced_accel(t, S[iy], S[iy + 1], x, xd, tau, Ja, c)
            S[ia] = float(qdd)
            for i in range(n):
                S[ia + 1 + i] = float(xdd[i])
            return float(qdd)
        return C.python_form(adapter, f"{type(self).__name__} has internal coordinates and no acceleration law "
                                      f"(override accel_form)")

    def load_form(self, model, data):
        """The MuJoCo loads as a law ``LOAD(t, P)`` writing ``qfrc_applied`` (a Form), or None when
        the mechanism has none.  Default: a Python adapter of :meth:`multibody_load` (the run is
        then not compiled); mechanisms with loads override it."""
        if not self.has_multibody_load():
            return None
        from .. import compiled as C

        load = self.multibody_load

        def adapter(t, P):
            load(model, data, t)
        return C.python_form(adapter, f"{type(self).__name__}.multibody_load has no law (override load_form)")

    def closure_form(self, model, data):
        """The loop-closure residual as a law ``CLOSURE(P, S) → m`` (a Form whose ``P`` becomes the
        MuJoCo plant's ``P.closure``; the law gets the plant's P): the connect sites' offsets when
        every equality is a site ``connect``
        (:meth:`closure_site_index`), else a Python adapter of :meth:`closure_error`."""
        from .. import compiled as C
        from ..backends.multibody import SitePairsP, site_pairs_closure

        idx = self.closure_site_index(model)
        if idx is not None:
            pairs = np.array(idx, dtype=np.int64).reshape(-1, 2)
            return C.Form(site_pairs_closure, SitePairsP(data.site_xpos.reshape(-1), pairs))
        err = self.closure_error

        def adapter(P, S):
            return err(model, data)
        return C.python_form(adapter, f"{type(self).__name__}.closure_error has no law")

    def motor_index(self, model):
        """(qpos, dof) of the motor's own hinge when the drive acts through a compliant gear, else None."""
        return None

    def internal_index(self, model):
        """The internal coordinates in the MuJoCo model as rows (qpos a, qpos b, dof a, dof b, c):
        x = q_a − c·q_b (an (n, 5) array), or None if they are not of that form (a Python adapter of
        :meth:`internal_state` then records them)."""
        return None

    def multibody_load(self, model, data, t: float) -> None:
        """Write external loads of the mechanism into ``data.qfrc_applied`` (default none).
        ``qfrc_applied[input]`` already holds the drive torque: add to it, do not replace it."""

    def has_multibody_load(self) -> bool:
        """Whether :meth:`multibody_load` does anything (the backends skip the call if not)."""
        return type(self).multibody_load is not Mechanism.multibody_load

    # --- kinematics for plots / video --------------------------------------------------------
    @abc.abstractmethod
    def points(self, q) -> dict:
        """Named points of the mechanism in its plane, ``{name: (x, y)}`` [m], for drawings."""

    def trace_point(self, q):
        """(x, y) [m] of the point whose path a video traces (coupler point, slider ...)."""
        return None

    def render_view(self) -> RenderView:
        """How a video shows this mechanism (default: the side view of a planar linkage)."""
        return RenderView(self.view, label=self.type_name)

    # --- design analysis (mjbench analyze) ------------------------------------------------------
    def linkage_view(self):
        """A generic :class:`~mjbench.mechanisms.linkage.Linkage` with this mechanism's kinematics
        (its link lines give transmission angles and toggles), or None (default: none)."""
        return None

    def input_positions(self, n: int):
        """(q, unit): n input positions over one period of the input (default: one turn from 0)."""
        return 2.0 * np.pi * np.arange(n) / n, "rad"

    def kinematics(self, q) -> dict:
        """What ``mjbench analyze`` shows of the kinematics over input positions q (array): keys
        ``source``, ``ratios`` {joint: dq_j/dq}, ``ratio_units``, ``transmission`` {name: μ(q)},
        ``toggles``, ``limit_positions`` (and ``strokes_m``, ``swings_deg``, ``stroke_arcs_deg``
        when known), ``unavailable`` {row: why it cannot be given}.

        Default: through :meth:`linkage_view` (the equivalent generic linkage's analysis); without
        one, nothing, and ``unavailable`` says so."""
        lk = self.linkage_view()
        if lk is None:
            why = (f"{type(self).__name__} has no linkage view (Mechanism.linkage_view): no joints or link lines "
                   f"to analyse")
            return {"source": "not available for this mechanism type", "ratios": {}, "ratio_units": {},
                    "transmission": {}, "toggles": {}, "limit_positions": {},
                    "unavailable": {"velocity_ratios": why, "transmission_angles": why, "toggles": why,
                                    "limit_positions": why}}
        out = lk.kinematic_analysis(q)
        out["source"] = ("own linkage kinematics" if lk is self else
                         f"the equivalent generic linkage of the {self.type_name} (mechanisms/linkage/)")
        out.setdefault("unavailable", {})
        return out

    def model_at_pose(self, model, data) -> None:
        """Bring a MuJoCo model whose constraints are updated every step (a cam's per-step equality,
        :mod:`mjbench.mechanisms.cam`) to the pose in ``data.qpos`` before it is evaluated outside a
        run (``mjbench.plausibility``); default nothing."""

    def metrics(self, trajectory, machine, config) -> dict | None:
        """Metric families the mechanism adds to every run's metrics (a cam's follower separation);
        default none."""
        return None

    def analysis_rows(self, speeds, n: int) -> dict | None:
        """What ``mjbench analyze`` adds for this mechanism family beyond the linkage rows (a cam: the
        jump speed, pressure angle, curvature, contact force): a JSON-ready dict stored under
        ``analysis.json[type_name]`` (its ``"top"`` entries also at the top level); default none."""
        return None

    def describe(self) -> dict:
        """Parameters as a plain dict (manifests, model cache keys)."""
        return {"type": self.type_name,
                **{k: v for k, v in vars(self).items() if not k.startswith("_")}}


def table_form(mech):
    """The periodic spline table of a rigid mechanism as a model law (:func:`table_model`), its
    description in ``flags["table"]`` (the run's meta)."""
    from .. import compiled as C
    from ..backends import table

    tab = table.table_for(mech)
    return C.Form(table.table_model, table.table_params(tab), flags={"table": tab.describe()})


def accel_call(form, t, q, qd, x, xd, tau, J_add, c_add):
    """(q̈, (ẍ₁, …)) of an acceleration law (:meth:`Mechanism.accel_form`) at one state: what a
    mechanism's :meth:`~Mechanism.reduced_accel` returns, computed by the law itself."""
    n = len(x)
    m = 2 * n + 2
    S = [0.0] * (m + n + 1)
    S[0], S[1] = float(q), float(qd)
    for i in range(n):
        S[2 + 2 * i] = float(x[i])
        S[3 + 2 * i] = float(xd[i])
    from .. import compiled as C

    form.bound()(float(t), S, 0, m, float(tau), float(J_add), float(c_add), C.python_view(form.P))
    return S[m], tuple(S[m + 1:])


def _closed_model(mech):
    """MODEL(q, q̇, t, P) from the closed forms (Python only)."""
    def model_law(q, qd, t, P):
        J, dJ, dEp = mech.reduced(q)
        return float(J), 0.5 * float(dJ), float(dEp), float(mech.external_torque(q, qd, t))
    return model_law


def connect_site_pairs(model) -> list:
    """(site 1, site 2) ids of the model's site ``connect`` equalities (the loop closures)."""
    import mujoco

    return [(int(model.eq_obj1id[i]), int(model.eq_obj2id[i])) for i in range(model.neq)
            if model.eq_type[i] == mujoco.mjtEq.mjEQ_CONNECT and model.eq_objtype[i] == mujoco.mjtObj.mjOBJ_SITE]
