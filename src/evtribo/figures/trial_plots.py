"""The check of a trial as a figure: what the analysis used, and what it left out.

One Axes per trial: the normal force and the tangential force (with its sign: it follows
the sliding direction) over time from the trial's start, in mN, as the analysis worked on
them (calibrated, tared, mains hum removed); the ON phases shaded; each steady-sliding
window a thick bar at its mean force over its span, ON and OFF windows apart (colour and
line style, so that they stay apart in greyscale); the finger-lifted stretches where the
zero was read; and, hatched, what no window may use (guard times at ON/OFF switches,
unknown state, the finger leaving or touching down, missing frames, pauses). A researcher
sees at once when the analysis picked the wrong stretches.

A check is drawn from the trial's :class:`~evtribo.results.trial_sketch.TrialSketch`: the one
``evtribo analyze`` kept (:func:`evtribo.results.trial_view.kept_sketches`), or one made from a
new analysis (:func:`~evtribo.results.trial_view.view_trial`, :func:`~evtribo.results.trial_view.
sketch_of`). The traces are rasterised in SVG and PDF (a trial's thousands of points, drawn
at the resolution asked) and the windows are two lines per condition, so that a check is
quick to write and to open.

:func:`trial_check_figures` gives one such figure per trial of a study, with its caption
(stem ``trial_<subject>_<trial>``, see :func:`trial_stem`).
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from evtribo.errors import AnalysisError, UserInputError
from evtribo.results.trial_sketch import MAX_POINTS, STRETCH_LABELS, Stretch, TrialSketch, envelope

if TYPE_CHECKING:
    from evtribo.analysis.settings import AnalysisSettings
    from evtribo.results.trial_view import TrialView
    from evtribo.study import StudyFolder

log = logging.getLogger(__name__)

__all__ = ["MAX_POINTS", "TRIAL_FIGSIZE", "TrialFigure", "draw_failed",
           "draw_trial_check", "envelope", "plot_trial", "trial_caption",
           "trial_check_figures", "trial_stem"]

#: Size of a trial's figure, inches: a journal's double column (175 mm) wide.
TRIAL_FIGSIZE = (6.89, 2.9)

# Okabe-Ito colours: apart for colour-blind readers
_NORMAL, _TANGENTIAL = "#0072B2", "#009E73"
_ON_WINDOW, _OFF_WINDOW = "#D55E00", "#000000"
_ON_SHADE, _LIFT_SHADE = "#F0E442", "#56B4E9"
_TRACE_LW = 0.6
#: One pattern per kind of excluded stretch, each unlike the others (not only its direction).
_HATCH = {"switch": "///", "lift-edge": "ooo", "unknown": "xxx", "hole": "...",
          "pause": "|||"}
#: The forces are drawn in mN.
_MN = 1e3


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


def _as_sketch(check: TrialView | TrialSketch) -> TrialSketch:
    if isinstance(check, TrialSketch):
        return check
    from evtribo.results.trial_view import sketch_of  # the analysis, imported when needed

    return sketch_of(check)


def _spans(ax: Axes, sketch: TrialSketch, stretches: list[Stretch]) -> set[str]:
    """Shade the ON phases, the lifted stretches and what is excluded; the kinds drawn."""
    kinds = set()
    for piece in sketch.pieces:
        for a, b in piece.on:
            ax.axvspan(a, b, color=_ON_SHADE, alpha=0.35, lw=0, zorder=0)
            kinds.add("on")
    for s in stretches:
        if s.kind == "lifted":
            ax.axvspan(s.t_start, s.t_end, color=_LIFT_SHADE, alpha=0.35, lw=0, zorder=0)
        else:
            ax.axvspan(s.t_start, s.t_end, facecolor="none", edgecolor="0.55",
                       hatch=_HATCH[s.kind], lw=0, zorder=0.5)
        kinds.add(s.kind)
    return kinds


def _bars(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segments ``(x0, x1)`` at heights *y* as one line, broken between them."""
    n = x.shape[0]
    xs = np.column_stack([x, np.full(n, np.nan)]).ravel()
    ys = np.column_stack([y, y, np.full(n, np.nan)]).ravel()
    return xs, ys


