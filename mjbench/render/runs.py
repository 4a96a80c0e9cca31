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


# ============================================================================ scenario → video
def simulate_for_video(scn, mode: str | None = None, t_end: float | None = None):
    """Multibody run of the scenario with every control step recorded.  Returns (machine, traj)."""
    from .. import scenario as scenario_mod
    from ..backends import multibody

    mode = scn.mode(mode)
    machine = scenario_mod.make_machine(scn, mode)
    t_end = float(t_end if t_end is not None else scn.simulation.t_end)
    h = scn.simulation.dt
    o = scn.multibody_options()
    if getattr(machine.mechanism, "frames_from_joints", False):  # its pose is more than q (a cam's follower)
        o = {**o, "record_joints": True}
    traj = multibody.simulate(machine, t_end, record_dt=h, options=o)
    return machine, traj


def render_trajectory(machine, traj, out, fps=30.0, width=960, height=540, title="", progress=True,
                      t_end=None, options=None, crf=23):
    """Write the video of a recorded run.  Returns a dict of numbers (frames, seconds, fps)."""

    mech, drive = machine.mechanism, machine.drive
    if mech.render_view().kind == "top":  # the mechanism's class says how it is shown
        return _render_platform_run(machine, traj, out, fps, width, height, title, progress, t_end, crf)
    idx = frame_indices(traj.t, fps, t_end)
    t, q, qd, V = traj.t, traj.q, traj.qd, traj.voltage
    t0 = time.perf_counter()
    view = MechanismView(mech, width, height, bounds_q=q[idx], armature=float(drive.J_eq), options=options,
                         overlay_lines=4 if title else 3)
    poses = _recorded_poses(view.model, traj) if getattr(mech, "frames_from_joints", False) else None
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
                img = view.frame(q[i], lines, trail_q=trail, out=buf, qpos=None if poses is None else poses(i))
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
                    crf=23):
    """Simulate (multibody) and render ``scn``.  Returns the render info dict plus ``sim_s``."""
    if not (np.isfinite(fps) and fps > 0):
        raise ParameterError(f"--fps = {fps!r}: must be > 0")
    gl_setup()
    from ..errors import ScenarioError

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
