"""Running composed programs: one run advanced in chunks (:class:`Stepper`), jobs of N runs
(:func:`run_many`) and the record they fill; which loop runs them: :mod:`.choice`.

**Chunks.**  The loop runs a range of steps and keeps its state in arrays, so a run is executed in
chunks of ≈ 0.05 s (:data:`CHUNK_S`): progress bars advance, Ctrl-C and SIGTERM stop a compiled run
within a chunk.
"""
from __future__ import annotations

import gc
import math
import os
import threading
import time

import numpy as np

from .. import signals as SIG
from ..errors import ParameterError, SimulationDiverged
from . import checks as CK
from . import layout as LY
from .choice import choose_loop, jit_mode, loop_function, python_loop
from .program import Program, Run
from ..backends.table import composing

#: wall time a chunk of a compiled run aims at (progress, signals)
CHUNK_S = 0.05

_KS_START = np.array(LY.KS_START_INDEX)  # (LY.KS_START, axis 0)


class Record:
    """Samples of one run (``data`` (nrec, ncol)) or of N runs (``data`` (nsim, nrec, ncol)) in
    ``columns`` order; ``nrows`` valid rows per run; divergence flags, times and messages; the
    interval statistics ``stats`` (same leading shape, ``stat_columns``)."""

    def __init__(self, data, columns, nrows, diverged, t_diverged, messages, meta, stats=None, stat_columns=()):
        self.data, self.columns, self.nrows = data, columns, nrows
        self.diverged, self.t_diverged, self.messages, self.meta = diverged, t_diverged, messages, meta
        self.stats, self.stat_columns = stats, tuple(stat_columns)


