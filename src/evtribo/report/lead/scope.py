"""What a result folder's warnings can concern: its trials and its cells (a subject's drive
at one amplitude), read with the standard library alone (the console of ``evtribo analyze``
imports nothing heavy for them; :mod:`evtribo.report.lead.warning_kinds` groups the
warnings by them)."""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from evtribo.documents.tables import ELECTROSTATIC, TRIALS

__all__ = ["Cell", "read_scope", "study_cells"]


@dataclass(frozen=True)
class Cell:
    """A cell of the headline tables: a subject's drive at one amplitude (None: any)."""

    subject: str
    waveform: str | None = None
    frequency_Hz: float | None = None
    amplitude_V: float | None = None

    def holds(self, subject: str, waveform: str, frequency_Hz: float,
              amplitude_V: float) -> bool:
        """Whether the cell (with None for any) is this subject's drive at this amplitude.

        Parameters
        ----------
        subject, waveform : str
        frequency_Hz : float, Hz
        amplitude_V : float, V

        Returns
        -------
        bool
        """
        return (self.subject == subject
                and (self.waveform is None or self.waveform == waveform)
                and (self.frequency_Hz is None or _same(self.frequency_Hz, frequency_Hz))
                and (self.amplitude_V is None or _same(self.amplitude_V, amplitude_V)))


def _same(a: float, b: float) -> bool:
    return abs(float(a) - float(b)) <= 1e-6 * max(1.0, abs(float(a)))


def study_cells(rows: Iterable[Mapping[Any, Any]]) -> list[Cell]:
    """The cells of electrostatic.csv's rows.

    Parameters
    ----------
    rows : iterable of mapping
        Rows with ``subject``, ``waveform``, ``frequency_Hz`` and ``amplitude_V``.

    Returns
    -------
    list of Cell
    """
    out = []
    for r in rows:
        wave = r.get("waveform")
        freq, amp = _number(r.get("frequency_Hz")), _number(r.get("amplitude_V"))
        out.append(Cell(str(r.get("subject")), None if wave in (None, "") else str(wave),
                        freq, amp))
    return out


def _number(value: object) -> float | None:
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def read_scope(folder: str | os.PathLike[str]) -> tuple[list[tuple[str, str]], list[Cell]]:
    """A result folder's trials (trials.csv) and cells (electrostatic.csv), read with the
    standard library (the console of ``evtribo analyze`` imports nothing heavy for it).

    Parameters
    ----------
    folder : path-like
        The result folder.

    Returns
    -------
    (list of (str, str), list of Cell)
        Empty where a table is missing or unreadable.
    """
    trials = [(r.get("subject", ""), r.get("trial", "")) for r in TRIALS.rows(folder)]
    return trials, study_cells(ELECTROSTATIC.rows(folder))
