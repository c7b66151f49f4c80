"""Figures comparing the model with the measurements (the seed paper's Figures 5-7) and the
electrostatic force of every subject in one figure.

Every ``plot_*`` function draws on the Axes it is given, or, with ``ax=None``, on a new
figure in the journal style (:mod:`evtribo.compare.style`: a single column wide, no title,
forces in mN, plain voltage ticks at the measured amplitudes, a legend that covers no
data), and returns the Axes, like lmfit's ``plot_fit``. Figures are built with
:class:`matplotlib.figure.Figure` directly (no pyplot state), so they render with the Agg
canvas on a machine without a display; :func:`save_figure` writes them with text as text.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from evtribo.compare.model_points import mean_electrostatic_force, mean_friction_force
from evtribo.compare.style import (
    DEFAULT_DPI,
    DEFAULT_FORMATS,
    PALETTE,
    place_legend,
    plain_log_axis,
    proxy,
    series_style,
    styled,
    voltage_ticks,
)
from evtribo.files import atomic_open
from evtribo.model import (
    area_increase_pct,
    friction_force,
    friction_time_series,
    sine_voltage,
)
from evtribo.model.params import TABLE_1, ModelParameters

log = logging.getLogger(__name__)

__all__ = ["new_axes", "plot_area_increase", "plot_electrostatic_force",
           "plot_electrostatic_force_all", "plot_friction_normal_force", "plot_friction_time",
           "safe_name", "save_figure", "trace_voltage"]

_WAVE_MARKERS = {"square": "o", "sine": "s"}
#: Text as text in SVG and PDF, whatever style the figure was drawn in.
_TEXT_AS_TEXT: Any = {"svg.fonttype": "none", "pdf.fonttype": 42, "ps.fonttype": 42}


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


def new_axes(figsize: tuple[float, float] | None = None) -> Axes:
    """A fresh Axes on its own Agg-backed figure (no pyplot state).

    Parameters
    ----------
    figsize : (float, float), optional
        The figure's size, inches; by default ``figure.figsize`` of the style in force (a
        single journal column inside :func:`~evtribo.compare.style.journal_style`).

    Returns
    -------
    Axes
        The figure's one Axes.
    """
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig.add_subplot()


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


def _metadata(fmt: str) -> dict[str, str | None]:
    # no creation date: the same data give byte-identical files
    if fmt == "svg":
        return {"Date": None}
    if fmt == "pdf":
        return {"CreationDate": None}
    return {}


def _nonpositive_note(ax: Axes, n: int) -> None:
    """Say on the Axes how many points a log axis cannot show."""
    if n:
        ax.text(0.98, 0.02, f"{n} point{'s' if n > 1 else ''} ≤ 0 not shown (log axis)",
                transform=ax.transAxes, ha="right", va="bottom", fontsize="x-small",
                color="0.3")


def _by_waveform(rows: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """*rows* grouped by waveform: square first, then the others by name."""
    groups = rows.groupby(rows["waveform"].astype(str), sort=True)
    return sorted(((str(w), g) for w, g in groups), key=lambda wg: (wg[0] != "square", wg[0]))


def _errors_mN(sel: pd.DataFrame) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The forces of *sel* and their 95 % error bars (2 x n), mN."""
    f = 1e3 * sel["electrostatic_force_N"].to_numpy(float)
    lo = np.clip(f - 1e3 * sel["electrostatic_force_ci_low_N"].to_numpy(float), 0, None)
    hi = np.clip(1e3 * sel["electrostatic_force_ci_high_N"].to_numpy(float) - f, 0, None)
    return f, np.vstack([lo, hi])


