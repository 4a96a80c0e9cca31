"""The co-step kernel: the one loop that runs a machine — on every backend, in CPython or compiled.

One co-simulation step h (0.1 ms by default) of one run, in this order (:func:`_loop`):

1. measurement: t_n, q_n, q̇_n from the plant, q̈_n = (q̇_n − q̇_{n−1})/h (the backward difference a
   digital controller sees; 0 at the first sample — the record's row 0 gets the forward difference
   (q̇_1 − q̇_0)/h of the first step once it is taken), I_n;
2. at each control sample (every ``controller.period``, a multiple of h): the sensor (encoder,
   speed estimate, noise; ideal: the exact values), the reference φ_ref, φ̇_ref, φ̈_ref, the
   control law, the limiter (±v_max, or ±i_max for a current reference), the one-sample delay;
   the output is held in between;
3. every ``record_dt``: the divergence check and one record row (preallocated);
4. the current loop (a current reference → voltage), the amplifier (ideal, averaged or switching
   PWM), the motor torque z·(k_m·Ī − T_0·sgn φ̇) from the exact step-mean current Ī, the gear
   efficiency; the viscous z²λ and the reflected inertia J_eq are the plant's (joint damping and
   armature in MuJoCo, the same terms in the reduced model), integrated inside the step;
5. one plant step (MuJoCo's ``mj_step``, or RK4 on the reduced model);
6. I_{n+1} by the drive's exact exponential update with the mean of φ̇_n and φ̇_{n+1}.

**Written once.**  :func:`_loop` is the only copy of this order.  Every formula in it is a *law*
of a component (:mod:`mjbench.compiled`): the drive's equations (:mod:`mjbench.drive`), the
control law and its reference (``controllers/``), the drive-train elements
(:mod:`mjbench.drivetrain`), the plant's step (:mod:`mjbench.backends`).  A run is *composed*
(:class:`Program`): each slot of the loop is bound to the law its component declares (absent
optional elements are switched off by constant flags), and the loop is then either executed by
CPython (the reference; short runs, components without a compiled form) or compiled by numba with
every law inlined (long runs, batches, design loops).  Both execute the same source, so they give
the same bits (tests/test_compiled.py).

**When compiled** (:func:`choose_loop`): numba installed and every component compiles, and the
job is large enough to pay numba's start-up (≈ 0.35 s of CPU to import numba and load a cached
kernel, against ≈ 2–3 µs saved per co-step: :data:`MIN_STEPS`), or numba is already loaded, or
``MJBENCH_JIT=1``.  ``MJBENCH_JIT=0`` always runs CPython.  The reason for the choice is recorded
(``meta["loop"]``, ``meta["loop_reason"]``).

**Chunks.**  The loop runs a range of steps and keeps its state in arrays, so a run is executed in
chunks of ≈ 0.05 s (:data:`CHUNK_S`): progress bars advance, Ctrl-C and SIGTERM stop a compiled run within a chunk.

Slot signatures (P: the component's parameter tuple, S: its state array):

* ``SENSE(t, q, q̇, q̈, I, δ, δ̇, P, S) → (q_m, q̇_m, q̈_m, I_m)`` (δ: compliant-gear deflection);
* ``REF(t, q_m, q̇_m, q̈_m, I_m, P, S) → (φ_ref, φ̇_ref, φ̈_ref)`` (motor side);
* ``CTRL(t, q_m, q̇_m, q̈_m, I_m, φ_ref, φ̇_ref, φ̈_ref, P, S) → u``;
* ``CLOOP(n, i*, I, P, S) → V``; ``AMP(t, I, V, φ̇₀, P, S) → (Ī, I_end, V_bridge, I_min, I_max)``
  (averaged: ``AMP(t, I, V, φ̇₀, P, S) → V_bridge``); ``AMP_END(I_end, φ̇₀, φ̇̄, P) → I₊``;
  ``EFF(T_m, φ̇, P) → T``;
* the drive's ``DLIMIT(I, V, φ̇, P) → V_a`` (the voltage its amplifier applies: the command
  limited so that the current stays within ±i_max over the step), ``DMEAN(I, V, φ̇, P) → Ī`` (step-mean current), ``DTORQUE(Ī, φ̇, P) → T_m`` (motor
  torque without its viscous part), ``DSTEP(I, V, φ̇̄, P) → I₊``, ``DREC(out, b, I, V_a, φ̇, P)`` (the
  drive's five recorded columns — current, voltage, crank torque, mechanical and electrical power —
  into ``out[b:b+5]``); P has at least ``z``.  A drive type (:mod:`mjbench.drives`: a DC motor, an
  ideal torque or speed source) is these five laws — the loop reads no drive quantity but ``z``;
* ``PLANT(τ, t, P, S) → (q, q̇, δ, δ̇)``; ``READ(P, S)`` the same at the start;
  ``CLOSURE(P, S) → m``; ``UNSTABLE(P, S) → bool``; ``PWRITE(out, b, P, S)`` the plant's recorded
  columns.

A law may take other laws as leading arguments (``Form.fn_args``: the rigid reduced plant's
``MODEL(q, q̇, t, P) → (J, ½J', E_p', Q_ext)``, a MuJoCo plant's loads, SMC's model of the plant);
the slot is then that law with those bound (:meth:`mjbench.compiled.Form.bound`, or a generated
adapter in compiled code).
"""
from __future__ import annotations

import math
import os
import time
from collections import namedtuple

import numpy as np

from controllers.base import Measurement

