"""Videos of runs: a scenario simulated on MuJoCo and rendered in real time (``mjbench render``)."""
from __future__ import annotations

import time

import numpy as np

from ..backends.joints import joint_list
from ..errors import ParameterError
from .gl import gl_setup
from .platform import _render_platform_run
from .video import VideoWriter, _frame_bar, _video_info, frame_indices
from .view import MechanismView
from .. import scenario as scenario_mod
from ..backends import multibody
from ..errors import ScenarioError
from ..outputs import atomic_write


# ============================================================================ scenario → video
def simulate_for_video(scn, mode: str | None = None, t_end: float | None = None):
    """Multibody run of the scenario with every control step recorded.  Returns (machine, traj)."""

    mode = scn.mode(mode)
    machine = scenario_mod.make_machine(scn, mode)
    t_end = float(t_end if t_end is not None else scn.simulation.t_end)
    h = scn.simulation.dt
    o = scn.multibody_options()
    if machine.mechanism.frames_from_joints:  # its pose is more than q (a cam's follower)
        o = {**o, "record_joints": True}
    traj = multibody.simulate(machine, t_end, record_dt=h, options=o)
    return machine, traj


def overlay_text(machine, traj, idx) -> list:
    """The overlay's lines below the time of every frame ``idx``: the crank and motor speeds, the
    drive's voltage, current and torque on the crank (an ideal drive: its torque), each process load
    of the mechanism (its magnitude from the mechanism's load law at the frame's angle); each line
    at most 47 characters (the text box)."""
    t, q, qd, V, I = traj.t, traj.q, traj.qd, traj.voltage, traj.current
    T = traj["torque_crank_Nm"]
    z = float(getattr(machine.drive, "z", 1.0))
    mech = machine.mechanism
    loads = []
    if hasattr(mech, "load_forces") and getattr(mech, "load_specs", None):
        for name, ld, (_, _, F) in zip(mech.load_names(), mech.load_specs, mech.load_forces(q[idx], qd[idx])):
            loads.append((name[:16], "kN" if ld.link is None else "kN·m", np.asarray(F, float) + 0.0 * q[idx]))
    out = []
    for k, i in enumerate(idx):
        lines = [f"crank {qd[i]:7.2f} rad/s   motor {z * qd[i]:8.2f} rad/s"]
        if np.isfinite(V[i]):
            lines.append(f"V {V[i]:6.2f} V  I {I[i]:6.2f} A  T {T[i]:7.2f} N·m")
        else:
            lines.append(f"drive torque {T[i]:8.2f} N·m")
        lines += [f"load {n}: {1e-3 * F[k]:7.3f} {u}" for n, u, F in loads[:2]]
        out.append(lines)
    return out


