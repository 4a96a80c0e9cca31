"""Laws read named signals (mjbench.signals): a controller written in this file reads the voltage
actually applied after the drive's limits and the command's limits, with no change to mjbench; the
kernel wires names, so a law that names a signal outside the set is refused before simulating;
the law contract is checked when the run is composed (one line naming the component, the law, the
rule and the line), a law numba cannot compile runs in CPython and says why, and asking for the
compiled loop then is an error; the kernel's cache survives corrupted entries and an unwritable
folder leaves nothing behind.

Independent paths: the drive's own limiter (``DCMotorDrive.limit``) for the applied voltage the
law must see; the CPython loop for the compiled one; the source of the law file for the lines."""
from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from collections import namedtuple

import numpy as np
import pytest

from mjbench import kernel
from mjbench import scenario as S
from mjbench import signals as SIG
from mjbench.backends import simulate
from mjbench.compiled import law
from mjbench.control import Controller
from mjbench.errors import ParameterError

H = 1e-4


# ============================================================================ a law that reads V
StepP = namedtuple("StepP", "dv")


@law(outputs=("u",))
def applied_plus(V, u_max, P, S):
    """u = the voltage the drive applied over the last step + dv: a ramp that follows the applied
    (limited) voltage, not its own command."""
    S[0] = u_max
    return V + P.dv


class AppliedPlus(Controller):
    type_name = "applied_plus_test"
    STATE = ("u_max_seen",)
    law = applied_plus

    def __init__(self, dv, period=0.0):
        self.dv, self.period = float(dv), float(period)

    @classmethod
    def from_params(cls, p, **kw):  # pragma: no cover - built in code here
        raise NotImplementedError

    def parameters(self, T, z):
        return StepP(self.dv)


def _machine(ctrl, sets=()):
    scn = S.load("incerti2012", list(sets))
    m = S.make_machine(scn, "open")
    m.controller = ctrl
    return m


@pytest.mark.parametrize("loop", ["python", "compiled"])
def test_a_law_reads_the_voltage_applied_after_the_limiter(loop):
    if loop == "compiled":
        pytest.importorskip("numba")
    v_max = 5.5
    m = _machine(AppliedPlus(1.0, period=1e-3), [f"drive.v_max={v_max}"])
    tr = simulate(m, "reduced", 0.02, record_dt=1e-3, loop=loop)
    assert tr.meta["loop"] == loop, tr.meta["loop_reason"]
    V = tr.voltage
    # sample k applies min(V_{k-1} + 1, v_max): 0 → 1 → 2 … → 5 → 5.5 → 5.5 (the command 6.5 is clipped,
    # and the law reads the clipped 5.5, so it never runs away)
    want = np.minimum(np.arange(len(V)) + 1.0, v_max)
    np.testing.assert_array_equal(V[:len(want)], want)


def test_the_law_reads_the_applied_voltage_after_the_current_limit():
    """With an amplifier current limit the applied voltage is below the command: the law sees the
    limited one (the drive's own law gives it from the recorded current and speed)."""
    from mjbench.drive import drive_voltage

    m = _machine(AppliedPlus(2.0, period=1e-4), ["drive.v_max=48", "drive.i_max=3"])
    tr = simulate(m, "reduced", 0.01, record_dt=1e-4, loop="python")
    d = m.drive
    P = d.step_params(H)
    I, w, V = tr.current, tr.omega, tr.voltage
    limited = 0
    for k in range(1, tr.n):
        # the command at sample k is the voltage applied over step k−1 plus 2 V, limited by the drive
        cmd = min(V[k - 1] + 2.0, 48.0)
        assert V[k] == drive_voltage(I[k], cmd, w[k], P), k
        limited += V[k] < cmd
    assert limited > 10  # the current limit acted, and the law followed the limited voltage
    assert np.max(np.abs(I)) <= 3.0 + 1e-12


def test_signals_of_the_last_sample_are_visible_by_name():
    m = _machine(AppliedPlus(1.0, period=1e-3), ["drive.v_max=5.5", "drive.i_max=40"])
    pl = __import__("mjbench.backends.reduced", fromlist=["ReducedPlant"]).ReducedPlant(m)
    st = kernel.Stepper(pl, m, H, 100, 10)
    st.advance(101)
    sig = st.signals()
    assert sig["u_max"] == 5.5 and sig["u_min"] == -5.5 and sig["v_max"] == 5.5 and sig["i_max"] == 40.0
    assert sig["z"] == float(m.drive.z) and sig["t"] == pytest.approx(0.01)  # the last sample: step 100 (the end)
    assert set(SIG.AXIS) <= set(sig)


