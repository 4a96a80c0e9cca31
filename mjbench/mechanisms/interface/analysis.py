"""Design analysis (``mjbench analyze``): the kinematics over input positions, through a linkage view;
a mechanism family's own analysis rows and run metrics."""
from __future__ import annotations

import abc

import numpy as np


class DesignAnalysis(abc.ABC):
    """What ``mjbench analyze`` asks of a mechanism (a part of :class:`~mjbench.mechanisms.base.Mechanism`)."""

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


    def analysis_rows(self, speeds, n: int) -> dict | None:
        """What ``mjbench analyze`` adds for this mechanism family beyond the linkage rows (a cam: the
        jump speed, pressure angle, curvature, contact force): a JSON-ready dict stored under
        ``analysis.json[type_name]`` (its ``"top"`` entries also at the top level); default none."""
        return None

    def metrics(self, trajectory, machine, config) -> dict | None:
        """Metric families the mechanism adds to every run's metrics (a cam's follower separation);
        default none."""
        return None
