"""Issue 35, "Trust, round 4": the newer surfaces' bad inputs (frest, design, FMU import, environment
variables, plugins, the Python API, signals, a Dask cluster without workers, a disk that fills).

Table-driven like tests/test_trust3.py: the CLI is called in-process, each bad input must give
exit status 2 and ONE line on stderr naming the option, key, file, mode or time, before any
simulation where it can be checked.  Then the behaviours: Ctrl-C at any moment (a subprocess
interrupted while MuJoCo is imported), a cluster that has no worker, the counts a disk-full sweep
prints, FMUs that fail at a time, a saturated frest, the settling check.  (The design torque
figures: tests/test_design_command.py, test_design_law.py; the stand-alone MJCF files:
tests/test_assets.py.)
"""
import errno
import json
import os
import re
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

from mjbench.cli import main

ROOT = Path(__file__).resolve().parents[1]
REQ = ROOT / "mjbench" / "scenarios" / "requirements"


def run_cli(args, capsys):
    """(exit status, stdout, stderr) of ``mjbench ARGS`` in-process."""
    code = main([str(a) for a in args])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def one_line(err, prefix="mjbench: error:"):
    lines = [ln for ln in err.strip().splitlines() if ln.startswith(prefix)]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def _edit(tmp_path, src, old, new, name="r.toml"):
    text = Path(src).read_text()
    assert old in text, old
    p = tmp_path / name
    p.write_text(text.replace(old, new, 1))
    return p


# ============================================================================ bad input → exit 2, one line
FREST = ["frest", "incerti-bezier"]
MOTION = REQ / "motion.toml"
POSE2 = '["60 mm", "40 mm", "-20 deg"]'

CASES = [
    # --- frest: every option value checked before simulating (were tracebacks, or a wrong blame)
    ("frest-amplitude-0", FREST + ["--amplitude", "0"], ["--amplitude", "> 0", "'0'"]),
    ("frest-amplitude-nan", FREST + ["--amplitude", "nan"], ["--amplitude", "finite"]),
    ("frest-amplitude-negative", FREST + ["--amplitude", "-2"], ["--amplitude", "> 0"]),
    ("frest-period-tiny", FREST + ["--period", "1e-9"], ["--period 1e-09 s", "8 control periods", "Nyquist"]),
    ("frest-period-zero", FREST + ["--period", "0"], ["--period", "> 0"]),
    ("frest-settle-negative", FREST + ["--settle", "-1"], ["--settle", ">= 0"]),
    ("frest-settle-inf", FREST + ["--settle", "inf"], ["--settle"]),
    ("frest-lines-0", FREST + ["--lines", "0"], ["--lines", ">= 1"]),  # (was blamed on rotation harmonics)
    ("frest-lines-text", FREST + ["--lines", "many"], ["--lines", "'many'"]),
    ("frest-periods-1", FREST + ["--periods", "1"], ["--periods", ">= 2"]),
    ("frest-band-above-nyquist", FREST + ["--band", "10,1e6"], ["--band", "Nyquist", "31415.9 rad/s"]),
    ("frest-band-reversed", FREST + ["--band", "500,50"], ["--band", "0 < LO < HI"]),
    ("frest-band-nan", FREST + ["--band", "10,nan"], ["--band", "finite"]),
    ("frest-band-between-lines", FREST + ["--band", "10,12", "--period", "0.5"], ["holds no harmonic"]),
    ("frest-at-q-huge", FREST + ["--at", "q=1e300"], ["--at q=1e+300", "<= 1e+06 rad"]),  # (ran on NaN)
    ("linearize-at-q-huge", ["linearize", "incerti2012", "--at", "q=-1e300", "--out", "{o}"], ["--at q=-1e+300"]),
    # --- design: degenerate poses are input errors (were NaN rows, a NumPy warning, a pydantic dump, exit 1)
    ("design-identical-poses", ["design", ("motion", POSE2, "[0.0, 0.0, 0.0]")],
     ["poses 1 and 2 are the same pose", "three different poses"]),
    ("design-pose-turned-full-circle", ["design", ("motion", '["120 mm", "20 mm", "-45 deg"]', '[0.0, 0.0, "360 deg"]')],
     ["poses 1 and 3 are the same pose"]),
    ("design-translation-on-a-line", ["design", ("motion", POSE2 + ', ["120 mm", "20 mm", "-45 deg"]',
                                                 '["60 mm", "0 mm", "0 deg"], ["120 mm", "0 mm", "0 deg"]')],
     ["pure translation along a line"]),
    ("design-search-box-empty", ["design", ("motion", 'search_box = [["-150 mm", "-250 mm"], ["150 mm", "50 mm"]]',
                                            'search_box = [["150 mm", "-250 mm"], ["-150 mm", "50 mm"]]')],
     ["search_box", "xmin < xmax"]),
    # --- scenario files and paths given to the API-backed commands
    ("run-scenario-folder", ["run", "{t}", "--out", "{o}"], ["is a directory"]),
]