from . import compiled as C
from . import environment
from .compiled import clip, isfinite
from .errors import ParameterError, SimulationDiverged
from .trajectory import NAMES

MAX_SPEED = 1e4  #: rad/s: beyond this an input speed is a diverged simulation, not physics
MAX_CURRENT = 1e5  #: A
NCORE = len(NAMES)
#: co-steps from which a job is compiled when numba is not loaded yet, unless its plant states its
#: own (``Form.flags["min_steps"]``): the start-up (numba import + cached kernel load) against the
#: CPython loop's extra cost per co-step, measured in docs/performance.md — reduced model ≈ 0.21 s
#: against ≈ 4.8 µs → 45 000 steps; MuJoCo ≈ 0.39 s against ≈ 2.2 µs → 180 000 steps
MIN_STEPS = 150_000
#: wall time a chunk of a compiled run aims at (progress, signals)
CHUNK_S = 0.05

# kernel state of one run between chunks (float64 array)
KS_Q, KS_QD, KS_QDP, KS_I, KS_U, KS_K, KS_DM, KS_DMD, KS_VB, KS_IBAR, KS_ILO, KS_IHI, KS_QM, KS_QDM, KS_QDDM, \
    KS_PEND, KS_V = range(17)
KS_SIZE = 17
# divergence record: flag, t, q, q̇, I, u
DIV_SIZE = 6

#: the per-run constants of the loop
Run = namedtuple("Run", "h nsteps decim every ks out ncol div u_lo u_hi")
#: the slots' parameters and states of one run
Parts = namedtuple("Parts", "drive sense_P sense_S ref_P ref_S ctrl_P ctrl_S cloop_P cloop_S amp_P amp_S eff_P "
                            "plant_P plant_S")


def check_times(t_end, h, record_dt):
    if not (np.isfinite(t_end) and t_end > 0):
        raise ParameterError(f"t_end = {t_end!r}: must be a finite time > 0 [s]")
    if not (np.isfinite(h) and 0 < h <= 0.01):
        raise ParameterError(f"simulation.dt = {h!r}: must be in (0, 0.01] s")
    if not (np.isfinite(record_dt) and record_dt > 0):
        raise ParameterError(f"simulation.record_dt = {record_dt!r}: must be > 0 [s]")
    k = record_dt / h
    if k < 1.0 - 1e-9 or abs(k - round(k)) > 1e-6 * k:
        lo = max(1, int(k)) * h
        raise ParameterError(f"simulation.record_dt = {record_dt:g} s is not a whole multiple of simulation.dt = "
                             f"{h:g} s (records are taken at co-steps): use e.g. {lo:g} or {lo + h:g} s")
    if record_dt > t_end:
        raise ParameterError(f"simulation.record_dt = {record_dt:g} s is longer than the run (t_end = {t_end:g} s): "
                             f"the record would hold one sample")


def control_every(controller, h) -> int:
    """Co-simulation steps per control sample (``controller.period`` must be a multiple of h)."""
    p = float(getattr(controller, "period", 0.0) or 0.0)
    if p <= 0.0:
        return 1
    k = p / h
    n = int(round(k))
    if n < 1 or abs(k - n) > 1e-6 * max(1.0, k):
        raise ParameterError(f"controller period = {p:g} s must be a whole multiple of the co-simulation step "
                             f"simulation.dt = {h:g} s")
    return n


class Record:
    """Samples of one run (``data`` (nrec, ncol)) or of N runs (``data`` (nsim, nrec, ncol)) in
    ``columns`` order; ``nrows`` valid rows per run; divergence flags, times and messages."""

    def __init__(self, data, columns, nrows, diverged, t_diverged, messages, meta):
        self.data, self.columns, self.nrows = data, columns, nrows
        self.diverged, self.t_diverged, self.messages, self.meta = diverged, t_diverged, messages, meta


# =============================================================================== the loop
# Slot functions and flags are globals of the module the loop runs in (see Program.env): numba
# treats them as constants (dead branches are pruned, laws inlined); CPython looks them up.
HAS_SENSE = HAS_REF = HAS_DELAY = HAS_CLOOP = HAS_EFF = HAS_CLOSURE = HAS_UNSTABLE = False
AMP_MODE = 0  # 0 ideal, 1 averaged (V → bridge V), 2 switching (the current within the step)
NEXTRA = 0  # plant columns
SENSE_COLS = AMP_COLS = MINMAX_COLS = IREF_COL = False
SENSE = REF = CTRL = CLOOP = AMP = AMP_END = EFF = PLANT = CLOSURE = UNSTABLE = PWRITE = None
DMEAN = DTORQUE = DSTEP = DREC = DLIMIT = None  # the drive's laws (a DC motor: mjbench.drive)


