"""A study's results from Python: :func:`analyze` (in memory), :meth:`Results.save` (the
result folder of study format §2), :func:`load_results` (a result folder read back).

``evtribo analyze`` runs the same two functions as ``analyze(study).save(out)``:
:func:`evtribo.results.pipeline.compute_study`, then
:func:`evtribo.results.pipeline.write_results`.

The tables have the same columns, in the same order, whether computed or read back, with
one set of types: names (``subject``, ``trial``, ``waveform``, ``condition``, ``tare``) as
Python strings (object columns, NaN where missing), counts (``frames``, ``dropped_frames``,
``skipped_lines``, ``n_on``, ``n_off``, ``replicate``) as nullable integers (``Int64``),
every other column as float64 (NaN where empty in the CSV file).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import pandas as pd

from evtribo.analysis.trial import SINE_TRACE_CSV_COLUMNS, TRIAL_COLUMNS, WINDOW_CSV_COLUMNS
from evtribo.api.study import Study
from evtribo.documents.summary import Summary
from evtribo.errors import UserInputError
from evtribo.fit.tables import read_summary
from evtribo.results.aggregate import BOOTSTRAP_COLUMNS, ELECTROSTATIC_COLUMNS, EXPONENT_COLUMNS
from evtribo.results.outputs import (
    BOOTSTRAP_FILE,
    SINE_TRACE_FILE,
)
from evtribo.results.pipeline import StudyResults, compute_study, write_results
from evtribo.results.workers import ProgressCallback
from evtribo.warning.record import WarningRecord

__all__ = ["COUNT_COLUMNS", "CSV_EXACT", "TEXT_COLUMNS", "FitView", "Results", "analyze",
           "read_table", "typed_table"]

#: Columns of names (strings), and of counts (nullable integers); the others are floats.
TEXT_COLUMNS = ("subject", "trial", "waveform", "condition", "tare", "friction_law")
COUNT_COLUMNS = ("frames", "dropped_frames", "skipped_lines", "n_on", "n_off", "replicate",
                 "duplicate_frames")

#: Columns a result folder written by an earlier version lacks: read as empty.
NEWER_COLUMNS = frozenset({"duplicate_frames", "analysed_s", "excluded_switch_s",
                           "excluded_lift_s", "excluded_unsteady_s", "excluded_other_s",
                           "friction_law", "friction_exponent", "friction_exponent_ci_low",
                           "friction_exponent_ci_high", "electrostatic_force_m075_N",
                           "electrostatic_force_m075_ci_low_N",
                           "electrostatic_force_m075_ci_high_N"})

#: read_csv's options that read back every float to_csv wrote, bit for bit (pandas 3's
#: default parser does; pandas 2's needs its round-trip parser).
CSV_EXACT: dict[str, Any] = ({} if int(pd.__version__.split(".")[0]) >= 3
                             else {"float_precision": "round_trip"})

#: Each table: its file and its columns.
_TABLES: dict[str, tuple[str, tuple[str, ...]]] = {
    "trials": ("trials.csv", TRIAL_COLUMNS),
    "windows": ("windows.csv", WINDOW_CSV_COLUMNS),
    "electrostatic": ("electrostatic.csv", ELECTROSTATIC_COLUMNS),
    "exponents": ("exponents.csv", EXPONENT_COLUMNS),
    "bootstrap": (BOOTSTRAP_FILE, BOOTSTRAP_COLUMNS),
    "sine_trace": (SINE_TRACE_FILE, SINE_TRACE_CSV_COLUMNS),
}


def typed_table(df: pd.DataFrame, text: tuple[str, ...] = TEXT_COLUMNS) -> pd.DataFrame:
    """A result table with the types of this module's tables (see the module's notes).

    Parameters
    ----------
    df : pandas.DataFrame
        A table as computed, or as read from its CSV file.
    text : tuple of str
        The columns of names (default :data:`TEXT_COLUMNS`).

    Returns
    -------
    pandas.DataFrame
        A new table: the same columns and rows, names as str (NaN where missing), counts
        as ``Int64``, the rest as float64.
    """
    out = pd.DataFrame(index=pd.RangeIndex(len(df)))
    for c in df.columns:
        col = df[c].reset_index(drop=True)
        if c in text:
            values = [np.nan if pd.isna(v) else str(v) for v in col.astype(object)]
            out[c] = pd.Series(values, dtype=object)
        elif c in COUNT_COLUMNS:
            out[c] = pd.to_numeric(col, errors="coerce").astype("Int64")
        else:
            out[c] = pd.to_numeric(col.astype(object), errors="coerce").astype("float64")
    return out


class FitView(Protocol):
    """What :attr:`Results.fit` holds: an :class:`evtribo.api.fit.Fit`, which is made from
    results (its module builds on this one), seen here by what a user reads of it."""

    table: pd.DataFrame
    figures: dict[str, Any]
    population: pd.DataFrame
    out: Path | None


@dataclass(eq=False)
class Results:
    """A study's results: the tables of study format §2 and ``summary.json``.

    Attributes
    ----------
    trials, windows, electrostatic, exponents : pandas.DataFrame
        The tables of ``trials.csv``, ``windows.csv``, ``electrostatic.csv`` and
        ``exponents.csv`` (types in the module's notes).
    summary : dict
        The content of ``summary.json``: provenance, settings, warnings, counts.
    bootstrap : pandas.DataFrame or None
        ``electrostatic_bootstrap.csv``: bootstrap replicates of every electrostatic row.
    sine_trace : pandas.DataFrame or None
        ``sine_trace.csv`` (None: no sine trial gave one).
    out : Path or None
        The result folder they were saved to or loaded from (None: in memory only).
    fit : Fit or None
        The model fit (:class:`evtribo.api.fit.Fit`): from :func:`evtribo.compare`, or the
        folder's ``fit.csv`` when it was loaded after ``evtribo compare``.
    """

    trials: pd.DataFrame
    windows: pd.DataFrame
    electrostatic: pd.DataFrame
    exponents: pd.DataFrame
    summary: dict[str, Any]
    bootstrap: pd.DataFrame | None = None
    sine_trace: pd.DataFrame | None = None
    out: Path | None = None
    fit: FitView | None = None
    _computed: StudyResults | None = field(default=None, repr=False)

    @property
    def subjects(self) -> list[str]:
        """The subjects with electrostatic results, in the table's order."""
        return list(dict.fromkeys(self.electrostatic["subject"]))

    @property
    def warnings(self) -> list[WarningRecord]:
        """What the analysis found worth saying (``summary.json``'s ``warnings``), as
        records: each with its ``kind``, its ``effect`` on the numbers, its ``text`` and
        where it was said (``scope``); an older result folder's lines lifted into records."""
        return Summary(dict(self.summary)).warnings

    def __repr__(self) -> str:
        where = "in memory" if self.out is None else f"in {str(self.out)!r}"
        return (f"Results({self.summary.get('study', '')!r}, {where}, "
                f"subjects={self.subjects!r}, {len(self.trials)} trials, "
                f"{len(self.windows)} windows, {len(self.electrostatic)} electrostatic rows, "
                f"{len(self.warnings)} warnings, fit={'yes' if self.fit else 'no'})")

    def save(self, out: str | os.PathLike[str], *, force: bool = False) -> Path:
        """Write the results as ``evtribo analyze --out OUT`` does (the same function).

        The folder is written as one unit (study format §5): under a lock, into a new
        folder beside it, swapped in at the end.

        Parameters
        ----------
        out : path-like
            The result folder (created if needed), outside the study folder.
        force : bool
            Replace the results already in *out*: analyze's, and the fit, figures and
            reports of compare and report (their files only); without it, existing results
            are refused.

        Returns
        -------
        Path
            The folder written (also :attr:`out`; :attr:`summary` becomes what was written;
            a :attr:`fit` made in memory stays, for :meth:`Fit.save`).

        Raises
        ------
        OutputExistsError
            *out* holds results and *force* is False.
        OutputBusyError
            Another process is writing *out*.
        UserInputError
            *out* is inside the study folder, or is a file; or the results were loaded from
            a folder (they are saved already).
        OutputWriteError
            The results could not be written (a full disk); *out* is left as it was.
        """
        if self._computed is None:
            raise UserInputError(
                "these results were read from a result folder, where they are saved already; "
                "copy that folder, or run evtribo.analyze again and save its results",
                path=self.out)
        written = write_results(self._computed, out, force=force)
        folder = Path(out)
        self._computed = written
        self.summary = read_summary(folder).data
        self.out = folder
        if self.fit is not None and self.fit.out is not None:
            self.fit = None  # its files were another folder's (or removed, as analyze does)
        return folder


def _from_computed(res: StudyResults) -> Results:
    return Results(trials=typed_table(res.trials), windows=typed_table(res.windows),
                   electrostatic=typed_table(res.electrostatic),
                   exponents=typed_table(res.exponents), summary=res.summary,
                   bootstrap=None if res.bootstrap is None else typed_table(res.bootstrap),
                   sine_trace=None if res.sine_trace is None else typed_table(res.sine_trace),
                   _computed=res)


def analyze(study: Study | str | os.PathLike[str], *, jobs: int | None = None,
            strict: bool = False, cache_dir: str | os.PathLike[str] | None = None,
            progress: ProgressCallback | None = None, recompute: bool = False,
            **settings: Any) -> Results:
    """Analyse every trial of a study, in memory: nothing is written (but the cache of
    decoded trials and outcomes); :meth:`Results.save` writes the result folder.

    Parameters
    ----------
    study : Study or path-like
        The study (:func:`evtribo.open_study`) or its folder.
    jobs : int, optional
        Worker processes (default: the number of CPUs; 1 works in this process).
    strict : bool
        A damaged line in a log is an error instead of a warning.
    cache_dir : path-like, optional
        Where decoded trials, the inputs' hashes and each trial's outcome are kept
        (default: :func:`evtribo.canlog.cache.default_cache_dir`).
    progress : callable, optional
        Called as ``progress(done, total)`` as trials complete.
    recompute : bool
        Analyse every trial again (by default a trial whose log, sidecar, rig, settings and
        evtribo are those of an outcome the cache kept is not analysed again:
        :mod:`evtribo.results.reuse`).
    **settings
        Analysis settings that take precedence over the study's ``[analysis]`` table, by
        name (``tare="none"``, ``guard_s=0.3``, ``n_boot=500``; every key in
        ``analysis/default.toml``).

    Returns
    -------
    Results
        With :attr:`Results.out` None.

    Raises
    ------
    StudyError, SidecarError, RigConfigError
        The study folder is wrong.
    ConfigError
        An unknown setting or a bad value (naming it).
    LogFormatError
        A damaged line under *strict*.
    """
    source: Any = study._folder if isinstance(study, Study) else study
    return _from_computed(compute_study(source, jobs=jobs, strict=strict, cache_dir=cache_dir,
                                        overrides=settings, progress=progress,
                                        reuse=not recompute))


def read_table(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:
    """A result table as written (names read as text, only empty cells missing).

    Parameters
    ----------
    path : Path
        The CSV table.
    columns : tuple of str
        The columns it must have.

    Returns
    -------
    DataFrame
        Typed as :func:`typed_table` types it.

    Raises
    ------
    UserInputError
        It cannot be read, or a column is missing.
    """
    try:
        raw = pd.read_csv(path, dtype=dict.fromkeys(TEXT_COLUMNS, str), keep_default_na=False,
                          na_values=[""], **CSV_EXACT)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise UserInputError(f"cannot read this CSV table: {err}", path=path) from err
    for c in NEWER_COLUMNS & set(columns) - set(raw.columns):  # a folder written before
        raw[c] = pd.NA
    missing = [c for c in columns if c not in raw.columns]
    if missing:
        raise UserInputError(f"missing column(s) {', '.join(missing)}: not a table evtribo "
                             "analyze wrote", path=path, key=missing[0])
    return typed_table(raw)
