"""The notebooks of docs/notebooks/ run top to bottom in a fresh kernel (nbclient), in an empty
folder, and their checks hold.

Each notebook asserts its numbers in its own cells (against the closed forms and independent
recomputations it writes out) and prints them as JSON in its last cell; the tests here read that
line and check the headline numbers again, so that a notebook whose checks were edited away still
fails.  Notebooks are stored without outputs (clean diffs)."""
import json
import os
import re
import sys
import time
from pathlib import Path

import nbformat
import numpy as np
import pytest
from jupyter_client.kernelspec import KernelSpec, KernelSpecManager
from jupyter_client.manager import KernelManager
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "docs" / "notebooks"
NAMES = ["01_quickstart.ipynb", "02_own_linkage.ipynb", "03_controller_design.ipynb"]


class _ThisPython(KernelSpecManager):
    """The kernel is this interpreter (the project's venv), whatever kernels Jupyter has installed."""

    def get_kernel_spec(self, kernel_name):
        from ipykernel.kernelspec import get_kernel_dict

        return KernelSpec(resource_dir="", **get_kernel_dict())


#: a cell that draws: a pyplot figure, or a result's ``plot`` called at the start of a line
DRAWS = re.compile(r"plt\.subplots\(|^\w+\.plot\(", re.M)


def figures_per_cell(nb) -> list[tuple[int, int, int]]:
    """(cell index, PNG images it displayed, images expected: 1 for a drawing cell, else 0)."""
    out = []
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        n = sum("image/png" in o.get("data", {}) for o in cell.outputs if o.output_type in ("display_data",
                                                                                           "execute_result"))
        out.append((i, n, 1 if DRAWS.search(cell.source) else 0))
    return out


def check_figures(nb, name: str, out_dir: Path | None = None) -> int:
    """Each drawing cell displayed exactly one figure, no other cell any (a figure shown twice, or
    not at all because the backend was switched, fails); the images are written to ``out_dir``
    (``MJBENCH_NOTEBOOK_FIGURES``: a folder to look at them).  Returns the number of figures."""
    import base64

    counts = figures_per_cell(nb)
    wrong = [(i, n, want) for i, n, want in counts if n != want]
    assert not wrong, f"{name}: (cell, figures shown, expected) {wrong}"
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        for i, cell in enumerate(nb.cells):
            for k, o in enumerate(getattr(cell, "outputs", [])):
                if "image/png" in o.get("data", {}):
                    (out_dir / f"{name[:2]}_cell{i:02d}_{k}.png").write_bytes(base64.b64decode(o["data"]["image/png"]))
    return sum(want for _, _, want in counts)


def execute(name: str, cwd: Path) -> tuple[dict, float]:
    """Run the notebook in ``cwd``; its summary (the last cell's JSON line) and the wall time [s];
    checks the figures each cell displayed (:func:`check_figures`)."""
    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    km = KernelManager(kernel_name="python3", kernel_spec_manager=_ThisPython())
    client = NotebookClient(nb, km=km, timeout=240, resources={"metadata": {"path": str(cwd)}})
    t0 = time.perf_counter()
    try:
        client.execute()  # a failing check raises CellExecutionError with the cell and its traceback
    finally:
        if km.has_kernel:  # a kernel manager given to nbclient is ours to shut down
            km.shutdown_kernel(now=True)
    wall = time.perf_counter() - t0
    look = os.environ.get("MJBENCH_NOTEBOOK_FIGURES")
    nfig = check_figures(nb, name, Path(look) if look else None)
    print(f"{name}: {nfig} figures, one per drawing cell", file=sys.stderr)
    last = [c for c in nb.cells if c.cell_type == "code"][-1]
    text = "".join(o.get("text", "") for o in last.outputs if o.output_type == "stream" and o.name == "stdout")
    return json.loads(text.strip().splitlines()[-1]), wall


def test_notebooks_are_stored_clean_and_listed():
    """No outputs or execution counts in the repository, valid nbformat, the kernel named
    python3; every notebook listed in docs/api.md and README.md."""
    assert sorted(p.name for p in NOTEBOOKS.glob("*.ipynb")) == NAMES
    api, readme = (ROOT / "docs" / "api.md").read_text(), (ROOT / "README.md").read_text()
    for name in NAMES:
        nb = nbformat.read(NOTEBOOKS / name, as_version=4)
        nbformat.validate(nb)
        assert nb.metadata["kernelspec"]["name"] == "python3"
        for cell in nb.cells:
            if cell.cell_type == "code":
                assert cell.outputs == [] and cell.execution_count is None, (name, cell.source[:60])
        assert f"docs/notebooks/{name}" in api and f"docs/notebooks/{name}" in readme, name


