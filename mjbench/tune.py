"""Controller autotuning: search on the cheap model, verify on MuJoCo (seed 000 §IV: "minimise χ over K_p, K_i, K_d").

Stages
1. **Global**: ``n_global`` candidate gain sets — a scrambled Sobol sequence over the log-scaled
   box (default: each gain within ×/÷ ``span`` = 10 of the scenario's gains) plus the scenario's
   own gains — simulated together on the search backend's batch (chunks of ``batch_size``).
2. **Local**: Nelder–Mead (``scipy.optimize.minimize``) in the log-gains from the best global
   candidates (``starts``), each evaluation one single run on the search backend; bounded by
   ``maxfev`` evaluations per start.  Nelder–Mead because χ is a max−min of a sampled signal:
   piecewise smooth, no useful gradient.
3. **Verification**: the ``verify`` best distinct candidates (local winners first, then the best
   global ones) re-simulated together on the multibody backend (:mod:`mjbench.backends.batch`:
   independent runs, the same numbers as single runs); the winner is the best *verified*
   candidate, and it and the scenario's gains are then run by the single-run
   ``multibody.simulate``.  The report states the search figure, the MuJoCo figure and their
   difference.

Search backend (``backend``): ``reduced`` (default; the reduced model, batched by
:mod:`mjbench.backends.reduced_batch`; every run, the sequential Nelder–Mead stage's single runs
included, executes the compiled co-step loop of :mod:`mjbench.kernel` — loaded up front by
:func:`mjbench.kernel.preload` when the planned co-steps pay numba's start-up — with the same bits
as the CPython loop, ≈ 0.05 µs per co-step, ≈ 1/180 of a MuJoCo co-step; docs/performance.md) or
``multibody`` (search on MuJoCo itself; the verification then repeats the search's numbers).

Objective (minimised, penalised): the metric plus 10 × the relative excess of the peak |voltage|
and peak |current| over their limits (``--limit voltage=V,current=A``; default: the peaks of the
scenario's own gains on the search backend, so a tuned controller may not draw more than the
paper's); a diverged run scores 1e3.  Metrics: ``chi`` (χ, Eq 22, on the scenario's
``metrics.chi_window``), ``chi_cycle`` (χ of the last complete crank cycle), ``ise``/``iae``/``itae``
(∫e², ∫|e|, ∫t|e| of the crank-speed error to the set-point over the run, [rad²/s], [rad], [rad·s]),
``tracking_rms``/``tracking_peak`` (RMS / peak of the crank-angle error q_ref − q to the
controller's motion-law reference [rad] — a law repeated per cycle included, the reference's own
law evaluated at the record's times — over ``metrics.chi_window`` when the scenario sets one,
else over the whole run).

Margin constraints (``--margin 'pm>=45' --margin 'ms<=2'``, quoted for the shell; keys pm [deg], gm [dB], ms = peak |S|,
bw [rad/s]): evaluated on the linear model (:mod:`mjbench.linear`) — the candidate's controller
counterpart closed around the reduced plant at ``margin_angles`` frozen angles over one turn at
the running speed, worst case over the angles, K_p·t frozen at the end of the run (the largest
gain).  ``margin_mode = "penalty"`` (default): the objective gets PENALTY × Σ relative violation
(each capped at 1), like the peak limits; ``"constraint"``: a violating candidate is not simulated
and scores DIVERGED × (1 + violation) — a hard constraint that also saves its simulation.

Controllers: every controller type whose class declares its tunable gains
(``Controller.TUNABLE`` = {gain: admissible interval}, optional ``TUNE_VARIANTS``;
:func:`tunable_controllers`), plugins included.  Built in: ``pid`` (constant K_p), ``pid-tv``
(K_p·t, Eq 15; the paper's), ``smc`` (sliding mode, controllers/smc.py, seed 004: λ and K),
``servo`` (the cascade servo tracking a motion law, controllers/servo.py: K_pp, K_vp, K_vi; its
feed-forward gains are kept).  Run length: the end of the χ window (0.5 s for seed 000), else the
scenario's ``simulation.t_end``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from . import metrics as M
from . import scenario as S
from .control import REGISTRY as CONTROLLERS
from .errors import MjbenchError, ParameterError, ScenarioError
from .linear import parse_margin
from . import kernel
from .linear import MARGIN_KEYS
from .backends import SEARCH_BACKENDS
from .runner import backend_options
from . import linear
from .machine import Machine
from .backends import simulate_many
from .errors import SimulationDiverged
from .backends import simulate


@dataclass(frozen=True)
class TuneSpec:
    """What ``tune --controller NAME`` tunes, from the controller class's declaration
    (:attr:`controllers.base.Controller.TUNABLE`, ``TUNE_VARIANTS``): the controller type of the
    scenario's mode, the gains (declaration order), the settings held fixed, and each gain's
    admissible interval (lo, hi)."""

    name: str
    ctype: str
    params: tuple
    fixed: dict
    intervals: dict


def declared_specs(cls) -> dict:
    """{tune name: TuneSpec} declared by one controller class (none without ``TUNABLE``); a
    ParameterError when the declaration names no field of its Params or a bad interval."""
    gains = {k: (float(lo), float(hi)) for k, (lo, hi) in dict(getattr(cls, "TUNABLE", None) or {}).items()}
    if not gains:
        return {}
    for k, (lo, hi) in gains.items():
        if k not in cls.Params.model_fields or not (0.0 <= lo < hi):
            raise ParameterError(f"{cls.__module__}.{cls.__qualname__}.TUNABLE[{k!r}] = ({lo:g}, {hi:g}): needs a field "
                                 f"of its Params and 0 <= lo < hi")
    variants = dict(getattr(cls, "TUNE_VARIANTS", None) or {cls.type_name: {}})
    return {name: TuneSpec(name, cls.type_name, tuple(gains), dict(fixed), gains) for name, fixed in variants.items()}


def tunable_controllers() -> dict:
    """{``tune --controller`` name: :class:`TuneSpec`} of every controller type that declares
    tunable gains: the built-in ones (pid, pid-tv, smc, servo) and the plugins' (every
    controller type is imported)."""
    out = {}
    for typ in CONTROLLERS.names():
        out.update(declared_specs(CONTROLLERS.get(typ)))
    return out


def tune_spec(name: str) -> TuneSpec:
    """The :class:`TuneSpec` of ``tune --controller NAME`` (a type name, or a declared variant such
    as ``pid-tv``); a ParameterError naming the choices otherwise."""
    cls = CONTROLLERS.get(name)
    specs = declared_specs(cls) if cls is not None else {}
    if name in specs:
        return specs[name]
    specs = tunable_controllers()
    if name in specs:
        return specs[name]
    why = ("its class declares no tunable gains (Controller.TUNABLE)" if cls is not None
           else "no controller type or tuning variant of that name")
    raise ParameterError(f"controller {name!r}: {why}; the tunable ones: {', '.join(specs)}")


#: a machine with several motors following a [path]: the end effector's RMS / largest distance from
#: the path [m] over the run (after ``metrics.settle_time``)
MULTI_OBJECTIVES = ("ee_rms", "ee_max")
OBJECTIVES = ("chi", "chi_cycle", "ise", "iae", "itae", "tracking_rms", "tracking_peak") + MULTI_OBJECTIVES


def several_motors(scn) -> bool:
    """Whether the scenario's machine has several motors (``mechanism.inputs``: read, not built)."""
    return len(scn.axes) > 1


