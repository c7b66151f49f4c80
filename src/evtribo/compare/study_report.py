"""``evtribo report``: the study's results, the model fit and the provenance in one page.

Reads a result folder (``evtribo analyze``'s tables and ``summary.json``, ``evtribo
compare``'s ``fit.csv``, ``fit.json`` and ``figures/``) and, when ``summary.json`` names a
study folder that still exists (one with a study.toml), the trials' sidecars there (for their
notes) and the inputs ``summary.json`` records (hashed again: a warning for each one changed,
missing or added since the analysis).

The folder must be one unit: the analysis's complete results
(:func:`~evtribo.compare.tables.read_results`) and a model fit of that analysis (``fit.json``'s
``run_id`` and the SHA-256 of compare's files); anything else is refused, naming
``evtribo compare OUT --force``. A ``summary.json`` is not trusted with paths: only inputs
inside the study folder (and the DBC the study's own study.toml names) are listed or read.
"""

from __future__ import annotations

import json
import logging
import os
import platform
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo import __version__
from evtribo.compare.params import parameter_unit
from evtribo.compare.report import Report
from evtribo.compare.run import FIGURES, FIT_CSV, FIT_JSON, compare, figure_stems
from evtribo.compare.tables import ResultTables, check_out_folder, read_results
from evtribo.documents.fit import FitDocument, read_fit
from evtribo.documents.summary import Summary
from evtribo.errors import FORCE, EvtriboError, OutputExistsError, ResultFolderError, UserInputError
from evtribo.files import sha256_file
from evtribo.model.params import ModelParameters
from evtribo.resultdir import inside, locked, recover
from evtribo.study import STUDY_FILE, discover_trials, read_study_toml

log = logging.getLogger(__name__)

__all__ = ["build_report", "file_hashes"]

_SUMMARY_KEYS = ("study", "run_id", "study_dir", "started", "created", "evtribo_version",
                 "trials",
                 "trials_analysed", "windows_on", "windows_off", "frames", "dropped_frames",
                 "skipped_lines", "strict", "elapsed_s")


def file_hashes(paths: list[Path], root: Path) -> pd.DataFrame:
    """``file, bytes, sha256`` of each existing file, names relative to *root*.

    Parameters
    ----------
    paths : list of Path
        The files (those that do not exist are left out).
    root : Path
        The folder the names are relative to (a file outside it keeps its full path).

    Returns
    -------
    DataFrame
        One row per file.
    """
    rows = []
    for p in paths:
        if p.is_file():
            try:
                name = str(p.relative_to(root))
            except ValueError:
                name = str(p)
            rows.append({"file": name, "bytes": p.stat().st_size, "sha256": sha256_file(p)})
    return pd.DataFrame(rows, columns=["file", "bytes", "sha256"])


def _study_name(summary: Summary, out: Path) -> str:
    """The study's name as summary.json records it (else the result folder's)."""
    return summary.study or out.name


def _study_dir(summary: Summary, out: Path) -> Path | None:
    """The study folder summary.json names, if it exists and is a study (a relative path is
    tried from the working directory, then from the result folder's parent)."""
    raw = summary.study_dir
    if not raw:
        return None
    path = Path(raw)
    for candidate in (path, out.parent / path) if not path.is_absolute() else (path,):
        if (candidate / STUDY_FILE).is_file():
            return candidate
    return None


def _study_rig(study_dir: Path | None) -> dict[str, Any]:
    """The [rig] table of the study's own study.toml ({} when unreadable)."""
    if study_dir is None:
        return {}
    try:
        rig = read_study_toml(study_dir / STUDY_FILE).get("rig", {})
    except EvtriboError as err:
        log.warning("report: %s", err)
        return {}
    return dict(rig) if isinstance(rig, dict) else {}


def _study_dbc(study_dir: Path) -> Path | None:
    """The DBC the study's own study.toml names (it may lie outside the study folder)."""
    dbc = _study_rig(study_dir).get("dbc")
    return (study_dir / dbc).resolve() if isinstance(dbc, str) else None


def _input_path(name: str, role: str, study_dir: Path | None,
                dbc: Path | None) -> Path | bool | None:
    """Where a recorded input is now: a path inside the study (or the study's DBC); None if
    the study is not at hand; False if the name is not one to list or read."""
    if name and not Path(name).is_absolute() and ".." not in Path(name).parts:
        return None if study_dir is None else inside(study_dir, name) or False
    if role == "dbc" and dbc is not None and Path(name).resolve() == dbc:
        return dbc
    return False


