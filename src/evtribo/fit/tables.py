"""Reading the result folder written by ``evtribo analyze`` (study-format §2).

Only the columns the comparison needs are checked; extra columns are kept and ignored.
A missing folder, a missing required table or a missing column is the user's to fix, so it
raises :class:`evtribo.errors.UserInputError` naming the file and the column.

Besides the §2 tables the comparison reads an optional ``sine_trace.csv``: the raw signals of
one sine trial, for the friction-versus-time figure (the seed paper's Figure 5). Its columns:

====================  ==========================================================
``time_s``            seconds from the start of the trace
``normal_force_N``    normal force, N
``friction_force_N``  friction (tangential) force magnitude, N
``voltage_V``         instantaneous applied voltage U(t), V (0 while OFF); or, when the
                      rig only reports the drive's settings, ``amplitude_V`` (0 while OFF)
                      and ``frequency_Hz``: the sine's phase is then taken as the one that
                      best matches the measured friction (friction oscillates at twice the
                      drive frequency, so the phase is known modulo pi, which is all the
                      model needs)
``subject``           optional: whose trace it is (else the first subject)
``trial``             optional: the trial's name
====================  ==========================================================

It also reads an optional ``electrostatic_bootstrap.csv`` (written by ``evtribo analyze``
next to electrostatic.csv; columns :data:`BOOTSTRAP_COLUMNS`): bootstrap replicates of every
electrostatic.csv row, replicate ``i`` of one subject's rows coming from one resampling of
its windows. :mod:`evtribo.fit.fit` refits the model to them for its intervals, and falls
back to the Jacobian when the file is absent.

A result folder is read only if it is one analysis's complete results: ``summary.json``
present and whole, and every table the SHA-256 ``summary.json`` records for it
(``output_sha256``, under the analysis's ``run_id``), with no table of another analysis
beside them. Anything else (a file changed, missing or half-written, a mix of two analyses)
raises :class:`~evtribo.errors.ResultFolderError` naming the file. Result folders of an older
evtribo, without a ``run_id``, are read as they are.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from evtribo.documents.summary import SUMMARY_FILE, Summary
from evtribo.documents.summary import read_summary as document_summary
from evtribo.errors import FORCE, ResultFolderError, UserInputError
from evtribo.results.outputs import ANALYSIS_FILES
from evtribo.store.files import sha256_file
from evtribo.store.resultdir import locked, pending, recover

log = logging.getLogger(__name__)

__all__ = ["BOOTSTRAP_COLUMNS", "BOOTSTRAP_CSV", "MIN_REPLICATES", "REQUIRED_COLUMNS",
           "SINE_TRACE_COLUMNS", "ResultTables", "check_analysis", "read_results",
           "read_summary", "replicate_matrix"]

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

#: The optional table of bootstrap replicates of electrostatic.csv, and its columns.
BOOTSTRAP_CSV = "electrostatic_bootstrap.csv"
BOOTSTRAP_COLUMNS: tuple[str, ...] = ("subject", "waveform", "amplitude_V", "replicate",
                                      "electrostatic_force_N")

#: Fewest replicates :func:`replicate_matrix` accepts.
MIN_REPLICATES = 20

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
    summary : Summary
        ``summary.json`` (empty when absent).
    sine_trace : DataFrame or None
        ``sine_trace.csv`` when present.
    bootstrap : DataFrame or None
        ``electrostatic_bootstrap.csv`` when present.
    """

    out: Path
    electrostatic: pd.DataFrame
    windows: pd.DataFrame
    exponents: pd.DataFrame
    trials: pd.DataFrame
    summary: Summary = field(default_factory=Summary)
    sine_trace: pd.DataFrame | None = None
    bootstrap: pd.DataFrame | None = None

    @property
    def subjects(self) -> list[str]:
        """Subjects with electrostatic results, in the table's order."""
        return list(dict.fromkeys(self.electrostatic["subject"]))

    @property
    def all_subjects(self) -> list[str]:
        """Every subject the results hold: those with electrostatic results, then those with
        windows only (a subject of OFF trials), then those whose trials gave none."""
        return list(dict.fromkeys([*self.subjects, *self.windows["subject"].astype(str),
                                   *self.trials.get("subject", pd.Series(dtype=str))
                                   .astype(str)]))


def _read_csv(path: Path, required: tuple[str, ...]) -> pd.DataFrame:
    try:
        table = pd.read_csv(path, dtype={"subject": str, "trial": str})
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise UserInputError(f"cannot read this CSV table: {err}", path=path) from err
    except PermissionError as err:
        raise ResultFolderError(f"cannot read: {err.strerror}", path=path) from None
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise UserInputError(
            f"missing column(s) {', '.join(missing)}; the file has: "
            f"{', '.join(map(str, table.columns))}", path=path, key=missing[0])
    return table


def _sha256(path: Path) -> str:
    """A result file's SHA-256; one the user may not read is refused by name."""
    try:
        return sha256_file(path, ResultFolderError, what="result file")
    except PermissionError as err:
        raise ResultFolderError(f"cannot read: {err.strerror}", path=path) from None


def check_out_folder(out: str | Path) -> Path:
    """Return *out* as a Path, or raise UserInputError if it is not an existing folder."""
    path = Path(out)
    if not path.is_dir():
        raise UserInputError("no such result folder (run `evtribo analyze STUDY --out OUT` "
                             "first)", path=path)
    return path


def _again(folder: Path, summary: Summary) -> str:
    study = summary.study_dir
    return f"run `evtribo analyze {study or 'STUDY'} --out " \
           f"{folder} {FORCE}` again"