def default_objective(scn) -> str:
    """``chi`` (one motor), ``ee_rms`` (several: the end effector's tracking of its path)."""
    return "ee_rms" if several_motors(scn) else "chi"
#: objectives measured against the controller's reference angle (a motion law, repeated or not)
TRACKING = ("tracking_rms", "tracking_peak")
PENALTY = 10.0
DIVERGED = 1e3


@dataclass
class TuneResult:
    controller: str
    objective: str
    mode: str
    params: list
    best: dict                       # gains of the winner
    baseline: dict                   # the scenario's gains
    validation: dict                 # {"tuned": metrics, "baseline": metrics} (single multibody runs)
    limits: dict
    history: dict = field(default_factory=dict)
    backend: str = "multibody"       # search backend
    search: dict = field(default_factory=dict)   # {"tuned": metrics, "baseline": metrics} on the search backend
    verified: list = field(default_factory=list)  # best candidates: gains, search and multibody scores
    margins: list = field(default_factory=list)  # [(key, op, value)] constraints

    @property
    def improvement(self):
        """Relative reduction of the objective metric vs the scenario's gains (validated)."""
        a, b = self.validation["baseline"]["objective"], self.validation["tuned"]["objective"]
        return (a - b) / a if a else float("nan")


def find_mode(scn, ctype):
    modes = {k: v for k, v in scn.modes.items() if v.type == ctype}
    if not modes:
        raise ScenarioError(f"scenario {scn.name!r} has no mode of controller type "
                            f"{ctype!r}; modes: {S.modes(scn)}")
    return ctype if ctype in modes else sorted(modes)[0]