def test_a_new_signal_changes_no_law():
    """The layout is by name: every shipped law names only what it reads."""
    import inspect

    import controllers

    for name in controllers.names():
        cls = controllers.get(name)
        fn = getattr(cls, "law", None)
        if fn is None or not getattr(fn, "__mjbench_law__", False):
            continue
        params = list(inspect.signature(fn).parameters)
        for p in params:
            if p.isupper() or p in ("P", "S"):
                continue
            SIG.resolve(p, 0, 1)  # a name of the set (raises otherwise)


# ============================================================================ refused before simulating
@law
def reads_nonsense(t, speed_of_light, P, S):
    return 0.0


class Nonsense(AppliedPlus):
    law = reads_nonsense


def test_a_law_naming_an_unknown_signal_is_refused_before_simulating():
    with pytest.raises(ParameterError, match=r"controller 'applied_plus_test': law .*reads_nonsense reads "
                                             r"'speed_of_light' is not a signal"):
        simulate(_machine(Nonsense(1.0)), "reduced", 0.01, loop="python")


@law(outputs=("q",))
def writes_the_angle(t, P, S):
    return 0.0


class WritesQ(AppliedPlus):
    law = writes_the_angle


def test_a_law_cannot_write_a_measured_signal():
    with pytest.raises(ParameterError, match="declares the output 'q', which is read-only"):
        simulate(_machine(WritesQ(1.0)), "reduced", 0.01, loop="python")


# ============================================================================ the law contract
@law
def numpy_law(t, qd, P, S):
    return float(np.clip(P.dv * qd, -1.0, 1.0))


class NumpyCtrl(AppliedPlus):
    law = numpy_law


@law
def overflow_law(t, P, S):
    S[3] = t
    return P.dv


class OverflowCtrl(AppliedPlus):
    law = overflow_law


@law
def missing_attr_law(t, P, S):
    return P.gain * t


class MissingCtrl(AppliedPlus):
    law = missing_attr_law


class DictParams(AppliedPlus):
    def parameters(self, T, z):
        return {"dv": self.dv}


def _line(fn, text):
    import inspect

    lines, first = inspect.getsourcelines(fn)
    return first + next(i for i, ln in enumerate(lines) if text in ln)


def test_a_numpy_call_runs_in_cpython_and_says_which_line():
    tr = simulate(_machine(NumpyCtrl(0.1)), "reduced", 0.01)
    assert tr.meta["loop"] == "python"
    line = _line(numpy_law, "np.clip")
    assert f"numpy_law cannot be compiled: line {line}: calls NumPy (np.clip)" in tr.meta["loop_reason"]
    assert "controller 'applied_plus_test'" in tr.meta["loop_reason"]


def test_asking_for_the_compiled_loop_with_such_a_law_is_one_line():
    pytest.importorskip("numba")
    with pytest.raises(ParameterError, match="compiled loop was requested but .*numpy_law cannot be compiled: .*calls NumPy"):
        simulate(_machine(NumpyCtrl(0.1)), "reduced", 0.01, loop="compiled")


@pytest.mark.parametrize("ctrl,pattern", [
    (OverflowCtrl(1.0), r"overflow_law breaks the law contract at line \d+: writes S\[3\] past its state of 1 entry"),
    (MissingCtrl(1.0), r"missing_attr_law breaks the law contract at line \d+: reads P.gain, which parameters\(\) "
                       r"does not give \(it gives dv\)"),
    (DictParams(1.0), r"parameters\(\) returned a dict \(P\); return a namedtuple"),
])
def test_a_broken_law_is_one_line_before_simulating(ctrl, pattern):
    with pytest.raises(ParameterError, match=pattern):
        simulate(_machine(ctrl), "reduced", 0.01)


@law
def dynamic_overflow(t, P, S):
    k = int(P.dv)
    S[k] = t
    return 0.0


class DynamicOverflow(AppliedPlus):
    law = dynamic_overflow


