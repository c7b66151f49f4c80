"""F_el against the drive's frequency, measured and as each fitted model has it (the figure
kind ``frequency_response`` of ``compare --models``, one per subject:
:mod:`evtribo.figures.registry.builtin`).

A subject none of whose drives (waveform and amplitude) was measured at
:data:`~evtribo.fit.model_comparison.MIN_FREQUENCIES` frequencies or more gets no such
figure (one x-value per drive: flat lines, and the circuit's curves where nothing was
measured); the models are then ranked on the voltage alone, and compare's notes say so.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes

from evtribo.figures.layout import place_legend, plain_log_axis, voltage_ticks
from evtribo.figures.plots import new_axes
from evtribo.figures.style import (
    EVERY_COLOUR,
    MAX_DRIVE_ENTRIES,
    amplitude_bar,
    proxy,
    series_style,
)
from evtribo.fit.models import ModelFit

__all__ = ["WIDE_RANGE", "plot_frequency_response"]

#: Forces spanning more than this factor get a log axis.
WIDE_RANGE = 20.0
_STYLES = {"paper": "-", "hertz": ":", "maugis": "-.", "circuit": "--"}


def _groups(rows: pd.DataFrame) -> list[tuple[tuple[str, float], pd.DataFrame]]:
    """Every (waveform, amplitude) drive of the rows: square first, then by amplitude."""
    keyed = rows.assign(_wave=rows["waveform"].astype(str),
                        _amp=rows["amplitude_V"].to_numpy(float))
    groups = [((str(w), float(a)), g)  # type: ignore[arg-type]
              for (w, a), g in keyed.groupby(["_wave", "_amp"])]
    groups.sort(key=lambda kg: (kg[0][0] != "square", kg[0][0], kg[0][1]))
    return groups


def plot_frequency_response(rows: pd.DataFrame, fits: Sequence[ModelFit], *,
                            subject: str = "", ax: Axes | None = None) -> Axes:
    """The subject's inferred electrostatic force against the drive frequency (log axis),
    with its 95 % intervals, and each fitted model's curve at the points' mean normal force.

    Every drive (waveform and amplitude) has its colour and marker, every model its line
    style; the legend gives each drive (its points) and each model (its line style, in
    :data:`~evtribo.figures.style.EVERY_COLOUR`: drawn in each drive's colour). With more
    than :data:`~evtribo.figures.style.MAX_DRIVE_ENTRIES` drives, a drive's colour is its
    amplitude's on a colour bar, its marker a circle (open for a sine), and the legend gives
    the waveforms and the models. Forces spanning more than :data:`WIDE_RANGE` times get a
    log axis.

    Parameters
    ----------
    rows : DataFrame
        The subject's rows of ``electrostatic.csv`` (``frequency_Hz`` among them).
    fits : sequence of ModelFit
        The subject's fitted models (:func:`evtribo.fit.models.fit_models`).
    subject : str
        The subject (figures carry no title: the caption names it).
    ax : Axes, optional
        Where to draw; a new figure when None.

    Returns
    -------
    Axes
    """
    ax = ax if ax is not None else new_axes()
    rows = rows[np.isfinite(rows["frequency_Hz"].to_numpy(float))
                & (rows["frequency_Hz"].to_numpy(float) > 0)]
    if rows.empty:
        ax.text(0.5, 0.5, "no point with a known drive frequency", ha="center",
                va="center", transform=ax.transAxes)
        return ax
    f_all = rows["frequency_Hz"].to_numpy(float)
    grid = np.geomspace(f_all.min() / 2.0, f_all.max() * 2.0, 121)
    drawn = [fit for fit in fits if fit.params is not None]
    groups = _groups(rows)
    many = len(groups) > MAX_DRIVE_ENTRIES
    colour = amplitude_bar(ax, [a for (_, a), _ in groups]) if many else None
    handles = _draw_drives(ax, groups, drawn, grid, colour)
    if colour is not None:  # the colour bar gives the amplitude, the marker the waveform
        waves = dict.fromkeys(w for (w, _), _ in groups)
        handles += [proxy(f"{w} drive", color=EVERY_COLOUR, linestyle="none", markersize=4,
                          **{k: v for k, v in _look(0, w, 0.0, lambda _: EVERY_COLOUR).items()
                             if k != "color"}) for w in waves]
        voltage_ticks(ax.figure.axes[-1].yaxis, [a for (_, a), _ in groups])
    handles += [proxy(_model_label(fit), color=EVERY_COLOUR, lw=1.1,
                      linestyle=_STYLES.get(fit.model, "-")) for fit in drawn]
    ax.set(xscale="log", xlabel="drive frequency $f$ (Hz)",
           ylabel=r"electrostatic force $F_\mathrm{el}$ (mN)")
    plain_log_axis(ax.xaxis, subs=(1.0,))
    _force_axis(ax, rows["electrostatic_force_N"].to_numpy(float))
    place_legend(ax, handles, [str(h.get_label()) for h in handles], ncol_outside=3)
    return ax


def _draw_drives(ax: Axes, groups: list[tuple[tuple[str, float], pd.DataFrame]],
                 drawn: Sequence[ModelFit], grid: np.ndarray,
                 colour: Callable[[float], Any] | None) -> list[Any]:
    """Each drive's points and its models' curves; the drives' legend entries (none when
    a colour bar gives them)."""
    handles: list[Any] = []
    for i, ((wave, amp), group) in enumerate(groups):
        g = group.sort_values("frequency_Hz")
        f = g["frequency_Hz"].to_numpy(float)
        y = 1e3 * g["electrostatic_force_N"].to_numpy(float)
        lo = 1e3 * g["electrostatic_force_ci_low_N"].to_numpy(float)
        hi = 1e3 * g["electrostatic_force_ci_high_N"].to_numpy(float)
        err = np.nan_to_num(np.vstack([y - lo, hi - y]), nan=0.0).clip(min=0.0)
        look = _look(i, wave, amp, colour)
        ax.errorbar(f, y, yerr=err, fmt=look["marker"], ms=4, color=look["color"],
                    markerfacecolor=look["markerfacecolor"], capsize=2)
        if colour is None:
            handles.append(proxy(f"{wave} {amp:g} V", color=look["color"],
                                 marker=look["marker"], markerfacecolor=look["markerfacecolor"],
                                 linestyle="none", markersize=4))
        fn = float(np.nanmean(g["normal_force_on_N"].to_numpy(float)))
        for fit in drawn:
            ax.plot(grid, 1e3 * fit.force(fn, amp, wave, grid),
                    linestyle=_STYLES.get(fit.model, "-"), color=look["color"], lw=1.1)
    return handles


def _force_axis(ax: Axes, y_all: np.ndarray) -> None:
    """The force axis: log over a wide range (:data:`WIDE_RANGE`), else linear from 0."""
    if (y_all > 0).all() and y_all.max() > WIDE_RANGE * y_all.min():
        # forces over decades: a log axis shows each drive's roll-off alike
        ax.set_yscale("log")
        ax.set_ylim(1e3 * y_all.min() / 2.0, 1e3 * y_all.max() * 1.5)
        plain_log_axis(ax.yaxis)
    else:
        ax.set_ylim(0, None)


def _look(i: int, wave: str, amp: float, colour: Callable[[float], Any] | None
          ) -> dict[str, Any]:
    """A drive's colour, marker and fill: the series' own, or (*colour* given, many drives)
    its amplitude's colour with a circle, open for a sine."""
    if colour is None:
        look = series_style(i)
        return {"color": look["color"], "marker": look["marker"],
                "markerfacecolor": look["color"]}
    return {"color": colour(amp), "marker": "o",
            "markerfacecolor": "white" if wave == "sine" else colour(amp)}


def _model_label(fit: ModelFit) -> str:
    """A model's legend entry: its name, its Δ of the criterion where defined, and the
    parameters left at a bound of their range."""
    parts = [f"Δ{fit.criterion} {fit.delta_aic:.1f}"] if math.isfinite(fit.delta_aic) else []
    parts += [f"${_MATH.get(n, n)}$ at its bound" for n in fit.at_bound]
    return f"{fit.model} ({'; '.join(parts)})" if parts else fit.model


#: Parameters' names in mathtext.
_MATH = {"h_L": "h_L", "r_g": "r_g", "r_sc": r"r_\mathrm{sc}"}
