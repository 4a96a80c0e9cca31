"""Reproduction report (issue 6): generated, tables = metrics.json numbers, opens in headless
Chromium without errors (images load, video decodes, screenshot not empty)."""
import html
import os
import re
import shutil
import subprocess

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from mjbench import papers
from mjbench import reproduce as R
from mjbench.outputs import read_json

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    case = papers.Case(name="incerti2012-short", scenario="incerti2012", title="short Fig. 4 run",
                       modes=["open", "pid"], t_end=0.6, video=True, video_mode="pid", video_t_end=0.5,
                       paper="incerti2012")
    res = R._clean(R.run_case(case, out, quick=True, progress=False, width=320, height=180))
    md, htm = R.write_report([res], out, total_s=res["runtime_s"])
    return out, res, md, htm


def test_registry_covers_every_paper():
    cases = R.load_cases()
    assert {c.paper for c in cases} == set(papers.MODULES)
    assert {c.scenario for c in cases} == set(__import__("mjbench.scenario").scenario.builtin_names())
    assert len({c.name for c in cases}) == len(cases)
    assert [c.name for c in R.select(cases, "incerti2012")] == ["incerti2012-fig4"]


def test_files_written(report):
    out, res, md, htm = report
    case_dir = out / "incerti2012-short"
    for f in ("metrics.json", "fig4.png", "backends_open.png", "backends_pid.png", "video.mp4", "trajectory_open_multibody.csv", "trajectory_pid_reduced.csv"):
        assert (case_dir / f).stat().st_size > 0, f
    assert md.exists() and htm.exists()
    assert res["video"]["frames"] == 16  # 0.5 s at 30 fps: frames at k/30, k = 0..15


def test_tables_hold_metrics_json_numbers(report):
    out, _, md, htm = report
    m = read_json(out / "incerti2012-short" / "metrics.json")  # strict JSON (no NaN/Infinity)
    md_text, html_text = md.read_text(), htm.read_text()
    chi_rows = [r for r in m["rows"] if "metric" in r]
    assert len(chi_rows) == 2  # the two χ figures of seed 000 (open loop, PID window)
    assert any("linear" in r["ours"] for r in m["rows"])  # + the linear analysis of the PID loop
    for row in chi_rows:
        # the row's numbers are the metrics of the run ...
        for b, v in row["ours"].items():
            assert v == pytest.approx(m["modes"][row["mode"]]["backends"][b][row["metric"]], rel=1e-12)
        assert row["difference"] == pytest.approx(row["ours"]["multibody"] - row["paper"], rel=1e-12)
        # ... and the report's table line prints exactly them
        lines = md_text.splitlines()
        k = next(i for i, l in enumerate(lines) if l.startswith(f"| {row['name']} |"))
        head = next(lines[i] for i in range(k, -1, -1) if lines[i].startswith("| quantity |"))
        col = {c.strip(): i for i, c in enumerate(head.strip("|").split("|"))}
        cells = [c.strip() for c in lines[k].strip("|").split("|")]
        assert cells[col["paper"]] == R.fmt(row["paper"])
        assert cells[col["ours: multibody"]] == R.fmt(row["ours"]["multibody"])
        assert cells[col["ours: reduced"]] == R.fmt(row["ours"]["reduced"])
        assert cells[col["difference"]] == R.fmt(row["difference"])
        assert row["reason"] and cells[col["reason"]] == row["reason"]
        hrow = re.search(r"<tr[^>]*><td>" + re.escape(html.escape(row["name"])) + r"</td>(.*?)</tr>", html_text)
        assert hrow, row["name"]
        for v in (row["paper"], row["ours"]["multibody"], row["ours"]["reduced"], row["difference"]):
            assert f">{R.fmt(v)}<" in hrow.group(1)
    assert 'src="incerti2012-short/fig4.png"' in html_text and 'src="incerti2012-short/video.mp4"' in html_text


def _chromium(args, tmp_path, timeout=60):
    cmd = [CHROMIUM, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
           "--virtual-time-budget=4000", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


@pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium not installed (Debian package `chromium`; "
                                             "scripts/ci_system_deps.sh installs it)")
def test_html_opens_in_headless_chromium(report, tmp_path):
    import imageio.v3 as iio

    out, res, _, htm = report
    url = htm.resolve().as_uri()
    p = _chromium(["--dump-dom", url], tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    m = re.search(r'data-check="images (\d+)/(\d+) video-errors (\d+)/(\d+)"', p.stdout)
    assert m, "the report's load check did not run:\n" + p.stdout[:500] + p.stderr[-1500:]
    ok, n_img, verr, n_vid = map(int, m.groups())
    assert n_img == len(res["figures"]) == 4 and ok == n_img, "an embedded figure did not load"
    assert n_vid == 1 and verr == 0, "the embedded video reports a media error"
    assert "Uncaught" not in p.stderr and "SyntaxError" not in p.stderr
    shot = tmp_path / "shot.png"
    p = _chromium([f"--screenshot={shot}", "--window-size=1200,1600", "--hide-scrollbars", url], tmp_path)
    assert p.returncode == 0 and shot.exists(), p.stderr[-2000:]
    img = iio.imread(shot)
    assert img.shape[0] >= 1000 and img.shape[1] >= 1000
    gray = np.asarray(img[..., :3], float).mean(axis=2)
    assert gray.std() > 10.0                         # not a blank page
    assert (gray < 128).mean() > 0.005               # text, table borders and the figure are drawn
