"""design.json's parts shared by every duty (constant speed, a motion law): the check rows of the
verified predictions and the sizing summary."""
from __future__ import annotations

import math

import numpy as np


DRIVE_FIGURES = (("current_rms_A", "motor current RMS [A]"), ("current_peak_A", "motor current peak [A]"),
                 ("motor_torque_rms_Nm", "motor torque k_m·I RMS [N·m]"),
                 ("motor_torque_peak_Nm", "motor torque k_m·I peak [N·m]"),
                 ("gear_torque_rms_Nm", "gearbox output torque RMS [N·m]"),
                 ("gear_torque_peak_Nm", "gearbox output torque peak [N·m]"),
                 ("voltage_peak_V", "armature voltage peak [V]"))


def check_row(name: str, p, a, t, note: str = "") -> dict:
    """One entry of design.json's ``checks``: {name, predicted, achieved, rel_diff, tolerance, ok, note}."""
    rd = (a - p) / abs(p) if p else (math.inf if a else 0.0)
    return {"name": name, "predicted": p, "achieved": a, "rel_diff": rd, "tolerance": t, "ok": bool(abs(rd) <= t),
            "note": note}


def drive_checks(pred: dict, ach: dict, pred_th: dict, T_amb: float, tol: float, note: str) -> tuple[list, dict]:
    """The rows of :data:`DRIVE_FIGURES` (tolerance ``tol``) and, apart, the winding temperature rise's
    (twice ``tol``: it goes as the RMS current squared)."""
    rows = [check_row(name, pred[key], ach[key], tol, note) for key, name in DRIVE_FIGURES]
    temp = check_row("winding temperature rise [K] (two-node model)", pred_th["T_winding_C"] - T_amb,
                     ach["T_winding_C"] - T_amb, 2.0 * tol, "∝ RMS current²: twice the current tolerance")
    return rows, temp


def sizing_common(sz, load, figure: str) -> dict:
    """What design.json's ``sizing`` holds for every duty: the load model, the gear-ratio study (60
    of its points), every candidate (with its summary's ``figure``), the counts, the choice, timing."""
    sw = sz.sweep
    k = np.unique(np.linspace(0, len(sw["z"]) - 1, 60).astype(int))
    return {"load_model": {"J_mean": load.J_mean, "J_ptp": load.J_ptp, "affine_error": load.affine_error,
                           "nodes": load.n},
            "ratio_sweep": {"motor": (sz.chosen or sz.closest).motor.name, "z_best": sw["z_best"],
                            "rms_best_Nm": sw["rms_best_Nm"], "z_closed_form": sw["z_closed_form"],
                            "best_at_envelope_limit": sw["at_limit"],
                            "z": sw["z"][k].tolist(), "rms_Nm": sw["rms_Nm"][k].tolist(),
                            "peak_Nm": sw["peak_Nm"][k].tolist(), "allowed": sw["allowed"][k].tolist()},
            "candidates": [{"label": c.label, "ok": c.ok, "cost": c.cost, "violation": c.violation,
                            "screened_out": c.screened_out, "current_rms_A": c.summary.get("current_rms_A"),
                            figure: c.summary.get(figure),
                            "fails": [x["name"] for x in c.checks if not x["ok"]],
                            "tightest": tightest(c.checks)} for c in sz.candidates],
            "n_candidates": len(sz.candidates), "n_analysed": sum(not c.screened_out for c in sz.candidates),
            "n_feasible": sum(c.ok for c in sz.candidates),
            "chosen": sz.chosen.label if sz.chosen else None, "timing": sz.timing}


def tightest(checks) -> dict | None:
    """The check of a candidate with the least relative margin (limit − value)/limit (a bound ≥:
    (value − limit)/limit): {name, margin, value, limit, unit}; None without bounds."""
    best = None
    for c in checks or []:
        v, lim = c.get("value"), c.get("limit")
        if c.get("compare") not in ("max", "min") or not isinstance(v, (int, float)) or not lim:
            continue
        m = (lim - v) / abs(lim) if c["compare"] == "max" else (v - lim) / abs(lim)
        if math.isfinite(m) and (best is None or m < best["margin"]):
            best = {"name": c["name"], "margin": float(m), "value": float(v), "limit": float(lim),
                    "unit": c.get("unit", "")}
    return best
