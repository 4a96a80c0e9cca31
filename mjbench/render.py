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
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from .errors import MjbenchError, ParameterError  # noqa: E402

_GL_CHOICE = None  # cached result of gl_setup()

# colours (RGBA 0..1) of the display-only items
TRACE_PATH_RGBA = (0.35, 0.35, 0.40, 1.0)
TRACE_TRAIL_RGBA = (0.95, 0.35, 0.0, 1.0)
BACKDROP_RGB = (0.96, 0.96, 0.94)
LINK_SCALE = 1.8  #: display thickness factor of link capsules, pins and sites
GRID_RGB = (0.80, 0.81, 0.84)


class RenderError(MjbenchError):
    """Offscreen rendering is not possible (no OpenGL backend, encoder failure)."""


# ============================================================================ OpenGL backend
def _probe(backend: str, timeout: float = 60.0):
    """Try to create a tiny offscreen context with ``backend`` in a fresh interpreter.
    Returns (ok, message)."""
    code = ("import mujoco; c = mujoco.GLContext(16, 16); c.make_current(); "
            "m = mujoco.MjModel.from_xml_string('<mujoco/>'); "
            "r = mujoco.Renderer(m, 16, 16); r.render(); print('ok')")
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                           timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as e:
        return False, str(e)
    if p.returncode == 0 and "ok" in p.stdout:
        return True, ""
    tail = (p.stderr or p.stdout).strip().splitlines()
    return False, tail[-1] if tail else f"exit code {p.returncode}"


#: MUJOCO_GL values MuJoCo accepts on Linux (anything else makes ``import mujoco`` fail)
MUJOCO_GL_VALUES = ("egl", "osmesa", "glfw", "glx", "", "enable", "enabled", "on", "true", "1",
                    "disable", "disabled", "off", "false", "0")
_GL_ERROR = None  # cached RenderError of a failed gl_setup()
INSTALL_HINT = ("On Debian/Ubuntu install EGL (sudo apt-get install libegl1 libgl1-mesa-dri) or OSMesa "
                "(sudo apt-get install libosmesa6); scripts/ci_system_deps.sh installs them")


def check_gl_env(verbose: bool = True):
    """Called by the CLI before MuJoCo is imported: a MUJOCO_GL value MuJoCo rejects at import
    (a typo) is replaced by ``egl`` with a warning, so that no command dies on it."""
    v = os.environ.get("MUJOCO_GL")
    if v is None or v.strip().lower() in MUJOCO_GL_VALUES or "mujoco" in sys.modules:
        return
    if verbose:
        print(f"mjbench: warning: MUJOCO_GL={v!r} is not a MuJoCo OpenGL backend (egl, osmesa, glfw); "
              f"using egl", file=sys.stderr)
    os.environ["MUJOCO_GL"] = "egl"


def gl_setup(verbose: bool = True) -> str:
    """Choose the offscreen OpenGL backend before MuJoCo's renderer is created.

    ``MUJOCO_GL`` (default ``egl``; ``osmesa`` and ``glfw`` are honoured too) is probed in a subprocess; if
    it fails, EGL then OSMesa are tried, with a message on stderr naming the fallback.  If none
    works, :class:`RenderError` says what to install.  Returns the backend name."""
    global _GL_CHOICE, _GL_ERROR
    if _GL_CHOICE is not None:
        return _GL_CHOICE
    if _GL_ERROR is not None:
        raise _GL_ERROR
    want = os.environ.get("MUJOCO_GL", "egl").strip().lower()
    if want not in ("egl", "osmesa", "glfw"):
        want = "egl"
    failed = []
    for backend in [want] + [b for b in ("egl", "osmesa") if b != want]:
        ok, msg = _probe(backend)
        if ok:
            break
        failed.append(f"{backend}: {msg}")
    else:
        _GL_ERROR = RenderError(f"no offscreen OpenGL ({'; '.join(failed)}). {INSTALL_HINT}.")
        if "mujoco" not in sys.modules:
            os.environ["MUJOCO_GL"] = "disable"  # simulations still run; only videos are impossible
        raise _GL_ERROR
    choice = backend
    if choice != want and verbose:
        print(f"mjbench render: MUJOCO_GL={want} is not available ({failed[0].split(': ', 1)[1]}); "
              f"falling back to {choice}" + (" (software, slower; install libegl1 libgl1-mesa-dri for EGL)"
                                             if choice == "osmesa" else ""), file=sys.stderr)
    os.environ["MUJOCO_GL"] = choice
    if "mujoco" in sys.modules:
        # MuJoCo was imported before us: make its Renderer use the chosen context class
        # (works as long as PyOpenGL has not been initialised for another platform).
        import importlib

        from mujoco.rendering.classic import gl_context, renderer
        cur = getattr(gl_context, "_MUJOCO_GL", "")
        if cur != choice:
            os.environ["PYOPENGL_PLATFORM"] = choice
            cls = importlib.import_module(f"mujoco.{choice}").GLContext
            gl_context.GLContext = cls
            renderer.gl_context.GLContext = cls
    _GL_CHOICE = choice
    return choice


