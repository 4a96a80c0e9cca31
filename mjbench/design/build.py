"""From a synthesised geometry to a ``[mechanism] type = "linkage"`` table, and the machine
scenario (``machine.toml``) that run / analyze / tune / render accept unchanged.

Link frames: every link's origin is its first joint point and its x-axis points to its second
(crank A→B, coupler B→C, rocker D→C; slider-crank crank O→B, rod B→C, ram at C), so the input
angle q is the crank's angle.  Mass model (requirements ``[mechanism.mass]``): uniform bars of
ρ = ``bar_mass_per_length`` (m = ρL, mass centre mid-length, I = mL²/12); a balanced crank is a
bar of length 2r centred on its axis; the ram, the tool (a point mass at the output point) and the
extra inertias as given.  The stated pose (input angle 0) carries every link's angle from the
closed-form analysis, which picks the synthesised assembly branch.
"""
from __future__ import annotations

import json
import math
import re

import numpy as np

from .synthesis import FourBar, SliderCrank

TWO_PI = 2.0 * math.pi


def _pt(v):
    return [float(v[0]), float(v[1])]


def _bar(rho, L):
    m = rho * L
    return {"mass": m, "com": [0.5 * L, 0.0], "inertia": m * L * L / 12.0}


def _crank(rho, L, balanced, extra):
    if balanced:
        m = rho * 2.0 * L
        d = {"mass": m, "com": [0.0, 0.0], "inertia": m * (2.0 * L) ** 2 / 12.0 + extra}
    else:
        d = _bar(rho, L)
        d["inertia"] += extra
    return d


def fourbar_table(fb: FourBar, mass, name="fourbar", gravity=(0.0, -9.81), q_stated=0.0, tool_at="rocker.C",
                  loads=()) -> dict:
    """``[mechanism]`` table of a synthesised four-bar (see the module doc)."""
    s = fb.solve(np.array([q_stated]))
    th3, th4 = float(s["theta3"][0]), float(s["theta4"][0])
    rho = mass.bar_mass_per_length
    crank = _crank(rho, fb.a, mass.crank_balanced, mass.crank_inertia)
    crank["points"] = {"A": [0.0, 0.0], "B": [fb.a, 0.0]}
    coupler = _bar(rho, fb.b)
    coupler["points"] = {"B": [0.0, 0.0], "C": [fb.b, 0.0]}
    if fb.P is not None:
        coupler["points"]["P"] = [float(fb.P[0]), float(fb.P[1])]
    coupler["angle"] = th3
    rocker = _bar(rho, fb.c)
    rocker["inertia"] += mass.output_inertia
    rocker["points"] = {"D": [0.0, 0.0], "C": [fb.c, 0.0]}
    rocker["angle"] = th4
    links = {"crank": crank, "coupler": coupler, "rocker": rocker}
    if mass.tool_mass > 0:
        ln, pt = tool_at.split(".")
        links[ln]["point_masses"] = {pt: mass.tool_mass}
    jd = float(mass.joint_damping)
    joints = []
    for nm, a, b in (("A", "ground.A", "crank.A"), ("B", "crank.B", "coupler.B"), ("C", "coupler.C", "rocker.C"),
                     ("D", "ground.D", "rocker.D")):
        j = {"name": nm, "at": [a, b]}
        if jd > 0:
            j["damping"] = jd
        joints.append(j)
    t = {"type": "linkage", "name": name, "input": "A", "input_angle": float(q_stated),
         "gravity": [float(gravity[0]), float(gravity[1])],
         "trace": "coupler.P" if fb.P is not None else "rocker.C",
         "ground": {"A": _pt(fb.A), "D": _pt(fb.D)}, "links": links, "joints": joints}
    if loads:
        t["loads"] = list(loads)
    return t


