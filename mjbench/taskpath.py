"""Motion in the task space: an end-effector path → inverse kinematics → joint references.

``[path]`` of a scenario (a machine with several inputs, docs/linkages.md §8.3)::

    [path]
    point = "dist1.C"                     # the end effector ("link.point")
    start = ["0 mm", "400 mm"]            # where the path starts (the machine starts there, at rest)
    segments = [
      {line = ["80 mm", "400 mm"], T = "0.3 s"},                          # a straight line to a point
      {arc = {center = ["0 mm", "400 mm"], angle = "180 deg"}, T = "0.6 s"},  # an arc about a centre
      {line = ["0 mm", "400 mm"], T = "0.3 s"},
    ]
    law = "345"        # the motion law along each segment (rest to rest): "345" or "cycloidal"
    dwell = "50 ms"    # rest after each segment
    repeat = true      # cyclic (the path must end where it starts)

Each segment is travelled rest to rest: its arc length s(t) = L·λ(t/T), λ the normalised motion law
(3-4-5: 10τ³ − 15τ⁴ + 6τ⁵; cycloidal: τ − sin(2πτ)/2π).  The inverse kinematics
(:meth:`~mjbench.mechanisms.linkage.multi_mechanism.MultiLinkage.inverse_kinematics`) follows the
assembly branch of the stated pose along the path, sampled every :data:`SAMPLE_DT`; a path that
passes a singular configuration (either kind) is refused before simulating, naming the time and the
point.  The joint trajectories q_k(t), q̇_k, q̈_k are tabulated at the samples (velocities and
accelerations from the kinematics, exact) and read by the reference law :func:`path_reference`
(cubic Hermite in time).
"""

import math
from collections import namedtuple
from typing import Literal

import numpy as np
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from .compiled import law
from .control import Reference
from .errors import ParameterError
from .fields import Bool, Q, Strict
from .mechanisms.table import mechanism_key

SAMPLE_DT = 5e-4  #: [s] the inverse kinematics' sampling of the path (the reference's nodes)

Len = Q("length", plausible=False)


class ArcSpec(Strict):
    center: tuple[Len, Len] = Field(description="the arc's centre [m]")
    angle: Q("angle", plausible=False) = Field(description="the angle swept, counter-clockwise > 0 [rad]")


class SegmentSpec(Strict):
    """One segment: ``line`` to a point, or ``arc`` about a centre; travelled in ``T`` s."""

    line: tuple[Len, Len] | None = None
    arc: ArcSpec | None = None
    T: Q("time", gt=0.0, plausible=False) = Field(description="travel time of the segment")

    @model_validator(mode="after")
    def _one(self):
        if (self.line is None) == (self.arc is None):
            raise PydanticCustomError("mjbench_value", "a segment is either line = [x, y] or arc = {center, angle}")
        return self


class PathParams(Strict):
    """``[path]``: the end effector's path in the plane and its timing (module docstring)."""

    point: str = Field(description='the end effector, "link.point"')
    start: tuple[Len, Len] = Field(description="where the path starts [m]")
    segments: list[SegmentSpec] = Field(min_length=1)
    law: Literal["345", "cycloidal"] = "345"
    dwell: Q("time", ge=0.0, plausible=False) = 0.0
    repeat: Bool = False


@law
def unit_law(kind, tau):
    """The normalised rest-to-rest law λ(τ), λ', λ'' on τ ∈ [0, 1] (kind 0: 3-4-5, 1: cycloidal)."""
    if tau <= 0.0:
        return 0.0, 0.0, 0.0
    if tau >= 1.0:
        return 1.0, 0.0, 0.0
    if kind == 0:
        t2 = tau * tau
        t3 = t2 * tau
        return (10.0 * t3 - 15.0 * t3 * tau + 6.0 * t3 * t2, 30.0 * t2 - 60.0 * t3 + 30.0 * t2 * t2,
                60.0 * tau - 180.0 * t2 + 120.0 * t3)
    w = 2.0 * math.pi
    return tau - math.sin(w * tau) / w, 1.0 - math.cos(w * tau), w * math.sin(w * tau)


