"""Slider-crank with offset from its stroke S and time ratio Q (the offset maximising the minimum
transmission angle unless given)."""
from __future__ import annotations

import math

import numpy as np

from ...errors import ParameterError
from .common import TWO_PI, Synthesis, _envelope_of, _golden, constraint, imbalance_angle
from .geometry import SliderCrank


def slider_crank_from(S, alpha, e):
    """(r, l) of the offset slider-crank with stroke S, imbalance angle α and offset e (closed
    form above); None if e is outside (0, S/(2 tan(α/2)))."""
    if alpha <= 0:
        return None
    P = S * e / math.sin(alpha)
    plus = S * S + 2 * P * (1 + math.cos(alpha))
    minus = S * S - 2 * P * (1 - math.cos(alpha))
    if e <= 0 or minus <= 0:
        return None
    s1, s2 = math.sqrt(plus), math.sqrt(minus)
    return 0.5 * s2, 0.5 * s1  # r = (A₁ − A₂)/2, l = (A₁ + A₂)/2


def slider_crank(stroke, time_ratio_Q, *, offset=None, min_transmission=None, max_link_ratio=None,
                 working_direction=(0.0, -1.0), envelope=None, rod_ratio=None, origin=(0.0, 0.0)) -> Synthesis:
    """Offset slider-crank from the stroke and the time ratio (slow stroke along
    ``working_direction`` with the crank turning counter-clockwise).  Free parameter: the offset
    (given, or the one that maximises the minimum transmission angle).  Q = 1: in-line, the rod
    is ``rod_ratio``·r (default: the shortest rod meeting ``min_transmission``, else 4r)."""
    S, Q = float(stroke), float(time_ratio_Q)
    if not (S > 0 and Q >= 1):
        raise ParameterError(f"slider-crank: need stroke > 0 and time ratio >= 1, got {S!r}, {Q!r}")
    alpha = imbalance_angle(Q)
    info = {"alpha_deg": math.degrees(alpha)}
    if alpha < 1e-12:
        r = 0.5 * S
        if rod_ratio is not None:
            l = rod_ratio * r
        elif min_transmission is not None:
            l = r / math.cos(min_transmission) * (1 + 1e-9)
        else:
            l = 4.0 * r
        e = 0.0
        info["offset_choice"] = "in-line (time ratio 1)"
    else:
        e_max = S / (2 * math.tan(0.5 * alpha))
        info["offset_max_m"] = e_max

        def mu_of(ev):
            rl = slider_crank_from(S, alpha, ev)
            if rl is None:
                return -1.0
            r_, l_ = rl
            return 0.5 * math.pi - math.asin(min(1.0, (r_ + ev) / l_))

        if offset is not None:
            e = float(offset)
            info["offset_choice"] = "given"
            if mu_of(e) < 0:
                raise ParameterError(f"slider-crank: offset = {e:g} m is outside (0, {e_max:.6g}) m for stroke "
                                     f"{S:g} m and time ratio {Q:g}")
        else:
            grid = np.linspace(0.0, e_max, 2001)[1:-1]
            vals = np.array([mu_of(x) for x in grid])
            k = int(np.argmax(vals))
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
            e = _golden(lambda x: -mu_of(x), lo, hi)
            info["offset_choice"] = "maximum of the minimum transmission angle"
        r, l = slider_crank_from(S, alpha, e)
    sc = SliderCrank(np.asarray(origin, float), r, l, e, np.asarray(working_direction, float))
    dc = sc.dead_centres()
    ach = {"stroke_m": dc["stroke"], "time_ratio": dc["arc_along_w"] / dc["arc_against_w"],
           "min_transmission_deg": math.degrees(sc.mu_min()), "r_m": r, "l_m": l, "offset_m": e,
           "q_extended_rad": dc["extended"]["q"], "q_folded_rad": dc["folded"]["q"],
           "u_extended_m": dc["extended"]["u"], "u_folded_m": dc["folded"]["u"]}
    cons = [constraint("stroke", dc["stroke"], S, "min", "m", ok=abs(dc["stroke"] - S) <= 1e-9 * S),
            constraint("time ratio (slow stroke along the working direction)", ach["time_ratio"], Q, "min", "1",
                       ok=abs(ach["time_ratio"] - Q) <= 1e-9 * Q),
            constraint("minimum transmission angle", ach["min_transmission_deg"],
                       None if min_transmission is None else math.degrees(min_transmission), "min", "°"),
            constraint("link-length ratio (rod / crank)", l / r, max_link_ratio, "max", "1")]
    if envelope is not None:
        q = np.linspace(0, TWO_PI, 721)
        s = sc.solve(q)
        w, h = _envelope_of([sc.O, s["B"], s["C"]])
        cons += [constraint("envelope width", w, envelope[0], "max", "m"),
                 constraint("envelope height", h, envelope[1], "max", "m")]
    return Synthesis("slider-crank", sc, {"stroke_m": S, "time_ratio": Q}, ach, cons, info)
