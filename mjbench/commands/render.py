"""``mjbench render SCENARIO --out FILE.mp4``: offscreen video of a multibody run (issue 6)."""
from __future__ import annotations

import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco's renderer

from . import MAX_HEIGHT, MAX_WIDTH, check_frame, cli_command, integer, quantity  # noqa: E402
from .. import api, outputs, render


def register(sub):
    p = sub.add_parser("render", help="offscreen video (MP4/GIF) of a scenario's multibody run",
                       description="Simulate the scenario with the multibody backend (every 0.1 ms step "
                                   "recorded) and render a real-time video offscreen (MUJOCO_GL=egl, "
                                   "OSMesa fallback).  The coupler-point path / slider stroke is traced; "
                                   "an overlay shows time, crank speed and voltage.")
    p.add_argument("scenario", help="built-in scenario name or TOML file")
    p.add_argument("--out", required=True, help="output video: *.mp4 (H.264) or *.gif")
    p.add_argument("--mode", default=None, help="scenario mode (default: simulation.mode)")
    p.add_argument("--fps", type=quantity("frequency", gt=0.0, le=240.0), default=30.0,
                   help="frames per second (real-time playback) [1/s], up to 240")
    p.add_argument("--width", type=integer(ge=16, le=MAX_WIDTH), default=960, help=f"frame width [px] (even, 16-{MAX_WIDTH})")
    p.add_argument("--height", type=integer(ge=16, le=MAX_HEIGHT), default=540,
                   help=f"frame height [px] (even, 16-{MAX_HEIGHT})")
    p.add_argument("--t-end", type=quantity("time", gt=0.0), default=None, help="simulated (= video) duration [s]")
    p.add_argument("--crf", type=integer(ge=0, le=51), default=23, help="H.264 quality 0-51 (lower = better, larger file)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value (repeatable), e.g. --set drive.R=2.5")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run, gl=True)


@cli_command
def run(args) -> int:
    """``mjbench render`` = ``mjbench.render_video`` (docs/api.md)."""

    outputs.check_out_file(args.out, suffixes=(".mp4", ".gif"))  # before any work
    check_frame(args.width, args.height)
    render.gl_setup()
    outputs.route_mujoco_log()
    scn = api.load(args.scenario, args.set)
    info = api.render_video(scn, args.out, mode=args.mode, fps=args.fps, width=args.width, height=args.height,
                            t_end=args.t_end, crf=args.crf, progress=not args.no_progress and sys.stderr.isatty(), what="--out")
    print(f"wrote {info['path']}: {info['frames']} frames {info['width']}x{info['height']} at {info['fps']:g} fps "
          f"({info['duration_s']:.2f} s video); simulation {info['sim_s']:.2f} s, rendering+encoding "
          f"{info['wall_s']:.1f} s ({info['frames_per_s']:.1f} frames/s, OpenGL: {info['gl']})")
    return 0