class Problem:
    """Evaluates gain sets (arrays in the parameter order) on the batch."""

    def __init__(self, scn, controller, objective="chi", limits=None, t_end=None, nthread=0, batch_size=64,
                 backend="multibody", margins=(), margin_mode="penalty", margin_angles=12):

        if backend not in SEARCH_BACKENDS:
            raise ParameterError(f"--backend {backend!r}: choose one of {list(SEARCH_BACKENDS)}")
        spec = tune_spec(controller)
        objective = default_objective(scn) if objective is None else objective
        if objective not in OBJECTIVES:
            raise ParameterError(f"--objective {objective!r}: choose one of {list(OBJECTIVES)}")
        self.multi = several_motors(scn)
        if self.multi and objective not in MULTI_OBJECTIVES:
            raise ParameterError(f"--objective {objective}: a machine with several motors is tuned on its end "
                                 f"effector's tracking of the path: choose {' or '.join(MULTI_OBJECTIVES)}")
        if not self.multi and objective in MULTI_OBJECTIVES:
            raise ParameterError(f"--objective {objective}: the end effector's tracking is for a machine with "
                                 f"several motors following a [path]; scenario {scn.name!r} has one motor")
        if self.multi and any(str(m).strip().startswith("bw") for m in margins):
            raise ParameterError("--margin bw: a machine with several motors has no speed-loop bandwidth; bound pm, "
                                 "gm (each axis's loop at a time, the others closed) or ms (‖S‖∞ of the MIMO loop)")
        ctype, self.params, fixed, self.intervals = spec.ctype, spec.params, spec.fixed, spec.intervals
        self.scn = scn
        self.mode = find_mode(scn, ctype)
        self.base_params = scn.modes[self.mode]  # the scenario's own controller (baseline)
        self.tuned_params = self.base_params.model_copy(update=fixed)
        self._fixed = dict(fixed)
        # [modes.NAME.axes.JOINT]: an axis keeps its own keys, but the searched gains are one set for every axis
        axes_raw = ((scn.raw.get("modes") or {}).get(self.mode) or {}).get("axes") or {}
        for joint, table in axes_raw.items():
            clash = sorted(set(table) & set(self.params)) if isinstance(table, dict) else []
            if clash:
                raise ParameterError(f"tune: modes.{self.mode}.axes.{joint} sets {', '.join(clash)}: tune searches one "
                                     f"set of {', '.join(self.params)} for every axis; remove the axis's own value")
        self.controller, self.objective = controller, objective
        self.x0 = np.array([float(getattr(self.tuned_params, p)) for p in self.params])
        self.window = scn.metrics.chi_window
        self.average = scn.metrics.chi_average
        if objective == "chi" and not self.window:
            raise ParameterError("--objective chi needs metrics.chi_window in the scenario (or use chi_cycle)")
        if t_end is None:
            t_end = float(self.window[1]) if (self.window and objective == "chi") else scn.simulation.t_end
        self.t_end = float(t_end)
        self.record_dt = min(scn.simulation.record_dt, 5e-4)
        self.backend = backend
        self.mb_options = backend_options(self.scn, "multibody")
        self.options = backend_options(self.scn, backend)
        if backend == "reduced":
            self.options["method"] = "rk4"  # the batched reduced model's integrator
        self.nthread, self.batch_size = nthread, batch_size
        base = S.make_machine(scn, self.mode)
        self._refs = linear.multi.path_references(base) if self.multi else None
        if self.multi and self._refs is None:
            raise ParameterError(f"tune: mode {self.mode!r} follows no [path]: a machine with several motors is tuned "
                                 f"on its end effector's tracking of the path")
        sp = None if self.multi else base.controller.setpoint(base)  # the controller's speed on both shafts
        self.setpoint = None if sp is None else float(sp["input_rad_s"])  # crank side [rad/s]
        self.limits = dict(limits or {})
        self.nfev = 0
        self._plant = None
        self._ref_angle = None
        if objective in TRACKING:
            ref = getattr(self.machine(self.x0).controller, "reference", None)
            if getattr(ref, "reference_angle", None) is None:
                raise ParameterError(f"--objective {objective} needs a controller that tracks a motion law (a [law] "
                                     f"reference); mode {self.mode!r} has {type(ref).__name__ if ref else 'none'}")
            self._ref_angle = ref.reference_angle
        if margin_mode not in ("penalty", "constraint"):
            raise ParameterError(f"--margin-mode {margin_mode!r}: choose penalty or constraint")
        self.margins = [c if isinstance(c, tuple) else _parse_margin(c) for c in margins]
        self.margin_mode = margin_mode
        self._plants = None
        if self.margins:
            m0 = self.machine(self.x0)
            if self.multi:  # the MIMO loop at the path's point where the inputs move fastest
                h = float(scn.simulation.dt)
                op = linear.path_operating_point(m0)
                A, B = linear.reduced_mechanics_n(m0, op)
                N = linear.multi._period(m0, h)
                self._plants = (op, linear.sample_n(linear.plant_n(A, B, m0.drives, m0.axis_labels, h=h), N,
                                                    m0.axis_labels))
            else:
                self._plants = linear.plant_family(m0, float(scn.simulation.dt), margin_angles, t=self.t_end)
            self._with_bw = any(k == "bw" for k, _, _ in self.margins)
            self.linear_margins(self.x0)  # fails early (e.g. SMC without boundary layer)

    # ------------------------------------------------------------------ evaluation
    def machine(self, x, params=None):
        """The scenario's machine with the controller gains x (or the controller ``params``)."""

        if params is None:
            params = self.tuned_params.model_copy(update={p: float(v) for p, v in zip(self.params, x)})
            for p, v in zip(self.params, x):
                lo, hi = self.intervals[p]
                if not (math.isfinite(float(v)) and lo <= float(v) <= hi):
                    raise ParameterError(f"tune: {p} = {v!r} is not a valid gain (admissible: {lo:g} ... {hi:g})")
        scn = self.scn
        if self._plant is None:  # the gains change, the mechanism and drive do not: build them once
            mech = S.make_mechanism(scn)
            drives = ([(scn.drives.get(nm) or scn.drive).build() for nm in mech.input_joints] if self.multi
                      else S.make_drive(scn))
            self._plant = mech, drives
        mech, drive = self._plant
        if self.multi:
            return self._multi_machine(params, mech, drive)
        ctrl = CONTROLLERS.build(params, drive=drive, mechanism=mech, scenario=scn)
        return Machine(mech, drive, ctrl, q0=scn.initial.q0, qd0=scn.initial.qd0, I0=scn.initial.I0)

    def _multi_machine(self, params, mech, drives):
        """A machine with several motors and the controller ``params`` (:func:`mjbench.scenario.multi_machine`):
        the searched gains on every axis, over an axis's own ``[modes.NAME.axes.JOINT]`` keys."""
        tuned = {p: getattr(params, p) for p in (*self.params, *self._fixed)}
        own = {j: ax.model_copy(update=tuned) for j, ax in self.scn.mode_axes.get(self.mode, {}).items()}
        return S.multi_machine(self.scn, mech, drives, params, own)

    def metrics(self, tr):
        if self.multi:  # the worst axis's peaks; the end effector's distance from its path
            ax = [tr.axis(lab) for lab in tr.axes]
            out = {"peak_voltage_V": max(float(np.max(np.abs(a.voltage))) for a in ax),
                   "peak_current_A": max(float(np.max(np.abs(a.current))) for a in ax)}
            ee = self._refs.metrics(tr, _MechanismOnly(self._plant[0]),
                                    self.scn.metrics)["end_effector"]
            out.update(ee_rms=ee["rms_error_m"], ee_max=ee["max_error_m"])
            return out
        t, om = tr.t, tr.omega
        out = {"peak_voltage_V": float(np.max(np.abs(tr.voltage))),
               "peak_current_A": float(np.max(np.abs(tr.current)))}
        if self.window and t[-1] >= self.window[1] - 1e-9:
            out["chi"] = M.chi(t, om, self.window[0], self.window[1], self.average)
        _, vals = M.chi_per_cycle(t, tr.q, om, self.average)
        if len(vals):
            out["chi_cycle"] = float(vals[-1])
        if self._ref_angle is not None:  # crank-angle error to the motion-law reference
            sel = (t >= self.window[0] - 1e-12) & (t <= self.window[1] + 1e-12) if self.window else slice(None)
            e = self._ref_angle(t[sel]) / float(self._plant[1].z) - tr.q[sel]
            out["tracking_rms"] = float(np.sqrt(np.mean(e * e))) if e.size else float("nan")
            out["tracking_peak"] = float(np.max(np.abs(e))) if e.size else float("nan")
        if self.setpoint is not None:
            e = self.setpoint - tr.qd
            out["ise"] = float(np.trapezoid(e * e, t))
            out["iae"] = float(np.trapezoid(np.abs(e), t))
            out["itae"] = float(np.trapezoid(t * np.abs(e), t))
        return out

    def linear_margins(self, x=None, params=None) -> dict:
        """Worst-case frozen-angle margins of gains x (linear model) and their violation."""

        if not self.margins:
            return {}
        mach = self.machine(x, params)
        if self.multi:
            op, P_T = self._plants
            mg = linear.margins_n(linear.loop_n(P_T, linear.controller_n(mach, op, float(self.scn.simulation.dt)),
                                                mach.axis_labels))
            axes = mg["loop_at_a_time"].values()
            w = {"phase_margin_deg": min(a["phase_margin_deg"] for a in axes),
                 "gain_margin_dB": min(a["gain_margin_dB"] for a in axes),
                 "peak_sensitivity": mg["mimo_sensitivity_peak"], "bandwidth_rad_s": float("nan"),
                 "all_stable": mg["stable"]}
        else:
            w = linear.family_margins(mach, self._plants, float(self.scn.simulation.dt), self._with_bw)
        w["violation"] = linear.margin_violation(w, self.margins)
        return w

    def score(self, m):
        if m is None or self.objective not in m or not np.isfinite(m[self.objective]):
            return DIVERGED
        pen = 0.0
        if self.margins and "margins" in m:
            pen += m["margins"]["violation"]
        for key, lim in (("peak_voltage_V", self.limits.get("voltage")), ("peak_current_A", self.limits.get("current"))):
            if lim is not None:
                pen += max(0.0, m[key] / lim - 1.0)
        return float(m[self.objective] + PENALTY * pen)

    def evaluate(self, X, backend=None):
        """Objective of every gain set in X (n, nparam) → (scores, metrics list), batched on the
        search backend (or ``backend``)."""

        backend = backend or self.backend
        X = np.atleast_2d(X)
        scores, mets = np.full(len(X), DIVERGED), [None] * len(X)
        if len(X) == 1:  # one simulation: the single-run loop (same numbers, less overhead)
            if self.margins and self.margin_mode == "constraint":
                try:
                    lin = self.linear_margins(X[0])
                except (MjbenchError, ValueError):
                    lin = None
                if lin is None or lin["violation"] > 0:
                    self.nfev += 1
                    scores[0] = DIVERGED * (1.0 + (lin["violation"] if lin else 1.0))
                    return scores, [{"margins": lin} if lin else None]
            try:
                m, _ = self.run(X[0], backend=backend)
                mets[0] = m
                scores[0] = m["score"]
            except (SimulationDiverged, MjbenchError, ValueError):
                pass
            self.nfev += 1
            return scores, mets
        opts = self.options if backend == self.backend else self.mb_options
        lin = [None] * len(X)
        if self.margins:
            for i in range(len(X)):
                try:
                    lin[i] = self.linear_margins(X[i])
                except (MjbenchError, ValueError):
                    lin[i] = None
        for s in range(0, len(X), self.batch_size):
            idx = range(s, min(len(X), s + self.batch_size))
            machines, ok = [], []
            for i in idx:
                if self.margins and self.margin_mode == "constraint" and (lin[i] is None or lin[i]["violation"] > 0):
                    scores[i] = DIVERGED * (1.0 + (lin[i]["violation"] if lin[i] else 1.0))
                    mets[i] = {"margins": lin[i]} if lin[i] else None
                    continue
                try:
                    machines.append(self.machine(X[i]))
                    ok.append(i)
                except (MjbenchError, ValueError):
                    pass
            if not machines:
                continue
            res = simulate_many(machines, backend, self.t_end, record_dt=self.record_dt, options=opts,
                                nthread=self.nthread)
            for j, i in enumerate(ok):
                if not res.diverged[j]:
                    try:
                        mets[i] = self.metrics(res.trajectory(j))
                        mets[i]["objective"] = mets[i].get(self.objective, float("nan"))
                    except MjbenchError:
                        mets[i] = None
                if mets[i] is not None and lin[i] is not None:
                    mets[i]["margins"] = lin[i]
                scores[i] = self.score(mets[i])
                if mets[i] is not None:
                    mets[i]["score"] = scores[i]
        self.nfev += len(X)
        return scores, mets

    def run(self, x, baseline=False, backend=None):
        """Single run of gains x (``baseline``: the scenario's controller as written, e.g. K_p·t
        when tuning a constant-K_p PID) on the search backend (or ``backend``) → metrics + objective."""

        backend = backend or self.backend
        opts = self.options if backend == self.backend else self.mb_options
        machine = self.machine(None, self.base_params) if baseline else self.machine(x)
        lin = None
        if self.margins:
            lin = self.linear_margins(None, self.base_params) if baseline else self.linear_margins(x)
        tr = simulate(machine, backend, self.t_end, record_dt=self.record_dt, options=dict(opts))
        m = self.metrics(tr)
        if lin is not None:
            m["margins"] = lin
        m["objective"] = m.get(self.objective, float("nan"))
        m["score"] = self.score(m)
        return m, tr

    def validate(self, x, baseline=False):
        """Single-run multibody simulation of gains x (the verification) → metrics + objective."""
        return self.run(x, baseline, backend="multibody")


