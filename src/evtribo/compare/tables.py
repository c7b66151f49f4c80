"""Reading the result folder written by ``evtribo analyze`` (study-format §2).

Only the columns the comparison needs are checked; extra columns are kept and ignored.
A missing folder, a missing required table or a missing column is the user's to fix, so it
raises :class:`evtribo.errors.UserInputError` naming the file and the column.

Besides the §2 tables the comparison reads an optional ``sine_trace.csv``: the raw signals of
one sine trial, for the friction-versus-time figure (the seed paper's Figure 5). Its columns:

=================  ==========================================================
``time_s``         seconds from the start of the trace
``normal_force_N`` normal force, N
``friction_force_N`` friction (tangential) force magnitude, N
``voltage_V``      instantaneous applied voltage U(t), V (0 while OFF); or, when the
                   rig only reports the drive's settings, ``amplitude_V`` (0 while OFF)
                   and ``frequency_Hz``: the sine's phase is then taken as the one that
                   best matches the measured friction (friction oscillates at twice the
                   drive frequency, so the phase is known modulo pi, which is all the
                   model needs)
``subject``        optional: whose trace it is (else the first subject)
``trial``          optional: the trial's name
=================  ==========================================================
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo.errors import UserInputError

log = logging.getLogger(__name__)

__all__ = ["REQUIRED_COLUMNS", "SINE_TRACE_COLUMNS", "ResultTables", "read_results"]

#: Columns each table must have for the comparison (study-format §2).
REQUIRED_COLUMNS: dict[str, tuple[str, ...]] = {
    "electrostatic.csv": ("subject", "waveform", "amplitude_V", "mu", "normal_force_on_N",
                          "electrostatic_force_N", "electrostatic_force_ci_low_N",
                          "electrostatic_force_ci_high_N"),
    "windows.csv": ("subject", "trial", "condition", "amplitude_V", "waveform",
                    "normal_force_N", "friction_force_N"),
    "exponents.csv": ("subject", "waveform", "exponent", "exponent_ci_low",
                      "exponent_ci_high"),
    "trials.csv": ("subject", "trial"),
}

#: Columns ``sine_trace.csv`` must have (plus ``voltage_V``, or ``amplitude_V`` and
#: ``frequency_Hz``).
SINE_TRACE_COLUMNS: tuple[str, ...] = ("time_s", "normal_force_N", "friction_force_N")

_OPTIONAL = frozenset({"exponents.csv", "trials.csv"})


@dataclass
class ResultTables:
    """The tables of one result folder, as pandas DataFrames.

    Attributes
    ----------
    out : Path
        The folder.
    electrostatic, windows : DataFrame
        The required tables.
    exponents, trials : DataFrame
        Empty (with the required columns) when the file is absent.
    summary : dict
        ``summary.json`` (empty when absent).
    sine_trace : DataFrame or None
        ``sine_trace.csv`` when present.
    """

    out: Path
    electrostatic: pd.DataFrame
    windows: pd.DataFrame
    exponents: pd.DataFrame
    trials: pd.DataFrame
    summary: dict[str, Any] = field(default_factory=dict)
    sine_trace: pd.DataFrame | None = None

    @property
    def subjects(self) -> list[str]:
        """Subjects with electrostatic results, in the table's order."""
        return list(dict.fromkeys(self.electrostatic["subject"]))


def _read_csv(path: Path, required: tuple[str, ...]) -> pd.DataFrame:
    try:
        table = pd.read_csv(path, dtype={"subject": str, "trial": str})
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise UserInputError(f"cannot read this CSV table: {err}", path=path) from err
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise UserInputError(
            f"missing column(s) {', '.join(missing)}; the file has: "
            f"{', '.join(map(str, table.columns))}", path=path, key=missing[0])
    return table


def check_out_folder(out: str | Path) -> Path:
    """Return *out* as a Path, or raise UserInputError if it is not an existing folder."""
    path = Path(out)
    if not path.is_dir():
        raise UserInputError("no such result folder (run `evtribo analyze STUDY --out OUT` "
                             "first)", path=path)
    return path


def read_results(out: str | Path) -> ResultTables:
    """Read the tables of a result folder.

    Parameters
    ----------
    out : str or Path
        Folder written by ``evtribo analyze``.

    Returns
    -------
    ResultTables

    Raises
    ------
    UserInputError
        When the folder, ``electrostatic.csv`` or ``windows.csv`` is missing, or a table
        lacks a required column.
    """
    folder = check_out_folder(out)
    tables: dict[str, pd.DataFrame] = {}
    for name, required in REQUIRED_COLUMNS.items():
        path = folder / name
        if not path.is_file():
            if name in _OPTIONAL:
                log.info("%s: absent; continuing without it", path)
                tables[name] = pd.DataFrame(columns=list(required))
                continue
            raise UserInputError("required result table not found (run `evtribo analyze` "
                                 "first)", path=path)
        tables[name] = _read_csv(path, required)
    if tables["electrostatic.csv"].empty:
        raise UserInputError("no electrostatic results (no ON data?): nothing to compare",
                             path=folder / "electrostatic.csv")
    summary: dict[str, Any] = {}
    summary_path = folder / "summary.json"
    if summary_path.is_file():
        try:
            loaded = json.loads(summary_path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as err:
            raise UserInputError(f"not valid JSON: {err}", path=summary_path) from err
        summary = loaded if isinstance(loaded, dict) else {"summary": loaded}
    trace = None
    trace_path = folder / "sine_trace.csv"
    if trace_path.is_file():
        trace = _read_csv(trace_path, SINE_TRACE_COLUMNS)
        if "voltage_V" not in trace.columns:
            _read_csv(trace_path, (*SINE_TRACE_COLUMNS, "amplitude_V", "frequency_Hz"))
    return ResultTables(out=folder, electrostatic=tables["electrostatic.csv"],
                        windows=tables["windows.csv"], exponents=tables["exponents.csv"],
                        trials=tables["trials.csv"], summary=summary, sine_trace=trace)