def slidercrank_table(sc: SliderCrank, mass, name="slidercrank", gravity=(0.0, -9.81), q_stated=0.0,
                      loads=()) -> dict:
    """``[mechanism]`` table of a synthesised offset slider-crank."""
    s = sc.solve(np.array([q_stated]))
    B, C = s["B"][0], s["C"][0]
    rod_angle = float(math.atan2(*(C - B)[::-1]))
    rho = mass.bar_mass_per_length
    crank = _crank(rho, sc.r, mass.crank_balanced, mass.crank_inertia)
    crank["points"] = {"O": [0.0, 0.0], "B": [sc.r, 0.0]}
    rod = _bar(rho, sc.l)
    rod["points"] = {"B": [0.0, 0.0], "C": [sc.l, 0.0]}
    rod["angle"] = rod_angle
    ram = {"mass": float(mass.slider_mass + mass.tool_mass), "inertia": 0.0, "points": {"C": [0.0, 0.0]}}
    G = sc.O - sc.e * sc.n
    jd = float(mass.joint_damping)
    joints = []
    for nm, a, b in (("O", "ground.O", "crank.O"), ("B", "crank.B", "rod.B"), ("C", "rod.C", "ram.C")):
        j = {"name": nm, "at": [a, b]}
        if jd > 0:
            j["damping"] = jd
        joints.append(j)
    guide = {"name": "guide", "type": "prismatic", "at": ["ground.G", "ram.C"], "axis": _pt(sc.w)}
    if mass.guide_damping > 0:
        guide["damping"] = float(mass.guide_damping)
    joints.append(guide)
    t = {"type": "linkage", "name": name, "input": "O", "input_angle": float(q_stated),
         "gravity": [float(gravity[0]), float(gravity[1])], "trace": "ram.C",
         "ground": {"O": _pt(sc.O), "G": _pt(G)}, "links": {"crank": crank, "rod": rod, "ram": ram},
         "joints": joints}
    if loads:
        t["loads"] = list(loads)
    return t


def point_path(geom, ref: str, n: int = 4096):
    """World positions (n, 2) of a named point of a synthesised linkage over one crank turn."""
    q = np.linspace(0.0, TWO_PI, n, endpoint=False)
    s = geom.solve(q)
    link, pt = ref.split(".")
    if isinstance(geom, SliderCrank):
        return {"crank.O": np.broadcast_to(geom.O, (n, 2)), "crank.B": s["B"], "rod.B": s["B"], "rod.C": s["C"],
                "ram.C": s["C"]}[ref]
    table = {"crank.A": np.broadcast_to(geom.A, (n, 2)), "crank.B": s["B"], "coupler.B": s["B"], "coupler.C": s["C"],
             "rocker.C": s["C"], "rocker.D": np.broadcast_to(geom.D, (n, 2))}
    if "P" in s:
        table["coupler.P"] = s["P"]
    return table[ref]


def load_table(ld, geom) -> dict:
    """A requirements ``[[loads]]`` entry → the linkage's LoadSpec table (a profile measured from
    the end of the active stroke becomes the table s/F of the point's coordinate along the
    direction: stroke_against ends at the smallest s, stroke_along at the largest)."""
    d = np.asarray(ld.direction, float)
    d = d / np.hypot(*d)
    out = {"name": ld.name or f"load on {ld.point}", "point": ld.point, "direction": _pt(d), "active": ld.active}
    if ld.force is not None:
        out["force"] = float(ld.force)
        return out
    s = point_path(geom, ld.point) @ d
    if ld.active == "stroke_against":
        pts = sorted((float(s.min()) + h, F) for h, F in ld.profile)
    else:
        pts = sorted((float(s.max()) - h, F) for h, F in ld.profile)
    out["s"] = [p[0] for p in pts]
    out["F"] = [float(p[1]) for p in pts]
    return out


# ============================================================================ TOML
_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k):
    return k if _BARE.match(str(k)) else json.dumps(str(k), ensure_ascii=False)


def _val(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        if math.isnan(x):
            return "nan"
        return repr(x)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_val(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_val(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} {v!r} to TOML")


def _is_table_list(v):
    return isinstance(v, list) and v and all(isinstance(x, dict) for x in v)


def toml_dumps(doc: dict, header: str = "", comments: dict | None = None) -> str:
    """A TOML document of nested dicts (tables; dicts nested 4 deep or more are inline tables),
    lists of dicts (arrays of tables) and scalars/arrays.  ``comments``: {table path: line}."""
    comments = comments or {}
    lines = [f"# {x}" if x else "#" for x in header.splitlines()] if header else []

    def emit(path, d, depth):
        scal = [(k, v) for k, v in d.items() if not (isinstance(v, dict) and depth < 3) and not _is_table_list(v)]
        subs = [(k, v) for k, v in d.items() if isinstance(v, dict) and depth < 3]
        arrs = [(k, v) for k, v in d.items() if _is_table_list(v)]
        if path and (scal or not subs):
            if lines:
                lines.append("")
            if ".".join(path) in comments:
                lines.append(f"# {comments['.'.join(path)]}")
            lines.append(f"[{'.'.join(_key(p) for p in path)}]")
        for k, v in scal:
            lines.append(f"{_key(k)} = {_val(v)}")
        for k, v in subs:
            emit(path + [k], v, depth + 1)
        for k, v in arrs:
            for item in v:
                lines.append("")
                lines.append(f"[[{'.'.join(_key(p) for p in path + [k])}]]")
                for kk, vv in item.items():
                    lines.append(f"{_key(kk)} = {_val(vv)}")

    emit([], doc, 0)
    return "\n".join(lines) + "\n"