class _MechanismOnly:
    """What the path's tracking metric reads of a machine: its mechanism."""

    def __init__(self, mechanism):
        self.mechanism = mechanism


def _parse_margin(text):
    return parse_margin(text)


def tune(scn, controller="pid-tv", objective=None, limits=None, n_global=64, starts=1, maxfev=80,
         span=10.0, bounds=None, seed=0, t_end=None, nthread=0, batch_size=64, log=print,
         backend="reduced", verify=3, margins=(), margin_mode="penalty", margin_angles=12) -> TuneResult:
    """Global (batched Sobol) + local (Nelder–Mead) search of the controller gains on ``backend``,
    then the ``verify`` best candidates on MuJoCo; see the module doc."""
    t0 = time.perf_counter()
    prob = Problem(scn, controller, objective, limits, t_end, nthread, batch_size, backend=backend, margins=margins,
                   margin_mode=margin_mode, margin_angles=margin_angles)
    search_box(prob.params, prob.x0, span, bounds, prob.intervals)  # bad bounds: one message before any simulation
    if backend == "reduced":  # the compiled co-step (numba, same bits) when the planned work pays for loading it
        h = float(prob.options.get("timestep", scn.simulation.dt))
        kernel.preload((n_global + 3 + max(0, starts) * maxfev) * prob.t_end / h)
    base_m, _ = prob.run(prob.x0, baseline=True)
    lim = dict(limits or {})
    lim.setdefault("voltage", base_m["peak_voltage_V"])
    lim.setdefault("current", base_m["peak_current_A"])
    prob.limits = lim
    base_m["score"] = prob.score(base_m)
    lo, hi = search_box(prob.params, prob.x0, span, bounds, prob.intervals)
    X, scores, order = _global_stage(prob, lo, hi, n_global, seed, log, t0)
    hist = {"global_X": X.tolist(), "global_scores": scores.tolist(), "local": []}
    best_x, best_s = X[order[0]].copy(), float(scores[order[0]])
    cands, best_x, best_s = _local_stage(prob, X, order, lo, hi, starts, maxfev, log, hist, best_x, best_s)
    t_search = time.perf_counter() - t0
    verified, tuned_m = [], None
    if backend != "multibody" and verify > 0:  # the best distinct candidates on MuJoCo
        verified, tuned_m, best_x = _verify(prob, cands, X, scores, order, verify, log, best_x)
    if not verified or tuned_m is None:
        tuned_m = _validated(prob, best_x)
    search, base_mb = _search_metrics(prob, backend, best_x, tuned_m, base_m)
    zb = np.log(np.maximum(best_x, 1e-300))  # (a gain of 0: the scenario's own, at the lower bound)
    hist["at_bound"] = [p for k, p in enumerate(prob.params)
                        if min(zb[k] - lo[k], hi[k] - zb[k]) < 1e-3 * (hi[k] - lo[k])]
    hist["bounds"] = {p: [math.exp(lo[k]), math.exp(hi[k])] for k, p in enumerate(prob.params)}
    hist["evaluations"] = prob.nfev
    hist["seconds_search"] = t_search
    hist["seconds"] = time.perf_counter() - t0
    return TuneResult(controller, prob.objective, prob.mode, list(prob.params),
                      dict(zip(prob.params, map(float, best_x))), dict(zip(prob.params, map(float, prob.x0))),
                      {"tuned": tuned_m, "baseline": base_mb}, lim, hist, backend=backend, search=search,
                      verified=verified, margins=list(prob.margins))


