"""The top view of a rotary table (the elastic platforms): the rigid and the deflected needles,
and the comparison video of motion laws."""
from __future__ import annotations

import math
import time

import numpy as np

from ..errors import ParameterError
from .gl import gl_setup
from .overlay import TextBox
from .scene import BACKDROP_RGB, frame_camera
from .video import VideoWriter, _frame_bar, _video_info, frame_indices
from .view import MechanismView
from ..vibration import simulate_multibody


# ============================================================================ platforms (seeds 001/003)
class PlatformView:
    """Top view of a rotary table (a mechanism whose :meth:`~mjbench.mechanisms.base.Mechanism.render_view`
    is ``"top"``: the elastic platforms of ``mechanisms/platform.py``) driven by a motion law.

    The view names the table's hinge and body, the ratio ρ and the deflection coordinate ψ.  The
    residual vibration is a deflection of milliradians, invisible at true scale, so two needles are
    drawn from the table's centre: grey at the rigid-transmission angle ρ·φ and magenta at
    ρ·φ + G·ψ (G printed in the overlay, chosen so that the largest |ψ| of the reference run maps
    to 30°)."""

    def __init__(self, platform, width=960, height=540, gain=1.0):
        import mujoco

        gl_setup()
        if width < 16 or height < 16 or width % 2 or height % 2:
            raise ParameterError(f"--width/--height = {width}x{height}: need even sizes >= 16 px (H.264)")
        self.plat, self.width, self.height, self.gain = platform, int(width), int(height), float(gain)
        self.rv = rv = platform.render_view()
        if rv.kind != "top":
            raise ParameterError(f"{platform.type_name}: its render view is {rv.kind!r}, not a top view")
        spec = platform.build_spec(options={"timestep": 1e-4})
        g = spec.visual.global_
        g.offwidth, g.offheight = max(int(g.offwidth), self.width), max(int(g.offheight), self.height)
        spec.visual.quality.offsamples = 4
        m = spec.compile()
        # bounds of the discs (cylinders about z) in the x-y plane
        d0 = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d0)
        xs, ys = [], []
        for i in range(m.ngeom):
            r = float(m.geom_rbound[i])
            p = d0.geom_xpos[i]
            xs += [p[0] - r, p[0] + r]
            ys += [p[1] - r, p[1] + r]
        span = max(max(xs) - min(xs), max(ys) - min(ys))
        half = 3 * span
        spec2 = platform.build_spec(options={"timestep": 1e-4})
        spec2.visual.global_.offwidth, spec2.visual.global_.offheight = g.offwidth, g.offheight
        spec2.visual.quality.offsamples = 4
        cz = min(float(d0.geom_xpos[i][2] - m.geom_size[i][1]) for i in range(m.ngeom)) - 0.05 * span
        spec2.worldbody.add_geom(name="mjb_backdrop", type=mujoco.mjtGeom.mjGEOM_BOX,
                                 size=[half, half, 1e-3 * span], pos=[0.5 * (min(xs) + max(xs)), 0.5 * (min(ys) + max(ys)), cz],
                                 rgba=list(BACKDROP_RGB) + [1.0], contype=0, conaffinity=0)
        self.model = m = spec2.compile()
        m.vis.headlight.ambient[:] = 0.45
        m.vis.headlight.diffuse[:] = 0.55
        self.data = mujoco.MjData(m)
        self.renderer = mujoco.Renderer(m, self.height, self.width, max_geom=2000)
        self.text = TextBox(self.width, self.height, 4, scale=self.height / 540)
        bounds = (min(xs), max(xs), min(ys), max(ys))
        # top view: camera above looking down −z; x right, y up
        cam = frame_camera(bounds, self.width, self.height, float(m.vis.global_.fovy), top_band_px=self.text.band_px)
        cam.elevation = -90.0
        cam.lookat[:] = [cam.lookat[0], cam.lookat[2], float(d0.geom_xpos[0][2])]
        self.camera = cam
        self.opt = mujoco.MjvOption()
        self._line = int(mujoco.mjtGeom.mjGEOM_LINE)
        self._qa = int(m.joint(platform.input_joint).qposadr[0])
        self._plat = int(m.joint(rv.output_joint).qposadr[0])
        self._pbody = m.body(rv.output_body).id
        self._needle = 0.9 * float(max(m.geom_rbound[i] for i in range(m.ngeom) if m.geom_bodyid[i] == self._pbody
                                       and m.geom_type[i] == mujoco.mjtGeom.mjGEOM_CYLINDER))
        mujoco.mj_kinematics(m, self.data)
        top = [float(self.data.geom_xpos[i][2] + (m.geom_size[i][2] if m.geom_type[i] == mujoco.mjtGeom.mjGEOM_BOX
                                             else m.geom_size[i][1]))
               for i in range(m.ngeom) if m.geom_bodyid[i] == self._pbody]
        self._top = max(top) + 0.02 * self._needle
        self.grey = np.array([0.25, 0.25, 0.25, 1.0], np.float32)  # lines are lit ≈2× (see MechanismView)
        self.magenta = np.array([0.5, 0.0, 0.45, 1.0], np.float32)

    def frame(self, phi, theta, psi, lines=(), out=None):
        import mujoco

        m, d = self.model, self.data
        rho = float(self.rv.ratio)
        d.qpos[:] = m.qpos0
        d.qpos[self._qa] = phi
        d.qpos[self._plat] = theta
        mujoco.mj_kinematics(m, d)
        self.renderer.update_scene(d, camera=self.camera, scene_option=self.opt)
        MechanismView.set_flags(self.renderer.scene)
        c = np.array(d.xpos[self._pbody], dtype=float)
        c[2] = self._top  # just above the platform's top face
        scn = self.renderer.scene
        for ang, rgba, w in ((rho * phi, self.grey, 4.0), (rho * phi + self.gain * psi, self.magenta, 6.0)):
            if scn.ngeom >= scn.maxgeom:
                break
            g = scn.geoms[scn.ngeom]
            tip = c + self._needle * np.array([math.cos(ang), math.sin(ang), 0.0])
            mujoco.mjv_initGeom(g, self._line, np.zeros(3), np.zeros(3), np.eye(3).ravel(), rgba)
            mujoco.mjv_connector(g, self._line, w * self.height / 540, c, tip)
            scn.ngeom += 1
        img = self.renderer.render(out=out)
        if lines:
            self.text.draw(img, lines)
        return img

    def close(self):
        self.renderer.close()


