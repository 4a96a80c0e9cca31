"""A cam from its requirement (``[mechanism] type = "cam"`` of a requirements file; docs/design.md §3c).

What the cam must do — the follower's lift, the rise, dwell and return angles with a motion law,
the largest pressure angle allowed, the follower's mass and load, the speed (``[duty]``) — and what
the design returns:

1. **the base circle**: the smallest R_b (to 0.1 mm, rounded up) whose cam meets the pressure-angle
   limit, is not undercut (roller) or is convex (flat face) and, if asked, keeps its surface's
   radius of curvature above ``min_radius_of_curvature`` — by bisection on R_b (the pressure angle
   falls and the curvature radii grow with R_b: the feasible set is R_b ≥ R*), every candidate
   checked by :func:`mjbench.mechanisms.cam_profile.checks` over 7200 cam angles; an oscillating
   roller follower's pivot is put where the arm is square to the cam radius at zero lift
   (a = √(ℓ² + R_p²) on the +x axis: the smallest pressure angle at the start of the rise);
2. **the spring**: the rate k and preload F0 of least peak spring force k·lift + F0 that hold the
   follower on the cam up to ``jump_margin`` × the speed (the jump condition M·y''·W² + c·y'·W +
   k·y + F0 + F_L ≥ 0 at every cam angle, W = margin·ω — a linear programme in (k, F0), solved by
   scipy's HiGHS), with the preload at most ``spring_precompression_max`` × lift of pre-compression
   (F0 ≤ k·y₀,max: a real spring);
3. **the drive**: the cam as the machine's mechanism through the constant-speed design of
   docs/design.md §3 (catalogue motor, gearbox, flywheel, the speed PID, the multibody verification);
   the multibody run must also keep the follower on the cam (``follower_separation_fraction`` = 0 on
   its last cycle) and the predicted jump speed be at least margin × speed.

:func:`synthesize` gives the pipeline a :class:`CamSynthesis` (the linkage syntheses' interface:
kind, targets, achieved, constraints, info) and the cam's ``[mechanism]`` table.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Literal

import numpy as np
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from .. import units as U
from ..errors import GeometryError, ParameterError
from ..fields import OptQ, Q, Strict
from ..mechanisms import from_dict
from ..mechanisms.cam_profile import CamProgram, Follower, FollowerLoad, checks, jump_speed
from .synthesis.common import Synthesis, constraint

#: the base radius is rounded up to this [m] (what a drawing states) and searched to a tenth of it
BASE_STEP = 1e-4


class CamReq(Strict):
    """``[mechanism] type = "cam"`` of a requirements file: the cam's task and its follower."""

    #: the cam's process load is its follower load: no ``[[loads]]``
    load_points: ClassVar = None
    loads_refused: ClassVar[str] = "a cam's process load is its follower_load ([mechanism] follower_load)"

    type: Literal["cam"] = "cam"
    follower: Literal["translating", "oscillating"] = "translating"
    contact: Literal["roller", "flat"] = "roller"
    lift: float | str = Field(description="the follower's lift: a length (translating) or an angle (oscillating)")
    rise_angle: Q("angle", gt=0.0) = Field(description="cam angle of the rise")
    top_dwell: Q("angle", ge=0.0) = Field(0.0, description="cam angle of the dwell at full lift")
    return_angle: Q("angle", gt=0.0) = Field(description="cam angle of the return")
    bottom_dwell: Q("angle", ge=0.0) = Field(0.0, description="cam angle of the dwell at the base (the rest of the turn)")
    law: Literal["345", "cycloidal", "pseudopoly", "bezier"] = Field("cycloidal", description="motion law of rise and return")
    gammas: list[float] | None = Field(None, description="pseudopoly exponents")
    m: int | None = Field(None, ge=0, description="bezier continuity order")
    p: int | None = Field(None, ge=0, description="bezier interior ordinates")
    interior_over_Phi: list[float] | None = Field(None, description="bezier interior ordinates / lift")
    max_pressure_angle: Q("angle", gt=0.0, lt=0.5 * math.pi) = Field(description="largest pressure angle allowed")
    min_radius_of_curvature: OptQ("length", gt=0.0) = Field(
        None, description="smallest radius of curvature of the cam surface (contact stress; default: no undercut only)")
    roller_radius: OptQ("length", gt=0.0) = Field(None, description="roller radius (roller followers)")
    offset: Q("length", plausible=False) = Field(0.0, description="translating: the follower line's offset")
    arm: OptQ("length", gt=0.0) = Field(None, description="oscillating roller: pivot to roller centre")
    follower_mass: OptQ("mass", gt=0.0) = Field(None, description="translating: the follower's moving mass")
    follower_inertia: OptQ("inertia", gt=0.0) = Field(None, description="oscillating: the follower about its pivot")
    follower_load: float | str = Field(0.0, description="constant load opposing the lift (N; oscillating N·m)")
    follower_damping: float | str = Field(0.0, description="viscous damping of the follower")
    cam_inertia: Q("inertia", gt=0.0) = Field(description="the cam with its shaft")
    jump_margin: float = Field(1.3, ge=1.0, le=5.0, description="the spring holds the follower up to this × the speed")
    spring_precompression_max: float = Field(4.0, gt=0.0, description="largest pre-compression y₀ = F0/k, × lift")

    @model_validator(mode="after")
    def _values(self):
        kinds = {"translating": ("length", "force", "lin_damping"), "oscillating": ("angle", "torque", "rot_damping")}
        lk, fk, ck = kinds[self.follower]
        for key, kind in (("lift", lk), ("follower_load", fk), ("follower_damping", ck)):
            try:
                x = U.to_si(getattr(self, key), kind)
            except U.UnitError as e:
                raise PydanticCustomError("mjbench_value", "{k}: {e} (a {f} follower)",
                                          {"k": key, "e": str(e), "f": self.follower}) from None
            if not math.isfinite(x) or (key == "lift" and not x > 0) or (key == "follower_damping" and x < 0):
                raise PydanticCustomError("mjbench_value", "{k} = {v!r}: out of range", {"k": key, "v": getattr(self, key)})
            object.__setattr__(self, key, x)
        total = self.rise_angle + self.top_dwell + self.return_angle + self.bottom_dwell
        if abs(total - 2 * math.pi) > 1e-9:
            raise PydanticCustomError("mjbench_value", "rise_angle + top_dwell + return_angle + bottom_dwell = {t:.6g}°, "
                                      "not 360°", {"t": math.degrees(total)})
        if self.contact == "roller" and self.roller_radius is None:
            raise PydanticCustomError("mjbench_value", "roller_radius: required for a roller follower")
        if self.follower == "translating" and self.follower_mass is None:
            raise PydanticCustomError("mjbench_value", "follower_mass: required for a translating follower")
        if self.follower == "oscillating":
            if self.contact == "flat":
                raise PydanticCustomError("mjbench_value", "follower: the design places an oscillating follower's pivot "
                                          "for a roller; give an oscillating flat-faced cam as a scenario "
                                          "([mechanism] type = \"cam\") instead")
            if self.follower_inertia is None or self.arm is None:
                raise PydanticCustomError("mjbench_value", "an oscillating follower needs arm and follower_inertia")
        return self

    def segments(self) -> list:
        law = {"law": self.law}
        for k in ("gammas", "m", "p", "interior_over_Phi"):
            if getattr(self, k) is not None:
                law[k] = getattr(self, k)
        segs = [dict(kind="rise", angle=self.rise_angle, **law)]
        if self.top_dwell > 0:
            segs.append(dict(kind="dwell", angle=self.top_dwell))
        segs.append(dict(kind="return", angle=self.return_angle, **law))
        if self.bottom_dwell > 0:
            segs.append(dict(kind="dwell", angle=self.bottom_dwell))
        return segs

    @property
    def mass(self) -> float:
        return float(self.follower_mass if self.follower == "translating" else self.follower_inertia)

    def synthesize(self, req) -> tuple:
        """(CamSynthesis, ``[mechanism]`` table, geometry): :func:`synthesize`."""
        return synthesize(req)

    def requirement_rows(self, req, syn, an, syn_json, ach, row) -> list:
        """The cam's pressure angle, curvature, spring and jump speed: :func:`requirement_rows`."""
        return requirement_rows(req, an, ach, row)


