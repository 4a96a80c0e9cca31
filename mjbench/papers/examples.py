"""Engineered examples (no paper): generic linkages and a user's MJCF (docs/linkages.md).

Cases: the offset slider-crank press, the Watt II six-bar, the knuckle-joint toggle press (each a
``[mechanism] type = "linkage"`` scenario: its reduced model comes from our own kinematics, an
independent check of the MuJoCo run) and the user's MJCF four-bar (``type = "mjcf"``: reduced model
MuJoCo-derived, cross-checked here against the Incerti 2012 closed form of the same geometry).

Report rows: what a designer looks at, from :func:`mjbench.analyze.analyze` at the run's set-point
speed — stroke, time ratio, swing, transmission-angle range, peak and RMS input torque, peak motor
torque against the motor line, energy per cycle — plus the run's multibody-vs-reduced agreement.
There is no paper value: each row's reason says what it is.  Figures: the run's time series
(``timeseries.png``, in the layout of Incerti 2012 Fig. 4) and the three ``mjbench analyze`` figures.
"""
from __future__ import annotations

import math

import numpy as np

from mjbench.papers import Case
from mjbench import analyze as A
from mjbench import scenario as S
from mjbench.reproduce import default_figures

KEY = "examples"
CITATION = "engineered examples"
TITLE = "Bring your own mechanism: generic planar linkages and a user's MJCF"
SCENARIOS = ("press-slidercrank", "sixbar-watt2", "toggle-press", "mjcf-fourbar")
CASES = [
    Case(name="example-press", scenario="press-slidercrank",
         title="Offset slider-crank press, 8 kN forming load, flywheel, PI speed control (60 SPM)",
         modes=["pi"], backend="both", video=True, video_t_end=3.0),
    Case(name="example-sixbar", scenario="sixbar-watt2",
         title="Watt II six-bar: 82° oscillating tool from a crank at 120 rpm, PI speed control",
         modes=["pi"], backend="both", video=True, video_t_end=2.0),
    Case(name="example-toggle-press", scenario="toggle-press",
         title="Knuckle-joint toggle press, 20 kN coining load, flywheel, PI speed control (40 SPM)",
         modes=["pi"], backend="both", video=True, video_t_end=3.0),
    Case(name="example-mjcf-fourbar", scenario="mjcf-fourbar",
         title="A user's MJCF four-bar (reduced model MuJoCo-derived), PID K_p·t of Incerti 2012",
         modes=["open", "pid"], backend="both", video=True, video_mode="pid", video_t_end=2.0),
]

DESIGN = "designer figure (mjbench analyze at the set-point speed); no paper value"


def _analysis(ctx):
    hit = ctx.extra.get("analysis")
    if hit is None:

        hit = ctx.extra["analysis"] = A.analyze(ctx.scn)
    return hit


def rows(ctx) -> list:
    """Designer rows of the case's mechanism and drive (see the module doc)."""
    res = _analysis(ctx)
    out = []
    if not res.get("applicable"):
        return out

    def row(name, unit, val, reason=DESIGN):
        out.append({"name": name, "unit": unit, "paper": None, "ours": {"analysis": val}, "reason": reason})

    for j, s in res["strokes_m"].items():
        row(f"stroke of {j}", "mm", 1000.0 * s)
    for j, arcs in res.get("stroke_arcs_deg", {}).items():
        if j in res["strokes_m"]:
            inc, dec = arcs["increasing"], arcs["decreasing"]
            row(f"time ratio of {j}: input arc of the decreasing / increasing stroke", "1", dec / inc,
                f"{dec:.1f}° / {inc:.1f}° of input angle; {DESIGN}")
    for j, sw in res.get("swings_deg", {}).items():
        if sw > 60.0:  # the large output swings only (every oscillating joint is in analysis.json)
            row(f"swing of joint {j}", "°", sw)
    for k, v in res["transmission_angles_deg"].items():
        row(f"transmission angle {k}: minimum", "°", v["min"],
            f"at q = {math.degrees(v['q_at_min']) % 360:.1f}°; guideline ≥ 40°; {DESIGN}")
    for sp in res["speeds"]:
        w = sp["input_speed_rad_s"]
        t = sp["input_torque_Nm"]
        row(f"input torque at {w:.4g} rad/s: peak", "N·m", max(abs(t["min"]), abs(t["max"])))
        row(f"input torque at {w:.4g} rad/s: RMS", "N·m", t["rms"])
        row(f"energy per input turn at {w:.4g} rad/s", "J", sp["energy_per_rev_J"],
            f"mean input torque × 2π: work of the loads and friction per cycle; {DESIGN}")
        if "motor_line_torque_Nm" in sp:
            row(f"motor torque at {w:.4g} rad/s: peak (motor line at v_max: {sp['motor_line_torque_Nm']:.3g} N·m)",
                "N·m", sp["motor_torque_Nm"]["max"],
                "above the motor line: the drive cannot hold this speed through the peak; the speed dips "
                "and the inertia (flywheel J_b, if any) carries it" if sp["torque_margin"] < 0 else DESIGN)
    for mode, m in ctx.metrics.items():
        c = m.get("multibody_vs_reduced")
        if c:
            note = m.get("reduced_model", "")
            row(f"multibody vs reduced crank speed, max |Δ|/peak ({mode})", "1", c["max_rel_diff"],
                note if note.startswith("MuJoCo-derived")
                else "reduced model from our own kinematics: an independent check of the MuJoCo run")
    if ctx.scn.mechanism.type == "mjcf":
        out += _mjcf_vs_closed_form(ctx)
    return out


def _mjcf_vs_closed_form(ctx) -> list:
    """The MuJoCo-derived J, J', E_p' of the user's MJCF four-bar against FourBar.reduced (the
    file holds the Incerti 2012 geometry of incerti2012.toml)."""

    mech = ctx.machines[ctx.case.modes[-1]].mechanism
    ref = S.make_mechanism(S.load("incerti2012"))
    q = np.linspace(0.0, 2 * np.pi, 1441)
    a, b = ref.reduced(q), mech.reduced(q)
    out = []
    for i, nm in enumerate(("J", "J'", "E_p'")):
        err = float(np.max(np.abs(a[i] - b[i])) / np.max(np.abs(a[i])))
        out.append({"name": f"MuJoCo-derived {nm}(q) vs the Incerti 2012 closed form, max |Δ|/max", "unit": "1",
                    "paper": None, "ours": {"analysis": err},
                    "reason": "accuracy of the MJCF route (1024-node table; J' spectral) on a known geometry"})
    return out


def figures(ctx) -> list:
    """The run's time series (``timeseries.png``) and the ``mjbench analyze`` figures."""

    figs = default_figures(ctx)
    res = _analysis(ctx)
    if res.get("applicable"):
        figs += A.figures(res, ctx.out)
    return figs