# ============================================================================ model + camera
def _nice_step(span: float) -> float:
    """A 1-2-5 grid spacing giving about 8 cells over ``span`` [m]."""
    raw = max(span, 1e-6) / 8.0
    e = 10 ** math.floor(math.log10(raw))
    for f in (1, 2, 5, 10):
        if f * e >= raw:
            return f * e
    return 10 * e


def point_bounds(mechanism, q) -> tuple:
    """(xmin, xmax, ymin, ymax) [m] of every named point of ``mechanism`` over angles ``q``."""
    pts = mechanism.points(np.asarray(q, dtype=float))
    xs, ys = [], []
    for x, y in pts.values():
        xs.append(np.ravel(np.asarray(x, dtype=float)))
        ys.append(np.ravel(np.asarray(y, dtype=float)))
    xs, ys = np.concatenate(xs), np.concatenate(ys)
    ok = np.isfinite(xs) & np.isfinite(ys)
    if not ok.any():
        raise RenderError("mechanism.points() returned no finite point: cannot frame the camera")
    return float(xs[ok].min()), float(xs[ok].max()), float(ys[ok].min()), float(ys[ok].max())


def build_render_model(mechanism, armature: float, options: dict | None, bounds, width, height):
    """Compile the mechanism's MJCF plus display-only items: backdrop with grid, sky, offscreen
    buffer ≥ the frame size.  Returns (model, grid_step_m)."""
    import mujoco

    spec = mechanism.build_spec(armature=armature, options=options)
    g = spec.visual.global_
    g.offwidth = max(int(g.offwidth), int(width))
    g.offheight = max(int(g.offheight), int(height))
    spec.visual.quality.offsamples = 4
    # thicker links / pins than the simulation model's (display only; inertias are explicit)
    for geom in spec.geoms:
        if geom.type in (mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER,
                         mujoco.mjtGeom.mjGEOM_SPHERE):
            geom.size[0] *= LINK_SCALE
    for site in spec.sites:
        site.size[0] *= LINK_SCALE
    _coupler_plate(spec)
    xmin, xmax, ymin, ymax = bounds
    span = max(xmax - xmin, ymax - ymin, 1e-3)
    step = _nice_step(span)
    cx, cy = 0.5 * (xmin + xmax), 0.5 * (ymin + ymax)
    # flat light backdrop behind the plane (a textured plane or a skybox costs 2-4× the frame
    # time on llvmpipe; the grid is drawn as scene lines instead, see MechanismView)
    half = 3.0 * span
    spec.worldbody.add_geom(name="mjb_backdrop", type=mujoco.mjtGeom.mjGEOM_BOX,
                            size=[half, 1e-3 * span, half], pos=[cx, 0.25 * span, cy],
                            rgba=list(BACKDROP_RGB) + [1.0], contype=0, conaffinity=0, group=0)
    model = spec.compile()
    model.vis.headlight.ambient[:] = 0.45
    model.vis.headlight.diffuse[:] = 0.55
    model.vis.headlight.specular[:] = 0.1
    return model, step, (cx, cy)