def _global_stage(prob, lo, hi, n_global, seed, log, t0):
    """The scenario's gains and ``n_global`` scrambled Sobol points of the log-box, one batch →
    (X, scores, their ranking)."""
    from scipy.stats import qmc

    sob = qmc.Sobol(len(lo), scramble=True, seed=seed)
    n_global = max(1, int(n_global))
    U = sob.random_base2(max(0, math.ceil(math.log2(n_global))))[:n_global]  # first n of 2^m points
    Z = lo + U * (hi - lo)
    X = np.vstack([prob.x0[None, :], np.exp(Z)])  # the scenario's gains (in the tuned form) first
    scores, mets = prob.evaluate(X)
    log(f"global stage: {len(X)} candidates in {time.perf_counter() - t0:.1f} s, best score "
        f"{scores.min():.5g} (scenario gains in the tuned form {scores[0]:.5g})")
    return X, scores, np.argsort(scores)


def _local_stage(prob, X, order, lo, hi, starts, maxfev, log, hist, best_x, best_s):
    """Nelder–Mead in the log-box from the ``starts`` best global candidates → (the local winners
    [(score, gains)], the best gains and score)."""
    from scipy.optimize import minimize

    def f(z):
        z = np.clip(z, lo, hi)
        s, _ = prob.evaluate(np.exp(z)[None, :])
        return float(s[0])

    cands = []  # (search score, gains) of the local winners
    for r in range(max(0, starts)):
        z0 = np.log(X[order[r]])
        step = 0.1 * (hi - lo)
        simplex = np.vstack([z0] + [z0 + np.eye(len(z0))[k] * step[k] for k in range(len(z0))])
        opt = minimize(f, z0, method="Nelder-Mead",
                       options={"maxfev": maxfev, "xatol": 1e-3, "fatol": 1e-6, "initial_simplex": simplex})
        x = np.exp(np.clip(opt.x, lo, hi))
        hist["local"].append({"start": X[order[r]].tolist(), "x": x.tolist(), "score": float(opt.fun),
                              "nfev": int(opt.nfev)})
        log(f"local stage from start {r + 1}: score {opt.fun:.5g} after {opt.nfev} evaluations")
        cands.append((float(opt.fun), x))
        if opt.fun < best_s:
            best_x, best_s = x, float(opt.fun)
    return cands, best_x, best_s


