"""``mjbench design``: requirements → linkage → drive → gains → verified machine.

Stages (each timed; docs/design.md):

1. **requirements** (:mod:`requirements`): validated, one message, exit 2;
2. **synthesis** (:mod:`synthesis`): the linkage from the task, its constraints, then the
   ``[mechanism] type = "linkage"`` table (:mod:`build`) solved by mjbench's own position solver
   (:func:`mjbench.mechanisms.linkage.compiled`) and compared with the synthesis at its
   precision positions (:mod:`solver_check`);
3. **sizing** (:mod:`sizing`): inverse dynamics at the duty, energy swing, flywheel, every
   catalogue motor × gearbox through the periodic steady state of the speed loop, ratings,
   thermal model, gear-ratio study; the cheapest feasible candidate;
4. **control** (:mod:`control`): the design rule's gains, then ``mjbench.tune`` within the box of
   gains the sizing model accepts; the tuned gains re-checked by the sizing model;
5. **verification**: the machine simulated on the multibody backend from the predicted steady
   state; every predicted figure compared (``checks``); the requirements against the achieved
   values (kinematics by ``mjbench.analyze``, the rest from the simulation);
6. **outputs** (:mod:`report`): ``machine.toml``, ``design.json``, ``design.md``, ``design.html``,
   ``design.png``.

A design that meets its requirements returns status ``"ok"`` (exit 0); otherwise ``"infeasible"``
(exit 1) with the closest candidate and every failing constraint or check.
"""
from __future__ import annotations

import math
import os
import time

import numpy as np

from . import control as CT
from . import periodic as P
from . import sizing as SZ
from . import thermal as TH
from .requirements import Requirements
from .finish import _clean_metrics, _finish, _row, accept_tuned, requirements_table  # noqa: F401
from .checks import DRIVE_FIGURES, check_row, drive_checks, sizing_common  # noqa: F401 - design.json's shared parts
from .solver_check import solver_check
from .synthesis import constraint
from .. import scenario as SC
from .. import metrics as M
from ..outputs import check_out_dir
from . import law_duty
from . import catalogue as CAT
from .requirements import load as load_req
from .. import mechanisms as MR
from ..errors import ParameterError
from ..backends import simulate
from ..runner import backend_options

TWO_PI = 2.0 * math.pi
#: longest verification run [cycles]
MAX_CYCLES = 60


class Clock:
    def __init__(self):
        self.t = {}

    def __call__(self, name):
        clock = self

        class _C:
            def __enter__(self):
                self.c, self.w = time.process_time(), time.perf_counter()

            def __exit__(self, *exc):
                clock.t[name] = {"cpu_s": time.process_time() - self.c, "wall_s": time.perf_counter() - self.w}
                return False

        return _C()


# ============================================================================ synthesis
def synthesize(req: Requirements):
    """(Synthesis or None for a given mechanism, [mechanism] table, geometry or None): the requirement
    type's own synthesis (:meth:`~.requirements._MechBase.synthesize`, a cam's in design/cam.py)."""
    return req.mechanism.synthesize(req)


# ============================================================================ scenario
def _pose_beyond_q(table) -> bool:
    """Whether the mechanism's pose is more than its input angle (its class's ``frames_from_joints``:
    a cam's follower may leave the cam): its runs record the joints its metrics read."""
    cls = MR.get(table.get("type"))
    return bool(cls is not None and cls.frames_from_joints)


