"""The sections of ``evtribo report``'s page, in the order a reader wants them.

1. the electrostatic force by subject and voltage (mN, 95 % intervals);
2. the model fit per subject (air gap in µm, exponents, μ) and the model's parameters, each
   said to be measured, fixed or fitted, with the paper cited; then the population's
   estimates (:mod:`evtribo.compare.population_section`);
3. the figures of all subjects together (``electrostatic_force_all`` first);
4. the model comparison (``models.csv`` and the ``frequency_response`` figures), when there
   is one;
5. one section per subject: its forces, its figures, its trials, and each trial's check
   figure folded in a ``<details>`` element;
6. the warnings;
7. provenance and settings: the study's facts, the trials, the power laws, the inputs and
   result files with their SHA-256, the rig, the software and the analysis settings, and
   how to cite the software and the model.

Every number is printed for people (:mod:`evtribo.compare.numbers`).
"""

from __future__ import annotations

import json
import math
import platform
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd
from markupsafe import escape

from evtribo import __version__
from evtribo.analysis.outputs import FIGURES
from evtribo.citation import PAPER, SOFTWARE, text
from evtribo.compare.headline import (
    CITATION,
    DOI_URL,
    Headline,
    fit_summary,
    force_table,
    model_comparison,
    parameter_roles,
)
from evtribo.compare.numbers import (
    frequency,
    quantity,
    significant,
    to_float,
    voltage,
    with_interval,
)
from evtribo.compare.report import Report
from evtribo.compare.study_files import file_hashes
from evtribo.compare.tables import ResultTables
from evtribo.documents.fit import FitDocument
from evtribo.documents.summary import Summary
from evtribo.resultdir import inside

__all__ = ["SECTIONS", "add_all_subjects", "add_headline", "add_models", "add_provenance",
           "add_subjects", "add_warnings", "trial_summary"]

#: The sections' titles, in the page's order (a subject's is ``Subject <name>``).
SECTIONS: dict[str, str] = {
    "forces": "Electrostatic force", "fit": "Model fit", "all": "All subjects",
    "models": "Model comparison", "warnings": "Warnings",
    "provenance": "Provenance and settings"}

#: Keys of summary.json shown in the provenance's facts.
_SUMMARY_KEYS = ("run_id", "study_dir", "started", "created", "evtribo_version", "trials",
                 "trials_analysed", "windows_on", "windows_off", "frames", "dropped_frames",
                 "skipped_lines", "strict", "elapsed_s")


def _add(report: Report, headline: Headline, section: str) -> None:
    report.add_table(headline.table, headline.title, caption=headline.caption,
                     section=section, wrap=True)


def _cite(report: Report, section: str, lead: str) -> None:
    report.add_html(f'<p class="cite">{escape(lead)} {escape(CITATION)} '
                    f'(<a href="{DOI_URL}">{DOI_URL}</a>).</p>', section=section)


def _figure(report: Report, fig: Mapping[str, Any], section: str,
            details: str | None = None) -> None:
    report.add_figure(fig["file"], str(fig.get("title") or fig.get("stem")),
                      caption=str(fig.get("caption") or ""), section=section, details=details)


def add_headline(report: Report, tables: ResultTables, fit: pd.DataFrame,
                 fit_doc: FitDocument) -> list[Headline]:
    """The page's first two sections: F_el by subject and voltage, and the fit.

    Parameters
    ----------
    report : Report
        The page.
    tables : ResultTables
        The result folder's tables.
    fit : DataFrame
        ``fit.csv``.
    fit_doc : FitDocument
        ``fit.json``.

    Returns
    -------
    list of Headline
        The two headline tables (what ``--tables`` exports).
    """
    forces, summary = force_table(tables.electrostatic), fit_summary(fit, fit_doc)
    _add(report, forces, SECTIONS["forces"])
    _add(report, summary, SECTIONS["fit"])
    methods = {str(v.get("interval", {}).get("method", "jacobian"))
               for v in fit_doc.subjects.values() if isinstance(v, dict)}
    how = {"bootstrap": "refits to the bootstrap replicates of the electrostatic forces",
           "jacobian": "the fit's Jacobian (each point's error taken as independent)"}
    intervals = " or ".join(how.get(m, m) for m in sorted(methods)) or how["jacobian"]
    report.add_html(f'<p class="caption">95 % intervals of the fitted parameters from '
                    f"{escape(intervals)}.</p>", section=SECTIONS["fit"])
    _cite(report, SECTIONS["fit"], "Model:")
    _add(report, parameter_roles(fit_doc, fit), SECTIONS["fit"])
    return [forces, summary]


