"""Videos from Python: :func:`render_video` (offscreen MuJoCo rendering of a multibody run)."""
from __future__ import annotations

import os
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..errors import MjbenchError, ParameterError
from .. import outputs
from ..preflight import simulation_errors
from .scenarios import as_scenario
from .simulation import seconds
from .. import render

if TYPE_CHECKING:
    from .scenarios import Scenario

#: largest frame [px]: 8K UHD, within H.264 level 6.2 and the 16384-px renderbuffer limit of the
#: usual OpenGL drivers (Mesa, NVIDIA)
MAX_WIDTH, MAX_HEIGHT = 7680, 4320
#: video file suffixes
SUFFIXES = (".mp4", ".gif")


def check_frame(width: int | None, height: int | None, option: str = "--width/--height") -> None:
    """Video frame size: even (H.264), 16 px to 8K (:data:`MAX_WIDTH` × :data:`MAX_HEIGHT`)."""
    if width is None or height is None:
        return
    if not (16 <= width <= MAX_WIDTH and 16 <= height <= MAX_HEIGHT) or width % 2 or height % 2:
        raise ParameterError(f"{option} = {width}x{height}: need even sizes from 16x16 to {MAX_WIDTH}x{MAX_HEIGHT} px "
                             f"(H.264 and the offscreen OpenGL framebuffer)")


def render_video(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any], path: str | os.PathLike[str], *,
                 mode: str | None = None, fps: float = 30.0, width: int = 960, height: int = 540,
                 t_end: float | str | None = None, crf: int = 23, progress: bool = False,
                 what: str = "path") -> dict[str, Any]:
    """Simulate a scenario on the multibody backend (every co-step recorded) and render a
    real-time video offscreen (EGL, OSMesa fallback): the mechanism, its traced point, an overlay
    with time, speed and voltage.

    Parameters
    ----------
    scenario : Scenario, str, path or dict
    path : str or path
        The video file: ``*.mp4`` (H.264) or ``*.gif``; written under a temporary name and renamed
        when complete (an existing file is replaced).
    mode : str, optional
        The mode to simulate (default: the scenario's).
    fps : float
        Frames per second [1/s] (real-time playback), up to 240.
    width, height : int
        Frame size [px], even, 16 to 7680 × 4320.
    t_end : float or str, optional
        Simulated (= video) duration [s] (default ``simulation.t_end``).
    crf : int
        H.264 quality 0–51 (lower: better, larger).
    progress : bool
        A progress bar of the frames.
    what : str
        How error messages name ``path`` (the CLI: ``--out``).

    Returns
    -------
    dict
        ``path``, ``frames``, ``width``, ``height``, ``fps``, ``duration_s`` (video), ``sim_s``
        (simulation), ``wall_s`` and ``frames_per_s`` (rendering + encoding), ``gl`` (backend).

    Raises
    ------
    mjbench.render.RenderError
        No offscreen OpenGL (the message says what to install).
    """

    outputs.check_out_file(path, what=what, suffixes=SUFFIXES)  # before any work
    check_frame(width, height)
    if not 0 < float(fps) <= 240:
        raise ParameterError(f"fps = {fps!r}: must be > 0 and <= 240 [1/s]")
    if not (isinstance(crf, int) and 0 <= crf <= 51):
        raise ParameterError(f"crf = {crf!r}: must be an integer 0 to 51")

    render.gl_setup()
    scn = as_scenario(scenario)
    spec: Any = scn.spec
    if scn.spec.modes:
        mode = scn.mode(mode)
        scn.check(mode)
    import mujoco

    with outputs.output_file(path, what=what, suffixes=SUFFIXES) as out, simulation_errors(scn.spec):
        try:
            info: dict[str, Any] = render.render_scenario(
                spec, out, mode=mode, fps=float(fps), width=width, height=height,
                t_end=None if t_end is None else seconds(t_end, "t_end"), progress=progress, crf=crf)
        except mujoco.FatalError as e:  # e.g. an offscreen framebuffer the OpenGL driver cannot make
            raise MjbenchError(f"--width/--height = {width}x{height}: OpenGL cannot render it ({e}); "
                               f"try a smaller frame") from None
    return info