def _render_platform_run(machine, traj, out, fps, width, height, title, progress, t_end, crf):
    """Video of a platform machine run (motor + servo): top view with the deflection needle."""
    plat = machine.mechanism
    rv = plat.render_view()
    idx = frame_indices(traj.t, fps, t_end)
    t, q, qd = traj.t, traj.q, traj.qd
    psi = traj[f"{rv.deflection}_rad"]
    psimax = float(np.max(np.abs(psi[idx]))) if len(idx) else 0.0
    gain = float(f"{math.radians(30.0) / psimax:.2g}") if psimax > 0 else 1.0
    t0 = time.perf_counter()
    view = PlatformView(plat, width, height, gain=gain)
    rho = float(rv.ratio)
    try:
        with VideoWriter(out, width, height, fps, crf=crf) as writer, _frame_bar(len(idx), out, progress) as bar:
            buf = np.empty((view.height, view.width, 3), np.uint8)
            for i in idx:
                lines = [title or rv.label,
                         f"t = {t[i]:6.3f} s   (real time, {fps:g} fps)",
                         f"motor speed {qd[i]:8.2f} rad/s   voltage {traj.voltage[i]:7.1f} V",
                         f"deflection ψ {1e3 * psi[i]:+8.3f} mrad   needle ×{gain:g}"]
                writer.write(view.frame(q[i], rho * q[i] + psi[i], psi[i], lines, out=buf))
                bar.update(1)
    finally:
        view.close()
    return _video_info(len(idx), fps, width, height, t0, out, needle_gain=gain)


def render_platform_laws(platform, laws: dict, out, t_after=0.5, fps=30.0, width=960, height=540,
                         progress=True, dt=1e-4):
    """Video of the platform driven by each law in turn (``laws`` = {name: MotionLaw}), each run
    simulated by ``vibration.simulate_multibody`` (step ``dt``, every step recorded) over
    [0, T + t_after] and played in real time.  Returns an info dict."""


    t0 = time.perf_counter()
    runs = {k: simulate_multibody(platform, law, t_end=law.T + t_after, dt=dt) for k, law in laws.items()}
    psimax = max(float(np.max(np.abs(r["psi"]))) for r in runs.values())
    gain = math.radians(30.0) / psimax if psimax > 0 else 1.0
    gain = float(f"{gain:.2g}")  # a round number for the overlay
    view = PlatformView(platform, width, height, gain=gain)
    nfr = 0
    total = sum(len(frame_indices(r["t"], fps)) for r in runs.values())
    try:
        with VideoWriter(out, width, height, fps) as writer, _frame_bar(total, out, progress) as bar:
            buf = np.empty((view.height, view.width, 3), np.uint8)
            for name, r in runs.items():
                idx = frame_indices(r["t"], fps)
                for i in idx:
                    lines = [f"{view.rv.label} — {name} law, T = {laws[name].T:g} s",
                             f"t = {r['t'][i]:6.3f} s   (real time, {fps:g} fps)",
                             f"motor speed {r['motor_speed'][i]:8.2f} rad/s",
                             f"deflection ψ {1e3 * r['psi'][i]:+8.3f} mrad   needle ×{gain:g}"]
                    writer.write(view.frame(r["motor_angle"][i], r["platform_angle"][i], r["psi"][i], lines, out=buf))
                    nfr += 1
                    bar.update(1)
    finally:
        view.close()
    return _video_info(nfr, fps, width, height, t0, out, needle_gain=gain)
