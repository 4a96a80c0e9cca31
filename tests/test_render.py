"""Offscreen video (issue 6): frame count and size, frames not blank and changing, GIF option."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from mjbench import render, scenario
from mjbench.cli import main

W, H, FPS, T_END = 320, 180, 30, 0.3  # 0.3 s at 30 fps → frames at k/30, k = 0..9


def _read_mp4(path):
    import imageio_ffmpeg

    gen = imageio_ffmpeg.read_frames(path)
    meta = gen.__next__()
    w, h = meta["size"]
    frames = [np.frombuffer(f, np.uint8).reshape(h, w, 3) for f in gen]
    return meta, frames


@pytest.fixture(scope="module")
def mp4(tmp_path_factory):
    out = tmp_path_factory.mktemp("render") / "pid.mp4"
    rc = main(["render", "incerti2012", "--out", str(out), "--fps", str(FPS), "--width", str(W),
               "--height", str(H), "--t-end", str(T_END), "--mode", "pid", "--no-progress"])
    assert rc == 0
    return out


def test_frame_count_and_size(mp4):
    meta, frames = _read_mp4(str(mp4))
    assert meta["size"] == (W, H)
    assert meta["fps"] == pytest.approx(FPS, rel=1e-3)
    assert len(frames) == int(np.floor(T_END * FPS + 1e-9)) + 1 == 10
    assert all(f.shape == (H, W, 3) for f in frames)


def test_frames_not_blank_and_changing(mp4):
    _, frames = _read_mp4(str(mp4))
    for f in frames:
        # backdrop, links, overlay text: a real picture has many distinct levels and contrast
        assert f.std() > 10.0
        assert len(np.unique(f[::4, ::4].reshape(-1, 3), axis=0)) > 30
    # the crank turns ≈ 1 rad per frame at speed: consecutive frames differ visibly
    diffs = [np.abs(a.astype(int) - b.astype(int)).mean() for a, b in zip(frames[3:], frames[4:])]
    assert min(diffs) > 0.3
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).max() > 100


def test_frame_times_real_time():
    t = np.arange(0, 20001) * 1e-4  # recorded every 0.1 ms step
    idx = render.frame_indices(t, 30.0, 1.0)
    assert len(idx) == 31
    assert np.max(np.abs(t[idx] - np.arange(31) / 30.0)) <= 0.5e-4 + 1e-12


def test_gif_option(tmp_path):
    import imageio.v3 as iio

    scn = scenario.load("incerti2012")
    out = tmp_path / "open.gif"
    info = render.render_scenario(scn, out, mode="open", fps=10, width=160, height=90, t_end=0.3,
                                  progress=False)
    frames = iio.imread(out, index=None)
    assert info["frames"] == 4 and len(frames) == 4
    assert frames.shape[1:3] == (90, 160)
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".tmp-")]  # atomic write


def test_bad_size_is_parameter_error(tmp_path):
    from mjbench.errors import ParameterError

    scn = scenario.load("incerti2012")
    with pytest.raises(ParameterError, match="width/--height"):
        render.render_scenario(scn, tmp_path / "x.mp4", fps=10, width=161, height=90, t_end=0.1,
                               progress=False)


def test_platform_video(tmp_path):
    """Seeds 001/003 motion-law cases: the platform under a law, frames change (needle, disc)."""
    import imageio_ffmpeg  # noqa: F401

    scn = scenario.load("incerti-bezier")
    plat = scenario.make_mechanism(scn)
    law = scn.law.build()
    out = tmp_path / "plat.mp4"
    info = render.render_platform_laws(plat, {"initial": law}, out, t_after=0.2, fps=10, width=160, height=90,
                                       progress=False)
    _, frames = _read_mp4(str(out))
    n = int(np.floor((law.T + 0.2) * 10 + 1e-9)) + 1
    assert info["frames"] == len(frames) == n
    assert frames[0].shape == (90, 160, 3) and min(f.std() for f in frames) > 10.0
    assert np.abs(frames[0].astype(int) - frames[n // 2].astype(int)).max() > 100


def test_render_view_comes_from_the_mechanism_class():
    """The video's view is declared by the mechanism (Mechanism.render_view): a linkage is seen from
    the side; a platform from the top, naming its output hinge and body (present in its MJCF), the
    ratio and the recorded deflection coordinate; a drive-train wrapper shows its inner mechanism."""
    import math

    from mjbench.drivetrain import Gear
    from mjbench.drivetrain.gear import DrivenMechanism

    assert scenario.make_mechanism(scenario.load("incerti2012")).render_view().kind == "side"
    scn = scenario.load("incerti-bezier")
    plat = scenario.make_mechanism(scn)
    rv = plat.render_view()
    assert rv.kind == "top" and rv.ratio == plat.ratio and rv.deflection in plat.internal
    m = plat.build_spec().compile()
    assert m.joint(rv.output_joint).id >= 0 and m.body(rv.output_body).id >= 0
    wrapped = DrivenMechanism(plat, scenario.make_drive(scn), Gear(backlash=math.radians(0.1)))
    assert wrapped.render_view() == rv and wrapped.internal == (rv.deflection, "gear_deflection")
    from mjbench.errors import ParameterError

    with pytest.raises(ParameterError, match="not a top view"):
        render.PlatformView(scenario.make_mechanism(scenario.load("incerti2012")))
