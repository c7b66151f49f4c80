"""The population's figure: every subject's forces and power law, and the population's.

One figure per condition (waveform x drive frequency) with a power law across subjects:
log-log, forces in mN, a tick at each measured amplitude (:mod:`evtribo.figures.layout`).
Each subject's points (95 % intervals) and its own weighted power law are drawn thin and
light in the subject's colour; the population's geometric mean at each amplitude (black
diamonds, 95 % intervals) and its power law across subjects (a thick black line in a grey
95 % band) on top. The legend gives each entry as it is drawn: the population's line
in its band, the means, each subject (up to :data:`MAX_NAMED`, else one entry for all)
and an outlier left out of the population's estimates (open markers).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.legend_handler import HandlerTuple
from matplotlib.patches import Patch

from evtribo.figures.electrostatic_plots import _errors_mN, _force_axes, _nonpositive_note
from evtribo.figures.layout import place_legend
from evtribo.figures.style import EVERY_COLOUR, new_axes, proxy, series_style, styled
from evtribo.population.estimates import Condition, Population, condition_label

__all__ = ["MAX_NAMED", "draw_population", "plot_population", "population_stem"]

#: Subjects named one by one in the legend at most; more share one entry in
#: :data:`~evtribo.figures.style.EVERY_COLOUR` (an outlier is always named).
MAX_NAMED = 6


def population_stem(condition: Condition) -> str:
    """The file stem of a condition's figure: ``population_square_10000Hz``.

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
    return f"population_{wave or 'drive'}{tail}".replace(".", "p")


def _rows_of(electrostatic: pd.DataFrame, condition: Condition) -> pd.DataFrame:
    es = electrostatic[electrostatic["waveform"].fillna("").astype(str) == condition[0]]
    if "frequency_Hz" in es.columns:
        f = es["frequency_Hz"].to_numpy(float)
        es = es[np.isnan(f)] if math.isnan(condition[1]) else es[np.isclose(f, condition[1])]
    return es


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
    fit, own = pop.lines[condition], pop.subject_lines.get(condition, {})
    amps = es["amplitude_V"].to_numpy(float)
    grid = np.geomspace(np.nanmin(amps) / 1.1, np.nanmax(amps) * 1.1, 60)
    out = pop.left_out.get(condition, set())
    subjects = list(dict.fromkeys(es["subject"].astype(str)))
    named = len(subjects) <= MAX_NAMED  # each subject its entry; else one in every colour
    handles: list[Any] = []
    hidden = 0
    for k, s in enumerate(subjects):
        style = series_style(k)
        sel = es[es["subject"].astype(str) == s]
        f, err = _errors_mN(sel)
        hidden += int(np.sum(~(f > 0)))
        ax.errorbar(sel["amplitude_V"].to_numpy(float), f, yerr=err, fmt=style["marker"],
                    color=style["color"], alpha=0.55, ms=3, elinewidth=0.6,
                    markerfacecolor="white" if s in out else style["color"])
        if s in own:
            a, n = own[s]
            ax.plot(grid, 1e3 * np.exp(a + n * (np.log(grid) - fit.log_u0)),
                    color=style["color"], lw=0.7, alpha=0.55)
        if named or s in out:
            handles.append(_subject_entry(f"{s} (outlier, left out)" if s in out else s,
                                          style, s in own, open_=s in out))
    est = [fit.at(float(x)) for x in np.log(grid)]
    band = np.exp(np.array([e.interval() for e in est]))
    # under the subjects' points and lines, which stay readable inside it
    ax.fill_between(grid, 1e3 * band[:, 0], 1e3 * band[:, 1], color="0.8", alpha=0.7,
                    lw=0, zorder=1)
    ax.plot(grid, 1e3 * np.exp([e.value for e in est]), color="black", lw=1.8, zorder=3)
    _population_points(ax, pop.table, condition)
    n_hat = fit.estimate([0.0, 1.0])
    lo, hi = n_hat.interval()
    line = (Patch(facecolor="0.75", alpha=0.6, lw=0), proxy("", color="black", lw=1.8))
    first: list[Any] = [line, proxy("", color="black", marker="D", linestyle="none", ms=4)]
    labels = [f"population: $n$ = {n_hat.value:.2f} [{lo:.2f}, {hi:.2f}], 95 % band",
              "geometric mean at each $U$"]
    if not named:
        first.append(proxy("", color=EVERY_COLOUR, marker="o", lw=0.7, alpha=0.55))
        labels.append("subjects (one colour each)")
    labels += [str(h.get_label()) for h in handles]
    _force_axes(ax, amps)
    _nonpositive_note(ax, hidden)
    place_legend(ax, first + handles, labels, ncol_outside=2,
                 handler_map={tuple: HandlerTuple(ndivide=1)})
    return ax