def _windows(ax: Axes, sketch: TrialSketch) -> set[str]:
    """Each window a thick bar at its mean force (normal, and the friction with the
    stroke's sign) over its span, a tick at each end (windows often follow each other): one
    line per condition and force; the conditions drawn."""
    bars = np.concatenate([p.windows for p in sketch.pieces]) if sketch.pieces else \
        np.empty((0, 4))
    on = np.concatenate([p.window_on for p in sketch.pieces]) if sketch.pieces else \
        np.empty(0, dtype=bool)
    drawn = set()
    for condition, mask in (("on", on), ("off", ~on)):
        if not mask.any():
            continue
        style: dict[str, Any] = {"color": _ON_WINDOW if condition == "on" else _OFF_WINDOW,
                                 "lw": 2.6, "ls": "-" if condition == "on" else (0, (1.2, 0.6)),
                                 "solid_capstyle": "butt", "dash_capstyle": "butt",
                                 "zorder": 4, "marker": "|", "markersize": 7,
                                 "markeredgewidth": 1.0}
        span = bars[mask, :2]
        ax.plot(*_bars(span, bars[mask, 2] * _MN), **style)
        ax.plot(*_bars(span, bars[mask, 3] * _MN), **style)
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


def draw_trial_check(check: TrialView | TrialSketch, ax: Axes | None = None) -> Axes:
    """Draw a trial's check: the forces (mN), the ON phases, the windows, what was left out.

    Parameters
    ----------
    check : TrialView or TrialSketch
        The trial as its analysis saw it (:func:`evtribo.results.trial_view.view_trial`), or
        its sketch (what analyze kept of it).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure, :data:`TRIAL_FIGSIZE`).

    Returns
    -------
    matplotlib.axes.Axes
    """
    sketch = _as_sketch(check)
    ax = ax if ax is not None else _new_axes()
    stretches = sketch.stretches
    kinds = _spans(ax, sketch, stretches)
    for piece in sketch.pieces:
        for y, colour in ((piece.normal, _NORMAL), (piece.tangential, _TANGENTIAL)):
            ax.plot(piece.t, y * _MN, color=colour, lw=_TRACE_LW, zorder=2, rasterized=True)
    conditions = _windows(ax, sketch)
    ax.axhline(0.0, color="0.3", lw=0.5, zorder=1, gid="zero")  # an axis line, not data
    ax.set_xlabel("time from the trial's start (s)")
    ax.set_ylabel("force (mN)")
    spans = [p.span for p in sketch.pieces if np.isfinite(p.span[0])]
    if spans:
        ax.set_xlim(min(0.0, *(a for a, _ in spans)), max(b for _, b in spans))
    _legend(ax, kinds, conditions)
    return ax


