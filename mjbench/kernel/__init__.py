"""The co-step kernel: the one loop that runs a machine — on every backend, in CPython or compiled.

One module per concern:

* :mod:`~mjbench.kernel.loop` — the loop itself, written once as a template over the machine's axes
  and controllers (the order of one co-step: measurement → control sample → record → drive → plant
  step → current update);
* :mod:`~mjbench.kernel.unroll` — the template unrolled for a composition's axes and controllers;
* :mod:`~mjbench.kernel.layout` — the state between chunks, the record's columns, the interval
  statistics and the signal array's indices, declared once;
* :mod:`~mjbench.kernel.wiring` — the control laws' named signals wired to the signal array;
* :mod:`~mjbench.kernel.program` — a run composed: every slot bound to its component's law;
* :mod:`~mjbench.kernel.running` — runs and batches in chunks, the record;
* :mod:`~mjbench.kernel.choice` — which loop runs them (CPython or compiled) and why;
* :mod:`~mjbench.kernel.checks` — what is refused before simulating, what a divergence says.

**Written once.**  Every formula in the loop is a *law* of a component (:mod:`mjbench.compiled`):
the drive's equations (:mod:`mjbench.drive`), the control laws (controllers and references, reading
named signals: :mod:`mjbench.signals`), the drive-train elements (:mod:`mjbench.drivetrain`), the
plant's step (:mod:`mjbench.backends`).  The loop is either executed by CPython (the reference;
short runs, components without a compiled form) or compiled by numba with every law inlined (long
runs, batches, design loops).  Both execute the same source, so they give the same bits
(tests/test_compiled.py, tests/test_digests.py).
"""
from __future__ import annotations

from .checks import (SMALL_RECORD, check_machine, check_record, check_times, control_every, diagnose,
                     machine_every, memory_limit, record_bytes)
from .layout import KS_AXIS, KS_GLOBAL, ks_index
from .loop import MAX_CURRENT, MAX_SPEED
from .program import MIN_STEPS, Parts, Program, Run
from .choice import JIT_MODES, choose_loop, jit_mode, loop_function, preload, python_loop
from .running import CHUNK_S, Record, Stepper, run, run_many

KS_K = ks_index("k")

__all__ = ["SMALL_RECORD", "check_machine", "check_record", "check_times", "control_every", "diagnose",
           "machine_every", "memory_limit", "record_bytes", "KS_AXIS", "KS_GLOBAL", "ks_index", "KS_K",
           "MAX_CURRENT", "MAX_SPEED", "MIN_STEPS", "Parts", "Program", "Run", "CHUNK_S", "JIT_MODES", "Record",
           "Stepper", "choose_loop", "jit_mode", "loop_function", "preload", "python_loop", "run", "run_many"]
