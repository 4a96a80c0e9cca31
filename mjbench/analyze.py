"""``mjbench analyze``: what a designer looks at over one input revolution, without simulating.

For any mechanism type with a rigid reduced model (fourbar, quickreturn, linkage, mjcf):

* the reduced model J(q), J'(q), E_p'(q), E_p(q);
* the velocity ratios of every joint (dq_j/dq) and the strokes of the prismatic joints;
* the transmission angle(s) and the toggle / limit positions: each mechanism's own
  :meth:`~mjbench.mechanisms.base.Mechanism.kinematics` (generic linkages their own; the four-bar
  and the quick-return through their equivalent generic linkage, ``linkage_view``; an MJCF model
  has velocity ratios and limit positions only: it has no link lines); the rows a mechanism cannot
  give are listed with the reason (``kinematics_unavailable``);
* the input torque needed to run at a constant input speed ω (the seed 000 Eq 5 balance with
  q̈ = 0): T(q) = ½·J'(q)·ω² + E_p'(q) − Q_ext(q, ω) — inertial + gravity/springs + loads and
  viscous friction of the mechanism — and through the gearbox the motor torque
  T_m = T/z + λ·zω + T_0 (motor friction), current I = T_m/k_m and voltage
  V = R·I + L·dI/dt + k_m·zω, against the motor's steady torque–speed line at the supply limit,
  T_line(ω_m) = k_m·(V_max − k_m·ω_m)/R.

Flags: toggle positions (two binary links collinear), limit positions (a joint stops), transmission
angles below ``mu_min`` (default 40°, the usual design guideline) and dead centres (below 1°),
voltage or current beyond the drive's limits at a speed.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from . import scenario as S
from .errors import ParameterError
from .mechanisms.fourbar import _angle_ranges
from .manifest import write_json
from . import cam_plots
from . import plotstyle as ps
from .plots import save

MU_MIN_DEG = 40.0  #: transmission angle below which force transmission is flagged as poor
DEAD_DEG = 1.0  #: transmission angle below which a position is flagged as a dead centre


def default_speeds(scn) -> list:
    """Input speeds [rad/s] to analyse: the set-point of every mode whose controller has one (its
    :meth:`~mjbench.control.Controller.setpoint`: PID ω₀/z, SMC ω_d …), else one revolution per second."""
    out = []
    for name in scn.modes:
        mc = S.make_machine(scn, name)
        sp = mc.controller.setpoint(mc)
        w = None if sp is None else float(sp["input_rad_s"])
        if w is not None and w > 0 and all(abs(w - x) > 1e-9 for x in out):
            out.append(w)
    return out or [2.0 * math.pi]


def _grid(mech, n):
    """Input positions over one revolution (a slide input: over its range) and their unit: the
    mechanism's own :meth:`~mjbench.mechanisms.base.Mechanism.input_positions`."""
    return mech.input_positions(n)


def analyze(scn, speeds=None, n: int = 720, mu_min_deg: float = MU_MIN_DEG) -> dict:
    """The analysis of a scenario's mechanism and drive (a JSON-ready dict with arrays as lists
    under ``curves``).  ``speeds``: input speeds [rad/s] (default :func:`default_speeds`)."""
    t_cpu, t_wall = time.process_time(), time.perf_counter()
    mech = S.make_mechanism(scn)
    drive = S.make_drive(scn)
    return analyze_parts(mech, drive, scn.name, speeds or (lambda: default_speeds(scn)), n, mu_min_deg,
                         mech_type=scn.mechanism.type, started=(t_cpu, t_wall))