def add_all_subjects(report: Report, figures: Sequence[Mapping[str, Any]]) -> None:
    """The figures of no one subject: all subjects' F_el first, then the model's figures.

    Parameters
    ----------
    report : Report
        The page.
    figures : sequence of mapping
        fit.json's figure records, each with its ``file``.

    Returns
    -------
    None
    """
    study_wide = [f for f in figures if f.get("subject") is None
                  and f.get("kind") not in ("trial", "frequency_response", "population")]
    study_wide.sort(key=lambda f: f.get("kind") != "electrostatic_force_all")
    for f in study_wide:
        _figure(report, f, SECTIONS["all"])


def add_models(report: Report, models: pd.DataFrame | None,
               figures: Sequence[Mapping[str, Any]], subjects: Sequence[str]) -> None:
    """The model comparison: each subject's models ranked by AIC, and F_el vs frequency.

    Parameters
    ----------
    report : Report
        The page.
    models : DataFrame or None
        ``models.csv`` (None: no models were compared; the section then holds the
        ``frequency_response`` figures alone, and is left out without them).
    figures : sequence of mapping
        fit.json's figure records, each with its ``file``.
    subjects : sequence of str
        The subjects, in order.

    Returns
    -------
    None
    """
    responses = [f for f in figures if f.get("kind") == "frequency_response"]
    if models is None and not responses:
        return
    sec = SECTIONS["models"]
    _cite(report, sec, "The paper's model and its variants; the paper:")
    for s in subjects:
        if models is not None and (models["subject"].astype(str) == s).any():
            _add(report, model_comparison(models, s), sec)
        for f in figures:
            if f in responses and f.get("subject") == s:
                _figure(report, f, sec)


def _excluded_in(caption: str) -> str:
    """What a trial check's caption says was excluded (``excluded (hatched): ...``)."""
    m = re.search(r"\bexcluded(?: \([^)]*\))?: (.+?)\.?$", caption.strip())
    return m.group(1).strip() if m else ""


def trial_summary(row: Mapping[str, Any], windows: pd.DataFrame,
                  failed: Mapping[str, str], caption: str = "") -> str:
    """The summary line of a trial's check: name, drive, windows, what was left out.

    Parameters
    ----------
    row : mapping
        The trial's row of ``trials.csv``.
    windows : DataFrame
        The trial's rows of ``windows.csv``.
    failed : mapping of str to str
        ``subject/trial`` -> why it was not analysed.
    caption : str
        The caption of the trial's check figure: the stretches it names as excluded
        (``excluded (hatched): ON/OFF switch (guard) 0.64 s.``) are named too.

    Returns
    -------
    str
        E.g. ``run-03: square 10 kHz, 160 V; 2 ON / 4 OFF windows; excluded: 1 damaged
        line``.
    """
    key = f"{row.get('subject')}/{row.get('trial')}"
    drive = " ".join(x for x in (str(row.get("waveform") or ""),
                                 frequency(row.get("frequency_Hz"))) if x and x != "—")
    parts = [f"{row.get('trial')}: {drive}, {voltage(row.get('amplitude_V'))}"]
    cond = windows["condition"].astype(str).str.lower() if not windows.empty else None
    if cond is not None:
        parts.append(f"{int((cond == 'on').sum())} ON / {int((cond == 'off').sum())} OFF "
                     "windows")
    excluded = [x for x in (_excluded_in(caption),) if x]
    for col, what in (("dropped_frames", "dropped frame(s)"),
                      ("skipped_lines", "damaged line(s) skipped")):
        n = to_float(row.get(col))
        if math.isfinite(n) and n > 0:
            excluded.append(f"{int(n)} {what}")
    if key in failed:
        excluded.append(f"not analysed: {failed[key]}")
    parts.append("excluded: " + ", ".join(excluded) if excluded else "nothing excluded")
    return "; ".join(parts)


