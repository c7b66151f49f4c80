"""``evtribo report``: the study's results, the model fit and the provenance in one page.

Reads a result folder (``evtribo analyze``'s tables and ``summary.json``, ``evtribo
compare``'s ``fit.csv``, ``fit.json`` and ``figures/``) and, when ``summary.json`` names a
study folder that still exists, the trials' sidecars there (for their notes) and the input
files (for their SHA-256 hashes).
"""

from __future__ import annotations

import json
import logging
import platform
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo import __version__
from evtribo.analysis.provenance import sha256_file
from evtribo.compare.params import parameter_unit
from evtribo.compare.report import Report
from evtribo.compare.run import FIGURES, FIT_CSV, FIT_JSON, compare, figure_stems
from evtribo.compare.tables import ResultTables, read_results
from evtribo.errors import EvtriboError, UserInputError
from evtribo.model.params import ModelParameters
from evtribo.study import discover_trials, read_study_toml

log = logging.getLogger(__name__)

__all__ = ["build_report", "file_hashes"]

_SUMMARY_KEYS = ("study", "study_dir", "started", "created", "evtribo_version", "trials",
                 "trials_analysed", "windows_on", "windows_off", "frames", "dropped_frames",
                 "skipped_lines", "strict", "elapsed_s")


def file_hashes(paths: list[Path], root: Path) -> pd.DataFrame:
    """``file, bytes, sha256`` of each existing file, names relative to *root*."""
    rows = []
    for p in paths:
        if p.is_file():
            try:
                name = str(p.relative_to(root))
            except ValueError:
                name = str(p)
            rows.append({"file": name, "bytes": p.stat().st_size, "sha256": sha256_file(p)})
    return pd.DataFrame(rows, columns=["file", "bytes", "sha256"])


def _hashes_in(obj: Any, found: list[dict[str, Any]]) -> None:
    """Collect every mapping holding a ``sha256`` key, anywhere in a JSON document."""
    if isinstance(obj, dict):
        if "sha256" in obj:
            found.append({"file": str(obj.get("path", obj.get("file", obj.get("name", "")))),
                          "bytes": obj.get("bytes", obj.get("size")),
                          "sha256": str(obj["sha256"])})
        for v in obj.values():
            _hashes_in(v, found)
    elif isinstance(obj, list):
        for v in obj:
            _hashes_in(v, found)


def _study_name(summary: dict[str, Any], out: Path) -> str:
    study = summary.get("study")
    if isinstance(study, dict):
        study = study.get("name")
    return str(study) if study else out.name


def _study_dir(summary: dict[str, Any], out: Path) -> Path | None:
    """The study folder summary.json names, if it exists (a relative path is tried from
    the working directory, then from the result folder's parent)."""
    raw = summary.get("study_dir")
    if raw is None and isinstance(summary.get("study"), dict):
        raw = summary["study"].get("path")
    if not raw:
        return None
    path = Path(str(raw))
    for candidate in (path, out.parent / path) if not path.is_absolute() else (path,):
        if candidate.is_dir():
            return candidate
    return None


def _study_inputs(study_dir: Path) -> tuple[list[Path], dict[str, str], dict[str, Any]]:
    """(input files, notes by subject/trial, rig table) read from the study folder."""
    files: list[Path] = []
    notes: dict[str, str] = {}
    rig: dict[str, Any] = {}
    toml = study_dir / "study.toml"
    if toml.is_file():
        files.append(toml)
        try:
            config = read_study_toml(toml)
            rig = dict(config.get("rig", {}))
            dbc = rig.get("dbc")
            if isinstance(dbc, str) and (study_dir / dbc).is_file():
                files.append(study_dir / dbc)
        except EvtriboError as err:
            log.warning("report: %s", err)
    try:
        trials, _ = discover_trials(study_dir)
    except (EvtriboError, OSError) as err:
        log.warning("report: cannot list the study's trials: %s", err)
        trials = []
    for t in trials:
        files.append(t.log_path)
        if t.sidecar_path is not None:
            files.append(t.sidecar_path)
        if t.sidecar.notes:
            notes[t.key] = t.sidecar.notes
    return files, notes, rig


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


