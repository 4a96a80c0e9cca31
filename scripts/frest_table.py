"""The FRF-vs-linear table of docs/bridges.md §3: `mjbench frest` on the shipped scenarios' default
modes (ideal drive) and on seeds 000 / 004 with the realistic drive of docs/drivetrain.md
(switching PWM, 2000-line encoder with M/T speed, 0.1° backlash, Coulomb friction).

    python scripts/frest_table.py [--backend reduced] [--only NAME ...] > table.md
"""
from __future__ import annotations

import argparse
import sys
import time

from mjbench import frest
from mjbench import scenario as S
from mjbench.papers.drivetrain_study import realistic

CASES = [("incerti-bezier", None, [], "ideal"), ("incerti-belt", None, [], "ideal"),
         ("incerti2012", "pid", [], "ideal"),
         ("incerti2012", "pid", ["drive.v_max=inf", "modes.pid.v_limit=none"], "ideal, no limiter"),
         ("incerti2012", "pid", realistic("incerti2012", "mt"), "realistic (M/T)"),
         ("incerti2012", "pid", realistic("incerti2012", "mt") + ["drive.v_max=inf", "modes.pid.v_limit=none"],
          "realistic (M/T), no limiter"),
         ("yigit2023", "smc", [], "ideal"), ("yigit2023", "smc", realistic("yigit2023", "mt"), "realistic (M/T)"),
         ("hulako2025-model1", None, [], "ideal"), ("press-slidercrank", None, [], "ideal"),
         ("sixbar-watt2", None, [], "ideal"), ("toggle-press", None, [], "ideal"), ("mjcf-fourbar", None, [], "ideal"),
         ("incerti2012", "open", [], "ideal")]


def fmt(v, f="{:.3g}"):
    return "—" if v is None else f.format(v)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--backend", default="reduced")
    ap.add_argument("--only", nargs="*", default=None)
    a = ap.parse_args(argv)
    print("| scenario | mode | drive | band [rad/s] | plant: max rel / |mag| / phase | loop: max rel / |mag| / phase "
          "| plant vs frozen-angle family: mean / inside envelope "
          "| min γ² | distortion | limiter on | GM/PM/peak|S| measured | linear | time |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, mode, ov, label in CASES:
        if a.only and name not in a.only:
            continue
        t0 = time.time()
        try:
            js = frest.measure(S.load(name, ov), mode, backend=a.backend)["json"]
        except Exception as e:  # noqa: BLE001 - a row says why
            print(f"| {name} | {mode or ''} | {label} | error: {e} |")
            continue
        c = js["comparison"]

        def row(k):
            x = c.get(k)
            if not x or x["max_rel_diff"] is None:
                return "—"
            return f"{x['max_rel_diff']:.2e} / {100 * x['max_mag_diff']:.3g} % / {x['max_phase_diff_deg']:.3g}°"

        ff = js.get("frozen_family")
        fam = (f"{row('plant_vs_family_mean')} / {100 * ff['plant_inside_envelope_fraction']:.0f} %" if ff else "—")
        lp = js.get("loop") or {}
        m, ml = lp.get("margins") or {}, lp.get("margins_linear") or {}
        print(f"| {name} | {js['mode']} | {label} | {fmt(js['band_rad_s'][0])}–{fmt(js['band_rad_s'][1])} | {row('plant')} "
              f"| {row('loop')} | {fam} | {min(js['plant']['coherence']):.3f} | {js['distortion_ratio']:.2e} "
              f"| {100 * js['limiter_active_fraction']:.0f} % "
              f"| {fmt(m.get('gain_margin_dB'))} dB / {fmt(m.get('phase_margin_deg'))}° / {fmt(m.get('peak_sensitivity'))} "
              f"| {fmt(ml.get('gain_margin_dB'))} dB / {fmt(ml.get('phase_margin_deg'))}° / {fmt(ml.get('peak_sensitivity'))} "
              f"| {time.time() - t0:.0f} s |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
