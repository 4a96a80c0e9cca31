"""The FRF-vs-linear tables of docs/bridges.md §3: `mjbench frest` on the shipped scenarios' default
modes (ideal drive) and on seeds 000 / 004 with the realistic drive of docs/drivetrain.md
(switching PWM, 2000-line encoder with M/T speed, 0.1° backlash, Coulomb friction); with
``--elements``, each element of the realistic drive alone on seed 000's PID (limiter removed) and seed
004's PID mode, at the report's settings (mjbench/papers/frest_study.py).

    python scripts/frest_table.py [--backend reduced] [--only NAME ...] > table.md
    python scripts/frest_table.py --elements > elements.md
"""
from __future__ import annotations

import argparse
import sys
import time

from mjbench import frest
from mjbench import scenario as S
from mjbench.papers.drivetrain_study import elements, realistic
from mjbench.papers.frest_study import NO_LIMIT, SETTINGS

CASES = [("incerti-bezier", None, [], "ideal"), ("incerti-belt", None, [], "ideal"),
         ("incerti2012", "pid", [], "ideal"),
         ("incerti2012", "pid", NO_LIMIT, "ideal, no limiter"),
         ("incerti2012", "pid", realistic("incerti2012", "mt"), "realistic (M/T)"),
         ("incerti2012", "pid", realistic("incerti2012", "mt") + NO_LIMIT, "realistic (M/T), no limiter"),
         ("yigit2023", "smc", [], "ideal"), ("yigit2023", "smc", realistic("yigit2023", "mt"), "realistic (M/T)"),
         ("yigit2023", "pid", [], "ideal"), ("yigit2023", "pid", realistic("yigit2023", "mt"), "realistic (M/T)"),
         ("hulako2025-model1", None, [], "ideal"), ("press-slidercrank", None, [], "ideal"),
         ("sixbar-watt2", None, [], "ideal"), ("toggle-press", None, [], "ideal"), ("mjcf-fourbar", None, [], "ideal"),
         ("incerti2012", "open", [], "ideal")]


def fmt(v, f="{:.3g}"):
    return "—" if v is None else ("∞" if v == float("inf") else f.format(v))


def cmp_text(c, k):
    x = c.get(k)
    if not x or x["max_rel_diff"] is None:
        return "—"
    return f"{x['max_rel_diff']:.2g} / {100 * x['max_mag_diff']:.3g} % / {x['max_phase_diff_deg']:.3g}°"


def row(name, js, label, seconds) -> str:
    c = js["comparison"]
    ff = js.get("frozen_family")
    fam = f"{cmp_text(c, 'plant_vs_family_mean')} / {100 * ff['plant_inside_envelope_fraction']:.0f} %" if ff else "—"
    sb = (ff or {}).get("sidebands")
    side = f"{100 * sb['speed_measured_max_rel']:.3g} % / {100 * sb['speed_frozen_max_rel']:.3g} %" if sb else "—"
    lp = js.get("loop") or {}
    m, ml = lp.get("margins") or {}, lp.get("margins_linear_on_lines") or {}
    per = js.get("periodic") or {}
    return (f"| {name} | {js['mode']} | {label} | {len(js['lines_rad_s'])} | {per.get('turns_per_period', '—')} "
            f"| {fmt(js['band_rad_s'][0])}–{fmt(js['band_rad_s'][1])} | {cmp_text(c, 'plant')} | {cmp_text(c, 'loop')} "
            f"| {fam} | {cmp_text(c, 'plant_vs_family_along_turn')} | {side} | {min(js['plant']['coherence']):.3f} "
            f"| {100 * js['limiter_active_fraction']:.0f} % "
            f"| {fmt(m.get('gain_margin_dB'))} dB / {fmt(m.get('phase_margin_deg'))}° / {fmt(m.get('peak_sensitivity'))} "
            f"| {fmt(ml.get('gain_margin_dB'))} dB / {fmt(ml.get('phase_margin_deg'))}° / {fmt(ml.get('peak_sensitivity'))} "
            f"| {seconds:.0f} s |")


HEAD = ("| scenario | mode | drive | lines | turns/period | frozen band [rad/s] | plant vs linear at q*: max rel / |mag| / phase "
        "| loop vs linear | plant vs family mean / inside envelope | plant vs family along the turn "
        "| ω ± Ω sidebands measured / frozen | min γ² | limiter on | GM / PM / peak|S| measured "
        "| linear, on the same lines | time |\n" + "|---" * 16 + "|")


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--backend", default="reduced")
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--elements", action="store_true", help="each realistic element alone (report settings)")
    a = ap.parse_args(argv)
    print(HEAD)
    if a.elements:
        todo = [("incerti2012", "pid", ov + NO_LIMIT, lab + " (no limiter)") for lab, ov in elements("incerti2012").items()]
        todo += [("yigit2023", "pid", ov, lab) for lab, ov in elements("yigit2023").items()]
        kw = dict(SETTINGS, backend=a.backend)
    else:
        todo, kw = CASES, {"backend": a.backend}
    for name, mode, ov, label in todo:
        if a.only and name not in a.only:
            continue
        t0 = time.time()
        try:
            js = frest.measure(S.load(name, ov), mode, **kw)["json"]
        except Exception as e:  # noqa: BLE001 - a row says why
            print(f"| {name} | {mode or ''} | {label} | error: {e} |")
            continue
        print(row(name, js, label, time.time() - t0), flush=True)


if __name__ == "__main__":
    sys.exit(main())
