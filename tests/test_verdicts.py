"""Verdict logic of the report (mjbench/verdicts.py) on synthetic rows: a band, an upper bound, a
point value, several backends, fitted figures, missing numbers — and the report's rendering of
them (the verdict cell is the computed text, the summary counts follow the verdicts)."""
import math

import pytest

from mjbench import reproduce as R
from mjbench import verdicts as V


# ---------------------------------------------------------------- one number
@pytest.mark.parametrize("value, status, ok", [
    (6.0, "below", False), (6.1, "inside", True), (6.25, "inside", True), (6.4, "inside", True), (6.5, "above", False)])
def test_band(value, status, ok):
    j = V.judge(value, [6.1, 6.4], unit="rad/s")
    assert (j["status"], j["ok"]) == (status, ok)


def test_band_distance_is_to_the_nearest_edge():
    """The issue's case: 5.871 rad/s against the 6.1-6.4 band is below it by 0.229 rad/s (3.75 %
    of the lower edge) — not "within 5 %" of the band's middle."""
    j = V.judge(5.871, [6.1, 6.4], unit="rad/s")
    assert j["signed"] == pytest.approx(5.871 - 6.1)
    assert j["distance"] == pytest.approx(0.229)
    assert j["relative"] == pytest.approx(-0.229 / 6.1)
    assert j["text"] == "below the band by 0.229 rad/s (3.75 % of its lower edge)"
    assert V.judge(6.7, [6.1, 6.4])["distance"] == pytest.approx(0.3)


@pytest.mark.parametrize("value, status, ok", [(0.009863, "meets", True), (0.01, "meets", True),
                                               (0.01002, "exceeds", False)])
def test_upper_bound(value, status, ok):
    """Table 3's 0.01 m/s: 0.01002 exceeds it (by 0.2 %), 0.009863 meets it."""
    j = V.judge(value, 0.01, "max", unit="m/s")
    assert (j["status"], j["ok"]) == (status, ok)
    if not ok:
        assert j["distance"] == pytest.approx(value - 0.01)
        assert "0.2 %" in j["text"] and "2e-05 m/s" in j["text"]


def test_lower_bound():
    assert V.judge(3.0, 2.0, "min")["status"] == "meets"
    j = V.judge(1.5, 2.0, "min")
    assert (j["status"], j["ok"], j["distance"]) == ("falls short", False, 0.5)


@pytest.mark.parametrize("value, ok", [(0.19, True), (0.21, True), (0.2099, True), (0.2101, False), (0.1899, False),
                                       (0.4047, False)])
def test_point_value_tolerance(value, ok):
    """A point value agrees within ±5 % of the paper's value (relative), not beyond."""
    j = V.judge(value, 0.2)
    assert j["ok"] is ok
    assert j["relative"] == pytest.approx((value - 0.2) / 0.2)


def test_point_value_texts():
    assert V.judge(0.197, 0.2, unit="%")["text"] == "agrees: -1.5 %"
    assert V.judge(5.2, 5.0, tolerance=0.01)["text"] == "differs: +4.0 %, ours higher (tolerance ±1 %)"
    assert V.judge(0.4047, 0.2)["text"] == "differs: ours is 2.02× the paper's value"
    assert V.judge(-0.1, 0.0)["ok"] is False and V.judge(0.0, 0.0)["ok"] is True


def test_nothing_to_judge():
    assert V.judge(1.0, None)["status"] == "no paper value"
    for v in (None, math.nan, math.inf):
        j = V.judge(v, 1.0)
        assert j["status"] == "not computed" and j["ok"] is None


def test_bad_expectations_are_errors():
    for paper, compare in (([6.4, 6.1], None), ([1, 2, 3], None), ("six", None), (1.0, "band"), ([1, 2], "max"),
                           (1.0, "around")):
        with pytest.raises(ValueError):
            V.judge(1.0, paper, compare)


# ---------------------------------------------------------------- rows of several numbers
def test_row_takes_the_worst_backend():
    j = V.judge_row({"multibody": 0.012, "reduced": 0.011}, 0.01, "max", unit="m/s")
    assert j["status"] == "exceeds" and j["worst"] == "multibody"
    assert j["distance"] == pytest.approx(0.002)


def test_row_whose_backends_disagree():
    j = V.judge_row({"multibody": 0.0099, "reduced": 0.0101}, 0.01, "max")
    assert j["status"] == "backends disagree" and j["ok"] is False
    assert j["by"] == {"multibody": "meets", "reduced": "exceeds"}
    assert "multibody: meets" in j["text"] and "reduced: exceeds" in j["text"]


def test_row_ignores_missing_numbers():
    j = V.judge_row({"multibody": 6.2, "reduced": None}, [6.1, 6.4])
    assert j["status"] == "inside" and j["by"]["reduced"] == "not computed"
    assert V.judge_row({"multibody": None}, [6.1, 6.4])["status"] == "not computed"


