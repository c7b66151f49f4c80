"""Ticks and legends of evtribo's figures.

:func:`voltage_ticks` puts a tick at each measured amplitude with a plain label (``140``,
not a power of ten), leaving out labels that would run into a neighbour's
(:class:`SpacedPlainFormatter`); :func:`plain_log_axis` labels a log axis with plain
numbers. :func:`place_legend` puts a legend above the Axes, where it covers no data, in
every figure alike (a figure of :func:`~evtribo.figures.style.new_axes` then grows by the
legend's height, so that the data keep theirs, and its layout is then fixed); asked to,
it tries the corners of the Axes first, each checked against the drawn data
(:func:`legend_overlap`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis, XAxis
from matplotlib.collections import Collection
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine
from matplotlib.legend import Legend
from matplotlib.ticker import (
    FixedLocator,
    Formatter,
    FuncFormatter,
    LogLocator,
    NullFormatter,
    NullLocator,
)
from matplotlib.transforms import Bbox
from numpy.typing import ArrayLike, NDArray

from evtribo.figures.style import owns

__all__ = ["SpacedPlainFormatter", "legend_overlap", "place_legend", "plain_log_axis",
           "reading_order", "voltage_ticks"]


def _plain(value: float, _pos: int | None = None) -> str:
    return f"{value:g}"


class SpacedPlainFormatter(Formatter):
    """Plain labels (``140``), left out where they would run into a neighbour's.

    Labels are kept from the largest value down, each only if it clears the last one kept
    (digits taken as 0.64 em wide, half an em apart), so the highest amplitude always has
    its label; the ticks themselves all stay.
    """

    def __call__(self, x: float, pos: int | None = None) -> str:
        """The plain label of *x*.

        Parameters
        ----------
        x : float
            The tick's value.
        pos : int, optional
            Its position (unused).

        Returns
        -------
        str
            ``f"{x:g}"``.
        """
        return _plain(x)

    def format_ticks(self, values: Sequence[float]) -> list[str]:
        """The labels of all ticks, blank where a label would overlap the next one up.

        Parameters
        ----------
        values : sequence of float
            The ticks' values.

        Returns
        -------
        list of str
            One label per value.
        """
        labels = [_plain(v) for v in values]
        axis = self.axis
        if not isinstance(axis, Axis) or len(labels) < 2 or axis.axes is None:
            return labels  # not on an Axes' axis (a colour bar's, say)
        ax = axis.axes
        xy = np.zeros((len(labels), 2))
        col = 0 if isinstance(axis, XAxis) else 1
        xy[:, col] = np.asarray(values, float)
        where = ax.transData.transform(xy)[:, col]
        ticks = axis.get_major_ticks()
        size = ticks[0].label1.get_fontsize() if ticks else mpl.rcParams["font.size"]
        em = float(size) * ax.figure.dpi / 72.0
        half = {i: (0.64 * em * len(t) if col == 0 else em) / 2 for i, t in enumerate(labels)}
        kept: int | None = None
        for i in np.argsort(-np.asarray(values, float), kind="stable"):
            if kept is None or abs(where[kept] - where[i]) >= half[kept] + half[i] + em / 2:
                kept = int(i)
            else:
                labels[i] = ""
        return labels


def voltage_ticks(axis: Axis, amplitudes: ArrayLike) -> None:
    """One major tick at each measured amplitude, with a plain label where it fits (always
    at the highest), no minor ticks.

    Parameters
    ----------
    axis : Axis
        The voltage axis (``ax.xaxis``), linear or logarithmic.
    amplitudes : array_like
        The measured amplitudes, V (repeats and NaN ignored).

    Returns
    -------
    None
    """
    amps = np.asarray(amplitudes, dtype=float).ravel()
    ticks = np.unique(amps[np.isfinite(amps)])
    if ticks.size == 0:
        return
    axis.set_major_locator(FixedLocator(ticks.tolist()))
    axis.set_major_formatter(SpacedPlainFormatter())
    axis.set_minor_locator(NullLocator())
    axis.set_minor_formatter(NullFormatter())


def plain_log_axis(axis: Axis, subs: Sequence[float] = (1.0, 2.0, 5.0)) -> None:
    """Ticks of a log axis at 1, 2, 5 x 10^k (or *subs*) with plain labels (``0.5``, ``20``).

    Parameters
    ----------
    axis : Axis
        A logarithmic axis.
    subs : sequence of float
        The multiples of each power of ten that get a labelled tick; ``(1.0,)`` for an axis
        over many decades.

    Returns
    -------
    None
    """
    axis.set_major_locator(LogLocator(base=10, subs=tuple(subs)))
    axis.set_major_formatter(FuncFormatter(_plain))
    axis.set_minor_locator(LogLocator(base=10, subs=tuple(range(1, 10))))
    axis.set_minor_formatter(NullFormatter())


def _data_points(ax: Axes) -> NDArray[np.float64]:
    """Display coordinates of what is drawn in *ax*: lines sampled densely along their
    segments, collections (error bars, fills), and texts' corners."""
    pts: list[NDArray[np.float64]] = []
    for line in ax.lines:
        if not line.get_visible():
            continue
        xy = line.get_transform().transform(np.asarray(line.get_xydata(), float))
        pts.append(_densify(xy) if line.get_linestyle() not in ("None", "", " ") else xy)
    for coll in ax.collections:
        if not isinstance(coll, Collection) or not coll.get_visible():
            continue
        trans = coll.get_transform()
        for path in coll.get_paths():
            xy = trans.transform(np.asarray(path.vertices, float))
            pts.append(_densify(xy))
    for text in ax.texts:
        if text.get_visible() and text.get_text():
            box = text.get_window_extent()
            pts.append(np.array([[box.x0, box.y0], [box.x1, box.y0], [box.x0, box.y1],
                                 [box.x1, box.y1]]))
    if not pts:
        return np.empty((0, 2))
    allp = np.concatenate(pts)
    return allp[np.isfinite(allp).all(axis=1)]