def _inputs(summary: Summary, study_dir: Path | None
            ) -> tuple[pd.DataFrame, list[str]]:
    """The inputs summary.json records (those inside the study), and a warning for each one
    changed, missing or added since the analysis, or not listed."""
    dbc = _study_dbc(study_dir) if study_dir is not None else None
    rows: list[dict[str, Any]] = []
    warnings, outside = [], 0
    for rec in summary.inputs:
        where = _input_path(rec.file, rec.role, study_dir, dbc)
        if where is False:
            outside += 1
            continue
        row: dict[str, Any] = {"file": rec.file, "bytes": rec.bytes, "sha256": rec.sha256}
        if isinstance(where, Path):
            now = sha256_file(where) if where.is_file() else None
            row["now"] = "unchanged" if now == rec.sha256 else \
                "missing" if now is None else "changed"
            if now is None:
                warnings.append(f"{rec.file}: no longer in the study folder {study_dir} "
                                "(it was an input of the analysis)")
            elif now != rec.sha256:
                warnings.append(f"{rec.file}: changed since the analysis (sha256 "
                                f"{rec.sha256[:12]}... then, {now[:12]}... now): these results "
                                "are not of the study as it is now; analyse it again")
        rows.append(row)
    if outside:
        warnings.append(f"summary.json names {outside} input file(s) outside the study "
                        "folder: not listed, not read (summary.json was edited?)")
    if study_dir is not None:
        warnings += _added(study_dir, {r["file"] for r in rows})
    columns = ["file", "bytes", "sha256", *(["now"] if study_dir is not None else [])]
    return pd.DataFrame(rows, columns=columns), warnings


def _added(study_dir: Path, recorded: set[str]) -> list[str]:
    try:
        trials, _ = discover_trials(study_dir)
    except (EvtriboError, OSError) as err:
        return [f"cannot list the study's trials now: {err}"]
    names = []
    for t in trials:
        names += [t.log_path] + ([t.sidecar_path] if t.sidecar_path is not None else [])
    return [f"{rel}: in the study folder but not in the analysis (added since?)"
            for rel in (p.relative_to(study_dir).as_posix() for p in names)
            if rel not in recorded]


def _notes(study_dir: Path | None, tables: ResultTables) -> dict[str, str]:
    """The sidecars' notes of the trials in trials.csv, read from the study folder."""
    notes: dict[str, str] = {}
    if study_dir is None:
        return notes
    try:
        trials, _ = discover_trials(study_dir)
    except (EvtriboError, OSError) as err:
        log.warning("report: cannot list the study's trials: %s", err)
        return notes
    for t in trials:
        if t.sidecar.notes:
            notes[t.key] = t.sidecar.notes
    return notes


def _trials_table(tables: ResultTables, notes: dict[str, str]) -> pd.DataFrame:
    trials = tables.trials.copy()
    if notes:
        keys = trials["subject"].astype(str) + "/" + trials["trial"].astype(str)
        from_sidecar = keys.map(notes)
        if "notes" in trials.columns:
            trials["notes"] = trials["notes"].where(trials["notes"].notna(), from_sidecar)
        else:
            trials["notes"] = from_sidecar
    return trials


def _warnings(tables: ResultTables, fit_doc: FitDocument) -> list[str]:
    """The analysis's warnings, its failed trials, the trials' dropped frames and damaged
    lines, and the comparison's notes, each once."""
    items = tables.summary.warnings
    for failed in tables.summary.failed_trials:
        items.append(f"{failed.get('trial')}: not analysed: {failed.get('error')}")
    tr = tables.trials
    for col, what in (("dropped_frames", "dropped frame(s)"),
                      ("skipped_lines", "damaged line(s) skipped")):
        if col in tr.columns:
            counts = pd.to_numeric(tr[col], errors="coerce").fillna(0)
            for (_, row), n in zip(tr.iterrows(), counts, strict=True):
                if n > 0:
                    items.append(f"{row['subject']}/{row['trial']}: {int(n)} {what}")
    items += [f"model comparison: {n}" for n in fit_doc.notes]
    return list(dict.fromkeys(items))


