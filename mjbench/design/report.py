"""Outputs of ``mjbench design``: machine.toml, design.json, design.md, design.html, design.png.

The folder is written whole or not at all (:func:`mjbench.outputs.staged_dir`).  ``machine.toml``
is written only for a design that meets its requirements; an infeasible design gets design.json,
design.md and design.html with the closest candidate and what fails.
"""
from __future__ import annotations

import html
import math
import os

import numpy as np

from ..outputs import atomic_write, staged_dir, write_json
from . import build as B
from .law_figure import figure as law_figure
from .. import plotstyle as ps
from ..plots import save
from .. import mechanisms as MR
from .. import linear as LN
from .. import scenario as S
from .sizing import FLYWHEEL_COST


def _fmt(x, unit=""):
    if x is None:
        return "—"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, (int, float, np.floating)):
        x = float(x)
        if not math.isfinite(x):
            return "∞" if x > 0 else ("−∞" if x < 0 else "nan")
        if x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-3):
            return f"{x:.4g}"
        return f"{x:.5g}"
    return str(x)


def _pct(x):
    return "—" if x is None or not math.isfinite(float(x)) else f"{100 * float(x):+.2f} %"


def _gains_text(g) -> str:
    return ", ".join(f"{k} {v:.4g}" for k, v in (g or {}).items()) or "—"


def _gains_row(g) -> list:
    """The gains' row of the drive table: the speed PID's, or a motion-law duty's servo's."""
    if g and "kpp" in g:
        return ["servo kpp [1/s], kvp [V·s/rad], kvi [V/rad], kffv [V·s/rad], kffa [V·s²/rad]",
                ", ".join(_fmt(g[k]) for k in ("kpp", "kvp", "kvi", "kffv", "kffa"))]
    return ["speed PID kp [V·s/rad], ki [V/rad], kd [V·s²/rad]",
            ", ".join(_fmt(g[k]) for k in ("kp", "ki", "kd")) if g else "—"]


def _law_text(duty) -> str:
    """', the crank following a 3-4-5 law ...' of a motion-law duty (empty otherwise)."""
    lw = duty.get("law")
    if not lw:
        return ""
    kind = "pseudo-polynomial " + "-".join(f"{x:g}" for x in lw["law"].get("gammas", [])) if lw["kind"] == "pseudopoly" \
        else "Bezier"
    return (f", the crank following a {kind} motion law once round per cycle (move {lw['move_time_s']:.4g} s, "
            f"dwell {lw['dwell_s']:.4g} s)"
            + (f", tracking error ≤ {math.degrees(lw['tracking_error_max_rad']):.3g}°"
               if lw.get("tracking_error_max_rad") else ""))


#: steel for the flywheel's size (kg/m³) and its shape: a disc whose thickness is this fraction of its diameter
STEEL_DENSITY, DISC_THICKNESS = 7850.0, 0.2


def flywheel_disc(J: float) -> dict | None:
    """A steel disc of inertia J [kg·m²] (thickness = :data:`DISC_THICKNESS` × diameter):
    J = ½·m·r² = π·ρ·t·r⁴/2, so D = (32·J/(π·ρ·k))^(1/5) with t = k·D; {diameter_m, thickness_m, mass_kg}."""
    if not J or J <= 0:
        return None
    D = (32.0 * J / (math.pi * STEEL_DENSITY * DISC_THICKNESS)) ** 0.2
    t = DISC_THICKNESS * D
    return {"diameter_m": D, "thickness_m": t, "mass_kg": STEEL_DENSITY * math.pi * D * D / 4.0 * t}


def flywheel_text(ch) -> str:
    """"0.0058 kg·m² on the motor shaft: a steel disc Ø130 × 26 mm, 2.7 kg (14.5 kg·m² at the crank)"."""
    J = float(ch.get("flywheel_kgm2") or 0.0)
    if J <= 0:
        return "none"
    loc = ch.get("flywheel_location", "crank")
    disc = flywheel_disc(J)
    at_crank = J * float(ch["ratio"]) ** 2 if loc == "motor" else J
    return (f"{_fmt(J)} kg·m² on the {loc} shaft: a steel disc Ø{1e3 * disc['diameter_m']:.0f} × "
            f"{1e3 * disc['thickness_m']:.0f} mm, {disc['mass_kg']:.3g} kg"
            + (f" (acts as {_fmt(at_crank)} kg·m² at the crank, ×z²)" if loc == "motor" else ""))


