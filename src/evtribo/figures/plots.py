"""Figures comparing the model with the measurements (the seed paper's Figures 5-7); the
electrostatic force against the voltage, per subject and of every subject in one figure, is
:mod:`evtribo.figures.electrostatic_plots`' (re-exported here).

Every ``plot_*`` function draws on the Axes it is given, or, with ``ax=None``, on a new
figure in the journal style (:mod:`evtribo.figures.style`: a single column wide, no title,
forces in mN, plain voltage ticks at the measured amplitudes, a legend that covers no
data), and returns the Axes, like lmfit's ``plot_fit``. Figures are built with
:class:`matplotlib.figure.Figure` directly (no pyplot state), so they render with the Agg
canvas on a machine without a display; :func:`save_figure` writes them with text as text.
"""

from __future__ import annotations

import io
import logging
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import NDArray

from evtribo.figures.electrostatic_plots import (
    plot_electrostatic_force,
    plot_electrostatic_force_all,
)
from evtribo.figures.layout import place_legend, voltage_ticks
from evtribo.figures.style import (
    DEFAULT_DPI,
    DEFAULT_FORMATS,
    EVERY_COLOUR,
    PALETTE,
    amplitude_bar,
    amplitude_colours,
    new_axes,
    proxy,
    series_style,
    styled,
)
from evtribo.fit.model_points import mean_friction_force
from evtribo.model import (
    area_increase_pct,
    friction_force,
    friction_time_series,
    sine_voltage,
)
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.store.files import atomic_open
from evtribo.util.numbers import significant

log = logging.getLogger(__name__)

__all__ = ["figure_bytes", "new_axes", "plot_area_increase", "plot_electrostatic_force",
           "plot_electrostatic_force_all", "plot_friction_normal_force", "plot_friction_time",
           "safe_name", "save_figure", "trace_voltage"]

#: Text as text in SVG and PDF, whatever style the figure was drawn in; the SVG's ids
#: from a fixed salt (not a random one), so that the same figure gives the same bytes.
_TEXT_AS_TEXT: Any = {"svg.fonttype": "none", "pdf.fonttype": 42, "ps.fonttype": 42,
                      "svg.hashsalt": "evtribo"}


def safe_name(name: str) -> str:
    """*name* reduced to letters, digits, ``-`` and ``_`` (for file names).

    Parameters
    ----------
    name : str
        A subject's name, say.

    Returns
    -------
    str
        Every other character replaced by ``_`` (``"_"`` for an empty name).
    """
    return re.sub(r"[^A-Za-z0-9_-]", "_", str(name)) or "_"


