"""The check of every trial in compare's figures: what the analysis did with each trial.

``compare`` draws one figure per trial of the analysed study (kind ``trial``, stem
``trial_<subject>_<trial>``; :mod:`evtribo.figures.trial_plots`) when the study folder that
``summary.json`` names is still there, and says so in its notes when it is not.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from evtribo.errors import UserInputError
from evtribo.fit.tables import ResultTables

__all__ = ["CHECK_DPI", "write_trial_checks"]

log = logging.getLogger(__name__)

#: Resolution of the trial checks' PNGs: figures to look at, not to print.
CHECK_DPI = 150.0


def write_trial_checks(tables: ResultTables, emit: Callable[..., None],
                       formats: tuple[str, ...],
                       progress: Callable[[str], None] | None = None) -> list[str]:
    """Draw the check of every trial of the analysed study and write it through *emit*.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables (``summary.json`` names the study and the settings).
    emit : callable
        ``emit(ax, kind, title, stem, *, subject, caption, extra, formats, dpi)``, which
        writes one figure and records it.
    formats : tuple of str
        The figure formats asked for; the checks are written as PNG (at :data:`CHECK_DPI`)
        when PNG is among them, else in the first.
    progress : callable, optional
        Told ``"[k/n] check of SUBJECT/TRIAL"`` after each trial's figure.

    Returns
    -------
    list of str
        Notes for the user (the study is gone, a trial the analysis analysed could not be
        checked); a trial the analysis could not analyse is said by its figure alone.
    """
    from evtribo.figures.trial_plots import trial_check_figures

    study_dir = tables.summary.study_dir
    if not study_dir or not Path(study_dir).is_dir():
        return [f"The study folder {study_dir or '(not recorded)'} is not there: no check "
                "figures of the trials (run compare where the study is)."]
    fmt = ("png",) if "png" in formats else formats[:1]
    notes: list[str] = []
    failed = {str(f.get("trial")) for f in tables.summary.failed_trials}
    try:
        checks = trial_check_figures(study_dir, tables.all_subjects,
                                     tables.summary.settings)
        total = len(tables.trials) if not tables.trials.empty else None
        for k, f in enumerate(checks, start=1):
            if progress is not None:
                progress(f"[{k}/{total or '?'}] check of {f.subject}/{f.trial}")
            if f.error is not None and f"{f.subject}/{f.trial}" not in failed:
                notes.append(f.caption)  # not said by the analysis: the study changed since
            emit(f.axes, "trial", f"{f.subject} / {f.trial}", f.stem, subject=f.subject,
                 caption=f.caption, extra={"trial": f.trial}, formats=fmt, dpi=CHECK_DPI)
            _close(f.axes)
    except UserInputError as err:  # the study changed since the analysis
        notes.append(f"No check figures of the trials: {err}")
    return notes


def _close(ax: Any) -> None:
    """Let a drawn figure go (the figures are pyplot-free, but drop their canvas)."""
    ax.figure.clear()