def failure_text(f) -> str:
    """One readable line for a failed check: "voltage (hot winding): 23.16 V, above the allowed 21.6 V
    (supply × (1 − headroom)) by 7.2 %" — the quantity, its value and the limit once each."""
    name = str(f.get("name", ""))
    v, lim, cmp_, unit = f.get("value", f.get("achieved")), f.get("limit", f.get("required")), f.get("compare"), \
        f.get("unit", "")
    u = "" if not unit or unit == "1" else unit if unit == "°" else f" {unit}"
    num = lambda x: isinstance(x, (int, float)) and not isinstance(x, bool)  # noqa: E731
    if cmp_ in ("max", "min") and num(v) and num(lim):
        sym = "≤" if cmp_ == "max" else "≥"
        qty, _, rule = name.partition(sym)
        rule = rule.strip()
        if " = " in rule:  # "supply × (1 − headroom) = 21.6 V": the number is the limit, shown once
            rule = rule.split(" = ")[0].strip()
        word = "above the allowed" if cmp_ == "max" else "below the required"
        by = abs(v - lim) / abs(lim) if lim else math.inf
        return (f"{qty.strip() or name}: {_fmt(v)}{u}, {word} {_fmt(lim)}{u}"
                + (f" ({rule})" if rule and not _same_number(rule, lim) else "") + f" by {100 * by:.3g} %")
    return f"{name}: not met" if cmp_ == "true" or isinstance(v, bool) else name


def _same_number(text, x) -> bool:
    try:
        return math.isclose(float(text.split()[0]), float(x), rel_tol=1e-3)
    except (ValueError, IndexError):
        return False


def public(res: dict) -> dict:
    """The result without its in-memory objects (keys starting with '_')."""
    return {k: v for k, v in res.items() if not k.startswith("_")}


# ============================================================================ text
def summary_text(res: dict) -> str:
    lines = [f"mjbench design {res['name']}: {res['status'].upper()}"]
    ch = res.get("chosen")
    if ch:
        lines.append(f"  drive: {ch['motor']} + {ch['gearbox'] or 'direct drive'} (z = {ch['ratio']:g})"
                     + (f", flywheel {flywheel_text(ch)}" if ch["flywheel_kgm2"] > 0 else ", no flywheel")
                     + f"; gains {_gains_text(ch['gains'])} ({res.get('control', {}).get('source', '')})")
    for c in res.get("checks", []):
        lines.append(f"  check {c['name']}: predicted {_fmt(c['predicted'])}, simulated {_fmt(c['achieved'])}, "
                     f"{_pct(c['rel_diff'])} (tolerance {100 * c['tolerance']:.3g} %) {'ok' if c['ok'] else 'FAIL'}")
    if res.get("closest") and res["status"] != "ok":
        c = res["closest"]
        lines.append(f"  closest candidate: {c['motor']} + {c['gearbox'] or 'direct drive'}"
                     + (f", flywheel {c['flywheel_kgm2']:.4g} kg·m²" if c["flywheel_kgm2"] else ""))
    for f in res.get("failures", []):
        lines.append(f"  FAILS ({f.get('stage')}): {failure_text(f)}"
                     + (f" — {f['note']}" if f.get("note") else "")
                     + (f" [{f['candidate']}]" if f.get("candidate") else ""))
    t = res.get("timing", {})
    lines.append(f"  time: synthesis + sizing {t.get('synthesis_and_sizing_cpu_s', 0):.2f} s CPU; whole design "
                 f"{t.get('total_wall_s', 0):.1f} s wall ({t.get('total_cpu_s', 0):.1f} s CPU)")
    return "\n".join(lines)