def test_fitted_rows_say_so_and_are_counted_apart():
    rows = [V.finish_row({"name": "χ", "paper": 54.3, "ours": {"m": 54.3}, "fitted": True}),
            V.finish_row({"name": "a", "paper": 1.0, "ours": {"m": 1.01}}),
            V.finish_row({"name": "b", "paper": [1, 2], "ours": {"m": 3.0}}),
            V.finish_row({"name": "c", "paper": None, "ours": {"m": 3.0}})]
    assert "FITTED" in rows[0]["verdict"]["text"] and rows[0]["paper_text"] == "54.3 (fitted)"
    assert V.counts(rows) == {"meet": 1, "fitted": 1, "differ": 1, "unjudged": 1}


def test_finish_row_fields():
    r = V.finish_row({"name": "x", "unit": "rad/s", "paper": [6.1, 6.4], "ours": {"multibody": 5.9}})
    assert (r["compare"], r["paper_text"], r["difference"]) == ("band", "6.1–6.4", None)
    r = V.finish_row({"name": "x", "paper": 0.01, "compare": "max", "ours": {"multibody": 0.005}})
    assert r["paper_text"] == "≤ 0.01" and r["verdict"]["status"] == "meets"
    r = V.finish_row({"name": "x", "paper": 2.0, "ours": {"multibody": 3.0, "reduced": 3.1}})
    assert r["difference"] == 1.0 and r["rel_difference"] == 0.5  # first number of ours


def test_paper_figures_entries():
    """[[paper.figures]]: exactly one of value, band, max, min."""
    assert V.from_figure({"name": "a", "band": [6.1, 6.4]})["compare"] == "band"
    assert V.from_figure({"name": "a", "max": 0.1})["compare"] == "max"
    e = V.from_figure({"name": "a", "value": 2.6, "unit": "%", "fitted": True})
    assert (e["paper"], e["unit"], e["fitted"]) == (2.6, "%", True)
    for bad in ({"name": "a"}, {"name": "a", "value": 1, "max": 2}):
        with pytest.raises(ValueError, match="exactly one"):
            V.from_figure(bad)


def test_every_builtin_paper_figure_is_well_formed():
    from mjbench import scenario as S

    for name in S.builtin_names():
        for fig in S.load(name).paper.get("figures", []) or []:
            V.from_figure(fig)  # raises on a malformed entry


# ---------------------------------------------------------------- the report renders the computed verdicts
def _case(rows):
    rows = [R._normalise_row(r) for r in rows]
    return {"case": "synthetic", "scenario": "s", "paper": "p", "citation": "Someone 2024", "paper_title": "",
            "title": "t", "scenario_title": "", "kind": "run", "overrides": [], "note": "", "rows": rows,
            "tables": [], "warnings": [], "figures": [], "video": None, "runtime_s": 1.0, "counts": V.counts(rows)}


def test_report_prints_the_computed_verdicts(tmp_path):
    res = _case([{"name": "speed band", "unit": "rad/s", "paper": [6.1, 6.4], "ours": {"multibody": 5.871}},
                 {"name": "deviation", "unit": "m/s", "paper": 0.01, "compare": "max", "ours": {"multibody": 0.01002},
                  "reason": "a stated reason"},
                 {"name": "error", "unit": "%", "paper": 0.2, "ours": {"multibody": 0.197}}])
    md, htm = R.write_report([res], tmp_path)
    text, page = md.read_text(), htm.read_text()
    lines = {l.split("|")[1].strip(): [c.strip() for c in l.strip().strip("|").split("|")]
             for l in text.splitlines() if l.startswith("| ") and l.count("|") == 7}
    assert lines["speed band"][2] == "6.1–6.4" and lines["speed band"][4].startswith("below the band by 0.229 rad/s")
    assert lines["speed band"][5] == "no reason stated"  # a miss without a reason says so
    assert lines["deviation"][2] == "≤ 0.01" and lines["deviation"][4].startswith("exceeds the upper bound by 0.2 %")
    assert lines["error"][4] == "agrees: -1.5 %"
    # summary: 1 of 3 meets the paper, in both files
    # (with the verdict bar: 1 of 3 rows meets, 2 differ → 3 green, 7 orange of 10 squares)
    assert "| [synthetic](#case-synthetic) | Someone 2024 | 🟩🟩🟩🟧🟧🟧🟧🟧🟧🟧 | 3 | 1/3 | 2 | 0 | 1.0 | — |" in text
    assert '<td class="num">1/3</td>' in page and "meet the paper" in page
    assert "Glossary" in text and "Glossary" in page
    for term in ("χ", "J(α)", "reduced", "multibody", "verdict"):
        assert f"**{term}**" in text and f"<dt>{term}</dt>" in page