class TaskPath:
    """The path as a function of time: position, velocity, acceleration of the end effector."""

    def __init__(self, p: PathParams):
        self.p = p
        self.kind = 0 if p.law == "345" else 1
        segs = []
        x = np.array(p.start, float)
        t0 = 0.0
        for k, s in enumerate(p.segments):
            if s.line is not None:
                end = np.array(s.line, float)
                L = float(np.linalg.norm(end - x))
                segs.append(("line", t0, float(s.T), x.copy(), end, L, None, 0.0))
            else:
                c = np.array(s.arc.center, float)
                r = float(np.linalg.norm(x - c))
                if not r > 0:
                    raise ParameterError(f"path.segments[{k}]: the arc's centre is its start point (radius 0)")
                a0 = math.atan2(x[1] - c[1], x[0] - c[0])
                ang = float(s.arc.angle)
                end = c + r * np.array([math.cos(a0 + ang), math.sin(a0 + ang)])
                segs.append(("arc", t0, float(s.T), x.copy(), end, r * abs(ang), (c, r, a0, ang), 0.0))
            x = end
            t0 += float(s.T) + float(p.dwell)
        self.segs = segs
        self.duration = t0
        if p.repeat and float(np.linalg.norm(x - np.array(p.start, float))) > 1e-9:
            raise ParameterError(f"path.repeat = true: the path ends at ({x[0]:.6g}, {x[1]:.6g}) m, not where it "
                                 f"starts ({p.start[0]:.6g}, {p.start[1]:.6g}) m")

    def at(self, t):
        """(xy (B, 2), v (B, 2), a (B, 2)) at times t (array; repeated when ``repeat``, held after the end)."""
        t = np.atleast_1d(np.asarray(t, float))
        if self.p.repeat:
            t = np.mod(t, self.duration)
        X, Vv, A = np.empty((len(t), 2)), np.zeros((len(t), 2)), np.zeros((len(t), 2))
        X[:] = self.segs[-1][4]
        for kind, t0, T, x0, x1, L, arc, _ in reversed(self.segs):
            sel = t < t0 + T + float(self.p.dwell) + 1e-15
            if not sel.any():
                continue
            tau = np.clip((t[sel] - t0) / T, 0.0, 1.0)
            lam = np.array([unit_law(self.kind, float(u)) for u in tau])
            s, sd, sdd = lam[:, 0], lam[:, 1] / T, lam[:, 2] / (T * T)
            if kind == "line":
                u = (x1 - x0) / L if L > 0 else np.zeros(2)
                X[sel] = x0 + np.outer(s * L, u)
                Vv[sel] = np.outer(sd * L, u)
                A[sel] = np.outer(sdd * L, u)
            else:
                c, r, a0, ang = arc
                th = a0 + ang * s
                e = np.stack([np.cos(th), np.sin(th)], axis=1)
                n = np.stack([-np.sin(th), np.cos(th)], axis=1)
                w, wd = ang * sd, ang * sdd
                X[sel] = c + r * e
                Vv[sel] = (r * w)[:, None] * n
                A[sel] = (r * wd)[:, None] * n - (r * w * w)[:, None] * e
        return X, Vv, A


#: the joint reference's parameters: the first node's time, 1/Δt, the nodes (N, 3): q, q̇, q̈ of the
#: axis, the cycle (s; 0: held after the end), the gear ratio z
PathRefP = namedtuple("PathRefP", "t0 inv_h h nodes period z")


@law(outputs=("phi_ref", "om_ref", "acc_ref"))
def path_reference(t, P, S):
    """φ_ref = z·q(t), φ̇_ref = z·q̇(t), φ̈_ref = z·q̈(t) of one axis from its tabulated joint
    trajectory: cubic Hermite of q (slopes q̇) and of q̇ (slopes q̈), q̈ linear, between nodes."""
    tt = t - P.t0
    if P.period > 0.0 and not (0.0 <= tt < P.period):  # (within the first cycle: no division, floor 0)
        tt = tt - P.period * math.floor(tt / P.period)
    u = tt * P.inv_h
    N = P.nodes.shape[0]
    if u <= 0.0:
        i = 0
        s = 0.0
    elif u >= N - 1:
        i = N - 2
        s = 1.0
    else:
        i = int(math.floor(u))
        s = u - i
    h = P.h
    R = P.nodes
    s2 = s * s
    s3 = s2 * s
    h00 = 2.0 * s3 - 3.0 * s2 + 1.0
    h10 = s3 - 2.0 * s2 + s
    h01 = -2.0 * s3 + 3.0 * s2
    h11 = s3 - s2
    q = h00 * R[i, 0] + h10 * h * R[i, 1] + h01 * R[i + 1, 0] + h11 * h * R[i + 1, 1]
    qd = h00 * R[i, 1] + h10 * h * R[i, 2] + h01 * R[i + 1, 1] + h11 * h * R[i + 1, 2]
    qdd = (1.0 - s) * R[i, 2] + s * R[i + 1, 2]
    return P.z * q, P.z * qd, P.z * qdd


class PathReferenceParams(Strict):
    """``[modes.NAME.reference] type = "path"``: every axis tracks its joint trajectory of the scenario's
    ``[path]`` (the inverse kinematics of the end effector's path)."""

    type: Literal["path"] = "path"


