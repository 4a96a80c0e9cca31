"""The multibody side of the mechanism interface: the MJCF model, its assembled state, its loads.

A mechanism builds its own ``mujoco.MjSpec`` (:func:`~.plane.new_spec`, the plane convention of
:mod:`.plane`) whose driven joint is :attr:`MultibodyModel.input_joint`, and gives the assembled
``qpos``/``qvel`` at an input angle and speed; optional loads on the MuJoCo tree
(:meth:`MultibodyModel.multibody_load`) and the loop-closure residual.
"""
from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np

from ...errors import ParameterError
from .plane import INPUT_JOINT, connect_site_pairs


class MultibodyModel(abc.ABC):
    """The MJCF model of a mechanism (a part of :class:`~mjbench.mechanisms.base.Mechanism`)."""

    #: name of the driven joint in the MJCF model
    input_joint: ClassVar[str] = INPUT_JOINT
    #: whether a run edits its compiled model every step (a cam's per-step equality,
    #: :mod:`mjbench.mechanisms.cam`): such a model is never shared between runs of a batch
    edits_model: ClassVar[bool] = False

    @property
    def input_joints(self) -> tuple:
        """The driven joints, one per axis, in axis order (one axis: :attr:`input_joint`; a mechanism
        with several inputs sets its own)."""
        return (self.input_joint,)

    def check_friction_joint(self, name: str) -> None:
        """ParameterError unless friction on joint ``name`` (``[drive.friction.joints]`` of a machine with
        several motors, :mod:`mjbench.drivetrain.axes`) is modelled for this mechanism (default: not)."""
        raise ParameterError(f"drive.friction.joints.{name}: friction on the joints of {type(self).__name__} with "
                             f"several motors is not modelled")

    @property
    def drive_joints(self) -> tuple:
        """The joints the drives' torques act on, one per axis: the input joints, or a motor's own
        hinge behind a compliant gear (:mod:`mjbench.drivetrain.gear`, :mod:`mjbench.drivetrain.axes`)."""
        if len(self.input_joints) == 1:
            return (getattr(self, "drive_joint", self.input_joint),)
        return tuple(self.input_joints)

    @property
    def n_inputs(self) -> int:
        """Number of driven inputs (axes)."""
        return len(self.input_joints)

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
        if type(self).closure_error is not MultibodyModel.closure_error or len(pairs) != model.neq:
            return None
        return tuple((3 * a + j, 3 * c + j) for a, c in pairs for j in range(3))

    def rigid_qpos(self, model, q):
        """``qpos`` at input q (several inputs: the vector) as the rigid mechanism has it — the pose the
        reduced model describes, where MuJoCo's model is compared with it (``mjbench.plausibility``).
        Default :meth:`initial_qpos`; a mechanism whose start pose is settled into MuJoCo's soft
        constraints (a cam: the deflection under the spring's load) returns the undeflected pose."""
        return self.initial_qpos(model, q)

    def model_at_pose(self, model, data) -> None:
        """Bring a model whose constraints are updated every step (:attr:`edits_model`: a cam's
        per-step equality) to the pose in ``data.qpos`` before it is evaluated outside a run
        (``mjbench.plausibility``); default nothing."""

    def multibody_load(self, model, data, t: float) -> None:
        """Write external loads of the mechanism into ``data.qfrc_applied`` (default none).
        ``qfrc_applied[input]`` already holds the drive torque: add to it, do not replace it."""

    def has_multibody_load(self) -> bool:
        """Whether :meth:`multibody_load` does anything (the backends skip the call if not)."""
        return type(self).multibody_load is not MultibodyModel.multibody_load