def analyze_parts(mech, drive, name: str, speeds, n: int = 720, mu_min_deg: float = MU_MIN_DEG,
                  mech_type: str | None = None, started=None) -> dict:
    """The analysis of a mechanism and (optionally) its drive, built in code or from a scenario.
    ``speeds``: input speeds [rad/s], or a callable giving the defaults; ``drive=None``: the input
    torque only (no motor rows); ``name``: what the outputs call it."""
    t_cpu, t_wall = started or (time.process_time(), time.perf_counter())
    mech_type = mech_type or getattr(mech, "type_name", type(mech).__name__)
    res = {"scenario": name, "mechanism": mech_type,
           "reduced_model": getattr(mech, "reduced_source", "")}
    if mech.internal or mech.render_view().kind == "top":
        res.update(applicable=False, reason=(
            f"mechanism type {mech_type!r} has internal elastic coordinates "
            f"({', '.join(mech.internal) or 'rotary table'}): a constant-speed revolution analysis does not "
            f"apply; use `mjbench optimize-law` for its motion law"))
        res["timing"] = {"cpu_s": time.process_time() - t_cpu, "wall_s": time.perf_counter() - t_wall}
        return res
    if n < 16:
        raise ParameterError(f"--points = {n}: need at least 16 samples over the revolution")
    speeds = list(speeds() if callable(speeds) else speeds)
    for w in speeds:
        if not (math.isfinite(w) and w > 0):
            raise ParameterError(f"--speed = {w!r}: an input speed must be finite and > 0 [rad/s]")
    q, qunit = _grid(mech, n)
    J, dJ, dEp = (np.asarray(x, float) * np.ones_like(q) for x in mech.reduced(q))
    Ep = np.asarray(mech.potential_energy(q), float) * np.ones_like(q)
    res["applicable"] = True
    res["input_unit"] = qunit
    res["points"] = int(n)
    res["table_info"] = getattr(mech, "table_info", None)
    curves = {"q": q, "J": J, "dJ": dJ, "dEp": dEp, "Ep": Ep}
    res["reduced"] = {"J_min": float(J.min()), "J_max": float(J.max()), "dJ_absmax": float(np.abs(dJ).max()),
                      "dEp_absmax": float(np.abs(dEp).max()), "Ep_range_J": float(np.ptp(Ep))}
    flags = []
    _kinematic_rows(res, curves, flags, mech, q, mu_min_deg)
    res["drive"] = None if drive is None else _drive_row(drive)
    res["speeds"] = [_speed_row(w, mech, res["drive"], q, qunit, dJ, dEp, curves, flags) for w in speeds]
    extra = mech.analysis_rows(speeds, n)  # a family's own rows (a cam's jump speed, pressure angle …)
    if extra:
        res.update(extra.pop("top", {}))
        flags += extra.pop("flags", [])
        res["family"] = mech_type
        res[mech_type] = _jsonable_curves(extra)
    res["flags"] = flags
    res["curves"] = {k: np.asarray(v, float).tolist() for k, v in curves.items()}
    res["timing"] = {"cpu_s": time.process_time() - t_cpu, "wall_s": time.perf_counter() - t_wall}
    return res


def _kinematic_rows(res, curves, flags, mech, q, mu_min_deg) -> None:
    """Velocity ratios, strokes, transmission angles (flagged below ``mu_min_deg`` and at dead
    centres), toggles and limit positions into ``res``, their curves and flags."""
    kin = _kinematics(mech, q)
    res["kinematics_source"] = kin.pop("source")
    res["kinematics_unavailable"] = kin.pop("unavailable", {})
    ratios = kin.pop("ratios")
    trans = kin.pop("transmission")
    curves.update({f"ratio:{k}": v for k, v in ratios.items()})
    curves.update({f"mu:{k}": v for k, v in trans.items()})
    res["velocity_ratios"] = {k: {"unit": kin["ratio_units"].get(k, ""), "min": float(np.nanmin(v)),
                                  "max": float(np.nanmax(v))} for k, v in ratios.items()}
    res["strokes_m"] = kin.get("strokes_m", {})
    res["transmission_angles_deg"] = {}
    res["transmission"] = {}
    keys = transmission_keys(list(trans), _joint_names(mech))
    for name, mu in trans.items():
        mu_d = np.degrees(mu)
        imin = int(np.nanargmin(mu_d))
        key = keys[name]
        res["transmission_angles_deg"][name] = {"min": float(np.nanmin(mu_d)), "max": float(np.nanmax(mu_d)),
                                                "q_at_min": float(q[imin]), "key": key}
        res["transmission"][key] = {"label": name, "min_deg": float(np.nanmin(mu_d)),
                                    "max_deg": float(np.nanmax(mu_d)), "q_at_min_rad": float(q[imin]),
                                    "curve": f"mu:{name}"}
        flags += [dict(f, key=key) for f in _transmission_flags(name, q, mu_d, mu_min_deg)]
    for jn, lst in kin.get("toggles", {}).items():
        for tg in lst:
            flags.append({"kind": "toggle", "where": jn, "q": tg["q"],
                          "text": f"toggle at joint {jn}: {' and '.join(tg['links'])} {tg['kind']} collinear at "
                                  f"q = {math.degrees(tg['q']) % 360:.1f}° (the driven side stops: "
                                  f"unbounded mechanical advantage)"})
    for jn, lst in kin.get("limit_positions", {}).items():
        for r in lst:
            flags.append({"kind": "limit_position", "where": jn, "q": float(r),
                          "text": f"joint {jn} momentarily stops (limit position) at q = {math.degrees(r) % 360:.1f}°"})
    res["toggles"] = kin.get("toggles", {})
    res["limit_positions"] = kin.get("limit_positions", {})
    res["swings_deg"] = kin.get("swings_deg", {})
    res["stroke_arcs_deg"] = kin.get("stroke_arcs_deg", {})