def save_figure(fig: Figure, folder: str | Path, stem: str, *, dpi: float = DEFAULT_DPI,
                formats: Sequence[str] = DEFAULT_FORMATS) -> list[Path]:
    """Write *fig* as ``folder/stem.<format>`` for each format, text as text, without a
    creation date (the same data give byte-identical files).

    Parameters
    ----------
    fig : Figure
        The figure.
    folder : str or Path
        Where the files go (created if missing).
    stem : str
        The files' name without suffix.
    dpi : float
        Resolution of raster formats, dots per inch (300 by default).
    formats : sequence of str
        Suffixes matplotlib knows (``png``, ``svg``, ``pdf``...).

    Returns
    -------
    list of Path
        The files written.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    with mpl.rc_context(_TEXT_AS_TEXT):
        for fmt in formats:
            path = folder / f"{stem}.{fmt}"
            with atomic_open(path, "wb") as fh:  # a killed process leaves no half figure
                fig.savefig(fh, dpi=dpi, format=fmt, metadata=_metadata(fmt))
            paths.append(path)
    return paths


def figure_bytes(fig: Figure, formats: Sequence[str], *, dpi: float = DEFAULT_DPI
                 ) -> dict[str, bytes]:
    """*fig* in each format, as :func:`save_figure` writes it, its layout worked out once
    for all of them (then fixed: each format is drawn once).

    Parameters
    ----------
    fig : Figure
        The figure (its layout engine, if any, is run once and then removed).
    formats : sequence of str
        Suffixes matplotlib knows (``png``, ``svg``, ``pdf``).
    dpi : float
        Resolution of raster formats, and of rasterised artists in vector ones, dots per
        inch.

    Returns
    -------
    dict
        The bytes of each format; the same figure gives the same bytes.
    """
    out = {}
    # no layout engine comes back while the formats are drawn: savefig sets the figure's
    # engine to none and back, and "back" from None is a new engine when the style asks
    # for constrained layout (matplotlib 3.11), which lays the figure out again
    with mpl.rc_context({**_TEXT_AS_TEXT, "figure.autolayout": False,
                         "figure.constrained_layout.use": False}):
        shown_dpi = fig.dpi
        # laid out at the resolution of the raster formats: their drawing then measures
        # no text again (matplotlib keeps text sizes per renderer, one per size and dpi)
        fig.set_dpi(dpi)
        try:
            engine = fig.get_layout_engine()
            if engine is not None:
                engine.execute(fig)  # the layout, once (the artists are drawn by each format)
                fig.set_layout_engine(None)
            for fmt in formats:
                buf = io.BytesIO()
                fig.savefig(buf, dpi=dpi, format=fmt, metadata=_metadata(fmt))
                out[fmt] = buf.getvalue()
        finally:
            fig.set_dpi(shown_dpi)
    return out


def _metadata(fmt: str) -> dict[str, str | None]:
    # no creation date: the same data give byte-identical files
    if fmt == "svg":
        return {"Date": None}
    if fmt == "pdf":
        return {"CreationDate": None}
    return {}


#: More ON drives than this in one friction-versus-load figure: a colour bar for the
#: amplitude instead of one legend entry per drive.
_MAX_ON_ENTRIES = 6
#: The model's line style per waveform (its colour is the drive's).
_WAVE_LINES = {"square": "-", "sine": "--"}


def _span(fn: NDArray[np.float64], n: int = 40) -> NDArray[np.float64]:
    """The normal forces a model line is drawn over: those measured, N (empty without)."""
    fn = fn[np.isfinite(fn)]
    if fn.size == 0:
        return np.empty(0)
    return np.linspace(float(fn.min()), float(fn.max()), n)


def _on_series(ax: Axes, on: pd.DataFrame, params: ModelParameters
               ) -> tuple[list[Line2D], list[Line2D]]:
    """Draw each ON drive's windows and its model line over their normal forces; return
    the legend entries of the points (one per drive, or per waveform with a colour bar) and
    of the model's lines (one per waveform)."""
    pairs = on[["waveform", "amplitude_V"]].drop_duplicates().itertuples(index=False)
    keys = sorted(((str(p[0]), float(p[1])) for p in pairs),
                  key=lambda wa: (wa[0] != "square", wa[0], wa[1]))
    amps = np.array([a for _, a in keys])
    many = len(keys) > _MAX_ON_ENTRIES
    colour = amplitude_colours(amps)
    points: list[Line2D] = []
    waves: dict[str, dict[str, Any]] = {}
    for k, (wave, amp) in enumerate(keys):
        sel = on[(on["waveform"].astype(str) == wave) & (on["amplitude_V"] == amp)]
        look = {"color": colour(amp), "marker": "o" if many else series_style(k + 1)["marker"],
                "markerfacecolor": "white" if wave == "sine" else colour(amp)}
        ax.plot(1e3 * sel["normal_force_N"], 1e3 * sel["friction_force_N"], linestyle="none",
                markersize=3, **look)
        span = _span(sel["normal_force_N"].to_numpy(float))
        line = _WAVE_LINES.get(wave, ":")
        ax.plot(1e3 * span, 1e3 * mean_friction_force(span, amp, wave, params),
                linestyle=line, color=look["color"])
        if not many:
            points.append(proxy(f"ON {amp:g} V" + (f" {wave}" if wave != "square" else ""),
                                linestyle="none", **look))
        waves.setdefault(wave, {**look, "color": EVERY_COLOUR,
                                "markerfacecolor": "white" if wave == "sine" else EVERY_COLOUR})
    if many:
        points += [proxy(f"ON, {wave}", linestyle="none", **look)
                   for wave, look in waves.items()]
        amplitude_bar(ax, amps)
        voltage_ticks(ax.figure.axes[-1].yaxis, amps)
    lines = [proxy("model, ON" + (f" {wave}" if len(waves) > 1 else ""),
                   color=EVERY_COLOUR, linestyle=_WAVE_LINES.get(wave, ":"))
             for wave in waves]
    return points, lines


