"""The journal style of evtribo's figures: sizes, fonts, colours, markers, line styles.

A figure drawn inside :func:`journal_style` is the width of a journal's single column
(85 mm) or of a full page (175 mm), has no title (a caption carries it), 7-8 pt text,
and is saved with text as text (SVG ``svg.fonttype = 'none'``, PDF Type 42 fonts) and PNG
at 300 dpi. Nothing is changed globally: the style is a :func:`matplotlib.rc_context`
entered and left by the caller (the ``plot_*`` functions enter it when they make their own
figure).

Colours are the Okabe-Ito palette (safe for the common colour-vision deficiencies); each
series also has its own marker and line style (:func:`series_style`), so that a greyscale
print still tells them apart. Ticks and legends are :mod:`evtribo.figures.layout`'s.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import inspect
import math
import weakref
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any, ParamSpec, TypeVar, cast

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import NDArray

from evtribo.errors import UserInputError

__all__ = [
    "AMPLITUDE_MAP",
    "DEFAULT_DPI",
    "DEFAULT_FORMATS",
    "EVERY_COLOUR",
    "FIGURE_FORMATS",
    "FIGURE_WIDTHS",
    "LINESTYLES",
    "MARKERS",
    "MAX_DRIVE_ENTRIES",
    "MIN_TEXT_PT",
    "PALETTE",
    "active_width",
    "amplitude_bar",
    "amplitude_colours",
    "figure_size",
    "journal_style",
    "new_axes",
    "owns",
    "parse_dpi",
    "parse_figure_formats",
    "parse_figure_width",
    "proxy",
    "series_style",
    "styled",
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
#: The smallest text of a figure, pt: a subscript of the legend's (mathtext shrinks one to
#: 70 %: a 7-pt legend's F_n had a 4.9-pt n).
MIN_TEXT_PT = 5.25
_SUBSCRIPT = 0.7
#: Okabe & Ito (2008), without yellow (too pale on white) until the eighth series.
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000",
           "#F0E442")
#: A legend entry drawn in this grey stands for its line style in every colour drawn (a
#: model's line style, drawn in each drive's colour).
EVERY_COLOUR = "#595959"
#: More drives than this in one figure: their colours from the amplitude (a colour bar)
#: instead of one legend entry per drive.
MAX_DRIVE_ENTRIES = 6
#: One marker per series (filled shapes that differ in outline).
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<")
#: One line style per series.
LINESTYLES: tuple[Any, ...] = ("-", "--", "-.", ":", (0, (5, 1, 1, 1, 1, 1)), (0, (6, 3)),
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
        "legend.fontsize": MIN_TEXT_PT / _SUBSCRIPT,
        "legend.title_fontsize": MIN_TEXT_PT / _SUBSCRIPT,
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


def parse_dpi(dpi: float | None) -> float:
    """Check the resolution asked for PNG figures.

    Parameters
    ----------
    dpi : float or None
        Dots per inch; None for :data:`DEFAULT_DPI`.

    Returns
    -------
    float
        The resolution.

    Raises
    ------
    UserInputError
        Unless a finite number from 10 to 2400 (key ``dpi``).
    """
    if dpi is None:
        return DEFAULT_DPI
    try:
        value = float(dpi)
    except (TypeError, ValueError):
        value = math.nan
    if not 10.0 <= value <= 2400.0:  # also NaN
        raise UserInputError(f"expected a resolution from 10 to 2400 dots per inch, got "
                             f"{dpi!r}", key="dpi")
    return value


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
        ``color``, ``marker`` and ``linestyle``, as Line2D keywords; no two of the first
        64 series have the same colour and marker.
    """
    n = len(PALETTE)
    return {"color": PALETTE[k % n], "marker": MARKERS[(k + k // n) % len(MARKERS)],
            "linestyle": LINESTYLES[(k + k // n) % len(LINESTYLES)]}


def new_axes(figsize: tuple[float, float] | None = None) -> Axes:
    """A fresh Axes on its own Agg-backed figure (no pyplot state).

    Parameters
    ----------
    figsize : (float, float), optional
        The figure's size, inches; by default ``figure.figsize`` of the style in force (a
        single journal column inside :func:`journal_style`).

    Returns
    -------
    Axes
        The figure's one Axes.
    """
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    _OWN.add(fig)
    return fig.add_subplot()


#: Figures :func:`new_axes` made: a legend above their Axes may make them taller.
_OWN: weakref.WeakSet[Figure] = weakref.WeakSet()


def owns(figure: Any) -> bool:
    """Whether *figure* is one :func:`new_axes` made (not a caller's).

    Parameters
    ----------
    figure : Figure

    Returns
    -------
    bool
    """
    return figure in _OWN


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


#: The part of the viridis map the amplitudes are drawn in: its darker 60 %, from purple to
#: teal, each colour at least 3:1 against white (its palest tenth, lime, was 1.5:1), its
#: grey level rising with the amplitude.
AMPLITUDE_MAP = (0.0, 0.6)


def _amplitude_map() -> Any:
    from matplotlib import colormaps
    from matplotlib.colors import ListedColormap

    return ListedColormap(colormaps["viridis"](np.linspace(*AMPLITUDE_MAP, 256)))


def _amplitude_norm(amplitudes: Sequence[float] | NDArray[np.float64]) -> Any:
    from matplotlib.colors import Normalize

    amps = np.asarray(amplitudes, float)
    amps = amps[np.isfinite(amps)]
    return Normalize(float(amps.min()), float(amps.max())) if amps.size else Normalize()


def amplitude_colours(amplitudes: Sequence[float] | NDArray[np.float64]
                      ) -> Callable[[float], Any]:
    """The colour of each voltage amplitude of a figure: the lowest darkest, the highest
    lightest, on :data:`AMPLITUDE_MAP` of viridis.

    Parameters
    ----------
    amplitudes : sequence of float
        The amplitudes drawn, V.

    Returns
    -------
    callable
        ``colour(amplitude)``: an RGBA tuple (the middle of the map for a single amplitude).
    """
    cmap, norm = _amplitude_map(), _amplitude_norm(amplitudes)
    amps = np.asarray(amplitudes, float)
    flat = amps.size == 0 or float(np.ptp(amps[np.isfinite(amps)] if amps.size else amps)) == 0
    return lambda amp: cmap(0.5 if flat else norm(amp))


def amplitude_bar(ax: Axes, amplitudes: Sequence[float] | NDArray[np.float64]
                  ) -> Callable[[float], Any]:
    """A colour bar of the voltage amplitude beside *ax*; the colour of each amplitude.

    The colours of :func:`amplitude_colours`, a tick at each amplitude
    (:func:`~evtribo.figures.layout.voltage_ticks` is the caller's).

    Parameters
    ----------
    ax : Axes
    amplitudes : sequence of float
        The amplitudes drawn, V.

    Returns
    -------
    callable
        ``colour(amplitude)``: an RGBA tuple.
    """
    from matplotlib.cm import ScalarMappable

    fig = ax.figure.figure
    bar = fig.colorbar(ScalarMappable(_amplitude_norm(amplitudes), _amplitude_map()), ax=ax,
                       pad=0.02, aspect=30)
    bar.set_label("voltage amplitude $U$ (V)")
    return amplitude_colours(amplitudes)
