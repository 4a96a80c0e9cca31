"""Plugins: a mechanism, a controller and a scenario from a separately installed package.

The package ``tests/data/plugin`` (mjbench-scotch-yoke: a Scotch yoke, a lead-lag speed controller,
a scenario using both) declares three entry points in a standard ``pyproject.toml``.  It is built
into a wheel here (offline: zip + dist-info, no build backend needed), installed by pip into a
temporary folder, and used from a fresh interpreter with that folder on PYTHONPATH: ``mjbench
list`` shows its scenario and its component types, and ``run`` (both backends, compiled),
``analyze``, ``sweep`` (batched), ``linearize``, ``tune`` (the scenario's PID, and the plugin's
lead-lag through the gains its class declares, ``LeadLag.TUNABLE``), ``frest`` and ``render`` run
it.  Nothing in mjbench names the plugin.  A drive type from an entry point (group
``mjbench.drives``) is found by the same registry class.

Independent checks: the yoke's closed-form reduced model against MuJoCo (the two backends of one
run agree); the lead-lag's recorded voltages against scipy's ``lfilter`` of its Tustin
coefficients; a batch against its single runs; the CPython loop against the compiled loop.
"""
import base64
import hashlib
import json
import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PLUGIN = ROOT / "tests" / "data" / "plugin"


def build_wheel(src: Path, out: Path) -> Path:
    """A pure-Python wheel of the plugin from its pyproject.toml ([project] name, version,
    entry points; [tool.setuptools] packages and package-data)."""
    meta = tomllib.loads((src / "pyproject.toml").read_text())
    proj, st = meta["project"], meta["tool"]["setuptools"]
    name, ver = proj["name"].replace("-", "_"), proj["version"]
    info = f"{name}-{ver}.dist-info"
    files = {}
    for pkg in st["packages"]:
        folder = src / pkg.replace(".", "/")
        pats = ["*.py"] + st.get("package-data", {}).get(pkg, [])
        for pat in pats:
            for f in sorted(folder.glob(pat)):
                files[f"{pkg.replace('.', '/')}/{f.name}"] = f.read_bytes()
    eps = "".join(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in items.items()) + "\n"
                  for group, items in proj["entry-points"].items())
    files[f"{info}/METADATA"] = f"Metadata-Version: 2.1\nName: {proj['name']}\nVersion: {ver}\n".encode()
    files[f"{info}/WHEEL"] = b"Wheel-Version: 1.0\nGenerator: mjbench-tests\nRoot-Is-Purelib: true\nTag: py3-none-any\n"
    files[f"{info}/entry_points.txt"] = eps.encode()
    record = "".join(f"{p},sha256={base64.urlsafe_b64encode(hashlib.sha256(b).digest()).rstrip(b'=').decode()},{len(b)}\n"
                     for p, b in files.items()) + f"{info}/RECORD,,\n"
    files[f"{info}/RECORD"] = record.encode()
    whl = out / f"{name}-{ver}-py3-none-any.whl"
    with zipfile.ZipFile(whl, "w") as z:
        for p, b in files.items():
            z.writestr(p, b)
    return whl


