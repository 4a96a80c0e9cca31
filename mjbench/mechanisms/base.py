"""The small interface every mechanism offers (seed 000 notation generalised).

A mechanism has one degree of freedom, the *input coordinate* ``q`` (the crank angle α of
seed 000, the motor-side platform angle of seeds 001/003 ...), driven through the gearbox by the
drive.  Everything a backend needs is here:

* reduced (Eksergian) dynamics, seed 000 Eq 5:
      ½ J'(q) q̇² + J(q) q̈ + E_p'(q) = T_c + Q_ext(q, q̇, t)
  ``reduced(q)`` returns (J, dJ/dq, dE_p/dq) and ``external_torque`` the extra generalised force;
* kinematics for plots / video (``points``) and the constraint residual (``closure_error``);
* an MJCF builder (``build_spec``) whose input joint is named ``INPUT_JOINT`` and carries the
  reflected drive inertia as ``armature``; ``initial_qpos`` assembles the model at q0;
* ``multibody_load(model, data, t)`` writes any external load into ``data.qfrc_applied``.

Subclasses implement the abstract methods.  All kinematic functions accept scalars or NumPy arrays.
"""
from __future__ import annotations

import abc

import numpy as np

INPUT_JOINT = "crank"  #: name of the driven joint in every generated MJCF model

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


def new_spec(name, options=None, gravity=(0.0, 0.0, -9.81), offscreen=(1920, 1080)):
    """An MjSpec with the options every mjbench model shares.

    ``options``: ``timestep`` [s] (default 1e-4), ``integrator`` (default RK4), ``iterations``,
    ``tolerance``.  Always: dense Jacobian (MuJoCo 4.0.0's sparse Cholesky is wrong on closed
    chains, upstream issue 3767), Newton solver, contacts off, energy computed, explicit inertials.
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
    opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    opt.iterations = int(o.get("iterations", 100))
    opt.tolerance = float(o.get("tolerance", 1e-12))
    opt.gravity = list(gravity)
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    spec.visual.global_.offwidth, spec.visual.global_.offheight = offscreen
    return spec


class Mechanism(abc.ABC):
    """Abstract single-DOF mechanism driven at its input coordinate q (rad)."""

    name: str = "mechanism"

    # --- reduced dynamics --------------------------------------------------------------------
    @abc.abstractmethod
    def reduced(self, q):
        """Return ``(J, dJ_dq, dEp_dq)``: equivalent inertia about q [kg·m²], its derivative
        [kg·m²/rad] and the derivative of the potential energy [N·m] (seed 000 Eqs 2-5)."""

    @abc.abstractmethod
    def potential_energy(self, q):
        """Gravitational (and elastic) potential energy E_p(q) [J]."""

    def kinetic_energy(self, q, qd):
        """E_k = ½ J(q) q̇² [J] (seed 000 Eq 2), mechanism only (no drive inertia)."""
        J, _, _ = self.reduced(q)
        return 0.5 * J * qd * qd

    def external_torque(self, q, qd, t):
        """Generalised external force on q [N·m] besides gravity and the drive (default 0)."""
        return 0.0 * q

    # --- multibody ---------------------------------------------------------------------------
    @abc.abstractmethod
    def build_spec(self, armature: float = 0.0, options=None):
        """Return a ``mujoco.MjSpec`` of the mechanism.  The driven joint is named
        ``INPUT_JOINT``; ``armature`` [kg·m²] is added to it (reflected drive inertia J_eq)."""

    @abc.abstractmethod
    def initial_qpos(self, model, q0: float) -> np.ndarray:
        """Full ``qpos`` vector of ``model`` with the loop assembled at input angle q0."""

    def input_from_qpos(self, model, qpos) -> float:
        """Input coordinate q from a multibody configuration (default: the input joint)."""
        return float(qpos[model.joint(INPUT_JOINT).qposadr[0]])

    def closure_error(self, model, data) -> float:
        """Largest loop-closure violation [m] in the multibody state: the equality-constraint
        residuals, which MuJoCo stores first (rows 0..ne-1) in ``efc_pos``."""
        ne = data.ne
        if ne == 0:
            return 0.0
        return float(np.abs(data.efc_pos[:ne]).max())

    def multibody_load(self, model, data, t: float) -> None:
        """Write external loads of the mechanism into ``data.qfrc_applied`` (default none)."""

    # --- kinematics for plots / video ----------------------------------------------------------
    @abc.abstractmethod
    def points(self, q) -> dict:
        """Named points of the mechanism in its plane, ``{name: (x, y)}`` [m], for drawings."""

    def trace_point(self, q):
        """(x, y) [m] of the point whose path a video traces (coupler point, slider ...)."""
        return None

    def describe(self) -> dict:
        """Parameters as a plain dict (for manifests)."""
        return {k: v for k, v in vars(self).items() if not k.startswith("_")}