def _verify(prob, cands, X, scores, order, verify, log, best_x):
    """The ``verify`` best distinct candidates (local winners, then the global ranking) re-run on
    MuJoCo → (their rows, the best one's multibody metrics, its gains)."""
    verified, tuned_m = [], None
    cands.sort(key=lambda c: c[0])
    cands += [(float(scores[i]), X[i]) for i in order]
    pick = []
    for sc, x in cands:
        if sc < DIVERGED and all(np.max(np.abs(np.log(x) - np.log(y))) > 1e-6 for _, y in pick):
            pick.append((sc, x))
        if len(pick) == verify:
            break
    if not pick:  # no candidate ran (all diverged, or none met --margin-mode constraint)
        log("verification: no candidate ran to the end on the search backend; the closest one is validated")
        return verified, tuned_m, best_x
    Xv = np.array([x for _, x in pick])
    sv, mv = prob.evaluate(Xv, backend="multibody")  # the same numbers as single multibody runs
    for k, (sc, x) in enumerate(pick):
        verified.append({"gains": dict(zip(prob.params, map(float, x))), "score_search": sc,
                         "score_multibody": float(sv[k]),
                         "objective_multibody": (mv[k] or {}).get("objective", float("nan"))})
    kbest = int(np.argmin(sv[:len(pick)]))
    if kbest != 0:
        log(f"verification: candidate {kbest + 1} of the search ranking is best on MuJoCo")
    log(f"verification: {len(pick)} best candidates re-run on the multibody backend")
    return verified, mv[kbest], pick[kbest][1]


