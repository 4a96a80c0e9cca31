"""Videos of runs: a scenario simulated on MuJoCo and rendered in real time (``mjbench render``)."""
from __future__ import annotations

import time

import numpy as np

from ..errors import ParameterError
from .gl import gl_setup
from .platform import _render_platform_run
from .video import VideoWriter, _frame_bar, _video_info, frame_indices
from .view import MechanismView
from .. import scenario as scenario_mod
from ..backends import multibody
from ..errors import ScenarioError


# ============================================================================ scenario → video
def simulate_for_video(scn, mode: str | None = None, t_end: float | None = None):
    """Multibody run of the scenario with every control step recorded.  Returns (machine, traj)."""

    mode = scn.mode(mode)
    machine = scenario_mod.make_machine(scn, mode)
    t_end = float(t_end if t_end is not None else scn.simulation.t_end)
    h = scn.simulation.dt
    traj = multibody.simulate(machine, t_end, record_dt=h, options=scn.multibody_options())
    return machine, traj


def render_trajectory(machine, traj, out, fps=30.0, width=960, height=540, title="", progress=True,
                      t_end=None, options=None, crf=23):
    """Write the video of a recorded run.  Returns a dict of numbers (frames, seconds, fps)."""

    mech = machine.mechanism
    if machine.naxes > 1:
        return _render_multi_axis(machine, traj, out, fps, width, height, title, progress, t_end, options, crf)
    drive = machine.drive
    if mech.render_view().kind == "top":  # the mechanism's class says how it is shown
        return _render_platform_run(machine, traj, out, fps, width, height, title, progress, t_end, crf)
    idx = frame_indices(traj.t, fps, t_end)
    t, q, qd, V = traj.t, traj.q, traj.qd, traj.voltage
    t0 = time.perf_counter()
    view = MechanismView(mech, width, height, bounds_q=q[idx], armature=float(drive.J_eq), options=options,
                         overlay_lines=4 if title else 3)
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
                    f"t = {t[i]:6.3f} s   (real time, {fps:g} fps)",
                    f"crank speed {qd[i]:7.2f} rad/s   motor {drive.z * qd[i]:7.2f} rad/s",
                    f"voltage {V[i]:7.2f} V   grid {view.grid_step * 1000:g} mm",
                ]
                r0 = time.perf_counter()
                img = view.frame(q[i], lines, trail_q=trail, out=buf)
                n_render += time.perf_counter() - r0
                writer.write(img)
                bar.update(1)
    finally:
        view.close()
    return _video_info(len(idx), fps, width, height, t0, out, render_s=n_render)


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


def render_scenario(scn: dict, out, mode=None, fps=30.0, width=960, height=540, t_end=None, progress=True,
                    crf=23):
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
                             options=scn.multibody_options(), crf=crf)
    info["sim_s"] = sim_s
    info["mode"] = mode
    return info
