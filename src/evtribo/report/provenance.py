"""The last section of ``evtribo report``'s page: provenance and settings.

The study's facts, the inputs and result files with their SHA-256 (each result file
linked), the rig, the software and the analysis settings, and how to cite the software and
the model (:data:`evtribo.citation.SOFTWARE`, :data:`evtribo.citation.PAPER`). The trials
are in their subjects' sections, the power laws in the fit's table: not repeated here.
"""

from __future__ import annotations

import json
import platform
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd
from markupsafe import escape

from evtribo import __version__
from evtribo.citation import PAPER, SOFTWARE, text
from evtribo.documents.fit import FitDocument
from evtribo.documents.summary import Summary
from evtribo.fit.tables import ResultTables
from evtribo.report.headline import DOI_URL
from evtribo.report.page import Report
from evtribo.report.sections import SECTIONS
from evtribo.report.study_files import file_hashes
from evtribo.results.outputs import FIGURES
from evtribo.store.resultdir import inside
from evtribo.util.numbers import plain, significant

__all__ = ["add_provenance"]

#: Keys of summary.json shown in the provenance's facts.
_SUMMARY_KEYS = ("run_id", "study_dir", "started", "created", "evtribo_version", "trials",
                 "trials_analysed", "windows_on", "windows_off", "frames", "dropped_frames",
                 "skipped_lines", "strict", "elapsed_s")


def _facts(tables: ResultTables, fit_doc: FitDocument, study: str) -> pd.DataFrame:
    summary = tables.summary
    facts = [{"item": "study", "value": study},
             {"item": "result folder", "value": str(tables.out)}]
    for k in _SUMMARY_KEYS:
        if k in summary:
            v = summary[k]
            facts.append({"item": k, "value": json.dumps(v) if isinstance(v, dict | list)
                          else significant(v) if isinstance(v, float) else str(v)})
    facts.append({"item": "subjects", "value": ", ".join(tables.all_subjects)})
    facts.append({"item": "fitted parameters", "value": ", ".join(fit_doc.fit) or "—"})
    return pd.DataFrame(facts, columns=["item", "value"])


def _software(summary: Summary, fit_doc: FitDocument) -> pd.DataFrame:
    """Who analysed, compared and reported: evtribo's versions and the libraries'."""
    software = [{"component": "evtribo (report)", "version": __version__},
                {"component": "evtribo (analysis)",
                 "version": summary.evtribo_version or summary.software.get("evtribo", "")},
                {"component": "evtribo (compare)",
                 "version": fit_doc.software.get("evtribo", "")}]
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


def _how_to_cite(report: Report, summary: Summary, section: str) -> None:
    """The two works a paper using these results cites: evtribo and the seed paper."""
    analysed_by = summary.evtribo_version or summary.software.get("evtribo", "")
    other = (f" These results were analysed by evtribo {analysed_by}: cite that version."
             if analysed_by and analysed_by != __version__ else "")
    paper = text(PAPER).removesuffix(DOI_URL)
    report.add_html(f'<p class="cite">To cite: the software, {escape(text(SOFTWARE))}'
                    f"{escape(other)} The model, {escape(paper)}"
                    f'<a href="{DOI_URL}">{DOI_URL}</a>. BibTeX of both: '
                    "<code>evtribo cite --bibtex</code>.</p>", section=section)


def _result_files(folder: Path, output: Path) -> pd.DataFrame:
    """The result folder's files and figures (not the report itself), hashed."""
    html_path = output.resolve()
    out_files = [p for p in sorted(folder.iterdir())
                 if p.is_file() and p.resolve() != html_path and not p.name.startswith(".")]
    out_files += sorted((folder / FIGURES).glob("*")) if (folder / FIGURES).is_dir() else []
    out_files = [p for p in out_files if inside(folder, p.relative_to(folder).as_posix())]
    return file_hashes(out_files, folder)


def _setting(value: Any) -> str:
    if isinstance(value, float):
        return plain(value)  # as given: 0.15, not 0.1500
    return json.dumps(value) if isinstance(value, dict | list) else str(value)


def add_provenance(report: Report, tables: ResultTables, fit_doc: FitDocument, *,
                   study: str, study_dir: Path | None, inputs: pd.DataFrame,
                   trials: pd.DataFrame, rig: Mapping[str, Any], output: Path) -> None:
    """The last section: facts, inputs, files, rig, software, settings.

    Parameters
    ----------
    report : Report
        The page.
    tables : ResultTables
        The result folder's tables.
    fit_doc : FitDocument
        ``fit.json``.
    study : str
        The study's name.
    study_dir : Path or None
        The study folder, when it is at hand.
    inputs : DataFrame
        The inputs summary.json records (and whether each is unchanged now).
    trials : DataFrame
        ``trials.csv`` with the sidecars' notes.
    rig : mapping
        The rig as summary.json (or the study) records it.
    output : Path
        The page (left out of the result files).

    Returns
    -------
    None
    """
    sec = SECTIONS["provenance"]
    report.add_table(_facts(tables, fit_doc, study), "Study", section=sec, wrap=True)
    if not inputs.empty:
        caption = (f"now: each file of the study folder {study_dir} hashed again"
                   if study_dir is not None else "The study folder named in summary.json is "
                   "not available here: the inputs could not be hashed again.")
        report.add_table(inputs, "Input files (as recorded in summary.json)", section=sec,
                         caption=caption, wrap="anywhere")
    else:
        report.add_text("summary.json records no input files inside the study folder.",
                        section=sec)
    assert tables.out is not None  # a folder read from disk
    files = _result_files(tables.out, output)
    report.add_table(files, "Result files", section=sec, wrap="anywhere",
                     caption="Each file of the result folder (every table and figure "
                             "linked) and its SHA-256.",
                     links={(i, "file"): tables.out / name
                            for i, name in enumerate(files["file"].astype(str))})
    if rig:
        report.add_table(pd.DataFrame([{"key": k, "value": _setting(v)}
                                       for k, v in rig.items()]), "Rig", section=sec,
                         wrap=True)
    report.add_table(_software(tables.summary, fit_doc), "Software", section=sec, wrap=True)
    _how_to_cite(report, tables.summary, sec)
    settings = tables.summary.settings
    if settings:
        report.add_table(pd.DataFrame([{"setting": k, "value": _setting(v)}
                                       for k, v in settings.items()]),
                         "Analysis settings", section=sec, wrap=True)
    pfile = fit_doc.parameters_file
    if pfile:
        report.add_text(f"Model parameter file: {pfile.get('path')} "
                        f"(sha256 {pfile.get('sha256')})", section=sec)