DRIVER = r'''
import contextlib, io, json, sys
import numpy as np
from mjbench import cli
out = sys.argv[1]
res = {}

def cmd(*args):
    buf, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
        rc = cli.main(list(args))
    return rc, buf.getvalue(), err.getvalue()

res["list"] = cmd("list")
res["run"] = cmd("run", "scotch-yoke", "--backend", "both", "--t-end", "0.5", "--out", f"{out}/run")
res["analyze"] = cmd("analyze", "scotch-yoke", "--points", "90", "--out", f"{out}/analyze")
res["sweep"] = cmd("sweep", "scotch-yoke", "--grid", "modes.leadlag.K=0.5,1.0,2.0", "--t-end", "0.3",
                   "--verify", "1", "--metric", "peak_current_A", "--out", f"{out}/sweep")
res["linearize"] = cmd("linearize", "scotch-yoke", "--at", "q=0.3", "--angles", "4", "--out", f"{out}/lin")
res["tune"] = cmd("tune", "scotch-yoke", "--controller", "pid", "--objective", "ise", "--t-end", "0.2",
                  "--global", "4", "--maxfev", "4", "--verify", "1", "--bounds", "kd=1e-5:1e-3",
                  "--out", f"{out}/tune")
res["tune_leadlag"] = cmd("tune", "scotch-yoke", "--controller", "lead-lag", "--objective", "ise", "--t-end", "0.2",
                          "--global", "4", "--maxfev", "4", "--verify", "1", "--span", "1000", "--out", f"{out}/tune-ll")
res["tune_leadlag_bounds"] = cmd("tune", "scotch-yoke", "--controller", "lead-lag", "--objective", "ise",
                                 "--bounds", "wp=10:1e5", "--t-end", "0.2")
res["frest"] = cmd("frest", "scotch-yoke", "--mode", "leadlag", "--periods", "2", "--lines", "6",
                   "--out", f"{out}/frest")
res["render"] = cmd("render", "scotch-yoke", "--t-end", "0.2", "--fps", "10", "--width", "160", "--height", "96",
                    "--no-progress", "--out", f"{out}/yoke.mp4")

# in Python: the registries, a batch against single runs, the CPython loop against the compiled loop
import controllers, mjbench.mechanisms as mechanisms
from mjbench import scenario as S
from mjbench.backends import simulate, simulate_many
res["types"] = [mechanisms.get("scotch-yoke").__module__, controllers.get("lead-lag").__module__,
                "scotch-yoke" in mechanisms.names(), "lead-lag" in controllers.names()]
import mjbench
res["components"] = [[c.kind, c.name, c.origin, c.source, {k: list(v) for k, v in c.tunable.items()}]
                     for c in mjbench.list_components() if c.origin != "built-in"]
scn = S.load("scotch-yoke")
Ks = (0.5, 2.0)
machines = [S.make_machine(S.with_values(scn, {"modes.leadlag.K": k}), "leadlag") for k in Ks]
loops = {}
for b in ("reduced", "multibody"):
    batch = simulate_many(machines, b, 0.2, record_dt=1e-4)
    single = [simulate(S.make_machine(S.with_values(scn, {"modes.leadlag.K": k}), "leadlag"), b, 0.2,
                       record_dt=1e-4, loop="compiled") for k in Ks]
    py = simulate(S.make_machine(S.with_values(scn, {"modes.leadlag.K": Ks[1]}), "leadlag"), b, 0.2,
                  record_dt=1e-4, loop="python")
    loops[b] = {"batch_equals_single": all(np.array_equal(batch.trajectory(i).data, s.data) for i, s in enumerate(single)),
                "python_equals_compiled": bool(np.array_equal(py.data, single[1].data)),
                "loop": single[1].meta["loop"], "batch_loop": batch.meta.get("loop")}
    np.save(f"{out}/{b}.npy", np.vstack([single[1].omega, single[1].voltage]))
res["loops"] = loops
json.dump(res, open(f"{out}/driver.json", "w"))
'''


@pytest.fixture(scope="module")
def plugin_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("plugin")
    whl = build_wheel(PLUGIN, tmp)
    site = tmp / "site"
    p = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "--quiet",
                        "--target", str(site), str(whl)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    out = tmp / "out"
    out.mkdir()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]),
           "MUJOCO_GL": "egl", "MJBENCH_JIT": "1"}
    p = subprocess.run([sys.executable, "-c", DRIVER, str(out)], env=env, capture_output=True, text=True,
                       timeout=900, cwd=tmp)
    assert p.returncode == 0, p.stderr[-4000:]
    return out, json.loads((out / "driver.json").read_text()), site


def test_installed_like_any_package(plugin_run):
    _, res, site = plugin_run
    assert sorted(x.name for x in site.glob("*.dist-info")) == ["mjbench_scotch_yoke-0.1.0.dist-info"]
    assert res["types"] == ["mjbench_scotch_yoke.yoke", "mjbench_scotch_yoke.leadlag", True, True]
    # no edit to mjbench: nothing in the package names the plugin
    for pkg in ("mjbench", "controllers"):
        for f in (ROOT / pkg).rglob("*.py"):
            assert "scotch" not in f.read_text().lower(), f
    # without the plugin on the path the names are unknown
    from mjbench import scenario as S

    assert "scotch-yoke" not in S.builtin_names()