def test_quickstart(tmp_path):
    s, wall = execute("01_quickstart.ipynb", tmp_path)
    print(f"01_quickstart: {wall:.1f} s", file=sys.stderr)
    assert s["mb_vs_red"] < 1e-5 and s["pid_mb_vs_red"] < 1e-5            # 2.2e-6 (open, 1 s), 1.2e-6 (PID, 0.5 s)
    assert s["energy_imbalance"] < 1e-4                                    # 1.1e-5 of the supplied energy
    assert s["chi_recomputed"] == pytest.approx(s["chi_last_cycle"], rel=1e-3)
    assert 0.9 < s["chi_last_cycle"] < 1.05                                 # 0.969 (docs/validation.md: 96.3 % over 2 s)
    assert 25.0 < s["pid_mean_speed"] < 30.0                                # 27.14 rad/s


def test_own_linkage(tmp_path):
    s, wall = execute("02_own_linkage.ipynb", tmp_path)
    print(f"02_own_linkage: {wall:.1f} s", file=sys.stderr)
    r, l, e, F = 0.050, 0.200, 0.020, 150.0                                  # the notebook's slider-crank
    stroke = np.sqrt((l + r) ** 2 - e**2) - np.sqrt((l - r) ** 2 - e**2)
    assert abs(s["stroke_m"] - stroke) < 1e-9 and abs(s["stroke_closed_form_m"] - stroke) < 1e-12
    assert s["work_per_turn_J"] == pytest.approx(F * stroke, rel=1e-5)
    assert s["J_err"] < 1e-9                                                # 3e-12
    assert s["mb_vs_red"] < 1e-5 and s["closure_m"] < 1e-6                  # 1.9e-7, 1.9e-9 m
    assert s["piston_pos_err_m"] < 1e-6 and s["piston_vel_err"] < 1e-4      # 1.6e-9 m, 1.7e-6
    assert s["crank_speed_late_rad_s"] == pytest.approx(4 * np.pi, rel=1e-3)  # 120 rpm


def test_controller_design(tmp_path):
    s, wall = execute("03_controller_design.ipynb", tmp_path)
    print(f"03_controller_design: {wall:.1f} s", file=sys.stderr)
    assert s["plant_mb_vs_red"] < 1e-3                                      # 4.4e-5
    assert s["kp_limit"] == pytest.approx(s["kp_limit_mjbench"], rel=1e-3)  # 1118.5 V·s/rad both
    assert 1000 < s["kp_limit"] < 1250
    assert 25.0 < s["worst_pm_deg"] < 40.0 and abs(s["worst_pm_q_rad"] - 5.50) < 0.01
    assert 40.0 < s["pm_deg"] < 100.0 and s["gm_dB"] > 20.0                 # 70.7°, 57.0 dB
    # mjb.hold_point: the PID (reference angle 0, K_i = 32) holds the crank at −0.1797 rad against
    # gravity (equal to the notebook's root of K_i·(0 − z·q) = R·E_p'(q)/(z·k_m)); mjb.step_check:
    # a 0.01 rad step there on MuJoCo against the linear closed loop
    assert s["hold_q_rad"] == pytest.approx(-0.1797, abs=1e-4)
    assert s["step_q_rel_error"] < 1e-3 and s["step_qd_rel_error"] < 1e-3   # 7.0e-5, 1.0e-4
    for factor, predicted in (("0.9x", 0.2767), ("1.1x", 3.602)):
        assert s["growth_predicted"][factor] == pytest.approx(predicted, rel=0.01)
        for b in ("reduced", "multibody"):
            assert s["growth"][f"{factor} {b}"] == pytest.approx(s["growth_predicted"][factor], rel=0.05)


def test_figures_show_once_and_leave_the_backend_alone(tmp_path):
    """In a kernel with ``%matplotlib inline`` (pyplot's inline backend active before mjbench
    plots), a result's figure is displayed once — as the cell's value, not a second time by pyplot
    — an assigned figure not at all until shown, and matplotlib's backend stays the user's."""
    cells = ["%matplotlib inline",
             "import matplotlib\nimport mjbench as mjb\nres = mjb.load('incerti2012').simulate('open', 'reduced', 0.05)",
             "res.plot()",
             "fig = res.plot(['current_A'])",
             "fig",
             "import matplotlib.pyplot as plt\nplt.plot([0, 1], [1, 0]);",
             "print(matplotlib.get_backend(), len(plt.get_fignums()))"]
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    km = KernelManager(kernel_name="python3", kernel_spec_manager=_ThisPython())
    try:
        NotebookClient(nb, km=km, timeout=240, resources={"metadata": {"path": str(tmp_path)}}).execute()
    finally:
        if km.has_kernel:
            km.shutdown_kernel(now=True)
    shown = [n for _, n, _ in figures_per_cell(nb)]
    assert shown == [0, 0, 1, 0, 1, 1, 0], shown
    backend, figs = nb.cells[-1].outputs[0]["text"].split()
    assert "inline" in backend and figs == "0"   # the inline backend kept; pyplot knows no mjbench figure