def test_a_computed_index_past_the_state_is_an_error_naming_the_law_in_cpython():
    line = _line(dynamic_overflow, "S[k] = t")
    with pytest.raises(ParameterError, match=rf"dynamic_overflow failed at line {line} \(t = 0 s\): IndexError"):
        simulate(_machine(DynamicOverflow(5.0)), "reduced", 0.01, loop="python")


CHECK_SCRIPT = """
import sys
sys.path.insert(0, {here!r})
import test_signals as T
from mjbench.backends import simulate
from mjbench.errors import MjbenchError
try:
    simulate(T._machine(T.DynamicOverflow(5.0)), "reduced", 0.01)
except MjbenchError as e:
    print("ERR", e)
except IndexError as e:
    print("INDEX", e)
"""


def test_check_mode_makes_a_compiled_overflow_an_error_not_a_crash(tmp_path):
    pytest.importorskip("numba")
    env = {**os.environ, "MJBENCH_JIT": "check", "MJBENCH_CACHE_DIR": str(tmp_path / "cache")}
    r = subprocess.run([sys.executable, "-c", CHECK_SCRIPT.format(here=os.path.dirname(__file__))],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "dynamic_overflow" in r.stdout and "IndexError" in r.stdout, r.stdout


def test_an_unknown_jit_mode_is_refused(monkeypatch):
    monkeypatch.setenv("MJBENCH_JIT", "yes please")
    with pytest.raises(ParameterError, match=r"MJBENCH_JIT = 'yes please': must be 0 .*1 .*check"):
        simulate(_machine(AppliedPlus(1.0)), "reduced", 0.01)


# ============================================================================ the cache
CACHE_SCRIPT = """
import numpy as np
from mjbench import scenario as S
from mjbench.backends import simulate
from mjbench.compiled import cache
tr = simulate(S.make_machine(S.load("incerti2012"), "pid"), "reduced", 0.01, loop="compiled")
print("ROW", repr(float(tr.qd[-1])))
print("NOTES", cache.NOTES)
"""


def _cache_run(env):
    r = subprocess.run([sys.executable, "-c", CACHE_SCRIPT], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    out = dict(ln.split(" ", 1) for ln in r.stdout.splitlines() if " " in ln)
    return out["ROW"], out["NOTES"]


def test_a_corrupted_cache_entry_is_rebuilt_and_reported(tmp_path):
    pytest.importorskip("numba")
    env = {**os.environ, "MJBENCH_CACHE_DIR": str(tmp_path / "cache")}
    row, notes = _cache_run(env)
    assert notes == "[]"
    mods = sorted((tmp_path / "cache" / "kernels").glob("mjbench_loop_*.py"))
    assert mods
    for m in mods:  # truncate the generated module
        m.write_text(m.read_text()[: len(m.read_text()) // 2])
    row2, notes2 = _cache_run(env)
    assert row2 == row
    assert "corrupted (checksum); rebuilt" in notes2
    for f in (tmp_path / "cache" / "numba").rglob("*.nbi"):  # now corrupt numba's own index
        f.write_bytes(b"\x00garbage")
    row3, _ = _cache_run(env)
    assert row3 == row


def test_an_unwritable_cache_leaves_nothing_behind(tmp_path):
    pytest.importorskip("numba")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    tmpd = tmp_path / "tmp"
    tmpd.mkdir()
    try:
        env = {**os.environ, "MJBENCH_CACHE_DIR": str(ro / "cache"), "TMPDIR": str(tmpd),
               "NUMBA_CACHE_DIR": str(ro / "numba")}
        if os.geteuid() == 0:  # root writes anywhere: a path under a file cannot be created by anyone
            (tmp_path / "afile").write_text("")
            env["MJBENCH_CACHE_DIR"] = str(tmp_path / "afile" / "cache")
        row, notes = _cache_run(env)
        assert "not writable" in notes
        assert list(tmpd.iterdir()) == []
        assert not (tmp_path / "afile" / "cache").exists()
    finally:
        ro.chmod(0o700)


# ============================================================================ the loop template
def test_the_loop_template_unrolls_for_several_axes_and_controllers():
    from mjbench.kernel import unroll as LP

    one = LP.source(1, 1)
    assert "q_0" in one and "q_1" not in one and "CTRL_0(Y" in one
    two = LP.source(2, 2)
    for name in ("q_1", "CTRL_1(Y", "DSTEP_1(", "TAU[1]", "QO[4 * 1 + 1]"):
        assert name in two
    compile(two, "<loop>", "exec")