def machine_scenario(req, table, cand, gains: P.Gains, init: dict, speed: float, t_end: float, title="") -> dict:
    """The machine's scenario tables (machine.toml)."""
    dm = cand.drive
    m = cand.motor
    i_max = min(x for x in (req.drive.current_limit, m.T_peak / m.k_m) if x is not None)
    T = TWO_PI / speed
    drive = dm.as_drive_table(v_max=float(req.drive.supply_voltage), i_max=float(i_max))
    return {
        "scenario": {"name": req.name, "title": title or req.design.title or f"designed machine {req.name}",
                     "description": (req.design.description + " " if req.design.description else "")
                     + "Written by `mjbench design`: synthesised linkage, catalogue motor and gearbox, flywheel, "
                       "tuned speed PID; starts from rest, its last cycle is the verified steady state."},
        "mechanism": table,
        "drive": drive,
        "initial": {"q0": 0.0, "qd0": 0.0, "I0": 0.0},
        "simulation": {"t_end": float(t_end), "dt": float(req.verify.dt), "record_dt": _record_dt(req.verify.dt, T),
                       "mode": "pi", "backend": "both",
                       **({"record_joints": True} if _pose_beyond_q(table) else {})},  # a cam's follower gap
        "modes": {"pi": {"type": "pid", "kp": float(gains.kp), "ki": float(gains.ki), "kd": float(gains.kd),
                         "omega0": float(dm.z * speed), "v_limit": float(req.drive.supply_voltage)},
                  "open": {"type": "open", "voltage": float(min(req.drive.supply_voltage,
                                                                cand.summary.get("voltage_mean_V", 0.0) or 1.0))}},
        "metrics": {"chi_window": [float(t_end - T), float(t_end)], "steady_start": float(max(0.0, t_end - T))},
    }


def start_up_time(dm, M_mean, T_load_mean, speed, i_lim, V) -> float:
    """Time to reach the speed from rest [s], accelerating with the current limited to i_lim and the
    voltage to V (the torque falls with the back-EMF; the mean load opposes): ∫ M dω / T_net."""
    w = np.linspace(0.0, speed, 200)
    I = np.minimum(i_lim, (V - dm.k_m * dm.z * w) / dm.R)
    T_net = dm.z * dm.eta * (dm.k_m * I - dm.T0) - dm.c_v * w - max(T_load_mean, 0.0)
    if np.any(T_net <= 0):
        return math.inf
    return float(np.trapezoid(M_mean / T_net, w))


def _record_dt(dt, T):
    k = max(1, int(round(T / 2000.0 / dt)))
    return float(k * dt)


# ============================================================================ verification
def measure(tr, dm: SZ.DriveModel, speed, motor, T_amb) -> dict:
    """Figures of the last complete crank cycle of a trajectory (the predicted ones' counterparts)."""

    t, q, om = tr.t, tr.q, tr.omega
    cyc = M.cycles(t, q)
    if not len(cyc):
        raise P.NoSteadyState("the verification run holds no complete crank cycle")
    a, b = cyc[-1]
    sel = (t >= a - 1e-12) & (t <= b + 1e-12)
    I, V, wm, qd = tr.current[sel], tr.voltage[sel], om[sel], tr.qd[sel]
    tt = t[sel]

    def rms(x):
        return float(np.sqrt(np.trapezoid(np.asarray(x) ** 2, tt) / (tt[-1] - tt[0])))

    Tg = dm.gear_output_of_run(I, wm, tr.qdd[sel])
    out = {"cycle_s": [float(a), float(b)], "current_rms_A": rms(I), "current_peak_A": float(np.max(np.abs(I))),
           "motor_torque_rms_Nm": dm.k_m * rms(I), "motor_torque_peak_Nm": dm.k_m * float(np.max(np.abs(I))),
           "gear_torque_rms_Nm": rms(Tg), "gear_torque_peak_Nm": float(np.max(np.abs(Tg))),
           "gear_work_per_cycle_J": float(np.trapezoid(Tg * qd, tt)),
           "voltage_peak_V": float(np.max(np.abs(V))), "chi": float(M.chi(t, om, a, b)),
           "speed_dev_max_rel": float(np.max(np.abs(qd - speed)) / speed),
           "mean_speed_rad_s": float(M.time_mean(tt, qd)), "motor_speed_max_rad_s": float(np.max(np.abs(wm))),
           "closure_max_m": float(np.max(np.abs(tr.closure[sel]))) if tr.has("closure_error_m") else 0.0}
    th = TH.steady(rms(I) ** 2, motor, T_amb)
    out["T_winding_C"] = th["T_winding_C"]
    return out


