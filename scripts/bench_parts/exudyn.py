"""MuJoCo vs Exudyn: the seed-000 four-bar under a constant crank torque, cost per simulated second at equal accuracy.

The mechanism is the four-bar of ``incerti2012`` (geometry, masses, inertias, gravity) with the
drive's reflected inertia J_eq = z²(J_m + J_a) + J_b on the crank and nothing else of the drive:
a constant crank torque ``TAU`` from rest at α = 0, no motor, no controller, no friction, for
``T_END`` simulated seconds (the crank goes over the gravity hump and runs up to ≈ 110 rad/s,
four turns).

* **MuJoCo** — mjbench's own model (``FourBar.build_spec`` with ``armature = J_eq``: the model
  ``multibody.build_model`` builds, without the drive's viscous friction), RK4, h = 0.1 ms, loop
  closed by the soft ``connect`` equality, stepped by a bare ``mujoco.mj_step`` loop in Python with
  the torque in ``qfrc_applied``.
* **Exudyn** — the same linkage as a planar system in redundant coordinates: three
  ``RigidBody2D`` (node at the mass centre, J_G; J_G + J_eq for the crank), four
  ``RevoluteJoint2D`` (A, B, D and the loop-closing C), gravity as ``LoadMassProportional``, the
  torque as ``LoadTorqueVector``; Exudyn's own implicit solvers, fixed step, default Newton
  tolerances: the default generalized-α (ρ∞ = 0.9, index-3 constraints) and the implicit
  trapezoidal rule with index-2 constraints (``TrapezoidalIndex2``).  Exudyn's ``exudynCPPfast``
  module (no range checks, AVX2) is used when the CPU has it: the faster Exudyn, so the ratio errs
  in Exudyn's favour.  No solution file; the crank speed is recorded by a sensor every 1 ms (the
  MuJoCo loop records it every 1 ms too).

Accuracy: the largest crank-speed error at the 1 ms samples against the reduced (Eksergian) model
J(α)α̈ + ½J'(α)α̇² + E_p'(α) = τ (``FourBar.reduced``, J + J_eq) integrated by SciPy's DOP853 at
rtol 1e-10, atol 1e-12, relative to the peak speed.  The Exudyn model is checked against it
before anything is timed.  "Equal accuracy": for each Exudyn solver the step whose error is at
most MuJoCo's at h = 0.1 ms (estimated from the solver's second order, then confirmed by a run;
refined until confirmed).

Rows: ``mujoco_ms_per_sim_s`` and ``exudyn_ms_per_sim_s`` (the cheaper Exudyn solver at equal
accuracy) in ms of CPU per simulated second, best of --repeat, every run measured in turn; their
errors; ``exudyn_over_mujoco`` (goal ≥ 5); per Exudyn solver its equal-accuracy step and cost and
its cost and error at h = 0.1 ms; ``exudyn_over_mujoco_same_step`` (not equal accuracy).
Needs Exudyn (``pip install exudyn``, or ``make bench``: the ``bench`` extra); without it the
part prints how to install it and measures nothing.
"""
import contextlib
import io
import math
import sys

import numpy as np

from bench_parts import interleaved

TAU = 2.5        #: constant crank torque [N·m] (the largest static gravity torque E_p' is 2.33 N·m)
T_END = 1.0      #: simulated time [s]
H = 1e-4         #: mjbench's default step [s]
SAMPLE = 1e-3    #: recording period of the crank speed [s]
GOAL = 5.0


def _import_exudyn():
    """Exudyn (its fast module when the CPU has AVX2), or None."""
    if "exudyn" not in sys.modules:
        sys.exudynFast = True  # exudyn falls back to its checked module by itself where AVX2 is missing
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # "Imported exudyn fast version ..."
            import exudyn
            import exudyn.itemInterface  # noqa: F401
    except ImportError:
        return None
    return exudyn


