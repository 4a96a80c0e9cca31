"""``mjbench frest SCENARIO [--mode M] [--at q=..,omega=..,t=..] --out DIR``: the frequency response
of the running nonlinear machine (plant and loop) with coherence, margins from the measured loop and
the linearisation overlaid (:mod:`mjbench.frest`, docs/bridges.md).  Writes frest.json and bode.png."""
from __future__ import annotations

import os

from ..outputs import add_force_option, staged_dir, write_json
from . import parse_numbers


def register(sub):
    p = sub.add_parser(
        "frest", help="frequency response of the nonlinear machine (multisine / stepped sine), vs the linearisation",
        description="Excite SCENARIO's running machine (mechanism, drive, drive train, controller) around an operating "
                    "point with a disturbance added to the controller output, measure the plant q̇/V and the loop L at "
                    "the plant input as python-control FRD with coherence, read gain/phase margins and peak |S| from the "
                    "measured loop, and overlay the linearisation (mjbench linearize) at the same point. Default point: "
                    "the initial angle at the controller's running speed (K_p·t frozen at simulation.t_end).")
    p.add_argument("scenario", help="built-in scenario name or TOML path")
    p.add_argument("--mode", help="controller mode (default: the scenario's)")
    p.add_argument("--at", action="append", default=[], metavar="q=..,omega=..",
                   help="operating point: q [rad], omega [rad/s, input side], I [A], t [s] (comma-separated)")
    p.add_argument("--signal", choices=["multisine", "sine"], default="multisine",
                   help="multisine (one run, default) or stepped sine (one run per frequency)")
    p.add_argument("--amplitude", type=float, default=None,
                   help="excitation peak [V] (default: 2 %% of the operating voltage, within the limiter's headroom)")
    p.add_argument("--band", default=None, metavar="LO,HI", help="frequency band [rad/s] (default: 1/period … "
                   "min(0.25 × Nyquist, 500 Hz))")
    p.add_argument("--lines", type=int, default=30, help="number of excited frequencies (default 30)")
    p.add_argument("--periods", type=int, default=3, help="measured periods (default 3: coherence over 3)")
    p.add_argument("--period", type=float, default=None, help="multisine period [s] (default 0.5 s, whole turns)")
    p.add_argument("--settle", type=float, default=None, help="settling time before measuring [s] (default: from "
                   "the linear closed loop's slowest pole)")
    p.add_argument("--backend", choices=["reduced", "multibody"], default="reduced")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--out", required=True, help="output directory (written whole or not at all)")
    add_force_option(p)
    p.set_defaults(func=cmd_frest)


def cmd_frest(args):
    from .. import frest as F
    from .. import scenario as S
    from ..errors import ParameterError
    from ..preflight import check_machine
    from .linearize import parse_at

    scn = S.load(args.scenario, args.overrides)
    check_machine(scn, args.mode)
    at = parse_at(args.at)
    band = None
    if args.band:
        try:
            lo, hi = (float(x) for x in args.band.split(","))
        except ValueError:
            raise ParameterError(f"--band {args.band!r}: expected LO,HI in rad/s") from None
        if not (0 < lo < hi):
            raise ParameterError(f"--band {args.band!r}: need 0 < LO < HI")
        band = (lo, hi)
    if args.periods < 2:
        raise ParameterError(f"--periods {args.periods}: at least 2 (the coherence needs two periods)")
    with staged_dir(args.out, force=args.force) as out:
        res = F.measure(scn, args.mode, backend=args.backend, signal=args.signal, amplitude=args.amplitude, band=band,
                        period=args.period, periods=args.periods, settle=args.settle, n_lines=args.lines, **at)
        write_json(os.path.join(out, "frest.json"), res["json"], indent=1)
        F.figure(res, os.path.join(out, "bode.png"), f"{scn.name} ({res['json']['mode']}, {args.backend})")
    print(summary(res["json"]))
    print(f"results written to {args.out}")
    return 0


def summary(js) -> str:
    def f(v, fmt="{:.4g}"):
        return "—" if v is None or v != v else ("∞" if v in (float("inf"), float("-inf")) else fmt.format(v))

    op = js["operating_point"]
    lines = [f"{js['scenario']} (mode {js['mode']}, {js['backend']}, {js['signal']}): q* = {f(op['q_rad'])} rad, "
             f"q̇* = {f(op['qd_rad_s'])} rad/s, V* = {f(op['V_V'])} V; amplitude {f(js['amplitude_V'])} V, "
             f"{len(js['lines_rad_s'])} lines {f(js['lines_rad_s'][0])}-{f(js['lines_rad_s'][-1])} rad/s"]
    c = js.get("comparison", {})
    for k in ("plant", "loop"):
        if k in c and c[k]["max_rel_diff"] is not None:
            lines.append(f"  {k} vs linearisation over {f(js['band_rad_s'][0])}-{f(js['band_rad_s'][1])} rad/s: "
                         f"max rel {f(c[k]['max_rel_diff'], '{:.2e}')}, |mag| {f(100 * c[k]['max_mag_diff'], '{:.3g}')} %, "
                         f"phase {f(c[k]['max_phase_diff_deg'], '{:.3g}')}°")
    lp = js.get("loop")
    if lp:
        m, ml = lp["margins"], lp.get("margins_linear") or {}
        lines.append(f"  measured loop: GM {f(m['gain_margin_dB'])} dB, PM {f(m['phase_margin_deg'])}°, peak |S| "
                     f"{f(m['peak_sensitivity'])}" + (f" (linear: {f(ml.get('gain_margin_dB'))} dB, "
                                                       f"{f(ml.get('phase_margin_deg'))}°, {f(ml.get('peak_sensitivity'))})"
                                                       if ml else ""))
    lines.append(f"  min coherence {f(min(js['plant']['coherence']), '{:.4f}')}, distortion ratio "
                 f"{f(js['distortion_ratio'], '{:.2e}')}; {js['band_note']}")
    for n in js.get("notes", []):
        lines.append(f"  note: {n}")
    return "\n".join(lines)
