"""The check of each trial among compare's figures: what the analysis did with each trial.

``compare`` draws one figure per trial of the analysed study (kind ``trial``, stem
``trial_<subject>_<trial>``; :mod:`evtribo.figures.trial_plots`) from the sketch ``evtribo
analyze`` kept of it (:func:`evtribo.results.trial_view.kept_sketches`): no trial is read or
analysed again. A trial whose sketch is not kept (a cache cleared, another cache folder,
an analysis of an older evtribo) is analysed again from the study folder, which must then be
there; a trial the analysis could not analyse gets a figure saying why.

Which trials (:data:`WHICH`): ``all``, ``none``, or ``auto`` (the default): every trial of a
study of at most :data:`AUTO_ALL` trials; of a larger one, those with a warning that may
change a number or widens an interval (not one only for information, such as a drift
followed; compare says which) or that the analysis could not analyse, and a note says how
to draw the others.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from evtribo.errors import AnalysisError, UserInputError
from evtribo.figures.trial_plots import trial_stem
from evtribo.fit.tables import ResultTables
from evtribo.results.trial_sketch import TrialSketch
from evtribo.store.pool import Mapper
from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

# the analysis (results.trial_view) and the rig's DBC (evtribo.study) are imported where a trial's
# check needs them: compare starts without them, and a large study's may need none

__all__ = ["AUTO_ALL", "CHECK_DPI", "WHICH", "CheckFigure", "chosen_trials", "parse_which",
           "sketch_again", "trial_checks"]

log = logging.getLogger(__name__)
emit = emitter(__name__)

#: Most resolution of the trial checks' PNGs (and of their rasterised traces in SVG and
#: PDF), dots per inch: figures to look at on a screen, 1033 pixels wide at 175 mm.
CHECK_DPI = 150.0
#: Which trials' checks compare draws.
WHICH = ("auto", "all", "none")
#: A study of at most this many trials gets every trial's check by default (``auto``).
AUTO_ALL = 24


@dataclass(frozen=True)
class CheckFigure:
    """A trial's check to draw: from its sketch, or saying why it was not analysed.

    Attributes
    ----------
    subject, trial : str
        The trial.
    caption : str
        The figure's caption (:func:`~evtribo.figures.trial_plots.trial_caption`).
    sketch : TrialSketch or None
        What the figure draws; None for a trial not analysed.
    error : str or None
        Why the trial was not analysed.
    """

    subject: str
    trial: str
    caption: str
    sketch: TrialSketch | None = None
    error: str | None = None

    @property
    def stem(self) -> str:
        """``trial_<subject>_<trial>`` (:func:`~evtribo.figures.trial_plots.trial_stem`)."""
        return trial_stem(self.subject, self.trial)


def parse_which(which: bool | str | None) -> str:
    """Which trials' checks to draw, as compare's ``trial_checks`` takes it.

    Parameters
    ----------
    which : bool or str or None
        One of :data:`WHICH`; True is ``all``, False ``none``, None ``auto``.

    Returns
    -------
    str

    Raises
    ------
    UserInputError
        Another word (key ``--trial-checks``).
    """
    if which is None or which is True or which is False:
        return {None: "auto", True: "all", False: "none"}[which]
    if str(which) not in WHICH:
        raise UserInputError(f"expected one of {', '.join(WHICH)}, got {which!r}",
                             key="--trial-checks")
    return str(which)


def chosen_trials(tables: ResultTables, which: str, *, flagged: Iterable[str]
                  ) -> tuple[list[tuple[str, str]], list[WarningRecord]]:
    """The trials (of ``trials.csv``, in its order) whose checks to draw, and a note on
    those left out.

    Parameters
    ----------
    tables : ResultTables
        The result folder.
    which : str
        One of :data:`WHICH`.
    flagged : iterable of str
        The trials (``subject/trial``) whose warnings call for a look (``auto`` in a large
        study draws them and the trials not analysed): compare's
        :func:`~evtribo.report.drawing.trials_to_check`.

    Returns
    -------
    (list of (str, str), list of WarningRecord)
        ``(subject, trial)`` of each check to draw; what compare says of those left out
        (made, not said).
    """
    rows = tables.trials
    if which == "none" or rows.empty:
        return [], []
    trials = list(zip(rows["subject"].astype(str), rows["trial"].astype(str), strict=True))
    if which == "all" or len(trials) <= AUTO_ALL:
        return trials, []
    keys = [f"{s}/{t}" for s, t in trials]
    warned = set(flagged) | {str(f.get("trial")) for f in tables.summary.failed_trials}
    chosen = [st for st, k in zip(trials, keys, strict=True) if k in warned]
    note = emit.record("checks-chosen", chosen=len(chosen), trials=len(trials),
                       auto_all=AUTO_ALL)
    return chosen, [note]


def sketch_again(job: tuple[str, str, str, Mapping[str, Any], str | None]) -> bytes | str:
    """A trial analysed again for its check: its sketch's bytes, or why it could not be.

    Parameters
    ----------
    job : tuple
        ``(study folder, subject, trial, settings, cache folder)``; the settings as
        ``summary.json`` gives them.

    Returns
    -------
    bytes or str
        The sketch (:meth:`~evtribo.results.trial_sketch.TrialSketch.to_bytes`), or the error.
    """
    from evtribo.results.trial_view import sketch_of, view_trial

    study, subject, trial, settings, cache_dir = job
    try:
        return sketch_of(view_trial(study, subject, trial, settings=settings,
                                     cache_dir=cache_dir)).to_bytes()
    except (AnalysisError, UserInputError) as err:
        log.info("%s/%s: no check figure: %s", subject, trial, err)  # its figure says why
        return str(err)


def trial_checks(tables: ResultTables, which: str = "auto", *,
                 cache_dir: str | os.PathLike[str] | None = None,
                 mapper: Mapper | None = None, flagged: Iterable[str]
                 ) -> tuple[list[CheckFigure], list[WarningRecord]]:
    """The check of each trial chosen (:func:`chosen_trials`), ready to draw.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables (``summary.json`` names the study and the settings).
    which : str
        One of :data:`WHICH`.
    cache_dir : path-like, optional
        The cache folder the analysis used (default: ``$EVTRIBO_CACHE_DIR`` or
        ``~/.cache/evtribo``).
    mapper : callable, optional
        ``mapper(func, items)``: the results of ``func`` on each item, in order (a pool of
        worker processes); the trials analysed again go through it (default: here).
    flagged : iterable of str
        The trials whose warnings call for a look (:func:`chosen_trials`).

    Returns
    -------
    (list of CheckFigure, list of WarningRecord)
        The checks in ``trials.csv``'s order; what compare says of them, made and not said
        (the study is gone, a trial the analysis analysed could not be checked, the trials
        left out).
    """
    chosen, notes = chosen_trials(tables, which, flagged=flagged)
    if not chosen:
        return [], notes
    from evtribo.figures.trial_plots import trial_caption
    from evtribo.results.trial_view import kept_sketches
    from evtribo.study import load_study

    study_dir = tables.summary.study_dir
    if not study_dir or not Path(study_dir).is_dir():
        return [], [*notes, emit.record("checks-study-gone",
                                        study_dir=study_dir or "(not recorded)")]
    try:
        study = load_study(study_dir)
    except UserInputError as err:  # the study changed since the analysis
        return [], [*notes, emit.record("checks-study-unreadable", error=str(err))]
    kept = kept_sketches(study, tables.summary, cache_dir)
    failed = {str(f.get("trial")): str(f.get("error")) for f in tables.summary.failed_trials}
    again = [(s, t) for s, t in chosen if f"{s}/{t}" not in kept and f"{s}/{t}" not in failed]
    if again:
        log.info("%d trial(s) analysed again for their checks (no sketch kept of them)",
                 len(again))
        jobs = [(os.fspath(study.root), s, t, dict(tables.summary.settings),
                 None if cache_dir is None else os.fspath(cache_dir)) for s, t in again]
        found = (mapper or _here)(sketch_again, jobs)
        for (s, t), got in zip(again, found, strict=True):
            if isinstance(got, bytes):
                kept[f"{s}/{t}"] = TrialSketch.from_bytes(got)
            else:
                failed[f"{s}/{t}"] = got
                notes.append(emit.record("check-not-analysed", Scope(s, t), subject=s,
                                         trial=t, error=got))
    out = []
    for s, t in chosen:
        sketch = kept.get(f"{s}/{t}")
        if sketch is not None:
            out.append(CheckFigure(s, t, trial_caption(sketch), sketch))
        else:
            why = failed.get(f"{s}/{t}", "no sketch")
            out.append(CheckFigure(s, t, f"Trial {s}/{t}: not analysed, so nothing to check: "
                                         f"{why}", error=why))
    return out, notes


def _here(func: Callable[[Any], Any], items: list[Any]) -> list[Any]:
    return [func(item) for item in items]
