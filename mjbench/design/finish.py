"""The end of a design, for every duty: the tuned candidate accepted or not, the requirements table
(required vs achieved), the status and timing, the report written (:mod:`.report`)."""
from __future__ import annotations

import time

from . import report as RP
from . import thermal as TH
from .. import analyze as A


def accept_tuned(ctl, tuned, cand, how: str):
    """The tuned candidate if the sizing model accepts it, else the design rule's ``cand``;
    ``ctl["source"]`` says which (and which checks the tuned gains fail)."""
    if tuned.ok:
        ctl["source"] = f"tuned ({how}), accepted by the sizing model"
        return tuned
    ctl["source"] = ("design rule: the tuned gains fail the sizing model ("
                     + "; ".join(c["name"] for c in tuned.checks if not c["ok"]) + ")")
    return cand


def _clean_metrics(d):
    out = {}
    for k, v in (d or {}).items():
        if isinstance(v, dict):
            out[k] = {kk: vv for kk, vv in v.items() if isinstance(vv, (int, float, str, bool)) or vv is None}
    return out


# ============================================================================ requirements vs achieved
def _row(name, required, achieved, compare, unit="", source="", ok=None):
    if ok is None:
        if compare == "max":
            ok = achieved <= required * (1 + 1e-9)
        elif compare == "min":
            ok = achieved >= required * (1 - 1e-9)
        elif compare == "eq":
            ok = abs(achieved - required) <= 1e-6 * max(1.0, abs(required))
        else:
            ok = bool(achieved)
    if compare == "max" and required:
        margin = (required - achieved) / abs(required)
    elif compare == "min" and required:
        margin = (achieved - required) / abs(required)
    elif compare == "eq" and required:
        margin = -abs(achieved - required) / abs(required)
    else:
        margin = None
    return {"name": name, "required": required, "achieved": achieved, "compare": compare, "unit": unit,
            "margin": margin, "ok": bool(ok), "source": source}


def requirements_table(req, syn, scn, cand, ach, syn_json) -> list:
    """Every requirement with the achieved value (kinematics: mjbench.analyze on the machine,
    i.e. mjbench's own position solver; drive: the multibody run) and its margin."""

    an = A.analyze(scn, speeds=[req.duty.omega], n=720)
    rows = req.mechanism.requirement_rows(req, syn, an, syn_json, ach, _row)
    if ach is not None:
        rows += _drive_rows(req, cand, ach)
    return rows


def _drive_rows(req, cand, ach) -> list:
    """The drive's requirements against the multibody run's last cycle (speed, χ, motor and gearbox
    ratings, winding temperature, supply, current limit, flywheel)."""
    rows = []
    src = "multibody run, last cycle"
    W = req.duty.omega
    rows.append(_row("mean input speed", W, ach["mean_speed_rad_s"], "eq", "rad/s", src,
                     ok=abs(ach["mean_speed_rad_s"] - W) <= req.verify.tolerance * W))
    if req.duty.chi_max is not None:
        rows.append(_row("speed fluctuation χ", req.duty.chi_max, ach["chi"], "max", "1", src))
    mo, g = cand.motor, cand.gearbox
    T_amb = req.duty.ambient_temperature
    rows += [
        _row("RMS motor torque ≤ continuous rating", TH.derated_continuous_torque(mo, T_amb),
             ach["motor_torque_rms_Nm"], "max", "N·m", src),
        _row("peak motor torque ≤ T_peak", mo.T_peak, ach["motor_torque_peak_Nm"], "max", "N·m", src),
        _row("winding temperature ≤ T_max", mo.T_max, ach["T_winding_C"], "max", "°C",
             "two-node model on the simulated current"),
        _row("armature voltage ≤ supply", req.drive.supply_voltage, ach["voltage_peak_V"], "max", "V", src),
        _row("motor speed ≤ maximum", mo.speed_max, ach["motor_speed_max_rad_s"], "max", "rad/s", src)]
    if req.drive.current_limit is not None:
        rows.append(_row("current ≤ amplifier limit", req.drive.current_limit, ach["current_peak_A"], "max", "A", src))
    if g is not None:
        rows += [_row("gearbox output torque RMS ≤ T_cont_out", g.T_cont_out, ach["gear_torque_rms_Nm"], "max", "N·m", src),
                 _row("gearbox output torque peak ≤ T_peak_out", g.T_peak_out, ach["gear_torque_peak_Nm"], "max",
                      "N·m", src),
                 _row("gearbox input speed ≤ maximum", g.speed_max_in, ach["motor_speed_max_rad_s"], "max", "rad/s", src)]
    if cand.J_f > 0 and req.drive.flywheel_max is not None:
        rows.append(_row("flywheel ≤ flywheel_max", req.drive.flywheel_max, cand.J_f, "max", "kg·m²", "sizing"))
    return rows


def _finish(res, req, failures, scn_doc, clock, t0c, t0w, out, force, log):
    res["status"] = "ok" if not failures else "infeasible"
    res["failures"] = failures
    t = dict(clock.t)
    syn_size = sum(t.get(k, {}).get("cpu_s", 0.0) for k in ("synthesis", "solver_check", "sizing"))
    res["timing"] = {**t, "synthesis_and_sizing_cpu_s": syn_size, "total_cpu_s": time.process_time() - t0c,
                     "total_wall_s": time.perf_counter() - t0w}
    if out is not None:
        res["files"] = RP.write(res, out, scn_doc, force=force)
    log(RP.summary_text(res))
    return res
