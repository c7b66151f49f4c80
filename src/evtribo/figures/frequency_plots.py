"""F_el against the drive's frequency, measured and as each fitted model has it (the figure
kind ``frequency_response``, one per subject, stem ``frequency_response_<subject>``), and
``compare --models``' outputs: ``models.csv`` and those figures.

A subject none of whose drives (waveform and amplitude) was measured at
:data:`MIN_FREQUENCIES` frequencies or more gets no such figure (one x-value per drive:
flat lines, and the circuit's curves where nothing was measured); the models are then
ranked on the voltage alone, and the notes say so.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes

from evtribo.figures.layout import place_legend, plain_log_axis, voltage_ticks
from evtribo.figures.plots import new_axes, safe_name
from evtribo.figures.style import (
    EVERY_COLOUR,
    MAX_DRIVE_ENTRIES,
    amplitude_bar,
    proxy,
    series_style,
)
from evtribo.fit.models import ModelFit, fit_models, models_table, study_ranking, verdict
from evtribo.fit.tables import ResultTables
from evtribo.model.params import ModelParameters
from evtribo.results.outputs import MODELS_CSV
from evtribo.store.files import atomic_write
from evtribo.store.resultdir import Staging

__all__ = ["MIN_FREQUENCIES", "WIDE_RANGE", "frequencies_of", "frequency_response_stem",
           "models_text", "plot_frequency_response", "write_models"]

#: ``emit(ax, kind, title, stem, subject=..., caption=...)`` of :mod:`evtribo.report.compare`.
Emit = Callable[..., Any]

#: Forces spanning more than this factor get a log axis.
WIDE_RANGE = 20.0
#: Fewer drive frequencies than this: no figure of F_el against the frequency.
MIN_FREQUENCIES = 2
_STYLES = {"paper": "-", "hertz": ":", "maugis": "-.", "circuit": "--"}


def frequency_response_stem(subject: str) -> str:
    """The figure's file stem for *subject*.

    Parameters
    ----------
    subject : str

    Returns
    -------
    str
        ``frequency_response_<subject>`` (the subject made safe for a file name).
    """
    return f"frequency_response_{safe_name(subject)}"


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


def frequencies_of(rows: pd.DataFrame) -> int:
    """How many drive frequencies the most swept drive (waveform and amplitude) of
    electrostatic.csv's rows was measured at.

    Parameters
    ----------
    rows : DataFrame
        Rows of ``electrostatic.csv``.

    Returns
    -------
    int
        0 without a known frequency; 1 when every drive had a single frequency (a square
        drive at 10 kHz and a sine at 10 Hz are two drives of one frequency each).
    """
    if rows.empty or "frequency_Hz" not in rows.columns:
        return 0
    f = pd.to_numeric(rows["frequency_Hz"], errors="coerce")
    known = rows.assign(_f=f)[np.isfinite(f.to_numpy(float)) & (f.to_numpy(float) > 0)]
    if known.empty:
        return 0
    per = known.groupby([known["waveform"].astype(str),
                         known["amplitude_V"].astype(float)])["_f"].nunique()
    return int(per.max())


def write_models(tables: ResultTables, stage: Staging, models: Sequence[str],
                 base: ModelParameters, emit: Emit) -> tuple[list[Path], list[str]]:
    """Fit the candidate *models*, write ``models.csv`` into *stage* and draw a
    ``frequency_response`` figure per subject through *emit*.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables.
    stage : Staging
        Where ``models.csv`` is written (the result folder's staging).
    models : sequence of str
        Names of :data:`evtribo.fit.models.CANDIDATES` (validated).
    base : ModelParameters
        Starting values and the fixed parameters.
    emit : callable
        ``emit(ax, kind, title, stem, subject=..., caption=...)``: saves and records a
        figure (``evtribo.report.compare``'s).

    Returns
    -------
    (list of Path, list of str)
        The files written (relative to the folder: ``models.csv``) and notes for fit.json.
    """
    fits = fit_models(tables, models, base)
    table = models_table(fits)
    atomic_write(stage.path(MODELS_CSV), table.to_csv(index=False))
    crit = {f.criterion for f in fits if f.params is not None}
    notes = []
    said = verdict(study_ranking(table))
    if said:
        notes.append(f"Models over the study ({models_text(crit)}; each model's criterion "
                     f"summed over the subjects): {said}.")
    for subject in tables.subjects:
        mine = [f for f in fits if f.subject == str(subject)]
        notes += [f"Model {f.model} of {subject} could not be fitted: {f.note}"
                  for f in mine if f.params is None]
        rows = tables.electrostatic[tables.electrostatic["subject"].astype(str) == str(subject)]
        if frequencies_of(rows) < MIN_FREQUENCIES:
            continue
        emit(plot_frequency_response(rows, mine, subject=str(subject)), "frequency_response",
             f"Electrostatic force vs drive frequency, {subject}",
             frequency_response_stem(str(subject)), subject=str(subject),
             caption="Inferred electrostatic force (points, 95 % intervals) against the "
                     "drive's frequency, one colour and marker per drive, and each candidate "
                     "model fitted to the subject's points (models.csv; one line style per "
                     "model, in each drive's colour), at the points' mean normal force ON.")
    bound: dict[tuple[str, str], list[str]] = {}
    for f in fits:
        for name in f.at_bound:
            bound.setdefault((f.model, name), []).append(f.subject)
    notes += [f"Model {model}: {name} at its bound for {', '.join(subjects)} (the data do "
              "not set it; models.csv's fitted holds the bound, not an estimate)."
              for (model, name), subjects in bound.items()]
    few = [str(s) for s in tables.subjects if frequencies_of(
        tables.electrostatic[tables.electrostatic["subject"].astype(str) == str(s)])
        < MIN_FREQUENCIES]
    if few:
        notes.append(f"{len(few)} subject(s) with each drive at a single frequency: no "
                     "figure of F_el against the frequency for them, and the models are told "
                     "apart by the voltage alone (the circuit's leak needs a drive at two "
                     "frequencies or more).")
    return [Path(MODELS_CSV)], notes


def models_text(criteria: set[str]) -> str:
    """How models.csv's ``aic`` column was computed, for a note.

    Parameters
    ----------
    criteria : set of str
        Of ``"AIC"`` and ``"AICc"``.

    Returns
    -------
    str
    """
    if criteria == {"AICc"}:
        return "aic is the small-sample AICc: fewer than 40 points per parameter"
    if "AICc" in criteria:
        return ("aic is the small-sample AICc for the subjects with fewer than 40 points per "
                "parameter, AIC for the others")
    return "aic is AIC"