# ============================================================================ tables
def requirements_rows(res) -> tuple:
    head = ["requirement", "required", "achieved", "unit", "margin", "pass", "source"]
    body = []
    for r in res.get("requirements_table", []):
        k, unit = _display_unit(r["name"], r["unit"])
        req = r["required"]
        cmp = {"max": "≤ ", "min": "≥ ", "eq": "= "}.get(r["compare"], "")
        body.append([r["name"], (cmp + _fmt(_scaled(req, k))) if req is not None else "—", _fmt(_scaled(r["achieved"], k)),
                     unit, _pct(r["margin"]) if r["margin"] is not None else "—", "✔" if r["ok"] else "✘", r["source"]])
    syn = res.get("synthesis", {})
    measured = ("stroke", "time ratio", "rocker swing", "minimum transmission angle", "precision points met",
                "poses met")
    for c in syn.get("constraints", []):
        if any(c["name"] == r["name"] for r in res.get("requirements_table", [])):
            continue
        if res.get("requirements_table") and c["name"].startswith(measured):
            continue  # the same requirement measured by mjbench's own solver is in the table
        k, unit = _display_unit(c["name"], c["unit"])
        body.append([c["name"], ({"min": "≥ ", "max": "≤ "}.get(c["compare"], "") + _fmt(_scaled(c["limit"], k)))
                     if c["limit"] is not None else "—", _fmt(_scaled(c["value"], k)), unit, "—", "✔" if c["ok"] else "✘",
                     "synthesis (closed form)" + (f"; {c['note']}" if c.get("note") else "")])
    return head, body


#: the units every table shows: lengths in mm, speed fluctuations and deviations in percent
UNIT_SHOWN = {"m": ("mm", 1e3), "m/s": ("mm/s", 1e3)}


def _is_fraction(name: str) -> bool:
    return "χ" in name or "/Ω" in name


def _display_unit(name: str, unit: str) -> tuple:
    """(scale, unit shown) of a value in ``unit`` (SI) named ``name``: mm for lengths, % for χ."""
    if _is_fraction(name) and unit in ("1", ""):
        return 100.0, "%"
    if unit in UNIT_SHOWN:
        return UNIT_SHOWN[unit][1], UNIT_SHOWN[unit][0]
    return 1.0, unit


def _scaled(x, k):
    return x * k if isinstance(x, (int, float)) and not isinstance(x, bool) else x


def checks_rows(res) -> tuple:
    head = ["prediction", "predicted", "simulated", "rel. diff", "tolerance", "pass"]
    body = []
    for c in res.get("checks", []):
        k = 100.0 if _is_fraction(c["name"]) else 1.0
        name = c["name"] + (" [%]" if k == 100.0 and "[" not in c["name"] else "")
        body.append([name, _fmt(_scaled(c["predicted"], k)), _fmt(_scaled(c["achieved"], k)), _pct(c["rel_diff"]),
                     f"{100 * c['tolerance']:.3g} %", "✔" if c["ok"] else "✘"])
    return head, body


def selection_text(res) -> str:
    """The selection rule, in the numbers of this design."""
    sz = res.get("sizing") or {}
    if not sz:
        return ""
    fw0, fw1 = FLYWHEEL_COST
    return (f"Every motor × gearbox of the catalogue ({sz.get('n_candidates')} combinations) is first screened on "
            f"mean values (speed, mean torque, mean voltage); the {sz.get('n_analysed')} left get their own flywheel "
            f"(energy method) and design-rule gains, and their periodic steady state is solved (harmonic balance): "
            f"RMS and peak current and torque, voltage with the hot winding, speeds, χ, winding temperature. "
            f"{sz.get('n_feasible')} meet every check. **Rule: the cheapest feasible candidate wins** — catalogue cost "
            f"of motor and gearbox plus a flywheel figure ({fw0:g} + {fw1:g} per kg·m²); a tie goes to the smaller RMS "
            f"motor torque. None feasible: the candidate of least total relative violation is reported with what fails.")