def periodicity(tr) -> float:
    """Relative difference of the RMS current and of the mean speed between the last two complete
    cycles (0: periodic steady state reached)."""

    cyc = M.cycles(tr.t, tr.q)
    if len(cyc) < 2:
        return math.inf
    v = []
    for a, b in cyc[-2:]:
        sel = (tr.t >= a) & (tr.t <= b)
        v.append((math.sqrt(float(np.mean(tr.current[sel] ** 2))), float(np.mean(tr.qd[sel]))))
    return max(abs(v[1][0] - v[0][0]) / max(abs(v[1][0]), 1e-12), abs(v[1][1] - v[0][1]) / abs(v[1][1]))


def start_up(tr, speed) -> dict:
    """Start from rest: time to 98 % of the speed, largest current and its time."""
    k = np.flatnonzero(tr.qd >= 0.98 * speed)
    i = int(np.argmax(np.abs(tr.current)))
    return {"time_to_98pct_s": float(tr.t[k[0]]) if len(k) else math.inf,
            "peak_current_A": float(abs(tr.current[i])), "t_peak_current_s": float(tr.t[i])}


#: the drive's figures every design verifies: (key in the prediction and in the run's figures, name)
def checks_of(pred: dict, ach: dict, chi_stmt: dict, pred_th: dict, T_amb: float, tol: float) -> list:
    """{name, predicted, achieved, rel_diff, tolerance, ok} for every verified prediction."""
    out, temp = drive_checks(pred, ach, pred_th, T_amb, tol, "harmonic balance of the reduced model vs the multibody run")
    out.append(check_row("speed fluctuation χ (harmonic balance)", pred["chi"], ach["chi"], tol,
                         "periodic steady state of the speed loop"))
    out.append(check_row("largest speed deviation |q̇ − Ω|/Ω", pred["speed_dev_max_rel"], ach["speed_dev_max_rel"], tol))
    out.append(check_row("speed fluctuation χ (energy method, flywheel sizing)", chi_stmt["chi_energy"], ach["chi"],
                         chi_stmt["tolerance"], f"stated error bound: loop {chi_stmt['error_loop']:.3g} + inertia "
                         f"variation {chi_stmt['error_J']:.3g} + second order {chi_stmt['error_second_order']:.3g}"))
    return out + [temp]