@pytest.mark.parametrize("name,args,words", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_and_exit_2(name, args, words, tmp_path, capsys):
    out = tmp_path / "out"
    argv = []
    for a in args:
        if isinstance(a, tuple):  # (requirements file, old text, new text)
            argv.append(_edit(tmp_path, REQ / f"{a[0]}.toml", a[1], a[2]))
        else:
            argv.append(a.format(o=out, t=tmp_path))
    if argv[0] in ("frest",):
        argv += ["--out", out]
    t0 = time.perf_counter()
    code, _, err = run_cli(argv, capsys)
    assert code == 2, err
    line = one_line(err)
    for w in words:
        assert w in line, (w, line)
    assert not out.exists() or not any(out.iterdir())  # nothing written
    assert time.perf_counter() - t0 < 30  # refused before any simulation


# ============================================================================ environment variables
ENV_CASES = [
    ("MJBENCH_JIT", "yes", ["MJBENCH_JIT = 'yes'", "must be 0", "1"]),  # (was silently ignored)
    ("MJBENCH_JIT", "2", ["MJBENCH_JIT = '2'"]),
    ("MJBENCH_MAX_RECORD_MB", "inf", ["MJBENCH_MAX_RECORD_MB = 'inf'", "finite number of MiB > 0"]),
    ("MJBENCH_MAX_RECORD_MB", "nan", ["MJBENCH_MAX_RECORD_MB = 'nan'"]),
    ("MJBENCH_MAX_RECORD_MB", "-5", ["MJBENCH_MAX_RECORD_MB = '-5'"]),  # (was a false "diverged" message)
    ("MJBENCH_MAX_RECORD_MB", "lots", ["MJBENCH_MAX_RECORD_MB = 'lots'"]),
    ("MJBENCH_MAX_SWEEP_ROWS", "inf", ["MJBENCH_MAX_SWEEP_ROWS = 'inf'", "whole number of rows >= 1"]),
    ("MJBENCH_MAX_SWEEP_ROWS", "nan", ["MJBENCH_MAX_SWEEP_ROWS = 'nan'"]),
    ("MJBENCH_MAX_SWEEP_ROWS", "-3", ["MJBENCH_MAX_SWEEP_ROWS = '-3'"]),
    ("MJBENCH_MAX_SWEEP_ROWS", "2.5", ["MJBENCH_MAX_SWEEP_ROWS = '2.5'"]),
    ("MJBENCH_DASK_TIMEOUT", "inf", ["MJBENCH_DASK_TIMEOUT = 'inf'", "finite number of seconds > 0"]),
    ("MJBENCH_DASK_TIMEOUT", "nan", ["MJBENCH_DASK_TIMEOUT = 'nan'"]),
    ("MJBENCH_DASK_TIMEOUT", "-1", ["MJBENCH_DASK_TIMEOUT = '-1'"]),
    ("MJBENCH_DASK_TIMEOUT", "0", ["MJBENCH_DASK_TIMEOUT = '0'"]),
]


@pytest.mark.parametrize("var,value,words", ENV_CASES, ids=[f"{c[0]}={c[1]}" for c in ENV_CASES])
def test_bad_environment_variable_is_one_line_before_anything(var, value, words, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv(var, value)
    code, _, err = run_cli(["run", "incerti2012", "--t-end", "0.01", "--out", tmp_path / "o"], capsys)
    assert code == 2
    line = one_line(err)
    for w in words:
        assert w in line, (w, line)
    assert not (tmp_path / "o").exists()


def test_environment_values_that_are_accepted(monkeypatch):
    from mjbench import environment as E

    for v, mode in (("0", "python"), ("python", "python"), ("1", "compiled"), ("COMPILED", "compiled"), ("", "")):
        monkeypatch.setenv("MJBENCH_JIT", v)
        assert E.jit() == mode
    monkeypatch.setenv("MJBENCH_MAX_SWEEP_ROWS", "1e3")
    monkeypatch.setenv("MJBENCH_MAX_RECORD_MB", "0.5")
    monkeypatch.setenv("MJBENCH_DASK_TIMEOUT", "2.5")
    assert E.max_sweep_rows() == 1000 and E.max_record_mb() == 0.5 and E.dask_timeout(5.0) == 2.5


def test_bad_jit_variable_is_an_error_from_python_too(monkeypatch):
    """The kernel itself reads MJBENCH_JIT through the checked reader (the API, a script)."""
    import mjbench as mjb

    monkeypatch.setenv("MJBENCH_JIT", "fast")
    with pytest.raises(mjb.ParameterError, match="MJBENCH_JIT = 'fast'"):
        mjb.load("incerti2012").simulate(backend="reduced", t_end=0.01)


# ============================================================================ the Python API
def test_api_arguments_of_the_wrong_kind_are_named():
    import mjbench as mjb

    with pytest.raises(mjb.ParameterError, match=r"Machine\(mechanism='fourbar'\): expected a Mechanism object"):
        mjb.Machine("fourbar", "drive", "pid")
    scn = mjb.load("incerti2012")
    m = scn.machine()
    with pytest.raises(mjb.ParameterError, match=r"Machine\(drive='drive'\): expected a Drive object"):
        mjb.Machine(m.mechanism, "drive", m.controller)
    with pytest.raises(mjb.ParameterError, match=r"Machine\(controller='pid'\): expected a controller"):
        mjb.Machine(m.mechanism, m.drive, "pid")
    with pytest.raises(mjb.ParameterError, match=r"Machine\(q0=nan\): must be a finite number"):
        mjb.Machine(m.mechanism, m.drive, m.controller, q0=float("nan"))
    with pytest.raises(mjb.ParameterError, match=r"grid\['drive.R'\] = 2.0: expected a list of values"):
        mjb.parameter_sweep("incerti2012", {"drive.R": 2.0})  # (was "TypeError: 'float' object is not iterable")
    with pytest.raises(mjb.ParameterError, match=r"grid = \[.*expected a mapping"):
        mjb.parameter_sweep("incerti2012", [("drive.R", [1, 2])])
    with pytest.raises(mjb.ParameterError, match=r"perturb\['drive.R'\] = \[0.05\]"):
        mjb.parameter_sweep("incerti2012", samples=2, perturb={"drive.R": [0.05]})
    with pytest.raises(mjb.MjbenchError, match="not int"):
        mjb.load(42)
    assert mjb.load(ROOT / "mjbench" / "scenarios" / "incerti2012.toml").name == "incerti2012"  # a Path is a path


def test_frequency_response_api_checks_every_value():
    import mjbench as mjb

    for kw, words in ((dict(amplitude=0.0), "--amplitude 0.0"), (dict(lines=0), "--lines 0"),
                      (dict(lines=2.5), "--lines 2.5"), (dict(periods=1), "--periods 1"),
                      (dict(period=-1.0), "--period -1.0"), (dict(settle=float("nan")), "--settle nan"),
                      (dict(band=(5.0, 1e9)), "Nyquist")):
        with pytest.raises(mjb.ParameterError, match=re.escape(words)):
            mjb.frequency_response("incerti-bezier", **kw)


# ============================================================================ plugins
class _EP:
    """An installed entry point, as importlib.metadata gives it."""

    def __init__(self, name, group, obj):
        self.name, self.group, self.value, self._obj, self.dist = name, group, f"fake:{name}", obj, None

    def load(self):
        return self._obj


def test_plugin_class_named_like_a_builtin_does_not_crash_list(capsys, monkeypatch):
    """A controller plugin whose class says type_name = "pid" under the entry point "my-pid": `mjbench
    list` lists everything else and warns once, naming the entry point (was a TypeError traceback)."""
    from controllers.pid import PID
    from mjbench import registry

    Impostor = type("Impostor", (PID,), {"__module__": "impostor_pkg"})  # type_name "pid", another module
    real = registry.entry_points

    def fake(group):
        got = dict(real(group))
        if group == "mjbench.controllers":
            got["my-pid"] = _EP("my-pid", group, Impostor)
        return got
    monkeypatch.setattr(registry, "entry_points", fake)
    code, out, err = run_cli(["list"], capsys)
    assert code == 0 and "pid            built-in   controllers.pid.PID" in out
    assert "my-pid" in err and "type_name = 'pid'" in err and "built-in controller type" in err
    import controllers

    with pytest.raises(TypeError, match="a built-in controller type"):  # registering it in code: named too
        controllers.register(Impostor)


# ============================================================================ signals
INTERRUPT_DURING_IMPORT = r'''
import os, signal, sys
class Interrupt:
    """Sends SIGNAL to this process when NAME is imported: the handler runs inside the import."""
    def find_spec(self, name, path=None, target=None):
        if name == sys.argv[1]:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), getattr(signal, sys.argv[2]))
        return None
sys.meta_path.insert(0, Interrupt())
from mjbench.cli import main
sys.exit(main(["run", "incerti2012", "--t-end", "0.05", "--out", sys.argv[3]]))
'''


@pytest.mark.parametrize("module,sig,code", [("mujoco", "SIGINT", 130), ("numpy", "SIGINT", 130),
                                             ("mujoco", "SIGTERM", 143)])
def test_interrupt_while_mujoco_is_imported_is_one_line(tmp_path, module, sig, code):
    """Ctrl-C in the first ~0.4 s (MuJoCo, NumPy being imported) was a KeyboardInterrupt traceback:
    the handlers are now installed before any heavy import; exit 130 (143) and one line."""
    env = {**os.environ, "MUJOCO_GL": "egl"}
    # the child starts with SIGINT/SIGTERM at their defaults, as from a terminal: a suite started in the
    # background (`cmd &` in a non-interactive shell) passes SIGINT ignored, which mjbench rightly keeps
    r = subprocess.run([sys.executable, "-c", INTERRUPT_DURING_IMPORT, module, sig, str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=120, env=env,
                       preexec_fn=lambda: (signal.signal(signal.SIGINT, signal.SIG_DFL),
                                           signal.signal(signal.SIGTERM, signal.SIG_DFL)))
    assert r.returncode == code, r.stderr
    assert r.stderr == f"mjbench: interrupted ({sig})\n"
    assert not (tmp_path / "o").exists()


def test_interrupt_turned_into_an_import_error_is_still_an_interrupt(tmp_path, capsys, monkeypatch):
    """A signal arriving inside an extension module's initialisation surfaces as "ImportError:
    initialization failed"; a signal swallowed by an import-lock callback surfaces as nothing:
    both still end the command with one line and 130."""
    from mjbench import cli, outputs

    def import_error(argv=None):
        try:
            outputs._handler(signal.SIGINT, None)
        except KeyboardInterrupt as e:
            raise ImportError("initialization failed") from e
    monkeypatch.setattr(cli, "build_parser", import_error)
    code, _, err = run_cli(["run", "incerti2012", "--out", tmp_path / "o"], capsys)
    assert code == 130 and err == "mjbench: interrupted (SIGINT)\n"

    real = cli.build_parser

    def swallowed(argv=None):
        try:
            outputs._handler(signal.SIGINT, None)
        except KeyboardInterrupt:
            pass  # ("Exception ignored in: <function _get_module_lock.<locals>.cb>")
        return real(argv)
    monkeypatch.setattr(cli, "build_parser", swallowed)
    code, _, err = run_cli(["run", "incerti2012", "--t-end", "0.01", "--out", tmp_path / "o"], capsys)
    assert code == 130 and err == "mjbench: interrupted (SIGINT)\n" and not (tmp_path / "o").exists()


# ============================================================================ Dask, disk full
def test_dask_cluster_without_workers_is_an_error_after_the_stated_timeout(tmp_path, capsys, monkeypatch):
    """A cluster that has (or keeps) no worker used to make the sweep wait forever."""
    distributed = pytest.importorskip("dask.distributed")
    monkeypatch.setenv("MJBENCH_DASK_TIMEOUT", "1")
    with distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        code, _, err = run_cli(["sweep", "incerti2012", "--grid", "drive.R=2,3", "--t-end", "0.05", "--scheduler",
                                cluster.scheduler_address, "--out", tmp_path / "s"], capsys)
    assert code == 2
    line = one_line(err)
    assert "the Dask cluster had no worker for 1 s (MJBENCH_DASK_TIMEOUT)" in line and "no row was saved" in line
    assert not (tmp_path / "s").exists()


def test_disk_full_sweep_counts_the_rows_the_table_holds(tmp_path, capsys, monkeypatch):
    """The table is rewritten after each chunk; when a write fails, the message counts the rows of
    the last complete write (was: the rows computed, 400 of 1500 while the file held 200)."""
    import mjbench.sweep as SW

    real, calls = SW.table.atomic_write, []

    def fill_up(path, writer, *a, **k):
        calls.append(path)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, writer, *a, **k)
    monkeypatch.setattr(SW.table, "atomic_write", fill_up)
    out = tmp_path / "s"
    code, _, err = run_cli(["sweep", "incerti2012", "--grid", "drive.R=1.8,2,2.2,2.4", "--t-end", "0.05",
                            "--chunk", "1", "--verify", "0", "--out", out], capsys)
    assert code == 2
    line = one_line(err)
    held = len((out / "results.csv").read_text().splitlines()) - 1
    assert held == 2 and "2 of 4 rows are saved" in line and "No space left on device" in line


# ============================================================================ FMU import
@pytest.fixture(scope="module")
def faulty_fmu(tmp_path_factory):
    """A pythonfmu controller FMU: u = 1 until t_fail, then its doStep raises (mode 1) or returns
    False (mode 2: fmi2Discard)."""
    pytest.importorskip("pythonfmu")
    from pythonfmu.builder import FmuBuilder

    d = tmp_path_factory.mktemp("faulty")
    src = d / "Faulty.py"
    src.write_text('''
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real


class Faulty(Fmi2Slave):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.u, self.t_fail, self.mode = 1.0, 0.005, 1
        self.register_variable(Real("u", causality=Fmi2Causality.output))
        self.register_variable(Real("t_fail", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))
        self.register_variable(Integer("mode", causality=Fmi2Causality.parameter, variability=Fmi2Variability.tunable))

    def do_step(self, current_time, step_size):
        if current_time >= self.t_fail:
            if self.mode == 1:
                raise RuntimeError("the controller's model failed")
            return False
        return True
''')
    return Path(FmuBuilder.build_FMU(src, dest=d))


def _fmu_mode(path, *extra):
    return ["run", "incerti2012", "--mode", "ext", "--backend", "reduced", "--t-end", "0.02",
            "--set", 'modes.ext.type="fmu"', "--set", f'modes.ext.path="{path}"', "--set", 'modes.ext.output="u"',
            "--set", "modes.ext.period=1e-3", *[x for e in extra for x in ("--set", e)]]


def _zip(path, files):
    with zipfile.ZipFile(path, "w") as z:
        for name, text in files.items():
            z.writestr(name, text)
    return path


MD = ('<fmiModelDescription fmiVersion="2.0" modelName="x" guid="{1}"><CoSimulation modelIdentifier="x"/>'
      '<ModelVariables><ScalarVariable name="u" valueReference="0" causality="output"><Real/></ScalarVariable>'
      '</ModelVariables><ModelStructure/></fmiModelDescription>')


@pytest.mark.parametrize("kind,words", [
    ("text", ["modes.ext.path", "not an FMU", "not one"]),
    ("folder", ["modes.ext.path", "is a folder"]),
    ("no-description", ["modes.ext.path", "no modelDescription.xml"]),
    ("bad-xml", ["modes.ext.path", "invalid modelDescription.xml", "XMLSyntaxError"]),
    ("no-binary", ["modes.ext.path", "no binary for this platform"]),
])
def test_fmu_that_is_not_usable_is_named_before_the_run(tmp_path, capsys, kind, words):
    pytest.importorskip("fmpy")
    p = tmp_path / "c.fmu"
    if kind == "text":
        p.write_text("not a zip")
    elif kind == "folder":
        p.mkdir()
    elif kind == "no-description":
        _zip(p, {"readme.txt": "x"})
    elif kind == "bad-xml":
        _zip(p, {"modelDescription.xml": '<fmiModelDescription fmiVersion="2.0"><oops'})
    else:
        _zip(p, {"modelDescription.xml": MD})
    code, _, err = run_cli(_fmu_mode(p) + ["--out", tmp_path / "o"], capsys)
    assert code == 2
    line = one_line(err)
    for w in words:
        assert w in line, (w, line)


@pytest.mark.parametrize("mode,status", [(1, "status 4 (fatal)"), (2, "status 2 (discard)")])
def test_fmu_whose_step_fails_names_the_mode_and_the_time(faulty_fmu, tmp_path, capsys, mode, status):
    args = _fmu_mode(faulty_fmu, f"modes.ext.parameters.mode={mode}") + ["--out", str(tmp_path / "o")]
    if mode == 1:
        # in its own process: a PythonFMU slave whose do_step raises leaves the interpreter it runs in
        # corrupted (PythonFMU 0.7.0: a later garbage collection segfaults; docs/bridges.md §2)
        r = subprocess.run([sys.executable, "-m", "mjbench", *args], capture_output=True, text=True, timeout=120,
                           env={**os.environ, "MUJOCO_GL": "egl"})
        code, err = r.returncode, r.stderr
    else:
        code, _, err = run_cli(args, capsys)
    assert code == 2
    line = one_line(err)
    assert "modes.ext" in line and "doStep at t = 0.005 s" in line and status in line
    assert not (tmp_path / "o").exists()


def test_fmu_integer_parameter_is_set_as_an_integer(faulty_fmu, tmp_path, capsys):
    """(An Integer parameter was set with setReal: the FMU failed "fatal" at t = 0.)"""
    code, _, err = run_cli(_fmu_mode(faulty_fmu, "modes.ext.parameters.mode=2", "modes.ext.parameters.t_fail=1")
                           + ["--no-figure", "--quiet", "--out", tmp_path / "o"], capsys)
    assert code == 0, err
    code, _, err = run_cli(_fmu_mode(faulty_fmu, "modes.ext.parameters.mode=1.5") + ["--out", tmp_path / "o2"], capsys)
    assert code == 2 and "modes.ext.parameters.mode = 1.5" in one_line(err) and "whole number" in one_line(err)


# ============================================================================ frest: saturation, settling
def test_frest_on_a_saturated_loop_is_flagged_in_the_printed_result(tmp_path, capsys):
    """--amplitude 1e6 printed GM ∞ / PM ∞ with coherence 1 and exit 0 while the limiter was on 99.9 % of
    the time: now the summary says SATURATED, the margins "NOT VALID", stderr one line, exit 1 (and
    1e6 V itself is refused: --amplitude ≤ 1e5)."""
    out = tmp_path / "f"
    code, text, err = run_cli(FREST + ["--amplitude", "1e4", "--lines", "4", "--periods", "2", "--settle", "0.2",
                                       "--period", "0.2", "--band", "40,400", "--out", out], capsys)
    assert code == 1
    js = json.loads((out / "frest.json").read_text())
    sat = js["saturation"]
    assert sat["saturated"] and sat["limiter_active_fraction"] > 0.5 and sat["limit_fraction"] == 0.01
    assert "SATURATED" in text and "NOT VALID: saturated" in text
    assert "mjbench: frest: the voltage limiter" in one_line(err, "mjbench: frest:")


def test_frest_settling_too_short_given_by_the_user_is_a_warning():
    """An explicit settling time is kept, and its result flagged when the lowest line still moves."""
    from mjbench import frest
    from mjbench import scenario as S

    res = frest.measure(S.load("incerti-bezier"), backend="reduced", settle=0.3, periods=2, n_lines=3,
                        band=(12.0, 200.0), linear=False)
    st = res["json"]["settling"]
    assert not st["settled"] and st["lowest_line_change"] > st["tolerance"] == frest.SETTLE_TOL
    assert st["extended_from_s"] is None and "lengthen --settle" in st["note"]
    assert any(n.startswith("warning: the lowest line changed") for n in res["json"]["notes"])


# ============================================================================ design: impossible bound
def test_design_impossible_tracking_bound_is_reported_as_the_bound(tmp_path, capsys):
    """(Was reported as "harmonic balance did not converge".)"""
    p = _edit(tmp_path, REQ / "seed000-law.toml", 'tracking_error_max = "1 deg"', 'tracking_error_max = "0.00001 deg"')
    code, out, err = run_cli(["design", p, "--no-tune", "--no-verify"], capsys)
    assert code == 1, err
    assert "peak tracking error: " in out and "(tracking_error_max, best of every analysed candidate)" in out
    assert "no candidate of the catalogue" in out
    assert "harmonic balance did not converge" not in out
