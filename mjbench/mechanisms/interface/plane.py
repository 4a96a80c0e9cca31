"""The plane convention and the MJCF spec helpers every generated model shares.

Part of the mechanism interface (:mod:`mjbench.mechanisms.base`): the one declaration of the plane
of every generated MJCF model, the MuJoCo options of a new spec (:func:`new_spec`), the
loop-closure equalities' solver parameters (:func:`closure_solref`) and the site ``connect``
pairs that close loops (:func:`connect_site_pairs`).
"""
from __future__ import annotations

from ...errors import ParameterError

INPUT_JOINT = "crank"  #: default name of the driven joint in the generated MJCF models

# ---------------------------------------------------------------------------- plane convention
# The ONE declaration of the plane of every generated MJCF model.  A planar mechanism is described
# in its plane (x, y), y up (``points``, link lengths, angles counter-clockwise from +x).  Its MJCF
# lies in MuJoCo's x–z plane: plane (x, y) → MuJoCo (x, 0, y) (:func:`plane_to_mj`), gravity along
# −z (plane −y), and every hinge turns about HINGE_AXIS = −y, so that a positive joint angle is
# counter-clockwise in the plane: a body rotated by q about −y maps (1, 0, 0) to (cos q, 0, sin q).
# ``mjbench render`` looks along +y at that plane (SIDE_CAMERA: plane x → right, plane y → up).
HINGE_AXIS = (0.0, -1.0, 0.0)  #: hinge axis of a planar mechanism's joints in MuJoCo
PLANE_INDEX = (0, 2)  #: MuJoCo coordinates holding the plane's x and y
SIDE_CAMERA = {"azimuth": 90.0, "elevation": 0.0}  #: free camera looking along +y at the x–z plane


def plane_to_mj(x, y) -> list:
    """MuJoCo position [x, 0, y] of the plane point (x, y) [m] (the plane convention above)."""
    return [x, 0.0, y]


def mj_to_plane(p) -> tuple:
    """Plane point (x, y) [m] of a MuJoCo position (its x and z; the plane convention above)."""
    return (p[PLANE_INDEX[0]], p[PLANE_INDEX[1]])

INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast")


def integrator_enum(name):
    """MuJoCo integrator enum from its name (case-insensitive); ParameterError otherwise."""
    import mujoco  # (MuJoCo is imported where a model is built: after the command chose its GL backend)

    table = {"euler": mujoco.mjtIntegrator.mjINT_EULER, "rk4": mujoco.mjtIntegrator.mjINT_RK4,
             "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
             "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}
    try:
        return table[str(name).lower()]
    except KeyError:
        raise ParameterError(f"multibody.integrator = {name!r}: choose one of {list(INTEGRATORS)}") from None


# Loop-closure equalities of every built-in MJCF (four-bar, quick-return, generic linkage, a
# user's MJCF): solref = (timeconst, dampratio) with timeconst = CLOSURE_TIMECONST_STEPS · h and
# impedance 0.9999 (MuJoCo's maximum).  The constraint acceleration is the Baumgarte reference
# a* = −b·ṙ − k·r.  3·h, not MuJoCo's floor 2·h: measured multibody-vs-reduced crank speed (max/peak,
# RK4, h = 0.1 ms) at 2h / 3h / 4h: seed-000 four-bar open loop 4.9e-5 / 1.3e-5 / 5.1e-6, PID 1.9e-5 /
# 5.1e-6 / 2.0e-6; the other machines stay ≤ 1.5e-6 at 3h (sixbar 7.1e-7 → 1.5e-6, toggle press
# 3.0e-7 → 5.9e-7) while 4h lets the toggle press's closure exceed 1e-7 m.  3h minimises the worst
# case with every closure ≤ 6.3e-8 m.  A scenario's ``multibody.solref`` overrides it.
CLOSURE_TIMECONST_STEPS = 3.0
CLOSURE_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)


def closure_solref(options, h):
    """Loop-closure (solref, solimp) for step ``h`` [s]: the options' ``solref``/``solimp`` when given
    (a negative time constant means the default), else (CLOSURE_TIMECONST_STEPS·h, 1) and CLOSURE_SOLIMP."""
    solref = list(options.get("solref") or (-1.0, 0.0))
    if solref[0] < 0:
        solref = [CLOSURE_TIMECONST_STEPS * h, 1.0]
    return solref, list(options.get("solimp") or CLOSURE_SOLIMP)


def new_spec(name, options=None, gravity=(0.0, 0.0, -9.81), offscreen=(1920, 1080)):
    """An MjSpec with the options every mjbench model shares.

    ``options``: ``timestep`` [s] (default 1e-4), ``integrator`` (default RK4), ``iterations``,
    ``tolerance``.  Always: Newton solver, contacts off, energy computed, explicit inertials.  The
    constraint Jacobian is MuJoCo's default (``auto``: dense below 60 DOFs, i.e. every mjbench
    model); the forced dense Jacobian of MuJoCo 4.0.0 (sparse-Cholesky bug on closed chains,
    upstream issue 3767) was dropped on 4.0.1 by test (tests/test_mujoco_version.py).
    """
    import mujoco

    o = dict(options or {})
    spec = mujoco.MjSpec()
    spec.modelname = name
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.autolimits = True
    opt = set_solver_options(spec.option, o)
    opt.gravity = list(gravity)
    opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    spec.visual.global_.offwidth, spec.visual.global_.offheight = offscreen
    return spec


def set_solver_options(opt, o: dict):
    """The step and solver options every mjbench model shares on an MjSpec's ``option``: ``timestep``
    [s] (default 1e-4), ``integrator`` (default RK4), Newton with ``iterations`` (100) and
    ``tolerance`` (1e-12) from ``o``; → ``opt``."""
    import mujoco

    opt.timestep = float(o.get("timestep", 1e-4))
    opt.integrator = integrator_enum(o.get("integrator", "RK4"))
    opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    opt.iterations = int(o.get("iterations", 100))
    opt.tolerance = float(o.get("tolerance", 1e-12))
    return opt


def connect_site_pairs(model) -> list:
    """(site 1, site 2) ids of the model's site ``connect`` equalities (the loop closures)."""
    import mujoco

    return [(int(model.eq_obj1id[i]), int(model.eq_obj2id[i])) for i in range(model.neq)
            if model.eq_type[i] == mujoco.mjtEq.mjEQ_CONNECT and model.eq_objtype[i] == mujoco.mjtObj.mjOBJ_SITE]