# ============================================================================ the command
def design(requirements, out=None, force=False, log=print, verify=True, tune=None) -> dict:
    """Run the whole design (module doc).  ``requirements``: a path, a built-in name or a
    :class:`Requirements`; ``out``: folder for the outputs (written whole or not at all).
    Returns the result dict (also design.json); ``result["status"]`` is "ok" or "infeasible"."""
    clock = Clock()
    t0c, t0w = time.process_time(), time.perf_counter()
    req, cat = _requirements(requirements, clock)
    if out is not None:  # an unusable --out is an error before any work
        check_out_dir(out, force=force)
    res = _result_head(req, cat)

    def finish(failures, scn_doc=None):
        return _finish(res, req, failures, scn_doc, clock, t0c, t0w, out, force, log)

    syn, table, failures = _synthesis_stage(req, res, clock)
    if failures:
        return finish(failures)
    if req.duty.law is not None:  # the crank follows a motion law per cycle: mjbench/design/law_duty.py

        return law_duty.design(req, res, syn, table, cat, clock, t0c, t0w, out, force, log, verify=verify, tune=tune)
    speed = req.duty.omega
    load, sz, failures, stop = _sizing_stage(req, cat, table, speed, res, clock, log)
    if stop:
        return finish(failures)
    cand = sz.chosen
    log(f"chosen: {cand.label}; RMS motor torque {cand.summary['motor_torque_rms_Nm']:.4g} N·m, "
        f"χ {cand.summary['chi']:.4g}")
    # ---------------------------------------------------------------- control
    T = TWO_PI / speed
    M_mean = load.J_mean + cand.drive.J_eq
    i_lim = min(x for x in (req.drive.current_limit, cand.motor.T_peak / cand.motor.k_m) if x is not None)
    t_acc = start_up_time(cand.drive, M_mean, sz.torque["T_mean_Nm"], speed, i_lim, req.drive.supply_voltage)
    if not math.isfinite(t_acc):
        failures.append(dict(constraint("the drive starts the machine from rest (torque at the current limit > "
                                        "mean load up to the speed)", False, compare="true"), stage="sizing"))
        res["closest"] = cand.describe()
        return finish(failures)
    runs = _RunLength(req, cand.drive, M_mean, t_acc, T)
    final, ctl = _control_stage(req, table, cand, load, speed, runs, req.control.tune if tune is None else tune, clock)
    chi_stmt, init, t_end = _prediction(res, ctl, final, load, sz, speed, M_mean, runs, t_acc)

    scn_doc = machine_scenario(req, table, final, final.gains, init, speed, t_end)
    scn = SC.from_raw(scn_doc, f"design:{req.name}")
    res["machine"] = scn_doc
    # ---------------------------------------------------------------- verification
    ach, trs = None, {}
    if verify:
        scn_doc, scn, ach, trs = _verification(req, res, table, final, init, speed, t_end, runs, scn_doc, scn,
                                               clock)
        res["checks"] = checks_of(final.summary, ach, chi_stmt, final.thermal, req.duty.ambient_temperature,
                                  req.verify.tolerance)
        failures += [dict(constraint(f"check: {c['name']}", c["achieved"], compare="true", ok=False,
                                     note=f"predicted {c['predicted']:.6g}, rel. diff {c['rel_diff']:+.3g} > "
                                          f"{c['tolerance']:.3g}"), stage="verification")
                     for c in res["checks"] if not c["ok"]]
    with clock("analysis"):
        res["requirements_table"] = requirements_table(req, syn, scn, final, ach, res.get("synthesis", {}))
    failures += [dict(r, stage="requirements") for r in res["requirements_table"] if r["ok"] is False]
    res["_trajectories"] = trs
    res["_sizing"] = sz
    res["_final"] = final
    return finish(failures, scn_doc)


def _requirements(requirements, clock):
    """(Requirements, the catalogue's selected motors and gearboxes): stage "requirements"."""

    with clock("requirements"):
        req = requirements if isinstance(requirements, Requirements) else load_req(str(requirements))
        cat = CAT.select(CAT.load(req.drive.catalogue, base=os.path.dirname(req.source)
                                  if req.source and not req.source.startswith("builtin:") else ""),
                         req.drive.motors, req.drive.gearboxes)
    return req, cat


def _result_head(req, cat) -> dict:
    """The result's first entries: the requirements, the catalogue, the duty."""
    res = {"name": req.name, "title": req.design.title, "requirements_source": req.source,
           "requirements": req.raw, "catalogue": {"source": cat.source, "title": cat.title,
                                                  "illustrative": cat.illustrative}}
    speed = req.duty.omega
    res["duty"] = {"speed_rad_s": speed, "speed_rpm": speed * 30 / math.pi, "cycle_s": TWO_PI / speed,
                   "chi_max": req.duty.chi_max, "ambient_C": req.duty.ambient_temperature}
    return res


