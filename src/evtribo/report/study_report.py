"""``evtribo report``: the study's answer first, then the fit, the figures, the trials and
the provenance, in one page.

Reads a result folder (``evtribo analyze``'s tables and ``summary.json``, ``evtribo
compare``'s ``fit.csv``, ``fit.json``, ``figures/``, ``population.csv`` and
``population_contrasts.csv`` and, when it compared models, ``models.csv``) and, when
``summary.json`` names a study folder that still exists, the trials' sidecars there (for
their notes) and the inputs ``summary.json`` records (hashed again,
:mod:`evtribo.report.study_files`). The page's sections and their order are
:mod:`evtribo.report.sections`'; with ``tables=("md", "tex")`` the headline tables
are also written as Markdown and LaTeX into ``tables/`` beside the page
(:mod:`evtribo.report.table_export`).

The folder must be one unit: the analysis's complete results
(:func:`~evtribo.fit.tables.read_results`) and a model fit of that analysis (``fit.json``'s
``run_id`` and the SHA-256 of compare's files); anything else is refused, naming
``evtribo compare OUT --force``.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo.documents.fit import FitDocument
from evtribo.documents.result_folder import ResultFolder
from evtribo.documents.tables import FIT_CSV, MODELS_CSV
from evtribo.errors import FORCE, OutputExistsError, ResultFolderError, UserInputError
from evtribo.fit.tables import ResultTables, check_out_folder, read_results
from evtribo.guard import refuse_in_study, refuse_input
from evtribo.report import sections
from evtribo.report.compare import compare
from evtribo.report.friction_report import add_friction
from evtribo.report.headline import Headline
from evtribo.report.lead.key_results import key_results
from evtribo.report.lead.scope import study_cells
from evtribo.report.lead.sections import add_key_results, add_warnings
from evtribo.report.page import Report
from evtribo.report.population import add_population, read_population
from evtribo.report.provenance import add_provenance
from evtribo.report.study_files import (
    file_hashes,
    input_table,
    study_dir_of,
    study_name,
    study_rig,
    trials_with_notes,
)
from evtribo.report.table_export import TABLE_FORMATS, parse_table_formats, table_files
from evtribo.results.outputs import FIGURES, FIT_JSON, REPORT_TABLES, TABLES
from evtribo.store.names import check_new_path
from evtribo.store.owned import refuse_foreign
from evtribo.store.resultdir import inside, locked, recover
from evtribo.warning.collect import collecting, emitter, replay
from evtribo.warning.record import Scope, WarningRecord
from evtribo.warning.render import group

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["MODELS_CSV", "build_report", "file_hashes"]

#: Figure files, in the order the page prefers them.
_FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


def _warnings(tables: ResultTables) -> list[WarningRecord]:
    """The analysis's warnings, and those its tables say besides: a failed trial that
    summary.json does not say (``not-analysed``), the trials' dropped frames
    (``frames-lost``) and damaged lines (``damaged-lines``, where summary.json has no
    record of them), each once (the comparison's follow them: fit.json's)."""
    records = list(tables.summary.warnings)
    said = {(r.kind, r.scope.subject, r.scope.trial) for r in records}
    with collecting(quiet=True) as more:
        for failed in tables.summary.failed_trials:
            subject, _, trial = str(failed.get("trial")).partition("/")
            if ("not-analysed", subject, trial) not in said:
                emit("not-analysed", Scope(subject, trial), error=str(failed.get("error")))
        tr = tables.trials
        for col, kind_id in (("dropped_frames", "frames-lost"),
                             ("skipped_lines", "damaged-lines")):
            if col not in tr.columns:
                continue
            counts = pd.to_numeric(tr[col], errors="coerce").fillna(0)
            for (_, row), n in zip(tr.iterrows(), counts, strict=True):
                scope = Scope(str(row["subject"]), str(row["trial"]))
                if n <= 0 or any((k, scope.subject, scope.trial) in said
                                 for k in (kind_id, "damaged-line", "damaged-lines-more")):
                    continue
                if kind_id == "frames-lost":
                    emit(kind_id, scope, frames=int(n))
                else:
                    emit(kind_id, scope, lines=int(n), log=_log_of(tables, scope))
    return records + more


def _log_of(tables: ResultTables, scope: Scope) -> str:
    """A trial's log as summary.json names it (else ``subject/trial``)."""
    for rec in tables.summary.inputs:
        parts = Path(rec.file).parts
        if rec.role == "log" and len(parts) == 2 and parts[0] == scope.subject \
                and parts[1].split(".", 1)[0] == scope.trial:
            return rec.file
    return f"{scope.subject}/{scope.trial}"