def _parameters_table(fit_doc: FitDocument) -> pd.DataFrame:
    """The model's parameters, fixed or fitted."""
    fixed = fit_doc.fixed_parameters or ModelParameters().as_dict()
    fitted = set(fit_doc.fit)
    rows = []
    for name, value in fixed.items():
        try:
            unit = parameter_unit(name)
        except EvtriboError:
            unit = ""
        rows.append({"parameter": name, "value": value, "unit": unit,
                     "role": "fitted per subject (start value)" if name in fitted
                     else "fixed"})
    return pd.DataFrame(rows, columns=["parameter", "value", "unit", "role"])


def _fit_doc(folder: Path, summary: Summary | Mapping[str, Any]) -> FitDocument:
    """fit.json, checked: a fit of the analysis now in *folder*, its files as compare wrote
    them.

    Raises
    ------
    ResultFolderError
        Naming ``evtribo compare OUT --force``.
    """
    if not isinstance(summary, Summary):
        summary = Summary(dict(summary))
    again = f"run `evtribo compare {folder} {FORCE}`"
    path = folder / FIT_JSON
    if not path.is_file():
        if summary.run_id is None:  # results of an older evtribo: a fit.csv alone
            return FitDocument()
        raise ResultFolderError(f"missing beside fit.csv (a comparison that did not finish?); "
                                f"{again}", path=path)
    doc = read_fit(path, again=f"; {again}")
    run_id = summary.run_id
    if run_id is not None and doc.get("run_id") != run_id:
        fitted = doc.get("run_id") or "one without a run_id"
        raise ResultFolderError(
            f"the model fit is of another analysis ({fitted}) than the results now in the "
            f"folder ({run_id}): it was fitted to data that are no longer these; {again}",
            path=path)
    for rel, digest in doc.output_sha256.items():
        file = inside(folder, rel)
        if file is None or not file.is_file() or sha256_file(file) != digest:
            raise ResultFolderError(f"missing, or not the file compare wrote (fit.json "
                                    f"records its SHA-256); {again}", path=folder / rel)
    return doc


def build_report(out: str | Path, output: str | Path, *, force: bool = False,
                 run_compare: bool = True, dpi: float = 150) -> Path:
    """Write the HTML report of a result folder.

    Parameters
    ----------
    out : str or Path
        Result folder (``evtribo analyze``; ``evtribo compare`` is run with its defaults
        when ``fit.csv`` is missing and *run_compare* is True).
    output : str or Path
        The HTML file; its figures also go to ``<stem>_files/`` beside it.
    force : bool
        Overwrite an existing report.
    run_compare : bool
        Run the comparison when it is missing (else raise).
    dpi : float
        Resolution of the figures when the comparison is run here.

    Returns
    -------
    Path
        The HTML file.

    Raises
    ------
    UserInputError
        Missing result folder or tables; missing comparison with *run_compare* False.
    ResultFolderError
        The folder is not one analysis's complete results, or its model fit is of another
        analysis or not whole (exit code 2, naming ``evtribo compare OUT --force``).
    OutputExistsError
        When the report exists and *force* is False.
    OutputBusyError
        Another process is writing the folder or the report.
    """
    folder = check_out_folder(out)
    if Path(output).exists() and not force:  # before the lock: a refusal writes nothing
        raise OutputExistsError("the report already exists; use {force} to overwrite it",
                                path=output)
    with locked(folder, "evtribo report"):
        recover(folder)
        tables = read_results(folder)
        if not (folder / FIT_CSV).is_file() and not (folder / FIT_JSON).is_file():
            if not run_compare:
                raise UserInputError(f"no model fit yet: run `evtribo compare {folder}` "
                                     "first", path=folder / FIT_CSV)
            log.warning("report: %s has no fit.csv; running `evtribo compare` with its "
                        "defaults", folder)
            compare(folder, dpi=dpi)
        fit_doc = _fit_doc(folder, tables.summary)
        if not (folder / FIT_CSV).is_file():
            raise ResultFolderError(f"missing beside fit.json; run `evtribo compare {folder} "
                                    f"{FORCE}`", path=folder / FIT_CSV)
        fit = pd.read_csv(folder / FIT_CSV, dtype={"subject": str})
        report = _page(tables, fit, fit_doc, Path(output))
        html = Path(os.path.realpath(output))
        in_folder = html.is_relative_to(Path(os.path.realpath(folder)))
        return report.save(output, overwrite=force, unit=folder if in_folder else None)