def _loop(n0, n1, K, X):
    """Co-steps n0 … n1−1 of one run (see the module doc); returns the next step index.  State
    between calls lives in ``K.ks`` and the components' state arrays; a divergence sets
    ``K.div[0]`` and stops."""
    h = K.h
    inv_h = 1.0 / h
    nsteps = K.nsteps
    decim = K.decim
    every = K.every
    ks = K.ks
    out = K.out
    ncol = K.ncol
    div = K.div
    u_lo = K.u_lo
    u_hi = K.u_hi
    Pd = X.drive
    Psen = X.sense_P
    Ssen = X.sense_S
    Pref = X.ref_P
    Sref = X.ref_S
    Pc = X.ctrl_P
    Sc = X.ctrl_S
    Pcl = X.cloop_P
    Scl = X.cloop_S
    Pamp = X.amp_P
    Samp = X.amp_S
    Peff = X.eff_P
    Pp = X.plant_P
    Sp = X.plant_S
    z = Pd.z
    q = ks[0]
    qd = ks[1]
    qd_prev = ks[2]
    I = ks[3]
    u = ks[4]
    k = int(ks[5])
    dm = ks[6]
    dmd = ks[7]
    Vb = ks[8]
    Ibar = ks[9]
    ilo = ks[10]
    ihi = ks[11]
    qm = ks[12]
    qdm = ks[13]
    qddm = ks[14]
    pend = ks[15]
    V = ks[16]
    n = n0
    while n < n1:
        t = n * h
        qdd = (qd - qd_prev) * inv_h
        if n % every == 0:
            # ---- sample: sensor → reference → control law → limiter → delay
            if HAS_SENSE:
                qm, qdm, qddm, Im = SENSE(t, q, qd, qdd, I, dm, dmd, Psen, Ssen)
            else:
                qm = q
                qdm = qd
                qddm = qdd
                Im = I
            if HAS_REF:
                phi_r, om_r, acc_r = REF(t, qm, qdm, qddm, Im, Pref, Sref)
            else:
                phi_r = 0.0
                om_r = 0.0
                acc_r = 0.0
            u = CTRL(t, qm, qdm, qddm, Im, phi_r, om_r, acc_r, Pc, Sc)
            u = clip(u, u_lo, u_hi)
            if HAS_DELAY:
                u_now = u
                u = pend
                pend = u_now
        if n % decim == 0:
            # ---- divergence check, then one record row
            if not (abs(qd) < MAX_SPEED and abs(I) < MAX_CURRENT and isfinite(u) and isfinite(q)) or \
                    (HAS_UNSTABLE and UNSTABLE(Pp, Sp)):
                div[0] = 1.0
                div[1] = t
                div[2] = q
                div[3] = qd
                div[4] = I
                div[5] = u
                break
            b = k * ncol
            w = z * (qd + dmd)  # motor speed φ̇ (a compliant gear: the motor's own)
            if HAS_CLOOP:
                volt = Vb  # the current loop's output (its reference is recorded as current_ref_A)
            elif AMP_MODE == 0:
                volt = DLIMIT(I, u, w, Pd)  # the voltage the (current-limiting) amplifier applies next
            else:
                volt = u  # the command (the PWM bridge's mean voltage is voltage_bridge_V)
            out[b] = t
            out[b + 1] = q
            out[b + 2] = qd
            out[b + 3] = qdd
            out[b + 4] = w
            DREC(out, b + 5, I, volt, w, Pd)  # current, voltage, crank torque, mechanical and electrical power
            out[b + 10] = CLOSURE(Pp, Sp) if HAS_CLOSURE else 0.0
            c = b + 11
            if NEXTRA > 0:
                PWRITE(out, c, Pp, Sp)
                c += NEXTRA
            if SENSE_COLS:
                out[c] = qm
                out[c + 1] = qdm
                out[c + 2] = qddm
                c += 3
            if AMP_COLS:
                out[c] = Vb
                out[c + 1] = Ibar
                c += 2
            if MINMAX_COLS:
                out[c] = ilo
                out[c + 1] = ihi
                c += 2
            if IREF_COL:
                out[c] = u
            k += 1
        if n == nsteps:
            n += 1
            break
        # ---- current loop → amplifier → motor torque → gear → plant step → current update
        if HAS_CLOOP:
            V = CLOOP(n, u, I, Pcl, Scl)
        else:
            V = u
        w0 = z * (qd + dmd)
        Iend = 0.0
        if AMP_MODE == 2:
            Ibar, Iend, Vb, ilo, ihi = AMP(t, I, V, w0, Pamp, Samp)
        else:
            if AMP_MODE == 1:
                Vb = AMP(t, I, V, w0, Pamp, Samp)
            else:
                Vb = DLIMIT(I, V, w0, Pd)
            Ibar = DMEAN(I, Vb, w0, Pd)
        Tm = DTORQUE(Ibar, w0, Pd)
        if HAS_EFF:
            Tm = EFF(Tm, w0, Peff)
        q1, qd1, dm, dmd = PLANT(z * Tm, t, Pp, Sp)
        if n == 0 and k > 0:  # row 0's acceleration: the forward difference of the first step
            out[3] = (qd1 - qd) * inv_h
        qd_prev = qd
        wm = 0.5 * (w0 + z * (qd1 + dmd))
        if AMP_MODE == 2:
            I = AMP_END(Iend, w0, wm, Pamp)
        else:
            I = DSTEP(I, Vb, wm, Pd)
        q = q1
        qd = qd1
        n += 1
    ks[0] = q
    ks[1] = qd
    ks[2] = qd_prev
    ks[3] = I
    ks[4] = u
    ks[5] = k
    ks[6] = dm
    ks[7] = dmd
    ks[8] = Vb
    ks[9] = Ibar
    ks[10] = ilo
    ks[11] = ihi
    ks[12] = qm
    ks[13] = qdm
    ks[14] = qddm
    ks[15] = pend
    ks[16] = V
    return n


# =============================================================================== composition
FLAGS = ("HAS_SENSE", "HAS_REF", "HAS_DELAY", "HAS_CLOOP", "HAS_EFF", "HAS_CLOSURE", "HAS_UNSTABLE",
         "AMP_MODE", "NEXTRA", "SENSE_COLS", "AMP_COLS", "MINMAX_COLS", "IREF_COL")
