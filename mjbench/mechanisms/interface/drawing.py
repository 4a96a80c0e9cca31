"""Kinematics for plots and videos: named points in the plane, a traced point, how a video shows it."""
from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import ClassVar


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


class Drawing(abc.ABC):
    """What drawings and videos show of a mechanism (a part of :class:`~mjbench.mechanisms.base.Mechanism`)."""

    #: how a video shows it: "side" (linkage in its plane x-y) or "top" (rotary table from above)
    view: ClassVar[str] = "side"
    #: whether a video's frames take their pose from the recorded joints (``record_joints``) rather
    #: than from the input angle: a mechanism whose pose is more than q (a cam's follower off the cam)
    frames_from_joints: ClassVar[bool] = False

    @abc.abstractmethod
    def points(self, q) -> dict:
        """Named points of the mechanism in its plane, ``{name: (x, y)}`` [m], for drawings."""

    def trace_point(self, q):
        """(x, y) [m] of the point whose path a video traces (coupler point, slider ...)."""
        return None

    def draw_profile(self, ax) -> None:
        """Draw outlines the points do not give on a matplotlib axis (a cam's profile and pitch
        curve) in the design report's figure; default nothing."""

    def render_view(self) -> RenderView:
        """How a video shows this mechanism (default: the side view of a planar linkage)."""
        return RenderView(self.view, label=self.type_name)

