"""The population's figure: every subject's forces and power law, and the population's.

One figure per condition (waveform x drive frequency) with a power law across subjects:
log-log, forces in mN, a tick at each measured amplitude (:mod:`evtribo.figures.layout`).
Everything drawn comes from the one model of the population (the nonlinear mixed model of
:mod:`evtribo.population.models.mixed`; the meta-analysis's per-amplitude means are not drawn
beside it):

- each subject's points (95 % intervals) and its own power law (its conditional mode in the
  model), in the subject's colour, marker and line style, so that the subjects stay apart in
  greyscale and for colour-blind readers; each named in the legend (a subject named as far
  from the others: open markers);
- the population's power law (a thick black line), the 95 % confidence band of that mean
  (mid grey) and the 95 % prediction band for a new subject (light grey, dashed edges).

The bands lie under the subjects, whose lines stay readable across them.
"""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np
import pandas as pd
from matplotlib import patheffects
from matplotlib.axes import Axes
from matplotlib.colors import to_rgb
from matplotlib.legend_handler import HandlerTuple
from matplotlib.patches import Patch
from numpy.typing import NDArray

from evtribo.figures.electrostatic_plots import _errors_mN, _force_axes, _nonpositive_note
from evtribo.figures.layout import place_legend
from evtribo.figures.style import new_axes, proxy, series_style, styled
from evtribo.population.estimates import Condition, Population, condition_label

__all__ = ["condition_stem", "plot_population", "population_caption"]

#: A thin white edge around each subject's line and markers: they stay apart from the grey
#: bands under them in greyscale.
#: The largest logarithm whose exp is a float.
_LOG_MAX = math.log(sys.float_info.max)
HALO = [patheffects.withStroke(linewidth=1.8, foreground="white"), patheffects.Normal()]
#: The grey of the confidence band of the population's mean, and of the prediction band.
CI_GREY, PI_GREY = "0.7", "0.9"


def condition_stem(condition: Condition) -> str:
    """A condition as a file stem names it: ``square_10000Hz`` (the population's figure of
    it is ``population_square_10000Hz``).

    Parameters
    ----------
    condition : (str, float)
        Waveform and drive frequency, Hz (NaN when unknown).

    Returns
    -------
    str
    """
    wave, freq = condition
    tail = f"_{freq:g}Hz" if math.isfinite(freq) else ""
    return f"{wave or 'drive'}{tail}".replace(".", "p")


def _rows_of(electrostatic: pd.DataFrame, condition: Condition) -> pd.DataFrame:
    es = electrostatic[electrostatic["waveform"].fillna("").astype(str) == condition[0]]
    if "frequency_Hz" in es.columns:
        f = es["frequency_Hz"].to_numpy(float)
        es = es[np.isnan(f)] if math.isnan(condition[1]) else es[np.isclose(f, condition[1])]
    return es


def _legible(color: str) -> tuple[float, float, float]:
    """*color*, darkened where it is pale (the palette's yellow): its grey, its relative
    luminance, at most 0.18 (a grey of 47 % in sRGB), so that its line shows on white and
    on the light bands."""
    rgb = np.array(to_rgb(color))
    lin = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    lum = float(lin @ [0.2126, 0.7152, 0.0722])
    if lum > 0.18:
        lin = lin * 0.18 / lum
        rgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    r, g, b = (float(x) for x in np.clip(rgb, 0.0, 1.0))
    return r, g, b