@dataclass
class CamSynthesis(Synthesis):
    """The designed cam (the linkage syntheses' interface, :class:`~.synthesis.common.Synthesis`)."""

    def check(self, table) -> dict:
        """The designed cam re-checked as the mechanism mjbench builds from its table (profile checks,
        jump speed): what the pipeline's solver check is for a linkage."""
        mech = from_dict(table)
        return {"max_pressure_angle_deg": mech.check["max_pressure_angle_deg"],
                "min_convex_radius_of_curvature_m": mech.check["min_convex_radius_of_curvature_m"],
                "jump_speed_rad_s": mech.jump["speed_rad_s"]}


def follower_for(m: CamReq, Rb: float) -> Follower:
    """The follower's geometry at base radius R_b (an oscillating roller's pivot by the design rule)."""
    if m.follower == "translating":
        return Follower("translating", m.contact, Rb, m.roller_radius or 0.0, (0.0, 1.0), m.offset)
    Rp = Rb + m.roller_radius
    a = math.sqrt(m.arm ** 2 + Rp ** 2)
    return Follower("oscillating", "roller", Rb, m.roller_radius, A=(a, 0.0), arm=m.arm, sense=1)


def _feasible(m: CamReq, prog, Rb: float):
    """(ok, checks or the reason) of the cam with base radius R_b."""
    try:
        fol = follower_for(m, Rb)
        ck = checks(fol, prog, n=7200, max_pressure_angle=m.max_pressure_angle)
    except (GeometryError, ParameterError) as e:
        return False, str(e)
    if m.min_radius_of_curvature is not None:
        rc = ck["min_convex_radius_of_curvature_m"]
        if rc is not None and rc < m.min_radius_of_curvature:
            return False, f"radius of curvature {1000 * rc:.3g} mm < {1000 * m.min_radius_of_curvature:.3g} mm"
    return True, ck