def _figures(tables: ResultTables, fit_doc: FitDocument) -> list[dict[str, Any]]:
    """The figures fit.json lists (else those compare draws), each with its PNG's path.

    Raises
    ------
    ResultFolderError
        A figure's PNG is missing from figures/.
    """
    folder = tables.out
    figures = fit_doc.figures or [
        {"stem": s, "title": s.replace("_", " "), "caption": "",
         "subject": next((x for x in tables.subjects if s.endswith(f"_{x}")), None)}
        for s in figure_stems(tables.subjects)]
    for f in figures:
        png = inside(folder, f"{FIGURES}/{f.get('stem')}.png")
        if png is None or not png.is_file():
            raise ResultFolderError(f"figure missing: run `evtribo compare {folder} {FORCE}`",
                                    path=png or folder / FIT_JSON)
        f["png"] = png
    return figures


def _summary_section(report: Report, tables: ResultTables, fit: pd.DataFrame,
                     fit_doc: FitDocument, trials: pd.DataFrame) -> None:
    """The study: summary.json's facts, the trials and the power laws."""
    sec = "Study summary"
    summary, folder = tables.summary, tables.out
    facts = [{"item": "study", "value": _study_name(summary, folder)},
             {"item": "result folder", "value": str(folder)}]
    facts += [{"item": k, "value": summary[k] if not isinstance(summary[k], dict | list)
               else json.dumps(summary[k])} for k in _SUMMARY_KEYS
              if k in summary and k != "study"]
    facts.append({"item": "subjects", "value": ", ".join(tables.subjects)})
    facts.append({"item": "fitted parameters", "value": ", ".join(fit_doc.fit) or
                  ", ".join(dict.fromkeys(fit["parameter"]))})
    report.add_table(pd.DataFrame(facts, columns=["item", "value"]), "Study", section=sec)
    report.add_table(trials, "Trials", section=sec,
                     caption="From trials.csv; notes from the trials' sidecars when the study "
                             "folder is available.")
    report.add_table(tables.exponents, "Power laws F_el = k·U^n (exponents.csv)", section=sec)


def _fit_section(report: Report, fit: pd.DataFrame, fit_doc: FitDocument,
                 figures: list[dict[str, Any]]) -> None:
    """The model fit: fit.csv, the figures of no one subject, the model's parameters."""
    sec = "Model fit"
    methods = {str(v.get("interval", {}).get("method", "jacobian"))
               for v in fit_doc.subjects.values() if isinstance(v, dict)}
    how = {"bootstrap": "refits to the bootstrap replicates of the electrostatic force "
                        "(electrostatic_bootstrap.csv)",
           "jacobian": "the fit's Jacobian"}
    intervals = " or ".join(how.get(m, m) for m in sorted(methods)) or how["jacobian"]
    report.add_table(fit, "Fitted parameters (fit.csv)", section=sec,
                     caption=f"95 % intervals from {intervals}; rmse_N and r2 describe "
                             "the electrostatic-force misfit; exponent: measured power law, "
                             "exponent_model: the fitted model's slope over the same "
                             "amplitudes.")
    for f in figures:
        if f.get("subject") is None:
            report.add_figure(f["png"], f["title"],
                              caption=f.get("caption", ""), section=sec)
    report.add_table(_parameters_table(fit_doc), "Model parameters", section=sec)


def _subject_sections(report: Report, tables: ResultTables, fit: pd.DataFrame,
                      trials: pd.DataFrame, figures: list[dict[str, Any]]) -> None:
    """One section per subject: its fit, electrostatic forces, trials and figures."""
    for subject in tables.subjects:
        sec = f"Subject {subject}"
        report.add_table(fit[fit["subject"] == subject], "Fit", section=sec)
        report.add_table(tables.electrostatic[tables.electrostatic["subject"] == subject],
                         "Electrostatic force (electrostatic.csv)", section=sec)
        report.add_table(trials[trials["subject"] == subject], "Trials", section=sec)
        for f in figures:
            if f.get("subject") == subject:
                report.add_figure(f["png"], f["title"],
                                  caption=f.get("caption", ""), section=sec)


