"""Reproduction report: generated, tables = metrics.json numbers, verdicts that follow the numbers
(re-derived here by the plain definitions), the page leads with pictures (per case: headline
figure, video, headline numbers, then the other figures and the folded full tables; a summary of
every case's verdicts on top), and it opens in headless Chromium without errors (every image
loads, the video decodes, every link resolves, the headline figure is laid out before the folded
tables, screenshot not empty).  The verdict logic itself: tests/test_verdicts.py."""
import html
import importlib.resources
import os
import re
import shutil
import subprocess

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np
import pytest

from mjbench import papers
from mjbench import report as RP
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
    # a second paper and kind: a study with an extra table and no video
    study = next(c for c in R.load_cases() if c.name == "yigit2023-design")
    res2 = R._clean(R.run_case(study, out, quick=True, progress=False))
    md, htm = R.write_report([res, res2], out, total_s=res["runtime_s"] + res2["runtime_s"])
    return out, res, md, htm


def test_registry_covers_every_paper():
    cases = R.load_cases()
    assert {c.paper for c in cases} == set(papers.MODULES)
    # every case runs a shipped scenario; a shipped scenario needs no case (a user's or a plugin's
    # scenario, a new example, are not report material until someone writes a case for them)
    from mjbench.scenario import shipped_names
    assert {c.scenario for c in cases if c.kind != "design"} <= set(shipped_names())
    from mjbench.design.requirements import builtin_names as requirement_names
    assert {c.scenario for c in cases if c.kind == "design"} == set(requirement_names())
    assert len({c.name for c in cases}) == len(cases)
    assert [c.name for c in R.select(cases, "incerti2012")] == ["incerti2012-fig4", "incerti2012-realdrive"]
    assert [c.name for c in R.select(cases, "incerti2012-fig4")] == ["incerti2012-fig4"]


def test_files_written(report):
    out, res, md, htm = report
    case_dir = out / "incerti2012-short"
    for f in ("metrics.json", "fig4.png", "backends_open.png", "backends_pid.png", "video.mp4", "trajectory_open_multibody.csv", "trajectory_pid_reduced.csv"):
        assert (case_dir / f).stat().st_size > 0, f
    assert md.exists() and htm.exists()
    assert res["video"]["frames"] == 16  # 0.5 s at 30 fps: frames at k/30, k = 0..15
    # the video shows the case's own PID run (recorded every 0.5 ms), not a second MuJoCo run
    assert res["video"]["source"] == "the case's multibody run (samples every 0.5 ms)"


def _split(line):
    return [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]


def _md_tables(md_text, case):
    """The markdown tables of one case's section: [(header cells, [row cells])] in page order."""
    sec = md_text.split(f'<a id="{RP._anchor(case)}"></a>')[1].split('<a id="')[0]
    tables, lines = [], sec.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("| quantity |") or (line.startswith("| ") and lines[i + 1].startswith("|---")):
            body = []
            for b in lines[i + 2:]:
                if not b.startswith("| "):
                    break
                body.append(_split(b))
            tables.append((_split(line), body))
    return tables


def _check_md_row(head, cells, row):
    """A table line prints exactly the row's numbers of metrics.json, its verdict (and reason)."""
    col = {c: i for i, c in enumerate(head)}
    assert cells[col["quantity"]] == row["name"]
    assert cells[col["unit"]] == row["unit"] and cells[col["paper"]] == row["paper_text"]
    for b, v in row["ours"].items():
        assert cells[col[f"ours: {b}"]] == R.fmt(v)
    assert cells[col["verdict"]] == row["verdict"]["text"]
    if "reason" in col:
        assert cells[col["reason"]] == (row["reason"] or "—")


