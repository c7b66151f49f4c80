"""The check of a trial as a figure: what the analysis used, and what it left out.

One Axes per trial: the normal force and the tangential force (with its sign: it follows
the sliding direction) over time from the trial's start, as the analysis worked on them
(calibrated, tared, mains hum removed); the ON phases shaded; each steady-sliding window a
thick bar at its mean force over its span, ON and OFF windows apart (colour and line style,
so that they stay apart in greyscale); the finger-lifted stretches where the zero was read;
and, hatched, what no window may use (guard times at ON/OFF switches, unknown state, the
finger leaving or touching down, missing frames, pauses). A researcher sees at once when
the analysis picked the wrong stretches.

:func:`trial_check_figures` gives one such figure per trial of a study, with its caption, for
``evtribo compare`` to save as kind ``trial`` (stem ``trial_<subject>_<trial>``, see
:func:`trial_stem`).
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from evtribo.analysis.forces.conditions import ON
from evtribo.analysis.settings import AnalysisSettings
from evtribo.errors import AnalysisError, UserInputError
from evtribo.results.check import (
    STRETCH_LABELS,
    Stretch,
    TrialCheck,
    check_trial,
    excluded_stretches,
    settings_of,
)
from evtribo.study import Study, load_study

log = logging.getLogger(__name__)

__all__ = ["MAX_POINTS", "TRIAL_FIGSIZE", "TrialFigure", "draw_trial_check", "envelope",
           "plot_trial", "trial_caption", "trial_check_figures", "trial_stem"]

#: Size of a trial's figure, inches: a journal's double column (175 mm) wide.
TRIAL_FIGSIZE = (6.89, 2.9)
#: Most points drawn per force line (longer traces are drawn as their min/max envelope).
MAX_POINTS = 4000

# Okabe-Ito colours: apart for colour-blind readers
_NORMAL, _TANGENTIAL = "#0072B2", "#009E73"
_ON_WINDOW, _OFF_WINDOW = "#D55E00", "#000000"
_ON_SHADE, _LIFT_SHADE = "#F0E442", "#56B4E9"
_TRACE_LW = 0.6
#: One pattern per kind of excluded stretch, each unlike the others (not only its direction).
_HATCH = {"switch": "///", "lift-edge": "ooo", "unknown": "xxx", "hole": "...",
          "pause": "|||"}


def trial_stem(subject: str, trial: str) -> str:
    """The file stem of a trial's check figure, ``trial_<subject>_<trial>``, each name
    reduced to letters, digits, ``-`` and ``_`` (as :func:`evtribo.figures.plots.safe_name`
    does).

    Parameters
    ----------
    subject, trial : str
        The trial's names.

    Returns
    -------
    str
    """
    def safe(name: str) -> str:
        return re.sub(r"[^A-Za-z0-9_-]", "_", str(name)) or "_"

    return f"trial_{safe(subject)}_{safe(trial)}"


def _new_axes() -> Axes:
    """A fresh Axes on its own Agg-backed figure (no pyplot state)."""
    fig = Figure(figsize=TRIAL_FIGSIZE, layout="constrained")
    FigureCanvasAgg(fig)
    return fig.add_subplot()


def envelope(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64]
             ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """A trace as drawn: its samples, or for a long one the minimum and maximum of each of
    :data:`MAX_POINTS` / 2 bins (what the pixels would show anyway; a bin without samples
    breaks the line).

    Parameters
    ----------
    t : ndarray of float64
        Times, increasing.
    y : ndarray of float64
        Values (NaN where missing).

    Returns
    -------
    (ndarray, ndarray)
        The times and values to draw.
    """
    if t.size <= MAX_POINTS:
        return t, y
    starts = np.linspace(0, t.size, MAX_POINTS // 2, endpoint=False).astype(np.int64)
    with np.errstate(invalid="ignore"):
        lo = np.fmin.reduceat(y, starts)
        hi = np.fmax.reduceat(y, starts)
    stops = np.append(starts[1:], t.size)
    mid = t[(starts + stops - 1) // 2]
    return (np.column_stack([t[starts], mid]).ravel(), np.column_stack([lo, hi]).ravel())


def _spans(ax: Axes, check: TrialCheck, stretches: list[Stretch]) -> set[str]:
    """Shade the ON phases, the lifted stretches and what is excluded; the kinds drawn."""
    kinds = set()
    lifted = [(s.t_start, s.t_end) for s in stretches if s.kind == "lifted"]
    for piece in check.pieces:
        t = piece.forces.t - check.t0
        dt = 1.0 / piece.forces.rate_Hz
        on = piece.condition == ON
        for a0, b0 in lifted:  # a lifted stretch shows as lifted, not in a mix of colours
            on &= ~((t + dt > a0) & (t < b0))
        edges = np.flatnonzero(np.diff(np.concatenate(([0], on.view(np.int8), [0]))))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            ax.axvspan(t[a], t[b - 1] + dt, color=_ON_SHADE, alpha=0.35, lw=0, zorder=0)
            kinds.add("on")
    for s in stretches:
        if s.kind == "lifted":
            ax.axvspan(s.t_start, s.t_end, color=_LIFT_SHADE, alpha=0.35, lw=0, zorder=0)
        else:
            ax.axvspan(s.t_start, s.t_end, facecolor="none", edgecolor="0.55",
                       hatch=_HATCH[s.kind], lw=0, zorder=0.5)
        kinds.add(s.kind)
    return kinds


def _windows(ax: Axes, check: TrialCheck) -> set[str]:
    """Each window a thick bar at its mean force (normal, and the friction with the
    stroke's sign) over its span, a tick at each end (windows often follow each other); the
    conditions drawn."""
    drawn = set()
    for piece in check.pieces:
        w = piece.windows
        if w.empty:
            continue
        starts = w.t_start.to_numpy(np.float64) - check.t0
        ends = w.t_end.to_numpy(np.float64) - check.t0
        normal = w.normal_force_N.to_numpy(np.float64)
        friction = (w.direction.to_numpy(np.float64)
                    * w.friction_force_N.to_numpy(np.float64))
        for i, condition in enumerate(w.condition.astype(str)):
            on = condition == "on"
            style: dict[str, Any] = {"color": _ON_WINDOW if on else _OFF_WINDOW, "lw": 2.6,
                                     "ls": "-" if on else (0, (1.2, 0.6)),
                                     "solid_capstyle": "butt", "zorder": 4,
                                     "marker": "|", "markersize": 7, "markeredgewidth": 1.0}
            ax.plot((starts[i], ends[i]), (normal[i],) * 2, **style)
            ax.plot((starts[i], ends[i]), (friction[i],) * 2, **style)
            drawn.add(condition)
    return drawn


def _legend(ax: Axes, kinds: set[str], conditions: set[str]) -> None:
    """A legend below the Axes (never over the data), of what is drawn."""
    handles: list[Any] = [Line2D([], [], color=_NORMAL, lw=_TRACE_LW, label="normal force"),
                          Line2D([], [], color=_TANGENTIAL, lw=_TRACE_LW,
                                 label="tangential force")]
    if "on" in conditions:
        handles.append(Line2D([], [], color=_ON_WINDOW, lw=2.6, marker="|", markersize=7,
                              label="ON window (mean)"))
    if "off" in conditions:
        handles.append(Line2D([], [], color=_OFF_WINDOW, lw=2.6, ls=(0, (1.2, 0.6)),
                              marker="|", markersize=7, label="OFF window (mean)"))
    if "on" in kinds:
        handles.append(Patch(color=_ON_SHADE, alpha=0.35, lw=0, label="voltage ON"))
    if "lifted" in kinds:
        handles.append(Patch(color=_LIFT_SHADE, alpha=0.35, lw=0, label=STRETCH_LABELS["lifted"]))
    for kind, hatch in _HATCH.items():
        if kind in kinds:
            handles.append(Patch(facecolor="none", edgecolor="0.55", hatch=hatch, lw=0,
                                 label=STRETCH_LABELS[kind]))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.22),
              ncol=min(3, len(handles)), fontsize="small", frameon=False)


def draw_trial_check(check: TrialCheck, ax: Axes | None = None) -> Axes:
    """Draw a trial's check: the forces, the ON phases, the windows, what was left out.

    Parameters
    ----------
    check : TrialCheck
        The trial as its analysis saw it (:func:`evtribo.results.check.check_trial`).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure, :data:`TRIAL_FIGSIZE`).

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = ax if ax is not None else _new_axes()
    stretches = excluded_stretches(check)
    kinds = _spans(ax, check, stretches)
    for piece in check.pieces:
        t = piece.forces.t - check.t0
        ax.plot(*envelope(t, piece.forces.normal), color=_NORMAL, lw=_TRACE_LW, zorder=2)
        ax.plot(*envelope(t, piece.forces.tangential), color=_TANGENTIAL, lw=_TRACE_LW,
                zorder=2)
    conditions = _windows(ax, check)
    ax.axhline(0.0, color="0.3", lw=0.5, zorder=1, gid="zero")  # an axis line, not data
    ax.set_xlabel("time from the trial's start (s)")
    ax.set_ylabel("force (N)")
    if check.pieces:
        ends = [(p.forces.t[0] - check.t0, p.forces.t[-1] - check.t0) for p in check.pieces
                if p.forces.t.size]
        ax.set_xlim(min(0.0, *(a for a, _ in ends)), max(b for _, b in ends))
    _legend(ax, kinds, conditions)
    return ax