def _zoom(ax: Axes, fn: NDArray[np.float64]) -> None:
    """Limits around what is drawn (8 % margins): the measured windows and the model's lines
    over their normal forces, the axes not forced to 0."""
    ys = [np.asarray(line.get_ydata(), float) for line in ax.lines]
    for values, setter in ((1e3 * fn, ax.set_xlim),
                           (np.concatenate(ys) if ys else np.empty(0), ax.set_ylim)):
        v = values[np.isfinite(values)]
        if v.size == 0:
            continue
        lo, hi = float(v.min()), float(v.max())
        pad = 0.08 * (hi - lo) if hi > lo else 0.1 * max(abs(hi), 1.0)
        setter(lo - pad, hi + pad)


@styled
def plot_friction_normal_force(windows: pd.DataFrame, params: ModelParameters = TABLE_1, *,
                               subject: str | None = None, ax: Axes | None = None) -> Axes:
    """Friction versus normal force, OFF and ON: measured windows and the model (Figure 6).

    Points are the steady-sliding windows, lines the model (eq. 5) over the normal forces
    each drive's windows span (nowhere else: the axes are zoomed to the windows); OFF in
    black, each ON drive (waveform and amplitude) in the colour of its amplitude
    (:func:`~evtribo.figures.style.amplitude_colours`, dark enough on white, ordered in
    greyscale) with its own marker; open markers for a sine drive. The legend gives the
    points (one entry per drive) apart from the model's lines (solid for a square drive,
    dashed for a sine, in each drive's colour). With more than six ON drives a colour bar
    gives the amplitude and the legend only the waveforms.

    Parameters
    ----------
    windows : DataFrame
        Rows of ``windows.csv`` (one subject's, or several).
    params : ModelParameters
        Model parameters (``mu`` from the measured OFF windows unless fitted).
    subject : str, optional
        The subject (the caption names it; no title is drawn).
    ax : Axes, optional
        Where to draw; a new figure in the journal style when None.

    Returns
    -------
    Axes
        Forces in mN.
    """
    ax = new_axes() if ax is None else ax
    cond = windows["condition"].astype(str).str.lower()
    off = windows[cond == "off"]
    ax.plot(1e3 * off["normal_force_N"], 1e3 * off["friction_force_N"], "o", color="k",
            markerfacecolor="white", markersize=3)
    span = _span(off["normal_force_N"].to_numpy(float))
    ax.plot(1e3 * span, 1e3 * mean_friction_force(span, 0.0, "square", params), "-",
            color="k")
    points = [proxy(f"OFF ($\\mu$ = {significant(params.mu)})", color="k", marker="o",
                    linestyle="none", markerfacecolor="white")]
    on_points, lines = _on_series(ax, windows[cond == "on"], params)
    lines.insert(0, proxy("model, OFF", color="k", linestyle="-"))
    handles = points + on_points + lines
    ax.set_xlabel("normal force $F_n$ (mN)")
    ax.set_ylabel("friction force $F_t$ (mN)")
    _zoom(ax, windows["normal_force_N"].to_numpy(float))
    place_legend(ax, handles, [str(h.get_label()) for h in handles], ncol_outside=3)
    return ax