def runners_up_rows(res, n: int = 3) -> tuple:
    """The chosen candidate and the next ``n`` feasible ones by cost: cost, its difference, χ or
    the RMS current, and the tightest check with its margin."""
    sz = res.get("sizing") or {}
    feas = sorted((c for c in sz.get("candidates", []) if c.get("ok")), key=lambda c: c["cost"])
    fig = "chi" if any("chi" in c for c in feas) else None
    head = ["rank", "candidate", "cost", "more than the chosen", "χ [%] (design-rule gains)" if fig else "figure",
            "RMS current [A]", "tightest check (margin)"]
    body = []
    if not feas:
        return head, body
    c0 = feas[0]["cost"]
    for i, c in enumerate(feas[: n + 1]):
        t = c.get("tightest")
        tt = f"{t['name'].split(' ≤')[0].split(' ≥')[0]}: {100 * t['margin']:.1f} %" if t else "—"
        figv = _fmt(100 * c["chi"]) if fig and c.get("chi") is not None else "—"
        body.append(["chosen" if i == 0 else str(i + 1), c["label"], _fmt(c["cost"]),
                     "—" if i == 0 else f"+{_fmt(c['cost'] - c0)} ({100 * (c['cost'] - c0) / c0:.2g} %)", figv,
                     _fmt(c.get("current_rms_A")), tt])
    return head, body


def loop_rows(res) -> tuple:
    """The speed loop: crossover, margins (linearised at the running point), slowest pole, settling."""
    ctl = res.get("control") or {}
    head = ["quantity", "value"]
    body = []
    if ctl.get("crossover_rad_s") is not None:
        w = ctl["crossover_rad_s"]
        body.append(["design crossover ω_c (the gains' basis)", f"{_fmt(w)} rad/s ({_fmt(w / (2 * math.pi))} Hz)"])
    lp = ctl.get("loop") or {}
    if lp.get("phase_margin_deg") is not None:
        body += [["gain crossover of the loop at the plant input (linearised)",
                  f"{_fmt(lp['w_gain_crossover_rad_s'])} rad/s ({_fmt(lp['w_gain_crossover_rad_s'] / (2 * math.pi))} Hz)"],
                 ["phase margin", f"{_fmt(lp['phase_margin_deg'])}°"],
                 ["gain margin", f"{_fmt(lp['gain_margin_dB'])} dB"],
                 ["peak sensitivity M_s", _fmt(lp["Ms"])]]
    elif lp.get("note"):
        body.append(["margins", lp["note"]])
    if ctl.get("slowest_decay_1_s") is not None:
        body.append(["slowest closed-loop pole (mean-inertia model)", f"−{_fmt(ctl['slowest_decay_1_s'])} 1/s"])
    if ctl.get("settling_time_s") is not None:
        body.append(["settling time (4 / slowest decay)", f"{_fmt(ctl['settling_time_s'])} s"])
    return head, body


def loop_margins(res) -> dict:
    """The designed machine's speed loop linearised at its running point (mjbench.linearize: the
    loop broken at the plant input): crossover, phase and gain margins, M_s; a note if not possible."""
    if res.get("status") != "ok" or not res.get("machine"):
        return {"note": "no machine (the design is infeasible)"}
    try:
        spec = S.from_raw(res["machine"], "design")
        m = LN.study(spec, spec.mode(None), n_angles=0, multibody=False)["objects"]["margins"]  # the reduced plant
        return {"w_gain_crossover_rad_s": m.w_gain_crossover_rad_s, "phase_margin_deg": m.phase_margin_deg,
                "gain_margin_dB": m.gain_margin_dB, "Ms": m.Ms, "source": "mjbench.linearize at the running point"}
    except Exception as e:  # noqa: BLE001 - a report line, not the design
        return {"note": f"not linearised: {type(e).__name__}: {e}"}


