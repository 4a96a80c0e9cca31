"""A run composed: each slot of the loop bound to the law its component declares.

Every component contributes its compiled form (:class:`mjbench.compiled.Form`): per axis the drive
(five laws: DLIMIT the applied command, DMEAN the step-mean current, DTORQUE the motor torque, DSTEP
the current update, DREC its recorded columns) and its drive-train elements (SENSE, CLOOP, AMP,
AMP_END, EFF), per axis a reference (REF), the controllers (CTRL), the plant (PLANT, READ, CLOSURE,
UNSTABLE, PWRITE).  The control laws (REF, CTRL) read and write named signals: each is called
through a wiring adapter (:mod:`mjbench.kernel.wiring`).  Absent optional elements are switched off
by constant flags.  Slot signatures:

* ``SENSE(t, q, q̇, q̈, I, δ, δ̇, P, S) → (q_m, q̇_m, q̈_m, I_m)`` (δ: compliant-gear deflection);
* ``REF(Y, P, S)``, ``CTRL(Y, P, S)``: the wiring adapters of the reference's and the controller's laws;
* ``CLOOP(n, i*, I, P, S) → V``; ``AMP(t, I, V, φ̇₀, P, S) → (Ī, I_end, V_bridge, I_min, I_max)``
  (averaged: ``→ V_bridge``); ``AMP_END(I_end, φ̇₀, φ̇̄, P) → I₊``; ``EFF(T_m, φ̇, P) → T``;
* the drive's ``DLIMIT(I, V, φ̇, P) → V_a``, ``DMEAN(I, V, φ̇, P) → Ī``, ``DTORQUE(Ī, φ̇, P) → T_m``,
  ``DSTEP(I, V, φ̇̄, P) → I₊``, ``DREC(out, b, I, V_a, φ̇, P)``; P has at least ``z``;
* ``PLANT(TAU, t, P, S, QO)``: one step with the axes' torques TAU held, the state after it into
  QO (q, q̇, δ, δ̇ per axis); ``READ(P, S, QO)`` the same at the start; ``CLOSURE(P, S) → m``;
  ``UNSTABLE(P, S) → bool``; ``PWRITE(out, b, P, S)`` the plant's recorded columns.

A law may take other laws as leading arguments (``Form.fn_args``); the slot is then that law with
those bound (:meth:`mjbench.compiled.Form.bound`, or a specialised copy in compiled code).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .. import compiled as C
from .. import signals as SIG
from ..compiled import contract
from ..control import controller_form, reference_form
from ..errors import ParameterError
from . import layout as LY
from . import wiring as W

#: co-steps from which a job is compiled when numba is not loaded yet, unless its plant states its
#: own (``Form.flags["min_steps"]``): the start-up (numba import + cached kernel load) against the
#: CPython loop's extra cost per co-step, measured in docs/performance.md
MIN_STEPS = 150_000

#: flags of one axis (each ``<FLAG>_<axis>`` in the loop's globals), with their "off" values
AXIS_FLAGS = {"HAS_SENSE": False, "HAS_REF": False, "HAS_DELAY": False, "HAS_CLOOP": False, "HAS_EFF": False,
              "AMP_MODE": 0, "SENSE_COLS": False, "AMP_COLS": False, "MINMAX_COLS": False, "IREF_COL": False}
#: flags of the whole run
FLAGS = {"HAS_CLOSURE": False, "HAS_UNSTABLE": False, "NEXTRA": 0}
#: slots of one axis, and of the run
AXIS_SLOTS = ("DMEAN", "DTORQUE", "DSTEP", "DREC", "DLIMIT", "SENSE", "REF", "CLOOP", "AMP", "AMP_END", "EFF")
RUN_SLOTS = ("PLANT", "CLOSURE", "UNSTABLE", "PWRITE")
#: drive-train columns of one axis, by flag
TRAIN_COLUMNS = (("SENSE_COLS", ("angle_meas_rad", "speed_est_rad_s", "accel_est_rad_s2")),
                 ("AMP_COLS", ("voltage_bridge_V", "current_mean_A")),
                 ("MINMAX_COLS", ("current_min_A", "current_max_A")),
                 ("IREF_COL", ("current_ref_A",)))

#: each record layout and its loop constants, by (axes, controllers, plant columns, drive-train columns, labels)
_LAYOUTS: dict = {}

#: the per-run constants of the loop
Run = namedtuple("Run", "h nsteps decim every ks out stats ncol nstat div y tau qo")
#: the slots' parameters and states of one run (per axis / per controller: tuples)
Parts = namedtuple("Parts", "drive sense_P sense_S ref_P ref_S ctrl_P ctrl_S cloop_P cloop_S amp_P amp_S eff_P "
                            "plant_P plant_S")


@C.law
def _absent(*args):  # a slot no run calls (its flag is off)
    return 0.0


_ABSENT = C.Form(_absent)
#: the state of an absent slot (never called, so never written: one array for every run)
_NO_STATE = np.zeros(0)


_BLANK: dict = {}


def _blank(naxes: int) -> tuple:
    """(slots, flags) of a program of ``naxes`` axes before its components bind them (every slot
    absent, every flag off): built once per number of axes, copied by each :class:`Program`."""
    hit = _BLANK.get(naxes)
    if hit is None:
        slots = {f"{s}_{a}": _ABSENT for a in range(naxes) for s in AXIS_SLOTS}
        slots.update({s: _ABSENT for s in RUN_SLOTS})
        flags = {f"{f}_{a}": v for a in range(naxes) for f, v in AXIS_FLAGS.items()}
        flags.update(FLAGS)
        hit = _BLANK[naxes] = (slots, flags)
    return hit


class _Key(tuple):
    """A composition's key (:attr:`Program.key`): a tuple that hashes once (the loop caches look it up
    several times per run; its wirings hash in Python).  Equal keys are one object (:data:`_KEYS`):
    a lookup then matches by identity."""

    def __new__(cls, items):
        k = super().__new__(cls, items)
        k._hash = tuple.__hash__(k)
        return k

    def __hash__(self):
        return self._hash

    def __reduce__(self):
        return _Key, (tuple(self),)


#: every composition key of this process once (bounded: a run whose laws are new functions has a new key)
_KEYS: dict = {}

_BARE: dict = {}


def _bare(law):
    """The form of a bare law (no parameters, no state): one per law (a slot's form is only read)."""
    hit = _BARE.get(id(law))
    if hit is None or hit[0] is not law:
        hit = _BARE[id(law)] = (law, C.Form(law))
    return hit[1]


def _ident(form) -> tuple:
    """A form's law and its function arguments' laws, nested, by identity (:attr:`Program.key`)."""
    if not form.fn_args:
        return id(form.law)
    return (id(form.law), tuple(_ident(f) for f in form.fn_args))


def _nested(pr) -> list:
    """Every form of a composition: its slots' and wired laws' forms and, nested, their function arguments."""
    stack = list(pr.slots.values()) + [f for f, _ in pr.wired.values()]
    out = []
    while stack:
        g = stack.pop()
        out.append(g)
        stack.extend(g.fn_args)
    return out


class Program:
    """One run composed: the form in each slot, the flags and layout constants, the parameters and
    states, the record's columns.

    Built from the machine's components (:meth:`build`); ``key`` identifies the composition (runs
    with the same key share one loop); ``compiled``: whether every slot compiles, else ``reasons``."""

    def __init__(self, naxes: int = 1, nctrl: int = 1):
        self.naxes, self.nctrl = naxes, nctrl
        slots, flags = _blank(naxes)
        self.slots = dict(slots)
        self.wired: dict = {}  # slot → (form, Wiring): the control laws, called through adapters
        self.flags = dict(flags)
        self.reasons: list[str] = []
        self.broken: list[str] = []  # laws that break the contract (numba cannot compile them)
        self.forms: dict = {}
        self.drive_P: list = [C.NO_PARAMS] * naxes
        self.signals0 = np.zeros(SIG.size(naxes))
        self.columns: tuple = ()
        self.stat_columns: tuple = ()
        self.u_lim = [(-math.inf, math.inf)] * naxes
        self.every = 1  # the control sample in co-steps (:meth:`build`'s)

    # ------------------------------------------------------------------ assembly
    def use(self, slot: str, form, why: str = ""):
        """Bind ``slot`` to ``form`` (a Form, or a bare law)."""
        if not isinstance(form, C.Form):
            form = _bare(form)
        self.slots[slot] = form
        if not form.compiled:
            self.reasons.append(f"{why or slot.lower()}: {form.reason}")

    def wire(self, slot: str, form, axis: int, outputs: tuple, why: str):
        """Bind the control-law slot ``slot`` to ``form`` through its signal wiring on ``axis``, after
        checking the law's contract (:mod:`mjbench.compiled.contract`: a law that cannot run is an
        error naming it; one numba cannot compile runs in CPython, and the run says why)."""
        what = form.what or why
        if getattr(form.law, "__mjbench_law__", False):
            v = contract.check(form.law, form.P, form.S0, len(form.fn_args), what)
            if v.fatal:
                raise ParameterError(v.fatal)
            if v.not_compilable and form.compiled:
                form.compiled, form.reason = False, v.not_compilable
                self.broken.append(v.not_compilable)
        self.wired[slot] = (form, W.wire(form, axis, self.naxes, outputs, what))
        if not form.compiled:
            self.reasons.append(form.reason if form.reason.startswith(what) else f"{what}: {form.reason}")

    @classmethod
    def build(cls, plant, machine, h: float, every: int) -> "Program":
        """Compose a run of ``machine`` on ``plant`` at step h with the controllers sampled every
        ``every`` steps: every component contributes its form (``form(...)`` methods)."""
        drives = machine.drives
        pr = cls(len(drives), 0)
        pr.every = every
        parts: dict = {}
        train_cols = []
        for a, drive in enumerate(drives):
            train_cols.append(pr._axis(a, drive, plant, h, every, parts))
        cforms = [(ctrl, axis, controller_form(ctrl, h, every, machine)) for ctrl, axis in machine.controllers]
        # a controller's child "then": a law in a control slot of its own, run right after the controller on
        # its axis (it reads and writes the axis's signals: frest's excitation adds d[k] to u)
        pr.nctrl = sum(1 + ("then" in cf.children) for _, _, cf in cforms)
        c = 0
        for ctrl, axis, cf in cforms:
            pr.wire(f"CTRL_{c}", cf, axis, SIG.CONTROLLER_OUTPUTS,
                    f"controller {getattr(ctrl, 'type_name', '') or type(ctrl).__name__!r}")
            parts[f"ctrl_{c}"] = cf
            c += 1
            then = cf.children.get("then")
            if then is not None:
                pr.wire(f"CTRL_{c}", then, axis, SIG.CONTROLLER_OUTPUTS, then.what or "controller's next law")
                parts[f"ctrl_{c}"] = then
                c += 1
            refs = {}
            ref = cf.children.get("reference")
            if ref is not None:
                refs[axis] = (ref, type(getattr(ctrl, "reference", None)).__name__)
            per_axis = getattr(ctrl, "axis_references", None)  # one controller for all axes: one per axis
            if per_axis is not None:
                for a, r in enumerate(per_axis(pr.naxes)):
                    refs[a] = (reference_form(r, h * every, float(drives[a].z)), type(r).__name__)
            for a, (form, name) in refs.items():
                if pr.flags[f"HAS_REF_{a}"]:
                    raise ParameterError(f"axis {a} has two references (one per axis)")
                pr.flags[f"HAS_REF_{a}"] = True
                pr.wire(f"REF_{a}", form, a, SIG.REFERENCE_OUTPUTS, f"reference {name}")
                parts[f"ref_{a}"] = form
        for a in range(pr.naxes):
            if f"REF_{a}" not in pr.wired:
                pr.wired[f"REF_{a}"] = (_ABSENT, None)
        pf = plant.form()  # the plant
        pr.use("PLANT", pf, "plant")
        for slot, name in (("CLOSURE", "closure"), ("UNSTABLE", "unstable"), ("PWRITE", "write")):
            if name in pf.laws:  # the plant's further laws take the plant's (P, S)
                pr.use(slot, pf.laws[name], f"plant {name}")
        pr.flags["HAS_CLOSURE"] = "closure" in pf.laws
        pr.flags["HAS_UNSTABLE"] = "unstable" in pf.laws
        pr.flags["NEXTRA"] = int(pf.flags.get("nextra", 0))
        # co-steps from which compiling pays: the plant's, or less when any component's law (or a model it
        # evaluates) declares that its CPython evaluation costs more (a multi-input model's table)
        pr.min_steps = min([int(pf.flags.get("min_steps", MIN_STEPS))]
                           + [int(g.flags["min_steps"]) for g in _nested(pr) if "min_steps" in g.flags])
        pr.read = pf.laws["read"]
        parts["plant"] = pf
        pr.forms = parts
        if len(plant.extra_columns) != pr.flags["NEXTRA"]:
            raise ParameterError(f"plant declares {len(plant.extra_columns)} extra columns but writes "
                                 f"{pr.flags['NEXTRA']}")
        labels = getattr(machine, "axis_labels", None)
        key = (pr.naxes, pr.nctrl, tuple(plant.extra_columns), tuple(map(tuple, train_cols)), tuple(labels or ()))
        if key not in _LAYOUTS:  # (one per record layout: a sweep composes a run per row)
            lay = LY.RecordLayout(pr.naxes, plant.extra_columns, train_cols, labels)
            _LAYOUTS[key] = lay, LY.constants(pr.naxes, pr.nctrl, lay)
        lay, consts = _LAYOUTS[key]
        pr.layout = lay
        pr.columns, pr.stat_columns = lay.columns, lay.stats
        # (the key names the layout instead of its ≈ 70 constants, which follow from it)
        pr._keyed_flags = (key, tuple(pr.flags.items()))
        pr.flags.update(consts)
        return pr

    def _axis(self, a: int, drive, plant, h: float, every: int, parts: dict) -> list:
        """Bind axis ``a``'s drive and drive-train elements; → its drive-train column names."""
        df = drive.form(h)  # the drive's laws: limit, step-mean current, motor torque, current update, record
        self.drive_P[a] = df.P
        for slot, name in (("DMEAN", "mean"), ("DTORQUE", "torque"), ("DSTEP", "step"), ("DREC", "record"),
                           ("DLIMIT", "limit")):
            self.use(f"{slot}_{a}", df.laws[name], "drive")
        dforms = drive.forms(h, every, plant)  # the drive train's elements (empty: ideal)
        lim = dforms.get("limit")  # the controller output's clip: the drive train's, else ±v_max
        v_max = float(getattr(drive, "v_max", math.inf))
        self.u_lim[a] = lim if lim is not None else (-v_max, v_max)
        y = self.signals0
        y[SIG.index("u_min", a)], y[SIG.index("u_max", a)] = (float(v) for v in self.u_lim[a])
        y[SIG.index("v_max", a)] = v_max
        y[SIG.index("i_max", a)] = float(getattr(drive, "i_max", math.inf))
        y[SIG.index("z", a)] = float(drive.z)
        f = self.flags
        sen = dforms.get("sense")
        if sen is not None:
            f[f"HAS_SENSE_{a}"] = f[f"SENSE_COLS_{a}"] = True
            self.use(f"SENSE_{a}", sen, "sensor")
            parts[f"sense_{a}"] = sen
        if dforms.get("sense_cols"):
            f[f"SENSE_COLS_{a}"] = True
        f[f"HAS_DELAY_{a}"] = bool(dforms.get("delay"))
        cl = dforms.get("cloop")
        if cl is not None:
            f[f"HAS_CLOOP_{a}"] = f[f"IREF_COL_{a}"] = True
            self.use(f"CLOOP_{a}", cl, "current loop")
            parts[f"cloop_{a}"] = cl
        amp = dforms.get("amp")
        if amp is not None:
            f[f"AMP_MODE_{a}"] = 2 if amp.flags.get("switching") else 1
            f[f"AMP_COLS_{a}"] = True
            f[f"MINMAX_COLS_{a}"] = bool(amp.flags.get("switching"))
            self.use(f"AMP_{a}", amp, "amplifier")
            if "end" in amp.laws:
                self.use(f"AMP_END_{a}", amp.laws["end"])
            parts[f"amp_{a}"] = amp
        eff = dforms.get("eff")
        if eff is not None:
            f[f"HAS_EFF_{a}"] = True
            self.use(f"EFF_{a}", eff, "gear efficiency")
            parts[f"eff_{a}"] = eff
        cols = []
        for flag, names in TRAIN_COLUMNS:
            if f[f"{flag}_{a}"]:
                cols += list(names)
        return cols

    @property
    def compiled(self) -> bool:
        return not self.reasons

    @property
    def key(self) -> tuple:
        """The composition: the slot laws' function objects (each slot's law and, nested, its function
        arguments' laws, by identity: the laws of a cached loop are kept alive, so their ids stay
        unique), the control laws' wirings and the flags.  Runs with the same key share one loop;
        computed once (the slots do not change after :meth:`build`).

        The slots and flags are listed in their dicts' order: every program starts from the same blank
        dicts (:func:`_blank`) and binds them in :meth:`build`'s order, so equal compositions list them
        alike (a different order could only cost a second loop, never a wrong one).  The flags are the
        components' own and the record layout's key: the layout's constants follow from it."""
        k = self.__dict__.get("_key")
        if k is None:
            flags = self.__dict__.get("_keyed_flags") or tuple(sorted(self.flags.items()))
            k = _Key((self.naxes, self.nctrl, tuple((s, _ident(f)) for s, f in self.slots.items()),
                      tuple((s, _ident(f), w) for s, (f, w) in sorted(self.wired.items())), flags))
            if len(_KEYS) > 256:
                _KEYS.clear()
            k = self._key = _KEYS.setdefault(k, k)
        return k

    @property
    def twins(self) -> tuple:
        """The CPython twins in this composition's slots (:attr:`mjbench.compiled.Form.python`): a
        CPython loop that holds one belongs to this run alone (computed once)."""
        t = self.__dict__.get("_twins")
        if t is None:
            forms = list(self.slots.values()) + [f for f, _ in self.wired.values()]
            t = self._twins = tuple(tw for f in forms for tw in f.twins)
        return t

    def loop_key(self, mode: str):
        """The key under which runs share a loop of ``mode``: :attr:`key`, or this program alone when
        its CPython loop holds twins."""
        return (self.key, id(self)) if mode == "python" and self.twins else self.key

    def law_frames(self) -> dict:
        """{code object: (component, law name)} of every law of the composition (error messages)."""
        out = {}
        forms = [(s, f) for s, f in self.slots.items()] + [(s, f) for s, (f, _) in self.wired.items()]
        for s, f in forms:
            stack = [f]
            while stack:
                g = stack.pop()
                stack.extend(g.fn_args)
                code = getattr(g.law, "__code__", None)
                if code is not None and getattr(g.law, "__mjbench_law__", False):
                    out[code] = (f.what or s.split("_")[0].lower(), f"{g.law.__module__}.{g.law.__qualname__}")
        return out

    def env(self) -> dict:
        """Globals of the CPython loop for this composition (flags, constants, slot functions and
        the control laws' wiring adapters)."""
        env = {**self.flags, **{s: f.bound() for s, f in self.slots.items()}}
        for s, (f, w) in self.wired.items():
            env[s] = f.bound() if w is None else W.python_adapter(s, f.bound(), w)
        return env

    # ------------------------------------------------------------------ per-run values
    def parts(self, python: bool):
        """The slots' parameters and fresh states of one run (memoryviews for CPython)."""
        f = self.forms
        view = C.python_view if python else (lambda x: x)

        def P(name):
            return view(f[name].P) if name in f else C.NO_PARAMS

        def S(name):  # (CPython: a memoryview — a law may hand its state to a law writing through slices)
            return view(f[name].state() if name in f else _NO_STATE)

        ax = range(self.naxes)
        return Parts(tuple(view(p) for p in self.drive_P), tuple(P(f"sense_{a}") for a in ax),
                     tuple(S(f"sense_{a}") for a in ax), tuple(P(f"ref_{a}") for a in ax),
                     tuple(S(f"ref_{a}") for a in ax), tuple(P(f"ctrl_{c}") for c in range(self.nctrl)),
                     tuple(S(f"ctrl_{c}") for c in range(self.nctrl)), tuple(P(f"cloop_{a}") for a in ax),
                     tuple(S(f"cloop_{a}") for a in ax), tuple(P(f"amp_{a}") for a in ax),
                     tuple(S(f"amp_{a}") for a in ax), tuple(P(f"eff_{a}") for a in ax), P("plant"), S("plant"))


__all__ = ["Program", "Run", "Parts", "MIN_STEPS", "AXIS_FLAGS", "FLAGS", "AXIS_SLOTS", "RUN_SLOTS"]