def _validated(prob, best_x) -> dict:
    """The multibody metrics of the best gains (a diverging candidate is reported, not raised)."""
    try:
        return prob.validate(best_x)[0]
    except MjbenchError as e:  # the closest candidate diverges: reported, not a traceback
        return {"objective": float("nan"), "score": DIVERGED, "diverged": str(e),
                **({"margins": prob.linear_margins(best_x)} if prob.margins else {})}


def _search_metrics(prob, backend, best_x, tuned_m, base_m):
    """The tuned and baseline metrics on the search backend, and the baseline on MuJoCo."""
    search = {"baseline": base_m}
    if backend == "multibody":
        search["tuned"] = tuned_m
        return search, base_m
    try:
        search["tuned"], _ = prob.run(best_x)
    except MjbenchError as e:
        search["tuned"] = {"objective": float("nan"), "score": DIVERGED, "diverged": str(e)}
    base_mb, _ = prob.validate(prob.x0, baseline=True)
    base_mb["score"] = prob.score(base_mb)
    return search, base_mb


def search_box(params, x0, span, bounds, intervals=None):
    """(lo, hi) log-bounds of the search: ``bounds`` {gain: (lo, hi)} where given, else the
    scenario's gain ×/÷ ``span``, within each gain's admissible interval ``intervals`` {gain: (lo,
    hi)} (the controller's ``TUNABLE`` declaration: the span is clipped to it, ``bounds`` must lie
    in it, and a scenario value of 0 searches the whole interval when it is finite).  Bad values
    are ONE error naming the option."""
    if not (math.isfinite(span) and span > 1.0):
        raise ParameterError(f"--span {span:g}: must be a factor > 1 (each gain is searched within ×/÷ span of the "
                             f"scenario's)")
    unknown = [k for k in (bounds or {}) if k not in params]
    if unknown:
        raise ParameterError(f"--bounds {unknown[0]}: not a gain of this controller; its gains are {', '.join(params)}")
    lo, hi = np.empty(len(params)), np.empty(len(params))
    for k, p in enumerate(params):
        a_lo, a_hi = (intervals or {}).get(p, (0.0, math.inf))
        b = (bounds or {}).get(p)
        if b is None:
            b = _default_interval(p, x0[k], span, a_lo, a_hi)
        elif not (math.isfinite(b[0]) and math.isfinite(b[1]) and 0 < b[0] < b[1]):
            raise ParameterError(f"--bounds {p}={b[0]:g}:{b[1]:g}: need finite 0 < LO < HI (gains are searched in log "
                                 f"scale)")
        elif b[0] < a_lo or b[1] > a_hi:
            raise ParameterError(f"--bounds {p}={b[0]:g}:{b[1]:g}: outside the interval {a_lo:g} ... {a_hi:g} the "
                                 f"controller admits for {p} (its TUNABLE declaration)")
        lo[k], hi[k] = math.log(b[0]), math.log(b[1])
    return lo, hi


def _default_interval(p, x0, span, a_lo, a_hi):
    """The search interval of gain p without ``--bounds``: its scenario value x0 ×/÷ span clipped to
    the admissible (a_lo, a_hi), or that whole interval when x0 is 0 and the interval finite."""
    if x0 > 0:
        b = (max(x0 / span, a_lo), min(x0 * span, a_hi))
        if not b[0] < b[1]:
            raise ParameterError(f"tune: {p} = {x0:g} in the scenario, and ×/÷ --span {span:g} of it lies outside the "
                                 f"interval {a_lo:g} ... {a_hi:g} the controller admits; give --bounds {p}=LO:HI")
        return b
    if a_lo > 0 and math.isfinite(a_hi):
        return a_lo, a_hi
    raise ParameterError(f"tune: {p} = {x0:g} in the scenario, so ×/÷ --span gives no interval; give "
                         f"--bounds {p}=LO:HI (0 < LO < HI)")