def _fit_doc(results: ResultFolder) -> FitDocument:
    """fit.json, checked: a fit of the analysis now in the folder, its files as compare wrote
    them (:meth:`~evtribo.documents.result_folder.ResultFolder.check_fit`).

    Raises
    ------
    ResultFolderError
        Naming ``evtribo compare OUT --force``.
    """
    folder = results.out
    assert folder is not None
    if not (folder / FIT_JSON).is_file() and results.summary.run_id is not None:
        raise ResultFolderError(f"missing beside fit.csv (a comparison that did not finish?); "
                                f"run `evtribo compare {folder} {FORCE}`",
                                path=folder / FIT_JSON)
    results.check_fit()  # an older evtribo's results without fit.json: a fit.csv alone
    return results.fit_doc


def _check_output(folder: Path, output: Path, formats: Iterable[str], force: bool) -> None:
    """Before anything is written: the page's name and its tables' are ones evtribo writes
    and records, over nothing it may not replace."""
    check_new_path(output, key="-o")  # a name evtribo writes and records, before the work
    refuse_in_study(folder, command="evtribo report")
    refuse_input(output, command="evtribo report", key="-o")  # --force or not
    tables_out = [f"{TABLES}/{stem}.{fmt}" for stem in REPORT_TABLES for fmt in formats]
    for rel in tables_out:
        refuse_input(output.parent / rel, command="evtribo report", key="--tables")
    # what the report writes replaces only a report's own files, --force or not
    refuse_foreign(output.parent, [output.name], {"report"}, key="-o")
    refuse_foreign(output.parent, tables_out, {"report"}, key="--tables")
    if output.exists() and not force:  # before the lock: a refusal writes nothing
        raise OutputExistsError("the report already exists; use {force} to overwrite it",
                                path=output)


def build_report(out: str | Path, output: str | Path, *, force: bool = False,
                 run_compare: bool = True, dpi: float | None = None,
                 tables: str | Iterable[str] | None = None) -> Path:
    """Write the HTML report of a result folder.

    Parameters
    ----------
    out : str or Path
        Result folder (``evtribo analyze``; ``evtribo compare`` is run with its defaults
        when ``fit.csv`` is missing and *run_compare* is True).
    output : str or Path
        The HTML file.
    force : bool
        Overwrite an existing report (and its tables).
    run_compare : bool
        Run the comparison when it is missing (else raise).
    dpi : float, optional
        Resolution of the PNG figures when the comparison is run here (default:
        compare's).
    tables : str or iterable of str, optional
        Also write the headline tables in these formats (``"md,tex"``,
        :data:`~evtribo.report.table_export.TABLE_FORMATS`) into ``tables/`` beside the
        page.

    Returns
    -------
    Path
        The HTML file.

    Raises
    ------
    UserInputError
        Missing result folder or tables; missing comparison with *run_compare* False; an
        unknown table format (key ``--tables``).
    ResultFolderError
        The folder is not one analysis's complete results, or its model fit is of another
        analysis or not whole (exit code 2, naming ``evtribo compare OUT --force``).
    OutputExistsError
        When the report exists and *force* is False; when it or a table is a study's input
        or a raw CAN log (*force* or not).
    OutputBusyError
        Another process is writing the folder or the report.
    """
    formats = parse_table_formats(tables)
    folder = check_out_folder(out)
    _check_output(folder, Path(output), formats, force)
    with locked(folder, "evtribo report"):
        recover(folder)
        results = read_results(folder)
        if not (folder / FIT_CSV).is_file() and not (folder / FIT_JSON).is_file():
            if not run_compare:
                raise UserInputError(f"no model fit yet: run `evtribo compare {folder}` "
                                     "first", path=folder / FIT_CSV)
            log.warning("report: %s has no fit.csv; running `evtribo compare` with its "
                        "defaults", folder)
            compare(folder, dpi=dpi)
        results.forget()  # compare may have run since it was read
        fit_doc = _fit_doc(results)
        fit = results.fit_table
        if fit is None:
            raise ResultFolderError(f"missing beside fit.json; run `evtribo compare {folder} "
                                    f"{FORCE}`", path=folder / FIT_CSV)
        report, headlines = _page(results, fit, fit_doc, Path(output))
        html = Path(os.path.realpath(output))
        # a page inside the result folder is written as one unit with it; one of a hidden
        # name, as a unit of its own (a hidden name is only ever an output's own)
        in_folder = html.is_relative_to(Path(os.path.realpath(folder))) \
            and not html.name.startswith(".")
        stale = [f"{TABLES}/{stem}.{fmt}" for stem in REPORT_TABLES for fmt in TABLE_FORMATS]
        return report.save(output, overwrite=force, unit=folder if in_folder else None,
                           figure_files=False, extra_files=table_files(headlines, formats),
                           stale=stale)