def _forces_of(rows: pd.DataFrame) -> pd.DataFrame:
    """A subject's rows of electrostatic.csv in readable units."""
    out = pd.DataFrame({
        "waveform": rows["waveform"].astype(str),
        "frequency": [frequency(f) for f in rows.get("frequency_Hz", [math.nan] * len(rows))],
        "amplitude": [voltage(a) for a in rows["amplitude_V"]],
        "μ": [significant(m) for m in rows["mu"]],
        "F_n ON (mN)": [significant(1e3 * to_float(x)) for x in rows["normal_force_on_N"]],
        "F_el (mN) [95 %]": [
            with_interval(1e3 * to_float(v), 1e3 * to_float(lo), 1e3 * to_float(hi))
            for v, lo, hi in zip(rows["electrostatic_force_N"],
                                 rows["electrostatic_force_ci_low_N"],
                                 rows["electrostatic_force_ci_high_N"], strict=True)]})
    for col, name in (("n_on", "ON windows"), ("n_off", "OFF windows")):
        if col in rows.columns:
            out[name] = [str(int(n)) if math.isfinite(to_float(n)) else "—"
                         for n in rows[col]]
    return out


def add_subjects(report: Report, tables: ResultTables, trials: pd.DataFrame,
                 figures: Sequence[Mapping[str, Any]]) -> None:
    """One section per subject: forces, figures, trials, each trial's check folded.

    Parameters
    ----------
    report : Report
        The page.
    tables : ResultTables
        The result folder's tables.
    trials : DataFrame
        ``trials.csv`` with the sidecars' notes.
    figures : sequence of mapping
        fit.json's figure records, each with its ``file``.

    Returns
    -------
    None
    """
    failed = {str(f.get("trial")): str(f.get("error")) for f in tables.summary.failed_trials}
    for subject in tables.subjects:
        sec = f"Subject {subject}"
        es = tables.electrostatic[tables.electrostatic["subject"].astype(str) == subject]
        report.add_table(_forces_of(es), "Electrostatic force", section=sec, wrap=True)
        for f in figures:
            if f.get("subject") == subject and f.get("kind") not in (
                    "trial", "frequency_response"):
                _figure(report, f, sec)
        mine = trials[trials["subject"].astype(str) == subject]
        report.add_table(_trials_view(mine), "Trials", section=sec, wrap=True)
        checks = {str(f.get("trial")): f for f in figures
                  if f.get("kind") == "trial" and f.get("subject") == subject}
        win = tables.windows
        for _, row in mine.iterrows():
            fig = checks.pop(str(row["trial"]), None)
            if fig is not None:
                w = win[(win["subject"].astype(str) == subject)
                        & (win["trial"].astype(str) == str(row["trial"]))]
                _figure(report, fig, sec,
                        details=trial_summary({str(k): v for k, v in row.items()}, w, failed,
                                              str(fig.get("caption") or "")))
        for trial, fig in checks.items():  # a check of a trial trials.csv does not list
            _figure(report, fig, sec, details=f"{trial}: not in trials.csv")