def _reference(fb, J_eq):
    """Dense solution (α, α̇)(t) of the reduced model under TAU, DOP853 at rtol 1e-10, atol 1e-12."""
    from scipy.integrate import solve_ivp

    def f(t, y):
        J, dJ, dEp = fb.reduced(float(y[0]))
        return [y[1], (TAU - 0.5 * dJ * y[1] * y[1] - dEp) / (J + J_eq)]
    sol = solve_ivp(f, (0.0, T_END), [0.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-12, dense_output=True)
    if not sol.success:
        raise RuntimeError(f"reference: {sol.message}")
    return sol.sol


def _error(t, w, ref):
    """Largest crank-speed error at the samples / the peak reference speed."""
    wr = ref(t)[1]
    return float(np.abs(w - wr).max() / np.abs(wr).max())


def _mujoco(fb, J_eq, options):
    """A bare mj_step loop on mjbench's model: returns the function (its samples stored on it)."""
    import mujoco

    model = fb.build_spec(armature=J_eq, options=options).compile()
    h = float(model.opt.timestep)
    va = int(model.joint(fb.input_joint).dofadr[0])
    k = int(round(SAMPLE / h))
    chunks = int(round(T_END / SAMPLE))
    qpos0 = fb.initial_qpos(model, 0.0)

    def f():
        d = mujoco.MjData(model)
        d.qpos[:] = qpos0
        mujoco.mj_forward(model, d)
        d.qfrc_applied[va] = TAU
        step, qvel = mujoco.mj_step, d.qvel
        t, w = np.empty(chunks), np.empty(chunks)
        for j in range(chunks):
            for _ in range(k):
                step(model, d)
            t[j], w[j] = d.time, qvel[va]
        f.t, f.w = t, w
    f.h = h
    return f


def _exudyn_model(exu, fb, J_eq):
    """(mbs, sensor): the four-bar as three planar rigid bodies closed by four revolute joints."""
    from exudyn.itemInterface import (LoadMassProportional, LoadTorqueVector, MarkerBodyMass, MarkerBodyPosition,
                                      MarkerNodeRigid, NodeRigidBody2D, ObjectGround, ObjectRigidBody2D,
                                      RevoluteJoint2D, SensorNode)

    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    alpha0 = 0.0
    beta, gamma = fb.angles(alpha0)
    centres = fb.mass_centres(alpha0)
    angles = (alpha0, beta, gamma)
    ground = mbs.AddObject(ObjectGround())
    nodes, bodies = [], []
    for i in range(3):
        node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[float(centres[i][0]), float(centres[i][1]),
                                                                 float(angles[i])]))
        body = mbs.AddObject(ObjectRigidBody2D(mass=fb.m[i], inertia=fb.J_G[i] + (J_eq if i == 0 else 0.0),
                                               nodeNumber=node))
        mbs.AddLoad(LoadMassProportional(markerNumber=mbs.AddMarker(MarkerBodyMass(bodyNumber=body)),
                                         loadVector=[0.0, -fb.g, 0.0]))
        nodes.append(node)
        bodies.append(body)

    def at(i, s):
        """Marker on link i at distance s along its line from its proximal joint (body frame at G_i)."""
        f, th = fb.f[i], fb.theta[i]
        return mbs.AddMarker(MarkerBodyPosition(bodyNumber=bodies[i],
                                                localPosition=[s - f * math.cos(th), -f * math.sin(th), 0.0]))

    def fixed(x, y):
        return mbs.AddMarker(MarkerBodyPosition(bodyNumber=ground, localPosition=[x, y, 0.0]))

    for m1, m2 in ((fixed(0.0, 0.0), at(0, 0.0)),            # A: crank / ground
                   (at(0, fb.a), at(1, 0.0)),                # B: crank / coupler
                   (at(1, fb.b), at(2, fb.c)),               # C: coupler / rocker (closes the loop)
                   (fixed(fb.h_x, fb.h_y), at(2, 0.0))):     # D: rocker / ground
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[m1, m2]))
    mbs.AddLoad(LoadTorqueVector(markerNumber=mbs.AddMarker(MarkerNodeRigid(nodeNumber=nodes[0])),
                                 loadVector=[0.0, 0.0, TAU]))
    sensor = mbs.AddSensor(SensorNode(nodeNumber=nodes[0], outputVariableType=exu.OutputVariableType.Coordinates_t,
                                      storeInternal=True, writeToFile=False))
    mbs.Assemble()
    return mbs, sensor


def _exudyn(exu, mbs, sensor, n, solver):
    """One Exudyn solve of n fixed steps: returns the function (its samples stored on it)."""
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.endTime = T_END
    ti.numberOfSteps = int(n)
    ti.verboseMode = 0
    s.solution.file.write = False
    s.solution.sensors.writePeriod = SAMPLE

    def f():
        exu.SolveDynamic(mbs, s, solverType=solver)
        data = mbs.GetSensorStoredData(sensor)
        f.t, f.w = data[:, 0], data[:, 3]
    f.h = T_END / n
    return f


def _match(exu, mbs, sensor, solver, n0, e0, target, ref, tries=6):
    """(n, error): the fewest-steps run found whose error ≤ target, from a run of n0 steps with
    error e0 (second order: e ∝ h²); refined by runs until confirmed."""
    n = max(1, math.ceil(n0 * math.sqrt(e0 / target)))
    for _ in range(tries):
        f = _exudyn(exu, mbs, sensor, n, solver)
        f()
        e = _error(f.t, f.w, ref)
        if e <= target:
            return n, e
        n = math.ceil(n * max(1.02, 1.01 * math.sqrt(e / target)))
    raise RuntimeError(f"Exudyn {solver}: no step ≤ {T_END / n:.3g} s reached the error {target:.3g}")