SLOTS = ("DMEAN", "DTORQUE", "DSTEP", "DREC", "DLIMIT", "SENSE", "REF", "CTRL", "CLOOP", "AMP", "AMP_END", "EFF", "PLANT",
         "CLOSURE", "UNSTABLE", "PWRITE")


@C.law
def _absent(*args):  # a slot no run calls (its flag is off)
    return 0.0


def _ident(form) -> tuple:
    """A form's law and its function arguments' laws, nested, by identity (:attr:`Program.key`)."""
    if not form.fn_args:
        return id(form.law)
    return (id(form.law), tuple(_ident(f) for f in form.fn_args))


_ABSENT = C.Form(_absent)


class Program:
    """One run composed: the form in each slot, the flags, the parameters and states, the columns.

    Built from the machine's components (:meth:`build`); ``key`` identifies the composition (runs
    with the same key share one compiled loop); ``compiled``: whether every slot compiles, else
    ``reasons``."""

    def __init__(self):
        self.slots = {s: _ABSENT for s in SLOTS}
        self.flags = {f: (0 if f in ("AMP_MODE", "NEXTRA") else False) for f in FLAGS}
        self.reasons: list[str] = []
        self.forms: dict = {}
        self.columns: tuple = NAMES
        self.u_lim = (-math.inf, math.inf)

    # ------------------------------------------------------------------ assembly
    def use(self, slot: str, form, why: str = ""):
        """Bind ``slot`` to ``form`` (a Form, or a bare law)."""
        if not isinstance(form, C.Form):
            form = C.Form(form)
        self.slots[slot] = form
        if not form.compiled:
            self.reasons.append(f"{why or slot.lower()}: {form.reason}")

    @classmethod
    def build(cls, plant, machine, h: float, every: int) -> "Program":
        """Compose a run of ``machine`` on ``plant`` at step h with the controller sampled every
        ``every`` steps: every component contributes its form (``form(...)`` methods)."""
        pr = cls()
        drive, ctrl = machine.drive, machine.controller
        df = drive.form(h)  # the drive's laws: limit, step-mean current, motor torque, current update, record
        pr.drive = df.P
        for slot, name in (("DMEAN", "mean"), ("DTORQUE", "torque"), ("DSTEP", "step"), ("DREC", "record"),
                           ("DLIMIT", "limit")):
            pr.use(slot, df.laws[name], "drive")
        dforms = drive.forms(h, every, plant)  # the drive train's elements (empty: ideal)
        lim = dforms.get("limit")  # the controller output's clip: the drive train's, else ±v_max
        pr.u_lim = lim if lim is not None else (-float(drive.v_max), float(drive.v_max))
        parts = {}
        # controller (+ reference)
        cf = controller_form(ctrl, h, every, machine)
        pr.use("CTRL", cf, "controller")
        parts["ctrl"] = cf
        ref = cf.children.get("reference")
        if ref is not None:
            pr.flags["HAS_REF"] = True
            pr.use("REF", ref, "reference")
            parts["ref"] = ref
        # drive train
        sen = dforms.get("sense")
        if sen is not None:
            pr.flags["HAS_SENSE"] = True
            pr.flags["SENSE_COLS"] = True
            pr.use("SENSE", sen, "sensor")
            parts["sense"] = sen
        if dforms.get("sense_cols"):
            pr.flags["SENSE_COLS"] = True
        pr.flags["HAS_DELAY"] = bool(dforms.get("delay"))
        cl = dforms.get("cloop")
        if cl is not None:
            pr.flags["HAS_CLOOP"] = True
            pr.flags["IREF_COL"] = True
            pr.use("CLOOP", cl, "current loop")
            parts["cloop"] = cl
        amp = dforms.get("amp")
        if amp is not None:
            pr.flags["AMP_MODE"] = 2 if amp.flags.get("switching") else 1
            pr.flags["AMP_COLS"] = True
            pr.flags["MINMAX_COLS"] = bool(amp.flags.get("switching"))
            pr.use("AMP", amp, "amplifier")
            if "end" in amp.laws:
                pr.use("AMP_END", amp.laws["end"])
            parts["amp"] = amp
        eff = dforms.get("eff")
        if eff is not None:
            pr.flags["HAS_EFF"] = True
            pr.use("EFF", eff, "gear efficiency")
            parts["eff"] = eff
        # plant
        pf = plant.form()
        pr.use("PLANT", pf, "plant")
        for slot, name in (("CLOSURE", "closure"), ("UNSTABLE", "unstable"), ("PWRITE", "write")):
            if name in pf.laws:  # the plant's further laws take the plant's (P, S)
                pr.use(slot, pf.laws[name], f"plant {name}")
        pr.flags["HAS_CLOSURE"] = "closure" in pf.laws
        pr.flags["HAS_UNSTABLE"] = "unstable" in pf.laws
        pr.flags["NEXTRA"] = int(pf.flags.get("nextra", 0))
        pr.min_steps = int(pf.flags.get("min_steps", MIN_STEPS))
        pr.read = pf.laws["read"]
        parts["plant"] = pf
        pr.forms = parts
        cols = list(NAMES) + list(plant.extra_columns)
        if pr.flags["SENSE_COLS"]:
            cols += ["angle_meas_rad", "speed_est_rad_s", "accel_est_rad_s2"]
        if pr.flags["AMP_COLS"]:
            cols += ["voltage_bridge_V", "current_mean_A"]
        if pr.flags["MINMAX_COLS"]:
            cols += ["current_min_A", "current_max_A"]
        if pr.flags["IREF_COL"]:
            cols.append("current_ref_A")
        pr.columns = tuple(cols)
        if len(plant.extra_columns) != pr.flags["NEXTRA"]:
            raise ParameterError(f"plant declares {len(plant.extra_columns)} extra columns but writes "
                                 f"{pr.flags['NEXTRA']}")
        return pr

    @property
    def compiled(self) -> bool:
        return not self.reasons

    @property
    def key(self) -> tuple:
        """The composition: the slot laws' function objects (each slot's law and, nested, its function
        arguments' laws, by identity: the laws of a cached loop are kept alive, so their ids stay
        unique) and the flags, in :data:`SLOTS` and :data:`FLAGS` order.  Runs with the same key share
        one loop; computed once (the slots do not change after :meth:`build`)."""
        k = self.__dict__.get("_key")
        if k is None:
            k = self._key = (tuple(_ident(self.slots[s]) for s in SLOTS), tuple(self.flags[f] for f in FLAGS))
        return k

    def env(self) -> dict:
        """Globals of the CPython loop for this composition (flags and slot functions)."""
        return {**self.flags, **{s: f.bound() for s, f in self.slots.items()}}

    # ------------------------------------------------------------------ per-run values
    def parts(self, python: bool):
        """The slots' parameters and fresh states of one run (memoryviews for CPython)."""
        f = self.forms
        view = C.python_view if python else (lambda x: x)

        def P(name):
            return view(f[name].P) if name in f else C.NO_PARAMS

        def S(name):
            return view(f[name].state() if name in f else np.zeros(0))

        return Parts(view(self.drive), P("sense"), S("sense"), P("ref"), S("ref"), P("ctrl"), S("ctrl"),
                     P("cloop"), S("cloop"), P("amp"), S("amp"), P("eff"), P("plant"), S("plant"))