class Stepper:
    """One run of the kernel advanced in chunks: the composed program, the loop (CPython or
    compiled), the per-run parameters and state, the record.  :func:`run_many` drives one per run;
    a caller that needs the run between chunks (an FMU's ``doStep``, a frequency-response
    measurement) drives its own with :meth:`advance`.

    ``out``/``stats``: the flat record and statistics to fill, default allocated; ``mode``:
    "python", "compiled" or "check" (:func:`choose_loop`); ``every``: the control sample in co-steps
    (default the machine's, :func:`~.checks.machine_every`)."""

    def __init__(self, plant, machine, h: float, nsteps: int, decim: int, mode: str = "python", program=None,
                 out=None, fn=None, stats=None, strict: bool = False, every: int | None = None):
        self.plant, self.machine, self.h, self.nsteps, self.decim, self.mode = plant, machine, h, nsteps, decim, mode
        self.strict = strict  # the compiled loop was asked for: a law numba refuses is an error, not a fallback
        self.fallback = ""
        self.every = int(every) if every is not None else CK.machine_every(machine, h)
        if program is None:
            plant.start()
            program = Program.build(plant, machine, h, self.every)
        self.program = pr = program
        self.columns = pr.columns
        self.ncol = ncol = len(pr.columns)
        self.nstat = nstat = len(pr.stat_columns)
        self.nrec = nsteps // decim + 1
        if out is None:
            out = np.full(self.nrec * ncol, np.nan)
        if stats is None:  # one statistics row per record row
            stats = np.full((len(out) // max(ncol, 1)) * nstat, np.nan)
        self.out, self.stats = out, stats
        python = mode == "python"
        self.fn = fn if fn is not None else loop_function(pr, mode)
        self.parts = X = pr.parts(python)
        nax = pr.naxes
        self.ks = ks = np.zeros(LY.ks_size(nax))
        self.qo = qo = np.zeros(4 * nax)
        pr.read(X.plant_P, X.plant_S, qo)
        I0 = _per_axis(machine.I0, nax)
        for a in range(nax):
            q, qd, dm, dmd = (float(v) for v in qo[4 * a:4 * a + 4])
            w = float(X.drive[a].z) * (qd + dmd)
            i0 = I0[a]
            start = {"q": q, "qd": qd, "qd_prev": qd, "I": i0, "dm": dm, "dmd": dmd, "qm": q, "qdm": qd,
                     "w_max": w, "w_min": w, "w_t_max": 0.0, "w_t_min": 0.0, "I_max": i0, "I_min": i0,
                     "I_t_max": 0.0, "I_t_min": 0.0, "Vb_max": -math.inf, "Vb_min": math.inf, "tq_max": -math.inf,
                     "tq_min": math.inf, "Vb_t_max": math.nan, "Vb_t_min": math.nan, "tq_t_max": math.nan,
                     "tq_t_min": math.nan}
            ks[_KS_START + a * len(LY.KS_AXIS)] = [start[n] for n in LY.KS_START]
        self.div = np.zeros(len(LY.DIV_FIELDS))
        self.y = pr.signals0.copy()
        self.tau = np.zeros(nax)
        self._bind(python)
        self.n = 0

    def _bind(self, python: bool):
        """The run's arrays as the loop reads them: the arrays themselves (compiled), memoryviews of the
        record and the kernel state, and lists of the signals, torques and plant outputs, which the
        CPython loop reads and writes at every step (copied back after each chunk: :meth:`_python_chunk`)."""
        view = memoryview if python else (lambda a: a)
        box = (lambda a: a.tolist()) if python else (lambda a: a)
        self.run = Run(self.h, self.nsteps, self.decim, self.every, view(self.ks), view(self.out), view(self.stats),
                       self.ncol, self.nstat, view(self.div), box(self.y), box(self.tau), box(self.qo))

    def _python_chunk(self, n1: int) -> int:
        """The CPython loop up to ``n1``: without the cyclic collector (the loop makes no cycles; its
        passes would cost ≈ 2 % of a co-step), the lists copied back into the arrays afterwards."""
        gc_on = gc.isenabled()
        if gc_on:
            gc.disable()
        try:
            return self.fn(self.n, n1, self.run, self.parts)
        finally:
            if gc_on:
                gc.enable()
            r = self.run
            self.y[:] = r.y
            self.tau[:] = r.tau
            self.qo[:] = r.qo

    @property
    def diverged(self) -> bool:
        return bool(self.div[0])

    @property
    def done(self) -> bool:
        return self.diverged or self.n > self.nsteps

    @property
    def nrows(self) -> int:
        return int(self.ks[LY.ks_index("k")])

    def state(self, axis: int = 0) -> dict:
        """The run's state now: t [s], q [rad], q̇ [rad/s], I [A], u (the held controller output)."""
        ks = self.ks

        def g(name):
            return float(ks[LY.ks_index(name, axis)])

        return {"t": self.n * self.h, "q": g("q"), "qd": g("qd"), "I": g("I"), "u": g("u"),
                "deflection": g("dm"), "deflection_rate": g("dmd"), "V_applied": g("Vb"), "torque": g("tq")}

    def signals(self) -> dict:
        """The signal array at the last control sample, by name (axis 0 unsuffixed)."""
        out = {}
        for a in range(self.program.naxes):
            for n in SIG.AXIS:
                out[n if a == 0 else f"{n}_{a}"] = float(self.y[SIG.index(n, a)])
        out["t"] = float(self.y[SIG.index("t")])
        return out

    def advance(self, n_to: int) -> int:
        """Run co-steps up to ``n_to`` (exclusive; at most nsteps + 1) or a divergence → the step reached.

        A law that numba refuses (first call of a compiled loop) makes the run continue in CPython,
        saying why (:attr:`fallback`), unless the compiled loop was asked for (then a ParameterError
        naming the law); a law that fails while running is a ParameterError naming the component,
        the law and the line."""
        if self.done:
            return self.n
        n1 = min(int(n_to), self.nsteps + 1)
        try:
            self.n = self._python_chunk(n1) if self.mode == "python" else self.fn(self.n, n1, self.run, self.parts)
        except (ParameterError, SimulationDiverged, KeyboardInterrupt, SystemExit, MemoryError):
            raise
        except Exception as e:  # noqa: BLE001 - a law's failure becomes one line naming it
            reason = getattr(e, "reason", None)
            if reason is not None:  # numba refused a law (jit.LawCompileError): nothing ran yet
                if self.strict:
                    raise ParameterError(reason) from None
                self.fallback = f"{reason}; the CPython loop ran instead"
                self.mode = "python"
                self.fn = python_loop(self.program)
                self.parts = self.program.parts(True)
                self._bind(True)
                self.n = self._python_chunk(n1)
                return self.n
            msg = CK.law_failure_message(self.program, e, self.n * self.h, self.fn)
            if msg is None and self.mode == "check" and isinstance(e, IndexError):
                msg = self._locate() or (f"an array was read or written past its end in the compiled loop "
                                         f"(MJBENCH_JIT=check) between t = {self.n * self.h:.6g} s and "
                                         f"{n1 * self.h:.6g} s: {e}")
            if msg is None:
                raise
            raise ParameterError(msg) from None
        return self.n

    def _locate(self) -> str:
        """The law that failed in the bounds-checked compiled loop: the run replayed in CPython from
        its start (fresh states) until it fails there, naming the law and the line."""
        try:
            self.plant.start()
            pr = Program.build(self.plant, self.machine, self.h, self.every)
            st = Stepper(self.plant, self.machine, self.h, self.nsteps, self.decim, "python", pr)
            while not st.done:
                st.advance(st.n + 4000)
        except ParameterError as e:
            return str(e)
        return ""

    def message(self, backend: str = "") -> str:
        """The divergence message: time and state, then the likely cause (:func:`diagnose`), else
        the controller's own hint (``divergence_hint``, e.g. the K_p·t ramp)."""
        d = self.div
        cause = CK.diagnose(self.machine, self.h)
        if not cause and backend == "reduced":  # (the reduced model's own limits: its table, its solve)
            cause = self._mechanism_hint()
        if not cause:
            hint_fn = getattr(self.machine.controller, "divergence_hint", None)
            cause = hint_fn(float(d[1]), self.h) if hint_fn is not None else ""
        return CK.divergence_message(backend, *d[1:6], cause)

    def _mechanism_hint(self) -> str:
        """The mechanism's own likely cause (``divergence_hint(t, q)``, e.g. a linkage with several inputs
        that left the inputs' table or reached a configuration its loops cannot take) at the last
        recorded sample whose inputs are finite; '' if it has none."""
        fn = getattr(self.machine.mechanism, "divergence_hint", None)
        n = self.nrows
        if fn is None or n <= 0:
            return ""
        labels = self.machine.axis_labels if self.program.naxes > 1 else ()
        names = [f"{a}:crank_angle_rad" for a in labels] if labels else ["crank_angle_rad"]
        try:
            cols = [self.columns.index(c) for c in names] + [self.columns.index("t_s")]
        except ValueError:
            return ""
        rows = self.out[:n * self.ncol].reshape(n, self.ncol)[:, cols]
        ok = np.flatnonzero(np.all(np.isfinite(rows), axis=1))
        if not len(ok):
            return ""
        last = rows[ok[-1]]
        return fn(float(last[-1]), last[:-1])


def _per_axis(v, n):
    if isinstance(v, (tuple, list, np.ndarray)):
        return [float(x) for x in v]
    return [float(v)] * n


def run(plant, machine, t_end: float, record_dt: float = 1e-3, progress=None, backend: str = "",
        loop: str | None = None) -> Record:
    """Co-simulate ``machine`` on ``plant`` for ``t_end`` s; one :class:`Record` (single run).

    Raises :class:`SimulationDiverged` (time and state in the message) when the run diverges."""
    rec = run_many([plant], [machine], t_end, record_dt, progress, backend, loop)
    state = rec.meta.pop("div_state", None)
    if rec.diverged[0]:
        raise SimulationDiverged(rec.messages[0], t=float(rec.t_diverged[0]), state=state)
    return Record(rec.data[0], rec.columns, rec.nrows, rec.diverged, rec.t_diverged, rec.messages,
                  {k: v for k, v in rec.meta.items() if k != "nsim"}, rec.stats[0], rec.stat_columns)


def run_many(plants, machines, t_end: float, record_dt: float = 1e-3, progress=None, backend: str = "",
             loop: str | None = None, threads: int | None = None, consume=None) -> Record:
    """Co-simulate N machines, each on its own plant → an (N, nrec, ncol) :class:`Record`.

    Runs are independent (a batch equals N single runs, bit for bit); a diverged run is flagged
    with its time and message, its rows stop there.  All runs must have the same step.  Compiled
    runs of a batch run on ``threads`` threads (default: the CPUs; the compiled loop releases the
    GIL).  Progress: co-steps of a single run, finished runs of a batch.

    ``consume(i, record)``: called with each run's own one-run :class:`Record` as soon as it ends;
    its records are then not kept (a sweep that needs only metrics holds one record per thread,
    reused by the thread's next run: ``consume`` copies what it keeps): the returned Record has
    ``data = None`` and ``results`` = the values ``consume`` returned."""
    plants, machines = list(plants), list(machines)
    h = float(plants[0].h)
    CK.check_times(t_end, h, record_dt)
    nsteps = int(round(t_end / h))
    decim = max(1, int(round(record_dt / h)))
    nrec = nsteps // decim + 1
    N = len(machines)
    progs = _programs(plants, machines, h)
    cols, scols = progs[0].columns, progs[0].stat_columns
    ncol, nstat = len(cols), len(scols)
    mode, why = _job_loop(progs, N * nsteps, loop)
    strict = jit_mode(loop) in ("compiled", "check")
    nthreads = min(N, threads or os.cpu_count() or 1) if mode != "python" and N > 1 else 1
    CK.check_record(nsteps, decim, ncol + nstat, nthreads if consume is not None else N, h, record_dt)
    # The loop writes every column of each row it records (the plant's own columns: its law, so those
    # start as NaN); the rows after a run's end are set to NaN when it ends (:func:`_blank_tail`).
    blank = bool(progs[0].flags["NEXTRA"])
    fresh = (lambda shape: np.full(shape, np.nan)) if blank else np.empty
    data = None if consume is not None else fresh((N, nrec * ncol))
    stats = None if consume is not None else fresh((N, nrec * nstat))
    fns = {}
    for pr in progs:
        if pr.loop_key(mode) not in fns:
            fns[pr.loop_key(mode)] = loop_function(pr, mode)
    meta = _job_meta(plants[0], machines[0], h, decim, progs[0].every, mode, why)
    nrows = np.zeros(N, dtype=int)
    diverged = np.zeros(N, dtype=bool)
    t_div = np.full(N, np.nan)
    messages = [""] * N
    results = [None] * N
    div_state = [None]

    local = threading.local()  # consume: each thread's record, refilled for its next run

    def task(i, prog, stop=None):
        pr = progs[i]
        if data is None:
            if not hasattr(local, "rec"):
                local.rec = np.full(nrec * ncol, np.nan), np.full(nrec * nstat, np.nan)
            elif blank:
                for a in local.rec:
                    a.fill(np.nan)
        out, sts = local.rec if data is None else (data[i], stats[i])
        st = Stepper(plants[i], machines[i], h, nsteps, decim, mode, pr, out, fns[pr.loop_key(mode)], sts,
                     strict=strict, every=pr.every)
        _run_one(st, prog, mode != "python", stop)
        _blank_tail(st)
        if st.fallback:
            meta["loop"], meta["loop_reason"] = "python", st.fallback
        nrows[i], diverged[i] = st.nrows, st.diverged
        if st.diverged:
            d = st.div
            t_div[i], messages[i] = d[1], st.message(backend)
            div_state[0] = {"q": float(d[2]), "qd": float(d[3]), "I": float(d[4]), "V": float(d[5])}
        if consume is not None:
            one = Record(st.out.reshape(nrec, ncol), cols, nrows[i:i + 1], diverged[i:i + 1], t_div[i:i + 1],
                         messages[i:i + 1], meta, st.stats.reshape(nrec, nstat), scols)
            results[i] = consume(i, one)

    if mode == "check":
        meta["loop_reason"] += "; every array access bounds-checked"
    if nthreads > 1:
        _run_threaded(task, N, nthreads, progress)
    else:
        for i in range(N):
            task(i, progress if N == 1 else None)
            if progress is not None and N > 1:
                progress.update(1)
    meta = {**meta, "nsim": N, "div_state": div_state[0]}
    rec = Record(None if data is None else data.reshape(N, nrec, ncol), cols, nrows, diverged, t_div, messages,
                 meta, None if stats is None else stats.reshape(N, nrec, nstat), scols)
    rec.results = results if consume is not None else None
    return rec


def _blank_tail(st: Stepper) -> None:
    """NaN in the record's and the statistics' rows after the run's last recorded one (a diverged or
    stopped run; a reused record's rows from its previous run)."""
    k = st.nrows
    st.out[k * st.ncol:] = np.nan
    st.stats[k * st.nstat:] = np.nan


def _programs(plants, machines, h: float) -> list:
    """Each run's :class:`Program` (its plant started), after the checks of a job: every machine
    (once per mechanism and drive inertia in this process), one step for all, the same recorded
    columns."""

    with composing():
        progs = []
        for pl, mc in zip(plants, machines):
            CK.check_machine(mc)
            if abs(float(pl.h) - h) > 1e-15 * h:
                raise ParameterError(f"simulation.dt: the runs of one batch need the same step ({pl.h:g} s vs {h:g} s)")
            pl.start()
            progs.append(Program.build(pl, mc, h, CK.machine_every(mc, h)))
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


def _job_meta(plant, machine, h: float, decim: int, every: int, mode: str, why: str) -> dict:
    """The job's meta: steps, control period, the plant's meta, the loop and the drive train."""
    drives = machine.drives
    meta = {"dt": h, "record_dt": decim * h, "control_period": every * h,
            "z": float(drives[0].z), **plant.meta, "loop": "compiled" if mode == "check" else mode,
            "loop_reason": why}
    if len(drives) > 1:
        meta["axes"] = list(machine.axis_labels)
        meta["z_axes"] = [float(d.z) for d in drives]
    if len(drives) == 1:
        train = getattr(drives[0], "train", None)
        if train is not None:
            meta["drivetrain"] = train.describe()
    else:
        trains = {lab: d.train.describe() for lab, d in zip(machine.axis_labels, drives)
                  if getattr(d, "train", None) is not None}
        if trains:
            meta["drivetrain"] = trains  # (per axis, by label)
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


__all__ = ["Record", "Stepper", "run", "run_many", "CHUNK_S"]
