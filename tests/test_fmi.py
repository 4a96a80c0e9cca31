"""FMI bridges (docs/bridges.md): the exported plant FMU against mjbench's own runs (FMPy), the
torque input's ideal current source, parameters with units, and controller FMUs in the kernel
(``type = "fmu"``): one built here from C sources with fmpy.build, one exported by mjbench."""
from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")

from mjbench import scenario as S  # noqa: E402
from mjbench.backends import simulate  # noqa: E402
from mjbench.runner import backend_options  # noqa: E402

DATA = Path(__file__).parent / "data"
H = 1e-4


@pytest.fixture(scope="module")
def plant_fmu(tmp_path_factory):
    from mjbench.fmi import export_fmu

    return export_fmu(S.load("incerti2012"), tmp_path_factory.mktemp("fmu") / "plant.fmu")


def _run(scn, mode, backend, t_end, record_dt):
    return simulate(S.make_machine(scn, mode), backend, t_end, record_dt=record_dt,
                    options=backend_options(scn, backend))


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


class _Slave:
    """An FMU instance driven step by step from the test (FMPy's FMU2Slave)."""

    def __init__(self, path, start=None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.md = md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.dir = extract(str(path))
        self.s = FMU2Slave(guid=md.guid, unzipDirectory=self.dir, modelIdentifier=md.coSimulation.modelIdentifier,
                           instanceName="test")
        self.s.instantiate()
        for k, v in (start or {}).items():
            self.s.setReal([self.vr[k]], [v])
        self.s.setupExperiment(startTime=0.0)
        self.s.enterInitializationMode()
        self.s.exitInitializationMode()

    def get(self, *names):
        return self.s.getReal([self.vr[n] for n in names])

    def close(self):
        self.s.terminate()
        self.s.freeInstance()
        self.s.freeLibrary()  # pythonfmu's binary must be released before the interpreter exits
        shutil.rmtree(self.dir, ignore_errors=True)


def test_exported_plant_validates_with_units(plant_fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(plant_fmu)) == []
    with zipfile.ZipFile(plant_fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
        names = set(z.namelist())
    var = {v.get("name"): v for v in root.iter("ScalarVariable")}
    units = {u.get("name") for u in root.iter("Unit")}
    for name, unit in (("drive.R", "Ohm"), ("drive.L", "H"), ("drive.k_m", "N.m/A"), ("drive.J_m", "kg.m2"),
                       ("mechanism.a", "m"), ("mechanism.m2", "kg"), ("voltage_in", "V"), ("crank_speed", "rad/s"),
                       ("current", "A"), ("crank_torque", "N.m")):
        assert var[name].find("Real").get("unit") == unit and unit in units, name
    assert var["drive.R"].get("causality") == "parameter" and float(var["drive.R"].find("Real").get("start")) == 2.0
    assert var["points.P.x"].get("causality") == "output"
    assert {"resources/mjbench_fmu.json", "resources/requirements.txt", "resources/mjbench/kernel/loop.py",
            "binaries/linux64/incerti2012_plant_voltage.so"} <= names
    req = zipfile.ZipFile(plant_fmu).read("resources/requirements.txt").decode()
    assert "mujoco" in req and "numpy" in req


def test_plant_fmu_constant_voltage_reproduces_open_loop(plant_fmu):
    """FMPy co-simulation at 25 V against `mjbench run --mode open` (multibody, same 0.1 ms step)."""
    from fmpy import simulate_fmu

    T, dt = 0.5, 5e-4
    res = simulate_fmu(str(plant_fmu), start_values={"voltage_in": 25.0}, stop_time=T, step_size=dt,
                       output_interval=dt, output=["crank_speed", "current", "crank_angle"])
    scn = S.load("incerti2012")
    tr = _run(scn, "open", "multibody", T, dt)
    assert len(res) == len(tr.t)
    np.testing.assert_allclose(res["time"], tr.t, rtol=0, atol=1e-12)
    assert _rel(res["crank_speed"], tr.qd) <= 1e-6
    assert _rel(res["current"], tr.current) <= 1e-6
    assert _rel(res["crank_angle"], tr.q) <= 1e-6


def test_pid_closed_on_the_fmpy_side_equals_mjbench_pid(plant_fmu):
    """The seed-000 PID (K_p·t, anti-windup, ±48 V) closed around the FMU at every 0.1 ms step on
    the FMPy side, against mjbench's own PID run with the same sampling."""
    from controllers.base import Measurement

    scn = S.load("incerti2012")
    mach = S.make_machine(scn, "pid")
    ctrl = mach.controller
    ctrl.reset()
    y = Measurement(z=float(mach.drive.z))
    T, dec = 0.4, 5
    N = int(round(T / H))
    fmu = _Slave(plant_fmu)
    got, qd_prev = [], None
    try:
        for n in range(N + 1):
            t = n * H
            q, qd, I = fmu.get("crank_angle", "crank_speed", "current")
            if n % dec == 0:
                got.append(qd)
            if n == N:
                break
            u = ctrl(t, y.set(t, q, qd, 0.0 if qd_prev is None else (qd - qd_prev) / H, I))
            fmu.s.setReal([fmu.vr["voltage_in"]], [u])
            fmu.s.doStep(currentCommunicationPoint=t, communicationStepSize=H)
            qd_prev = qd
    finally:
        fmu.close()
    tr = _run(scn, "pid", "multibody", T, dec * H)
    assert _rel(got, tr.qd) <= 1e-6
    assert float(np.max(np.abs(tr.voltage))) == pytest.approx(48.0)  # the limiter is exercised


def test_parameter_with_unit_changes_the_plant(tmp_path):
    """drive.R set through the FMU equals `--set drive.R=2.5`; reduced backend FMU."""
    from fmpy import simulate_fmu

    from mjbench.fmi import export_fmu

    path = export_fmu(S.load("incerti2012"), tmp_path / "red.fmu", backend="reduced")
    res = simulate_fmu(str(path), start_values={"voltage_in": 25.0, "drive.R": 2.5}, stop_time=0.3, step_size=1e-3,
                       output_interval=1e-3, output=["crank_speed"])
    tr = _run(S.load("incerti2012", ["drive.R=2.5"]), "open", "reduced", 0.3, 1e-3)
    ref = _run(S.load("incerti2012"), "open", "reduced", 0.3, 1e-3)
    assert _rel(res["crank_speed"], tr.qd) <= 1e-6
    assert _rel(res["crank_speed"], ref.qd) > 1e-2  # R matters


def test_torque_input_is_an_ideal_current_source():
    """Each co-step's exact mean current (the torque's) equals T/k_m (the voltage it takes is not
    limited: an ideal current source)."""
    from mjbench.drive import current_mean
    from mjbench.fmi.session import PlantSession

    scn = S.load("incerti2012")
    ps = PlantSession(scn, "torque", "reduced")
    ps.start()
    Pd = ps.program.drive_P[0]
    T = 1.3
    ps.set_input(T)
    errs = []
    for n in range(300):
        I0, w0 = ps.output("current"), ps.output("motor_speed")
        ps.step(n * H, H)
        Ibar = current_mean(I0, ps.output("voltage"), w0, Pd)
        errs.append(Ibar - T / float(scn.drive.k_m))
    assert max(abs(e) for e in errs) < 1e-12
    with pytest.raises(Exception, match="ideal current source"):
        PlantSession(S.load("incerti2012", ["drive.pwm.frequency=20e3", "drive.pwm.v_bus=48"]), "torque").start()


@pytest.fixture(scope="module")
def c_pid_fmu(tmp_path_factory):
    """The C-source PID FMU of tests/data/fmu_pid built with the machine's compiler (fmpy.build)."""
    if shutil.which("cmake") is None or (shutil.which("cc") is None and shutil.which("gcc") is None):
        pytest.skip("cmake and a C compiler are needed to build the FMU")
    from fmpy.build import build_platform_binary
    from fmpy.util import create_zip_archive

    tmp = tmp_path_factory.mktemp("cfmu")
    src = tmp / "pid"
    shutil.copytree(DATA / "fmu_pid", src)
    (tmp / "build").mkdir()
    build_platform_binary(src, build_dir=tmp / "build")
    path = tmp / "pid.fmu"
    create_zip_archive(path, src)
    return path


EXT_PID = ['modes.ext.type="fmu"', 'modes.ext.output="V"', "modes.ext.period=1e-4", "modes.ext.omega0=30.0",
           'modes.ext.inputs={phi="phi", omega="omega", omega_dot="omega_dot", phi_ref="phi_ref", '
           'omega_ref="omega_ref", omega_dot_ref="omega_dot_ref"}',
           'modes.ext.parameters={kp=80.0, ki=32.0, kd=0.015, ramp=1.0}']


@pytest.mark.parametrize("backend", ["reduced", "multibody"])
def test_c_source_fmu_controller_equals_builtin_pid(c_pid_fmu, backend):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(c_pid_fmu)) == []
    # Eq 16 with K_p·t, no anti-windup (the C FMU has none): the built-in PID with v_limit = none
    scn = S.load("incerti2012", ["modes.pid.v_limit=none", f'modes.ext.path="{c_pid_fmu}"', *EXT_PID])
    a = _run(scn, "ext", backend, 0.4, 5e-4)
    b = _run(scn, "pid", backend, 0.4, 5e-4)
    assert a.meta["loop"] == "python" and "no compiled form" in a.meta["loop_reason"]
    assert _rel(a.qd, b.qd) <= 1e-9
    assert float(np.max(np.abs(a.voltage - b.voltage))) <= 1e-9 * 48
    # wrong mapping: one error naming the variable
    with pytest.raises(Exception, match="no input variable"):
        S.make_machine(S.load("incerti2012", [f'modes.ext.path="{c_pid_fmu}"', *EXT_PID[:-2],
                                              'modes.ext.inputs={speed="omega"}']), "ext")


def test_exported_controller_fmu_equals_builtin_pid(tmp_path):
    """mjbench's own export of the seed-000 PID (K_p·t, anti-windup) run back as type = "fmu"."""
    from mjbench.fmi import export_fmu

    path = export_fmu(S.load("incerti2012"), tmp_path / "pid.fmu", kind="controller", mode="pid")
    scn = S.load("incerti2012", ['modes.ext.type="fmu"', f'modes.ext.path="{path}"', 'modes.ext.output="u"',
                                 "modes.ext.period=1e-4", 'modes.ext.inputs={q="q", qd="qd", qdd="qdd", current="current"}'])
    a = _run(scn, "ext", "reduced", 0.4, 5e-4)
    b = _run(scn, "pid", "reduced", 0.4, 5e-4)
    assert _rel(a.qd, b.qd) <= 1e-9
    assert float(np.max(np.abs(b.voltage))) == pytest.approx(48.0)


def test_cli_export_fmu(tmp_path, capsys):
    from mjbench.cli import main

    out = tmp_path / "bez.fmu"
    assert main(["export-fmu", "incerti-bezier", "--backend", "reduced", "--out", str(out)]) == 0
    assert "FMPy validation: passed" in capsys.readouterr().out
    with zipfile.ZipFile(out) as z:
        md = z.read("modelDescription.xml").decode()
    assert 'name="deflection"' in md and 'name="mechanism.k"' in md
    assert main(["export-fmu", "incerti-bezier", "--out", str(out)]) == 2  # exists, no --force
    assert main(["export-fmu", "incerti2012", "--input", "torque", "--set", "drive.pwm.frequency=2e4",
                 "--set", "drive.pwm.v_bus=48", "--out", str(tmp_path / "t.fmu")]) == 2
    assert "ideal current source" in capsys.readouterr().err
    assert not (tmp_path / "t.fmu").exists()
