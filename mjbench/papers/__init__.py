"""Paper studies: one module per paper, registered here in code.

Each module holds what is specific to its paper — which scenarios reproduce it, the cases
``mjbench reproduce`` runs, the report rows (paper figure, ours, verdict) and the figures in the
paper's style — plus, as submodules, the paper-specific tools (the Incerti 2012 calibration, the
Hülako & Çakar demand helper, the Yiğit & Şen optimum design).  The engine (scenario, mechanisms, drive,
controllers, kernel, backends, outputs) never imports this package; ``reproduce`` and the
commands do.

A new paper = one module defining ``KEY``, ``CITATION``, ``TITLE``, ``SCENARIOS``, ``CASES``
(a list of :class:`Case`), ``rows(ctx)`` and ``figures(ctx)`` (``ctx``: a
:class:`mjbench.reproduce.CaseRun`), added to :data:`MODULES`; optional: ``study(ctx)`` for cases
of ``kind = "study"``, ``SCENARIO_TITLES`` ({scenario: paper title} when a module covers several
papers).  Rows state the paper's figure (a value, a band [lo, hi], a bound) and our numbers,
never a verdict: :mod:`mjbench.verdicts` computes it; ``"headline": True`` puts a row among the
few numbers the report shows next to the case's first figure (:func:`mjbench.report.headline`),
and ``figures(ctx)`` lists the case's headline figure first.  Hooks may append extra tables to
``ctx.tables`` and warnings to ``ctx.warnings``.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field

#: submodules that import matplotlib or scipy.optimize when loaded: this package's ONE lazy place —
#: ``papers.<name>`` imports them on first use (:func:`__getattr__`), so a paper's rows cost no
#: plotting or optimiser imports
LAZY = ("hulako2025_plots", "incerti_platforms_plots", "yigit2023_plots", "yigit2023_design")


def __getattr__(name: str):
    if name in LAZY:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: paper key → module (one module per paper)
MODULES = {
    "incerti2012": "mjbench.papers.incerti2012",
    "incerti-platforms": "mjbench.papers.incerti_platforms",
    "hulako2025": "mjbench.papers.hulako2025",
    "yigit2023": "mjbench.papers.yigit2023",
    "examples": "mjbench.papers.examples",
    "design": "mjbench.papers.design_examples",
}


@dataclass
class Case:
    """One ``mjbench reproduce`` case: a scenario run end to end (``kind = "run"``: the listed
    modes on the backends; ``"optimize-law"``: the motion-law study; ``"study"``: the paper
    module's ``study(ctx)``; ``"design"``: ``scenario`` names a requirements file, the paper
    module's ``design(case, out)`` designs and verifies the machine)."""

    name: str
    scenario: str
    kind: str = "run"
    title: str = ""
    modes: list = field(default_factory=list)
    backend: str = "both"
    t_end: float | None = None
    overrides: list = field(default_factory=list)
    video: bool = True
    video_mode: str | None = None
    video_t_end: float | None = None
    note: str = ""
    paper: str = ""


def module(key: str):
    return importlib.import_module(MODULES[key])


def cases() -> list[Case]:
    """Every case of every paper, with its paper key filled in."""
    out, seen = [], {}
    for key in MODULES:
        for c in module(key).CASES:
            if c.name in seen:
                raise ValueError(f"reproduce case {c.name!r} defined twice ({seen[c.name]}, {key})")
            seen[c.name] = key
            c.paper = key
            out.append(c)
    return out
