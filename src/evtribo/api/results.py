"""A study's results from Python: :func:`analyze` (in memory), :meth:`Results.save` (the
result folder of study format §2), :func:`load_results` (a result folder read back).

``evtribo analyze`` runs the same two functions as ``analyze(study).save(out)``:
:func:`evtribo.analysis.pipeline.compute_study`, then
:func:`evtribo.analysis.pipeline.write_results`.

The tables have the same columns, in the same order, whether computed or read back, with
one set of types: names (``subject``, ``trial``, ``waveform``, ``condition``, ``tare``) as
Python strings (object columns, NaN where missing), counts (``frames``, ``dropped_frames``,
``skipped_lines``, ``n_on``, ``n_off``, ``replicate``) as nullable integers (``Int64``),
every other column as float64 (NaN where empty in the CSV file).
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from evtribo.analysis.aggregate import BOOTSTRAP_COLUMNS, ELECTROSTATIC_COLUMNS, EXPONENT_COLUMNS
from evtribo.analysis.outputs import (
    BOOTSTRAP_FILE,
    FIT_CSV,
    FIT_JSON,
    SINE_TRACE_FILE,
    SUMMARY_FILE,
)
from evtribo.analysis.pipeline import StudyResults, compute_study, write_results
from evtribo.analysis.trial import SINE_TRACE_CSV_COLUMNS, TRIAL_COLUMNS, WINDOW_CSV_COLUMNS
from evtribo.analysis.workers import ProgressCallback
from evtribo.api.study import Study
from evtribo.compare.tables import check_analysis, check_out_folder, read_summary
from evtribo.documents.fit import read_fit
from evtribo.errors import UserInputError
from evtribo.files import sha256_file
from evtribo.resultdir import locked, pending, recover

if TYPE_CHECKING:
    from evtribo.api.fit import Fit

__all__ = ["COUNT_COLUMNS", "CSV_EXACT", "TEXT_COLUMNS", "Results", "analyze", "load_results",
           "typed_table"]

#: Columns of names (strings), and of counts (nullable integers); the others are floats.
TEXT_COLUMNS = ("subject", "trial", "waveform", "condition", "tare")
COUNT_COLUMNS = ("frames", "dropped_frames", "skipped_lines", "n_on", "n_off", "replicate")

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
        The model fit: from :func:`evtribo.compare`, or the folder's ``fit.csv`` when it
        was loaded after ``evtribo compare``.
    """

    trials: pd.DataFrame
    windows: pd.DataFrame
    electrostatic: pd.DataFrame
    exponents: pd.DataFrame
    summary: dict[str, Any]
    bootstrap: pd.DataFrame | None = None
    sine_trace: pd.DataFrame | None = None
    out: Path | None = None
    fit: Fit | None = None
    _computed: StudyResults | None = field(default=None, repr=False)

    @property
    def subjects(self) -> list[str]:
        """The subjects with electrostatic results, in the table's order."""
        return list(dict.fromkeys(self.electrostatic["subject"]))

    @property
    def warnings(self) -> list[str]:
        """What the analysis found worth saying (``summary.json``'s ``warnings``)."""
        return list(self.summary.get("warnings") or [])

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
        (default: :func:`evtribo.cache.default_cache_dir`).
    progress : callable, optional
        Called as ``progress(done, total)`` as trials complete.
    recompute : bool
        Analyse every trial again (by default a trial whose log, sidecar, rig, settings and
        evtribo are those of an outcome the cache kept is not analysed again:
        :mod:`evtribo.analysis.reuse`).
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


def _read_table(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:
    """A result table as written (names read as text, only empty cells missing)."""
    try:
        raw = pd.read_csv(path, dtype=dict.fromkeys(TEXT_COLUMNS, str), keep_default_na=False,
                          na_values=[""], **CSV_EXACT)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise UserInputError(f"cannot read this CSV table: {err}", path=path) from err
    missing = [c for c in columns if c not in raw.columns]
    if missing:
        raise UserInputError(f"missing column(s) {', '.join(missing)}: not a table evtribo "
                             "analyze wrote", path=path, key=missing[0])
    return typed_table(raw)


def load_results(out: str | os.PathLike[str]) -> Results:
    """Read a result folder written by ``evtribo analyze`` (or :meth:`Results.save`).

    Parameters
    ----------
    out : path-like
        The result folder.

    Returns
    -------
    Results
        The same tables as :func:`analyze` gave, with :attr:`Results.out` set and
        :attr:`Results.fit` when ``evtribo compare`` has fitted these results.

    Raises
    ------
    UserInputError
        No such folder, or it holds no analysis (no ``summary.json``), or a table is missing
        or lacks a column.
    ResultFolderError
        The folder is not one analysis's complete results (a table changed since, or of
        another analysis): run the analysis again with ``--force``.
    OutputBusyError
        Another process is writing the folder.
    """
    folder = check_out_folder(Path(out))
    if pending(folder):  # a write interrupted after its commit: finish it first
        with locked(folder, "evtribo (reading results)"):
            recover(folder)
    summary = read_summary(folder)
    if not summary.data:
        raise UserInputError("missing: the folder holds no results of evtribo analyze (run "
                             f"`evtribo analyze STUDY --out {folder}`)",
                             path=folder / SUMMARY_FILE)
    check_analysis(folder, summary)
    tables: dict[str, pd.DataFrame | None] = {}
    for name, (file, columns) in _TABLES.items():
        path = folder / file
        if path.is_file():
            tables[name] = _read_table(path, columns)
        elif name in ("bootstrap", "sine_trace"):
            tables[name] = None
        else:
            raise UserInputError("missing: not a complete result folder of evtribo analyze",
                                 path=path)
    results = Results(_required(tables, "trials"), _required(tables, "windows"),
                      _required(tables, "electrostatic"), _required(tables, "exponents"),
                      summary=summary.data, bootstrap=tables["bootstrap"],
                      sine_trace=tables["sine_trace"], out=folder)
    results.fit = _fit_of(folder, results)
    return results


def _required(tables: dict[str, pd.DataFrame | None], name: str) -> pd.DataFrame:
    table = tables[name]
    assert table is not None
    return table


def _fit_of(folder: Path, results: Results) -> Fit | None:
    """The folder's fit when ``evtribo compare`` fitted these results (a warning and None
    when its fit is of another analysis, or its fit.csv changed since)."""
    if not (folder / FIT_JSON).is_file():
        return None
    from evtribo.api.fit import Fit  # fit.py builds on this module

    doc = read_fit(folder / FIT_JSON)
    run_id = results.summary.get("run_id")
    recorded = (doc.get("output_sha256") or {}).get(FIT_CSV)
    if doc.get("run_id") != run_id:
        why = f"it fitted analysis {doc.get('run_id')}, not these results ({run_id})"
    elif not (folder / FIT_CSV).is_file():
        why = f"{FIT_CSV} is missing"
    elif recorded is not None and sha256_file(folder / FIT_CSV) != recorded:
        why = f"{FIT_CSV} changed since compare wrote it"
    else:
        return Fit.from_folder(folder, doc, results)
    warnings.warn(f"{folder / FIT_JSON}: not used ({why}); run `evtribo compare {folder} "
                  "--force` to fit these results", UserWarning, stacklevel=3)
    return None