def _coupler_plate(spec):
    """If the traced point is a site ``coupler_point`` off the coupler line (four-bar with a
    triangular coupler, seed 002), draw the rigid coupler triangle B-P-C with two thin, massless,
    collision-free capsules in the coupler's colour (display only)."""
    import mujoco

    try:
        site = spec.site("coupler_point")
    except Exception:
        return
    if site is None:
        return
    body = site.parent
    p = np.array(site.pos, dtype=float)
    link = next((g for g in body.geoms if g.type == mujoco.mjtGeom.mjGEOM_CAPSULE), None)
    if link is None:
        return
    ft = np.array(link.fromto, dtype=float)
    a, b = ft[:3], ft[3:]
    ab = b - a
    L = float(np.linalg.norm(ab))
    if L <= 0:
        return
    off = np.linalg.norm(np.cross(ab, p - a)) / L
    if off < 0.05 * L:  # on the link line: nothing to add
        return
    rgba = list(link.rgba)
    rgba[3] = 0.85
    for end in (a, b):
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[*end, *p], size=[0.6 * link.size[0], 0, 0],
                      rgba=rgba, contype=0, conaffinity=0, mass=0, group=0)


def frame_camera(bounds, width, height, fovy_deg, margin=0.12, top_band_px=0):
    """Free camera looking along +y at the bounds (x right, paper y = MuJoCo z up).

    The distance fits the padded bounding box into the frame for the vertical field of view
    ``fovy_deg``; ``top_band_px`` rows at the top are kept free for the text overlay."""
    import mujoco

    xmin, xmax, ymin, ymax = bounds
    w = max(xmax - xmin, 1e-3) * (1 + 2 * margin)
    h = max(ymax - ymin, 1e-3) * (1 + 2 * margin)
    usable = max(height - top_band_px, height // 2)
    # world height shown = h · height/usable; centre shifted up by the band
    h_world = max(h * height / usable, w * height / width)
    t = math.tan(math.radians(fovy_deg) / 2)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.azimuth = 90.0
    cam.elevation = 0.0
    cam.distance = 0.5 * h_world / t
    shift = 0.5 * h_world * (height - usable) / height  # lift the view centre by half the band
    cam.lookat[:] = [0.5 * (xmin + xmax), 0.0, 0.5 * (ymin + ymax) + shift]
    return cam


# ============================================================================ overlay
_FONTS = {}


def _font(size: int):
    from PIL import ImageFont
    if size not in _FONTS:
        try:
            from matplotlib import font_manager
            path = font_manager.findfont("DejaVu Sans Mono", fallback_to_default=True)
            _FONTS[size] = ImageFont.truetype(path, size)
        except Exception:  # pragma: no cover - no usable TrueType font
            _FONTS[size] = ImageFont.load_default()
    return _FONTS[size]


class TextBox:
    """Text in a fixed top-left panel of a frame.  The font is monospaced (DejaVu Sans Mono), so
    every character is rendered once by Pillow into an alpha mask and cached; a line is then the
    concatenation of its characters' masks, blended with NumPy (≈10× cheaper than drawing with
    Pillow on every frame)."""

    COLOR = np.array([20, 20, 30], np.float32)

    def __init__(self, width, height, nlines, scale=1.0):
        self.size = max(11, int(round(18 * scale)))
        self.pad = max(4, self.size // 3)
        self.line_h = int(self.size * 1.3)
        font = _font(self.size)
        try:
            self.adv = max(1, int(round(font.getlength("M"))))
        except AttributeError:  # pragma: no cover - bitmap default font
            self.adv = max(1, int(self.size * 0.62))
        self.w = min(width - 4, self.adv * 47 + 2 * self.pad)
        self.h = min(height - 4, nlines * self.line_h + 2 * self.pad)
        self.x0 = self.y0 = max(2, self.size // 2)
        self._glyphs = {}

    @property
    def band_px(self):
        return self.y0 + self.h

    def _glyph(self, ch):
        g = self._glyphs.get(ch)
        if g is None:
            from PIL import Image, ImageDraw
            img = Image.new("L", (self.adv, self.line_h), 0)
            ImageDraw.Draw(img).text((0, 0), ch, fill=255, font=_font(self.size))
            g = self._glyphs[ch] = np.asarray(img, dtype=np.float32) / 255.0
        return g

    def draw(self, frame, lines):
        y0, x0, h, w = self.y0, self.x0, self.h, self.w
        crop = frame[y0:y0 + h, x0:x0 + w]
        crop[:] = (crop.astype(np.uint16) * 3 // 10 + 178).astype(np.uint8)  # translucent white panel
        maxc = (w - 2 * self.pad) // self.adv
        for i, line in enumerate(lines):
            line = line[:maxc]
            if not line:
                continue
            a = np.hstack([self._glyph(c) for c in line])[..., None]
            top = self.pad + i * self.line_h
            reg = crop[top:top + a.shape[0], self.pad:self.pad + a.shape[1]]
            a = a[: reg.shape[0], : reg.shape[1]]
            reg[:] = (reg - (reg - self.COLOR) * a).astype(np.uint8)
        return frame


# ============================================================================ renderer
class MechanismView:
    """Renders a mechanism at given input angles, with its traced path and an overlay."""

    def __init__(self, mechanism, width=960, height=540, bounds_q=None, armature=0.0, options=None,
                 trail_turns=0.6, overlay_lines=4):
        import mujoco

        gl_setup()
        if width < 16 or height < 16 or width % 2 or height % 2:
            raise ParameterError(f"--width/--height = {width}x{height}: need even sizes >= 16 px (H.264)")
        self.mech = mechanism
        self.width, self.height = int(width), int(height)
        q_b = np.asarray(bounds_q if bounds_q is not None else np.linspace(0, 2 * np.pi, 361), float)
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
        self.path = self._trace(np.linspace(q_b[0], q_b[0] + 2 * np.pi, 73))  # 5° per segment
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
        x, y = (np.broadcast_to(np.asarray(c, float), np.shape(q)) for c in p)
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

    def frame(self, q, lines=(), trail_q=None, out=None):
        """RGB frame (height, width, 3) uint8 at input angle q [rad]; ``trail_q``: input angles
        whose trace points form the highlighted trail."""
        import mujoco

        m, d = self.model, self.data
        d.qpos[:] = self.mech.initial_qpos(m, float(q))
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


# ============================================================================ writers
def _frame_bar(total, out, progress):
    from tqdm import tqdm
    return tqdm(total=total, unit="frame", desc=f"render {os.path.basename(os.fspath(out))}",
                disable=not progress, leave=False)


def _video_info(nframes, fps, width, height, t0, out, **extra):
    """Numbers describing a written video (frames, seconds, throughput)."""
    wall = time.perf_counter() - t0
    return {"frames": nframes, "width": width, "height": height, "fps": fps, "duration_s": nframes / fps,
            "wall_s": wall, "frames_per_s": nframes / wall if wall > 0 else float("nan"), "gl": _GL_CHOICE,
            "path": os.fspath(out), **extra}


def _check_mp4(tmp, path):
    """Refuse an incomplete MP4 (ffmpeg could not write it whole, e.g. the disk is full): its
    top-level boxes must tile the file and hold ``ftyp``, ``moov`` (the index) and ``mdat``."""
    import errno
    import struct

    size = os.path.getsize(tmp)
    kinds, pos = set(), 0
    with open(tmp, "rb") as f:
        while pos < size:
            f.seek(pos)
            head = f.read(16)
            if len(head) < 8:
                break
            n, kind = struct.unpack(">I4s", head[:8])
            if n == 1 and len(head) == 16:
                n = struct.unpack(">Q", head[8:16])[0]
            elif n == 0:
                n = size - pos
            if n < 8 or pos + n > size:
                break
            kinds.add(kind)
            pos += n
    if pos != size or not {b"ftyp", b"moov", b"mdat"} <= kinds:
        st = os.statvfs(os.path.dirname(os.path.abspath(tmp)))
        if st.f_bavail * st.f_frsize < 1 << 20:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), path)
        raise RenderError(f"--out {path}: ffmpeg did not write a complete MP4 ({size} bytes, boxes "
                          f"{sorted(k.decode('latin-1') for k in kinds)}); the video was not saved")


class VideoWriter:
    """MP4 (H.264 via imageio-ffmpeg's bundled ffmpeg) or GIF (Pillow), written atomically."""

    def __init__(self, path, width, height, fps, crf=23):
        self.path = os.fspath(path)
        self.ext = os.path.splitext(self.path)[1].lower()
        if self.ext not in (".mp4", ".gif"):
            raise ParameterError(f"--out {self.path!r}: the video file must end in .mp4 or .gif")
        folder = os.path.dirname(os.path.abspath(self.path))
        os.makedirs(folder, exist_ok=True)
        fd, self.tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=self.ext)
        os.close(fd)
        self.fps, self.n = float(fps), 0
        self._frames = []
        if self.ext == ".mp4":
            import imageio_ffmpeg
            self._gen = imageio_ffmpeg.write_frames(
                self.tmp, (int(width), int(height)), fps=self.fps, codec="libx264", quality=None,
                pix_fmt_in="rgb24", pix_fmt_out="yuv420p", macro_block_size=2,
                ffmpeg_log_level="error",
                output_params=["-preset", "veryfast", "-crf", str(int(crf)), "-movflags", "+faststart"])
            self._gen.send(None)

    def write(self, frame):
        if self.ext == ".mp4":
            self._gen.send(np.ascontiguousarray(frame))
        else:
            self._frames.append(frame.copy())
        self.n += 1

    def close(self):
        try:
            if self.ext == ".mp4":
                self._gen.close()
            else:
                from PIL import Image
                imgs = [Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE, colors=128)
                        for f in self._frames]
                if not imgs:
                    raise RenderError("no frame to write")
                imgs[0].save(self.tmp, format="GIF", save_all=True, append_images=imgs[1:],
                             duration=int(round(1000 / self.fps)), loop=0, optimize=False)
            from .outputs import FILE_MODE, _test_hook
            if self.ext == ".mp4":
                _check_mp4(self.tmp, self.path)  # ffmpeg reports a failed write (disk full) only on its log
            os.chmod(self.tmp, FILE_MODE)  # mkstemp creates 0600
            os.replace(self.tmp, self.path)
            _test_hook(os.path.basename(self.path))
        except BaseException:
            self.abort()
            raise

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        """Complete file on success, nothing on error (the temporary file is removed)."""
        if exc_type is None:
            self.close()
        else:
            self.abort()
        return False

    def abort(self):
        try:
            if self.ext == ".mp4":
                self._gen.close()
        except Exception:
            pass
        try:
            os.unlink(self.tmp)
        except OSError:
            pass


