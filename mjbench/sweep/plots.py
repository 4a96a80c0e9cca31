"""The summary plots of a sweep (a line or a heat map of the summary metric over the grid)."""
from __future__ import annotations

import math
import os

import numpy as np

from .spec import SweepSpec
from .table import default_metric, plot_metric
from .. import plots as P
from ..plotstyle import new


def summary_plots(spec: SweepSpec, results: list[dict], out_dir, metric: str | None = None) -> list:
    """Heat map (two grid keys), line (one grid key) and, for Monte Carlo, histograms."""

    metric = metric or default_metric(results) or plot_metric(results)
    if metric is None:
        return []
    paths = []
    gk = list(spec.grid)
    ok = [r for r in results if r.get("status") == "ok" and metric in r]
    if not spec.samples and len(gk) == 2:
        xs, ys = spec.grid[gk[0]], spec.grid[gk[1]]
        Z = np.full((len(ys), len(xs)), np.nan)
        for r in ok:
            try:
                Z[ys.index(_match(ys, r[gk[1]])), xs.index(_match(xs, r[gk[0]]))] = r[metric]
            except ValueError:
                pass
        fig, ax = new(figsize=(6.4, 5))
        im = ax.imshow(Z, origin="lower", aspect="auto", cmap="viridis")
        ax.set_xlabel(gk[0])
        ax.set_ylabel(gk[1])
        if len(xs) <= LABELLED_CELLS and len(ys) <= LABELLED_CELLS:  # values written only where they can be read
            for (iy, ix), v in np.ndenumerate(Z):
                if np.isfinite(v):
                    ax.text(ix, iy, f"{v:.3g}", ha="center", va="center", fontsize=7, color="w")
        step = max(1, len(xs) // LABELLED_CELLS), max(1, len(ys) // LABELLED_CELLS)  # readable tick labels
        ax.set_xticks(range(0, len(xs), step[0]), [_tick(v) for v in xs[::step[0]]], rotation=45)
        ax.set_yticks(range(0, len(ys), step[1]), [_tick(v) for v in ys[::step[1]]])
        fig.colorbar(im, ax=ax, label=metric)
        ax.set_title(f"{metric} (blank: diverged/error)")
        paths.append(P.save(fig, os.path.join(out_dir, f"heatmap_{metric}.png")))
    elif not spec.samples and len(gk) == 1:
        xs = [r[gk[0]] for r in ok]
        fig, ax = new(figsize=(6.4, 4))
        ax.plot(xs, [r[metric] for r in ok], "o-")
        ax.set_xlabel(gk[0])
        ax.set_ylabel(metric)
        ax.grid(alpha=0.3)
        paths.append(P.save(fig, os.path.join(out_dir, f"line_{metric}.png")))
    if spec.samples:
        vals = np.array([r[metric] for r in ok])
        fig, ax = new(figsize=(6.4, 4))
        if len(vals):
            ax.hist(vals, bins=max(5, min(40, len(vals) // 4)), color="tab:blue", alpha=0.8)
            q = np.percentile(vals, [5, 50, 95])
            for v, ls in zip(q, (":", "-", ":")):
                ax.axvline(v, color="k", ls=ls, lw=1)
            ax.set_title(f"{metric}: median {q[1]:.4g}, 5–95 % [{q[0]:.4g}, {q[2]:.4g}], n = {len(vals)} "
                         f"({len(results) - len(ok)} failed)", fontsize=9)
        ax.set_xlabel(metric)
        ax.set_ylabel("simulations")
        paths.append(P.save(fig, os.path.join(out_dir, f"distribution_{metric}.png")))
    return paths


#: the heat map writes each cell's value (and every tick label) only up to this many cells per axis
LABELLED_CELLS = 16


def _tick(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _match(values, v):
    for x in values:
        if x == v or (isinstance(x, (int, float)) and isinstance(v, (int, float)) and math.isclose(x, v, rel_tol=1e-12)):
            return x
    raise ValueError(v)
