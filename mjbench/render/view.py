"""A mechanism's side view: the pose of every frame from the recorded input angle, the traced
point's path and trail, the overlay (:class:`MechanismView`)."""
from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError
from .gl import gl_setup
from .overlay import TextBox
from .scene import GRID_RGB, TRACE_PATH_RGBA, TRACE_TRAIL_RGBA, build_render_model, frame_camera, point_bounds


# ============================================================================ renderer
class MechanismView:
    """Renders a mechanism at given input angles, with its traced path and an overlay."""

    def __init__(self, mechanism, width=960, height=540, bounds_q=None, armature=0.0, options=None,
                 trail_turns=0.6, overlay_lines=4, path_q=None):
        """``path_q``: input values whose traced points are the static path (default: one turn of
        the input from the first of ``bounds_q``; a machine with several inputs: give them, (k, n))."""
        import mujoco

        gl_setup()
        if width < 16 or height < 16 or width % 2 or height % 2:
            raise ParameterError(f"--width/--height = {width}x{height}: need even sizes >= 16 px (H.264)")
        self.mech = mechanism
        self.width, self.height = int(width), int(height)
        n_in = int(getattr(mechanism, "n_inputs", 1) or 1)
        if bounds_q is None:
            bounds_q = np.linspace(0, 2 * np.pi, 361) if n_in == 1 else np.atleast_2d(mechanism.stated_inputs)
        q_b = np.asarray(bounds_q, float)
        self.bounds = point_bounds(mechanism, q_b)
        self.model, self.grid_step, _ = build_render_model(mechanism, armature, options, self.bounds,
                                                           self.width, self.height)
        self.data = mujoco.MjData(self.model)
        self.renderer = mujoco.Renderer(self.model, self.height, self.width, max_geom=4000)
        self.text = TextBox(self.width, self.height, overlay_lines, scale=self.height / 540)
        self.camera = frame_camera(self.bounds, self.width, self.height, float(self.model.vis.global_.fovy),
                                   top_band_px=self.text.band_px)
        self.opt = mujoco.MjvOption()
        self._line = int(mujoco.mjtGeom.mjGEOM_LINE)
        self._mjv_initGeom = mujoco.mjv_initGeom
        self._mjv_connector = mujoco.mjv_connector
        self._eye = np.eye(3).ravel()
        self._zero3 = np.zeros(3)
        px = self.height / 540.0  # line widths [px] scale with the frame
        # static lines: grid on the backdrop, trace path over one crank turn from the first angle
        segs = [self._grid_segments()]
        if path_q is None:
            path_q = np.linspace(q_b[0], q_b[0] + 2 * np.pi, 73) if n_in == 1 else q_b  # 5° per segment
        self.path = self._trace(path_q)
        gain = self._line_gain()
        self._static = []  # ((k, 2, 3) segments, width px, rgba)
        self._static.append((segs[0], 1.0 * px, self._line_rgba(GRID_RGB + (1.0,), gain)))
        if self.path is not None and len(self.path) > 1:
            self._static.append((np.stack([self.path[:-1], self.path[1:]], axis=1), 1.5 * px,
                                 self._line_rgba(TRACE_PATH_RGBA, gain)))
        self.trail_turns = float(trail_turns)
        self.trail_w = 3.5 * px
        self.trail_rgba = self._line_rgba(TRACE_TRAIL_RGBA, gain)

    @staticmethod
    def set_flags(scene):
        """Scene render flags: no shadow maps (they triple the frame time on llvmpipe with the
        full-frame backdrop) and no reflections."""
        import mujoco

        scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0

    @staticmethod
    def _line_rgba(rgba, gain):
        c = np.array(rgba, np.float32)
        c[:3] /= gain
        return c

    def _line_gain(self):
        """Brightness gain the scene lights give a line (lines are lit as if facing every light,
        ≈2× here): measured once on a test line so that traces show their nominal colour."""
        import mujoco

        self.data.qpos[:] = self.model.qpos0
        mujoco.mj_kinematics(self.model, self.data)
        self.renderer.update_scene(self.data, camera=self.camera, scene_option=self.opt)
        self.set_flags(self.renderer.scene)
        c = np.array(self.camera.lookat, dtype=float)
        hw = 2.0 * self.camera.distance
        ref = 0.2
        self._segments(np.array([[c - [hw, 0, 0], c + [hw, 0, 0]]]), 9.0,
                       np.array([ref, ref, ref, 1.0], np.float32))
        img = self.renderer.render()
        v = float(np.median(img[self.height // 2, :, :].mean(axis=1))) / 255.0  # robust to a link in the way
        return float(np.clip(v / ref, 1.0, 4.0)) if v < 0.99 else 4.0

    def _grid_segments(self):
        """Grid lines (k, 2, 3) every ``grid_step`` over the visible part of the backdrop."""
        cam = self.camera
        hh = 1.15 * cam.distance * math.tan(math.radians(float(self.model.vis.global_.fovy)) / 2)
        hw = hh * self.width / self.height
        cx, _, cz = cam.lookat
        s = self.grid_step
        yb = 0.2 * max(self.bounds[1] - self.bounds[0], self.bounds[3] - self.bounds[2])
        xs = np.arange(math.floor((cx - hw) / s), math.ceil((cx + hw) / s) + 1) * s
        zs = np.arange(math.floor((cz - hh) / s), math.ceil((cz + hh) / s) + 1) * s
        segs = [((x, yb, cz - hh), (x, yb, cz + hh)) for x in xs]
        segs += [((cx - hw, yb, z), (cx + hw, yb, z)) for z in zs]
        return np.asarray(segs, dtype=float)

    def _trace(self, q):
        try:
            p = self.mech.trace_point(np.asarray(q, dtype=float))
        except Exception:
            p = None
        if p is None:
            return None
        x, y = (np.asarray(c, float) for c in p)
        shape = np.broadcast_shapes(x.shape, y.shape) or np.shape(q)[:1]  # (k,) of k inputs, n each
        x, y = (np.broadcast_to(c, shape).ravel() for c in (x, y))
        pts = np.stack([x, np.zeros_like(x), y], axis=1)  # paper (x, y) → MuJoCo (x, z)
        return pts[np.all(np.isfinite(pts), axis=1)]

    def _add_static(self, scn):
        """Grid and full trace path.  ``update_scene`` rewrites only the first ``ngeom`` slots and
        the model's slot count is the same every frame, so the static lines are written once into
        the slots after the model's and re-enabled by raising ``ngeom`` (no per-frame cost)."""
        n0 = scn.ngeom
        if getattr(self, "_static_at", None) != n0:
            for segs, w, rgba in self._static:
                self._segments(segs, w, rgba)
            self._static_at, self._static_n = n0, scn.ngeom - n0
        else:
            scn.ngeom = n0 + self._static_n

    def _segments(self, segs, width, rgba):
        """Append line connectors segs (k, 2, 3) to the scene (mjGEOM_LINE: width in pixels;
        capsules would cost 4× the frame on llvmpipe)."""
        scn = self.renderer.scene
        n0 = scn.ngeom
        k = min(len(segs), scn.maxgeom - n0)
        init, conn, line, z3, eye = self._mjv_initGeom, self._mjv_connector, self._line, self._zero3, self._eye
        geoms = scn.geoms
        for i in range(k):
            g = geoms[n0 + i]
            init(g, line, z3, z3, eye, rgba)
            conn(g, line, width, segs[i, 0], segs[i, 1])
            g.emission = 1.0  # unlit: the line shows its own colour
        scn.ngeom = n0 + k

    def frame(self, q, lines=(), trail_q=None, out=None, qpos=None):
        """RGB frame (height, width, 3) uint8 at input angle q [rad]; ``trail_q``: input angles
        whose trace points form the highlighted trail; ``qpos``: the recorded pose (a mechanism whose
        pose is more than q: a cam's follower off the cam), else the assembled pose at q."""
        import mujoco

        m, d = self.model, self.data
        d.qpos[:] = qpos if qpos is not None else self.mech.initial_qpos(
            m, float(q) if np.ndim(q) == 0 else np.asarray(q, float))
        mujoco.mj_kinematics(m, d)
        if m.ntendon:  # springs drawn as spatial tendons: their paths come from mj_tendon
            mujoco.mj_tendon(m, d)
        self.renderer.update_scene(d, camera=self.camera, scene_option=self.opt)
        self.set_flags(self.renderer.scene)
        self._add_static(self.renderer.scene)
        if trail_q is not None and len(trail_q) > 1:
            pts = self._trace(trail_q)
            if pts is not None and len(pts) > 1:
                self._segments(np.stack([pts[:-1], pts[1:]], axis=1), self.trail_w, self.trail_rgba)
        img = self.renderer.render(out=out)
        if lines:
            self.text.draw(img, lines)
        return img

    def close(self):
        self.renderer.close()
