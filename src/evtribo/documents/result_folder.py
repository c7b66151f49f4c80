"""A result folder as one object: :class:`ResultFolder` holds analyze's tables and
``summary.json`` (read from a folder, or in memory before they are saved), reads compare's
documents when first asked for them, and finds a subject's cell and the population's rows by
key.

A folder is read (:meth:`ResultFolder.open`) only if it is one analysis's complete results:
``summary.json`` present and whole, and every table the SHA-256 ``summary.json`` records for
it (``output_sha256``, under the analysis's ``run_id``), with no table of another analysis
beside them (:func:`check_analysis`). Anything else (a file changed, missing or
half-written, a mix of two analyses) raises :class:`~evtribo.errors.ResultFolderError`
naming the file. Result folders of an older evtribo, without a ``run_id``, are read as they
are. compare's documents (``fit.json``, ``fit.csv``, ``models.csv``, the population's
tables) are read on first use: None when absent; a table that ``fit.json`` lists is refused,
naming it, when fit.json is of another analysis or the file is not the one compare wrote.

Every table has the one typing of :mod:`evtribo.documents.tables`.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Self

import pandas as pd

from evtribo.documents.fit import FIT_JSON, FitDocument, read_fit
from evtribo.documents.population_table import Drive, PopulationTable
from evtribo.documents.summary import SUMMARY_FILE, Summary, read_summary
from evtribo.documents.tables import (
    ANALYSIS_FILES,
    BOOTSTRAP,
    CONTRASTS,
    ELECTROSTATIC,
    EXPONENTS,
    FIT,
    MODELS,
    POPULATION,
    POPULATION_SUBJECTS,
    SINE_TRACE,
    TRIALS,
    WINDOWS,
    TableSchema,
)
from evtribo.errors import FORCE, ResultFolderError, UserInputError
from evtribo.store.files import sha256_file
from evtribo.store.resultdir import inside, locked, pending, recover
from evtribo.util.numbers import amplitude_key

log = logging.getLogger(__name__)

__all__ = ["ResultFolder", "check_analysis", "check_out_folder", "folder_summary"]

#: analyze's tables, by attribute.
_ANALYSIS = {"trials": TRIALS, "windows": WINDOWS, "electrostatic": ELECTROSTATIC,
             "exponents": EXPONENTS, "bootstrap": BOOTSTRAP, "sine_trace": SINE_TRACE}
#: The attributes read on first use (forgotten when the folder changes).
_LAZY = ("fit_doc", "fit_table", "models", "population", "contrasts", "population_subjects")


def check_out_folder(out: str | os.PathLike[str]) -> Path:
    """*out* as a Path, if it is an existing folder.

    Parameters
    ----------
    out : path-like

    Returns
    -------
    Path

    Raises
    ------
    UserInputError
        It is not a folder.
    """
    path = Path(out)
    if not path.is_dir():
        raise UserInputError("no such result folder (run `evtribo analyze STUDY --out OUT` "
                             "first)", path=path)
    return path


def _again(folder: Path, summary: Summary) -> str:
    return f"run `evtribo analyze {summary.study_dir or 'STUDY'} --out {folder} {FORCE}` again"


def folder_summary(folder: Path) -> Summary:
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
    return read_summary(path, again=f"; run `evtribo analyze STUDY --out {folder} {FORCE}` "
                                    "again")


def _sha256(path: Path) -> str:
    """A result file's SHA-256; one the user may not read is refused by name."""
    try:
        return sha256_file(path, ResultFolderError, what="result file")
    except PermissionError as err:
        raise ResultFolderError(f"cannot read: {err.strerror}", path=path) from None


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
    run_id, hashes = summary.run_id, summary.output_sha256
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