def controller_form(ctrl, h: float, every: int, machine) -> C.Form:
    """The controller's form; a controller without one (a plain ``__call__(t, y)``) runs through a
    Python adapter (the loop then runs in CPython)."""
    fn = getattr(ctrl, "form", None)
    f = fn(h * every, machine) if fn is not None else None
    if f is not None:
        return f
    reset = getattr(ctrl, "reset", None)
    if reset is not None:  # a plain Python controller keeps its state in itself: start it afresh
        reset()
    y = Measurement(z=machine.drive.z)

    def adapter(t, q, qd, qdd, I, phi_r, om_r, acc_r, P, S):
        return ctrl(t, y.set(t, q, qd, qdd, I))

    return C.python_form(adapter, f"{type(ctrl).__name__} has no compiled form (no law)")


# =============================================================================== running
_PY_LOOPS: dict = {}


def python_loop(program: Program):
    """The loop executed by CPython for this composition (the same code object as :func:`_loop`)."""
    import types

    key = program.key
    fn = _PY_LOOPS.get(key) if program.compiled else None
    if fn is None:
        env = {**globals(), **program.env()}
        fn = types.FunctionType(_loop.__code__, env, "_loop")
        if program.compiled:
            _PY_LOOPS[key] = fn  # (its globals hold the laws: their ids in the key stay unique)
    return fn


def choose_loop(program: Program, run_steps: float, loop: str | None = None) -> tuple[str, str]:
    """("compiled" | "python", why) for a job of ``run_steps`` co-steps (all runs together)."""
    from .compiled import jit

    mode = (loop or environment.jit()).lower()  # (MJBENCH_JIT checked: 0/1/python/compiled, else an error)
    if mode in ("0", "python"):
        return "python", "CPython loop requested (MJBENCH_JIT=0 / loop='python')"
    if not program.compiled:
        return "python", "; ".join(program.reasons)
    if mode in ("1", "compiled"):
        why = "compiled loop requested (MJBENCH_JIT=1 / loop='compiled')"
    elif jit.loaded():
        why = "numba already loaded"
    elif run_steps >= program.min_steps:
        why = f"{int(run_steps):,} co-steps ≥ {int(program.min_steps):,} (pays numba's start-up)"
    else:
        return "python", (f"{int(run_steps):,} co-steps < {int(program.min_steps):,}: numba's start-up would cost more "
                          f"than it saves")
    if not jit.available():
        return "python", "numba is not installed"
    return "compiled", why


def preload(run_steps: float) -> bool:
    """Load numba now when a design loop plans ``run_steps`` co-steps over all its runs and that
    pays for the start-up (then every later run of the process is compiled); → whether loaded."""
    from .compiled import jit

    if environment.jit() == "python" or not jit.available():
        return False
    if jit.loaded() or run_steps >= MIN_STEPS:
        jit.init()
        return True
    return False


#: records up to this size [bytes] are allocated without reading the available memory (16 MiB)
SMALL_RECORD = 16 * 2 ** 20


def record_bytes(nrec: int, ncol: int, nsim: int = 1) -> int:
    """Memory of a record [bytes]: nsim × nrec rows × ncol float64 columns."""
    return 8 * nrec * ncol * nsim


def memory_limit(need: int | None = None) -> int:
    """Largest record a run may allocate [bytes]: ``MJBENCH_MAX_RECORD_MB`` if set, else half the
    machine's available memory (Linux ``MemAvailable``; 4 GiB where it cannot be read).  With
    ``need`` [bytes] at most :data:`SMALL_RECORD` and no ``MJBENCH_MAX_RECORD_MB``, ``need`` itself
    without reading the system's figure (a record that small is never refused)."""
    env = environment.max_record_mb()  # (checked: a finite number > 0, else an error naming it)
    if env is not None:
        return int(env * 2 ** 20)
    if need is not None and need <= SMALL_RECORD:
        return int(need)
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024 // 2
    except OSError:
        pass
    return 4 * 2 ** 30


