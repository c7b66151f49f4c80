"""What a result folder's warnings can concern: its trials and its cells (a subject's drive
at one amplitude, a :class:`~evtribo.warning.record.Scope`), read with the standard library
alone (the console of ``evtribo analyze`` imports nothing heavy for them;
:mod:`evtribo.warning.render` says where each kind of warning was said by them)."""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from typing import Any

from evtribo.documents.tables import ELECTROSTATIC, TRIALS
from evtribo.warning.record import Scope

__all__ = ["read_scope", "study_cells"]


def study_cells(rows: Iterable[Mapping[Any, Any]]) -> list[Scope]:
    """The cells of electrostatic.csv's rows.

    Parameters
    ----------
    rows : iterable of mapping
        Rows with ``subject``, ``waveform``, ``frequency_Hz`` and ``amplitude_V``.

    Returns
    -------
    list of Scope
        Each a subject's drive at one amplitude.
    """
    out = []
    for r in rows:
        wave = r.get("waveform")
        freq, amp = _number(r.get("frequency_Hz")), _number(r.get("amplitude_V"))
        out.append(Scope(str(r.get("subject")), None,
                         None if wave in (None, "") or _missing(wave) else str(wave), freq, amp))
    return out


def _missing(value: object) -> bool:
    return isinstance(value, float) and math.isnan(value)


def _number(value: object) -> float | None:
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def read_scope(folder: str | os.PathLike[str]) -> tuple[list[tuple[str, str]], list[Scope]]:
    """A result folder's trials (trials.csv) and cells (electrostatic.csv), read with the
    standard library (the console of ``evtribo analyze`` imports nothing heavy for it).

    Parameters
    ----------
    folder : path-like
        The result folder.

    Returns
    -------
    (list of (str, str), list of Scope)
        Empty where a table is missing or unreadable.
    """
    trials = [(r.get("subject", ""), r.get("trial", "")) for r in TRIALS.rows(folder)]
    return trials, study_cells(ELECTROSTATIC.rows(folder))
