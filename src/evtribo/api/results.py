"""A study's results from Python: :func:`analyze` (in memory), :meth:`Results.save` (the
result folder of study format §2), :func:`~evtribo.api.load.load_results` (a result folder read
back).

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

import pandas as pd

from evtribo.api.study import Study
from evtribo.documents.result_folder import ResultFolder, folder_summary
from evtribo.documents.schema import csv_exact
from evtribo.documents.tables import (
    COUNT_COLUMNS,
    NEWER_COLUMNS,
    SCHEMAS,
    TEXT_COLUMNS,
    Column,
    Kind,
    TableSchema,
)
from evtribo.errors import UserInputError
from evtribo.results.pipeline import StudyResults, compute_study, write_results
from evtribo.results.workers import ProgressCallback
from evtribo.warning.record import WarningRecord

__all__ = ["COUNT_COLUMNS", "CSV_EXACT", "NEWER_COLUMNS", "TEXT_COLUMNS", "FitView", "Results",
           "analyze", "read_table", "typed_table"]

#: read_csv's options that read back every float to_csv wrote, bit for bit (the columns'
#: kinds and the one typing are :mod:`evtribo.documents.tables`').
CSV_EXACT: dict[str, Any] = csv_exact()


def typed_table(df: pd.DataFrame, text: tuple[str, ...] = TEXT_COLUMNS) -> pd.DataFrame:
    """A result table with the one typing (see the module's notes), each column's kind
    from analyze's tables (:mod:`evtribo.documents.tables`; a column of none: float).

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
    kinds: dict[str, Kind] = {**dict.fromkeys(COUNT_COLUMNS, "count"),
                              **dict.fromkeys(text, "text")}
    columns = tuple(Column(str(c), kinds.get(str(c), "float"), "", "") for c in df.columns)
    return TableSchema("", columns, key=(), required=()).typed(df)


class FitView(Protocol):
    """What :attr:`Results.fit` holds: an :class:`evtribo.api.fit.Fit`, which is made from
    results (its module builds on this one), seen here by what a user reads of it."""

    table: pd.DataFrame
    figures: dict[str, Any]
    population: pd.DataFrame
    out: Path | None


@dataclass(eq=False)
class Results(ResultFolder):
    """A study's results: the tables of study format §2 and ``summary.json``
    (:class:`~evtribo.documents.result_folder.ResultFolder`), which :meth:`save` writes,
    and the model fit.

    Attributes
    ----------
    trials, windows, electrostatic, exponents : pandas.DataFrame
        The tables of ``trials.csv``, ``windows.csv``, ``electrostatic.csv`` and
        ``exponents.csv`` (types in the module's notes).
    summary : Summary
        The content of ``summary.json`` (provenance, settings, warnings, counts), a
        read-only mapping (``dict(results.summary)`` for a dict).
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

    fit: FitView | None = None
    _computed: StudyResults | None = field(default=None, repr=False)

    @property
    def warnings(self) -> list[WarningRecord]:
        """What the analysis found worth saying (``summary.json``'s ``warnings``), as
        records: each with its ``kind``, its ``effect`` on the numbers, its ``text`` and
        where it was said (``scope``); an older result folder's lines lifted into records."""
        return self.summary.warnings

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
            a :attr:`fit` made in memory stays, for :meth:`~evtribo.api.fit.Fit.save`).

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
        self.summary = folder_summary(folder)
        self.out = folder
        self.forget()
        if self.fit is not None and self.fit.out is not None:
            self.fit = None  # its files were another folder's (or removed, as analyze does)
        return folder


def _from_computed(res: StudyResults) -> Results:
    results = Results.in_memory(res.tables, res.summary)
    results._computed = res
    return results


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
        The columns it must have: a table's of :mod:`evtribo.documents.tables` (else the
        table *path* names).

    Returns
    -------
    DataFrame
        Typed as :func:`typed_table` types it.

    Raises
    ------
    UserInputError
        It cannot be read, or a column is missing.
    """
    schema = next((s for s in SCHEMAS.values() if s.names() == tuple(columns)),
                  SCHEMAS[Path(path).name])
    return schema.read(path, complete=True)