def check_record(nsteps: int, decim: int, ncol: int, nsim: int, h: float, record_dt: float) -> None:
    """Refuse, before simulating, a record that would not fit (ParameterError naming the cause)."""
    nrec = nsteps // decim + 1
    need = record_bytes(nrec, ncol, nsim)
    lim = memory_limit(need)
    if need > lim:
        raise ParameterError(
            f"the record needs {need / 2 ** 20:,.0f} MiB ({nsim} run(s) × {nrec:,} samples × {ncol} columns at "
            f"record_dt = {record_dt:g} s), more than the limit {lim / 2 ** 20:,.0f} MiB (half the available "
            f"memory; MJBENCH_MAX_RECORD_MB overrides): shorten t_end, raise simulation.record_dt or run fewer "
            f"simulations at once")


class Stepper:
    """One run of the kernel advanced in chunks: the composed program, the loop (CPython or
    compiled), the per-run parameters and state, the record.  :func:`run_many` drives one per run;
    a caller that needs the run between chunks (an FMU's ``doStep``, a frequency-response
    measurement) drives its own with :meth:`advance`.

    ``out``: the flat record (nrec·ncol) to fill, default allocated; ``mode``: "python" or
    "compiled" (:func:`choose_loop`)."""

    def __init__(self, plant, machine, h: float, nsteps: int, decim: int, mode: str = "python", program=None,
                 out=None, fn=None):
        self.plant, self.machine, self.h, self.nsteps, self.decim, self.mode = plant, machine, h, nsteps, decim, mode
        self.every = control_every(machine.controller, h)
        if program is None:
            plant.start()
            program = Program.build(plant, machine, h, self.every)
        self.program = pr = program
        self.columns = pr.columns
        self.ncol = ncol = len(pr.columns)
        self.nrec = nsteps // decim + 1
        if out is None:
            out = np.full(self.nrec * ncol, np.nan)
        self.out = out
        python = mode == "python"
        self.fn = fn if fn is not None else (python_loop(pr) if python else _compiled(pr))
        self.parts = X = pr.parts(python)
        self.ks = ks = np.zeros(KS_SIZE)
        q, qd, dm, dmd = pr.read(X.plant_P, X.plant_S)
        ks[KS_Q], ks[KS_QD], ks[KS_QDP], ks[KS_I] = q, qd, qd, float(machine.I0)
        ks[KS_DM], ks[KS_DMD] = dm, dmd
        ks[KS_QM], ks[KS_QDM] = q, qd
        self.div = np.zeros(DIV_SIZE)
        view = memoryview if python else (lambda a: a)
        self.run = Run(h, nsteps, decim, self.every, view(ks), view(out), ncol, view(self.div), float(pr.u_lim[0]),
                       float(pr.u_lim[1]))
        self.n = 0

    @property
    def diverged(self) -> bool:
        return bool(self.div[0])

    @property
    def done(self) -> bool:
        return self.diverged or self.n > self.nsteps

    @property
    def nrows(self) -> int:
        return int(self.ks[KS_K])

    def state(self) -> dict:
        """The run's state now: t [s], q [rad], q̇ [rad/s], I [A], u (the held controller output)."""
        ks = self.ks
        return {"t": self.n * self.h, "q": float(ks[KS_Q]), "qd": float(ks[KS_QD]), "I": float(ks[KS_I]),
                "u": float(ks[KS_U]), "deflection": float(ks[KS_DM]), "deflection_rate": float(ks[KS_DMD])}

    def advance(self, n_to: int) -> int:
        """Run co-steps up to ``n_to`` (exclusive; at most nsteps + 1) or a divergence → the step reached."""
        if not self.done:
            self.n = self.fn(self.n, min(int(n_to), self.nsteps + 1), self.run, self.parts)
        return self.n

    def message(self, backend: str = "") -> str:
        """The divergence message: time and state, then the likely cause (:func:`diagnose`), else
        the controller's own hint (``divergence_hint``, e.g. the K_p·t ramp)."""
        d = self.div
        cause = diagnose(self.machine, self.h)
        if not cause:
            hint_fn = getattr(self.machine.controller, "divergence_hint", None)
            cause = hint_fn(float(d[1]), self.h) if hint_fn is not None else ""
        return _message(backend, *d[1:6], cause)


def input_inertia(machine, n: int = 16) -> tuple[float, float]:
    """(smallest, largest) inertia at the input coordinate, J_eq + J(q) over n angles of one
    period [kg·m²] (the mechanism's closed forms; the drive's reflected J_eq)."""
    mech, drive = machine.mechanism, machine.drive
    period = getattr(mech, "reduced_period", None) or 2.0 * math.pi
    J = []
    for q in np.linspace(0.0, period, n, endpoint=False):
        try:
            J.append(float(mech.reduced(float(q))[0]))
        except Exception:  # noqa: BLE001 - a pose the linkage cannot take: skip it
            continue
    Jeq = float(drive.J_eq)
    if not J:
        return Jeq, Jeq
    return Jeq + min(J), Jeq + max(J)


#: machines already checked in this process (by :func:`_machine_key`)
_CHECKED: set = set()


