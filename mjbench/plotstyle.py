"""One matplotlib style for every mjbench figure; figures without pyplot.

mjbench never selects a matplotlib backend: every figure is a :class:`Figure` made without pyplot
(:func:`new`, :func:`subplots`), saved through Agg (:func:`mjbench.plots.save`) whatever backend
the user has, and never registered with pyplot — so a notebook's ``%matplotlib inline`` (or any
backend the user chose) keeps working, and a figure a function returns is shown once, by Jupyter's
display of the returned object (:meth:`Figure._repr_png_`), not a second time by pyplot.

* ``use()`` / ``context()``: rcParams — DejaVu Sans, 9-10 pt, light grid, thin axes, legends with
  a white frame, 130 dpi PNG; every figure laid out tight (``figure.autolayout``: the layout is
  computed when the figure is drawn, so a figure is drawn once when saved — a tight *bounding
  box* at save time would draw it twice: once to measure, once to write);
* ``BACKEND``: one line style per simulator backend, so that multibody and reduced results are
  told apart the same way in every figure (solid blue / dashed orange);
* ``setpoint(ax, value, label)``: the paper's set-point line (seed 000 Fig. 4: horizontal dashed
  black line);
* ``label(quantity, unit)``: axis labels always carry the unit in brackets.
"""
from __future__ import annotations

import contextlib

import functools

from cycler import cycler  # (matplotlib's own dependency; matplotlib itself is imported where a figure is drawn)


def _matplotlib():
    """matplotlib, imported on first use (≈ 1 s: a run without a figure never loads it); no backend
    is selected (module doc)."""
    import matplotlib
    import matplotlib.figure  # noqa: F401 - the Figure class below

    return matplotlib

RC = {
    "font.family": "DejaVu Sans",
    "font.size": 9.5,
    "axes.titlesize": 10,
    "axes.labelsize": 9.5,
    "axes.linewidth": 0.8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "legend.fontsize": 8,
    "legend.framealpha": 0.9,
    "legend.edgecolor": "0.7",
    "lines.linewidth": 1.3,
    "xtick.labelsize": 8.5,
    "ytick.labelsize": 8.5,
    "figure.dpi": 100,
    "savefig.dpi": 130,
    "figure.autolayout": True,  # tight layout at draw time (no "savefig.bbox": "tight": one draw per save)
    "figure.constrained_layout.use": False,
    "axes.prop_cycle": cycler(color=["tab:blue", "tab:orange", "tab:green", "tab:red",
                                                "tab:purple", "tab:brown", "tab:pink", "tab:gray"]),
}

#: line style per backend (the same in every figure)
BACKEND = {
    "multibody": dict(color="tab:blue", lw=1.4, ls="-", label="multibody (MuJoCo)"),
    "reduced": dict(color="tab:orange", lw=1.0, ls="--", label="reduced J(α) model"),
}
#: the paper's set-point line (seed 000 Fig. 4 caption: "horizontal dashed line")
SETPOINT = dict(color="k", ls="--", lw=0.9)
#: a paper band or reported value range
BAND = dict(color="0.6", alpha=0.25, lw=0)


def use():
    """Apply the mjbench rcParams globally."""
    _matplotlib().rcParams.update(RC)


@contextlib.contextmanager
def context():
    """Temporarily apply the mjbench rcParams (``with plotstyle.context(): ...``)."""
    with _matplotlib().rc_context(RC):
        yield


def label(quantity: str, unit: str) -> str:
    """'quantity [unit]' (every axis carries its unit)."""
    return f"{quantity} [{unit}]" if unit else quantity


def backend_style(backend: str, several_axes: bool = False, **extra) -> dict:
    """The line style of ``backend`` (``extra`` over it); the reduced model of a machine with several
    motors is M̄(q), not J(α)."""
    st = {**BACKEND.get(backend, dict(label=backend)), **extra}
    if several_axes and "label" in st:
        st["label"] = st["label"].replace("J(α)", "M̄(q)")
    return st