def base_radius(m: CamReq, prog) -> tuple:
    """The smallest feasible base radius, rounded up to BASE_STEP → (R_b, checks, search log)."""
    lift_len = m.lift if m.follower == "translating" else m.arm * m.lift
    lo = max(BASE_STEP, 0.05 * lift_len)
    log = []
    ok, ck = _feasible(m, prog, lo)
    log.append((lo, ok))
    if ok:
        return lo, ck, log
    hi = 2.0 * lo
    while True:
        ok, ck = _feasible(m, prog, hi)
        log.append((hi, ok))
        if ok:
            break
        lo, hi = hi, 2.0 * hi
        if hi > 200.0 * lift_len + 1.0:
            raise ParameterError(f"mechanism: no base circle up to {hi:.3g} m meets max_pressure_angle = "
                                 f"{math.degrees(m.max_pressure_angle):.4g}° for this lift, angle and law")
    while hi - lo > 0.1 * BASE_STEP:
        mid = 0.5 * (lo + hi)
        ok, _ = _feasible(m, prog, mid)
        log.append((mid, ok))
        lo, hi = (lo, mid) if ok else (mid, hi)
    Rb = math.ceil(hi / BASE_STEP - 1e-9) * BASE_STEP
    ok, ck = _feasible(m, prog, Rb)
    if not ok:  # pragma: no cover - the rounded-up radius is larger than a feasible one
        raise ParameterError(f"mechanism: base radius {Rb} m unexpectedly infeasible: {ck}")
    return Rb, ck, log


def spring(m: CamReq, prog, omega: float, n: int = 4000) -> tuple:
    """(k, F0): the least peak spring force k·lift + F0 holding the follower up to margin × ω
    (module docstring), by scipy's linprog (HiGHS) over n cam angles."""
    from scipy.optimize import linprog

    th = 2.0 * math.pi * np.arange(n) / n
    y, y1, y2, _ = prog(th)
    W = m.jump_margin * float(omega)
    need = -(m.mass * y2 * W * W + m.follower_damping * y1 * W + m.follower_load)  # k·y + F0 ≥ need
    h = float(m.lift)
    A = np.vstack([np.column_stack([-y, -np.ones_like(y)]), [[-m.spring_precompression_max * h, 1.0]]])
    b = np.concatenate([-need, [0.0]])
    r = linprog([h, 1.0], A_ub=A, b_ub=b, bounds=[(0.0, None), (0.0, None)], method="highs")
    if not r.success:  # pragma: no cover - the programme is always feasible (k large enough)
        raise ParameterError(f"mechanism: no spring holds the follower up to {W:.4g} rad/s: {r.message}")
    k, F0 = (max(float(v), 0.0) + 0.0 for v in r.x)
    # a hair above the optimum (the LP's constraint is active at the binding angles): both by 1e-6
    return k * (1.0 + 1e-6), F0 * (1.0 + 1e-6)


