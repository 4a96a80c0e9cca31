"""The whole linear study of a scenario's mode (``mjbench linearize``) and its plain-data form."""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from .controller import controller_counterpart, reference_gain, running_speed
from .family import frozen_angle_family, kp_ramp_limit
from .loop import analyse
from .plant import (
    _angle_mode, frequency_difference, frequency_grid, modes, multibody_plant, reduced_plant,
    transmission_modes)
from .point import operating_point
from .signals import _ct
from .steps import agree_above, rise_time, step_response
from .. import scenario as S
from ..kernel import control_every


# ============================================================================ JSON
def matrices(sys) -> dict:
    """The state-space matrices and signal names of a python-control system (plain lists)."""
    return {"A": np.asarray(sys.A).tolist(), "B": np.asarray(sys.B).tolist(), "C": np.asarray(sys.C).tolist(),
            "D": np.asarray(sys.D).tolist(), "dt": float(sys.dt) if sys.dt else 0.0,
            "states": list(sys.state_labels), "inputs": list(sys.input_labels), "outputs": list(sys.output_labels)}


def plain(o):
    """Plain Python data: complex → [re, im], NumPy → Python numbers and lists (non-finite floats
    kept: :func:`mjbench.outputs.write_json` writes them as null and lists them in ``_nonfinite``)."""
    if isinstance(o, dict):
        return {str(k): plain(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [plain(v) for v in o]
    if isinstance(o, np.ndarray):
        return plain(o.tolist())
    if isinstance(o, (complex, np.complexfloating)):
        return [float(o.real), float(o.imag)]
    if isinstance(o, (bool, np.bool_)):
        return bool(o)
    if isinstance(o, (int, np.integer)):
        return int(o)
    if isinstance(o, (float, np.floating)):
        return float(o)
    return o


def study(scn, mode=None, q=None, qd=None, I=None, t=None, n_angles=36, multibody=True) -> dict:
    """What ``mjbench linearize`` computes for a scenario: the plant (reduced and multibody) at
    the operating point and their agreement, modes, the loop and its margins, the frozen-angle
    family, the K_p·t stability limit.  Returns {"json": plain data for ``outputs.write_json``,
    "objects": the python-control objects, for the figures}.
    Defaults: q = the scenario's initial angle, q̇ = the running speed there, I = the current
    sustaining it on average over a turn (at rest: holding q̈ = 0), t = simulation.t_end for a K_p·t
    PID (the largest gain of the run), else 0."""
    mode = scn.mode(mode)
    mach = S.make_machine(scn, mode)
    h = float(scn.simulation.dt)
    ramp = bool(getattr(mach.controller, "kp_ramp", False))
    if t is None:
        t = float(scn.simulation.t_end) if ramp else 0.0
    if q is None:
        q = float(scn.initial.q0)
    if qd is None:
        qd = running_speed(mach, q)
    op = operating_point(mach, q, qd, I, t)
    angle = _angle_mode(None, op)
    objs = {"machine": mach, "op": op, "h": h}
    js = _plant_study(scn, mode, mach, op, h, angle, objs, multibody)
    closed = _loop_study(js, objs, mach, op, h, angle, ramp, t, n_angles)
    if n_angles and n_angles > 0:
        _angle_study(js, objs, mach, h, n_angles, t, angle, closed)
    return {"json": plain(js), "objects": objs}


def _limits_warnings(d, op) -> list:
    """Where the operating point needs more than the drive's voltage or current limit."""
    warn = []
    if math.isfinite(float(d.v_max)) and abs(op.V) > float(d.v_max):
        warn.append(f"the operating point needs V = {op.V:.4g} V > drive.v_max = {float(d.v_max):.4g} V: the limiter "
                    f"saturates there, the linear model does not apply")
    if math.isfinite(float(d.i_max)) and abs(op.I) > float(d.i_max):
        warn.append(f"the operating point needs I = {op.I:.4g} A > drive.i_max: current limited there")
    return warn


def _modal(sys) -> dict:
    return {**matrices(sys), "modes": [m.as_dict() for m in modes(sys)]}


def _plant_study(scn, mode, mach, op, h, angle, objs, multibody) -> dict:
    """The study's header and plants: the reduced plant (and its full Jacobian for a frozen angle),
    the co-step against the exact ZOH, the multibody plant in model and input coordinates, the
    transmission modes of an elastic machine."""

    ct = _ct()
    ctrl = mach.controller
    warn = _limits_warnings(mach.drive, op)
    red = reduced_plant(mach, op, angle=angle)
    red_full = reduced_plant(mach, op, angle="state")
    objs["plant_reduced"], objs["plant_reduced_full"] = red, red_full
    js = {"scenario": scn.name, "mode": mode, "controller": getattr(ctrl, "type_name", type(ctrl).__name__),
          "co_step_s": h, "control_period_s": control_every(ctrl, h) * h if getattr(ctrl, "type_name", "") != "open"
          else None, "operating_point": op.as_dict(), "angle_model": angle, "warnings": warn,
          "plant": {"reduced": _modal(red)}}
    if angle == "frozen":
        js["plant"]["reduced_full_jacobian"] = _modal(red_full)
    om = frequency_grid(None, 0.1, 400, min(1e4, 0.9 * math.pi / h))
    costep = reduced_plant(mach, op, h, angle=angle)
    js["agreement"] = {"costep_vs_exact_zoh": frequency_difference(ct.c2d(red, h, "zoh"), costep, frequency_grid(h))}
    if multibody:
        _multibody_study(js, objs, mach, op, scn.multibody_options(), angle, red_full, om)
    if mach.mechanism.internal:
        tm = transmission_modes(mach, op)
        js["transmission_modes"] = {k: [m.as_dict() for m in v] for k, v in tm.items()}
    return js


def _multibody_study(js, objs, mach, op, opts, angle, red_full, om) -> None:
    """The MuJoCo plant (model and input coordinates) and its agreement with the reduced one."""
    mb = multibody_plant(mach, op, opts)
    mbi = multibody_plant(mach, op, opts, coordinates="input")
    objs["plant_multibody"], objs["plant_multibody_input"] = mb, mbi
    objs["plant_multibody_loop"] = mbi if angle == "state" else multibody_plant(
        mach, op, opts, coordinates="input", angle=angle)
    js["plant"]["multibody"] = _modal(mb)
    js["plant"]["multibody_input_coordinates"] = _modal(mbi)
    js["agreement"]["reduced_vs_multibody_input_coordinates"] = frequency_difference(red_full, mbi, om)
    js["agreement"]["reduced_vs_multibody_model_coordinates"] = {
        **frequency_difference(red_full, mb, om), "agree_within_1pct_above_rad_s": agree_above(red_full, mb, om)}


def _loop_study(js, objs, mach, op, h, angle, ramp, t, n_angles) -> bool:
    """The loop at the point: margins, closed-loop modes, rise time, the K_p·t limit → whether the
    controller has a linear counterpart (else ``loop_note`` says why: plant only)."""

    ctrl = mach.controller
    try:
        controller_counterpart(mach, op, h, angle=angle)
    except ParameterError as e:  # e.g. SMC without a boundary layer: plant only
        js["loop_note"] = str(e)
        return False
    lp, mg = analyse(mach, op, h, angle=angle)
    objs["loop"], objs["margins"] = lp, mg
    js["loop"] = {**mg.as_dict(), "closed_loop_modes": [m.as_dict() for m in modes(lp.feedback)],
                  "reference_gain_1_s": reference_gain(ctrl, op.q),
                  "plant_sampled": matrices(lp.plant), "controller": matrices(lp.controller)}
    if lp.speed is not lp and lp.speed is not None:
        js["loop"]["speed_loop_modes"] = [m.as_dict() for m in modes(lp.speed.feedback)]
    tt = np.arange(0.0, 10.0 / mg.bandwidth_rad_s if math.isfinite(mg.bandwidth_rad_s) else 0.0,
                   control_every(ctrl, h) * h)
    sp = lp.speed or lp
    if len(tt) > 1 and float(np.max(np.abs(sp.feedback.poles()))) < 1.0:
        r = step_response(sp, tt, qd_set=1.0)
        js["loop"]["rise_time_90_s"] = rise_time(tt, r["qd"])
    if ramp:
        js["kp_ramp"] = {"t_s": t, "kp_eff": float(np.asarray(ctrl.gain_p(t))),
                         "limit": kp_ramp_limit(mach, h, min(24, int(n_angles)))}
    return True


def _angle_study(js, objs, mach, h, n_angles, t, angle, closed) -> None:
    """Over one turn: the frozen-angle family of the loop (closed loop), or the plant at each angle."""
    if closed:
        fam = frozen_angle_family(mach, h, n_angles, t=t)
        objs["family"] = fam
        js["frozen_angle"] = {"angles_rad": fam.angles, "speeds_rad_s": fam.speeds,
                              **{k: [getattr(m, a) for m in fam.margins] for k, a in
                                 (("gain_margin_dB", "gain_margin_dB"), ("phase_margin_deg", "phase_margin_deg"),
                                  ("peak_sensitivity", "Ms"), ("bandwidth_rad_s", "bandwidth_rad_s"),
                                  ("stable", "stable"))},
                              "worst": fam.worst, "validity": fam.validity}
        return
    qs = np.linspace(0.0, 2 * np.pi, int(n_angles), endpoint=False)
    objs["plant_family"] = (qs, [reduced_plant(mach, operating_point(mach, qq, running_speed(mach, qq), t=t),
                                               angle=angle) for qq in qs])