def _joint_names(mech) -> list:
    """The joint names of the mechanism's generic-linkage view (empty without one)."""
    try:
        lk = mech.linkage_view()
    except Exception:  # noqa: BLE001 - a mechanism without a usable view has no joint names to offer
        return []
    params = getattr(lk, "params", None)
    return [str(j.name) for j in getattr(params, "joints", ())]


def transmission_keys(labels, joints) -> dict:
    """{display label: stable key}.  A transmission angle is measured at a joint; its label names
    the joint and the two links ("C (coupler on rocker)"), its key is the joint's name ("C") — it
    does not change when a link is renamed.  A label that names no known joint (or a joint that
    would get two angles) keeps the label as its key."""
    out = {}
    for lab in labels:
        cands = [j for j in joints if lab == j or lab.startswith(j + " (")]
        out[lab] = max(cands, key=len) if cands else lab
    seen = {}
    for lab, key in out.items():
        seen.setdefault(key, []).append(lab)
    return {lab: (key if len(seen[key]) == 1 else lab) for lab, key in out.items()}


def _transmission_flags(name, q, mu_d, mu_min_deg) -> list:
    """Flags of the input ranges where the transmission angle ``name`` is below 1° (a dead centre;
    then no further flag) or below ``mu_min_deg``."""
    flags = []
    for lim, kind in ((DEAD_DEG, "dead_centre"), (mu_min_deg, "poor_transmission")):
        low = mu_d < lim
        if np.any(low):

            for lo, hi in _angle_ranges(q, low):
                flags.append({"kind": kind, "where": name, "q_from": float(lo), "q_to": float(hi),
                              "text": f"transmission angle {name} below {lim:g}° for q = "
                                      f"{math.degrees(lo) % 360:.1f}°..{math.degrees(hi) % 360:.1f}°"})
            if kind == "dead_centre":
                break
    return flags


def _drive_row(drive) -> dict:
    """The drive's constants (SI) with its no-load speed and stall torque at v_max."""
    z, km, R, L = float(drive.z), float(drive.k_m), float(drive.R), float(drive.L)
    lam, T0, vmax, imax = float(drive.lam), float(drive.T_0), float(drive.v_max), float(drive.i_max)
    return {"z": z, "k_m": km, "R": R, "L": L, "lam": lam, "T_0": T0, "v_max": vmax, "i_max": imax,
            "no_load_motor_speed_rad_s": (vmax / km) if math.isfinite(vmax) else None,
            "stall_motor_torque_Nm": (km * vmax / R) if math.isfinite(vmax) else None}


