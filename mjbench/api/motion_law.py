"""Motion laws from Python: :func:`optimize_motion_law` minimises the residual vibration of an
elastic platform over the shape of its motion law (Incerti belt, Incerti Bezier)."""
from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .scenarios import Scenario, as_scenario, warn
from .. import vibration
from ..motionlaws import solve_coefficients
from ..outputs import staged_dir, write_json
from .. import papers


class LawOptimization:
    """The initial and optimised motion laws, their residual energy E(T), shapers, the ω_n
    sensitivity and (with a ``[modes]`` servo) the real motor + servo runs.

    Attributes
    ----------
    report : dict
        What ``optimize_law.json`` holds: ``laws`` {initial, optimised, shaped ...: E(T) [J],
        envelope and peak residual [rad], peak speed/acceleration}, ``optimiser``, ``sensitivity``,
        ``paper_check`` (ω_n, ξ against the paper's printed digits), ``table_II`` (Incerti belt).
    objects : dict
        The laws, the oscillator and the runs behind the figures.
    """

    def __init__(self, scenario: Scenario, report: dict[str, Any], objects: dict[str, Any]) -> None:
        self.scenario, self.report, self.objects = scenario, report, objects
        self.files: dict[str, str] = {}  # the figures of the last save()

    @property
    def warnings(self) -> list[str]:
        """Degenerate trial laws, a stopped ODE check, an optimiser held back."""
        out = []
        for k, v in self.report["laws"].items():
            out += [f"the {k} law looks degenerate: {w}" for w in v.get("warnings") or []]
            if v.get("ode_note"):
                out.append(f"the {k} law's E(T) ODE check was stopped: {v['ode_note']}")
        if self.report["optimiser"].get("held_back"):
            out.append(f"optimiser held back: {self.report['optimiser']['held_back']}")
        return out

    def summary(self) -> str:
        """The text ``mjbench optimize-law`` prints."""
        return law_summary(self.scenario, self.report, self.objects["osc"])

    def save(self, path: str | os.PathLike[str], *, force: bool = False, plots: bool = True,
             what: str = "save") -> Path:
        """Write ``optimize_law.json`` and (``plots``) the figures into the folder ``path``, whole
        or not at all (``mjbench optimize-law --out``)."""

        final = os.path.abspath(os.fspath(path))
        with staged_dir(path, force=force, what=what) as out:
            files = law_figures(self.scenario.name, self.report, self.objects, os.fspath(out)) if plots else {}
            rep = dict(self.report)
            rep["files"] = {k: os.path.join(final, os.path.basename(v)) for k, v in files.items()}
            rep["scenario_source"] = self.scenario.source
            rep["overrides"] = self.scenario.overrides
            write_json(os.path.join(out, "optimize_law.json"), rep)
        self.files = dict(rep["files"])
        return Path(final)


def optimize_motion_law(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any], *,
                        multibody: bool | None = None, progress: bool = False) -> LawOptimization:
    """Optimise the scenario's ``[law]`` against residual vibration (docs/vibration.md).

    Parameters
    ----------
    scenario : Scenario, str, path or dict
        A scenario with a ``[law]`` table and an elastic platform (``incerti-belt``,
        ``incerti-bezier``).
    multibody : bool, optional
        Check E(T) on MuJoCo (default: the scenario's ``[check]``); False skips it.
    progress : bool
        A progress bar of the six stages.

    Returns
    -------
    LawOptimization
        ``report`` (optimize_law.json), ``summary()``, ``warnings``, ``save(dir)``.
    """

    scn = as_scenario(scenario)
    if progress:
        from tqdm import tqdm

        with tqdm(total=6, desc="optimize-law", leave=False) as bar:
            res = vibration.study(scn.spec, progress=bar, multibody=multibody)
    else:
        res = vibration.study(scn.spec, multibody=multibody)
    rep, obj = res["report"], res["objects"]
    pap = rep["paper"]
    rep["paper_check"] = paper_check(obj["osc"], pap)
    if "table_II_pseudo_gammas" in pap:
        rows = []
        for g, cp in ((pap.get("table_II_polynomial_gammas", [3.0, 4.0, 5.0]), pap.get("table_II_polynomial")),
                      (pap["table_II_pseudo_gammas"], pap.get("table_II_pseudo_C"))):
            C = solve_coefficients(g)
            ok = cp is not None and bool(np.all(np.abs(C - np.asarray(cp)) <= 5e-4 + 1e-12))
            rows.append({"gammas": list(g), "C": C.tolist(), "paper_C": cp, "match_3_decimals": ok})
        rep["table_II"] = rows
    out = LawOptimization(scn, rep, obj)
    warn(out.warnings)
    return out