def drive_rows(res) -> tuple:
    ch = res.get("chosen") or res.get("closest")
    head = ["item", "value"]
    if not ch:
        return head, []
    p = ch["predicted"]
    body = [["motor", ch["motor"]], ["gearbox", ch["gearbox"] or "direct drive"], ["ratio z", _fmt(ch["ratio"])],
            ["flywheel", flywheel_text(ch)],
            _gains_row(ch.get("gains")),
            ["gains from", res.get("control", {}).get("source", "—")],
            ["RMS / peak motor current [A]", f"{_fmt(p.get('current_rms_A'))} / {_fmt(p.get('current_peak_A'))}"],
            ["winding temperature (steady) [°C]", _fmt(ch["thermal"].get("T_winding_C"))],
            ["speed fluctuation χ [%]", _fmt(_scaled(p.get("chi"), 100.0))] if p.get("tracking_peak_rad") is None else
            ["tracking error |q_ref − q|, peak / RMS [rad]",
             f"{_fmt(p.get('tracking_peak_rad'))} / {_fmt(p.get('tracking_rms_rad'))}"]]
    sz = res.get("sizing", {})
    sw = sz.get("ratio_sweep", {})
    if sw:
        body.append([f"gear-ratio study for {sw['motor']} (continuous ratio, no flywheel)", ratio_study_text(sw, ch)])
    fw = sz.get("flywheel", {})
    if fw:
        body.append(["energy swing ΔE per cycle [J]", _fmt(fw.get("dE_J"))])
    if sz:
        body.append(["catalogue candidates: total / analysed / feasible",
                     f"{sz['n_candidates']} / {sz['n_analysed']} / {sz['n_feasible']}"])
    return head, body


def ratio_study_text(sw, ch) -> str:
    """The gear-ratio study in words: what it assumes, where its optimum is and why, and how the
    chosen ratio relates to it."""
    txt = (f"least RMS motor torque at z = {_fmt(sw['z_best'])}, the crank held at exactly constant speed without "
           f"a flywheel, so the motor carries the whole torque ripple")
    if sw.get("best_at_envelope_limit"):
        txt += (" — there the ripple's torque peaks bring the armature voltage (or the motor speed, or T_peak) to its "
                "limit, so a higher ratio is not allowed in this study")
    z = ch.get("ratio")
    if z is not None and sw.get("z_best") and abs(float(z) - float(sw["z_best"])) > 1e-6 * float(z):
        txt += (f"; the chosen catalogue ratio z = {_fmt(z)} "
                + ("lies beyond it because its flywheel carries the ripple (peak motor torque "
                   f"{_fmt((ch.get('predicted') or {}).get('motor_torque_peak_Nm'))} N·m), which keeps the voltage "
                   f"within the supply" if ch.get("flywheel_kgm2") and float(z) > float(sw["z_best"])
                   else "is the cheapest feasible gearbox, not this study's optimum"))
    return txt + f"; the lossless closed form without limits: z = {_fmt(sw['z_closed_form'])}"


#: how linkage_rows shows the synthesis's quantities: key suffix → (unit shown, scale)
LINKAGE_UNITS = (("_m", "mm", 1e3), ("_rad", "°", 180.0 / math.pi), ("_deg", "°", 1.0))


def linkage_rows(res) -> tuple:
    syn = res.get("synthesis", {})
    head = ["quantity", "value"]
    if syn.get("kind") == "given":
        return head, [["mechanism", f"given: scenario {syn.get('scenario')}"]]
    a = syn.get("achieved", {})
    body = []
    for k, v in a.items():
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            continue
        suf = next((s for s in LINKAGE_UNITS if k.endswith(s[0])), None)
        if suf is None:
            body.append([k.replace("_", " "), _fmt(v)])
        else:
            body.append([f"{k[:-len(suf[0])].replace('_', ' ')} [{suf[1]}]", _fmt(v * suf[2])])
    sc = syn.get("solver_check", {})
    if "residual" in sc:
        body.append(["largest residual vs mjbench's position solver", _fmt(sc["residual"])])
        body.append(["branch: largest closed-form vs solver joint distance over a turn [mm]",
                     _fmt(_scaled(sc.get("branch_max_position_diff_m"), 1e3))])
    return head, body