def joint_trajectories(mechanism, path: PathParams, dt: float = SAMPLE_DT):
    """(t (N,), q, q̇, q̈ (N, n)) of the inputs along the path, sampled every ``dt`` over one run of it
    (one cycle when it repeats): :meth:`inverse_kinematics` of the mechanism."""
    tp = TaskPath(path)
    n = max(2, int(math.ceil(tp.duration / dt)) + 1)
    t = np.linspace(0.0, tp.duration, n)
    X, V, A = tp.at(t)
    start = mechanism.points(np.asarray(mechanism.c.q_ref))[path.point]
    gap = math.hypot(float(start[0]) - path.start[0], float(start[1]) - path.start[1])
    if gap > 1e-6:
        raise ParameterError(f"path.start = ({path.start[0]:.6g}, {path.start[1]:.6g}) m: the stated pose puts "
                             f"{path.point} at ({float(start[0]):.6g}, {float(start[1]):.6g}) m ({gap:.3g} m away); "
                             f"start the path where the machine starts (or set input_angles)")
    Q, Qd, Qdd = mechanism.inverse_kinematics(path.point, X, V, A, t)
    return t, Q, Qd, Qdd, tp


class PathReference(Reference):
    """One axis's joint trajectory along the task-space path (:func:`path_reference`)."""

    STATE = ()
    law = path_reference

    def __init__(self, t, q, qd, qdd, period, nodes=None):
        self.t, self.period = np.asarray(t, float), float(period)
        if nodes is None:  # (given: the same stacked (q, q̇, q̈), kept by PathReferences)
            nodes = np.ascontiguousarray(np.stack([q, qd, qdd], axis=1), dtype=float)
        self.nodes = nodes
        self.h = float(self.t[1] - self.t[0])
        self.reset()

    def parameters(self, T, z):
        return PathRefP(float(self.t[0]), 1.0 / self.h, self.h, self.nodes, self.period, float(z))

    def crank_speed_at(self, machine, q):
        return None

    def setpoint(self, machine):
        return None

    def metrics(self, tr, machine, config) -> dict:
        """The end effector's tracking of the path (:meth:`PathReferences.metrics`)."""
        src = getattr(self, "source", None)
        return src.metrics(tr, machine, config) if src is not None else {}


_TRAJ: dict = {}


class PathReferences:
    """The joint trajectories of every axis along a path; :meth:`for_axis` gives an axis's reference.
    (Solved once per mechanism and path in a process.)"""

    def __init__(self, mechanism, path: PathParams):
        key = (type(mechanism).__name__, mechanism_key(mechanism), path.model_dump_json())
        hit = _TRAJ.get(key)
        if hit is None:
            if len(_TRAJ) > 8:
                _TRAJ.clear()
            hit = _TRAJ[key] = joint_trajectories(mechanism, path) + ({},)
        self.t, self.Q, self.Qd, self.Qdd, self.path, self._nodes = hit
        self.period = self.path.duration if path.repeat else 0.0

    def reset(self):
        """(A per-axis reference holds the state; this set has none.)"""

    def for_axis(self, k: int) -> PathReference:
        nodes = self._nodes.get(k)  # (axis k's node table: stacked once per trajectory, only read)
        if nodes is None:
            nodes = self._nodes[k] = np.ascontiguousarray(np.stack([self.Q[:, k], self.Qd[:, k], self.Qdd[:, k]],
                                                                   axis=1), dtype=float)
        r = PathReference(self.t, self.Q[:, k], self.Qd[:, k], self.Qdd[:, k], self.period, nodes)
        r.source = self
        return r

    def metrics(self, tr, machine, config) -> dict:
        """``end_effector``: the distance between where the end effector is (the mechanism's kinematics at
        the recorded inputs) and where the path puts it, max and RMS over t ≥ ``settle_time`` (the
        scenario's ``[metrics]``; default 0), and the same over the last cycle of a repeated path."""
        labels = tr.axes
        q = np.stack([tr[f"{lab}:crank_angle_rad"] for lab in labels], axis=1)
        pts = machine.mechanism.points(q)[self.path.p.point]
        actual = np.stack([pts[0], pts[1]], axis=1)
        plan = self.path.at(tr.t)[0]
        err = np.linalg.norm(actual - plan, axis=1)
        t0 = float(getattr(config, "settle_time", None) or 0.0)
        sel = tr.t >= t0 - 1e-12
        out = {"point": self.path.p.point, "from_s": t0, "max_error_m": float(np.max(err[sel])),
               "rms_error_m": float(np.sqrt(np.mean(err[sel] ** 2)))}
        if self.period > 0 and tr.t[-1] >= self.period:
            last = tr.t >= tr.t[-1] - self.period - 1e-12
            out["max_error_last_cycle_m"] = float(np.max(err[last]))
        return {"end_effector": out}

    def end_effector(self, t):
        """The planned end-effector position (B, 2) at times t."""
        return self.path.at(t)[0]


__all__ = ["PathParams", "SegmentSpec", "ArcSpec", "TaskPath", "unit_law", "path_reference", "PathRefP",
           "SAMPLE_DT", "PathReferenceParams", "PathReference", "PathReferences", "joint_trajectories"]
