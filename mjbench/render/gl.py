"""The offscreen OpenGL backend: ``MUJOCO_GL`` checked, probed in a subprocess once, with fallbacks
(EGL, OSMesa) and an error that says what to install (:func:`gl_setup`)."""
from __future__ import annotations

import os
import subprocess
import sys

from ..errors import MjbenchError


os.environ.setdefault("MUJOCO_GL", "egl")


_GL_CHOICE = None  # cached result of gl_setup()


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
