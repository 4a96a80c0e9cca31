"""What the kernel checks before simulating: times, control periods, the machine, the record's memory;
and what it says when a run diverges."""
from __future__ import annotations

import math

from .. import environment
from ..errors import ParameterError
from .inline import LINE_BASE
from .loop import MAX_CURRENT, MAX_SPEED
from ..backends.table import mechanism_key


def check_times(t_end, h, record_dt):
    if not (math.isfinite(t_end) and t_end > 0):
        raise ParameterError(f"t_end = {t_end!r}: must be a finite time > 0 [s]")
    if not (math.isfinite(h) and 0 < h <= 0.01):
        raise ParameterError(f"simulation.dt = {h!r}: must be in (0, 0.01] s")
    if not (math.isfinite(record_dt) and record_dt > 0):
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


def machine_every(machine, h) -> int:
    """The machine's control sample in co-steps: every controller's (they must agree)."""
    ks = {control_every(c, h) for c, _ in machine.controllers}
    if len(ks) > 1:
        raise ParameterError(f"the controllers of one machine must share a sample period (they have "
                             f"{', '.join(f'{k * h:g} s' for k in sorted(ks))})")
    return ks.pop()


#: machines already checked in this process (by :func:`_machine_key`)
_CHECKED: set = set()


def _machine_key(mc):
    """What :func:`check_machine` depends on: the mechanism's parameters and the drives' inertias."""

    try:
        mech = (type(mc.mechanism).__name__, mechanism_key(mc.mechanism))
    except Exception:  # noqa: BLE001 - a mechanism that cannot describe itself: check each
        mech = id(mc.mechanism)
    return mech, tuple(float(d.J_eq) for d in mc.drives)


def check_machine(machine) -> None:
    """Refuse, before simulating, a machine with nothing to accelerate: J_eq + J(q) ≤ 0 (all
    masses and inertias zero) — its acceleration would be a division by zero.  Checked once per
    mechanism and drive inertia in this process."""
    key = _machine_key(machine)
    if key in _CHECKED:
        return
    jmin, jmax = machine.input_inertia()
    if not jmax > 0.0:
        raise ParameterError(f"the machine has no inertia at its input (J_eq + J(q) = {jmax:g} kg·m²: drive.J_m, "
                             f"J_a, J_b and every mass and inertia of the mechanism are zero): give the drive or the "
                             f"mechanism some inertia")
    if len(_CHECKED) > 4096:
        _CHECKED.clear()
    _CHECKED.add(key)


def diagnose(machine, h: float) -> str:
    """The likely cause of a divergence from the machine itself ('' if none is recognised):
    an initial current beyond the amplifier's limit; a mechanical time constant J·R/(z·k_m)²
    (J the smallest input inertia) below 2·h, i.e. an inertia too small for the step (or a unit
    slip in the inertias)."""
    if len(machine.drives) > 1:
        return ""  # (the causes below are stated for one axis)
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
    jmin, _ = machine.input_inertia()
    k = float(drive.z) * float(drive.k_m)
    tau_m = jmin * float(drive.R) / (k * k) if k > 0 else math.inf
    if tau_m < 2.0 * h:
        return (f" Likely cause: the smallest inertia at the input, J_eq + J(q) = {jmin:.3g} kg·m², gives a mechanical "
                f"time constant J·R/(z·k_m)² = {tau_m:.3g} s below 2·dt = {2 * h:g} s: the inertia is too small for the "
                f"step (a unit slip in a mass or inertia?), or reduce simulation.dt.")
    return ""


def divergence_message(backend, t, q, qd, I, V, hint=""):
    return (f"{backend + ' ' if backend else ''}simulation diverged at t = {t:.6g} s: input angle = {q:.6g} rad, "
            f"input speed = {qd:.6g} rad/s, current = {I:.6g} A, voltage = {V:.6g} V (limits |q̇| < "
            f"{MAX_SPEED:g} rad/s, |I| < {MAX_CURRENT:g} A, finite values). Reduce the time step or check "
            f"gains/parameters." + hint)


# ============================================================================ the record's memory
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
    env = environment.max_record_mb()  # (checked in one place: a finite number > 0, else an error naming it)
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
    """Refuse, before simulating, a record that would not fit (ParameterError naming the cause).
    ``ncol``: the columns of a row, the interval statistics included."""
    nrec = nsteps // decim + 1
    need = record_bytes(nrec, ncol, nsim)
    lim = memory_limit(need)
    if need > lim:
        raise ParameterError(
            f"the record needs {need / 2 ** 20:,.0f} MiB ({nsim} run(s) × {nrec:,} samples × {ncol} values at "
            f"record_dt = {record_dt:g} s), more than the limit {lim / 2 ** 20:,.0f} MiB (half the available "
            f"memory; MJBENCH_MAX_RECORD_MB overrides): shorten t_end, raise simulation.record_dt or run fewer "
            f"simulations at once")



def law_failure_message(program, exc, t: float, loop=None) -> str | None:
    """One line naming the component, the law and the line where ``exc`` was raised inside a law of
    ``program`` (None when it was not raised in a law); ``loop``: the CPython loop that ran, whose
    inlined statements carry their law's line (:data:`.inline.LINE_BASE`)."""
    frames = program.law_frames()
    inlined = getattr(loop, "__mjbench_inlined__", ())
    code = getattr(loop, "__code__", None)
    tb, hit = exc.__traceback__, None
    while tb is not None:
        c, line = tb.tb_frame.f_code, tb.tb_lineno
        if c in frames:
            hit = (frames[c], line)
        elif c is code and line is not None and line >= LINE_BASE and line // LINE_BASE - 1 < len(inlined):
            fn, first = inlined[line // LINE_BASE - 1]
            if getattr(fn, "__code__", None) in frames:
                hit = (frames[fn.__code__], first + line % LINE_BASE - 1)
        tb = tb.tb_next
    if hit is None:
        return None
    (what, name), line = hit
    extra = ""
    if isinstance(exc, IndexError):
        extra = " (an index past an array: its state S has the entries of STATE; MJBENCH_JIT=check bounds-checks " \
                "the compiled loop too)"
    return f"{what}: law {name} failed at line {line} (t = {t:.6g} s): {type(exc).__name__}: {exc}{extra}"


__all__ = ["law_failure_message", "check_times", "control_every", "machine_every", "check_machine", "diagnose", "divergence_message",
           "record_bytes", "memory_limit", "check_record", "SMALL_RECORD"]