def _machine_key(mc):
    """What :func:`check_machine` depends on: the mechanism's parameters and the drive's inertia."""
    from .backends.table import mechanism_key

    try:
        mech = (type(mc.mechanism).__name__, mechanism_key(mc.mechanism))
    except Exception:  # noqa: BLE001 - a mechanism that cannot describe itself: check each
        mech = id(mc.mechanism)
    return mech, float(mc.drive.J_eq)


def check_machine(machine) -> None:
    """Refuse, before simulating, a machine with nothing to accelerate: J_eq + J(q) ≤ 0 (all
    masses and inertias zero) — its acceleration would be a division by zero."""
    jmin, jmax = input_inertia(machine)
    if not jmax > 0.0:
        raise ParameterError(f"the machine has no inertia at its input (J_eq + J(q) = {jmax:g} kg·m²: drive.J_m, "
                             f"J_a, J_b and every mass and inertia of the mechanism are zero): give the drive or the "
                             f"mechanism some inertia")


def diagnose(machine, h: float) -> str:
    """The likely cause of a divergence from the machine itself ('' if none is recognised):
    an initial current beyond the amplifier's limit; a mechanical time constant J·R/(z·k_m)²
    (J the smallest input inertia) below 2·h, i.e. an inertia too small for the step (or a unit
    slip in the inertias)."""
    drive = machine.drive
    own = getattr(drive, "diagnose", None)  # a drive type with its own causes (mjbench.drives)
    if own is not None:
        return own(machine, h)
    I0, imax = abs(float(machine.I0)), float(drive.i_max)
    if I0 > imax:
        return (f" Likely cause: initial.I0 = {machine.I0:g} A is beyond the amplifier's current limit "
                f"drive.i_max = {imax:g} A.")
    if abs(float(machine.I0)) > 10.0 * max(abs(float(getattr(drive, "v_max", math.inf)) / float(drive.R)), 0.0):
        return (f" Likely cause: initial.I0 = {machine.I0:g} A is far beyond the stall current v_max/R = "
                f"{float(drive.v_max) / float(drive.R):g} A.")
    jmin, _ = input_inertia(machine)
    k = float(drive.z) * float(drive.k_m)
    tau_m = jmin * float(drive.R) / (k * k) if k > 0 else math.inf
    if tau_m < 2.0 * h:
        return (f" Likely cause: the smallest inertia at the input, J_eq + J(q) = {jmin:.3g} kg·m², gives a mechanical "
                f"time constant J·R/(z·k_m)² = {tau_m:.3g} s below 2·dt = {2 * h:g} s: the inertia is too small for the "
                f"step (a unit slip in a mass or inertia?), or reduce simulation.dt.")
    return ""


def run(plant, machine, t_end: float, record_dt: float = 1e-3, progress=None, backend: str = "",
        loop: str | None = None) -> Record:
    """Co-simulate ``machine`` on ``plant`` for ``t_end`` s; one :class:`Record` (single run).

    Raises :class:`SimulationDiverged` (time and state in the message) when the run diverges."""
    rec = run_many([plant], [machine], t_end, record_dt, progress, backend, loop)
    state = rec.meta.pop("div_state", None)
    if rec.diverged[0]:
        raise SimulationDiverged(rec.messages[0], t=float(rec.t_diverged[0]), state=state)
    return Record(rec.data[0], rec.columns, rec.nrows, rec.diverged, rec.t_diverged, rec.messages,
                  {k: v for k, v in rec.meta.items() if k != "nsim"})


def run_many(plants, machines, t_end: float, record_dt: float = 1e-3, progress=None, backend: str = "",
             loop: str | None = None, threads: int | None = None, consume=None) -> Record:
    """Co-simulate N machines, each on its own plant → an (N, nrec, ncol) :class:`Record`.

    Runs are independent (a batch equals N single runs, bit for bit); a diverged run is flagged
    with its time and message, its rows stop there.  All runs must have the same step.  Compiled
    runs of a batch run on ``threads`` threads (default: the CPUs; the compiled loop releases the
    GIL).  Progress: co-steps of a single run, finished runs of a batch.

    ``consume(i, record)``: called with each run's own one-run :class:`Record` as soon as it ends;
    its records are then not kept (a sweep that needs only metrics holds one record per thread):
    the returned Record has ``data = None`` and ``results`` = the values ``consume`` returned."""
    plants, machines = list(plants), list(machines)
    h = float(plants[0].h)
    check_times(t_end, h, record_dt)
    nsteps = int(round(t_end / h))
    decim = max(1, int(round(record_dt / h)))
    nrec = nsteps // decim + 1
    N = len(machines)
    progs = _programs(plants, machines, h)
    cols = progs[0].columns
    ncol = len(cols)
    mode, why = _job_loop(progs, N * nsteps, loop)
    nthreads = min(N, threads or os.cpu_count() or 1) if mode == "compiled" and N > 1 else 1
    check_record(nsteps, decim, ncol, nthreads if consume is not None else N, h, record_dt)
    data = None if consume is not None else np.full((N, nrec * ncol), np.nan)
    fns = {}
    for pr in progs:
        if pr.key not in fns:
            fns[pr.key] = python_loop(pr) if mode == "python" else _compiled(pr)
    meta = _job_meta(plants[0], machines[0], h, decim, mode, why)
    nrows = np.zeros(N, dtype=int)
    diverged = np.zeros(N, dtype=bool)
    t_div = np.full(N, np.nan)
    messages = [""] * N
    results = [None] * N
    div_state = [None]

    def task(i, prog, stop=None):
        pr = progs[i]
        st = Stepper(plants[i], machines[i], h, nsteps, decim, mode, pr, None if data is None else data[i],
                     fns[pr.key])
        _run_one(st, prog, mode == "compiled", stop)
        nrows[i], diverged[i] = st.nrows, st.diverged
        if st.diverged:
            d = st.div
            t_div[i], messages[i] = d[1], st.message(backend)
            div_state[0] = {"q": float(d[2]), "qd": float(d[3]), "I": float(d[4]), "V": float(d[5])}
        if consume is not None:
            one = Record(st.out.reshape(nrec, ncol), cols, nrows[i:i + 1], diverged[i:i + 1], t_div[i:i + 1],
                         messages[i:i + 1], meta)
            results[i] = consume(i, one)

    if nthreads > 1:
        _run_threaded(task, N, nthreads, progress)
    else:
        for i in range(N):
            task(i, progress if N == 1 else None)
            if progress is not None and N > 1:
                progress.update(1)
    meta = {**meta, "nsim": N, "div_state": div_state[0]}
    rec = Record(None if data is None else data.reshape(N, nrec, ncol), cols, nrows, diverged, t_div, messages, meta)
    rec.results = results if consume is not None else None
    return rec