def _force_axes(ax: Axes, amplitudes: NDArray[np.float64]) -> None:
    """Log-log F_el (mN) against U (V), ticks at the amplitudes and plain numbers."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    voltage_ticks(ax.xaxis, amplitudes)
    plain_log_axis(ax.yaxis)
    ax.set_xlabel("voltage amplitude $U$ (V)")
    ax.set_ylabel("electrostatic force $F_\\mathrm{el}$ (mN)")


@styled
def plot_electrostatic_force(rows: pd.DataFrame, params: ModelParameters = TABLE_1, *,
                             subject: str | None = None, ax: Axes | None = None) -> Axes:
    """Electrostatic force versus voltage amplitude, log-log: measured, model, U^2 guide.

    Parameters
    ----------
    rows : DataFrame
        One subject's rows of ``electrostatic.csv``.
    params : ModelParameters
        The subject's fitted parameters.
    subject : str, optional
        The subject (the caption names it; no title is drawn).
    ax : Axes, optional
        Where to draw; a new figure in the journal style when None.

    Returns
    -------
    Axes
        Forces in mN, a tick at each measured amplitude.
    """
    ax = new_axes() if ax is None else ax
    amps_all = rows["amplitude_V"].to_numpy(float)
    grid = np.geomspace(np.nanmin(amps_all) / 1.15, np.nanmax(amps_all) * 1.15, 80)
    hidden, handles, guide = 0, [], False
    for k, (wave, sel) in enumerate(_by_waveform(rows)):
        style = {**series_style(k), "marker": _WAVE_MARKERS.get(wave, series_style(k)["marker"])}
        amp = sel["amplitude_V"].to_numpy(float)
        f, err = _errors_mN(sel)
        hidden += int(np.sum(~(f > 0)))
        ax.errorbar(amp, f, yerr=err, fmt=style["marker"], color=style["color"])
        fn = float(np.nanmean(sel["normal_force_on_N"].to_numpy(float)))
        ax.plot(grid, 1e3 * mean_electrostatic_force(fn, grid, wave, params),
                linestyle=style["linestyle"], color=style["color"])
        handles.append(proxy(f"{wave} ($F_n$ = {1e3 * fn:.0f} mN)", **style))
        pos = f > 0
        if pos.any():  # U^2 through the points' geometric centre
            centre_u = np.exp(np.mean(np.log(amp[pos])))
            centre_f = np.exp(np.mean(np.log(f[pos])))
            ax.plot(grid, centre_f * (grid / centre_u) ** 2, ":", color="0.5", lw=0.8)
            guide = True
    if guide:
        handles.append(proxy("$\\propto U^2$ guide", color="0.5", linestyle=":", lw=0.8))
    _force_axes(ax, amps_all)
    _nonpositive_note(ax, hidden)
    place_legend(ax, handles, [str(h.get_label()) for h in handles])
    return ax


@styled
def plot_electrostatic_force_all(electrostatic: pd.DataFrame,
                                 params: Mapping[str, ModelParameters], *,
                                 ax: Axes | None = None) -> Axes:
    """Every subject's electrostatic force versus voltage amplitude, with its fitted model.

    One colour, marker and line style per subject (in the order of *params*); filled
    markers for a square drive, open ones for a sine drive. Points are spread by 1.5 % in U
    between subjects (by at most ±3 % in all) around their amplitude so that the intervals
    of different subjects do not hide one another.

    Parameters
    ----------
    electrostatic : DataFrame
        ``electrostatic.csv`` (all subjects).
    params : mapping
        ``{subject: fitted ModelParameters}``; subjects without an entry are not drawn.
    ax : Axes, optional
        Where to draw; a new figure in the journal style when None.

    Returns
    -------
    Axes
        Log-log, forces in mN, a tick at each measured amplitude.
    """
    ax = new_axes() if ax is None else ax
    subjects = [s for s in params if (electrostatic["subject"].astype(str) == s).any()]
    amps_all = electrostatic["amplitude_V"].to_numpy(float)
    grid = np.geomspace(np.nanmin(amps_all) / 1.15, np.nanmax(amps_all) * 1.15, 80)
    n = len(subjects)
    handles, hidden, waves = [], 0, set()
    for k, s in enumerate(subjects):
        style = series_style(k)
        rows = electrostatic[electrostatic["subject"].astype(str) == s]
        # 1.5 % in U between neighbours, all within +-3 %
        shift = np.exp(min(0.015, 0.06 / (n - 1)) * (k - (n - 1) / 2)) if n > 1 else 1.0
        for wave, sel in _by_waveform(rows):
            waves.add(wave)
            f, err = _errors_mN(sel)
            hidden += int(np.sum(~(f > 0)))
            ax.errorbar(sel["amplitude_V"].to_numpy(float) * shift, f, yerr=err,
                        fmt=style["marker"], color=style["color"], elinewidth=0.7,
                        markerfacecolor="white" if wave == "sine" else style["color"])
            fn = float(np.nanmean(sel["normal_force_on_N"].to_numpy(float)))
            ax.plot(grid, 1e3 * mean_electrostatic_force(fn, grid, wave, params[s]),
                    color=style["color"], linestyle=style["linestyle"],
                    alpha=0.6 if wave == "sine" else 1.0)
        handles.append(proxy(s, **style))
    if len(waves) > 1:
        handles += [proxy("square drive", color="0.3", marker="o", linestyle="none"),
                    proxy("sine drive", color="0.3", marker="o", linestyle="none",
                          markerfacecolor="white")]
    _force_axes(ax, amps_all)
    _nonpositive_note(ax, hidden)
    place_legend(ax, handles, [str(h.get_label()) for h in handles], ncol_outside=4)
    return ax


@styled
def plot_friction_normal_force(windows: pd.DataFrame, params: ModelParameters = TABLE_1, *,
                               subject: str | None = None, ax: Axes | None = None) -> Axes:
    """Friction versus normal force, OFF and ON: measured windows and the model (Figure 6).

    Points are the steady-sliding windows, lines the model (eq. 5); OFF in black, each ON
    drive (waveform and amplitude) in the colour of its amplitude on the viridis map
    (readable in greyscale) with its own marker and line style; open markers for a sine
    drive.

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
    fn = windows["normal_force_N"].to_numpy(float)
    top = float(np.nanmax(fn)) * 1.15 if fn.size and np.isfinite(fn).any() else 1.0
    grid = np.linspace(0.02 * top, top, 60)
    cond = windows["condition"].astype(str).str.lower()
    off = windows[cond == "off"]
    ax.plot(1e3 * off["normal_force_N"], 1e3 * off["friction_force_N"], "o", color="k",
            markerfacecolor="white", markersize=3, alpha=0.8)
    ax.plot(1e3 * grid, 1e3 * mean_friction_force(grid, 0.0, "square", params), "-",
            color="k")
    handles = [proxy(f"OFF (μ = {params.mu:.3g})", color="k", marker="o", linestyle="-",
                     markerfacecolor="white")]
    on = windows[cond == "on"]
    pairs = on[["waveform", "amplitude_V"]].drop_duplicates().itertuples(index=False)
    keys = sorted(((str(p[0]), float(p[1])) for p in pairs),
                  key=lambda wa: (wa[0] != "square", wa[0], wa[1]))
    amps = np.array([a for _, a in keys])
    span = float(np.ptp(amps)) if amps.size else 0.0
    for k, (wave, amp) in enumerate(keys):
        sel = on[(on["waveform"].astype(str) == wave) & (on["amplitude_V"] == amp)]
        shade = 0.85 * (amp - float(amps.min())) / span if span > 0 else 0.4
        style = {**series_style(k + 1), "color": colormaps["viridis"](shade),
                 "markerfacecolor": "white" if wave == "sine" else None}
        ax.plot(1e3 * sel["normal_force_N"], 1e3 * sel["friction_force_N"], linestyle="none",
                markersize=3, alpha=0.8,
                **{key: v for key, v in style.items() if key != "linestyle"})
        ax.plot(1e3 * grid, 1e3 * mean_friction_force(grid, amp, wave, params),
                linestyle=style["linestyle"], color=style["color"])
        handles.append(proxy(f"ON {amp:g} V" + (f" {wave}" if wave != "square" else ""),
                             **style))
    ax.set_xlabel("normal force $F_n$ (mN)")
    ax.set_ylabel("friction force $F_t$ (mN)")
    ax.set_xlim(0, 1e3 * top)
    ax.set_ylim(bottom=0)
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
        ax.plot(t, 1e3 * fn, "-.", color=PALETTE[2], label="normal force, measured")
        # the model underneath, wide and pale, so that the measured trace stays visible
        ax.plot(t, 1e3 * friction_time_series(t, fn, u, params), "-", color=PALETTE[1],
                lw=3.0, alpha=0.45, solid_capstyle="butt",
                label="friction, model (drive phase fitted)" if fitted_phase
                else "friction, model")
        ax.plot(t, 1e3 * friction_time_series(t, fn, np.zeros_like(t), params), "--",
                color=PALETTE[0], label="friction, model OFF")
        ax.plot(t, 1e3 * trace["friction_force_N"].to_numpy(float), "-", color="k", lw=0.7,
                label="friction, measured")
    else:
        t = np.linspace(0.0, 3.0 / frequency, 600)
        fn = np.full_like(t, normal_force)
        ax.plot(t, 1e3 * fn, "-.", color=PALETTE[2], label="normal force")
        ax.plot(t, 1e3 * friction_time_series(t, fn, sine_voltage(t, amplitude, frequency),
                                              params),
                "-", color=PALETTE[1], label=f"model ON ({amplitude:g} V, {frequency:g} Hz)")
        ax.plot(t, 1e3 * friction_time_series(t, fn, np.zeros_like(t), params), "--",
                color=PALETTE[0], label="model OFF")
        ax.text(0.02, 0.5, "model only: no measured sine trace\n(sine_trace.csv absent)",
                transform=ax.transAxes, fontsize="small", color=PALETTE[1], va="center")
    ax.set_xlabel("time $t$ (s)")
    ax.set_ylabel("force (mN)")
    ax.set_xlim(float(np.nanmin(t)), float(np.nanmax(t)))
    ax.set_ylim(bottom=0)
    place_legend(ax)
    return ax


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
        colour and line style per label, in this order.
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
                linestyle=style["linestyle"], label=f"{label} ($F_n$ = {1e3 * fn:.0f} mN)")
    ax.set_xlabel("voltage amplitude $U$ (V)")
    ax.set_ylabel("contact area increase (%)")
    ax.set_xlim(0, u_max)
    ax.set_ylim(bottom=0)
    if amplitudes is not None and len(amplitudes):
        voltage_ticks(ax.xaxis, [0.0, *amplitudes])
    place_legend(ax)
    return ax