def read_summary(folder: Path) -> Summary:
    """``summary.json`` of a result folder (empty when the folder holds no analysis at all).

    Parameters
    ----------
    folder : Path
        The result folder.

    Returns
    -------
    Summary
        Read by :func:`evtribo.documents.summary.read_summary`.

    Raises
    ------
    ResultFolderError
        summary.json is not whole, or is missing beside tables of an analysis.
    """
    path = folder / SUMMARY_FILE
    if not path.is_file():
        present = [n for n in ANALYSIS_FILES if (folder / n).is_file()]
        if present:
            raise ResultFolderError(
                f"missing beside {', '.join(present)}: the folder does not hold an "
                "analysis's complete results (one that was interrupted?); run `evtribo "
                f"analyze STUDY --out {folder} {FORCE}` again", path=path)
        return Summary()
    return document_summary(path, again=f"; run `evtribo analyze STUDY --out {folder} "
                                        f"{FORCE}` again")


def check_analysis(folder: Path, summary: Summary | Mapping[str, Any]) -> None:
    """Refuse a folder whose tables are not those of the analysis *summary* describes.

    Parameters
    ----------
    folder : Path
        The result folder.
    summary : Summary or mapping
        Its ``summary.json`` (as read, or as the JSON object).

    Raises
    ------
    ResultFolderError
        Naming the first table missing, changed (or half-written), or of another analysis.
    """
    if not isinstance(summary, Summary):
        summary = Summary(dict(summary), folder / SUMMARY_FILE)
    run_id = summary.run_id
    hashes = summary.output_sha256
    if run_id is None or hashes is None:
        return  # results of an older evtribo: nothing to check them against
    for name in ANALYSIS_FILES:
        path = folder / name
        if name in hashes:
            if not path.is_file():
                raise ResultFolderError(
                    f"missing: the folder holds part of analysis {run_id}'s results only; "
                    f"{_again(folder, summary)}", path=path)
            if _sha256(path) != hashes[name]:
                raise ResultFolderError(
                    f"not the file analysis {run_id} wrote (its SHA-256 differs from the one "
                    "in summary.json: changed since, half-written, or of another analysis); "
                    f"{_again(folder, summary)}", path=path)
        elif name != SUMMARY_FILE and path.exists():
            raise ResultFolderError(
                f"not written by analysis {run_id} (summary.json does not list it): a file of "
                f"another analysis; {_again(folder, summary)}", path=path)


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
        When the folder, ``electrostatic.csv`` or ``windows.csv`` is missing, a table lacks
        a required column, or no trial gave a window (results without electrostatic forces
        are read: a study of OFF trials has each subject's μ to report).
    ResultFolderError
        When the folder is not one analysis's complete results (see the module's notes).
    OutputBusyError
        When another process is writing the folder.
    """
    folder = check_out_folder(out)
    if pending(folder):  # a write that was interrupted after its commit: finish it first
        with locked(folder, "evtribo (reading results)"):
            recover(folder)
    summary = read_summary(folder)
    check_analysis(folder, summary)
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
    if tables["electrostatic.csv"].empty and tables["windows.csv"].empty:
        raise UserInputError("no steady-sliding window in any trial (summary.json says "
                             "why): nothing to compare or report", path=folder / "windows.csv")
    trace = None
    trace_path = folder / "sine_trace.csv"
    if trace_path.is_file():
        trace = _read_csv(trace_path, SINE_TRACE_COLUMNS)
        if "voltage_V" not in trace.columns:
            _read_csv(trace_path, (*SINE_TRACE_COLUMNS, "amplitude_V", "frequency_Hz"))
    boot = None
    boot_path = folder / BOOTSTRAP_CSV
    if boot_path.is_file():
        boot = _read_csv(boot_path, BOOTSTRAP_COLUMNS)
    return ResultTables(out=folder, electrostatic=tables["electrostatic.csv"],
                        windows=tables["windows.csv"], exponents=tables["exponents.csv"],
                        trials=tables["trials.csv"], summary=summary, sine_trace=trace,
                        bootstrap=boot)


def replicate_matrix(rows: pd.DataFrame, bootstrap: pd.DataFrame | None,
                     max_replicates: int = 200) -> NDArray[np.float64] | None:
    """The bootstrap replicates of *rows*' forces as a matrix (None when some row has none).

    Parameters
    ----------
    rows : DataFrame
        One subject's rows of ``electrostatic.csv``.
    bootstrap : DataFrame or None
        The subject's rows of ``electrostatic_bootstrap.csv``.
    max_replicates : int
        Replicates kept (the first ones).

    Returns None as well with fewer than :data:`MIN_REPLICATES` complete replicates, and
    when two rows share a waveform, frequency and amplitude (their replicates cannot be told
    apart).

    Returns
    -------
    ndarray, shape (n_replicates, len(rows)), N, or None
    """
    if bootstrap is None or bootstrap.empty or rows.empty:
        return None

    def keys(df: pd.DataFrame) -> pd.MultiIndex:
        freq = (df["frequency_Hz"].to_numpy(float) if "frequency_Hz" in df.columns
                else np.full(len(df), np.nan))  # a row per frequency, each its replicates
        return pd.MultiIndex.from_arrays(
            [df["waveform"].fillna("").astype(str).to_numpy(),
             np.nan_to_num(np.round(freq, 6), nan=-1.0),
             np.round(df["amplitude_V"].to_numpy(float), 6)])

    boot = bootstrap.assign(_key=keys(bootstrap))
    wide = boot.pivot_table(index="replicate", columns="_key",
                            values="electrostatic_force_N", aggfunc="first")
    want = list(keys(rows))
    if len(set(want)) < len(want) or any(k not in wide.columns for k in want):
        return None
    mat = wide[want].to_numpy(float)
    mat = mat[np.all(np.isfinite(mat), axis=1)][:max_replicates]
    return mat if mat.shape[0] >= MIN_REPLICATES else None