def test_tables_hold_metrics_json_numbers(report):
    out, _, md, htm = report
    m = read_json(out / "incerti2012-short" / "metrics.json")  # strict JSON (no NaN/Infinity)
    md_text, html_text = md.read_text(), htm.read_text()
    figs = [r for r in m["rows"] if r.get("metric")]
    assert len(figs) == 2  # the two χ figures of Incerti 2012 (open loop, PID window), in percent
    assert any("linear" in r["ours"] for r in m["rows"])  # + the linear analysis of the PID loop
    for row in figs:
        # the row's numbers are the metrics of the run (χ, a fraction, printed in percent) ...
        assert row["unit"] == "%"
        for b, v in row["ours"].items():
            assert v == pytest.approx(100 * m["modes"][row["mode"]]["backends"][b][row["metric"]], rel=1e-12)
        assert row["difference"] == pytest.approx(row["ours"]["multibody"] - row["paper"], rel=1e-12)
    # ... and the report prints exactly them: the headline table (its rows: metrics.json "headline"),
    # then the full table, every row, with the reason
    (h_head, h_body), (f_head, f_body) = [t for t in _md_tables(md_text, "incerti2012-short") if t[0][0] == "quantity"]
    assert "reason" not in h_head and f_head[-1] == "reason"
    assert len(f_body) == len(m["rows"]) and len(h_body) == len(m["headline"]) == RP.HEADLINE_MAX
    for cells, row in zip(f_body, m["rows"]):
        _check_md_row(f_head, cells, row)
    for cells, i in zip(h_body, m["headline"]):
        _check_md_row(h_head, cells, m["rows"][i])
    for row in m["rows"]:  # the HTML tables hold the same cells
        hrows = re.findall(r"<tr[^>]*><td>" + re.escape(html.escape(row["name"])) + r"</td>(.*?)</tr>", html_text)
        assert len(hrows) == (2 if m["rows"].index(row) in m["headline"] else 1), row["name"]
        for hrow in hrows:
            for v in (row["ours"].get("multibody"), row["ours"].get("reduced")):
                if v is not None:
                    assert f">{R.fmt(v)}<" in hrow
            assert f">{html.escape(row['verdict']['text'])}<" in hrow
    assert 'src="incerti2012-short/fig4.png"' in html_text and 'src="incerti2012-short/video.mp4"' in html_text


def test_headline_rows():
    """Headline numbers: at most HEADLINE_MAX rows in table order — the rows a paper module marks
    headline, then those with a paper figure, then the others."""
    judged = {"ok": True}
    rows = ([{"verdict": {"ok": None}}] * 3 + [{"verdict": judged}] * 4 + [{"verdict": {"ok": None}, "headline": True}]
            + [{"verdict": {"ok": False}}] * 2)
    assert R.headline(rows) == [3, 4, 5, 6, 7]           # flagged (7) + the first four judged, in table order
    assert R.headline(rows, n=3) == [3, 4, 7]
    assert R.headline(rows[:3]) == [0, 1, 2]             # no paper figure at all: the first rows
    assert R.headline([]) == []


