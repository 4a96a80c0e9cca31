"""The paper cases from Python: :func:`reproduce_papers` runs them end to end and writes the
report (``mjbench reproduce``, ``mjbench demo``)."""
from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .scenarios import warn
from .. import reproduce as R
from .. import render
from ..outputs import staged_dir
from .video import check_frame


def paper_cases() -> list[Any]:
    """The registered paper cases (``mjbench reproduce --list``): ``.name``, ``.paper``,
    ``.scenario``, ``.kind``, ``.modes``, ``.title``."""

    return list(R.load_cases())


def reproduce_papers(path: str | os.PathLike[str], case: str = "all", *, quick: bool = False, video: bool = True,
                     width: int | None = None, height: int | None = None, force: bool = False,
                     progress: bool = False, log: Callable[[str], Any] | None = None,
                     what: str = "save", jobs: int = 1) -> list[dict[str, Any]]:
    """Run paper cases end to end and write their report into the folder ``path``.

    Parameters
    ----------
    path : str or path
        The report folder (``report.md``, ``report.html``, ``summary.json``, one folder per case),
        written whole or not at all; a non-empty one is replaced only with ``force=True``.
    case : str
        ``"all"``, a case name (:func:`paper_cases`) or a scenario name (all its cases).
    quick : bool
        Short videos (``mjbench demo``).
    video : bool
        Render a video per case (needs offscreen OpenGL; without it the report says why each video
        is missing and a :class:`MjbenchWarning` is emitted).
    width, height : int, optional
        Video frame size [px].
    progress, log
        Progress bars; a callable for the per-case lines (default: silent).
    jobs : int
        Worker processes running the cases side by side (1: in this process; the numbers do not
        depend on it).  The workers are spawned: a script calling this with ``jobs > 1`` must
        guard its entry point (``if __name__ == "__main__":``), as for any ``multiprocessing`` use.

    Returns
    -------
    list of dict
        Each case's results (what its ``metrics.json`` holds).
    """

    R.select(R.load_cases(), case)  # an unknown case name: an error before anything is written
    if video:
        check_frame(width if width is not None else (640 if quick else 960),
                    height if height is not None else (360 if quick else 540))
        try:
            render.gl_setup()
        except render.RenderError as e:
            warn([f"{e} The report is written without videos."])
    with staged_dir(path, force=force, what=what) as tmp:
        res: list[dict[str, Any]] = R.reproduce(case, tmp, quick=quick, video=video, progress=progress, width=width,
                                                height=height, log=log or (lambda *a: None), jobs=jobs)
    return res
