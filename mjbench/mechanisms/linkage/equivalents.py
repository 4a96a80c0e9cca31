"""The hand-coded mechanisms written as generic linkages (their ``linkage_view()``).

The four-bar (:class:`~mjbench.mechanisms.fourbar.FourBar`) and the quick-return
(:class:`~mjbench.mechanisms.quickreturn.QuickReturn`) give ``mjbench analyze`` their kinematics
(velocity ratios, transmission angles, toggles) through the equivalent :class:`~.mechanism.Linkage`
of these ``[mechanism]`` tables (the same notation as tests/data/linkages/*.toml).
"""
from __future__ import annotations

import math


def table_from_fourbar(fb) -> dict:
    """The ``[mechanism]`` table of a :class:`~mjbench.mechanisms.fourbar.FourBar` written as a
    generic linkage (same notation as tests/data/linkages/incerti2012.toml): link frames at the
    proximal joints along the link lines, joint point masses as point masses, hinge damping."""
    beta, gamma = (float(v) for v in fb.angles(0.0))
    pol = (lambda r, t: [r * math.cos(t), r * math.sin(t)])
    jm = fb.joint_masses
    pt = fb.coupler_point
    return {
        "type": "linkage", "name": f"{fb.name}-linkage", "input": "A", "input_angle": 0.0,
        "gravity": [0.0, -float(fb.g)], "trace": "coupler.P",
        "ground": {"A": [0.0, 0.0], "D": [float(fb.h_x), float(fb.h_y)]},
        "links": {
            "crank": {"mass": fb.m[0], "com": pol(fb.f[0], fb.theta[0]), "inertia": fb.J_G[0],
                      "points": {"A": [0.0, 0.0], "B": [fb.a, 0.0]},
                      "point_masses": {k: v for k, v in (("A", jm.get("A", 0.0)), ("B", jm.get("B", 0.0))) if v}},
            "coupler": {"mass": fb.m[1], "com": pol(fb.f[1], fb.theta[1]), "inertia": fb.J_G[1],
                        "points": {"B": [0.0, 0.0], "C": [fb.b, 0.0], "P": pol(pt.f, pt.theta)}, "angle": beta},
            "rocker": {"mass": fb.m[2], "com": pol(fb.f[2], fb.theta[2]), "inertia": fb.J_G[2],
                       "points": {"D": [0.0, 0.0], "C": [fb.c, 0.0]}, "angle": gamma,
                       "point_masses": {k: v for k, v in (("C", jm.get("C", 0.0)), ("D", jm.get("D", 0.0))) if v}},
        },
        "joints": [{"name": "A", "at": ["ground.A", "crank.A"], "damping": fb.damping_A},
                   {"name": "B", "at": ["crank.B", "coupler.B"], "damping": fb.joint_damping},
                   {"name": "C", "at": ["coupler.C", "rocker.C"], "damping": fb.damping_C},
                   {"name": "D", "at": ["ground.D", "rocker.D"], "damping": fb.joint_damping}],
    }


def table_from_quickreturn(qr) -> dict:
    """The seed-004 quick-return (:class:`~mjbench.mechanisms.quickreturn.QuickReturn`) as a
    generic linkage (tests/data/linkages/yigit2023.toml); the cutting force on the "stroke"
    profile becomes a load against the slider on its working stroke (other profiles: no load)."""
    k = qr.kin(0.0)
    H = qr.a + qr.b
    loads = []
    if qr.cut_profile == "stroke" and qr.cut_force > 0:
        loads = [{"name": "cut", "point": "slider.C", "direction": [-qr.working_direction, 0.0],
                  "force": float(qr.cut_force), "active": "stroke_against"}]
    return {
        "type": "linkage", "name": f"{qr.name}-linkage", "input": "A0", "input_angle": 0.0,
        "gravity": [0.0, -float(qr.g)], "trace": "slider.C",
        "ground": {"A0": [0.0, qr.a], "B0": [0.0, 0.0], "S": [0.0, H]},
        "links": {
            "crank": {"mass": qr.m2, "com": [qr.c2, 0.0], "inertia": qr.I_G2,
                      "points": {"A0": [0.0, 0.0], "A": [qr.r2, 0.0]}},
            "block": {"mass": qr.m_block, "inertia": qr.I_block, "points": {"A": [0.0, 0.0]},
                      "angle": float(k["th3"])},
            "lever": {"mass": qr.m3, "com": [qr.c3, 0.0], "inertia": qr.I_G3,
                      "points": {"B0": [0.0, 0.0], "B": [qr.r3, 0.0]}, "angle": float(k["th3"])},
            "rod": {"mass": qr.m4, "com": [qr.c4, 0.0], "inertia": qr.I_G4,
                    "points": {"B": [0.0, 0.0], "C": [qr.r4, 0.0]}, "angle": float(k["th4"])},
            "slider": {"mass": qr.m5, "inertia": 0.0, "points": {"C": [0.0, 0.0]}},
        },
        "joints": [{"name": "A0", "at": ["ground.A0", "crank.A0"]},
                   {"name": "A", "at": ["crank.A", "block.A"]},
                   {"name": "slot", "type": "prismatic", "at": ["lever.B0", "block.A"], "axis": [1.0, 0.0]},
                   {"name": "B0", "at": ["ground.B0", "lever.B0"]},
                   {"name": "B", "at": ["lever.B", "rod.B"]},
                   {"name": "C", "at": ["rod.C", "slider.C"]},
                   {"name": "slide", "type": "prismatic", "at": ["ground.S", "slider.C"], "axis": [1.0, 0.0]}],
        "loads": loads,
    }


def equivalent(mech):
    """A :class:`Linkage` equivalent to a mechanism (kinematic analysis of the built-in four-bar
    and quick-return: velocity ratios, transmission angles, toggles), or None: the mechanism's own
    :meth:`~mjbench.mechanisms.base.Mechanism.linkage_view`."""
    return mech.linkage_view()