# ============================================================================ scenario → video
def simulate_for_video(scn, mode: str | None = None, t_end: float | None = None):
    """Multibody run of the scenario with every control step recorded.  Returns (machine, traj)."""
    from . import scenario as scenario_mod
    from .backends import multibody

    mode = scn.mode(mode)
    machine = scenario_mod.make_machine(scn, mode)
    t_end = float(t_end if t_end is not None else scn.simulation.t_end)
    h = scn.simulation.dt
    traj = multibody.simulate(machine, t_end, record_dt=h, options=scn.multibody_options())
    return machine, traj


def frame_indices(t, fps: float, t_end: float | None = None) -> np.ndarray:
    """Indices into the recorded times ``t`` nearest to k/fps, k = 0..floor(t_end·fps)."""
    t = np.asarray(t, float)
    t_end = float(t[-1] if t_end is None else min(t_end, t[-1]))
    nfr = int(math.floor(t_end * fps + 1e-9)) + 1
    tk = np.arange(nfr) / fps
    idx = np.clip(np.searchsorted(t, tk), 1, len(t) - 1)
    left = t[idx - 1]
    idx = np.where(np.abs(tk - left) <= np.abs(t[idx] - tk), idx - 1, idx)
    return idx


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


def render_scenario(scn: dict, out, mode=None, fps=30.0, width=960, height=540, t_end=None, progress=True,
                    crf=23):
    """Simulate (multibody) and render ``scn``.  Returns the render info dict plus ``sim_s``."""
    if not (np.isfinite(fps) and fps > 0):
        raise ParameterError(f"--fps = {fps!r}: must be > 0")
    gl_setup()
    from . import scenario as scenario_mod
    from .errors import ScenarioError

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

    from .vibration import simulate_multibody

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