# ============================================================================ markdown / html
def _md_table(head, body):
    cell = lambda x: str(x).replace("|", "\\|").replace("\n", " ")  # noqa: E731
    out = ["| " + " | ".join(cell(h) for h in head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(cell(x) for x in row) + " |" for row in body]
    return out


def markdown(res) -> str:
    st = res["status"]
    md = [f"# Design `{res['name']}`: {res.get('title') or ''}", "",
          f"**Status: {'meets its requirements' if st == 'ok' else 'INFEASIBLE — does not meet its requirements'}.** "
          f"Requirements: `{res['requirements_source']}`; catalogue: `{os.path.basename(res['catalogue']['source'])}`"
          + (" (**illustrative values**, not a vendor's data)" if res["catalogue"].get("illustrative") else "") + ".",
          f"Duty: {res['duty']['speed_rpm']:.4g} rpm ({res['duty']['speed_rad_s']:.4g} rad/s)"
          + (f", χ ≤ {100 * res['duty']['chi_max']:g} %" if res["duty"].get("chi_max") else "") + _law_text(res["duty"])
          + f", ambient {res['duty']['ambient_C']:g} °C.", ""]
    if res.get("failures"):
        md += ["**What fails:**", ""]
        for f in res["failures"]:
            md.append(f"- ({f.get('stage')}) {failure_text(f)}"
                      + (f" — {f['note']}" if f.get("note") else "") + (f" [{f['candidate']}]" if f.get("candidate") else ""))
        md.append("")
    if selection_text(res):
        md += ["## Why this drive", "", selection_text(res), ""]
        head, body = runners_up_rows(res)
        if body:
            md += ["The chosen candidate and the next three feasible ones (margin: how far the tightest check is "
                   "from its limit):", ""] + _md_table(head, body) + [""]
    md += ["## Requirements vs achieved", ""] + _md_table(*requirements_rows(res)) + [""]
    if res.get("checks"):
        md += ["## Predicted (sizing model) vs simulated (multibody)", ""] + _md_table(*checks_rows(res)) + [""]
    md += ["## Drive", ""] + _md_table(*drive_rows(res)) + [""]
    if loop_rows(res)[1]:
        md += ["## Speed loop", ""] + _md_table(*loop_rows(res)) + [""]
    md += ["## Linkage", ""] + _md_table(*linkage_rows(res)) + [""]
    if "design.png" in (res.get("files") or []) or res.get("_figure"):
        md += ["![design](design.png)", ""]
    t = res.get("timing", {})
    md += [f"Synthesis + sizing {t.get('synthesis_and_sizing_cpu_s', 0):.2f} s CPU; the whole design "
           f"{t.get('total_wall_s', 0):.1f} s wall. Files: `machine.toml` (run, analyze, tune, render it), "
           f"`design.json` (every number)." if st == "ok" else
           f"Synthesis + sizing {t.get('synthesis_and_sizing_cpu_s', 0):.2f} s CPU. No machine.toml: the design "
           f"does not meet its requirements (design.json holds the closest candidate)."]
    return "\n".join(md) + "\n"


_CSS = ("body{font-family:DejaVu Sans,Arial,sans-serif;max-width:1100px;margin:1.2em auto;padding:0 1em;color:#222}"
        "table{border-collapse:collapse;margin:.6em 0;font-size:.86em}th,td{border:1px solid #bbb;padding:.2em .45em;"
        "text-align:left;vertical-align:top}th{background:#eef1f5}.ok{background:#e6f5e6}.bad{background:#fdebd6}"
        "img{max-width:100%;border:1px solid #ddd}.st{font-size:1.1em;padding:.4em .8em}")


def _html_table(head, body, pass_col=None):
    e = html.escape
    out = ["<table><tr>" + "".join(f"<th>{e(h)}</th>" for h in head) + "</tr>"]
    for row in body:
        cls = ""
        if pass_col is not None:
            cls = ' class="ok"' if row[pass_col] == "✔" else ' class="bad"'
        out.append(f"<tr{cls}>" + "".join(f"<td>{e(str(x))}</td>" for x in row) + "</tr>")
    return "\n".join(out + ["</table>"])


def html_page(res) -> str:
    e = html.escape
    st = res["status"]
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             f"<title>mjbench design {e(res['name'])}</title><style>{_CSS}</style></head><body>",
             f"<h1>Design <code>{e(res['name'])}</code>: {e(res.get('title') or '')}</h1>",
             f'<p class="st {"ok" if st == "ok" else "bad"}"><b>Status: '
             f"{'meets its requirements' if st == 'ok' else 'INFEASIBLE — does not meet its requirements'}</b></p>",
             f"<p>Requirements <code>{e(res['requirements_source'])}</code>; catalogue "
             f"<code>{e(os.path.basename(res['catalogue']['source']))}</code>"
             + (" (<b>illustrative values</b>, not a vendor's data)" if res["catalogue"].get("illustrative") else "")
             + f". Duty {res['duty']['speed_rpm']:.4g} rpm"
             + (f", χ ≤ {100 * res['duty']['chi_max']:g} %" if res["duty"].get("chi_max") else "")
             + e(_law_text(res["duty"])) + ".</p>"]
    if res.get("failures"):
        parts.append("<p><b>What fails:</b></p><ul>" + "".join(
            f"<li>({e(str(f.get('stage')))}) {e(failure_text(f))}" + (f" — {e(f['note'])}" if f.get("note") else "")
            + (f" [{e(f['candidate'])}]" if f.get("candidate") else "") + "</li>"
            for f in res["failures"]) + "</ul>")
    if selection_text(res):
        import re

        rule = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", e(selection_text(res)))
        parts += ["<h2>Why this drive</h2>", f"<p>{rule}</p>"]
        head, body = runners_up_rows(res)
        if body:
            parts += ["<p>The chosen candidate and the next three feasible ones (margin: how far the tightest check "
                      "is from its limit):</p>", _html_table(head, body)]
    parts += ["<h2>Requirements vs achieved</h2>", _html_table(*requirements_rows(res), pass_col=5)]
    if res.get("checks"):
        parts += ["<h2>Predicted (sizing model) vs simulated (multibody)</h2>", _html_table(*checks_rows(res), pass_col=5)]
    parts += ["<h2>Drive</h2>", _html_table(*drive_rows(res))]
    if loop_rows(res)[1]:
        parts += ["<h2>Speed loop</h2>", _html_table(*loop_rows(res))]
    parts += ["<h2>Linkage</h2>", _html_table(*linkage_rows(res))]
    if "design.png" in (res.get("files") or []) or res.get("_figure"):
        parts.append('<p><img src="design.png" alt="design figure"></p>')
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