def _synthesis_stage(req, res, clock):
    """Stages "synthesis" and "solver_check" → (Synthesis or None, [mechanism] table, failures);
    ``res`` gets ``synthesis``, ``mechanism`` and ``_geometry``."""
    failures = []
    with clock("synthesis"):
        syn, table, geom = synthesize(req)
        if syn is not None:
            res["synthesis"] = {"kind": syn.kind, "targets": syn.targets, "achieved": syn.achieved,
                                "constraints": syn.constraints,
                                "info": {k: v for k, v in syn.info.items() if k != "spec"}}
            failures += [dict(c, stage="synthesis") for c in syn.failures()]
        else:
            res["synthesis"] = {"kind": "given", "scenario": req.mechanism.scenario}
    if syn is not None:
        with clock("solver_check"):
            try:
                own = getattr(syn, "check", None)  # a cam re-checks itself as the mechanism mjbench builds
                res["synthesis"]["solver_check"] = own(table) if own else solver_check(syn, table)
            except Exception as e:  # noqa: BLE001 - a linkage the solver cannot follow is a failure, reported
                text = "; ".join(x.strip() for x in str(e).splitlines() if x.strip())  # one line
                text = text if len(text) <= 400 else text[:397] + "..."
                res["synthesis"]["solver_check"] = {"error": text}
                failures.append(dict(constraint("mjbench's position solver follows the linkage over a turn", False,
                                                compare="true", note=text), stage="synthesis"))
    res["mechanism"] = table
    res["_geometry"] = geom
    return syn, table, failures


def _sizing_stage(req, cat, table, speed, res, clock, log):
    """Stage "sizing" → (load model, Sizing, failures, stop): ``stop`` when no candidate is chosen
    (``res["closest"]``: the closest one, its failing checks in ``failures``)."""

    failures = []
    with clock("sizing"):
        mech = MR.from_dict(table)
        if mech.internal or getattr(getattr(mech, "_tab", None), "lo", None) is not None:

            raise ParameterError(f"mechanism {table.get('type')!r}: the design sizes rigid machines whose input turns "
                                 f"fully (internal elastic coordinates or a slide input are not supported)")
        load = SZ.LoadModel(mech, speed)
        sz = SZ.size(load, req, cat, speed, log=log)
        best = sz.chosen or sz.closest
        if best.gains is not None and not best.screened_out:
            if sz.chosen is None:
                SZ.refine_closest(best, lambda: SZ.finalize(best, load, req, speed))
            else:
                SZ.finalize(best, load, req, speed)
    res["sizing"] = _sizing_json(sz, load)
    if sz.chosen is None:
        failures += [dict(c, stage="sizing", candidate=best.label) for c in best.checks if not c["ok"]]
        res["closest"] = best.describe()
        return load, sz, failures, True
    cand = sz.chosen
    if not cand.ok:  # the full-resolution steady state disagrees with the screening one
        failures += [dict(c, stage="sizing", candidate=cand.label) for c in cand.checks if not c["ok"]]
        res["closest"] = cand.describe()
        return load, sz, failures, True
    return load, sz, failures, False


class _RunLength:
    """Lengths of the verification runs: whole cycles of period T covering the start from rest (at
    the current limit, ``t_acc``) and the loop's settling, plus the cycles asked, on the recording
    grid."""

    def __init__(self, req, drive, M_mean, t_acc, T):
        self.req, self.drive, self.M_mean, self.t_acc, self.T = req, drive, M_mean, t_acc, T

    def __call__(self, gains):
        """(t_end [s], the loop's settling time [s]) for ``gains``."""
        ts = CT.settling_time(self.drive, self.M_mean, gains)
        n = self.req.verify.cycles + math.ceil((self.t_acc + (ts if math.isfinite(ts) else 0.0)) / self.T)
        return self.on_record_grid(min(n, MAX_CYCLES) * self.T), ts

    def on_record_grid(self, t):
        """t rounded up to the recording grid (the last sample falls on t_end: the χ window's end)."""
        rdt = _record_dt(self.req.verify.dt, self.T)
        return math.ceil(t / rdt - 1e-9) * rdt


