"""``mjbench linearize SCENARIO [--mode M] [--at q=..,omega=..] --out DIR``: the machine's linear
model (reduced and multibody), its loop, margins, poles and the frozen-angle family
(:mod:`mjbench.linear`).  Writes bode.png, nyquist.png, poles.png, plant.png and linear.json."""
from __future__ import annotations

import os

from ..outputs import add_force_option, staged_dir, write_json
from . import integer, parse_numbers

AT_KEYS = {"q": "q", "omega": "qd", "qd": "qd", "I": "I", "t": "t"}


def register(sub):
    p = sub.add_parser(
        "linearize", help="linear model, loop margins, poles and frozen-angle Bode family (python-control)",
        description="Linearise SCENARIO at an operating point (input angle q [rad], input speed omega [rad/s], "
                    "current I [A], time t [s] for K_p·t): the reduced model (analytic Jacobian) and the multibody "
                    "model (MuJoCo mjd_transitionFD), their agreement, the controller's discrete-time counterpart, "
                    "the loop at the plant input (gain/phase margins, peak |S|, bandwidth, closed-loop poles) and "
                    "the loop at frozen angles over one turn. Default point: the initial angle, the controller's "
                    "running speed there, the current holding q̈ = 0, t = simulation.t_end for a K_p·t PID.")
    p.add_argument("scenario", help="built-in scenario name or TOML path")
    p.add_argument("--mode", help="controller mode (default: the scenario's)")
    p.add_argument("--at", action="append", default=[], metavar="q=..,omega=..",
                   help="operating point: q [rad], omega [rad/s, input side], I [A], t [s] (comma-separated)")
    p.add_argument("--angles", type=integer(ge=0, le=3600), default=36,
                   help="frozen angles over one turn (0: none; default 36)")
    p.add_argument("--no-multibody", action="store_true", help="skip the MuJoCo linearisation")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--out", required=True, help="output directory (written whole or not at all)")
    add_force_option(p)
    p.set_defaults(func=cmd_linearize)


#: |value| limits of an operating point: beyond any motor a DC drive model covers (the plausible
#: ranges of mjbench.units for angular velocity and current); t: a run length
AT_LIMITS = {"omega": 1e5, "qd": 1e5, "I": 1e5, "t": 1e5}


def parse_at(items) -> dict:
    """``--at q=..,omega=..,I=..,t=..`` → {q, qd, I, t} (floats, SI), checked: finite, |ω| and
    |I| ≤ 1e5, 0 ≤ t ≤ 1e5 s (t is the time of the K_p·t ramp: a negative one is a negative gain)."""
    from ..errors import ParameterError

    got = parse_numbers(items, "--at", [("q", "rad"), ("omega", "rad/s"), ("qd", "rad/s"), ("I", "A"), ("t", "s")])
    if "omega" in got and "qd" in got:
        raise ParameterError("--at omega and qd are the same input speed: give one of them")
    for k, v in got.items():
        lim = AT_LIMITS.get(k)
        if lim is not None and abs(v) > lim:
            raise ParameterError(f"--at {k}={v:g}: |{k}| must be <= {lim:g} {dict(omega='rad/s', qd='rad/s', I='A', t='s')[k]} "
                                 f"(beyond what the drive model covers)")
    if got.get("t", 0.0) < 0:
        raise ParameterError(f"--at t={got['t']:g}: must be >= 0 s (the time of the run; K_p·t would be a negative gain)")
    return {AT_KEYS[k]: v for k, v in got.items()}


def cmd_linearize(args):
    from .. import linear as LN
    from .. import linear_plots as LP
    from .. import plotstyle
    from .. import scenario as S
    from ..preflight import check_machine

    from ..errors import SimulationDiverged

    at = parse_at(args.at)
    scn = S.load(args.scenario, args.overrides)
    check_machine(scn, args.mode)
    with staged_dir(args.out, force=args.force) as out:
        try:
            res = LN.study(scn, args.mode, n_angles=args.angles, multibody=not args.no_multibody, **at)
        except ArithmeticError as e:  # (ZeroDivisionError, OverflowError, FloatingPointError)
            point = ", ".join(f"{k}={v:g}" for k, v in at.items()) or "the default operating point"
            raise SimulationDiverged(f"linearize at {point}: the linear model cannot be computed there "
                                     f"({type(e).__name__}: {e}); the state is out of the model's numerical range "
                                     f"(a speed or current far beyond the motor's?)") from None
        js, objs = res["json"], res["objects"]
        write_json(os.path.join(out, "linear.json"), js, indent=1)
        with plotstyle.context():
            LP.family_figures(objs, os.fspath(out), scn.name)
    print(summary(js))
    print(f"results written to {args.out}")
    return 0