def test_every_command_runs_it(plugin_run):
    out, res, _ = plugin_run
    for name in ("list", "run", "analyze", "sweep", "linearize", "tune", "frest", "render"):
        assert res[name][0] == 0, (name, res[name][2][-2000:])
    assert any(line.startswith("scotch-yoke ") and "leadlag" in line for line in res["list"][1].splitlines())
    assert (out / "yoke.mp4").stat().st_size > 1000
    assert (out / "lin" / "linear.json").exists()
    an = json.loads((out / "analyze" / "analysis.json").read_text())
    assert an["applicable"] and an["reduced"]["J_max"] > an["reduced"]["J_min"]  # J(q) of the yoke over a turn
    assert "no linkage view" in an["kinematics_unavailable"]["transmission_angles"]  # says what it cannot give
    assert (out / "frest" / "frest.json").exists() and (out / "tune" / "tune.json").exists()
    rows = (out / "sweep" / "results.csv").read_text().splitlines()
    assert len(rows) == 4 and all(",ok," in r for r in rows[1:])


def test_list_shows_the_plugin_types(plugin_run):
    _, res, _ = plugin_run
    assert res["components"] == [
        ["mechanism", "scotch-yoke", "plugin", "mjbench_scotch_yoke.yoke.ScotchYoke (distribution mjbench-scotch-yoke)",
         {}],
        ["controller", "lead-lag", "plugin", "mjbench_scotch_yoke.leadlag.LeadLag (distribution mjbench-scotch-yoke)",
         {"lead-lag": ["K", "wz", "wp"]}]]
    lines = res["list"][1].splitlines()
    kinds = [line for line in lines if line.endswith(" types:")]
    assert kinds == ["mechanism types:", "controller types:", "drive types:"]
    assert any(line.split()[:2] == ["lead-lag", "plugin"] and "tune --controller lead-lag (K, wz, wp)" in line
               for line in lines)
    assert any(line.split()[:3] == ["pid", "built-in", "controllers.pid.PID"]
               and "pid (kp, ki, kd); pid-tv (kp, ki, kd)" in line for line in lines)
    assert any(line.split()[:2] == ["torque", "built-in"] for line in lines)


def test_tune_a_plugin_controller_by_its_declared_gains(plugin_run):
    """``tune --controller lead-lag``: the gains LeadLag.TUNABLE declares, in its order; the box
    ×/÷ --span 1000 around the scenario's K = 1, ω_z = 300, ω_p = 3000 clipped to the declared
    intervals (ω_z, ω_p within 1 ... 3e4 rad/s); a --bounds outside them refused before any run."""
    out, res, _ = plugin_run
    rc, text, err = res["tune_leadlag"]
    assert rc == 0, err[-2000:]
    assert "improvement of ise" in text
    tj = json.loads((out / "tune-ll" / "tune.json").read_text())
    assert tj["controller"] == "lead-lag" and list(tj["tuned"]) == ["K", "wz", "wp"]
    box = tj["history"]["bounds"]
    assert box["K"] == pytest.approx([1e-3, 1e3], rel=1e-12)
    assert box["wz"] == pytest.approx([1.0, 3e4], rel=1e-12) and box["wp"] == pytest.approx([3.0, 3e4], rel=1e-12)
    for p, (lo, hi) in box.items():
        assert lo * (1 - 1e-9) <= tj["tuned"][p] <= hi * (1 + 1e-9), (p, tj["tuned"][p])
    rc, _, err = res["tune_leadlag_bounds"]
    assert rc == 2 and "--bounds wp=10:100000: outside the interval 1 ... 30000" in err, err


