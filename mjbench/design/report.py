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


def public(res: dict) -> dict:
    """The result without its in-memory objects (keys starting with '_')."""
    return {k: v for k, v in res.items() if not k.startswith("_")}


# ============================================================================ text
def summary_text(res: dict) -> str:
    lines = [f"mjbench design {res['name']}: {res['status'].upper()}"]
    ch = res.get("chosen")
    if ch:
        lines.append(f"  drive: {ch['motor']} + {ch['gearbox'] or 'direct drive'} (z = {ch['ratio']:g})"
                     + (f", flywheel {ch['flywheel_kgm2']:.4g} kg·m²" if ch["flywheel_kgm2"] > 0 else ", no flywheel")
                     + f"; gains {_gains_text(ch['gains'])} ({res.get('control', {}).get('source', '')})")
    for c in res.get("checks", []):
        lines.append(f"  check {c['name']}: predicted {_fmt(c['predicted'])}, simulated {_fmt(c['achieved'])}, "
                     f"{_pct(c['rel_diff'])} (tolerance {100 * c['tolerance']:.3g} %) {'ok' if c['ok'] else 'FAIL'}")
    if res.get("closest") and res["status"] != "ok":
        c = res["closest"]
        lines.append(f"  closest candidate: {c['motor']} + {c['gearbox'] or 'direct drive'}"
                     + (f", flywheel {c['flywheel_kgm2']:.4g} kg·m²" if c["flywheel_kgm2"] else ""))
    for f in res.get("failures", []):
        v = f.get("value")
        lim = f.get("limit", f.get("required"))
        lines.append(f"  FAILS ({f.get('stage')}): {f['name']}" + (f" = {_fmt(v)}" if not isinstance(v, bool) and v is not None else "")
                     + (f" (limit {_fmt(lim)} {f.get('unit', '')})" if lim is not None and not isinstance(lim, bool) else "")
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
        req = r["required"]
        cmp = {"max": "≤ ", "min": "≥ ", "eq": "= "}.get(r["compare"], "")
        body.append([r["name"], (cmp + _fmt(req)) if req is not None else "—", _fmt(r["achieved"]), r["unit"],
                     _pct(r["margin"]) if r["margin"] is not None else "—", "✔" if r["ok"] else "✘", r["source"]])
    syn = res.get("synthesis", {})
    measured = ("stroke", "time ratio", "rocker swing", "minimum transmission angle", "precision points met",
                "poses met")
    for c in syn.get("constraints", []):
        if any(c["name"] == r["name"] for r in res.get("requirements_table", [])):
            continue
        if res.get("requirements_table") and c["name"].startswith(measured):
            continue  # the same requirement measured by mjbench's own solver is in the table
        body.append([c["name"], ({"min": "≥ ", "max": "≤ "}.get(c["compare"], "") + _fmt(c["limit"]))
                     if c["limit"] is not None else "—", _fmt(c["value"]), c["unit"], "—", "✔" if c["ok"] else "✘",
                     "synthesis (closed form)" + (f"; {c['note']}" if c.get("note") else "")])
    return head, body


def checks_rows(res) -> tuple:
    head = ["prediction", "predicted", "simulated", "rel. diff", "tolerance", "pass"]
    body = [[c["name"], _fmt(c["predicted"]), _fmt(c["achieved"]), _pct(c["rel_diff"]),
             f"{100 * c['tolerance']:.3g} %", "✔" if c["ok"] else "✘"] for c in res.get("checks", [])]
    return head, body


def drive_rows(res) -> tuple:
    ch = res.get("chosen") or res.get("closest")
    head = ["item", "value"]
    if not ch:
        return head, []
    p = ch["predicted"]
    body = [["motor", ch["motor"]], ["gearbox", ch["gearbox"] or "direct drive"], ["ratio z", _fmt(ch["ratio"])],
            [f"flywheel on the {ch.get('flywheel_location', 'crank')} shaft [kg·m²]", _fmt(ch["flywheel_kgm2"])],
            _gains_row(ch.get("gains")),
            ["gains from", res.get("control", {}).get("source", "—")],
            ["RMS / peak motor current [A]", f"{_fmt(p.get('current_rms_A'))} / {_fmt(p.get('current_peak_A'))}"],
            ["winding temperature (steady) [°C]", _fmt(ch["thermal"].get("T_winding_C"))],
            ["speed fluctuation χ", _fmt(p.get("chi"))] if p.get("tracking_peak_rad") is None else
            ["tracking error |q_ref − q|, peak / RMS [rad]",
             f"{_fmt(p.get('tracking_peak_rad'))} / {_fmt(p.get('tracking_rms_rad'))}"]]
    sz = res.get("sizing", {})
    sw = sz.get("ratio_sweep", {})
    if sw:
        body.append([f"ratio of least RMS torque for {sw['motor']} (brute force; closed form)",
                     f"{_fmt(sw['z_best'])}{' (at the speed/voltage limit)' if sw.get('best_at_envelope_limit') else ''}; "
                     f"{_fmt(sw['z_closed_form'])}"])
    fw = sz.get("flywheel", {})
    if fw:
        body.append(["energy swing ΔE per cycle [J]", _fmt(fw.get("dE_J"))])
    if sz:
        body.append(["catalogue candidates: total / analysed / feasible",
                     f"{sz['n_candidates']} / {sz['n_analysed']} / {sz['n_feasible']}"])
    return head, body


def linkage_rows(res) -> tuple:
    syn = res.get("synthesis", {})
    head = ["quantity", "value"]
    if syn.get("kind") == "given":
        return head, [["mechanism", f"given: scenario {syn.get('scenario')}"]]
    a = syn.get("achieved", {})
    body = [[k, _fmt(v)] for k, v in a.items() if isinstance(v, (int, float)) and not isinstance(v, bool)]
    sc = syn.get("solver_check", {})
    if "residual" in sc:
        body.append(["largest residual vs mjbench's position solver", _fmt(sc["residual"])])
        body.append(["branch: largest closed-form vs solver joint distance over a turn [m]",
                     _fmt(sc.get("branch_max_position_diff_m"))])
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
          + (f", χ ≤ {res['duty']['chi_max']:g}" if res["duty"].get("chi_max") else "") + _law_text(res["duty"])
          + f", ambient {res['duty']['ambient_C']:g} °C.", ""]
    if res.get("failures"):
        md += ["**What fails:**", ""]
        for f in res["failures"]:
            md.append(f"- ({f.get('stage')}) {f['name']}" + (f": {_fmt(f.get('value'))}" if not isinstance(f.get('value'), bool) and f.get('value') is not None else "")
                      + (f" vs {_fmt(f.get('limit'))}" if f.get("limit") is not None and not isinstance(f.get("limit"), bool) else "")
                      + (f" — {f['note']}" if f.get("note") else "") + (f" [{f['candidate']}]" if f.get("candidate") else ""))
        md.append("")
    md += ["## Requirements vs achieved", ""] + _md_table(*requirements_rows(res)) + [""]
    if res.get("checks"):
        md += ["## Predicted (sizing model) vs simulated (multibody)", ""] + _md_table(*checks_rows(res)) + [""]
    md += ["## Drive", ""] + _md_table(*drive_rows(res)) + [""]
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
             + (f", χ ≤ {res['duty']['chi_max']:g}" if res["duty"].get("chi_max") else "")
             + e(_law_text(res["duty"])) + ".</p>"]
    if res.get("failures"):
        parts.append("<p><b>What fails:</b></p><ul>" + "".join(
            f"<li>({e(str(f.get('stage')))}) {e(f['name'])}" + (f" — {e(f['note'])}" if f.get("note") else "") + "</li>"
            for f in res["failures"]) + "</ul>")
    parts += ["<h2>Requirements vs achieved</h2>", _html_table(*requirements_rows(res), pass_col=5)]
    if res.get("checks"):
        parts += ["<h2>Predicted (sizing model) vs simulated (multibody)</h2>", _html_table(*checks_rows(res), pass_col=5)]
    parts += ["<h2>Drive</h2>", _html_table(*drive_rows(res)), "<h2>Linkage</h2>", _html_table(*linkage_rows(res))]
    if "design.png" in (res.get("files") or []) or res.get("_figure"):
        parts.append('<p><img src="design.png" alt="design figure"></p>')
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


# ============================================================================ figure
def figure(res, path):
    """Linkage at eight crank angles (or the traced point's path), torques, current and speed over
    one cycle: predicted (harmonic balance) and simulated (multibody)."""
    from .. import plotstyle as ps
    from ..plots import save

    if res.get("duty", {}).get("law"):  # a motion-law duty: over the cycle's time
        from .law_duty import figure as law_figure

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
            from .. import mechanisms as MR
            m = MR.from_dict(mech)
            qq = np.linspace(0, 2 * np.pi, 361)
            tp = m.trace_point(qq)
            draw = getattr(m, "draw_profile", None)  # a cam: its profile and pitch curve
            if draw is not None:
                draw(a)
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
                ax[0][1].plot(qs[os_], dm.gear_output(tr.current[sel], tr.omega[sel], tr.qdd[sel])[os_], "--", color="C1",
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
        res["files"] = files + ["design.json", "design.md", "design.html"]
        write_json(tmp / "design.json", public(res))
        md = markdown(res)
        atomic_write(tmp / "design.md", lambda f: f.write(md))
        page = html_page(res)
        atomic_write(tmp / "design.html", lambda f: f.write(page))
    return res["files"]