def _software(summary: Summary, fit_doc: FitDocument) -> pd.DataFrame:
    """Who analysed, compared and reported: evtribo's versions and the libraries'."""
    software = [{"component": "evtribo (report)", "version": __version__},
                {"component": "evtribo (analysis)",
                 "version": summary.evtribo_version or summary.software.get("evtribo", "")},
                {"component": "evtribo (compare)",
                 "version": fit_doc.software.get("evtribo", "")}]
    # what the analysis ran with, as summary.json recorded it
    software += [{"component": f"{name} (analysis)", "version": v}
                 for name, v in summary.software.items() if name != "evtribo"]
    software.append({"component": "python (report)", "version": platform.python_version()})
    for module in ("numpy", "scipy", "pandas", "matplotlib", "cantools", "can"):
        try:
            mod = __import__(module)
        except ImportError:
            continue
        name = "python-can" if module == "can" else module
        software.append({"component": f"{name} (report)",
                         "version": getattr(mod, "__version__", "")})
    return pd.DataFrame(software)


def _result_files(folder: Path, output: Path) -> pd.DataFrame:
    """The result folder's files and figures (not the report itself), hashed."""
    html_path = output.resolve()
    out_files = [p for p in sorted(folder.iterdir())
                 if p.is_file() and p.resolve() != html_path and not p.name.startswith(".")]
    out_files += sorted((folder / FIGURES).glob("*")) if (folder / FIGURES).is_dir() else []
    out_files = [p for p in out_files if inside(folder, p.relative_to(folder).as_posix())]
    return file_hashes(out_files, folder)


def _provenance_section(report: Report, tables: ResultTables, fit_doc: FitDocument, *,
                        study_dir: Path | None, inputs: pd.DataFrame, output: Path) -> None:
    """Provenance: the inputs, the result files, the rig, the software, the settings."""
    sec = "Provenance"
    summary = tables.summary
    if not inputs.empty:
        caption = (f"now: each file of the study folder {study_dir} hashed again"
                   if study_dir is not None else "The study folder named in summary.json is "
                   "not available here: the inputs could not be hashed again.")
        report.add_table(inputs, "Input files (as recorded in summary.json)", section=sec,
                         caption=caption)
    else:
        report.add_text("summary.json records no input files inside the study folder.",
                        section=sec)
    report.add_table(_result_files(tables.out, output), "Result files", section=sec)
    rig_info = summary.rig or _study_rig(study_dir)
    if rig_info:
        report.add_table(pd.DataFrame([{"key": k, "value": json.dumps(v) if isinstance(
            v, dict | list) else v} for k, v in rig_info.items()]), "Rig", section=sec)
    report.add_table(_software(summary, fit_doc), "Software", section=sec)
    if summary.settings:
        report.add_table(pd.DataFrame([{"setting": k, "value": v} for k, v in
                                       summary.settings.items()]),
                         "Analysis settings", section=sec)
    pfile = fit_doc.parameters_file
    if pfile:
        report.add_text(f"Model parameter file: {pfile.get('path')} "
                        f"(sha256 {pfile.get('sha256')})", section=sec)


def _page(tables: ResultTables, fit: pd.DataFrame, fit_doc: FitDocument,
          output: Path) -> Report:
    """The report's page (figures from the folder's figures/)."""
    figures = _figures(tables, fit_doc)
    study_dir = _study_dir(tables.summary, tables.out)
    inputs, input_warnings = _inputs(tables.summary, study_dir)
    trials = _trials_table(tables, _notes(study_dir, tables))
    report = Report(f"evtribo report: {_study_name(tables.summary, tables.out)}")
    _summary_section(report, tables, fit, fit_doc, trials)
    _fit_section(report, fit, fit_doc, figures)
    _subject_sections(report, tables, fit, trials, figures)
    for w in input_warnings:
        log.warning("report: %s", w)
    report.add_list([*input_warnings, *_warnings(tables, fit_doc)], "Warnings",
                    section="Warnings",
                    caption="The study folder now against the inputs summary.json records; "
                            "then from summary.json, trials.csv (dropped frames, skipped "
                            "lines) and the model comparison.")
    _provenance_section(report, tables, fit_doc, study_dir=study_dir, inputs=inputs,
                        output=output)
    return report