def _densify(xy: NDArray[np.float64], step: float = 2.0) -> NDArray[np.float64]:
    """Points every *step* display units along the polyline *xy*."""
    xy = xy[np.isfinite(xy).all(axis=1)]
    if len(xy) < 2:
        return xy
    seg = np.diff(xy, axis=0)
    n = np.clip(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / step).astype(int), 1, 2000)
    frac = [np.arange(k) / k for k in n]
    parts = [xy[i] + f[:, None] * seg[i] for i, f in enumerate(frac)]
    return np.concatenate([*parts, xy[-1:]])


def legend_overlap(ax: Axes, legend: Legend | None = None, pad: float = 2.0) -> int:
    """How many drawn data points fall under the legend of *ax* (0: it covers nothing).

    Parameters
    ----------
    ax : Axes
        The Axes, laid out (as last drawn).
    legend : Legend, optional
        The legend to check; the Axes' own by default.
    pad : float
        Margin around the legend's frame, points.

    Returns
    -------
    int
        The number of sampled data points (lines every 2 display units, error bars, texts)
        inside the legend's box; 0 without a legend.
    """
    legend = legend if legend is not None else ax.get_legend()
    if legend is None:
        return 0
    fig = ax.get_figure()
    assert fig is not None
    box = legend.get_window_extent()
    grow = pad * fig.dpi / 72.0
    box = Bbox.from_extents(box.x0 - grow, box.y0 - grow, box.x1 + grow, box.y1 + grow)
    pts = _data_points(ax)
    inside = ((pts[:, 0] >= box.x0) & (pts[:, 0] <= box.x1)
              & (pts[:, 1] >= box.y0) & (pts[:, 1] <= box.y1))
    return int(inside.sum())


_CORNERS = ("upper left", "upper right", "lower right", "lower left", "center left",
            "center right", "upper center", "lower center")


def place_legend(ax: Axes, handles: Sequence[Any] | None = None,
                 labels: Sequence[str] | None = None, *, ncol_outside: int = 2,
                 inside: bool = False, **kwargs: Any) -> Legend | None:
    """A legend where it covers no data: above the Axes, as in every figure of evtribo
    (with *inside*, the first free corner, in one column then in two, else above); its
    entries read in their order, row by row.

    The figure is laid out first (so the Axes have their final size), then each corner is
    tried and checked with :func:`legend_overlap`. Above the Axes of a figure of
    :func:`~evtribo.figures.style.new_axes`, the figure grows by what the legend needs and
    that layout is fixed: every Axes keeps its size and its place from the bottom, and
    nothing is laid out again when the figure is saved (a legend wider than the figure
    leaves the layout engine to narrow the Axes instead). Draw nothing on the figure after
    its legend.

    Parameters
    ----------
    ax : Axes
        The Axes, with everything drawn.
    handles, labels : sequence, optional
        As for :meth:`Axes.legend`; the Axes' labelled artists by default.
    ncol_outside : int
        Columns of the legend when it goes above the Axes.
    inside : bool
        Try the corners inside the Axes first (default False: straight above, the place of
        every legend of evtribo's figures, so that they read alike).
    **kwargs
        Passed to :meth:`Axes.legend`.

    Returns
    -------
    Legend or None
        The legend (None when nothing is labelled).
    """
    if handles is None or labels is None:
        handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    root: Figure = ax.figure.figure  # the figure itself, or a subfigure's
    engine = root.get_layout_engine()
    if engine is not None:
        engine.execute(root)  # fixes the layout (the limits below)
    else:
        root.draw_without_rendering()
    ax.set_xlim(ax.get_xlim())
    ax.set_ylim(ax.get_ylim())
    make: Any = ax.legend  # loc as a plain str
    for ncol in (1, 2) if inside else ():
        if ncol > 1 and len(handles) < 4:
            break
        for loc in _CORNERS:
            legend: Legend = make(*reading_order(handles, labels, ncol), loc=loc, ncol=ncol,
                                  **kwargs)
            if legend_overlap(ax, legend) == 0:
                return legend
    return _legend_above(ax, make, handles, labels, ncol_outside, **kwargs)