def summary(js) -> str:
    """Text summary of a linear.json."""
    def f(v, fmt="{:.4g}"):
        return "—" if v is None or v != v else ("∞" if v in (float("inf"), float("-inf")) else fmt.format(v))

    op = js["operating_point"]
    lines = [f"{js['scenario']} (mode {js['mode']}, {js['controller']}): q* = {f(op['q_rad'])} rad, "
             f"q̇* = {f(op['qd_rad_s'])} rad/s, I* = {f(op['I_A'])} A, V* = {f(op['V_V'])} V"
             + (f", t = {f(op['t_s'])} s" if op["t_s"] else "") + f"; angle model: {js['angle_model']}"]
    for w in js.get("warnings", []):
        lines.append(f"WARNING: {w}")
    ag = js.get("agreement", {})
    if "reduced_vs_multibody_input_coordinates" in ag:
        a = ag["reduced_vs_multibody_input_coordinates"]
        lines.append(f"  plant q̇/V, reduced vs multibody (input coordinates): max relative difference "
                     f"{f(a['max_rel'], '{:.2e}')} over {f(a['omega_lo_rad_s'])}-{f(a['omega_hi_rad_s'])} rad/s")
    tm = js.get("transmission_modes")
    if tm:
        for k, v in tm.items():
            lines.append(f"  transmission mode, {k:<7s}: " + ", ".join(
                f"ω_n = {f(m['omega_n_rad_s'])} rad/s, ζ = {f(m['zeta'])}" for m in v))
    lp = js.get("loop")
    if lp:
        lines.append(f"  loop: GM = {f(lp['gain_margin_dB'])} dB, PM = {f(lp['phase_margin_deg'])}°, "
                     f"peak |S| = {f(lp['peak_sensitivity'])}, bandwidth = {f(lp['bandwidth_rad_s'])} rad/s, "
                     f"{'stable' if lp['stable'] else 'UNSTABLE'} (spectral radius {f(lp['spectral_radius'], '{:.6f}')})")
    elif js.get("loop_note"):
        lines.append(f"  no loop analysis: {js['loop_note']}")
    fa = js.get("frozen_angle")
    if fa:
        w, v = fa["worst"], fa["validity"]
        lines.append(f"  frozen angles ({len(fa['angles_rad'])}): worst PM {f(w['phase_margin_deg']['value'])}° at q = "
                     f"{f(w['phase_margin_deg']['at_q_rad'])} rad, worst GM {f(w['gain_margin_dB']['value'])} dB at q = "
                     f"{f(w['gain_margin_dB']['at_q_rad'])} rad, max peak |S| {f(w['peak_sensitivity']['value'])}"
                     f"{'' if w['all_stable'] else ', some frozen loops UNSTABLE'}")
        lines.append(f"  frozen-angle validity ν = {f(v['ratio'])} ({v['verdict']}): inertia/reference change rate "
                     f"{f(max(v['inertia_rate_max_1_s'] or 0, v['reference_rate_max_1_s'] or 0))} 1/s vs bandwidth "
                     f"{f(v['bandwidth_min_rad_s'])} rad/s")
    kr = js.get("kp_ramp")
    if kr:
        lim = kr["limit"]
        lines.append(f"  K_p·t = {f(kr['kp_eff'])} V·s/rad at t = {f(kr['t_s'])} s; the sampled loop loses stability at "
                     f"t = {f(lim['t_s'])} s (K_p·t = {f(lim['kp_eff'])}, q = {f(lim['at_q_rad'])} rad)")
    return "\n".join(lines)