def _programs(plants, machines, h: float) -> list:
    """Each run's :class:`Program` (its plant started), after the checks of a job: every machine
    (once per mechanism and drive inertia in this process: :data:`_CHECKED`), one step for all, the
    same recorded columns."""
    from .backends.table import composing

    with composing():
        return _compose(plants, machines, h)


def _compose(plants, machines, h: float) -> list:
    progs = []
    for pl, mc in zip(plants, machines):
        key = _machine_key(mc)
        if key not in _CHECKED:  # (a sweep's rows, the runs of a design loop share it: check once per process)
            check_machine(mc)
            if len(_CHECKED) > 4096:
                _CHECKED.clear()
            _CHECKED.add(key)
        if abs(float(pl.h) - h) > 1e-15 * h:
            raise ParameterError(f"simulation.dt: the runs of one batch need the same step ({pl.h:g} s vs {h:g} s)")
        pl.start()
        progs.append(Program.build(pl, mc, h, control_every(mc.controller, h)))
    cols = progs[0].columns
    if any(p.columns != cols for p in progs):
        raise ParameterError("the runs of one batch must record the same columns (same drive-train elements and "
                             "mechanism family)")
    return progs


def _job_loop(progs, steps: int, loop: str | None) -> tuple:
    """(mode, reason): one loop for the whole job — CPython as soon as one run needs it (the same
    numbers either way)."""
    mode, why = "python", ""
    for p in progs:
        mode, why = choose_loop(p, steps, loop)
        if mode == "python":
            break
    return mode, why


def _job_meta(plant, machine, h: float, decim: int, mode: str, why: str) -> dict:
    """The job's meta: steps, control period, the plant's meta, the loop and the drive train."""
    meta = {"dt": h, "record_dt": decim * h, "control_period": control_every(machine.controller, h) * h,
            **plant.meta, "loop": mode, "loop_reason": why}
    train = getattr(machine.drive, "train", None)
    if train is not None:
        meta["drivetrain"] = train.describe()
    return meta


def _run_one(st: Stepper, progress, compiled: bool, stop=None) -> None:
    """Advance one run to its end in chunks of ≈ CHUNK_S (progress, signals between chunks)."""
    chunk = 20000 if compiled else 4000
    while not st.done:
        if stop is not None and stop.is_set():
            return
        t0 = time.perf_counter()
        n0 = st.n
        n_to = n0 + chunk
        if st.nsteps + 1 - n_to <= chunk // 4:  # a short tail (a run's last step): in this call
            n_to = st.nsteps + 1
        st.advance(n_to)
        if progress is not None:
            progress.update(st.n - n0)
        dt = time.perf_counter() - t0
        if compiled and dt > 0 and st.n > n0:
            chunk = int(max(1000, min(5_000_000, (st.n - n0) * CHUNK_S / dt)))


def _run_threaded(task, N: int, nthreads: int, progress) -> None:
    """``task(i, None, stop)`` for every run on a thread pool (the compiled loop releases the GIL);
    Ctrl-C/SIGTERM reach the main thread, which stops the workers at their next chunk and re-raises."""
    import threading
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    stop = threading.Event()
    with ThreadPoolExecutor(max_workers=nthreads, thread_name_prefix="mjbench-run") as ex:
        pending = {ex.submit(task, i, None, stop) for i in range(N)}
        try:
            while pending:
                done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                for f in done:
                    f.result()
                    if progress is not None:
                        progress.update(1)
        except BaseException:
            stop.set()
            raise


def _compiled(program: Program):
    from .compiled import jit

    return jit.loop_for(program, _loop, _LOOP_SOURCE)


#: the loop's source as loaded (the compiled loop is generated from exactly the code CPython runs,
#: even if the file changes on disk while this process lives)
_LOOP_SOURCE = __import__("inspect").getsource(_loop)


def _message(backend, t, q, qd, I, V, hint=""):
    return (f"{backend + ' ' if backend else ''}simulation diverged at t = {t:.6g} s: input angle = {q:.6g} rad, "
            f"input speed = {qd:.6g} rad/s, current = {I:.6g} A, voltage = {V:.6g} V (limits |q̇| < "
            f"{MAX_SPEED:g} rad/s, |I| < {MAX_CURRENT:g} A, finite values). Reduce the time step or check "
            f"gains/parameters." + hint)