def _subject_entry(label: str, style: dict[str, Any], line: bool, *, open_: bool) -> Any:
    """A subject's legend entry, drawn as its points (and its power law's line) are."""
    return proxy(label, color=style["color"], marker=style["marker"], alpha=0.55, ms=3,
                 linestyle="-" if line else "none", lw=0.7,
                 markerfacecolor="white" if open_ else style["color"])


def _population_points(ax: Axes, table: pd.DataFrame, condition: Condition) -> None:
    """The geometric mean at each amplitude with its interval (black diamonds)."""
    rows = table[(table["quantity"] == "electrostatic_force_N")
                 & (table["waveform"].astype(str) == condition[0])]
    f = rows["frequency_Hz"].to_numpy(float)
    rows = rows[np.isnan(f)] if math.isnan(condition[1]) else rows[np.isclose(f, condition[1])]
    if rows.empty:
        return
    est = 1e3 * rows["estimate"].to_numpy(float)
    err = np.vstack([est - 1e3 * rows["ci_low"].to_numpy(float),
                     1e3 * rows["ci_high"].to_numpy(float) - est])
    ax.errorbar(rows["amplitude_V"].to_numpy(float), est, yerr=err, fmt="D", color="black",
                ms=4, elinewidth=1.0, capsize=2, zorder=4)


def _caption(pop: Population, condition: Condition) -> str:
    fit = pop.lines[condition]
    out = sorted(pop.left_out.get(condition, set()))
    left = (f" Open markers: {', '.join(out)}, left out of the population's estimates as "
            "outlier(s)." if out else "")
    random = "intercepts and exponents" if fit.random_slopes else "intercepts"
    return (f"{condition_label(*condition)}: every subject's inferred electrostatic force "
            "(points, 95 % intervals) and its own power law (thin lines, weighted by the "
            "intervals), and the population's: the geometric mean at each amplitude "
            "(diamonds, 95 % intervals; random-effects meta-analysis) and the power law "
            f"across {len(fit.subjects)} subjects (thick line and its 95 % band; "
            f"mixed-effects REML, subjects' {random} random).{left}")


def draw_population(electrostatic: pd.DataFrame, pop: Population,
                    emit: Callable[..., Any], conditions: Sequence[Condition] | None = None
                    ) -> None:
    """Draw the population's figure of each condition with a power law, and emit it.

    Parameters
    ----------
    electrostatic : DataFrame
        ``electrostatic.csv``.
    pop : Population
        The population's estimates.
    emit : callable
        ``emit(ax, kind, title, stem, *, subject, caption)`` writes or keeps the figure.
    conditions : sequence, optional
        The conditions to draw (default: all with a power law).

    Returns
    -------
    None
    """
    for condition in conditions if conditions is not None else list(pop.lines):
        ax = plot_population(electrostatic, pop, condition)
        emit(ax, "population", f"The population, {condition_label(*condition)}",
             population_stem(condition), subject=None, caption=_caption(pop, condition))
