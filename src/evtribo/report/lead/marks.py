"""The cells of electrostatic.csv each warning touches: a cell's own warnings, its
subject's, those of the trials that measured it (a whole-OFF trial gave every cell of its
subject its references), and the study's (every cell). The comparison's warnings
(:data:`~evtribo.warning.kinds_compare.COMPARE_IDS`: the fit's, the population's) touch
none: they concern what was estimated from the cells, not the cells."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import pandas as pd

from evtribo.report.lead.scope import study_cells
from evtribo.util.numbers import to_float
from evtribo.warning.kinds_compare import COMPARE_IDS
from evtribo.warning.record import Scope
from evtribo.warning.render import WarningGroup

__all__ = ["FLAGGING", "Marks", "cell_marks", "warning_anchor"]

#: The effects of a warning that flag the cells it touches.
FLAGGING = ("number", "interval")


def warning_anchor(k: int) -> str:
    """The id of the *k*-th warning kind on the page (1-based): ``w1``.

    Parameters
    ----------
    k : int

    Returns
    -------
    str
    """
    return f"w{k}"


def _trial_cells(trials: pd.DataFrame) -> dict[tuple[str, str], Scope]:
    """The cell each trial measured: its drive at its amplitude (a whole-OFF trial: every
    cell of its subject, whose references it gave)."""
    out = {}
    for r in trials.to_dict("records"):
        subject, trial = str(r.get("subject")), str(r.get("trial"))
        amp = to_float(r.get("amplitude_V"))
        if str(r.get("condition", "")).lower() == "off" or not math.isfinite(amp):
            out[(subject, trial)] = Scope(subject)
            continue
        wave = r.get("waveform")
        freq = to_float(r.get("frequency_Hz"))
        out[(subject, trial)] = Scope(subject, None, None if not isinstance(wave, str) else wave,
                                      freq if math.isfinite(freq) else None, amp)
    return out


@dataclass
class Marks:
    """The warnings that touch each cell of electrostatic.csv, and those that touch all."""

    by_row: list[list[int]]
    everywhere: list[int] = field(default_factory=list)


def cell_marks(electrostatic: pd.DataFrame, trials: pd.DataFrame,
               groups: Sequence[WarningGroup]) -> Marks:
    """Which warnings (by their 1-based place in *groups*) touch each cell.

    Parameters
    ----------
    electrostatic : DataFrame
        electrostatic.csv.
    trials : DataFrame
        trials.csv.
    groups : sequence of WarningGroup
        The warnings, grouped (:func:`~evtribo.warning.render.group`); only
        those whose effect is in :data:`FLAGGING` mark a cell.

    Returns
    -------
    Marks
        ``by_row``: per row of *electrostatic*, the warnings touching it (none of those that
        touch every row, which are ``everywhere``).
    """
    cells = study_cells(electrostatic.to_dict("records"))
    per_trial = _trial_cells(trials)
    by_row: list[list[int]] = [[] for _ in cells]
    everywhere = []
    for k, g in enumerate(groups, start=1):
        if g.effect not in FLAGGING or g.kind in COMPARE_IDS:
            continue
        touched = g.touches(per_trial)
        hit = [(g.study and not touched) or any(
            t.holds(c.subject, c.waveform or "", c.frequency_Hz or math.nan,
                    c.amplitude_V or math.nan) or _any_drive(t, c) for t in touched)
            for c in cells]
        if cells and all(hit):
            everywhere.append(k)
            continue
        for row, h in zip(by_row, hit, strict=True):
            if h:
                row.append(k)
    return Marks(by_row, everywhere)


def _any_drive(touch: Scope, cell: Scope) -> bool:
    """A touch naming no waveform, frequency or amplitude of its own holds every cell of its
    subject; one whose waveform or frequency is unknown holds the cells of that amplitude."""
    if touch.subject != cell.subject:
        return False
    return ((touch.waveform is None or cell.waveform is None or touch.waveform == cell.waveform)
            and (touch.frequency_Hz is None or cell.frequency_Hz is None
                 or math.isclose(touch.frequency_Hz, cell.frequency_Hz))
            and (touch.amplitude_V is None or cell.amplitude_V is None
                 or math.isclose(touch.amplitude_V, cell.amplitude_V)))