def trace_voltage(trace: pd.DataFrame, params: ModelParameters = TABLE_1,
                  n_phases: int = 90) -> NDArray[np.float64]:
    """Instantaneous voltage U(t) of a sine trace, V.

    ``voltage_V`` when the trace has it; otherwise A(t) sin(2 pi f t + phi) from
    ``amplitude_V`` and ``frequency_Hz``, with the phase phi in [0, pi) that best matches the
    measured friction (the model's friction depends on U^2, so phi + pi gives the same).

    Parameters
    ----------
    trace : DataFrame
        Rows of ``sine_trace.csv`` (one trial).
    params : ModelParameters
        Model parameters for matching the phase.
    n_phases : int
        Phases tried.

    Returns
    -------
    ndarray
        U(t) at the trace's rows, V.
    """
    if "voltage_V" in trace.columns:
        return trace["voltage_V"].to_numpy(float)
    t = trace["time_s"].to_numpy(float)
    amp = np.nan_to_num(trace["amplitude_V"].to_numpy(float))
    freq = np.nan_to_num(trace["frequency_Hz"].to_numpy(float))
    fn = trace["normal_force_N"].to_numpy(float)
    ft = trace["friction_force_N"].to_numpy(float)
    phases = np.linspace(0.0, np.pi, n_phases, endpoint=False)
    u = amp[None, :] * np.sin(2 * np.pi * freq[None, :] * t[None, :] + phases[:, None])
    model = np.asarray(friction_force(fn[None, :], u, params), dtype=float)
    err = np.nansum((model - ft[None, :]) ** 2, axis=1)
    return u[int(np.argmin(err))]


@styled
def plot_friction_time(trace: pd.DataFrame | None, params: ModelParameters = TABLE_1, *,
                       amplitude: float = 140.0, frequency: float = 10.0,
                       normal_force: float = 0.5, subject: str | None = None,
                       ax: Axes | None = None) -> Axes:
    """Friction versus time during a sine drive, measured and model (Figure 5).

    With a measured trace (``sine_trace.csv``), the model is evaluated at its normal force
    and voltage sample by sample. Without one the model alone is drawn for the paper's
    conditions (*amplitude*, *frequency*, constant *normal_force*), ON and OFF, and the
    Axes says so.

    Parameters
    ----------
    trace : DataFrame or None
        Columns ``time_s``, ``normal_force_N``, ``friction_force_N``, ``voltage_V``.
    params : ModelParameters
        Model parameters.
    amplitude, frequency : float
        Drive for the model-only figure, V and Hz.
    normal_force : float
        Normal force for the model-only figure, N.
    subject : str, optional
        The subject (the caption names it; no title is drawn).
    ax : Axes, optional
        Where to draw; a new figure in the journal style when None.

    Returns
    -------
    Axes
        Forces in mN.
    """
    ax = new_axes() if ax is None else ax
    if trace is not None and len(trace):
        t = trace["time_s"].to_numpy(float)
        fn = trace["normal_force_N"].to_numpy(float)
        u = trace_voltage(trace, params)
        fitted_phase = "voltage_V" not in trace.columns
        # the model underneath, wide and pale, so that the measured trace stays visible
        model = ax.plot(t, 1e3 * friction_time_series(t, fn, u, params), "-",
                        color=PALETTE[1], lw=3.0, alpha=0.45, solid_capstyle="butt",
                        label="friction, model (drive phase fitted)" if fitted_phase
                        else "friction, model")
        off = ax.plot(t, 1e3 * friction_time_series(t, fn, np.zeros_like(t), params), "--",
                      color=PALETTE[0], label="friction, model OFF")
        normal = ax.plot(t, 1e3 * fn, "-", color=PALETTE[2], lw=0.7,
                         label="normal force $F_n$, measured")
        measured = ax.plot(t, 1e3 * trace["friction_force_N"].to_numpy(float), "-", color="k",
                           lw=0.7, label="friction $F_t$, measured")
        handles = [*measured, *normal, *model, *off]  # the measurements, then the model's
    else:
        t = np.linspace(0.0, 3.0 / frequency, 600)
        fn = np.full_like(t, normal_force)
        handles = [
            *ax.plot(t, 1e3 * friction_time_series(t, fn, sine_voltage(t, amplitude, frequency),
                                                   params),
                     "-", color=PALETTE[1], label=f"model ON ({amplitude:g} V, {frequency:g} Hz)"),
            *ax.plot(t, 1e3 * friction_time_series(t, fn, np.zeros_like(t), params), "--",
                     color=PALETTE[0], label="model OFF"),
            *ax.plot(t, 1e3 * fn, "-", color=PALETTE[2], lw=0.7, label="normal force (given)")]
    ax.set_xlabel("time $t$ (s)")
    ax.set_ylabel("force (mN)")
    ax.set_xlim(float(np.nanmin(t)), float(np.nanmax(t)))
    ax.set_ylim(bottom=0)
    _zero_tick(ax.yaxis)
    place_legend(ax, handles, [str(h.get_label()) for h in handles])
    return ax