def test_page_leads_with_pictures(report):
    """Per case, in page order: title, headline figure, video, headline numbers, the other figures,
    then the folded tables (every row, the extra tables); a summary with every case's verdict bar
    on top; report.md in the same order."""
    out, res, md, htm = report
    html_text, md_text = htm.read_text(), md.read_text()
    cases = [("incerti2012-short", res), ("yigit2023-design", read_json(out / "yigit2023-design" / "metrics.json"))]
    summary = html_text.split('<h2 id="case-', 1)[0]
    for case, r in cases:
        assert f'href="#{RP._anchor(case)}"' in summary
        c = RP._counts(r)
        widths = re.search(rf'href="#{RP._anchor(case)}".*?<div class="bar"[^>]*>(.*?)</div>', summary, re.S).group(1)
        n = sum(c.values())
        for k, v in c.items():  # the bar's segments are the verdict counts, to scale
            seg = re.search(rf'class="c-{k}" style="width:([\d.]+)%"', widths)
            assert (seg is None) == (v == 0)
            assert seg is None or float(seg.group(1)) == pytest.approx(100 * v / n, abs=0.01)
    sec = {case: html_text.split(f'<h2 id="{RP._anchor(case)}"')[1].split("<h2 ")[0] for case, _ in cases}
    s = sec["incerti2012-short"]
    pos = [s.index(x) for x in ('<img src="incerti2012-short/fig4.png"', "<video ", 'class="headline"',
                                '<img src="incerti2012-short/linear_bode_pid.png"', "<details>")]
    assert pos == sorted(pos), pos
    assert s.count("<details>") == 1 and s.index('<table class="rows">') > s.index("<details>")
    s = sec["yigit2023-design"]  # no video, an extra table: folded after the full table
    assert "<video" not in s and s.count("<details>") == 2
    assert s.index('<img src="yigit2023-design/designs.png"') < s.index('class="headline"') < s.index("<details>")
    assert re.search(r"<details><summary>Table: Designs.*?<table", s, re.S)
    for case, r in cases:
        m = md_text.split(f'<a id="{RP._anchor(case)}"></a>')[1]
        m = m.split('<a id="')[0]
        first = f"[![{r['figures'][0]}]({case}/{r['figures'][0]})]"
        assert m.index(first) < m.index("headline numbers**") < m.index("<details><summary>All ")
    assert "🟧" in md_text.split("<details>")[0]  # the summary's verdict bars (incerti2012: 'differ' rows)


def test_cases_in_worker_processes_give_the_same_numbers(tmp_path):
    """``--jobs 2``: the cases run side by side in spawned worker processes; every result (rows,
    verdicts, metrics of every mode and backend, figures) is the one the same case gives in this
    process, in the cases' order."""
    cases = [papers.Case(name="jobs-a", scenario="incerti2012", modes=["open", "pid"], t_end=0.3, video=False),
             papers.Case(name="jobs-b", scenario="hulako2025-model1", modes=["pid"], t_end=0.3, video=False)]
    kw = dict(quick=True, video=False, width=None, height=None)
    seq = R.run_cases(cases, tmp_path / "seq", kw, progress=False, log=lambda *a: None)
    lines = []
    par = R.run_cases(cases, tmp_path / "par", kw, progress=False, log=lines.append, jobs=2)
    assert [r["case"] for r in par] == ["jobs-a", "jobs-b"] and "2 worker processes" in lines[0]
    for a, b in zip(seq, par):
        assert a["rows"] == b["rows"] and a["figures"] == b["figures"]
        for mode, m in a["modes"].items():
            for bk, mb in m["backends"].items():
                num = {k: v for k, v in mb.items() if isinstance(v, float)}
                assert num and num == {k: v for k, v in b["modes"][mode]["backends"][bk].items() if k in num}
        assert (tmp_path / "par" / b["case"] / "metrics.json").exists()


def test_markdown_bar():
    bar = RP._bar_md
    assert bar({"meet": 31, "fitted": 0, "differ": 0, "unjudged": 0}) == "🟩" * 10
    b = bar({"meet": 1, "fitted": 0, "differ": 2, "unjudged": 97})
    assert len(b) == 10 and b.count("🟩") == 1 and b.count("🟧") == 1 and b.count("⬜") == 8
    assert bar({"meet": 0, "fitted": 0, "differ": 0, "unjudged": 0}) == "—"


def test_verdicts_follow_the_numbers(report):
    """Every verdict of the report, re-derived here from the row's own numbers by the plain
    definitions (band: lo ≤ v ≤ hi; upper bound: v ≤ bound; value: |v − p| ≤ 5 % of |p|)."""
    out, _, md, _ = report
    m = read_json(out / "incerti2012-short" / "metrics.json")
    assert len(m["rows"]) >= 6  # the χ figures, χ over the last 2π, the limiter what-ifs, time at the limit
    judged = 0
    for row in m["rows"]:
        vals = [v for v in row["ours"].values() if v is not None]
        v = row["verdict"]
        if row["paper"] is None:
            assert v["ok"] is None and v["status"] == "no paper value"
            continue
        ok = {"band": lambda x: row["paper"][0] <= x <= row["paper"][1], "max": lambda x: x <= row["paper"],
              "min": lambda x: x >= row["paper"],
              "value": lambda x: abs(x - row["paper"]) <= 0.05 * abs(row["paper"]) * (1 + 1e-12)}[row["compare"]]
        assert v["ok"] == all(ok(x) for x in vals), row["name"]
        judged += 1
    assert judged >= 4
    c = m["counts"]
    assert c["meet"] + c["fitted"] + c["differ"] == judged
    md_text = md.read_text()
    assert f"| {c['meet'] + c['fitted']}/{judged} |" in md_text