@dataclass(eq=False)
class ResultFolder:
    """A study's results: analyze's tables and ``summary.json``, and compare's documents.

    Attributes
    ----------
    out : Path or None
        The folder (None: in memory, not saved).
    electrostatic, windows, exponents, trials : pandas.DataFrame
        ``electrostatic.csv``, ``windows.csv``, ``exponents.csv``, ``trials.csv``.
    summary : Summary
        ``summary.json`` (empty when absent).
    sine_trace : pandas.DataFrame or None
        ``sine_trace.csv`` (None: no sine trial gave one).
    bootstrap : pandas.DataFrame or None
        ``electrostatic_bootstrap.csv``: bootstrap replicates of every electrostatic row.
    """

    out: Path | None
    electrostatic: pd.DataFrame
    windows: pd.DataFrame
    exponents: pd.DataFrame
    trials: pd.DataFrame
    summary: Summary = field(default_factory=Summary)
    sine_trace: pd.DataFrame | None = None
    bootstrap: pd.DataFrame | None = None

    @classmethod
    def open(cls, out: str | os.PathLike[str], *, complete: bool = False) -> Self:
        """Read a result folder written by ``evtribo analyze``.

        Parameters
        ----------
        out : path-like
            The folder.
        complete : bool
            Require what analyze writes: summary.json, every table, every column (but those
            an earlier evtribo did not write). Else (compare, report) trials.csv and
            exponents.csv may be absent, a table needs only the columns compare reads, and
            a folder of no window at all is refused (nothing to compare).

        Returns
        -------
        ResultFolder
            Of this class.

        Raises
        ------
        UserInputError
            The folder, a required table or a column is missing, or no trial gave a window.
        ResultFolderError
            The folder is not one analysis's complete results (see the module's notes).
        OutputBusyError
            Another process is writing the folder.
        """
        folder = check_out_folder(out)
        if pending(folder):  # a write interrupted after its commit: finish it first
            with locked(folder, "evtribo (reading results)"):
                recover(folder)
        summary = folder_summary(folder)
        if complete and not summary.data:
            raise UserInputError("missing: the folder holds no results of evtribo analyze "
                                 f"(run `evtribo analyze STUDY --out {folder}`)",
                                 path=folder / SUMMARY_FILE)
        check_analysis(folder, summary)
        tables: dict[str, Any] = {name: _read_analysis(folder, schema, complete)
                                  for name, schema in _ANALYSIS.items()}
        if not complete and tables["electrostatic"].empty and tables["windows"].empty:
            raise UserInputError("no steady-sliding window in any trial (summary.json says "
                                 "why): nothing to compare or report",
                                 path=folder / WINDOWS.file)
        return cls(out=folder, summary=summary, **tables)

    @classmethod
    def in_memory(cls, tables: Mapping[str, pd.DataFrame | None],
                  summary: Summary | Mapping[str, Any], **more: Any) -> Self:
        """Results not saved, their tables given the one typing.

        Parameters
        ----------
        tables : mapping
            ``trials``, ``windows``, ``electrostatic``, ``exponents`` (DataFrames), and
            ``bootstrap``, ``sine_trace`` (DataFrame or None).
        summary : Summary or mapping
            ``summary.json``'s content.
        **more
            The other fields of this class.

        Returns
        -------
        ResultFolder
            Of this class, with :attr:`out` None.
        """
        typed: dict[str, Any] = {}
        for name, schema in _ANALYSIS.items():
            table = tables.get(name)
            typed[name] = None if table is None else schema.typed(table)
        doc = summary if isinstance(summary, Summary) else Summary(dict(summary))
        return cls(out=None, summary=doc, **typed, **more)

    @classmethod
    def compare_documents(cls, out: str | os.PathLike[str]) -> Self:
        """A folder's summary.json and compare's documents (read on first use), without
        analyze's tables (empty).

        Parameters
        ----------
        out : path-like
            The result folder.

        Returns
        -------
        ResultFolder
            Of this class.

        Raises
        ------
        ResultFolderError
            summary.json is not whole, or is missing beside tables of an analysis.
        """
        folder = Path(out)
        return cls(out=folder, summary=folder_summary(folder),
                   **{name: _ANALYSIS[name].empty(_ANALYSIS[name].required)
                      for name in ("trials", "windows", "electrostatic", "exponents")})

    @property
    def tables(self) -> dict[str, pd.DataFrame | None]:
        """analyze's tables by name (``trials``, ``windows``, ``electrostatic``,
        ``exponents``, ``bootstrap``, ``sine_trace``)."""
        return {name: getattr(self, name) for name in _ANALYSIS}

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

    @property
    def drives(self) -> list[Drive]:
        """The drives (waveform and frequency) of electrostatic.csv, each once, in order."""
        es = self.electrostatic
        freq = es["frequency_Hz"] if "frequency_Hz" in es.columns else [None] * len(es)
        return sorted({Drive.of(w, f) for w, f in zip(es["waveform"], freq, strict=True)})

    def cell(self, subject: str, drive: Drive, amplitude_V: float) -> pd.Series | None:
        """A subject's row of electrostatic.csv at a drive and an amplitude.

        Parameters
        ----------
        subject : str
        drive : Drive
        amplitude_V : float, V

        Returns
        -------
        pandas.Series or None
            None when the subject has no such cell.

        Raises
        ------
        ResultFolderError
            Two rows share the key: the table is not one analysis's.
        """
        es = self.electrostatic
        freq = es["frequency_Hz"] if "frequency_Hz" in es.columns else [None] * len(es)
        want = amplitude_key(amplitude_V)
        hits = [i for i, (s, w, f, a) in enumerate(zip(es["subject"], es["waveform"], freq,
                                                       es["amplitude_V"], strict=True))
                if s == subject and amplitude_key(a) == want and Drive.of(w, f) == drive]
        if len(hits) > 1:
            raise ResultFolderError(f"{len(hits)} rows of {subject} ({drive.label()}, "
                                    f"{amplitude_V:g} V): electrostatic.csv has one row per "
                                    "subject, drive and amplitude",
                                    path=None if self.out is None else
                                    self.out / ELECTROSTATIC.file)
        return es.iloc[hits[0]] if hits else None

    # --- compare's documents, read on first use ----------------------------------------

    def _compare_again(self) -> str:
        return f"; run `evtribo compare {self.out} {FORCE}`"

    @cached_property
    def fit_doc(self) -> FitDocument:
        """``fit.json`` (empty when absent, or in memory).

        Raises
        ------
        ResultFolderError
            It is not valid JSON, or not an object.
        """
        if self.out is None or not (self.out / FIT_JSON).is_file():
            return FitDocument()
        return read_fit(self.out / FIT_JSON, again=self._compare_again())

    def check_fit(self) -> None:
        """Refuse a model fit that is not of these results: fit.json of another analysis,
        or one of the files it lists (fit.csv, figures) missing or changed since.

        Raises
        ------
        ResultFolderError
            Naming the file and ``evtribo compare OUT --force``.
        """
        doc, run_id = self.fit_doc, self.summary.run_id
        again = self._compare_again().removeprefix("; ")
        if self.out is None or not doc:
            return
        if run_id is not None and doc.run_id != run_id:
            fitted = doc.run_id or "one without a run_id"
            raise ResultFolderError(
                f"the model fit is of another analysis ({fitted}) than the results now in the "
                f"folder ({run_id}): it was fitted to data that are no longer these; {again}",
                path=self.out / FIT_JSON)
        for rel, digest in doc.output_sha256.items():
            file = inside(self.out, rel)
            if file is None or not file.is_file() or _sha256(file) != digest:
                raise ResultFolderError(f"missing, or not the file compare wrote (fit.json "
                                        f"records its SHA-256); {again}", path=self.out / rel)

    def _compare_table(self, schema: TableSchema) -> pd.DataFrame | None:
        """One of compare's tables (None when absent, or in memory)."""
        if self.out is None or not (path := self.out / schema.file).is_file():
            return None
        listed = self.fit_doc.output_sha256.get(schema.file) if self.fit_doc else None
        run_id = self.summary.run_id
        if listed is not None and run_id is not None and self.fit_doc.run_id != run_id:
            raise ResultFolderError(f"of another analysis than the results now in the folder "
                                    f"(fit.json's run_id is not {run_id}){self._compare_again()}",
                                    path=path)
        if listed is not None and _sha256(path) != listed:
            raise ResultFolderError("not the file compare wrote (fit.json records its "
                                    f"SHA-256){self._compare_again()}", path=path)
        return schema.read(path, error=ResultFolderError, again=self._compare_again())

    @cached_property
    def fit_table(self) -> pd.DataFrame | None:
        """``fit.csv``: one row per subject and fitted parameter (None when absent)."""
        return self._compare_table(FIT)

    @cached_property
    def models(self) -> pd.DataFrame | None:
        """``models.csv`` (``compare --models``; None when absent)."""
        return self._compare_table(MODELS)

    @cached_property
    def population(self) -> PopulationTable | None:
        """``population.csv``, its rows by key, with fit.json's checks of each drive (None
        when absent)."""
        frame = self._compare_table(POPULATION)
        return None if frame is None else PopulationTable(
            frame, checks=self.fit_doc.population_checks(),
            path=None if self.out is None else self.out / POPULATION.file)

    @cached_property
    def contrasts(self) -> pd.DataFrame | None:
        """``population_contrasts.csv`` (None when absent)."""
        return self._compare_table(CONTRASTS)

    @cached_property
    def population_subjects(self) -> pd.DataFrame | None:
        """``population_subjects.csv`` (None when absent)."""
        return self._compare_table(POPULATION_SUBJECTS)

    def forget(self) -> None:
        """Read compare's documents again when next asked for (after a write)."""
        for name in _LAZY:
            self.__dict__.pop(name, None)


def _read_analysis(folder: Path, schema: TableSchema, complete: bool) -> pd.DataFrame | None:
    """One of analyze's tables (None: an optional one absent)."""
    path = folder / schema.file
    if path.is_file():
        return schema.read(path, complete=complete)
    if schema in (BOOTSTRAP, SINE_TRACE):
        return None
    if complete:
        raise UserInputError("missing: not a complete result folder of evtribo analyze",
                             path=path)
    if schema in (TRIALS, EXPONENTS):
        log.info("%s: absent; continuing without it", path)
        return schema.empty(schema.required)
    raise UserInputError("required result table not found (run `evtribo analyze` first)",
                         path=path)