# ============================================================================ figure
def figure(res, path):
    """Linkage at eight crank angles (or the traced point's path), torques, current and speed over
    one cycle: predicted (harmonic balance) and simulated (multibody)."""

    if res.get("duty", {}).get("law"):  # a motion-law duty: over the cycle's time
        return law_figure(res, path)
    sz = res.get("_sizing")
    tr = (res.get("_trajectories") or {}).get("multibody")
    ch = res.get("_final") or (sz.chosen if sz is not None else None)
    with ps.context():
        fig, ax = ps.new(2, 2, figsize=(11, 8))
        a = ax[0][0]
        mech = res.get("mechanism") or {}
        geom = res.get("_geometry")
        q8 = np.linspace(0, 2 * np.pi, 8, endpoint=False)
        if geom is not None:
            s = geom.solve(q8)
            for k in range(len(q8)):
                al = 0.25 + 0.75 * (k == 0)
                if hasattr(geom, "D"):
                    xy = np.array([geom.A, s["B"][k], s["C"][k], geom.D])
                    a.plot(xy[:, 0], xy[:, 1], "-o", color="C0", alpha=al, ms=3)
                    if "P" in s:
                        tri = np.array([s["B"][k], s["P"][k], s["C"][k]])
                        a.plot(tri[:, 0], tri[:, 1], "-", color="C1", alpha=al)
                else:
                    xy = np.array([geom.O, s["B"][k], s["C"][k]])
                    a.plot(xy[:, 0], xy[:, 1], "-o", color="C0", alpha=al, ms=3)
            qq = np.linspace(0, 2 * np.pi, 361)
            ss = geom.solve(qq)
            key = "P" if "P" in ss else "C"
            a.plot(ss[key][:, 0], ss[key][:, 1], ":", color="C3", lw=1, label="output point path")
            a.legend(loc="best", fontsize=7)
        elif mech:
            m = MR.from_dict(mech)
            qq = np.linspace(0, 2 * np.pi, 361)
            tp = m.trace_point(qq)
            m.draw_profile(a)  # outlines beyond the points (a cam: its profile and pitch curve)
            if tp is not None:
                a.plot(tp[0], tp[1], color="C3", label="traced point")
                a.legend(loc="best", fontsize=7)
        a.set_aspect("equal", adjustable="datalim")
        a.set_xlabel(ps.label("x", "m"))
        a.set_ylabel(ps.label("y", "m"))
        a.set_title("cam at θ = 0 and the follower's path" if mech.get("type") == "cam"
                    else "linkage (crank at 0°, 45°, … ; bold: 0°)", fontsize=9)
        if sz is not None and ch is not None and ch.ss is not None:
            ss = ch.ss
            qdeg = np.degrees(sz.q) % 360
            o = np.argsort(qdeg)
            ax[0][1].plot(qdeg[o], sz.T_L[o], color="0.5", label="mechanism at constant speed (inverse dynamics)")
            qp = np.degrees(ss["q"]) % 360
            op = np.argsort(qp)
            ax[0][1].plot(qp[op], ss["T_gear"][op], color="C0", label="gearbox output, predicted")
            qm = np.degrees(ss["q"]) % 360
            ax[1][0].plot(qm[op], ss["I"][op], color="C0", label="predicted (harmonic balance)")
            ax[1][1].plot(qm[op], ss["qd"][op], color="C0", label="predicted (harmonic balance)")
            if tr is not None:
                ver = res.get("verification", {}).get("achieved", {})
                c0, c1 = ver.get("cycle_s", [tr.t[0], tr.t[-1]])
                sel = (tr.t >= c0) & (tr.t <= c1)
                qs = np.degrees(tr.q[sel]) % 360
                os_ = np.argsort(qs)
                dm = ch.drive
                ax[0][1].plot(qs[os_], dm.gear_output_of_run(tr.current[sel], tr.omega[sel], tr.qdd[sel])[os_], "--", color="C1",
                              label="gearbox output, multibody")
                ax[1][0].plot(qs[os_], tr.current[sel][os_], "--", color="C1", label="multibody")
                ax[1][1].plot(qs[os_], tr.qd[sel][os_], "--", color="C1", label="multibody")
            ax[0][1].set_ylabel(ps.label("crank torque", "N·m"))
            ax[1][0].set_ylabel(ps.label("motor current", "A"))
            ax[1][1].set_ylabel(ps.label("crank speed", "rad/s"))
            for a2 in (ax[0][1], ax[1][0], ax[1][1]):
                a2.set_xlabel(ps.label("crank angle q mod 360°", "°"))
                a2.legend(loc="best", fontsize=7)
        ps.finish(fig, f"mjbench design {res['name']}: {res['status']}")
        return save(fig, path)