def run(args):
    exu = _import_exudyn()
    if exu is None:
        print("  exudyn not installed: pip install exudyn (or `make bench`, which installs the bench extra "
              "mjbench[bench]); nothing measured")
        return []
    from mjbench import scenario as S
    from mjbench.runner import backend_options

    scn = S.load("incerti2012")
    fb = S.make_mechanism(scn)
    J_eq = float(S.make_machine(scn, "open").drive.J_eq)
    opts = {**backend_options(scn, "multibody"), "timestep": H}
    ref = _reference(fb, J_eq)
    peak = float(np.abs(ref(np.linspace(0.0, T_END, 2001))[1]).max())

    mj = _mujoco(fb, J_eq, opts)
    mj()
    e_mj = _error(mj.t, mj.w, ref)
    mbs, sensor = _exudyn_model(exu, fb, J_eq)
    n0 = int(round(T_END / H))
    solvers = {"ga": exu.DynamicSolverType.GeneralizedAlpha, "trap": exu.DynamicSolverType.TrapezoidalIndex2}
    same, err = {}, {}
    for key, solver in solvers.items():
        same[key] = _exudyn(exu, mbs, sensor, n0, solver)
        same[key]()
        err[key] = _error(same[key].t, same[key].w, ref)
    # the model check, before any timing: Exudyn's second-order error at 0.1 ms is ~1e-4 of the
    # peak speed; a wrong mass, inertia, joint or load would show as errors of percents
    if max(err.values()) > 5e-3:
        print(f"  Exudyn model disagrees with the reference: speed errors {err} of the peak; nothing timed")
        return [("exudyn_model_error", max(err.values()), "Exudyn vs reduced reference at h = 0.1 ms: model check FAILED")]
    matched = {}
    for key, solver in solvers.items():
        n, e = _match(exu, mbs, sensor, solver, n0, err[key], e_mj, ref)
        matched[key] = (_exudyn(exu, mbs, sensor, n, solver), e)

    fns = {"mujoco": mj, **{f"{k}_h": f for k, f in same.items()}, **{f"{k}_eq": f for k, (f, _) in matched.items()}}
    t = interleaved(fns, args.repeat)
    ms = {k: 1e3 * v / T_END for k, v in t.items()}
    best = min(solvers, key=lambda k: ms[f"{k}_eq"])
    names = {"ga": "generalized-α ρ∞ 0.9 (default)", "trap": "trapezoidal index-2"}
    module = getattr(exu, "_compiledModuleName", "?")
    ver = getattr(exu, "__version__", "?")
    hm = f"h = {1e3 * mj.h:g} ms"
    bf, be = matched[best]
    rows = [
        ("mujoco_ms_per_sim_s", ms["mujoco"], f"MuJoCo {getattr(sys.modules.get('mujoco'), '__version__', '')}, "
         f"mjbench's model, RK4, {hm}, bare mj_step loop [ms CPU per simulated s]"),
        ("mujoco_speed_error", e_mj, f"MuJoCo {hm}: max crank-speed error / peak speed ({peak:.1f} rad/s) vs the "
         "reduced reference (DOP853 rtol 1e-10)"),
        ("exudyn_ms_per_sim_s", ms[f"{best}_eq"], f"Exudyn {ver} ({module}) at equal accuracy: {names[best]}, "
         f"h = {1e6 * bf.h:.3g} µs (the cheaper of its two solvers) [ms CPU per simulated s]"),
        ("exudyn_speed_error", be, "Exudyn at that step: max crank-speed error / peak speed (≤ MuJoCo's)"),
        ("exudyn_over_mujoco", ms[f"{best}_eq"] / ms["mujoco"],
         f"Exudyn / MuJoCo at equal accuracy, CPU per simulated s (goal ≥ {GOAL:g})"),
    ]
    for key in solvers:
        f, e = matched[key]
        order = math.log(err[key] / e) / math.log(H / f.h)
        rows += [
            (f"exudyn_{key}_step_us", 1e6 * f.h, f"Exudyn {names[key]}: step whose speed error ({e:.3g}) ≤ "
             f"MuJoCo's ({e_mj:.3g}) [µs]; observed order of convergence to the reference {order:.2f}"),
            (f"exudyn_{key}_ms_per_sim_s", ms[f"{key}_eq"], f"Exudyn {names[key]} at that step [ms CPU per simulated s]"),
            (f"exudyn_{key}_h01ms_ms_per_sim_s", ms[f"{key}_h"], f"Exudyn {names[key]}, {hm} [ms CPU per simulated s]"),
            (f"exudyn_{key}_h01ms_speed_error", err[key], f"Exudyn {names[key]}, {hm}: max crank-speed error / peak "
             f"({err[key] / e_mj:.0f}× MuJoCo's)"),
        ]
    same_best = min(solvers, key=lambda k: ms[f"{k}_h"])
    rows.append(("exudyn_over_mujoco_same_step", ms[f"{same_best}_h"] / ms["mujoco"],
                 f"Exudyn ({names[same_best]}) / MuJoCo, both {hm}: NOT equal accuracy (Exudyn "
                 f"{err[same_best] / e_mj:.0f}× less accurate)"))
    return rows
