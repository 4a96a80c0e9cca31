"""The scene of a side view: the mechanism's MJCF with display-only items (backdrop, grid,
coupler plate), its bounds over a run and the camera looking along +y at its plane."""
from __future__ import annotations

import math

import numpy as np

from ..mechanisms.base import SIDE_CAMERA
from .gl import RenderError


# colours (RGBA 0..1) of the display-only items
TRACE_PATH_RGBA = (0.35, 0.35, 0.40, 1.0)


TRACE_TRAIL_RGBA = (0.95, 0.35, 0.0, 1.0)


BACKDROP_RGB = (0.96, 0.96, 0.94)


LINK_SCALE = 1.8  #: display thickness factor of link capsules, pins and sites


GRID_RGB = (0.80, 0.81, 0.84)


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
                         mujoco.mjtGeom.mjGEOM_SPHERE) and not geom.name.startswith("shape_"):
            geom.size[0] *= LINK_SCALE  # ("shape_…": drawn to size — a cam's roller, a gear's pitch circle)
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
    cam.azimuth = SIDE_CAMERA["azimuth"]  # along +y: the plane convention of mechanisms/base.py
    cam.elevation = SIDE_CAMERA["elevation"]
    cam.distance = 0.5 * h_world / t
    shift = 0.5 * h_world * (height - usable) / height  # lift the view centre by half the band
    cam.lookat[:] = [0.5 * (xmin + xmax), 0.0, 0.5 * (ymin + ymax) + shift]
    return cam