def _speed_row(w, mech, drv, q, qunit, dJ, dEp, curves, flags) -> dict:
    """The torque at constant input speed w through the gearbox against the motor (module doc):
    the row of ``speeds``, its curves and its voltage/current flags."""
    Qext = np.asarray(mech.external_torque(q, w + 0.0 * q, 0.0), float) * np.ones_like(q)
    T_in = 0.5 * dJ * w * w + dEp - Qext
    if drv is None:  # a mechanism without a drive: the input torque only
        curves[f"T_in@{w:g}"] = T_in
        return {"input_speed_rad_s": float(w), "input_speed_rpm": float(w * 30 / math.pi),
                "input_torque_Nm": {"min": float(T_in.min()), "max": float(T_in.max()),
                                    "rms": float(np.sqrt(np.mean(T_in ** 2))), "mean": float(T_in.mean())},
                "parts_absmax_Nm": {"inertial": float(np.abs(0.5 * dJ * w * w).max()),
                                    "gravity_springs": float(np.abs(dEp).max()),
                                    "loads_friction": float(np.abs(Qext).max())},
                "mean_power_W": float(np.mean(T_in) * w),
                "energy_per_rev_J": float(np.mean(T_in) * 2 * math.pi) if qunit == "rad" else None}
    z, km, R, L = drv["z"], drv["k_m"], drv["R"], drv["L"]
    lam, T0, vmax, imax = drv["lam"], drv["T_0"], drv["v_max"], drv["i_max"]
    dq = (q[1] - q[0]) if len(q) > 1 else 1.0
    wm = z * w
    Tm = T_in / z + lam * wm + T0 * math.copysign(1.0, wm)
    I = Tm / km
    dIdq = np.gradient(I, dq) if qunit == "m" else _periodic_gradient(I, dq)
    V = R * I + L * dIdq * w + km * wm
    row = {"input_speed_rad_s": float(w), "input_speed_rpm": float(w * 30 / math.pi),
           "motor_speed_rad_s": float(wm),
           "input_torque_Nm": {"min": float(T_in.min()), "max": float(T_in.max()),
                               "rms": float(np.sqrt(np.mean(T_in ** 2))), "mean": float(T_in.mean())},
           "parts_absmax_Nm": {"inertial": float(np.abs(0.5 * dJ * w * w).max()),
                               "gravity_springs": float(np.abs(dEp).max()),
                               "loads_friction": float(np.abs(Qext).max())},
           "motor_torque_Nm": {"min": float(Tm.min()), "max": float(Tm.max()),
                               "rms": float(np.sqrt(np.mean(Tm ** 2)))},
           "current_A": {"min": float(I.min()), "max": float(I.max()), "rms": float(np.sqrt(np.mean(I ** 2)))},
           "voltage_V": {"min": float(V.min()), "max": float(V.max())},
           "mean_power_W": float(np.mean(T_in) * w),
           "energy_per_rev_J": float(np.mean(T_in) * 2 * math.pi) if qunit == "rad" else None}
    if math.isfinite(vmax):
        Tline = km * (vmax - km * wm) / R
        row["motor_line_torque_Nm"] = float(Tline)
        row["torque_margin"] = float(Tline - Tm.max())
        if V.max() > vmax or V.min() < -vmax:
            flags.append({"kind": "voltage", "where": f"{w:g} rad/s",
                          "text": f"at {w:.4g} rad/s the constant speed needs up to {np.abs(V).max():.3g} V "
                                  f"> v_max = {vmax:g} V: the motor cannot hold that speed over the whole turn"})
    if math.isfinite(imax) and np.abs(I).max() > imax:
        flags.append({"kind": "current", "where": f"{w:g} rad/s",
                      "text": f"at {w:.4g} rad/s the current reaches {np.abs(I).max():.3g} A > i_max = {imax:g} A"})
    curves[f"T_in@{w:g}"] = T_in
    curves[f"T_m@{w:g}"] = Tm
    curves[f"I@{w:g}"] = I
    curves[f"V@{w:g}"] = V
    return row


def _jsonable_curves(d):
    """``d`` with NumPy arrays (and floats of NumPy) as lists and floats, walked recursively."""
    if isinstance(d, dict):
        return {k: _jsonable_curves(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_jsonable_curves(v) for v in d]
    if isinstance(d, np.ndarray):
        return d.tolist()
    if isinstance(d, np.generic):
        return d.item()
    return d


def _periodic_gradient(f, h):
    return (np.roll(f, -1) - np.roll(f, 1)) / (2.0 * h)


def _kinematics(mech, q) -> dict:
    """Velocity ratios, transmission angles, toggles and limit positions: the mechanism's own
    :meth:`~mjbench.mechanisms.base.Mechanism.kinematics` (through its linkage view, or its own
    analysis), with the rows it cannot give and why (``unavailable``)."""
    return mech.kinematics(q)


# ============================================================================ outputs
#: the figures of a mechanism family's own analysis rows (``analysis.json["family"]``, from
#: :meth:`~mjbench.mechanisms.base.Mechanism.analysis_rows`), drawn after the linkage figures
FAMILY_FIGURES = {"cam": cam_plots.figures}


def write(res: dict, out_dir) -> list:
    """analysis.json and the figures into ``out_dir``; returns the written paths."""

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "analysis.json"]
    write_json(paths[0], res)
    if res.get("applicable"):
        paths += figures(res, out)
        family = FAMILY_FIGURES.get(res.get("family"))  # a family's own figures (a cam's S-V-A-J …)
        if family is not None:
            paths += family(res, out)
    return paths


