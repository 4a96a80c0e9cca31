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

The interface is written one concern per module (:mod:`mjbench.mechanisms.interface`):
:mod:`~.interface.plane` (the plane convention, the MJCF spec helpers), :mod:`~.interface.dynamics`
(reduced dynamics), :mod:`~.interface.multibody` (the MJCF model, loads, loop closure),
:mod:`~.interface.forms` (compiled forms), :mod:`~.interface.drawing` (points, videos),
:mod:`~.interface.analysis` (design analysis); :class:`Mechanism` joins them.  Every name is
importable from here as before.
"""
from __future__ import annotations

import abc
from typing import ClassVar

from .interface.analysis import DesignAnalysis
from .interface.drawing import Drawing, RenderView
from .interface.dynamics import ReducedDynamics
from .interface.forms import (CompiledForms, SitePairsP, _closed_model, accel_call, rigid_accel,  # noqa: F401
                              site_pairs_closure, table_form)
from .interface.multibody import MultibodyModel
from .interface.plane import (CLOSURE_SOLIMP, CLOSURE_TIMECONST_STEPS, HINGE_AXIS, INPUT_JOINT,  # noqa: F401
                              INTEGRATORS, PLANE_INDEX, SIDE_CAMERA, closure_solref, connect_site_pairs,
                              integrator_enum, mj_to_plane, new_spec, plane_to_mj, set_solver_options)


class Mechanism(ReducedDynamics, MultibodyModel, CompiledForms, Drawing, DesignAnalysis, abc.ABC):
    """Abstract single-input mechanism driven at its input coordinate q [rad]."""

    #: scenario ``[mechanism] type`` of this class (set by subclasses)
    type_name: ClassVar[str] = ""
    #: pydantic model of the ``[mechanism]`` table (a :class:`mjbench.schema.Strict` subclass)
    Params: ClassVar[type | None] = None

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

    def describe(self) -> dict:
        """Parameters as a plain dict (manifests, model cache keys)."""
        return {"type": self.type_name,
                **{k: v for k, v in vars(self).items() if not k.startswith("_")}}