def draw_failed(subject: str, trial: str, error: str) -> Axes:
    """The figure of a trial that could not be analysed: why, in words.

    Parameters
    ----------
    subject, trial : str
        The trial.
    error : str
        Why it was not analysed.

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = _new_axes()
    ax.set_axis_off()
    ax.text(0.5, 0.5, f"{subject}/{trial}: not analysed\n{error}", ha="center", va="center",
            wrap=True, transform=ax.transAxes)
    return ax


def _seconds(stretches: list[Stretch], kind: str) -> float:
    return sum(s.t_end - s.t_start for s in stretches if s.kind == kind)


def trial_caption(check: TrialView | TrialSketch) -> str:
    """A caption for a trial's check figure: what it shows, counted.

    Parameters
    ----------
    check : TrialView or TrialSketch
        The trial's check, or its sketch.

    Returns
    -------
    str
    """
    sketch = _as_sketch(check)
    row = sketch.row
    n_on = int(sum(int(p.window_on.sum()) for p in sketch.pieces))
    n_off = int(sum(p.window_on.size for p in sketch.pieces)) - n_on
    drive = (f"{row.get('waveform') or 'unknown waveform'}"
             + (f" {row['frequency_Hz']:g} Hz" if row.get("frequency_Hz") else "")
             + (f" at {row['amplitude_V']:g} V" if row.get("amplitude_V") else ""))
    parts = [f"Trial {sketch.key} ({drive}): normal and tangential force as analysed, in mN "
             f"(tare: {row.get('tare') or 'none'}); ON phases shaded; {n_on} ON and {n_off} "
             "OFF steady-sliding windows, each a bar at its mean force over its span"]
    stretches = sketch.stretches
    lifted = [s for s in stretches if s.kind == "lifted"]
    if lifted:
        parts.append(f"finger lifted (zero read) {len(lifted)} time(s), "
                     f"{_seconds(stretches, 'lifted'):.1f} s")
    left = [f"{STRETCH_LABELS[k]} {_seconds(stretches, k):.2f} s"
            for k in ("switch", "unknown", "lift-edge", "hole", "pause")
            if any(s.kind == k for s in stretches)]
    if left:
        parts.append("excluded (hatched): " + ", ".join(left))
    if not n_on + n_off:
        parts.append("no steady-sliding window was found: this trial gives no estimate")
    return "; ".join(parts) + "."


def plot_trial(study: StudyFolder | str | os.PathLike[str], subject: str, trial: str, *,
               ax: Axes | None = None,
               settings: AnalysisSettings | Mapping[str, Any] | None = None,
               cache_dir: str | os.PathLike[str] | None = None) -> Axes:
    """The check of one trial of a study, drawn: decoded through the cache and analysed
    with the study's settings, as ``evtribo analyze`` does (its windows are those of
    ``windows.csv``).

    Parameters
    ----------
    study : StudyFolder or path-like
        The study, or its folder.
    subject, trial : str
        The trial.
    ax : matplotlib.axes.Axes, optional
        Where to draw (default: a new figure).
    settings : AnalysisSettings or mapping, optional
        The analysis settings (default: the study's; a mapping such as ``summary.json``'s
        ``settings``, see :func:`evtribo.results.trial_view.settings_of`).
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
    from evtribo.results.trial_view import view_trial

    return draw_trial_check(view_trial(study, subject, trial, settings=settings,
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
    """The figure of a trial that could not be analysed, and its caption."""
    return TrialFigure(subject, trial, draw_failed(subject, trial, str(err)),
                       f"Trial {subject}/{trial}: not analysed, so nothing to check: {err}",
                       error=str(err))


def trial_check_figures(study_root: StudyFolder | str | os.PathLike[str],
                        subjects: Sequence[str] | None = None,
                        settings: AnalysisSettings | Mapping[str, Any] | None = None, *,
                        cache_dir: str | os.PathLike[str] | None = None
                        ) -> Iterator[TrialFigure]:
    """The check figure of every trial of a study, one at a time, in the study's order.

    Parameters
    ----------
    study_root : StudyFolder or path-like
        The study, or its folder.
    subjects : sequence of str, optional
        Only these subjects' trials (default: all).
    settings : AnalysisSettings or mapping, optional
        The settings the results were analysed with (``summary.json``'s ``settings``; see
        :func:`evtribo.results.trial_view.settings_of`); default: the study's.
    cache_dir : path-like, optional
        The decoded-trial cache.

    Yields
    ------
    TrialFigure
        ``(subject, trial, axes, caption)``; its ``stem`` is ``trial_<subject>_<trial>``. A
        trial that cannot be analysed (or read) gets a figure saying why. Each figure is
        its own (no pyplot state): save it, then let it go.
    """
    from evtribo.results.trial_view import settings_of, sketch_of, view_trial
    from evtribo.study import StudyFolder, load_study

    study = study_root if isinstance(study_root, StudyFolder) else load_study(study_root)
    chosen = settings_of(study, settings)
    for ref in study.trials:
        if subjects is not None and ref.subject not in subjects:
            continue
        try:
            check = view_trial(study, ref.subject, ref.name, settings=chosen,
                                cache_dir=cache_dir)
        except (AnalysisError, UserInputError) as err:
            log.info("%s: no check figure: %s", ref.key, err)  # its figure says why
            yield _failed(ref.subject, ref.name, err)
            continue
        sketch = sketch_of(check)
        yield TrialFigure(ref.subject, ref.name, draw_trial_check(sketch), trial_caption(sketch))