def render_trajectory(machine, traj, out, fps=30.0, width=960, height=540, title="", progress=True,
                      t_end=None, options=None, crf=23, poster=None, poster_at=0.6):
    """Write the video of a recorded run.  Returns a dict of numbers (frames, seconds, fps).
    ``poster``: also write that PNG, a frame of the machine running (:func:`poster_frame`, after
    ``poster_at`` of the video; not at rest at t = 0): the page's still image before the video
    plays (``info["poster"]``)."""

    mech = machine.mechanism
    if machine.naxes > 1:
        return _render_multi_axis(machine, traj, out, fps, width, height, title, progress, t_end, options, crf)
    drive = machine.drive
    if mech.render_view().kind == "top":  # the mechanism's class says how it is shown
        return _render_platform_run(machine, traj, out, fps, width, height, title, progress, t_end, crf)
    idx = frame_indices(traj.t, fps, t_end)
    t, q, qd = traj.t, traj.q, traj.qd
    t0 = time.perf_counter()
    text = overlay_text(machine, traj, idx)
    view = MechanismView(mech, width, height, bounds_q=q[idx], armature=float(drive.J_eq), options=options,
                         overlay_lines=(1 if title else 0) + 2 + max(len(x) for x in text))
    k_poster = poster_frame(traj, idx, poster_at)
    poses = _recorded_poses(view.model, traj) if mech.frames_from_joints else None
    # trail: the last 0.6 crank turn, 40-80 points decimated from the recorded steps
    n_render = 0.0
    try:
        with VideoWriter(out, width, height, fps, crf=crf) as writer, \
                _frame_bar(len(idx), out, progress) as bar:
            buf = np.empty((view.height, view.width, 3), np.uint8)
            for k, i in enumerate(idx):
                lo = np.searchsorted(q[: i + 1], q[i] - 2 * np.pi * view.trail_turns) if qd[i] >= 0 else 0
                lo = max(0, min(lo, i))
                trail = q[lo: i + 1][:: max(1, (i - lo) // 40)] if i > lo else None
                if trail is not None and trail[-1] != q[i]:
                    trail = np.append(trail, q[i])
                lines = ([title] if title else []) + [
                    f"t = {t[i]:6.3f} s  ({fps:g} fps)  grid {view.grid_step * 1000:g} mm"] + text[k]
                r0 = time.perf_counter()
                img = view.frame(q[i], lines, trail_q=trail, out=buf, qpos=None if poses is None else poses(i))
                n_render += time.perf_counter() - r0
                writer.write(img)
                if poster is not None and k == k_poster:
                    _write_png(poster, img)
                bar.update(1)
    finally:
        view.close()
    info = _video_info(len(idx), fps, width, height, t0, out, render_s=n_render)
    if poster is not None:
        info["poster"] = str(poster)
        info["poster_t_s"] = float(t[idx[k_poster]])
    return info


def poster_frame(traj, idx, after=0.6) -> int:
    """The frame the still image shows: the machine working hardest (largest |drive torque on the
    crank|) in the last part of the video (from ``after`` of it), so the still shows it running
    under its load, not at rest at t = 0."""
    k0 = min(len(idx) - 1, int(after * len(idx)))
    T = np.abs(np.asarray(traj["torque_crank_Nm"], dtype=float)[np.asarray(idx[k0:])])
    return k0 + int(np.nanargmax(T)) if np.any(np.isfinite(T)) else k0


def _write_png(path, img) -> None:
    """A frame (H, W, 3 uint8) as a PNG, written atomically."""
    from PIL import Image

    atomic_write(path, lambda f: Image.fromarray(np.ascontiguousarray(img)).save(f, format="PNG"), mode="wb")


#: the traced point's trail behind the mechanism of a machine with several motors [s]
TRAIL_S = 0.3


def _render_multi_axis(machine, traj, out, fps, width, height, title, progress, t_end, options, crf):
    """The video of a machine with several motors: the pose from every axis's recorded angle, the
    traced point's whole recorded path and its last :data:`TRAIL_S` as the trail, and one overlay
    line per axis (input speed, motor current and voltage)."""
    mech, labels = machine.mechanism, machine.axis_labels
    idx = frame_indices(traj.t, fps, t_end)
    t = traj.t
    axes = [traj.axis(lab) for lab in labels]
    q = np.stack([a.q for a in axes], axis=1)
    qd, cur, V = (np.stack([getattr(a, k) for a in axes], axis=1) for k in ("qd", "current", "voltage"))
    t0 = time.perf_counter()
    step = max(1, len(t) // 2000)
    view = MechanismView(mech, width, height, bounds_q=q[idx], armature=tuple(float(d.J_eq) for d in machine.drives),
                         options=options, overlay_lines=len(labels) + (2 if title else 1), path_q=q[::step])
    n_render = 0.0
    try:
        with VideoWriter(out, width, height, fps, crf=crf) as writer, \
                _frame_bar(len(idx), out, progress) as bar:
            buf = np.empty((view.height, view.width, 3), np.uint8)
            for i in idx:
                lo = int(np.searchsorted(t, t[i] - TRAIL_S))
                trail = q[lo: i + 1][:: max(1, (i - lo) // 40)] if i > lo else None
                if trail is not None:
                    trail = np.vstack([trail, q[i:i + 1]])
                lines = ([title] if title else []) + [f"t = {t[i]:6.3f} s   (real time, {fps:g} fps)"] + [
                    f"{lab}: {qd[i, k]:6.2f} rad/s  I {cur[i, k]:6.2f} A  V {V[i, k]:6.2f} V"
                    for k, lab in enumerate(labels)]
                r0 = time.perf_counter()
                img = view.frame(q[i], lines, trail_q=trail, out=buf)
                n_render += time.perf_counter() - r0
                writer.write(img)
                bar.update(1)
    finally:
        view.close()
    return _video_info(len(idx), fps, width, height, t0, out, render_s=n_render)


def _recorded_poses(model, traj):
    """pose(i) → the recorded qpos of row i from the joint columns (``record_joints``), or None when
    the run did not record every joint of the model."""
    joints = joint_list(model)
    cols = []
    for stem, kind, qa, _ in joints:
        name = f"{stem}_rad" if kind == "hinge" else f"{stem}_m"
        if name not in traj.columns:
            return None
        cols.append((qa, traj.columns.index(name)))
    data = traj.data

    def pose(i):
        qpos = np.array(model.qpos0, float)
        for qa, c in cols:
            qpos[qa] = data[i, c]
        return qpos
    return pose


def render_scenario(scn: dict, out, mode=None, fps=30.0, width=960, height=540, t_end=None, progress=True,
                    crf=23, poster=None):
    """Simulate (multibody) and render ``scn``.  Returns the render info dict plus ``sim_s``."""
    if not (np.isfinite(fps) and fps > 0):
        raise ParameterError(f"--fps = {fps!r}: must be > 0")
    gl_setup()

    if not scn.modes:
        raise ScenarioError(f"scenario {scn.name!r} defines no [modes.*] controller to simulate")
    mode = scn.mode(mode)
    t0 = time.perf_counter()
    machine, traj = simulate_for_video(scn, mode, t_end)
    sim_s = time.perf_counter() - t0
    info = render_trajectory(machine, traj, out, fps=fps, width=width, height=height,
                             title=f"{scn.name} — mode {mode} (multibody)", progress=progress, t_end=t_end,
                             options=scn.multibody_options(), crf=crf, poster=poster)
    info["sim_s"] = sim_s
    info["mode"] = mode
    return info
