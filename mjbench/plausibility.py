"""Plausibility flags in metrics.json: results that are computed fine but should not be trusted.

Backends agreement
------------------
When a mode runs on both backends, the multibody (MuJoCo) and reduced (Eksergian J(α)) crank
speeds are compared (``metrics.compare``: max |difference| over the run, divided by the peak
|crank speed| of the reduced run).  They model the same machine with the same drive and
controller, so they must agree: on every built-in scenario and mode the difference is at most
1.3e-5 of the peak (incerti2012 open loop; 1e-7 to 2e-6 for the other machines).

:data:`BACKENDS_TOLERANCE` = 1e-3 of the peak (over 70 times the largest healthy difference).
Above it, ``metrics.json`` holds ``"plausibility": {"backends_agree": false, ...}`` and
``mjbench run`` prints a warning on stderr: one of the models is then outside its validity range
(e.g. ``--set modes.pid.kd=1e3`` on incerti2012: 178 % of the peak, a loop that is unstable at the
control period), and neither trajectory should be used without checking why.
"""
from __future__ import annotations

import math

BACKENDS_TOLERANCE = 1e-3  #: max |multibody − reduced| crank speed / peak |crank speed|


def backends(compare: dict) -> dict:
    """The ``plausibility`` entry of a mode's metrics from its ``multibody_vs_reduced`` entry."""
    mx = compare.get("max_rel_diff")
    agree = mx is not None and math.isfinite(mx) and mx <= BACKENDS_TOLERANCE
    out = {"backends_agree": bool(agree), "max_rel_diff": mx, "tolerance": BACKENDS_TOLERANCE,
           "column": compare.get("column", "crank_speed_rad_s"),
           "normalisation": compare.get("normalisation", "peak |reference| over the run")}
    if not agree:
        out["note"] = ("the multibody and reduced models of the same machine disagree: at least one is "
                       "outside its validity range (unstable loop at the control period, step too large, "
                       "non-physical parameters); do not use these trajectories without finding out why")
    return out


def warnings_of(res: dict) -> list:
    """Warning lines for the CLI from a mode's metrics dict (runner.mode_metrics)."""
    p = res.get("plausibility")
    if not p or p.get("backends_agree", True):
        return []
    mx = p.get("max_rel_diff")
    mx_txt = "not finite" if mx is None or not math.isfinite(mx) else f"{100 * mx:.3g} % of the peak"
    return [f"multibody and reduced crank speeds differ by {mx_txt} (tolerance "
            f"{100 * p['tolerance']:g} %): the results are not plausible; metrics.json has "
            f"\"plausibility\": {{\"backends_agree\": false}}"]