def paper_check(osc: Any, pap: Mapping[str, Any]) -> dict[str, Any]:
    """Compare ω_n and ξ with the paper's printed values, which are rounded or truncated to the
    printed digits (Incerti Bezier prints 53.3 for 53.36 — docs/errata.md)."""
    out = {}
    for key, ours, unit, scale in (("omega_n", osc.omega_n, "rad/s", 1.0), ("xi", osc.xi, "%", 100.0)):
        if key not in pap:
            continue
        p = float(pap[key]) * scale
        o = ours * scale
        txt = f"{pap[key] * scale:g}".rstrip()
        dec = len(txt.split(".")[1]) if "." in txt else 0
        q = 10.0 ** -dec
        rounded = abs(o - p) <= 0.5 * q + 1e-12
        truncated = abs(np.floor(o / q + 1e-9) * q - p) <= 1e-9
        ok = rounded or truncated
        how = "rounded" if rounded else ("truncated" if truncated else "DIFFERS")
        out[key] = {"paper": p, "ours": o, "unit": unit, "match": bool(ok), "how": how,
                    "text": f"{'ω_n' if key == 'omega_n' else 'ξ'} = {txt} {unit} {'✓' if ok else '✗'} ({how})"}
    return out


def _fmt(x: Any) -> str:
    return "—" if x is None else f"{x:.4g}"


