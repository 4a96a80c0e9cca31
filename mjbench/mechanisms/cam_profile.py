"""Disc cams: the motion program, the follower's kinematic coefficients and the cam designer's checks.

A disc cam turns about its centre O (the plane's origin) by the input angle θ = q, counter-clockwise.
The follower's coordinate y is a translation s [m] (translating follower) or the arm's angle ψ [rad]
measured from its base position (oscillating follower); it is prescribed over one cam turn by a
**program** of segments — rise, dwell, return, dwell … — each a rest-to-rest law of
:mod:`mjbench.motionlaws` with the segment's cam angle β as its "time" and the segment's lift as
its amplitude: the 3-4-5 polynomial and the seed-001 pseudo-polynomial laws
(:class:`~mjbench.motionlaws.PseudoPolynomialLaw`), the seed-003 Bezier laws
(:class:`~mjbench.motionlaws.BezierLaw`) and the cycloidal law
(:class:`~mjbench.motionlaws.CycloidalLaw`).  The program's kinematic coefficients
y(θ), y' = dy/dθ, y'' and y''' are those laws' own values (:func:`cam_motion`, one compiled law);
the reduced model of the cam is exact in them (:mod:`mjbench.mechanisms.cam`).

The cam profile follows from the follower's geometry by kinematic inversion (the cam held, the
follower turned by −θ about O):

* **roller** follower: the roller centre C(y) traces the *pitch curve* P(θ) = R(−θ)·C(y(θ)) in the
  cam frame; the cam surface is the pitch curve offset inwards by the roller radius R_r along its
  normal.  Translating: C = e·n + (d₀ + s)·u (u the follower's direction, e its offset from O,
  d₀ = √(R_p² − e²), R_p = R_b + R_r the prime circle); oscillating: C = A + ℓ·(cos ψ, sin ψ) with
  ψ = ψ₀ + σ·Ψ (A the pivot, ℓ the arm, σ = ±1 the sense of the lift, ψ₀ on the prime circle);
* **flat-faced** follower: the face is a line with unit normal ν and support h (ν·x = h); the cam
  surface is the envelope of the face's lines in the cam frame, x = h·ν + (dh/dα)·Sν (α the angle
  of ν in the cam frame, S the rotation by 90°), its radius of curvature ρ = h + d²h/dα².
  Translating: ν = u, h = R_b + s (so ρ = R_b + s + s'', the classic condition); oscillating: ν at
  the arm's angle ψ, h = ν·A + f (f the face's offset from the pivot).

The checks (:func:`geometry`): the **pressure angle** φ between the contact normal and the
velocity of the follower's contact point, the **radius of curvature** of the pitch curve and of the
cam surface, **undercut** (a convex pitch curve tighter than the roller: the surface would cross
itself; a flat face on a cam that is not convex), the face width a flat face needs; the **contact
force** along the cycle at a constant cam speed ω (:func:`contact_force`): the generalised force
the follower needs, Q = M·(y''ω² + y'·θ̈) + c·y'ω + k·(y + y₀) + F_L (M its mass, or its inertia
about the pivot; k, y₀ the spring's rate and preload; F_L a constant load opposing the lift),
divided by the normal's share of the contact point's velocity, N = Q / (N̂·V_y); and the **jump
speed** (:func:`jump_speed`): the lowest constant cam speed at which Q reaches zero somewhere on
the cycle — above it the spring cannot hold the follower on the cam where the law decelerates it
(y'' < 0): M·y''·ω² + c·y'·ω + k·(y + y₀) + F_L < 0.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..compiled import law
from ..errors import GeometryError, ParameterError
from ..motionlaws import (BezierLaw, BezierP, CycloidalLaw, CycloidalP, PseudoPolynomialLaw, PseudoPolyP,
                          bezier_motion, cycloidal_motion, pseudopoly_motion)

TWO_PI = 2.0 * math.pi
LAW_KINDS = ("345", "cycloidal", "pseudopoly", "bezier")
SEGMENT_KINDS = ("rise", "dwell", "return")
#: the sum of the program's angles must equal one turn to this [rad]
TURN_TOL = 1e-9
#: a segment's law must start and end at rest: |y'|, |y''| at its ends ≤ this × their peaks
END_TOL = 1e-9


# ============================================================================ the program
class CamProgram:
    """A rise–dwell–return–dwell program over one cam turn.

    ``segments``: objects or dicts with ``kind`` (rise | dwell | return), ``angle`` β [rad], ``law``
    (345 | cycloidal | pseudopoly | bezier; not for a dwell), the law's parameters (``gammas``;
    ``m``, ``p``, ``interior_over_Phi``) and optionally ``lift`` (default: the program's ``lift``);
    ``lift``: the follower's travel [m or rad].  Raises ParameterError naming the segment."""

    def __init__(self, segments, lift: float, where: str = "mechanism.program"):
        lift = float(lift)
        if not (math.isfinite(lift) and lift > 0):
            raise ParameterError(f"{where.rsplit('.', 1)[0]}.lift = {lift!r}: the follower's lift must be > 0")
        self.lift = lift
        segs = [_as_dict(s) for s in segments]
        if not segs:
            raise ParameterError(f"{where}: no segment (a program is rise, dwell, return, dwell …)")
        self.th = [0.0]
        self.y0 = []
        self.laws = []  # (kind, law object or None)
        y = 0.0
        for k, s in enumerate(segs):
            w = f"{where}[{k}]"
            kind = s.get("kind")
            if kind not in SEGMENT_KINDS:
                raise ParameterError(f"{w}.kind = {kind!r}: choose one of {', '.join(SEGMENT_KINDS)}")
            beta = float(s.get("angle", 0.0))
            if not (math.isfinite(beta) and beta > 0):
                raise ParameterError(f"{w}.angle = {beta!r}: a segment's cam angle must be > 0")
            self.y0.append(y)
            if kind == "dwell":
                if s.get("law") is not None:
                    raise ParameterError(f"{w}.law: a dwell has no law")
                self.laws.append(("dwell", None))
            else:
                h = float(s.get("lift") if s.get("lift") is not None else lift)
                if not (math.isfinite(h) and h > 0):
                    raise ParameterError(f"{w}.lift = {h!r}: must be > 0")
                Phi = h if kind == "rise" else -h
                lw = make_segment_law(s, Phi, beta, w)
                self.laws.append((kind, lw))
                y += Phi
                if y < -1e-12 * lift:
                    raise ParameterError(f"{w}: the follower would go {-y:.4g} below its base position (returns "
                                         f"exceed the rises before them)")
            self.th.append(self.th[-1] + beta)
        if abs(self.th[-1] - TWO_PI) > TURN_TOL:
            raise ParameterError(f"{where}: the segments' angles add up to {math.degrees(self.th[-1]):.6g}°, not "
                                 f"360° (one cam turn)")
        self.th[-1] = TWO_PI
        if abs(y) > 1e-12 * lift:
            raise ParameterError(f"{where}: the program ends {y:.4g} away from where it starts (the returns must "
                                 f"bring the follower back to its base position)")
        self.segments = segs
        self.P = self._params()

    # ------------------------------------------------------------------ compiled form
    def _params(self):
        pp, bz, cy, kinds, idx = [], [], [], [], []
        for kind, lw in self.laws:
            if lw is None:
                kinds.append(0)
                idx.append(0)
            elif isinstance(lw, PseudoPolynomialLaw):
                kinds.append(1)
                idx.append(len(pp))
                pp.append(lw.motion_form().P)
            elif isinstance(lw, BezierLaw):
                kinds.append(2)
                idx.append(len(bz))
                bz.append(lw.motion_form().P)
            else:
                kinds.append(3)
                idx.append(len(cy))
                cy.append(lw.motion_form().P)
        # (a dummy of each family: the tuples are never empty, so the law's types are fixed)
        pp = pp or [PseudoPolynomialLaw(1.0, 1.0).motion_form().P]
        bz = bz or [BezierLaw(1.0, 1.0).motion_form().P]
        cy = cy or [CycloidalLaw(1.0, 1.0).motion_form().P]
        return CamP(len(self.laws), np.array(self.th, float), np.array(self.y0, float),
                    np.array(kinds, dtype=np.int64), np.array(idx, dtype=np.int64), tuple(pp), tuple(bz), tuple(cy))

    # ------------------------------------------------------------------ evaluation
    def __call__(self, theta):
        """(y, y', y'', y''') at cam angles θ (float → floats, array → arrays) [m or rad, per rad …]."""
        if isinstance(theta, (float, int)):
            return cam_motion(float(theta), self.P)
        th = np.asarray(theta, dtype=float)
        out = np.array([cam_motion(x, self.P) for x in th.ravel().tolist()], dtype=float).reshape(-1, 4)
        return tuple(out[:, k].reshape(th.shape) for k in range(4))

    def segment_table(self) -> list:
        """[{kind, law, start_deg, end_deg, y_start, y_end}] for reports."""
        out = []
        for k, (kind, lw) in enumerate(self.laws):
            y1 = self.y0[k] + (lw.Phi if lw is not None else 0.0)
            out.append({"kind": kind, "law": _law_name(self.segments[k]) if lw is not None else "",
                        "start_deg": math.degrees(self.th[k]), "end_deg": math.degrees(self.th[k + 1]),
                        "y_start": self.y0[k], "y_end": y1})
        return out

    def describe(self) -> list:
        return [dict(s) for s in self.segments]


def _as_dict(s) -> dict:
    if isinstance(s, dict):
        return dict(s)
    if hasattr(s, "model_dump"):
        return s.model_dump()
    return dict(vars(s))


def _law_name(s) -> str:
    lw = s.get("law")
    if lw == "pseudopoly":
        return f"pseudopoly {list(s.get('gammas') or (3, 4, 5))}"
    if lw == "bezier":
        return f"bezier m={s.get('m') or 2} p={s.get('p') if s.get('p') is not None else 3}"
    return str(lw)


def make_segment_law(s: dict, Phi: float, beta: float, where: str):
    """The motion law of one rise or return (Φ = ±lift over the cam angle β)."""
    kind = s.get("law")
    if kind not in LAW_KINDS:
        raise ParameterError(f"{where}.law = {kind!r}: choose one of {', '.join(LAW_KINDS)}")
    extra = [k for k in ("gammas",) if s.get(k) is not None and kind not in ("pseudopoly",)]
    extra += [k for k in ("m", "p", "interior_over_Phi") if s.get(k) is not None and kind != "bezier"]
    if extra:
        raise ParameterError(f"{where}: {', '.join(extra)} do not belong to the law {kind!r}")
    try:
        if kind == "345":
            lw = PseudoPolynomialLaw(Phi, beta, (3.0, 4.0, 5.0))
        elif kind == "pseudopoly":
            lw = PseudoPolynomialLaw(Phi, beta, s.get("gammas") or (3.0, 4.0, 5.0))
        elif kind == "cycloidal":
            lw = CycloidalLaw(Phi, beta)
        else:
            m = int(s.get("m") if s.get("m") is not None else 2)
            p = int(s.get("p") if s.get("p") is not None else 3)
            rel = s.get("interior_over_Phi")
            lw = BezierLaw(Phi, beta, m, p, None if rel is None else np.asarray(rel, float) * Phi)
    except ParameterError as e:
        raise ParameterError(f"{where}: {e}") from None
    # a cam segment starts and ends at rest with zero acceleration (no infinite jerk on the follower)
    ends = np.array([0.0, beta])
    _, v, a, _ = lw.evaluate(ends, 3)
    mid = np.linspace(0.0, beta, 801)
    _, vm, am, _ = lw.evaluate(mid, 3)
    vpk, apk = max(float(np.max(np.abs(vm))), 1e-300), max(float(np.max(np.abs(am))), 1e-300)
    if np.max(np.abs(v)) > END_TOL * vpk or np.max(np.abs(a)) > END_TOL * apk:
        hint = {"pseudopoly": "give at least 3 exponents (n ≥ 2 boundary conditions)",
                "bezier": "use m ≥ 2"}.get(kind, "")
        raise ParameterError(f"{where}: the law {_law_name(s)} does not start and end with zero speed and "
                             f"acceleration (|y''| at the ends {np.max(np.abs(a)):.3g}, {np.max(np.abs(a)) / apk:.2g} "
                             f"of its peak): a cam segment needs both, or the follower takes an infinite jerk"
                             + (f"; {hint}" if hint else ""))
    return lw


#: the program's compiled parameters: segment count, boundaries θ_k (nseg + 1) [rad], start values
#: y_k, kind (0 dwell, 1 pseudo-polynomial, 2 Bezier, 3 cycloidal), index into that family's tuple
#: of law parameters (pp, bz, cy: each holds at least one entry)
CamP = namedtuple("CamP", "n th y0 kind idx pp bz cy")


@law
def cam_motion(theta, P):
    """The program's kinematic coefficients (y, dy/dθ, d²y/dθ², d³y/dθ³) at cam angle θ [rad]
    (periodic over one turn): the segment's own motion law (:mod:`mjbench.motionlaws`) with the
    segment's cam angle as its time, plus the segment's start value."""
    u = theta - TWO_PI * math.floor(theta / TWO_PI)
    k = 0
    while k < P.n - 1 and u >= P.th[k + 1]:
        k += 1
    x = u - P.th[k]
    kind = P.kind[k]
    if kind == 0:
        return P.y0[k], 0.0, 0.0, 0.0
    if kind == 1:
        p, v, a, j = pseudopoly_motion(x, 3, P.pp[P.idx[k]])
    elif kind == 2:
        p, v, a, j = bezier_motion(x, 3, P.bz[P.idx[k]])
    else:
        p, v, a, j = cycloidal_motion(x, 3, P.cy[P.idx[k]])
    return P.y0[k] + p, v, a, j



# ============================================================================ the follower's geometry
class Follower:
    """The follower's geometry (module docstring): ``motion`` "translating" | "oscillating",
    ``contact`` "roller" | "flat"; base circle ``Rb``, roller radius ``Rr``; translating: unit
    direction ``u``, offset ``e``; oscillating: pivot ``A``, arm ``arm`` (roller) or face offset
    ``face_offset`` (flat), lift sense ``sense`` (+1: counter-clockwise).  Raises GeometryError when
    the follower cannot touch the base circle."""

    def __init__(self, motion, contact, Rb, Rr=0.0, u=(0.0, 1.0), e=0.0, A=(0.0, 0.0), arm=0.0,
                 face_offset=0.0, sense=1):
        self.motion, self.contact = motion, contact
        self.Rb, self.Rr = float(Rb), float(Rr)
        self.sense = 1.0 if sense >= 0 else -1.0
        if contact == "flat":
            self.Rr = 0.0
        self.Rp = self.Rb + self.Rr  #: prime circle (the roller centre's distance at the base position)
        if motion == "translating":
            u = np.asarray(u, float)
            self.u = u / math.hypot(*u)
            self.n = np.array([self.u[1], -self.u[0]])  # to the right of u
            self.e = float(e)
            if contact == "roller":
                if not abs(self.e) < self.Rp:
                    raise GeometryError(f"mechanism.offset = {self.e:g} m: a translating roller follower's offset must "
                                        f"be smaller than the prime circle R_b + R_r = {self.Rp:g} m")
                self.d0 = math.sqrt(self.Rp ** 2 - self.e ** 2)
            else:
                self.d0 = self.Rb
        else:
            self.A = np.asarray(A, float)
            a = math.hypot(*self.A)
            if not a > 0:
                raise GeometryError("mechanism.pivot: the follower's pivot cannot be the cam centre")
            self.arm = float(arm)
            self.f = float(face_offset)
            bA = math.atan2(self.A[1], self.A[0])
            if contact == "roller":
                kappa = (self.Rp ** 2 - a * a - self.arm ** 2) / (2.0 * self.arm)
                if not abs(kappa) < a:
                    raise GeometryError(f"mechanism.arm = {self.arm:g} m: from the pivot at {a:g} m the arm cannot "
                                        f"put the roller on the prime circle R_b + R_r = {self.Rp:g} m")
                c = kappa / a
            else:
                c = (self.Rb - self.f) / a
                if not abs(c) < 1.0:
                    raise GeometryError(f"mechanism.face_offset = {self.f:g} m: the face cannot touch the base circle "
                                        f"R_b = {self.Rb:g} m from the pivot at {a:g} m")
            self.psi0 = bA - self.sense * math.acos(c)

    # ------------------------------------------------------------------ the contact element
    def roller_centre(self, y, y1=0.0, y2=0.0):
        """C, dC/dθ, d²C/dθ² of the roller centre (fixed frame) for follower values y, y', y'' (arrays)."""
        y, y1, y2 = (np.asarray(v, float) for v in (y, y1, y2))
        if self.motion == "translating":
            base = self.e * self.n + self.d0 * self.u
            C = base[None, :] + y[..., None] * self.u[None, :]
            Cy = np.broadcast_to(self.u, C.shape)
            return C, Cy * y1[..., None], Cy * y2[..., None], Cy
        psi = self.psi0 + self.sense * y
        d = np.stack([np.cos(psi), np.sin(psi)], axis=-1)
        Sd = np.stack([-np.sin(psi), np.cos(psi)], axis=-1)
        C = self.A + self.arm * d
        Cy = self.sense * self.arm * Sd  # dC/dΨ
        Cyy = -self.arm * d
        return C, Cy * y1[..., None], Cyy * (y1 * y1)[..., None] + Cy * y2[..., None], Cy

    def face(self, y, y1=0.0, y2=0.0):
        """Flat face: unit normal ν, its angle's rate dα_f/dθ and acceleration, support h, h', h''."""
        y, y1, y2 = (np.asarray(v, float) for v in (y, y1, y2))
        if self.motion == "translating":
            nu = np.broadcast_to(self.u, y.shape + (2,))
            z = np.zeros_like(y)
            return nu, z, z, self.Rb + y, y1, y2
        psi = self.psi0 + self.sense * y
        nu = np.stack([np.cos(psi), np.sin(psi)], axis=-1)
        Snu = np.stack([-np.sin(psi), np.cos(psi)], axis=-1)
        SA = Snu @ self.A
        NA = nu @ self.A
        h = NA + self.f
        h1 = SA * self.sense * y1
        h2 = SA * self.sense * y2 - NA * y1 * y1
        return nu, self.sense * y1, self.sense * y2, h, h1, h2

    def describe(self) -> dict:
        d = {"motion": self.motion, "contact": self.contact, "base_radius_m": self.Rb, "roller_radius_m": self.Rr,
             "prime_radius_m": self.Rp}
        if self.motion == "translating":
            d.update(direction=self.u.tolist(), offset_m=self.e)
        else:
            d.update(pivot_m=self.A.tolist(), arm_m=self.arm, face_offset_m=self.f, sense=self.sense,
                     base_arm_angle_rad=self.psi0)
        return d


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _rot(v, th):
    c, s = np.cos(th), np.sin(th)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _S(v):
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def geometry(fol: Follower, prog: CamProgram, theta) -> dict:
    """The cam designer's quantities at cam angles θ (array): follower y, y', y'', y''';
    ``contact_fixed`` (the contact point, fixed frame), ``profile`` (the cam surface, cam frame),
    ``pitch`` (roller centre, cam frame; flat: the surface), ``normal`` N̂ (unit contact normal from
    the cam to the follower, fixed frame), ``V_y`` (velocity of the follower's contact point per unit
    ẏ, fixed frame), ``pressure_angle`` φ [rad] (signed: atan2(N̂ × V_y, N̂·V_y)), ``rho_pitch``,
    ``rho_cam`` [m] (radius of curvature, > 0 convex), ``face_position`` (flat: the contact point's
    distance along the face from the stem or the pivot's foot)."""
    th = np.asarray(theta, float)
    y, y1, y2, y3 = prog(th)
    out = {"theta": th, "y": y, "y1": y1, "y2": y2, "y3": y3}
    if fol.contact == "roller":
        C, C1, C2, Cy = fol.roller_centre(y, y1, y2)
        T = C1 - _S(C)                     # R(θ)·dP/dθ: the pitch curve's tangent (fixed-frame axes)
        T2 = C2 - 2.0 * _S(C1) - C         # R(θ)·d²P/dθ²
        nT = np.hypot(T[..., 0], T[..., 1])
        N = _S(T) / nT[..., None]           # outward normal of a clockwise-traversed pitch curve
        rho_p = -nT ** 3 / _cross(T, T2)
        Q = C - fol.Rr * N
        out.update(contact_fixed=Q, profile=_rot(Q, -th), pitch=_rot(C, -th), normal=N, V_y=Cy,
                   rho_pitch=rho_p, rho_cam=rho_p - fol.Rr)
    else:
        nu, a1, a2, h, h1, h2 = fol.face(y, y1, y2)
        al1 = a1 - 1.0                      # dα/dθ of the face normal in the cam frame
        dh = h1 / al1
        rho = h + (h2 * al1 - h1 * a2) / al1 ** 3
        X = h[..., None] * nu + dh[..., None] * _S(nu)
        if fol.motion == "translating":
            Vy = np.broadcast_to(fol.u, X.shape)
            face_pos = np.einsum("...k,k->...", X, fol.n) - fol.e  # along the face, from the stem
        else:
            Vy = fol.sense * _S(X - fol.A)
            face_pos = np.einsum("...k,...k->...", X - fol.A, _S(nu))
        out.update(contact_fixed=X, profile=_rot(X, -th), pitch=_rot(X, -th), normal=np.array(nu), V_y=Vy,
                   rho_pitch=rho, rho_cam=rho, face_position=face_pos)
    N, Vy = out["normal"], out["V_y"]
    out["pressure_angle"] = np.arctan2(_cross(N, Vy), np.einsum("...k,...k->...", N, Vy))
    out["normal_share"] = np.einsum("...k,...k->...", N, Vy)  # N̂·V_y: Q = N·(N̂·V_y)
    return out


def checks(fol: Follower, prog: CamProgram, n: int = 7200, max_pressure_angle=None, where="mechanism") -> dict:
    """Pressure angle, curvature and undercut over a turn (n samples, the extremes refined);
    GeometryError naming the parameter for an undercut cam, a flat face on a cam that is not
    convex, or a pressure angle beyond ``max_pressure_angle`` [rad] (None: not checked, beyond
    80°: always refused)."""
    th = TWO_PI * np.arange(n) / n
    g = geometry(fol, prog, th)
    phi = np.abs(g["pressure_angle"])
    k = int(np.argmax(phi))
    phi_max, th_phi = _refine_max(lambda x: abs(float(geometry(fol, prog, np.array([x]))["pressure_angle"][0])),
                                  th, phi)
    rho_c = g["rho_cam"]
    convex = g["rho_pitch"] > 0
    res = {"max_pressure_angle_rad": phi_max, "max_pressure_angle_deg": math.degrees(phi_max),
           "theta_at_max_pressure_angle_deg": math.degrees(th_phi) % 360.0,
           "min_pitch_radius_of_curvature_m": float(np.min(np.where(convex, g["rho_pitch"], np.inf))),
           "min_convex_radius_of_curvature_m": float(np.min(np.where(rho_c > 0, rho_c, np.inf))),
           "min_concave_radius_of_curvature_m": float(np.min(np.where(rho_c < 0, -rho_c, np.inf))),
           "base_radius_m": fol.Rb, "prime_radius_m": fol.Rp}
    for key in list(res):
        if isinstance(res[key], float) and not math.isfinite(res[key]):
            res[key] = None
    if fol.contact == "roller":
        bad = convex & (rho_c <= 0.0)
        if bad.any():
            i = int(np.argmax(bad))
            raise GeometryError(
                f"{where}.base_radius: the cam is undercut at cam angle {math.degrees(th[i]):.1f}°: its pitch curve's radius of "
                f"curvature {1000 * float(np.min(g['rho_pitch'][bad])):.3g} mm is smaller than the roller radius "
                f"{1000 * fol.Rr:.3g} mm (the surface would cross itself); enlarge the base circle (base_radius) or use a "
                f"smaller roller")
    else:
        if np.any(rho_c <= 0.0):
            i = int(np.argmin(rho_c))
            raise GeometryError(
                f"{where}.base_radius: a flat-faced follower needs a convex cam, but the surface's radius of curvature is "
                f"{1000 * float(rho_c[i]):.3g} mm at cam angle {math.degrees(th[i]):.1f}° (R_b + s + s'' ≤ 0 for a "
                f"translating face); enlarge the base circle (base_radius)")
        fp = g["face_position"]
        res["face_contact_range_m"] = [float(np.min(fp)), float(np.max(fp))]
    lim = math.radians(80.0) if max_pressure_angle is None else float(max_pressure_angle)
    if phi_max > lim:
        what = ("max_pressure_angle" if max_pressure_angle is not None else "the pressure angle")
        raise GeometryError(
            f"{where}.{what if max_pressure_angle is not None else 'base_radius'}: the pressure angle reaches "
            f"{math.degrees(phi_max):.2f}° at cam angle {math.degrees(th_phi) % 360:.1f}° > {math.degrees(lim):.4g}°"
            f"{' allowed' if max_pressure_angle is not None else ' (the cam would lock)'}: the base circle "
            f"R_b = {1000 * fol.Rb:.4g} mm is too small for this lift and angle; enlarge it")
    return res


def _refine_max(f, th, vals):
    """The maximum of a sampled periodic function refined by golden section around the best sample."""
    from scipy.optimize import minimize_scalar

    k = int(np.argmax(vals))
    h = th[1] - th[0] if len(th) > 1 else 1e-3
    r = minimize_scalar(lambda x: -f(x), bounds=(th[k] - h, th[k] + h), method="bounded",
                        options={"xatol": 1e-12})
    if -r.fun >= vals[k]:
        return float(-r.fun), float(r.x)
    return float(vals[k]), float(th[k])


# ============================================================================ forces and jump
class FollowerLoad:
    """What holds the follower on the cam, in the follower coordinate's units: ``M`` its mass [kg]
    (or inertia about the pivot [kg·m²]), spring rate ``k`` [N/m or N·m/rad] and preload ``F0`` at
    the base position [N or N·m] (k·y₀ = F0), a constant load ``FL`` opposing the lift, viscous
    damping ``c``."""

    def __init__(self, M, k, F0, FL=0.0, c=0.0):
        self.M, self.k, self.F0, self.FL, self.c = float(M), float(k), float(F0), float(FL), float(c)

    def static(self, y):
        """k·(y + y₀) + F_L = k·y + F0 + F_L: the force pressing the follower onto the cam at rest."""
        return self.k * np.asarray(y, float) + self.F0 + self.FL


def generalised_force(load: FollowerLoad, g: dict, omega, alpha=0.0):
    """Q(θ) = M·(y''ω² + y'α) + c·y'ω + k·(y + y₀) + F_L: the force (torque) along the follower
    coordinate the cam must supply at cam speed ω [rad/s] and acceleration α [rad/s²]."""
    return (load.M * (g["y2"] * omega * omega + g["y1"] * alpha) + load.c * g["y1"] * omega + load.static(g["y"]))


def contact_force(load: FollowerLoad, g: dict, omega, alpha=0.0):
    """The normal contact force N [N] along the cycle: Q / (N̂·V_y) (negative: the cam would have to pull)."""
    return generalised_force(load, g, omega, alpha) / g["normal_share"]


def jump_speed(load: FollowerLoad, prog: CamProgram, n: int = 20000) -> dict:
    """The lowest constant cam speed at which the follower leaves the cam (module docstring):
    {speed_rad_s, theta_rad, theta_deg, y, y1, y2} (speed None when the program never decelerates the
    follower).  Per θ with y'' < 0 the positive root of M·y''·ω² + c·y'·ω + K = 0 (K = k·(y + y₀) +
    F_L > 0); its minimum over the turn (n samples, refined by bounded Brent).  Raises
    ParameterError when K ≤ 0 somewhere: the follower is not held even at rest."""
    th = TWO_PI * np.arange(n) / n
    y, y1, y2, _ = prog(th)
    K = load.static(y)
    if np.any(K <= 0.0):
        i = int(np.argmin(K))
        raise ParameterError(f"mechanism.spring_preload: the spring ({load.k:g}, preload {load.F0:g}) and the load "
                             f"{load.FL:g} leave {float(K[i]):.4g} pressing the follower onto the cam at cam angle "
                             f"{math.degrees(th[i]):.1f}°: it is not held even at rest (raise the preload)")

    def root(x):
        yy, v1, v2, _ = cam_motion(float(x), prog.P)
        a = load.M * v2
        if a >= 0.0:
            return math.inf
        b = load.c * v1
        Kx = load.k * yy + load.F0 + load.FL
        return (-b - math.sqrt(b * b - 4.0 * a * Kx)) / (2.0 * a)

    a = load.M * y2
    b = load.c * y1
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(a < 0.0, (-b - np.sqrt(np.maximum(b * b - 4.0 * a * K, 0.0))) / (2.0 * np.where(a < 0, a, -1.0)),
                     np.inf)
    if not np.any(np.isfinite(w)):
        return {"speed_rad_s": None, "theta_rad": None, "theta_deg": None}
    k = int(np.argmin(w))
    from scipy.optimize import minimize_scalar

    h = th[1] - th[0]
    r = minimize_scalar(root, bounds=(th[k] - h, th[k] + h), method="bounded", options={"xatol": 1e-13})
    ws, ts = (float(r.fun), float(r.x)) if r.fun <= w[k] else (float(w[k]), float(th[k]))
    yy, v1, v2, _ = cam_motion(ts, prog.P)
    return {"speed_rad_s": ws, "speed_rpm": ws * 30.0 / math.pi, "theta_rad": ts % TWO_PI,
            "theta_deg": math.degrees(ts) % 360.0, "y": yy, "y1": v1, "y2": v2}


def spring_for_speed(M, prog: CamProgram, omega, FL=0.0, c=0.0, k=None, margin=1.0, n: int = 20000):
    """The spring that holds the follower up to ``margin``·ω: with the rate ``k`` given (or the
    rate that makes the preload smallest for a spring that is also at its minimum at full lift),
    the smallest preload F0 with M·y''·W² + c·y'·W + k·y + F0 + F_L ≥ 0 over the turn, W = margin·ω.
    Returns (k, F0)."""
    th = TWO_PI * np.arange(n) / n
    y, y1, y2, _ = prog(th)
    W = float(margin) * float(omega)
    need = -(M * y2 * W * W + c * y1 * W + FL)  # k·y + F0 ≥ need
    if k is None:
        # the rate with the least force at full lift: the line k·y + F0 touching the demand from above
        # at its two binding points; among the supporting lines of the demand, the one of least k·lift + F0
        best = None
        lift = float(np.max(y))
        for kk in np.linspace(0.0, 4.0 * max(float(np.max(need)) / max(lift, 1e-12), 1e-9), 401):
            F0 = float(np.max(need - kk * y))
            cost = kk * lift + 2.0 * F0  # the force swing and the preload both size the spring
            if best is None or cost < best[0]:
                best = (cost, kk, F0)
        k = best[1]
    F0 = float(np.max(need - k * y))
    return float(k), max(F0, 0.0)
