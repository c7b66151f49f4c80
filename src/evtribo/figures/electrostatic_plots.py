"""The electrostatic force against the voltage amplitude: one subject's (measured and model)
and every subject's in one figure (``electrostatic_force_all``).

Both are log-log with forces in mN, a tick at each measured amplitude and plain numbers
(:mod:`evtribo.figures.layout`); a model line runs over its waveform's measured amplitudes
(and 15 % beyond each end on the log axis), never from one point over amplitudes not
measured; with ``ax=None`` they draw on a new figure in the journal style
(:mod:`evtribo.figures.style`) and return the Axes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.legend_handler import HandlerTuple
from numpy.typing import NDArray

from evtribo.figures.layout import place_legend, plain_log_axis, voltage_ticks
from evtribo.figures.style import new_axes, proxy, series_style, styled
from evtribo.fit.model_points import mean_electrostatic_force
from evtribo.model.params import TABLE_1, ModelParameters

__all__ = ["plot_electrostatic_force", "plot_electrostatic_force_all"]

_WAVE_MARKERS = {"square": "o", "sine": "s"}


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


def _model_curves_mN(sel: pd.DataFrame, grid: NDArray[np.float64], wave: str,
                     params: ModelParameters) -> list[NDArray[np.float64]]:
    """The model's F_el over the voltage *grid* at the points' mean normal force ON, mN: one
    curve, or one per drive frequency of the points when a layer leaks (finite ``r_sc`` or
    ``r_g``, so that the force depends on the frequency; spec §9)."""
    fn = float(np.nanmean(sel["normal_force_on_N"].to_numpy(float)))
    leaks = math.isfinite(params.r_sc) or math.isfinite(params.r_g)
    freqs = (np.unique(sel["frequency_Hz"].to_numpy(float)) if "frequency_Hz" in sel
             else np.empty(0))
    freqs = freqs[np.isfinite(freqs) & (freqs > 0)]
    if not leaks or freqs.size == 0:
        return [1e3 * mean_electrostatic_force(fn, grid, wave, params)]
    return [1e3 * mean_electrostatic_force(fn, grid, wave, params, frequency=f)
            for f in freqs]


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


def _grid(amplitudes: NDArray[np.float64], n: int = 80) -> NDArray[np.float64]:
    """The voltages a model line is drawn at: the measured amplitudes' span, 15 % beyond
    each end (a single amplitude: that 15 % about it), V."""
    amps = amplitudes[np.isfinite(amplitudes) & (amplitudes > 0)]
    if amps.size == 0:
        return np.empty(0)
    return np.geomspace(float(amps.min()) / 1.15, float(amps.max()) * 1.15, n)


@styled
def plot_electrostatic_force(rows: pd.DataFrame, params: ModelParameters = TABLE_1, *,
                             subject: str | None = None, ax: Axes | None = None) -> Axes:
    """Electrostatic force versus voltage amplitude, log-log: measured and model.

    The legend gives the points (``measured``, a marker per waveform) apart from the
    model's lines (one per waveform, at the points' mean normal force ON).

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
    hidden, points, lines = 0, [], []
    groups = _by_waveform(rows)
    for k, (wave, sel) in enumerate(groups):
        style = {**series_style(k), "marker": _WAVE_MARKERS.get(wave, series_style(k)["marker"])}
        amp = sel["amplitude_V"].to_numpy(float)
        f, err = _errors_mN(sel)
        hidden += int(np.sum(~(f > 0)))
        ax.errorbar(amp, f, yerr=err, fmt=style["marker"], color=style["color"])
        fn = float(np.nanmean(sel["normal_force_on_N"].to_numpy(float)))
        grid = _grid(amp)
        for curve in _model_curves_mN(sel, grid, wave, params):
            ax.plot(grid, curve, linestyle=style["linestyle"], color=style["color"])
        named = f", {wave}" if len(groups) > 1 else ""
        points.append(proxy(f"measured{named}", color=style["color"], marker=style["marker"],
                            linestyle="none"))
        lines.append(proxy(f"model{named} ($F_n$ = {1e3 * fn:.0f} mN)", color=style["color"],
                           linestyle=style["linestyle"]))
    _force_axes(ax, amps_all)
    _nonpositive_note(ax, hidden)
    handles = points + lines
    place_legend(ax, handles, [str(h.get_label()) for h in handles],
                 ncol_outside=2 if len(groups) > 1 else 1)
    return ax


@styled
def plot_electrostatic_force_all(electrostatic: pd.DataFrame,
                                 params: Mapping[str, ModelParameters], *,
                                 ax: Axes | None = None) -> Axes:
    """Every subject's electrostatic force versus voltage amplitude, with its fitted model.

    One colour, marker and line style per subject (in the order of *params*); filled
    markers for a square drive, open ones for a sine drive; each model line over its
    subject's and waveform's own amplitudes. Points are spread by 1.5 % in U
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
    n = len(subjects)
    several = electrostatic["waveform"].astype(str).nunique() > 1
    handles: list[Any] = []
    labels: list[str] = []
    hidden = 0
    for k, s in enumerate(subjects):
        style = series_style(k)
        rows = electrostatic[electrostatic["subject"].astype(str) == s]
        # 1.5 % in U between neighbours, all within +-3 %
        shift = np.exp(min(0.015, 0.06 / (n - 1)) * (k - (n - 1) / 2)) if n > 1 else 1.0
        for wave, sel in _by_waveform(rows):
            look = {**style, "alpha": 1.0 if wave == "square" else 0.6,
                    "markerfacecolor": style["color"] if wave == "square" else "white"}
            f, err = _errors_mN(sel)
            hidden += int(np.sum(~(f > 0)))
            ax.errorbar(sel["amplitude_V"].to_numpy(float) * shift, f, yerr=err,
                        fmt=style["marker"], color=style["color"], elinewidth=0.7,
                        markerfacecolor=look["markerfacecolor"])
            grid = _grid(sel["amplitude_V"].to_numpy(float))
            for curve in _model_curves_mN(sel, grid, wave, params[s]):
                ax.plot(grid, curve, color=style["color"], linestyle=style["linestyle"],
                        alpha=look["alpha"])
            # each line drawn has its entry, drawn as it is (a sine's lighter, open)
            handles.append(_entry(look))
            labels.append(f"{s}, {wave}" if several else s)
    _force_axes(ax, amps_all)
    _nonpositive_note(ax, hidden)
    place_legend(ax, handles, labels, ncol_outside=max(2, n),
                 handler_map={tuple: HandlerTuple(ndivide=1)})
    return ax


def _entry(look: dict[str, Any]) -> tuple[Any, Any]:
    """A legend entry for the points and the model line of one look: the line at its
    opacity, the points' marker over it at full opacity (as they are drawn)."""
    return (proxy("", color=look["color"], linestyle=look["linestyle"], alpha=look["alpha"]),
            proxy("", color=look["color"], marker=look["marker"], linestyle="none",
                  markerfacecolor=look["markerfacecolor"]))
