"""Video rendering: cost per frame of mjbench's renderer vs a bare mujoco.Renderer.render().

Both render the same model (the mechanism's MJCF plus the display-only backdrop) at the same
size (960x540), camera and scene flags (no shadows).  "bare" = ``update_scene(data) + render()`` with the pose already set;
"frame" = what ``mjbench render`` does per frame: pose from the crank angle (initial_qpos +
mj_kinematics), scene update, traced path / trail / grid lines, render, text overlay.  Encoding
(imageio-ffmpeg, H.264, separate process) is timed separately.  Blocks of the two loops alternate
and the best block is kept, so machine load affects both alike.  Goal: render_frame_ratio ≤ 1.3.
"""
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")


def run(args):
    import tempfile

    import mujoco
    import numpy as np

    from mjbench import render, scenario

    render.gl_setup(verbose=True)
    scn = scenario.load("incerti2012")
    machine = scenario.make_machine(scn, "pid")
    mech = machine.mechanism
    W, H, nblk, nfr = 960, 540, max(3, int(getattr(args, "repeat", 3))), 15
    q = np.linspace(0.0, 4 * np.pi, nblk * nfr)
    view = render.MechanismView(mech, W, H, bounds_q=q, armature=float(machine.drive.J_eq))
    lines = ["incerti2012 — mode pid (multibody)", "t =  0.500 s   (real time, 30 fps)",
             "crank speed   29.50 rad/s   motor   29.50 rad/s", "voltage   25.00 V   grid 100 mm"]
    bare = mujoco.Renderer(view.model, H, W)
    d = mujoco.MjData(view.model)
    d.qpos[:] = mech.initial_qpos(view.model, 0.3)
    mujoco.mj_kinematics(view.model, d)
    buf = np.empty((H, W, 3), np.uint8)
    # warm-up
    bare.update_scene(d, camera=view.camera)
    bare.render()
    view.frame(0.1, lines, trail_q=np.linspace(-3, 0.1, 60), out=buf)
    t_bare, t_ours = [], []
    for b in range(nblk):
        t0 = time.perf_counter()
        for _ in range(nfr):
            bare.update_scene(d, camera=view.camera)
            view.set_flags(bare.scene)  # same scene settings (no shadows)
            bare.render(out=buf)
        t_bare.append((time.perf_counter() - t0) / nfr)
        t0 = time.perf_counter()
        for k in range(nfr):
            qk = q[b * nfr + k]
            view.frame(qk, lines, trail_q=np.linspace(qk - 3.77, qk, 41), out=buf)
        t_ours.append((time.perf_counter() - t0) / nfr)
    # encoding cost: frames through the H.264 writer
    with tempfile.TemporaryDirectory() as tmp:
        w = render.VideoWriter(os.path.join(tmp, "b.mp4"), W, H, 30)
        t0 = time.perf_counter()
        for k in range(nfr * 2):
            w.write(view.frame(q[k], lines, trail_q=np.linspace(q[k] - 3.77, q[k], 41), out=buf))
        w.close()
        t_enc = (time.perf_counter() - t0) / (nfr * 2)
    bare.close()
    view.close()
    tb, to = min(t_bare), min(t_ours)
    return [
        ("render_frame_ratio", to / tb, f"mjbench frame / bare Renderer.render(), same model {W}x{H} (goal <= 1.3)"),
        ("render_bare_ms", 1e3 * tb, f"bare update_scene+render per frame [ms] ({render.gl_setup()})"),
        ("render_frame_ms", 1e3 * to, "mjbench frame (pose, scene, traces, render, overlay) [ms]"),
        ("render_encode_ratio", t_enc / tb, "frame incl. H.264 encoding (ffmpeg process) / bare render"),
        ("render_frames_per_s", 1.0 / t_enc, "video frames per second incl. encoding"),
    ]