def setpoint(ax, value, text="set-point", unit="rad/s"):
    """Draw the set-point as the paper does (horizontal dashed line) and label it in the legend."""
    if value is None:
        return None
    return ax.axhline(float(value), **SETPOINT, label=f"{text} {value:g} {unit}".strip())


def band(ax, lo, hi, text):
    """A shaded horizontal band (e.g. a range the paper reports)."""
    return ax.axhspan(float(lo), float(hi), **BAND, label=text)


def suptitle(fig, text, **kw):
    """``fig.suptitle(text)`` wrapped onto as many lines as it needs to fit the figure's width:
    figures are saved at their canvas size (no tight bounding box, see :data:`RC`), so a title
    wider than the figure would be cut.  Call it before the layout is computed."""
    t = fig.suptitle(text, **kw)
    if not text:
        return t
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if hasattr(fig.canvas, "get_renderer") else FigureCanvasAgg(fig)
    room = 0.96 * fig.bbox.width
    width = t.get_window_extent(canvas.get_renderer()).width
    if width > room:
        import textwrap

        longest = max(len(line) for line in text.split("\n"))
        n = max(20, int(longest * room / width))
        t.set_text("\n".join(textwrap.fill(line, n) for line in text.split("\n")))
    return t


def finish(fig, title=None):
    if title:
        suptitle(fig, title, fontsize=10.5)
    if fig.get_layout_engine() is None:  # else laid out once, when drawn (RC "figure.autolayout")
        fig.tight_layout()
    return fig


@functools.cache
def _figure_class():
    """:class:`Figure` (defined on first use: matplotlib is imported then)."""

    class Figure(_matplotlib().figure.Figure):
        """A matplotlib Figure that is not pyplot's: nothing to close, and shown once in a notebook.

        Jupyter displays it as a PNG through ``_repr_png_`` (or through the inline backend's own
        formatter for figures, when one is registered: one image either way); pyplot does not know it,
        so ``plt.show()`` and the inline backend's end-of-cell display do not show it again.  In a
        script, save it (``fig.savefig(path)``)."""

        def _repr_png_(self):
            import io

            from matplotlib.backends.backend_agg import FigureCanvasAgg

            buf = io.BytesIO()
            FigureCanvasAgg(self).print_png(buf)
            return buf.getvalue()

    return Figure


def __getattr__(name):  # ``plotstyle.Figure``: the class, matplotlib imported on first use
    if name == "Figure":
        return _figure_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def new(nrows=1, ncols=1, *, figsize=None, layout=None, **kw):
    """A figure and its axes (like ``plt.subplots``) with the mjbench style active for the created
    figure.  A :class:`Figure`: no pyplot (its import, its figure manager), nothing to close; save
    it with :func:`mjbench.plots.save`."""
    with context():
        fig = _figure_class()(figsize=figsize, layout=layout)
        return fig, fig.subplots(nrows, ncols, **kw)


def subplots(nrows=1, ncols=1, *, figsize=None, layout=None, **kw):
    """``plt.subplots`` without pyplot and without the mjbench style: a :class:`Figure` and its
    axes (the paper modules draw in their own styles)."""
    fig = _figure_class()(figsize=figsize, layout=layout)
    return fig, fig.subplots(nrows, ncols, **kw)


class _NoPyplot:
    """What the paper modules used of pyplot, without pyplot: ``subplots`` (a :class:`Figure`),
    ``close`` (nothing to release), ``Rectangle``."""

    subplots = staticmethod(subplots)

    @staticmethod
    def close(fig=None):
        return None

    @property
    def Rectangle(self):
        from matplotlib.patches import Rectangle

        return Rectangle


#: ``from mjbench.plotstyle import no_pyplot as plt`` in a module that draws with ``plt.subplots``
no_pyplot = _NoPyplot()