def law_summary(scn: Scenario, rep: dict[str, Any], osc: Any) -> str:
    """The printed summary of an optimisation: ω_n, Table II, the laws' E(T), sensitivity, servo."""
    lines = [f"{scn.name}: {scn.title}"]
    line = f"  ω_n = {osc.omega_n:.4f} rad/s ({osc.omega_n / (2 * np.pi):.3f} Hz), ξ = {100 * osc.xi:.3f} %"
    if rep["paper_check"]:
        line += "   [paper: " + ", ".join(c["text"] for c in rep["paper_check"].values()) + "]"
    lines.append(line)
    if "table_II" in rep:
        lines.append("  Table II (Incerti belt): " + "; ".join(
            f"γ = {r['gammas']} → C = {np.round(r['C'], 4).tolist()} {'✓' if r['match_3_decimals'] else '✗'}"
            for r in rep["table_II"]))
    opt = rep["optimiser"]
    lines.append(f"  optimiser: {opt['method']}, {opt['iterations']} iterations, {opt['evaluations']} evaluations "
                 f"({opt['message']})")
    lines.append(f"  {'law':<16s} {'T_end[s]':>8s} {'E(T) closed [J]':>16s} {'E(T) ODE [J]':>13s} {'E(T) MuJoCo':>12s} "
                 f"{'envelope@T[rad]':>15s} {'peak|ψ|,T+2s':>13s} {'peak φ̇[rad/s]':>13s} {'peak φ̈[rad/s²]':>14s}")
    for k, v in rep["laws"].items():
        lines.append(f"  {k:<16s} {v['T_total_s']:8.4f} {v['E_T_J']:16.4e} {_fmt(v.get('E_T_ode_J')):>13s} "
                     f"{_fmt(v.get('E_T_multibody_J')):>12s} {v['residual_envelope_at_T_rad']:15.4e} "
                     f"{v['residual_peak_after_T_rad']:13.4e} "
                     f"{v['peak_motor_speed_rad_s']:13.2f} {v['peak_motor_accel_rad_s2']:14.1f}")
    shape = {k: rep["laws"][k]["law"].get("gammas", rep["laws"][k]["law"].get("interior_over_Phi"))
             for k in ("initial", "optimised")}
    lines.append(f"  shape parameters: initial {np.round(shape['initial'], 6).tolist()} → optimised "
                 f"{np.round(shape['optimised'], 6).tolist()}")
    lines.append(f"  E(T) reduced by {rep['reduction_orders']:.1f} orders of magnitude")
    lines.append("  envelope@T: amplitude of the free vibration from the state at T; peak|ψ|: largest deflection "
                 "actually reached over [T, T + 2 s]")
    lines.append("  sensitivity: E(T_end) [J] when the real ω_n is off by (ξ kept):")
    lines.append("  " + f"{'law':<16s}" + "".join(f"{100 * e:>+11.1f}%" for e in rep["sensitivity"]["omega_n_errors"]))
    for k, rows in rep["sensitivity"]["table"].items():
        lines.append("  " + f"{k:<16s}" + "".join(f"{r['E_J']:12.3e}" for r in rows))
    if "servo" in rep:
        sv = rep["servo"]
        lines.append(f"  real motor + servo (mode {sv['mode']!r}, co-step kernel, {sv['backend']} model; "
                     f"not in the papers):")
        for k, v in sv["laws"].items():
            lines.append(f"  {k:<16s} E(T) = {v['E_T_J']:.3e} J (ideal {v['ideal_E_T_J']:.3e}), peak |ψ| over "
                         f"[T, T + {v['residual_peak_window_s']:g} s] = {v['residual_peak_after_T_rad']:.3e} rad "
                         f"(ideal {v['ideal_residual_peak_after_T_rad']:.3e}), max tracking error = "
                         f"{v['max_tracking_error_rad']:.2e} rad, peak current = {v['peak_current_A']:.1f} A, "
                         f"peak voltage = {v['peak_voltage_V']:.0f} V")
    return "\n".join(lines)


def law_figures(name: str, rep: dict[str, Any], obj: dict[str, Any], out: str) -> dict[str, str]:
    """The figures of an optimisation in ``out`` → {key: path}."""
    pv = papers.incerti_platforms_plots  # (matplotlib: loaded on first use)

    laws, ta, osc = obj["laws"], obj["t_after"], obj["osc"]
    files = {"response": pv.fig_energy_response(laws["initial"], laws["optimised"], osc,
                                                os.path.join(out, "response_before_after.png"), ta,
                                                suptitle=f"{name}: platform response, initial (left) and optimised "
                                                         f"(right)"),
             "commands_initial": pv.fig_commands_platform(laws["initial"], osc, os.path.join(out, "commands_initial.png"),
                                                          ta, title=f"{name}: commands and platform, initial law"),
             "commands_optimised": pv.fig_commands_platform(laws["optimised"], osc,
                                                            os.path.join(out, "commands_optimised.png"), ta,
                                                            title=f"{name}: commands and platform, optimised law")}
    fine, table = obj["sens_fine"]
    files["sensitivity"] = pv.fig_sensitivity(fine, table, os.path.join(out, "sensitivity_omega_n.png"),
                                              title=f"{name}: E(T_end) vs ω_n error (laws designed for nominal)")
    if rep.get("multibody"):
        files["multibody_check"] = pv.fig_multibody_check(obj["platform"], laws["initial"], osc,
                                                          os.path.join(out, "multibody_vs_ode.png"),
                                                          ta, dt=rep["multibody"]["dt_s"])
    if obj.get("servo_runs"):
        files["servo"] = pv.fig_servo(laws, obj["servo_runs"], osc, os.path.join(out, "servo_vs_ideal.png"), ta,
                                      title=f"{name}: ideal vs real servo (transmission deflection)")
    files["laws"] = pv.fig_laws({**laws, **obj["shaped"]}, os.path.join(out, "laws.png"), title=f"{name}: motor laws")
    return files