def reading_order(handles: Sequence[Any], labels: Sequence[str], ncol: int
                  ) -> tuple[list[Any], list[str]]:
    """The entries arranged so that a legend of *ncol* columns (which matplotlib fills
    column by column) reads in their order row by row, as text is read.

    Parameters
    ----------
    handles, labels : sequence
        The entries, in the order they are to be read.
    ncol : int
        Columns of the legend.

    Returns
    -------
    (list, list)
        The handles and labels in the order to hand to :meth:`Axes.legend`.
    """
    n = len(handles)
    rows = -(-n // max(ncol, 1))
    order = [r * ncol + c for c in range(ncol) for r in range(rows) if r * ncol + c < n]
    return [handles[i] for i in order], [labels[i] for i in order]


def _legend_above(ax: Axes, make: Any, handles: Sequence[Any], labels: Sequence[str],
                  ncol: int, **kwargs: Any) -> Legend:
    """A legend above the Axes in the fewest rows that fit its width (up to *ncol*
    columns), and of those the one with the fewest empty places."""
    room = ax.get_window_extent().width
    n = len(handles)

    def shape(cols: int) -> tuple[int, int]:
        rows = -(-n // cols)
        return rows, rows * cols - n

    fits = [1]
    for cols in range(2, min(ncol, n) + 1):
        trial: Legend = make(*reading_order(handles, labels, cols), loc="lower center",
                             bbox_to_anchor=(0.5, 1.02), ncol=cols, borderaxespad=0.0,
                             **kwargs)
        if trial.get_window_extent().width <= room:
            fits.append(cols)
    best = min(fits, key=shape)
    legend: Legend = make(*reading_order(handles, labels, best), loc="lower center",
                          bbox_to_anchor=(0.5, 1.02), ncol=best, borderaxespad=0.0, **kwargs)
    fig = ax.figure.figure
    if owns(fig):  # the figure grows by the legend: the data keep the height they had
        if not _grow_to_hold(fig, legend):
            fig.set_figheight(fig.get_figheight()
                              + legend.get_window_extent().height / fig.dpi)
    return legend


def _grow_to_hold(fig: Figure, legend: Legend) -> bool:
    """Make *fig*, laid out, taller by what *legend* above its Axes needs, every Axes
    keeping its size and its place from the bottom, and fix that layout (no layout engine
    left to run again: its result is known). False, with nothing changed, when the legend
    is wider than the figure holds (the layout engine, still there, then narrows the Axes).
    """
    engine = fig.get_layout_engine()
    if not isinstance(engine, ConstrainedLayoutEngine):
        return False
    pads = engine.get()
    box = legend.get_window_extent()
    dpi, width, height = fig.dpi, fig.get_figwidth(), fig.get_figheight()
    if box.x0 < pads["w_pad"] * dpi or box.x1 > (width - pads["w_pad"]) * dpi:
        return False
    grown = max(height, box.y1 / dpi + pads["h_pad"])
    places = [(a, a.get_position()) for a in fig.axes]  # as the layout left them
    fig.set_layout_engine("none")  # not None: a style asking for constrained layout
    #                                would bring a new engine back
    fig.set_figheight(grown)
    for a, p in places:  # the same inches from the bottom, the same height in inches
        a.set_position(Bbox.from_bounds(p.x0, p.y0 * height / grown, p.width,
                                        p.height * height / grown))
    return True