def _figure_file(folder: Path, stem: str, written: Mapping[str, str]) -> Path | None:
    """A figure's file in figures/: its PNG, else its SVG, else its PDF, among those compare
    wrote (*written*, fit.json's ``output_sha256``: another file of the figure's name, a
    user's or another command's, is never shown as the figure; any, for an older fit.json
    that lists none)."""
    for suffix in _FIGURE_SUFFIXES:
        rel = f"{FIGURES}/{stem}{suffix}"
        path = inside(folder, rel)
        if path is not None and path.is_file() and (not written or rel in written):
            return path
    return None


def _figures(tables: ResultTables, fit_doc: FitDocument) -> list[dict[str, Any]]:
    """The figures fit.json lists (else those in figures/), each with its file.

    Raises
    ------
    ResultFolderError
        A figure fit.json lists has no file in figures/.
    """
    folder = tables.out
    assert folder is not None  # a folder read from disk
    figures = fit_doc.figures
    if not figures and (folder / FIGURES).is_dir():  # results of an older evtribo compare
        stems = dict.fromkeys(p.stem for p in sorted((folder / FIGURES).iterdir())
                              if p.suffix in _FIGURE_SUFFIXES)
        figures = [{"stem": s, "title": s.replace("_", " "), "caption": "",
                    "subject": next((x for x in tables.subjects if s.endswith(f"_{x}")),
                                    None)} for s in stems]
    for f in figures:
        path = _figure_file(folder, str(f.get("stem")), fit_doc.output_sha256)
        if path is None:
            raise ResultFolderError(f"figure missing: run `evtribo compare {folder} {FORCE}`",
                                    path=folder / FIGURES / f"{f.get('stem')}.png")
        f["file"] = path
    return figures


def _page(tables: ResultTables, fit: pd.DataFrame, fit_doc: FitDocument,
          output: Path) -> tuple[Report, list[Headline]]:
    """The report's page (figures from the folder's figures/) and its headline tables."""
    figures = _figures(tables, fit_doc)
    assert tables.out is not None  # a folder read from disk
    study_dir = study_dir_of(tables.summary, tables.out)
    inputs, input_warnings = input_table(tables.summary, study_dir)
    trials = trials_with_notes(tables, study_dir)
    name = study_name(tables.summary, tables.out)
    report = Report(f"evtribo report: {name}")
    replay(input_warnings)  # the study as it is now: said by the report
    keys = list(zip(tables.trials["subject"].astype(str), tables.trials["trial"].astype(str),
                    strict=True))
    compared = fit_doc.warnings  # the comparison's, after the analysis's: one list
    groups = group([*input_warnings, *_warnings(tables), *compared])
    cells = study_cells(tables.electrostatic.to_dict("records"))
    models = tables.models
    population, contrasts = tables.population, read_population(tables)[1]
    if tables.electrostatic.empty:  # a study of OFF trials: its friction, no fit
        headlines = add_friction(report, tables.windows)
        add_warnings(report, groups, keys, cells, compared)
        headlines += add_population(report, population, contrasts, fit_doc,
                                    sections.placed(figures, "population"), friction_only=True)
    else:
        key = key_results(tables, fit, models, groups)
        add_key_results(report, key)
        add_warnings(report, groups, keys, cells, compared)
        headlines = sections.add_headline(report, tables, fit, fit_doc, key.marks)
        headlines += add_population(report, population, contrasts, fit_doc,
                                    sections.placed(figures, "population"))
    grid = len(tables.subjects) >= sections.GRID_FROM
    sections.add_all_subjects(report, figures, tables.subjects if grid else ())
    sections.add_predictions(report, figures)
    sections.add_models(report, models, figures, tables.subjects)
    sections.add_subjects(report, tables, trials, figures, grid=grid)
    add_provenance(report, tables, fit_doc, study=name, study_dir=study_dir, inputs=inputs,
                   trials=trials, rig=tables.summary.rig or study_rig(study_dir),
                   output=output)
    return report, headlines