def synthesize(req) -> tuple:
    """(CamSynthesis, the cam's [mechanism] table, None)."""
    m = req.mechanism
    omega = req.duty.omega
    prog = CamProgram(m.segments(), m.lift)
    Rb, ck, search = base_radius(m, prog)
    k, F0 = spring(m, prog, omega)
    fol = follower_for(m, Rb)
    load = FollowerLoad(m.mass, k, F0, m.follower_load, m.follower_damping)
    js = jump_speed(load, prog)
    deg = 180.0 / math.pi
    table = {"type": "cam", "name": req.name, "follower": m.follower, "contact": m.contact,
             "base_radius": Rb, "roller_radius": float(m.roller_radius or 0.0), "lift": float(m.lift),
             "program": [{kk: v for kk, v in s.items()} for s in m.segments()],
             "cam_inertia": float(m.cam_inertia), "spring_rate": k, "spring_preload": F0,
             "follower_load": float(m.follower_load), "follower_damping": float(m.follower_damping),
             "max_pressure_angle": float(m.max_pressure_angle)}
    if m.follower == "translating":
        table.update(offset=float(m.offset), follower_mass=float(m.follower_mass))
    else:
        table.update(pivot=[float(fol.A[0]), float(fol.A[1])], arm=float(m.arm), lift_sense="ccw",
                     follower_inertia=float(m.follower_inertia))
    wj = js["speed_rad_s"]
    cons = [constraint("pressure angle ≤ max_pressure_angle", ck["max_pressure_angle_deg"],
                       math.degrees(m.max_pressure_angle), "max", "°"),
            constraint("no undercut (roller) / convex cam (flat face)", True, compare="true"),
            constraint("jump speed ≥ jump_margin × speed", wj, m.jump_margin * omega, "min", "rad/s")]
    if m.min_radius_of_curvature is not None:
        cons.append(constraint("radius of curvature of the cam surface", ck["min_convex_radius_of_curvature_m"],
                               m.min_radius_of_curvature, "min", "m"))
    syn = CamSynthesis(
        kind="cam", geometry=None,
        targets={"lift": m.lift, "max_pressure_angle_deg": math.degrees(m.max_pressure_angle),
                 "speed_rad_s": omega, "jump_margin": m.jump_margin},
        achieved={"base_radius_m": Rb, "prime_radius_m": fol.Rp, "max_pressure_angle_deg": ck["max_pressure_angle_deg"],
                  "theta_at_max_pressure_angle_deg": ck["theta_at_max_pressure_angle_deg"],
                  "min_convex_radius_of_curvature_m": ck["min_convex_radius_of_curvature_m"],
                  "spring_rate": k, "spring_preload": F0, "spring_force_max": k * m.lift + F0,
                  "jump_speed_rad_s": wj, "jump_speed_over_speed": wj / omega if wj else None,
                  "jump_cam_angle_deg": js["theta_deg"]},
        constraints=cons,
        info={"method": "base radius: bisection on R_b (pressure angle, undercut, curvature over 7200 cam angles), "
                        "rounded up to 0.1 mm; spring: least k·lift + F0 holding the follower to jump_margin × speed "
                        "(linear programme, HiGHS)", "search": [[float(r), bool(o)] for r, o in search],
              "units": "lift and spring in the follower's units: m, N/m, N (translating); rad, N·m/rad, N·m "
                       "(oscillating)", "deg_per_rad": deg})
    return syn, table, None


def requirement_rows(req, an, ach, row) -> list:
    """The cam's rows of the requirements table: pressure angle and curvature (mjbench analyze of the
    machine), the predicted jump speed against margin × speed, the follower on the cam in the multibody
    run's last cycle.  ``row``: the pipeline's row builder."""
    m = req.mechanism
    cam = an.get("cam", {})
    ck = cam.get("checks", {})
    src = "mjbench analyze (the cam's program and profile)"
    rows = [row("pressure angle", math.degrees(m.max_pressure_angle), ck.get("max_pressure_angle_deg"), "max", "°", src)]
    if m.min_radius_of_curvature is not None:
        rows.append(row("radius of curvature of the cam surface", 1e3 * m.min_radius_of_curvature,
                        1e3 * ck["min_convex_radius_of_curvature_m"], "min", "mm", src))
    wj = an.get("jump_speed_rad_s")
    rows.append(row("jump speed (predicted)", m.jump_margin * req.duty.omega, wj, "min", "rad/s", src))
    if ach is not None and "follower_separation_fraction" in ach:
        rows.append(row("follower on the cam (separated fraction of the last cycle)", 0.0,
                        ach["follower_separation_fraction"], "max", "1", "multibody run, last cycle"))
    return rows