def figures(res: dict, out: Path) -> list:

    c = {k: np.asarray(v) for k, v in res["curves"].items()}
    deg = res["input_unit"] == "rad"
    x = np.degrees(c["q"]) if deg else c["q"]
    xl = ps.label("input angle q", "°") if deg else ps.label("input position q", "m")
    tag = " [MuJoCo-derived]" if str(res.get("reduced_model", "")).startswith("MuJoCo-derived") else ""
    paths = []
    with ps.context():
        fig, ax = ps.new(3, 1, figsize=(8, 7.5), sharex=True)
        ax[0].plot(x, c["J"], color="C0")
        ax[0].set_ylabel(ps.label("J(q)", "kg·m²"))
        ax[1].plot(x, c["dJ"], color="C1")
        ax[1].set_ylabel(ps.label("J'(q)", "kg·m²/rad"))
        ax[2].plot(x, c["dEp"], color="C2")
        ax[2].set_ylabel(ps.label("E_p'(q)", "N·m"))
        ax[2].set_xlabel(xl)
        ps.finish(fig, f"{res['scenario']}: reduced model{tag}")
        paths.append(save(fig, out / "reduced_model.png"))

        rk = [k for k in c if k.startswith("ratio:")]
        mk = [k for k in c if k.startswith("mu:")]
        fig, ax = ps.new(2, 1, figsize=(8, 7), sharex=True)
        units = {k: v.get("unit", "") for k, v in res.get("velocity_ratios", {}).items()}
        for k in rk:
            name = k[6:]
            ax[0].plot(x, c[k], label=f"{name} [{units.get(name) or '—'}]")
        ax[0].set_ylabel("velocity ratio dq_j/dq")
        if rk:
            ax[0].legend(loc="upper right", fontsize=7, ncol=2)
        for k in mk:
            ax[1].plot(x, np.degrees(c[k]), label=k[3:])
        ax[1].axhline(MU_MIN_DEG, color="0.4", ls="--", lw=0.8)
        for f in res.get("flags", []):
            if f["kind"] == "toggle":
                for a in ax:
                    a.axvline(math.degrees(f["q"]) % 360 if deg else f["q"], color="0.6", ls=":", lw=0.8)
        ax[1].set_ylabel(ps.label("transmission angle μ", "°"))
        ax[1].set_xlabel(xl)
        if mk:
            ax[1].legend(loc="lower right", fontsize=7)
        else:
            ax[1].text(0.5, 0.5, "no transmission angle (no binary link drives a ground-guided link,\n"
                                 "or an MJCF model without link lines)", ha="center", va="center",
                       transform=ax[1].transAxes, fontsize=8)
        ps.finish(fig, f"{res['scenario']}: velocity ratios, transmission angles (dotted: toggles)")
        paths.append(save(fig, out / "kinematics.png"))

        fig, ax = ps.new(2, 1, figsize=(8, 7))
        for i, row in enumerate(res["speeds"]):
            w = row["input_speed_rad_s"]
            ax[0].plot(x, c[f"T_in@{w:g}"], color=f"C{i}", label=f"{w:.3g} rad/s ({row['input_speed_rpm']:.3g} rpm)")
        ax[0].set_xlabel(xl)
        ax[0].set_ylabel(ps.label("input torque at constant speed", "N·m"))
        ax[0].legend(loc="upper right", fontsize=7)
        d = res["drive"]
        if d is None:  # a mechanism without a drive: no motor panel
            ax[1].text(0.5, 0.5, "no drive given: input torque only", ha="center", va="center",
                       transform=ax[1].transAxes, fontsize=8)
            ax[1].set_axis_off()
            ps.finish(fig, f"{res['scenario']}: torque at constant speed")
            paths.append(save(fig, out / "torque_speed.png"))
            return paths
        wms = [r["motor_speed_rad_s"] for r in res["speeds"]]
        if d["no_load_motor_speed_rad_s"]:
            wmax = max(d["no_load_motor_speed_rad_s"], max(wms) * 1.1)
            ww = np.linspace(0, wmax, 50)
            ax[1].plot(ww, d["k_m"] * (d["v_max"] - d["k_m"] * ww) / d["R"], color="k", lw=1.2,
                       label=f"motor at v_max = {d['v_max']:g} V")
        for i, row in enumerate(res["speeds"]):
            tm = row["motor_torque_Nm"]
            ax[1].plot([row["motor_speed_rad_s"]] * 2, [tm["min"], tm["max"]], color=f"C{i}", lw=4, alpha=0.7)
            ax[1].plot(row["motor_speed_rad_s"], tm["rms"], "o", color=f"C{i}", ms=4)
        ax[1].axhline(0.0, color="0.5", lw=0.6)
        ax[1].set_xlabel(ps.label("motor speed z·ω", "rad/s"))
        ax[1].set_ylabel(ps.label("motor torque", "N·m"))
        ax[1].legend(loc="upper right", fontsize=7)
        ps.finish(fig, f"{res['scenario']}: torque at constant speed; bars: range over a turn, dot: RMS")
        paths.append(save(fig, out / "torque_speed.png"))
    return paths