def _trials_view(trials: pd.DataFrame) -> pd.DataFrame:
    """trials.csv for people: forces' offsets in mN, frequencies with their unit."""
    view = pd.DataFrame({"trial": trials["trial"].astype(str)})
    if "waveform" in trials.columns:
        nan = pd.Series([math.nan] * len(trials), index=trials.index)
        view["drive"] = [f"{w} {frequency(f)}, {voltage(a)}" for w, f, a in zip(
            trials["waveform"].astype(str), trials.get("frequency_Hz", nan),
            trials.get("amplitude_V", nan), strict=True)]
    names = {"condition": "condition", "duration_s": "duration (s)", "frames": "frames",
             "dropped_frames": "dropped frames", "skipped_lines": "damaged lines"}
    for col, name in names.items():
        if col in trials.columns:
            view[name] = [significant(v, 3) if col == "duration_s" else
                          (str(int(to_float(v))) if math.isfinite(to_float(v)) else str(v))
                          for v in trials[col]]
    for col, name in (("normal_offset_N", "normal offset"),
                      ("tangential_offset_N", "tangential offset")):
        if col in trials.columns:
            view[name] = [quantity(v, "N", prefix="m") if math.isfinite(to_float(v))
                          else "—" for v in trials[col]]
    for col in ("tare", "notes"):
        if col in trials.columns:
            view[col] = [("" if v is None or (isinstance(v, float) and math.isnan(v))
                          else str(v)) for v in trials[col]]
    return view


def add_warnings(report: Report, warnings: Sequence[str]) -> None:
    """The warnings: the study now against the analysis, then the analysis's, each once.

    Parameters
    ----------
    report : Report
        The page.
    warnings : sequence of str
        The warnings, in order.

    Returns
    -------
    None
    """
    report.add_list(warnings, "Warnings", section=SECTIONS["warnings"],
                    caption="The study folder now against the inputs summary.json records; "
                            "then from summary.json, trials.csv (dropped frames, skipped "
                            "lines) and the model comparison.")


def _facts(tables: ResultTables, fit_doc: FitDocument, study: str) -> pd.DataFrame:
    summary = tables.summary
    facts = [{"item": "study", "value": study},
             {"item": "result folder", "value": str(tables.out)}]
    for k in _SUMMARY_KEYS:
        if k in summary:
            v = summary[k]
            facts.append({"item": k, "value": json.dumps(v) if isinstance(v, dict | list)
                          else significant(v) if isinstance(v, float) else str(v)})
    facts.append({"item": "subjects", "value": ", ".join(tables.subjects)})
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
        return significant(value, 4) if not float(value).is_integer() else str(int(value))
    return json.dumps(value) if isinstance(value, dict | list) else str(value)


def add_provenance(report: Report, tables: ResultTables, fit_doc: FitDocument, *,
                   study: str, study_dir: Path | None, inputs: pd.DataFrame,
                   trials: pd.DataFrame, rig: Mapping[str, Any], output: Path) -> None:
    """The last section: facts, trials, power laws, inputs, files, rig, software, settings.

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
    view = _trials_view(trials)
    view.insert(0, "subject", trials["subject"].astype(str).to_numpy())
    report.add_table(view, "Trials", section=sec, wrap=True,
                     caption="From trials.csv; notes from the trials' sidecars when the "
                             "study folder is available.")
    ex = tables.exponents
    if not ex.empty:
        report.add_table(pd.DataFrame({
            "subject": ex["subject"].astype(str), "waveform": ex["waveform"].astype(str),
            "frequency": [frequency(f) for f in ex.get("frequency_Hz", [math.nan] * len(ex))],
            "exponent n [95 %]": [f"{significant(n)} [{significant(lo)}, {significant(hi)}]"
                                  for n, lo, hi in zip(ex["exponent"], ex["exponent_ci_low"],
                                                       ex["exponent_ci_high"], strict=True)],
            "k at 1 V": [quantity(k, "N") for k in ex.get("prefactor_N", [math.nan] * len(ex))],
        }), "Power laws F_el = k·U^n (exponents.csv)", section=sec)
    if not inputs.empty:
        caption = (f"now: each file of the study folder {study_dir} hashed again"
                   if study_dir is not None else "The study folder named in summary.json is "
                   "not available here: the inputs could not be hashed again.")
        report.add_table(inputs, "Input files (as recorded in summary.json)", section=sec,
                         caption=caption, wrap="anywhere")
    else:
        report.add_text("summary.json records no input files inside the study folder.",
                        section=sec)
    report.add_table(_result_files(tables.out, output), "Result files", section=sec,
                     wrap="anywhere")
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