def _zero_tick(axis: Any) -> None:
    """A labelled tick at 0 on a linear axis that starts there (the locator's own ticks
    otherwise, which may leave 0 out)."""
    from matplotlib.ticker import MaxNLocator

    axis.set_major_locator(MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10], min_n_ticks=3))


@styled
def plot_area_increase(normal_forces: Mapping[str, float],
                       params: Mapping[str, ModelParameters], *, u_max: float = 150.0,
                       amplitudes: Sequence[float] | None = None,
                       ax: Axes | None = None) -> Axes:
    """Predicted increase of the contact area versus voltage amplitude (Figure 7).

    Parameters
    ----------
    normal_forces : mapping
        ``{label: normal force in N}``, e.g. each subject's mean normal force ON; one
        colour and line style per label, in this order (the legend gives each label's
        force).
    params : mapping
        ``{label: ModelParameters}`` with the same keys.
    u_max : float
        Largest voltage amplitude drawn, V.
    amplitudes : sequence of float, optional
        The measured amplitudes, V: the voltage axis gets a tick at each (and at 0).
    ax : Axes, optional
        Where to draw; a new figure in the journal style when None.

    Returns
    -------
    Axes
    """
    ax = new_axes() if ax is None else ax
    u = np.linspace(0.0, u_max, 120)
    for k, (label, fn) in enumerate(normal_forces.items()):
        style = series_style(k)
        ax.plot(u, area_increase_pct(fn, u, params[label]), color=style["color"],
                linestyle=style["linestyle"], label=f"{label} ({1e3 * fn:.0f} mN)")
    ax.set_xlabel("voltage amplitude $U$ (V)")
    ax.set_ylabel("contact area increase, model (%)")
    ax.set_xlim(0, u_max)
    ax.set_ylim(bottom=0)
    if amplitudes is not None and len(amplitudes):
        voltage_ticks(ax.xaxis, _from_zero(amplitudes))
    place_legend(ax, ncol_outside=4, title="at the normal force $F_n$ ON")
    return ax


def _from_zero(amplitudes: Sequence[float]) -> list[float]:
    """The measured amplitudes and, below the lowest, ticks down to 0 at their own step
    (60, 80... 140 V get 0, 20, 40 too: no gap without a label on a linear axis)."""
    amps = np.unique(np.asarray(amplitudes, float))
    amps = amps[np.isfinite(amps) & (amps > 0)]
    if amps.size == 0:
        return [0.0]
    steps = np.diff(amps)
    step = float(np.min(steps)) if steps.size else float(amps[0])
    below = np.arange(0.0, float(amps[0]) - 0.5 * step, step)
    return [*below.tolist(), *amps.tolist()]