def summary_text(res: dict) -> str:
    """Plain-text summary printed by ``mjbench analyze``."""
    if not res.get("applicable"):
        return f"mjbench analyze: not applicable to {res['scenario']}: {res['reason']}"
    what = res["scenario"] if res.get("built_in_code") else f"scenario {res['scenario']}"
    lines = [f"{what} ({res['mechanism']}): reduced model {res['reduced_model']}"]
    r = res["reduced"]
    lines.append(f"  J(q) {r['J_min']:.4g} … {r['J_max']:.4g} kg·m²   |J'| ≤ {r['dJ_absmax']:.4g} kg·m²/rad   "
                 f"|E_p'| ≤ {r['dEp_absmax']:.4g} N·m")
    for k, v in res["transmission_angles_deg"].items():
        lines.append(f"  transmission angle {k}: {v['min']:.1f}° … {v['max']:.1f}°")
    for k, v in res["strokes_m"].items():
        lines.append(f"  stroke of {k}: {1000 * v:.2f} mm")
    for row, why in res.get("kinematics_unavailable", {}).items():
        lines.append(f"  no {row.replace('_', ' ')}: {why}")
    for row in res["speeds"]:
        t = row["input_torque_Nm"]
        if "motor_torque_Nm" not in row:  # no drive
            lines.append(f"  at {row['input_speed_rad_s']:.4g} rad/s: input torque {t['min']:.3g} … {t['max']:.3g} N·m "
                         f"(RMS {t['rms']:.3g}), mean power {row['mean_power_W']:.3g} W (no drive given)")
            continue
        lines.append(f"  at {row['input_speed_rad_s']:.4g} rad/s: input torque {t['min']:.3g} … {t['max']:.3g} N·m "
                     f"(RMS {t['rms']:.3g}), motor {row['motor_torque_Nm']['max']:.3g} N·m peak, "
                     f"{row['current_A']['max']:.3g} A, {row['voltage_V']['max']:.3g} V"
                     + (f", motor line {row['motor_line_torque_Nm']:.3g} N·m" if "motor_line_torque_Nm" in row else ""))
    for line in (res.get(res.get("family") or "", {}) or {}).get("summary", []):
        lines.append(f"  {line}")
    kinds = {}
    for f in res["flags"]:
        kinds.setdefault(f["kind"], []).append(f)
    for kind in ("dead_centre", "poor_transmission", "toggle", "voltage", "current", "jump"):
        for f in kinds.get(kind, []):
            lines.append(f"  FLAG {kind}: {f['text']}")
    if kinds.get("limit_position"):
        lines.append(f"  {len(kinds['limit_position'])} limit positions (see analysis.json)")
    tm = res["timing"]
    lines.append(f"  analysis took {tm['cpu_s']:.2f} s CPU ({tm['wall_s']:.2f} s wall)")
    return "\n".join(lines)