def _warnings(tables: ResultTables, fit_doc: dict[str, Any]) -> list[str]:
    items = [str(w) for w in tables.summary.get("warnings", []) or []]
    for failed in tables.summary.get("failed_trials", []) or []:
        if isinstance(failed, dict):
            items.append(f"{failed.get('trial')}: not analysed: {failed.get('error')}")
    tr = tables.trials
    for col, what in (("dropped_frames", "dropped frame(s)"),
                      ("skipped_lines", "damaged line(s) skipped")):
        if col in tr.columns:
            counts = pd.to_numeric(tr[col], errors="coerce").fillna(0)
            for (_, row), n in zip(tr.iterrows(), counts, strict=True):
                if n > 0:
                    items.append(f"{row['subject']}/{row['trial']}: {int(n)} {what}")
    items += [f"model comparison: {n}" for n in fit_doc.get("notes", [])]
    return list(dict.fromkeys(items))


def _parameters_table(fit_doc: dict[str, Any]) -> pd.DataFrame:
    fixed = fit_doc.get("fixed_parameters") or ModelParameters().as_dict()
    fitted = set(fit_doc.get("fit", []))
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
    OutputExistsError
        When the report exists and *force* is False.
    """
    tables = read_results(out)
    folder = tables.out
    if not (folder / FIT_CSV).is_file():
        if not run_compare:
            raise UserInputError(f"no model fit yet: run `evtribo compare {folder}` first",
                                 path=folder / FIT_CSV)
        log.warning("report: %s has no fit.csv; running `evtribo compare` with its defaults",
                    folder)
        compare(folder, dpi=dpi)
    fit = pd.read_csv(folder / FIT_CSV, dtype={"subject": str})
    fit_doc: dict[str, Any] = {}
    if (folder / FIT_JSON).is_file():
        fit_doc = json.loads((folder / FIT_JSON).read_text(encoding="utf-8"))
    figures = fit_doc.get("figures") or [
        {"stem": s, "title": s.replace("_", " "), "caption": "",
         "subject": next((x for x in tables.subjects if s.endswith(f"_{x}")), None)}
        for s in figure_stems(tables.subjects)]
    for f in figures:
        png = folder / FIGURES / f"{f['stem']}.png"
        if not png.is_file():
            raise UserInputError(f"figure missing: run `evtribo compare {folder} --force`",
                                 path=png)

    summary = tables.summary
    name = _study_name(summary, folder)
    study_dir = _study_dir(summary, folder)
    inputs, notes, rig = _study_inputs(study_dir) if study_dir else ([], {}, {})
    trials = _trials_table(tables, notes)
    report = Report(f"evtribo report: {name}")

    # --------------------------------------------------------------- study summary
    sec = "Study summary"
    facts = [{"item": "study", "value": name}, {"item": "result folder", "value": str(folder)}]
    facts += [{"item": k, "value": summary[k] if not isinstance(summary[k], dict | list)
               else json.dumps(summary[k])} for k in _SUMMARY_KEYS
              if k in summary and k != "study"]
    facts.append({"item": "subjects", "value": ", ".join(tables.subjects)})
    facts.append({"item": "fitted parameters", "value": ", ".join(fit_doc.get("fit", [])) or
                  ", ".join(dict.fromkeys(fit["parameter"]))})
    report.add_table(pd.DataFrame(facts, columns=["item", "value"]), "Study", section=sec)
    report.add_table(trials, "Trials", section=sec,
                     caption="From trials.csv; notes from the trials' sidecars when the study "
                             "folder is available.")
    report.add_table(tables.exponents, "Power laws F_el = k·U^n (exponents.csv)", section=sec)

    # --------------------------------------------------------------------- model fit
    sec = "Model fit"
    methods = {str(v.get("interval", {}).get("method", "jacobian"))
               for v in (fit_doc.get("subjects") or {}).values() if isinstance(v, dict)}
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
            report.add_figure(folder / FIGURES / f"{f['stem']}.png", f["title"],
                              caption=f.get("caption", ""), section=sec)
    report.add_table(_parameters_table(fit_doc), "Model parameters", section=sec)

    # ------------------------------------------------------------------ per subject
    for subject in tables.subjects:
        sec = f"Subject {subject}"
        report.add_table(fit[fit["subject"] == subject], "Fit", section=sec)
        report.add_table(tables.electrostatic[tables.electrostatic["subject"] == subject],
                         "Electrostatic force (electrostatic.csv)", section=sec)
        report.add_table(trials[trials["subject"] == subject], "Trials", section=sec)
        for f in figures:
            if f.get("subject") == subject:
                report.add_figure(folder / FIGURES / f"{f['stem']}.png", f["title"],
                                  caption=f.get("caption", ""), section=sec)

    # -------------------------------------------------------------------- warnings
    report.add_list(_warnings(tables, fit_doc), "Warnings", section="Warnings",
                    caption="From summary.json, trials.csv (dropped frames, skipped lines) "
                            "and the model comparison.")

    # ------------------------------------------------------------------ provenance
    sec = "Provenance"
    recorded: list[dict[str, Any]] = []
    _hashes_in(summary.get("inputs", summary.get("files", [])), recorded)
    if recorded:
        report.add_table(pd.DataFrame(recorded, columns=["file", "bytes", "sha256"]),
                         "Input files (as recorded in summary.json)", section=sec)
    if inputs:
        report.add_table(file_hashes(inputs, study_dir or folder),
                         f"Input files (study folder {study_dir}, hashed now)", section=sec)
    if not recorded and not inputs:
        report.add_text("The study folder named in summary.json is not available here: "
                        "input files could not be hashed.", section=sec)
    html_path = Path(output).resolve()
    out_files = [p for p in sorted(folder.iterdir())
                 if p.is_file() and p.resolve() != html_path]
    out_files += sorted((folder / FIGURES).glob("*")) if (folder / FIGURES).is_dir() else []
    report.add_table(file_hashes(out_files, folder), "Result files", section=sec)
    rig_info = summary.get("rig") if isinstance(summary.get("rig"), dict) else rig
    if rig_info:
        report.add_table(pd.DataFrame([{"key": k, "value": json.dumps(v) if isinstance(
            v, dict | list) else v} for k, v in rig_info.items()]), "Rig", section=sec)
    software = [{"component": "evtribo (report)", "version": __version__},
                {"component": "evtribo (analysis)",
                 "version": summary.get("evtribo_version",
                                        (summary.get("software") or {}).get("evtribo", ""))},
                {"component": "evtribo (compare)",
                 "version": (fit_doc.get("software") or {}).get("evtribo", "")}]
    # what the analysis ran with, as summary.json recorded it
    analysis_software = summary.get("software") if isinstance(summary.get("software"),
                                                              dict) else {}
    software += [{"component": f"{name} (analysis)", "version": v}
                 for name, v in analysis_software.items() if name != "evtribo"]
    software.append({"component": "python (report)", "version": platform.python_version()})
    for module in ("numpy", "scipy", "pandas", "matplotlib", "cantools", "can"):
        try:
            mod = __import__(module)
            name = "python-can" if module == "can" else module
            software.append({"component": f"{name} (report)",
                             "version": getattr(mod, "__version__", "")})
        except ImportError:
            continue
    report.add_table(pd.DataFrame(software), "Software", section=sec)
    if summary.get("settings"):
        report.add_table(pd.DataFrame([{"setting": k, "value": v} for k, v in
                                       summary["settings"].items()]),
                         "Analysis settings", section=sec)
    pfile = fit_doc.get("parameters_file")
    if pfile:
        report.add_text(f"Model parameter file: {pfile.get('path')} "
                        f"(sha256 {pfile.get('sha256')})", section=sec)
    return report.save(output, overwrite=force)