def test_limiter_what_ifs_are_reported(report):
    """The a-priori PID χ depends on our assumed limiter: the report gives it without the limiter
    and with a plain clip, each from its own run (they differ from the default and each other)."""
    out, _, _, _ = report
    m = read_json(out / "incerti2012-short" / "metrics.json")
    rows = {r["name"]: r for r in m["rows"]}
    base = next(r for r in m["rows"] if r.get("metric") == "chi_window")["ours"]["multibody"]
    no_lim = next(r for n, r in rows.items() if "without the voltage limiter" in n)["ours"]["multibody"]
    clip = next(r for n, r in rows.items() if "plain clip" in n)["ours"]["multibody"]
    assert len({round(base, 3), round(no_lim, 3), round(clip, 3)}) == 3
    assert all(r["paper"] == 2.6 for n, r in rows.items() if "without the voltage limiter" in n or "plain clip" in n)
    at_limit = next(r for n, r in rows.items() if n.startswith("time at the ±48 V limit, PID, over the whole run"))
    assert 0 < at_limit["ours"]["multibody"] <= 100


def test_scenario_notes_explain_and_never_judge():
    """[[paper.figures]] notes are reasons, never verdicts (the verdict is computed), and no
    scenario cites anything outside the project."""
    from mjbench import scenario as S

    words = ("inside", "within", "agree", "exceed", "meets", "below it", "above it")
    for name in S.builtin_names():
        scn = S.load(name)
        for fig in scn.paper.get("figures", []) or []:
            note = fig.get("note", "").lower()
            assert not any(w in note for w in words), (name, fig["name"], note)
        assert "notes" not in scn.paper, f"{name}: a [paper.notes] table (fixed verdict texts) is back"
        text = importlib.resources.files("mjbench").joinpath("scenarios", f"{name}.toml").read_text(encoding="utf-8")
        # no pointer to the seeds folder outside the project or its errata file (names built so that a
        # grep of the repository for them finds no reference): the project carries its own docs/errata.md
        outside = ("../" + "shared", "SEED-" + "ERRATA", "Seed 00")
        assert not any(w in text for w in outside), name


