"""Metrics of a constant-coupler-speed run (Hülako & Çakar 2025 §4-§5.1, Table 3).

The computations are the engine's (:func:`mjbench.metrics.coupler_tracking`, written by
``mjbench run`` into metrics.json whenever the controller tracks a ``coupler_speed`` reference);
this module keeps the paper-side helpers: the scenario's ``[metrics]`` settings and the
backend-to-backend comparison of the study script.  Definitions: docs/coupler_speed.md §4.
"""
from __future__ import annotations

import numpy as np

from mjbench.metrics import coupler_signals as signals  # noqa: F401  (re-exported for the plots)
from mjbench.metrics import coupler_tracking as compute  # noqa: F401

DEFAULTS = {"settle_time": 1.5, "band_rel": 0.10, "rise_fraction": 0.90, "crank_error_band": 0.1}


def settings(scn) -> dict:
    """The scenario's ``[metrics]`` settle_time, band_rel, rise_fraction, crank_error_band
    (defaults above where unset)."""
    mt = scn.metrics
    return {**DEFAULTS, **{k: getattr(mt, k) for k in DEFAULTS if getattr(mt, k, None) is not None}}


def from_run(scn, traj, machine) -> dict:
    """Metrics of a scenario run (settings from the scenario's [metrics] table)."""
    return compute(traj, machine.mechanism, machine.controller.reference, **settings(scn))


def compare_backends(ta, tb) -> dict:
    """Largest state differences between two trajectories on common samples (multibody vs reduced)."""
    n = min(ta.n, tb.n)
    return {"crank_angle_max_diff_rad": float(np.max(np.abs(ta.q[:n] - tb.q[:n]))),
            "crank_speed_max_diff_rad_s": float(np.max(np.abs(ta.qd[:n] - tb.qd[:n]))),
            "current_max_diff_A": float(np.max(np.abs(ta.current[:n] - tb.current[:n])))}
