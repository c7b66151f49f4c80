"""The journal style of evtribo's figures: sizes, fonts, colours, ticks and legends.

A figure drawn inside :func:`journal_style` is the width of a journal's single column
(85 mm) or of a full page (175 mm), has no title (a caption carries it), 7-8 pt text,
and is saved with text as text (SVG ``svg.fonttype = 'none'``, PDF Type 42 fonts) and PNG
at 300 dpi. Nothing is changed globally: the style is a :func:`matplotlib.rc_context`
entered and left by the caller (the ``plot_*`` functions enter it when they make their own
figure).

Colours are the Okabe-Ito palette (safe for the common colour-vision deficiencies); each
series also has its own marker and line style (:func:`series_style`), so that a greyscale
print still tells them apart. :func:`place_legend` puts a legend in a corner of the Axes
where it covers no data, checked against the drawn data, or above the Axes when no corner
is free. :func:`voltage_ticks` puts a plain tick label (``140``, not a power of ten) at
each measured amplitude.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import inspect
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any, ParamSpec, TypeVar, cast

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis, XAxis
from matplotlib.collections import Collection
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
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

from evtribo.errors import UserInputError

__all__ = [
    "DEFAULT_DPI",
    "DEFAULT_FORMATS",
    "FIGURE_FORMATS",
    "FIGURE_WIDTHS",
    "LINESTYLES",
    "MARKERS",
    "PALETTE",
    "SpacedPlainFormatter",
    "active_width",
    "figure_size",
    "journal_style",
    "legend_overlap",
    "parse_figure_formats",
    "parse_figure_width",
    "place_legend",
    "plain_log_axis",
    "proxy",
    "series_style",
    "styled",
    "voltage_ticks",
]

#: The figure formats compare writes, in the order it lists them.
FIGURE_FORMATS = ("pdf", "svg", "png")
#: What compare writes when not told: the report embeds the PNG (or the SVG).
DEFAULT_FORMATS = ("svg", "png")
#: Resolution of PNG figures, dots per inch.
DEFAULT_DPI = 300.0
#: Figure widths, mm: a journal's single column and full page width.
FIGURE_WIDTHS = {"single": 85.0, "double": 175.0}

_MM = 1.0 / 25.4
#: Okabe & Ito (2008), without yellow (too pale on white) until the eighth series.
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000",
           "#F0E442")
#: One marker per series (filled shapes that differ in outline).
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<")
#: One line style per series.
LINESTYLES: tuple[Any, ...] = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)), (0, (8, 2)),
                               (0, (1, 1)), (0, (3, 1, 3, 1, 1, 1)))

_ACTIVE: contextvars.ContextVar[str | None] = contextvars.ContextVar("journal_width",
                                                                    default=None)


def _rc(width: str) -> dict[str, Any]:
    from cycler import cycler

    return {
        "figure.figsize": figure_size(width),
        "figure.dpi": 100,
        "savefig.dpi": DEFAULT_DPI,
        "figure.constrained_layout.use": True,
        "svg.fonttype": "none",
        "pdf.fonttype": 42,
        "ps.fonttype": 42,
        "font.family": "sans-serif",
        "font.sans-serif": ["DejaVu Sans"],
        "font.size": 8,
        "axes.titlesize": 8,
        "axes.labelsize": 8,
        "xtick.labelsize": 7,
        "ytick.labelsize": 7,
        "legend.fontsize": 7,
        "legend.title_fontsize": 7,
        "legend.frameon": False,
        "legend.handlelength": 2.6,
        "axes.linewidth": 0.6,
        "xtick.major.width": 0.6,
        "ytick.major.width": 0.6,
        "xtick.minor.width": 0.4,
        "ytick.minor.width": 0.4,
        "lines.linewidth": 1.0,
        "lines.markersize": 4.0,
        "errorbar.capsize": 2.0,
        "axes.spines.top": False,
        "axes.spines.right": False,
        "axes.formatter.useoffset": False,
        "axes.formatter.limits": (-4, 5),
        "axes.prop_cycle": cycler(color=list(PALETTE)),
    }


def figure_size(width: str = "single", aspect: float | None = None) -> tuple[float, float]:
    """A figure's size in inches for a journal width.

    Parameters
    ----------
    width : {"single", "double"}
        Single column (85 mm) or full page width (175 mm).
    aspect : float, optional
        Height over width; by default 0.75 for a single column and 0.45 for a full page.

    Returns
    -------
    (float, float)
        Width and height, inches.

    Raises
    ------
    UserInputError
        For another width.
    """
    name = parse_figure_width(width)
    mm = FIGURE_WIDTHS[name]
    if aspect is None:
        aspect = 0.75 if name == "single" else 0.45
    return mm * _MM, mm * _MM * aspect


def parse_figure_width(width: str) -> str:
    """Check a figure width's name.

    Parameters
    ----------
    width : str
        ``"single"`` or ``"double"``.

    Returns
    -------
    str
        The name, lower case, stripped.

    Raises
    ------
    UserInputError
        For another name (key ``figure-width``).
    """
    name = str(width).strip().lower()
    if name not in FIGURE_WIDTHS:
        raise UserInputError(f"unknown figure width {str(width)!r}; known: "
                             f"{', '.join(FIGURE_WIDTHS)}", key="figure-width")
    return name


def parse_figure_formats(formats: str | Iterable[str] | None) -> tuple[str, ...]:
    """Check the figure formats asked for (``"pdf,svg,png"`` or a sequence).

    Parameters
    ----------
    formats : str or iterable of str or None
        Comma-separated names, or names; None for :data:`DEFAULT_FORMATS`.

    Returns
    -------
    tuple of str
        The formats, each once, in the order given.

    Raises
    ------
    UserInputError
        For an unknown or empty list of formats (key ``figure-format``).
    """
    if formats is None:
        return DEFAULT_FORMATS
    items = formats.split(",") if isinstance(formats, str) else list(formats)
    names = [str(f).strip().lower().lstrip(".") for f in items]
    names = [n for n in names if n]
    for name in names:
        if name not in FIGURE_FORMATS:
            shown = str(next(f for f in items if str(f).strip().lower().lstrip(".") == name))
            raise UserInputError(f"unknown figure format {shown.strip()!r}; known: "
                                 f"{', '.join(FIGURE_FORMATS)}", key="figure-format")
    if not names:
        raise UserInputError(f"no figure format given; known: {', '.join(FIGURE_FORMATS)}",
                             key="figure-format")
    return tuple(dict.fromkeys(names))


@contextlib.contextmanager
def journal_style(width: str = "single") -> Iterator[None]:
    """Draw and save figures in the journal style while the context is open.

    Parameters
    ----------
    width : {"single", "double"}
        The width of the figures made inside (85 or 175 mm).

    Returns
    -------
    context manager
        Restores matplotlib's settings on leaving.

    Raises
    ------
    UserInputError
        For an unknown width.
    """
    name = parse_figure_width(width)
    token = _ACTIVE.set(name)
    try:
        with mpl.rc_context(cast(Any, _rc(name))):
            yield
    finally:
        _ACTIVE.reset(token)


def active_width() -> str | None:
    """The width of the journal style in force, None outside :func:`journal_style`.

    Returns
    -------
    str or None
        ``"single"``, ``"double"`` or None.
    """
    return _ACTIVE.get()


P = ParamSpec("P")
R = TypeVar("R")


def styled(func: Callable[P, R]) -> Callable[P, R]:
    """Decorate a ``plot_*`` function: with ``ax=None`` it draws in the journal style.

    When the caller gives an Axes, its own style is kept; inside a :func:`journal_style`
    already entered, that one (and its width) holds.

    Parameters
    ----------
    func : callable
        A plotting function with an ``ax`` keyword.

    Returns
    -------
    callable
        The same function, drawing in the journal style when it makes its own figure.
    """
    signature = inspect.signature(func)

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        given = signature.bind_partial(*args, **kwargs).arguments.get("ax")
        if given is not None or _ACTIVE.get() is not None:
            return func(*args, **kwargs)
        with journal_style():
            return func(*args, **kwargs)
    return wrapper


def series_style(k: int) -> dict[str, Any]:
    """Colour, marker and line style of the *k*-th series (cycling).

    Parameters
    ----------
    k : int
        The series' index.

    Returns
    -------
    dict
        ``color``, ``marker`` and ``linestyle``, as Line2D keywords.
    """
    return {"color": PALETTE[k % len(PALETTE)], "marker": MARKERS[k % len(MARKERS)],
            "linestyle": LINESTYLES[k % len(LINESTYLES)]}


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
                 inside: bool = True, **kwargs: Any) -> Legend | None:
    """A legend where it covers no data: the first free corner, else above the Axes.

    The figure is laid out first (so the Axes have their final size), then each corner is
    tried and checked with :func:`legend_overlap`.

    Parameters
    ----------
    ax : Axes
        The Axes, with everything drawn.
    handles, labels : sequence, optional
        As for :meth:`Axes.legend`; the Axes' labelled artists by default.
    ncol_outside : int
        Columns of the legend when it goes above the Axes.
    inside : bool
        Try the corners inside the Axes first (False: straight above, e.g. when a twin
        Axes draws data this check does not see).
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
    root.draw_without_rendering()  # fixes the layout and the limits
    ax.set_xlim(ax.get_xlim())
    ax.set_ylim(ax.get_ylim())
    make: Any = ax.legend  # loc as a plain str
    for loc in _CORNERS if inside else ():
        legend: Legend = make(handles, labels, loc=loc, **kwargs)
        if legend_overlap(ax, legend) == 0:
            return legend
    return _legend_above(ax, make, handles, labels, ncol_outside, **kwargs)


def _legend_above(ax: Axes, make: Any, handles: Sequence[Any], labels: Sequence[str],
                  ncol: int, **kwargs: Any) -> Legend:
    """A legend above the Axes, in as many columns (up to *ncol*) as fit its width."""
    fig = ax.get_figure()
    assert fig is not None
    room = ax.get_window_extent().width
    for n in range(min(ncol, len(handles)), 0, -1):
        legend: Legend = make(handles, labels, loc="lower center",
                              bbox_to_anchor=(0.5, 1.02), ncol=n, borderaxespad=0.0,
                              **kwargs)
        if n == 1 or legend.get_window_extent().width <= room:
            return legend
    raise AssertionError("unreachable")  # pragma: no cover


def proxy(label: str, **style: Any) -> Line2D:
    """A legend entry for a style that is drawn several times (one subject's colour).

    Parameters
    ----------
    label : str
        The entry's text.
    **style
        Line2D keywords (``color``, ``marker``, ``linestyle``).

    Returns
    -------
    Line2D
        A line not added to any Axes.
    """
    return Line2D([], [], label=label, **style)