def _control_stage(req, table, cand, load, speed, runs, do_tune, clock):
    """Stage "tuning" → (the final candidate, the ``control`` entry so far): the design rule's
    gains, the box of gains the sizing model accepts, then ``mjbench.tune`` within it (when
    ``do_tune``); the tuned gains kept only if the sizing model accepts them."""
    g0 = cand.gains
    ctl = {"design_rule": {"gains": g0.as_dict(), "crossover_rad_s": req.control.bandwidth_ratio * speed,
                           "zero_ratio": CT.ZERO_RATIO}}
    final = cand
    with clock("tuning"):
        box, scan = _gain_box(cand, load, req, speed)
        SZ.finalize(cand, load, req, speed)  # with the design rule's small K_d (the tuning's start)
        ctl["box"] = {k: list(v) for k, v in box.items()}
        ctl["box_scan"] = scan
        if do_tune:
            final = _tuned(req, table, cand, load, speed, runs, box, ctl)
        else:
            ctl["source"] = "design rule ([control] tune = false)"
    return final, ctl


def _tuned(req, table, cand, load, speed, runs, box, ctl):
    """``mjbench.tune`` from the candidate's gains within ``box`` (``ctl``: ``tune``, ``source``) →
    the tuned candidate if the sizing model accepts it, else ``cand``."""

    g0 = cand.gains
    t_end, _ = runs(g0)
    init0 = P.initial_state(cand.ss)
    scn0 = SC.from_raw(machine_scenario(req, table, cand, g0, init0, speed, t_end), f"design:{req.name}")
    i_lim = scn0.drive.i_max
    try:
        tr = CT.tune_gains(scn0, req, g0, box, t_end, {"voltage": float(req.drive.supply_voltage),
                                                       "current": float(i_lim)}, log=None)
        gt = P.Gains(tr.best["kp"], tr.best["ki"], tr.best["kd"])
        ctl["tune"] = {"best": tr.best, "baseline": tr.baseline, "objective": tr.objective,
                       "search": _clean_metrics(tr.search), "validation": _clean_metrics(tr.validation),
                       "evaluations": tr.history.get("evaluations"), "at_bound": tr.history.get("at_bound"),
                       "seconds": tr.history.get("seconds"), "margins": [list(m) for m in tr.margins]}
        tuned = SZ.Candidate(cand.motor, cand.gearbox, cand.drive, cand.J_f, gt, location=cand.location,
                             cost=cand.cost)
        SZ.finalize(tuned, load, req, speed)
        return accept_tuned(ctl, tuned, cand, "mjbench.tune")
    except Exception as e:  # noqa: BLE001 - tuning trouble keeps the design rule, reported
        ctl["source"] = f"design rule: tuning failed ({type(e).__name__}: {e})"
    return cand


def _prediction(res, ctl, final, load, sz, speed, M_mean, runs, t_acc):
    """The final gains' loop figures into ``ctl`` (then ``res["control"]``), the predicted figures
    (``res["prediction"]``, ``res["chosen"]``) → (χ statement, initial state, run length)."""
    gains = final.gains
    ctl["final"] = gains.as_dict()
    ctl["crossover_rad_s"] = CT.crossover(final.drive, M_mean, gains)
    poles = CT.closed_loop_poles(final.drive, M_mean, gains)
    ctl["closed_loop_poles"] = [[float(p.real), float(p.imag)] for p in poles]
    ctl["slowest_decay_1_s"] = float(-max(p.real for p in poles))
    chi_stmt = SZ.chi_energy_statement(final, load, sz.torque["dE_J"], speed, sz.T_L)
    init = P.initial_state(final.ss)
    t_end, t_settle = runs(gains)
    ctl["settling_time_s"] = t_settle
    ctl["start_up_time_s"] = t_acc
    res["control"] = ctl
    res["prediction"] = {**final.summary, "thermal": final.thermal, "chi_energy": chi_stmt,
                         "initial_state": init, "harmonic_balance": {"samples": final.ss["n"],
                                                                     "iterations": final.ss["iterations"],
                                                                     "residual": final.ss["residual"],
                                                                     "phase_lag_rad": final.ss["c0"]}}
    res["chosen"] = final.describe()
    return chi_stmt, init, t_end


