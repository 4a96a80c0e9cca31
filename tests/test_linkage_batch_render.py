"""The generic linkage through the engine's other paths unchanged: the batched backend (a load
written on the batch's state columns) and the offscreen video (tendon springs drawn)."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np

from mjbench import scenario as S
from mjbench.backends import batch, multibody
from mjbench.cli import main


def test_batch_equals_single_runs_with_a_point_load():
    """Press (forming load + counterbalance spring) at two armature resistances: the batch =
    single runs to round-off."""
    scn = S.load("press-slidercrank")
    machines = [S.make_machine(S.with_values(scn, {"drive.R": R}), "pi") for R in (0.25, 0.35)]
    T = 0.25
    res = batch.simulate(machines, T, record_dt=1e-3, nthread=2, options=scn.multibody_options())
    assert not res.diverged.any()
    for i, R in enumerate((0.25, 0.35)):
        single = multibody.simulate(S.make_machine(S.with_values(scn, {"drive.R": R}), "pi"), T, record_dt=1e-3,
                                    options=scn.multibody_options())
        d = np.max(np.abs(res.trajectory(i).data[:, :10] - single.data[:, :10]))
        assert d <= 1e-9 * np.max(np.abs(single.data[:, :10]))


def test_video_of_a_linkage(tmp_path):
    import imageio_ffmpeg

    out = tmp_path / "press.mp4"
    assert main(["render", "press-slidercrank", "--out", str(out), "--width", "320", "--height", "180",
                 "--t-end", "0.2", "--no-progress"]) == 0
    gen = imageio_ffmpeg.read_frames(str(out))
    meta = gen.__next__()
    frames = [np.frombuffer(f, np.uint8).reshape(180, 320, 3) for f in gen]
    assert meta["size"] == (320, 180) and len(frames) == 7
    assert all(f.std() > 5 for f in frames)          # not blank
    # the counterbalance spring (orange tendon) is drawn: orange-ish pixels present
    f = frames[-1].astype(int)
    orange = (f[..., 0] > 180) & (f[..., 1] > 90) & (f[..., 1] < 190) & (f[..., 2] < 90)
    assert orange.sum() > 20