def _seconds(stretches: list[Stretch], kind: str) -> float:
    return sum(s.t_end - s.t_start for s in stretches if s.kind == kind)


def trial_caption(check: TrialCheck) -> str:
    """A caption for a trial's check figure: what it shows, counted.

    Parameters
    ----------
    check : TrialCheck
        The trial's check.

    Returns
    -------
    str
    """
    row = check.row
    w = check.windows
    n_on = int((w.condition == "on").sum()) if len(w) else 0
    n_off = len(w) - n_on
    drive = (f"{row.get('waveform') or 'unknown waveform'}"
             + (f" {row['frequency_Hz']:g} Hz" if row.get("frequency_Hz") else "")
             + (f" at {row['amplitude_V']:g} V" if row.get("amplitude_V") else ""))
    parts = [f"Trial {check.key} ({drive}): normal and tangential force as analysed "
             f"(tare: {row.get('tare') or 'none'}); ON phases shaded; {n_on} ON and {n_off} "
             "OFF steady-sliding windows, each a bar at its mean force over its span"]
    stretches = excluded_stretches(check)
    lifted = [s for s in stretches if s.kind == "lifted"]
    if lifted:
        parts.append(f"finger lifted (zero read) {len(lifted)} time(s), "
                     f"{_seconds(stretches, 'lifted'):.1f} s")
    left = [f"{STRETCH_LABELS[k]} {_seconds(stretches, k):.2f} s"
            for k in ("switch", "unknown", "lift-edge", "hole", "pause")
            if any(s.kind == k for s in stretches)]
    if left:
        parts.append("excluded (hatched): " + ", ".join(left))
    if not len(w):
        parts.append("no steady-sliding window was found: this trial gives no estimate")
    return "; ".join(parts) + "."