def _verification(req, res, table, final, init, speed, t_end, runs, scn_doc, scn, clock):
    """Stage "verification": the machine (``scn_doc``, ``scn``: run length ``t_end``) on the multibody
    backend from the predicted steady state, longer runs (up to MAX_CYCLES) until its last two
    cycles agree → (scenario doc, scenario, achieved figures, {"multibody": trajectory}); ``res``:
    ``machine`` (a longer run), ``verification``."""

    T = runs.T
    with clock("verification"):
        for attempt in range(4):
            tr = simulate(SC.make_machine(scn), "multibody", t_end, record_dt=scn.simulation.record_dt,
                          options=backend_options(scn, "multibody"))
            ach = measure(tr, final.drive, speed, final.motor, req.duty.ambient_temperature)
            ach.update(SC.make_mechanism(scn).metrics(tr, None, None) or {})  # a cam's follower on the cam
            drift = periodicity(tr)
            if drift <= 0.05 * req.verify.tolerance or t_end >= MAX_CYCLES * T - 1e-9:
                break
            t_end = runs.on_record_grid(min(MAX_CYCLES, 2 * round(t_end / T)) * T)  # not settled yet: a longer run
            scn_doc = machine_scenario(req, table, final, final.gains, init, speed, t_end)
            scn = SC.from_raw(scn_doc, f"design:{req.name}")
            res["machine"] = scn_doc
        ach["start_up"] = start_up(tr, speed)
    res["verification"] = {"backend": "multibody", "t_end_s": t_end, "achieved": ach,
                           "last_two_cycles_rel_diff": drift, "loop": tr.meta.get("loop", "")}
    return scn_doc, scn, ach, {"multibody": tr}


def _gain_box(cand, load, req, speed):
    """Gains the sizing model accepts around the design rule: crossovers ×/÷ 4 (9 points), each
    checked by its periodic steady state; the box spans the accepted ones (at least ×/÷ 1.25), with
    K_i not below the design rule's (a settling-time constraint: the integral — the slowest mode —
    no slower than the design rule's)."""
    M_mean = load.J_mean + cand.drive.J_eq
    w0 = req.control.bandwidth_ratio * speed
    scan, ok = [], []
    for f in np.geomspace(0.25, 4.0, 9):
        g = CT.design_gains(cand.drive, M_mean, w0 * f)
        c = SZ.Candidate(cand.motor, cand.gearbox, cand.drive, cand.J_f, g, location=cand.location)
        SZ.evaluate(c, load, req, speed)
        scan.append({"crossover_rad_s": w0 * f, "gains": g.as_dict(), "ok": c.ok,
                     "chi": c.summary.get("chi"), "current_rms_A": c.summary.get("current_rms_A"),
                     "fails": [x["name"] for x in c.checks if not x["ok"]]})
        if c.ok:
            ok.append(g)
    g0 = cand.gains
    kp = [g.kp for g in ok] or [g0.kp]
    ki = [g.ki for g in ok] or [g0.ki]
    lo_p, hi_p = min(min(kp), g0.kp / 1.25), max(max(kp), g0.kp * 1.25)
    # the integral at least as fast as the design rule's (its settling time bounds the tuned loop's)
    lo_i, hi_i = g0.ki, max(max(ki), g0.ki * 1.25)
    kd0 = 0.01 * g0.kp / w0
    cand.gains = P.Gains(g0.kp, g0.ki, kd0)  # tune searches K_d in log scale: a small positive start
    return {"kp": (lo_p, hi_p), "ki": (lo_i, hi_i), "kd": (kd0 / 10.0, kd0 * 10.0)}, scan


def _sizing_json(sz: SZ.Sizing, load) -> dict:
    return {"speed_rad_s": sz.speed, "torque_at_constant_speed": sz.torque, "flywheel": sz.flywheel,
            **sizing_common(sz, load, "chi")}