def constraint_status(res: "TuneResult") -> tuple:
    """([violated --margin bounds], [exceeded peak limits]) of the winner, one text each: the
    margins at the worst frozen angle (linear model), the peak |V|, |I| against ``--limit``
    (multibody validation; always a penalty) and a divergence."""

    out, lim_out = [], []
    tuned = res.validation.get("tuned") or {}
    w = tuned.get("margins") or {}
    for key, op, val in res.margins:
        name, _, label = MARGIN_KEYS[key]
        v = w.get(name)
        if not w.get("all_stable", True):
            out.append(f"{key}{op}{val:g}: some frozen-angle loops are unstable")
        elif v is None or (isinstance(v, float) and math.isnan(v)):
            out.append(f"{key}{op}{val:g}: the {label} cannot be computed")
        elif op == ">=" and v < val:
            out.append(f"{key}{op}{val:g}: worst {label} is {v:.4g}, short by {val - v:.3g}")
        elif op == "<=" and v > val:
            out.append(f"{key}{op}{val:g}: worst {label} is {v:.4g}, over by {v - val:.3g}")
    for key, lim, label in (("peak_voltage_V", res.limits.get("voltage"), "voltage"),
                            ("peak_current_A", res.limits.get("current"), "current")):
        v = tuned.get(key)
        if lim is not None and v is not None and v > lim * (1 + 1e-9):
            unit = "V" if label == "voltage" else "A"
            lim_out.append(f"--limit {label}={lim:.4g}: peak |{label}| is {v:.4g} {unit}, over by {v - lim:.3g} {unit}")
    if tuned.get("diverged"):
        out.append(f"the candidate diverges on the multibody backend ({tuned['diverged']})")
    return out, lim_out


def report(res: TuneResult) -> str:
    v = res.validation
    lines = [f"controller {res.controller} (mode {res.mode}), objective {res.objective}, search on the "
             f"{res.backend} backend; {res.history.get('evaluations', '?')} simulations in "
             f"{res.history.get('seconds', 0):.2f} s (search {res.history.get('seconds_search', 0):.2f} s)",
             f"  {'':<22s} {'scenario ctrl':>16s} {'tuned':>16s}"]
    for p in res.params:
        at = "  (at a search bound)" if p in res.history.get("at_bound", []) else ""
        lines.append(f"  {p:<22s} {res.baseline[p]:>16.6g} {res.best[p]:>16.6g}{at}")
    for k in dict.fromkeys((res.objective, "chi", "chi_cycle", "ise", "ee_rms", "ee_max", "peak_voltage_V",
                            "peak_current_A")):
        if k in v["baseline"] or k in v["tuned"]:
            lines.append(f"  {k:<22s} {v['baseline'].get(k, float('nan')):>16.6g} {v['tuned'].get(k, float('nan')):>16.6g}")
    for key, op, val in res.margins:
        name = MARGIN_KEYS[key][0]
        b = v["baseline"].get("margins", {}).get(name)
        tv = v["tuned"].get("margins", {}).get(name)
        lines.append(f"  {('worst ' + key + ' ' + op + ' ' + format(val, 'g')):<22s} "
                     f"{(b if b is not None else float('nan')):>16.6g} {(tv if tv is not None else float('nan')):>16.6g}")
    lines.append(f"  limits: {', '.join(f'{k} {x:.4g}' for k, x in res.limits.items())} "
                 f"(penalty {PENALTY:g} × relative excess)")
    lines.append(f"  improvement of {res.objective} over the scenario's gains (multibody validation): "
                 f"{100 * res.improvement:.1f} %")
    if res.backend != "multibody" and res.search.get("tuned"):
        lines.append(f"  {res.objective} of the winner: {res.backend} {_f(res.search['tuned'].get('objective'))}, "
                     f"multibody {_f(v['tuned'].get('objective'))}, difference "
                     f"{_rel(res.search['tuned'].get('objective'), v['tuned'].get('objective'))}")
        lines.append(f"  {res.objective} of the scenario's gains: {res.backend} "
                     f"{_f(res.search['baseline'].get('objective'))}, multibody {_f(v['baseline'].get('objective'))}, "
                     f"difference {_rel(res.search['baseline'].get('objective'), v['baseline'].get('objective'))}")
    if res.verified:
        lines.append(f"  verified candidates (score = objective + penalties): {res.backend} → multibody")
        for k, c in enumerate(res.verified):
            g = ", ".join(f"{p} {c['gains'][p]:.4g}" for p in res.params)
            lines.append(f"    {k + 1}. {g}: {c['score_search']:.6g} → {c['score_multibody']:.6g} "
                         f"({_rel(c['score_search'], c['score_multibody'])})")
    return "\n".join(lines)


def _f(x):
    return "nan" if x is None else f"{x:.6g}"


def _rel(a, b):
    """Difference b − a, absolute and relative to |b|, as text."""
    if a is None or b is None or not (np.isfinite(a) and np.isfinite(b)):
        return "n/a"
    return f"{b - a:+.3g} ({100 * (b - a) / abs(b) if b else float('nan'):+.3g} %)"