def test_a_drive_type_from_an_entry_point(tmp_path):
    """A drive type of an installed package (entry-point group ``mjbench.drives``) is found by the
    drive registry, listed, and runs a scenario (a distribution folder on sys.path)."""
    import importlib
    import warnings

    import mjbench
    from mjbench import drives
    from mjbench import scenario as S
    from mjbench.backends import simulate

    (tmp_path / "geared_torque_plugin.py").write_text(
        "from dataclasses import dataclass\nfrom typing import Literal\n"
        "from mjbench.drives.ideal import TorqueDrive, TorqueDriveParams\n\n"
        "class GearedTorqueParams(TorqueDriveParams):\n"
        "    type: Literal['geared-torque'] = 'geared-torque'\n\n"
        "    def build(self):\n"
        "        return GearedTorque(J=float(self.J), damping=float(self.damping), T_max=float(self.T_max))\n\n"
        "@dataclass\nclass GearedTorque(TorqueDrive):\n"
        "    type_name = 'geared-torque'\n    Params = GearedTorqueParams\n")
    info = tmp_path / "geared_torque_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: geared-torque-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[mjbench.drives]\ngeared-torque = geared_torque_plugin:GearedTorque\n")
    sys.path.insert(0, str(tmp_path))
    try:
        importlib.invalidate_caches()
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # (no plugin may fail to load)
            assert "geared-torque" in drives.names()
            comp = [c for c in mjbench.list_components("drive") if c.name == "geared-torque"]
        assert comp and comp[0].origin == "plugin" and "geared-torque-plugin" in comp[0].source
        scn = S.from_raw({"scenario": {"name": "plugin-drive"}, "mechanism": {"type": "rotor", "J": 0.01},
                          "drive": {"type": "geared-torque", "damping": 0.05},
                          "simulation": {"t_end": 0.3, "dt": 1e-3, "record_dt": 1e-2},
                          "modes": {"m": {"type": "pid", "kp": 0.5, "ki": 0.0, "kd": 0.0, "omega0": 2.0}}})
        drive = S.make_drive(scn)
        assert type(drive).__name__ == "GearedTorque" and drives.get("geared-torque") is type(drive)
        tr = simulate(S.make_machine(scn, "m"), "reduced", 0.3, record_dt=1e-2)
        # J·ω̇ = k_p·(ω₀ − ω) − c·ω: settles (time constant J/(k_p + c) = 18 ms) at k_p·ω₀/(k_p + c)
        assert tr.qd[-1] == pytest.approx(0.5 * 2.0 / 0.55, rel=1e-6)
        power = tr.data[-1, tr.columns.index("power_mech_W")]  # the source's T·ω = c·ω² at steady state
        assert power == pytest.approx(0.05 * tr.qd[-1] ** 2, rel=1e-5)
    finally:
        sys.path.remove(str(tmp_path))
        drives.REGISTRY._classes.pop("geared-torque", None)
        sys.modules.pop("geared_torque_plugin", None)


def test_run_both_backends_compiled_and_agreeing(plugin_run):
    out, res, _ = plugin_run
    man = json.loads((out / "run" / "manifest.json").read_text())
    assert {b: m["loop"] for b, m in man["run_meta"].items()} == {"multibody": "compiled", "reduced": "compiled"}
    met = json.loads((out / "run" / "metrics.json").read_text())
    assert met["multibody_vs_reduced"]["max_rel_diff"] < 1e-6  # closed-form J(q) vs MuJoCo's yoke
    for b, r in res["loops"].items():
        assert r == {"batch_equals_single": True, "python_equals_compiled": True, "loop": "compiled",
                     "batch_loop": r["batch_loop"]}, (b, r)


def test_lead_lag_is_its_difference_equation(plugin_run):
    """The recorded voltages of the compiled run are the lead-lag's Tustin difference equation on
    the recorded motor-speed error (scipy, independent of the law's code)."""
    from scipy.signal import lfilter

    out, _, _ = plugin_run
    omega, V = np.load(out / "reduced.npy")  # motor speed, voltage of the compiled run (K = 2)
    K, wz, wp, T = 2.0, 300.0, 3000.0, 1e-4
    c = 2.0 / T
    b0, b1, a1 = K * (1 + c / wz) / (1 + c / wp), K * (1 - c / wz) / (1 + c / wp), (1 - c / wp) / (1 + c / wp)
    u = lfilter([b0, b1], [1.0, a1], 2 * np.pi * 20.0 - omega)
    np.testing.assert_allclose(V, np.clip(u, -24.0, 24.0), rtol=1e-12, atol=1e-12)