def plot_trial(study: Study | str | os.PathLike[str], subject: str, trial: str, *,
               ax: Axes | None = None,
               settings: AnalysisSettings | Mapping[str, Any] | None = None,
               cache_dir: str | os.PathLike[str] | None = None) -> Axes:
    """The check of one trial of a study, drawn: decoded through the cache and analysed
    with the study's settings, as ``evtribo analyze`` does (its windows are those of
    ``windows.csv``).

    Parameters
    ----------
    study : Study or path-like
        The study, or its folder.
    subject, trial : str
        The trial.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    settings : AnalysisSettings or mapping, optional
        The analysis settings (default: the study's; a mapping such as ``summary.json``'s
        ``settings``, see :func:`evtribo.results.check.settings_of`).
    cache_dir : path-like, optional
        The decoded-trial cache (default: ``$EVTRIBO_CACHE_DIR`` or ``~/.cache/evtribo``).

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    StudyError
        No such study, subject or trial.
    AnalysisError
        The trial cannot be analysed.
    """
    return draw_trial_check(check_trial(study, subject, trial, settings=settings,
                                        cache_dir=cache_dir), ax)


class TrialFigure(NamedTuple):
    """One trial's check figure, for ``evtribo compare`` to save (kind ``trial``)."""

    subject: str
    trial: str
    axes: Axes
    caption: str
    error: str | None = None
    """Why the trial could not be analysed (its figure then says so); None when checked."""

    @property
    def stem(self) -> str:
        """``trial_<subject>_<trial>`` (:func:`trial_stem`)."""
        return trial_stem(self.subject, self.trial)


def _failed(subject: str, trial: str, err: Exception) -> TrialFigure:
    """The figure of a trial that could not be analysed: why, in words."""
    ax = _new_axes()
    ax.set_axis_off()
    ax.text(0.5, 0.5, f"{subject}/{trial}: not analysed\n{err}", ha="center", va="center",
            wrap=True, transform=ax.transAxes)
    return TrialFigure(subject, trial, ax,
                       f"Trial {subject}/{trial}: not analysed, so nothing to check: {err}",
                       error=str(err))


def trial_check_figures(study_root: Study | str | os.PathLike[str],
                        subjects: Sequence[str] | None = None,
                        settings: AnalysisSettings | Mapping[str, Any] | None = None, *,
                        cache_dir: str | os.PathLike[str] | None = None
                        ) -> Iterator[TrialFigure]:
    """The check figure of every trial of a study, one at a time, in the study's order.

    Parameters
    ----------
    study_root : Study or path-like
        The study, or its folder.
    subjects : sequence of str, optional
        Only these subjects' trials (default: all).
    settings : AnalysisSettings or mapping, optional
        The settings the results were analysed with (``summary.json``'s ``settings``; see
        :func:`evtribo.results.check.settings_of`); default: the study's.
    cache_dir : path-like, optional
        The decoded-trial cache.

    Yields
    ------
    TrialFigure
        ``(subject, trial, axes, caption)``; its ``stem`` is ``trial_<subject>_<trial>``. A
        trial that cannot be analysed (or read) gets a figure saying why. Each figure is
        its own (no pyplot state): save it, then let it go.
    """
    study = study_root if isinstance(study_root, Study) else load_study(study_root)
    chosen = settings_of(study, settings)
    for ref in study.trials:
        if subjects is not None and ref.subject not in subjects:
            continue
        try:
            check = check_trial(study, ref.subject, ref.name, settings=chosen,
                                cache_dir=cache_dir)
        except (AnalysisError, UserInputError) as err:
            log.info("%s: no check figure: %s", ref.key, err)  # its figure says why
            yield _failed(ref.subject, ref.name, err)
            continue
        yield TrialFigure(ref.subject, ref.name, draw_trial_check(check), trial_caption(check))
