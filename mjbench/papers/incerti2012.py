"""Incerti 2012 (seed 000): four-bar linkage + DC motor + PID with the time-varying gain K_p·t.

Report rows: the scenario's ``[[paper.figures]]`` (χ of Eq 22 open loop and PID) come from the
run itself (:func:`mjbench.runner.paper_rows`); the figure is Fig. 4's layout (both columns,
both backends).  The calibration of the illegible Table I values is
:mod:`mjbench.papers.incerti2012_calibration`.
"""
from __future__ import annotations

from mjbench.papers import Case

KEY = "incerti2012"
CITATION = "Incerti 2012"
TITLE = "On the dynamic behaviour of a four-bar linkage driven by a velocity controlled DC motor"
SCENARIOS = ("incerti2012", "incerti2012-calibrated")
CASES = [
    Case(name="incerti2012-fig4", scenario="incerti2012",
         title="Fig. 4: open loop 25 V (left) and PID K_p·t (right), χ of Eq 22",
         modes=["open", "pid"], backend="both", t_end=2.0, video=True, video_mode="pid", video_t_end=2.0),
    Case(name="incerti2012-calibrated-fig4", scenario="incerti2012-calibrated",
         title="Fig. 4 with the missing Table I values FITTED to the paper's χ (not a prediction)",
         modes=["open", "pid"], backend="both", t_end=2.0, video=True, video_mode="pid", video_t_end=2.0),
]


def rows(ctx) -> list:
    """No rows beyond the scenario's [[paper.figures]] (added by reproduce for every run case)."""
    return []


def figures(ctx) -> list:
    """Seed 000 Fig. 4 layout: one column per mode, every backend drawn, set-point dashed."""
    from mjbench.reproduce import default_figures
    return default_figures(ctx)