def _exp_or_nan(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``exp`` of each of *x*, NaN where it is beyond any float (an end the data do not
    bound: not drawn)."""
    x = np.asarray(x, dtype=float)
    return np.exp(np.where(x <= _LOG_MAX, x, np.nan))


def _subject(ax: Axes, sel: pd.DataFrame, k: int, line: tuple[float, float] | None,
             log_u0: float, *, far: bool) -> tuple[Any, int]:
    """One subject's points and line; its legend entry and its points a log axis hides."""
    style = series_style(k)
    style["color"] = _legible(style["color"])
    f, err = _errors_mN(sel)
    u = sel["amplitude_V"].to_numpy(float)
    face = "white" if far else style["color"]
    ax.errorbar(u, f, yerr=err, fmt=style["marker"], color=style["color"], ms=3.2,
                elinewidth=0.6, capsize=0, markerfacecolor=face, markeredgewidth=0.8,
                zorder=4)
    if line is not None:
        grid = np.geomspace(np.nanmin(u), np.nanmax(u), 30)
        ax.plot(grid, 1e3 * np.exp(line[0] + line[1] * (np.log(grid) - log_u0)),
                color=style["color"], linestyle=style["linestyle"], lw=1.0, zorder=3,
                path_effects=HALO)
    entry = proxy("", color=style["color"], marker=style["marker"], ms=3.2, lw=1.0,
                  linestyle=style["linestyle"] if line is not None else "none",
                  markerfacecolor=face, markeredgewidth=0.8)
    return entry, int(np.sum(~(f > 0)))


def _band(ax: Axes, x: np.ndarray, ends: np.ndarray, colour: str, *, zorder: float) -> None:
    """A shaded band between ``ends[:, 0]`` and ``ends[:, 1]`` (one polygon patch)."""
    ax.fill(np.concatenate([x, x[::-1]]), np.concatenate([ends[:, 0], ends[::-1, 1]]),
            facecolor=colour, edgecolor="none", lw=0, zorder=zorder)


@styled
def plot_population(electrostatic: pd.DataFrame, pop: Population, condition: Condition, *,
                    ax: Axes | None = None) -> Axes:
    """Every subject's F_el and power law, and the population's, for one condition.

    Parameters
    ----------
    electrostatic : DataFrame
        ``electrostatic.csv``.
    pop : Population
        The population's estimates (:func:`evtribo.population.estimates.population`).
    condition : (str, float)
        The waveform and drive frequency shown (one of ``pop.lines``).
    ax : Axes, optional
        Where to draw; a new figure in the journal style when None.

    Returns
    -------
    Axes
    """
    ax = new_axes() if ax is None else ax
    es = _rows_of(electrostatic, condition)
    es = es[~es["subject"].astype(str).isin(pop.excluded)]
    fit, own = pop.lines[condition], pop.subject_lines.get(condition, {})
    amps = es["amplitude_V"].to_numpy(float)
    grid = np.geomspace(np.nanmin(amps) / 1.1, np.nanmax(amps) * 1.1, 60)
    far = pop.far.get(condition, set())
    handles: list[Any] = []
    labels: list[str] = []
    hidden = 0
    for k, s in enumerate(dict.fromkeys(es["subject"].astype(str))):
        entry, n = _subject(ax, es[es["subject"].astype(str) == s], k, own.get(s),
                            fit.log_u0, far=s in far)
        hidden += n
        handles.append(entry)
        labels.append(f"{s} (far from the others)" if s in far else s)
    est = [fit.at(float(x)) for x in np.log(grid)]
    # an end the data do not bound (exp beyond any float) is not drawn: NaN, not a band to
    # infinity (the fit's checks say the exponent is not determined)
    band = _exp_or_nan(np.array([e.interval() for e in est]))
    pred = _exp_or_nan(np.array([fit.prediction_interval([1.0, float(x) - fit.log_u0])
                                 for x in np.log(grid)]))
    _band(ax, grid, 1e3 * pred, PI_GREY, zorder=1)
    for edge in (pred[:, 0], pred[:, 1]):
        ax.plot(grid, 1e3 * edge, color="0.35", lw=0.6, linestyle=(0, (4, 2)), zorder=1.5)
    _band(ax, grid, 1e3 * band, CI_GREY, zorder=2)
    ax.plot(grid, 1e3 * np.exp([e.value for e in est]), color="black", lw=2.0, zorder=5)
    n_hat = fit.estimate([0.0, 1.0])
    lo, hi = n_hat.interval()
    first: list[Any] = [proxy("", color="black", lw=2.0), Patch(facecolor=CI_GREY, lw=0),
                        (Patch(facecolor=PI_GREY, lw=0),
                         proxy("", color="0.35", lw=0.6, linestyle=(0, (4, 2))))]
    first_labels = ["population mean", "95 % CI of the mean", "95 % PI, new subject"]
    ax.text(0.03, 0.97, f"population: $n$ = {n_hat.value:.2f} [{lo:.2f}, {hi:.2f}]",
            transform=ax.transAxes, ha="left", va="top", fontsize="small")
    _force_axes(ax, amps)
    _zoomed(ax, es, 1e3 * band, 1e3 * pred)
    _nonpositive_note(ax, hidden)
    place_legend(ax, first + handles, first_labels + labels, ncol_outside=4, inside=False,
                 handler_map={tuple: HandlerTuple(ndivide=1)}, fontsize="small",
                 handlelength=2.4, columnspacing=1.0)
    return ax


def _zoomed(ax: Axes, es: pd.DataFrame, band: np.ndarray, pred: np.ndarray) -> None:
    """The force axis over the subjects' points with their intervals and the mean's band
    (mN), a factor of 2 beyond; where the prediction band reaches further (few subjects: its
    t has k - 2 degrees of freedom), it runs off the axes, and the plot says so."""
    f, err = _errors_mN(es)
    values = np.concatenate([f - err[0], f + err[1], band.ravel()])
    values = values[np.isfinite(values) & (values > 0)]
    if values.size == 0:
        return
    low, high = float(values.min()) / 2.0, float(values.max()) * 2.0
    edges = pred[np.isfinite(pred)]
    if edges.size == 0 or (edges.min() >= low and edges.max() <= high):
        return
    ax.set_ylim(low, high)
    ax.text(0.97, 0.03, "prediction band runs beyond the axes", transform=ax.transAxes,
            ha="right", va="bottom", fontsize="x-small", color="0.3")


def population_caption(pop: Population, condition: Condition) -> str:
    """The caption of a condition's figure: what is drawn, and the subjects far from the
    others.

    Parameters
    ----------
    pop : Population
        The population's estimates.
    condition : (str, float)
        The waveform and drive frequency shown (one of ``pop.lines``).

    Returns
    -------
    str
    """
    fit = pop.lines[condition]
    far = sorted(pop.far.get(condition, set()))
    named = (f" Open markers: {', '.join(far)}, far from the other subjects (every estimate "
             "has it; population.csv has them without it too)." if far else "")
    random = "levels and exponents" if fit.random_slopes else "levels"
    return (f"{condition_label(*condition)}: every subject's inferred electrostatic force "
            "(points, 95 % intervals) and its own power law (lines, its conditional mode), "
            "and the population's power law across "
            f"{len(fit.subjects)} subjects (thick line; a nonlinear mixed model on the "
            f"linear scale, subjects' {random} random, each force with its own error): the "
            "mid-grey band is the 95 % confidence band of the population's mean, the light "
            "band with dashed edges the 95 % prediction band for a new subject." + named)