def _chromium(args, tmp_path, timeout=60):
    cmd = [CHROMIUM, *FLAGS, f"--user-data-dir={tmp_path / 'profile'}", "--enable-logging=stderr", "--v=0",
           "--virtual-time-budget=4000", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def _targets(dom: str):
    """Every href and src of a page (as written in its DOM)."""
    return [html.unescape(u) for u in re.findall(r'\s(?:href|src)="([^"]+)"', dom)]


@pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium not installed (Debian package `chromium`; "
                                             "scripts/ci_system_deps.sh installs it)")
def test_html_opens_in_headless_chromium(report, tmp_path):
    import imageio.v3 as iio

    out, res, _, htm = report
    n_figs = len(res["figures"]) + len(read_json(out / "yigit2023-design" / "metrics.json")["figures"])
    url = htm.resolve().as_uri()
    p = _chromium(["--window-size=1280,1600", "--dump-dom", url], tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    m = re.search(r'data-check="images (\d+)/(\d+) video-errors (\d+)/(\d+) anchors-missing (\d+)/(\d+) '
                  r'first-figure-top (-?\d+) first-details-top (-?\d+)"', p.stdout)
    assert m, "the report's load check did not run:\n" + p.stdout[:500] + p.stderr[-1500:]
    ok, n_img, verr, n_vid, bad, n_links, fig_top, det_top = map(int, m.groups())
    # the page renders: every figure (headline and thumbnails, each once) loaded, the video decodes
    assert n_img == n_figs == 5 and ok == n_img, "an embedded figure did not load"
    assert n_vid == 1 and verr == 0, "the embedded video reports a media error"
    assert "Uncaught" not in p.stderr and "SyntaxError" not in p.stderr
    # every link resolves: in-page anchors (checked by the page), files next to the report (here)
    assert n_links >= 3 and bad == 0, "an in-page link points at no element"
    files = {u for u in _targets(p.stdout) if not u.startswith(("#", "data:"))}
    assert {f"incerti2012-short/{f}" for f in res["figures"]} | {"incerti2012-short/metrics.json",
                                                                  "incerti2012-short/video.mp4"} <= files
    for u in files:
        assert "://" not in u, f"the report links outside its folder: {u}"
        assert (out / u).is_file() and (out / u).stat().st_size > 0, f"broken link {u}"
    # it leads with pictures: the first case's headline figure is in the first screen, above its folded tables
    assert 0 < fig_top < 1600 and fig_top < det_top, (fig_top, det_top)
    shot = tmp_path / "shot.png"
    p = _chromium([f"--screenshot={shot}", "--window-size=1280,1600", "--hide-scrollbars", url], tmp_path)
    assert p.returncode == 0 and shot.exists(), p.stderr[-2000:]
    img = iio.imread(shot)
    assert img.shape[0] >= 1000 and img.shape[1] >= 1000
    gray = np.asarray(img[..., :3], float).mean(axis=2)
    assert gray.std() > 10.0                         # not a blank page
    assert (gray < 128).mean() > 0.005               # text, table borders and the figure are drawn
    rgb = np.asarray(img[..., :3], int)
    green = (rgb[..., 1] > 150) & (rgb[..., 0] < 110) & (rgb[..., 2] < 110)
    orange = (rgb[..., 0] > 220) & (rgb[..., 1] > 130) & (rgb[..., 1] < 180) & (rgb[..., 2] < 80)
    assert orange.sum() > 200, "the summary's verdict bars are not drawn"


def test_engineering_verdicts_lead_and_follow_the_numbers(report):
    """Every case opens with its engineering verdicts, computed from its metrics.json: here the
    Incerti 2012 PID pinned at its 48 V supply (the duty figures' fraction at the voltage limit),
    backends agreeing; the summary table holds them beside the paper comparison; the video's still
    image is a frame of the machine running, not t = 0."""
    out, res, md, htm = report
    eng = res["engineering"]
    assert set(eng) == {k for k, _ in RP.CHECKS}
    pid = res["modes"]["pid"]["backends"]["multibody"]
    frac = pid["voltage_limit_fraction_steady"]
    assert eng["limits"]["ok"] is (frac <= 0.01)
    if frac > 0.01:
        assert f"{100 * frac:.1f} % of the steady state" in eng["limits"]["detail"]
    assert eng["models"]["ok"] is True and eng["duty"]["ok"] is None          # no rating stated in incerti2012
    assert eng["duty"]["detail"].startswith("RMS current")
    page = htm.read_text()
    summary = page.split('<table class="summary">')[1].split("</table>")[0]
    assert summary.index("engineering verdicts") < summary.index("paper comparison")
    sec = page.split('id="case-incerti2012-short"')[1]
    assert sec.index('<table class="eng">') < sec.index('class="headline"')
    v = res["video"]
    assert v["poster"] == "video_poster.png" and (out / "incerti2012-short" / "video_poster.png").stat().st_size > 0
    assert v["poster_t_s"] >= 0.6 * 0.5 - 1e-9 and f'poster="incerti2012-short/video_poster.png"' in page