# ============================================================================ writing
def write(res: dict, out, scn_doc, force=False) -> list:
    """Write the outputs into ``out`` (whole or nothing); returns the file names."""
    files = []
    with staged_dir(out, force=force) as tmp:
        if scn_doc is not None and res["status"] == "ok":
            head = (f"{scn_doc['scenario']['name']}: written by `mjbench design` from {res['requirements_source']}\n"
                    f"{res.get('chosen', {}).get('motor')} + {res.get('chosen', {}).get('gearbox') or 'direct drive'}"
                    f" (catalogue {os.path.basename(res['catalogue']['source'])}"
                    + (": illustrative values" if res["catalogue"].get("illustrative") else "") + ")\n"
                    "Starts from rest; simulation.t_end covers the start-up and the control loop's settling, and\n"
                    "its last cycle (metrics.chi_window) is the periodic steady state design.json predicts and verifies.")
            text = B.toml_dumps(scn_doc, header=head)
            atomic_write(tmp / "machine.toml", lambda f: f.write(text))
            files.append("machine.toml")
        try:
            if res.get("_sizing") is not None or res.get("_geometry") is not None:
                figure(res, tmp / "design.png")
                files.append("design.png")
        except Exception as e:  # noqa: BLE001 - a figure problem must not lose the design
            res["figure_error"] = f"{type(e).__name__}: {e}"
        if res.get("control") is not None and "loop" not in res["control"]:
            res["control"]["loop"] = loop_margins(res)
        res["files"] = files + ["design.json", "design.md", "design.html"]
        write_json(tmp / "design.json", public(res))
        md = markdown(res)
        atomic_write(tmp / "design.md", lambda f: f.write(md))
        page = html_page(res)
        atomic_write(tmp / "design.html", lambda f: f.write(page))
    return res["files"]
