"""Offscreen videos of a scenario's multibody run (issue 6).

Pipeline (``render_scenario``):

1. the scenario's machine is co-simulated by ``backends.multibody.simulate`` at its control step
   h (0.1 ms) with every step recorded (``record_dt = h``);
2. video frame k shows the simulated state at the step nearest to t_k = k/fps (error ≤ h/2), so
   the video plays in real time; the mechanism is 1-DOF and closed, so the full assembled pose is
   ``mechanism.initial_qpos(model, q)`` of the recorded crank angle q (exact up to the loop-closure
   residual of the run, < 1e-6 m), followed by ``mj_kinematics``;
3. the model is the mechanism's own MJCF plus display-only items (light backdrop with a grid
   whose spacing is printed in the overlay, gradient sky); the camera looks along +y at the
   mechanism plane (paper x → right, paper y → up) and frames the bounding box of
   ``mechanism.points(q)`` over the whole run;
4. the path of ``mechanism.trace_point`` (four-bar: coupler point; quick-return: output slider)
   is drawn as scene connectors: the full kinematic path over one crank turn (thin, pale) and
   the trail of the last crank turn (thick, orange);
5. a text box (time, crank speed, voltage, real-time factor) is drawn with Pillow (already a
   matplotlib dependency) on a small crop of the frame only;
6. frames stream to ``imageio-ffmpeg``'s bundled ffmpeg (H.264, yuv420p) or, for ``*.gif``,
   to Pillow's GIF writer; the file is written under a temporary name and renamed at the end.

OpenGL: ``MUJOCO_GL`` defaults to ``egl`` (Mesa's llvmpipe on a CPU-only machine).  The chosen
backend is probed in a subprocess once; if it fails the renderer falls back to EGL, then OSMesa,
and says why; if none works, the error says what to install (``gl_setup``).

Layout (one module per concern; every public name is importable from ``mjbench.render``): ``gl``
(OpenGL backend), ``scene`` (render model, bounds, camera), ``overlay`` (text box), ``view``
(a mechanism's side view), ``video`` (writers, frame times), ``platform`` (a rotary table's top
view), ``runs`` (videos of simulated runs).
"""
from __future__ import annotations

import importlib as _importlib

#: public name → submodule (imported on first use: ``import mjbench.render`` costs nothing until a
#: name is used, so the CLI's GL check does not import the renderer)
_WHERE = {
    **dict.fromkeys(("RenderError", "MUJOCO_GL_VALUES", "INSTALL_HINT", "check_gl_env", "gl_setup"), "gl"),
    **dict.fromkeys(("TRACE_PATH_RGBA", "TRACE_TRAIL_RGBA", "BACKDROP_RGB", "LINK_SCALE", "GRID_RGB", "point_bounds",
                     "build_render_model", "frame_camera"), "scene"),
    "TextBox": "overlay", "MechanismView": "view", "VideoWriter": "video", "frame_indices": "video",
    "PlatformView": "platform", "render_platform_laws": "platform",
    **dict.fromkeys(("simulate_for_video", "render_trajectory", "render_scenario"), "runs"),
}


_SUBMODULES = ("gl", "scene", "overlay", "view", "video", "platform", "runs")


def __getattr__(name):
    if name in _SUBMODULES:
        return _importlib.import_module(f"{__name__}.{name}")
    mod = _WHERE.get(name)
    if mod is None:
        raise AttributeError(f"module 'mjbench.render' has no attribute {name!r}")
    return getattr(_importlib.import_module(f"{__name__}.{mod}"), name)


__all__ = sorted(_WHERE)
