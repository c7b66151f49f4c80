"""The sections of ``evtribo report``'s page, in the order a reader wants them.

1. the key results: a sentence, a table per voltage and one per subject
   (:mod:`evtribo.report.lead`);
2. the warnings, each kind once, by what they do to the reported numbers;
3. the electrostatic force by subject and voltage (mN, 95 % intervals; the cells a warning
   touches linked to it), what was analysed and left out per subject, and the methods;
4. the model fit per subject (air gap in µm, exponents, μ) and the model's parameters, each
   said to be measured, fixed or fitted, with the paper cited; then the population's
   estimates (:mod:`evtribo.report.population`);
5. the measured figures of all subjects together (``electrostatic_force_all`` first) and,
   with :data:`GRID_FROM` subjects or more, each kind of per-subject figure that has a grid
   as one grid of small multiples;
6. the model's predictions (nothing measured: ``area_increase``);
7. the model comparison (``models.csv`` ranked over the study and per subject, and the
   ``frequency_response`` figures), when there is one;
8. one section per subject: its forces, its figures (when not in a grid), its trials, and
   each trial's check figure folded in a ``<details>`` element;
9. provenance and settings (:mod:`evtribo.report.provenance`).

Every figure is placed where its kind's spec in the figure registry says
(:func:`evtribo.figures.registry.placement`: its section, and its grid); every number is
printed for people (:mod:`evtribo.util.numbers`), every frequency as ``10 kHz``; every
figure links its files.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd
from markupsafe import escape

from evtribo.documents.fit import FitDocument
from evtribo.figures.registry import placement
from evtribo.fit.tables import ResultTables
from evtribo.report.friction_report import add_trial_mu
from evtribo.report.headline import (
    CITATION,
    DOI_URL,
    Headline,
    fit_summary,
    force_table,
    model_comparison,
    model_ranking,
    parameter_roles,
)
from evtribo.report.lead.marks import Marks
from evtribo.report.lead.sections import KEY_SECTION, WARNINGS_SECTION, add_analysed, hertz
from evtribo.report.page import Report
from evtribo.util.numbers import frequency, quantity, significant, to_float, voltage, with_interval

__all__ = ["GRID_FROM", "SECTIONS", "add_all_subjects", "add_headline", "add_models",
           "add_predictions", "add_subjects", "figure_files", "placed",
           "trial_summary", "trials_view"]

#: The sections' titles, in the page's order (a subject's is ``Subject <name>``).
SECTIONS: dict[str, str] = {
    "key": KEY_SECTION, "warnings": WARNINGS_SECTION,
    "forces": "Electrostatic force", "fit": "Model fit", "all": "All subjects",
    "predictions": "Model predictions", "models": "Model comparison",
    "provenance": "Provenance and settings"}
#: With this many subjects or more, each kind of per-subject figure is one grid.
GRID_FROM = 4


def _add(report: Report, headline: Headline, section: str, **kwargs: Any) -> None:
    report.add_table(headline.table, headline.title, caption=hertz(headline.caption),
                     section=section, wrap=True, **kwargs)


def figure_files(fig: Mapping[str, Any]) -> list[Path]:
    """The files of a figure record in its result folder's figures/ (PNG, SVG, PDF).

    Parameters
    ----------
    fig : mapping
        A fit.json figure record with its ``file`` (one of them).

    Returns
    -------
    list of Path
        Those that exist.
    """
    first = Path(fig["file"])
    return [f for f in (first.with_suffix(s) for s in (".png", ".svg", ".pdf")) if f.is_file()]


def placed(figures: Sequence[Mapping[str, Any]], section: str) -> list[Mapping[str, Any]]:
    """The figures the report places in one section, in the registry's order of their
    kinds (fit.json's order within a kind).

    Parameters
    ----------
    figures : sequence of mapping
        fit.json's figure records.
    section : str
        One of :data:`evtribo.figures.registry.SECTIONS`.

    Returns
    -------
    list of mapping
    """
    mine = [(placement(f), f) for f in figures]
    return [f for p, f in sorted(((p, f) for p, f in mine if p.section == section),
                                 key=lambda pf: pf[0].order)]


def _grids(figures: Sequence[Mapping[str, Any]]) -> dict[str, tuple[str, str]]:
    """The kinds of per-subject figures shown as one grid with many subjects, each with
    the grid's title and caption, in the registry's order."""
    out: dict[str, tuple[str, str]] = {}
    for f in placed(figures, "subject"):
        grid = placement(f).grid
        if grid is not None:
            out.setdefault(str(f.get("kind")), grid)
    return out


def _cite(report: Report, section: str, lead: str) -> None:
    report.add_html(f'<p class="cite">{escape(lead)} {escape(CITATION)} '
                    f'(<a href="{DOI_URL}">{DOI_URL}</a>).</p>', section=section)


def _figure(report: Report, fig: Mapping[str, Any], section: str,
            details: str | None = None) -> None:
    report.add_figure(fig["file"], hertz(str(fig.get("title") or fig.get("stem"))),
                      caption=hertz(str(fig.get("caption") or "")), section=section,
                      details=None if details is None else hertz(details),
                      links=figure_files(fig))


def _force_marks(headline: Headline, electrostatic: pd.DataFrame, marks: Marks
                 ) -> dict[tuple[int, str], list[tuple[str, str]]]:
    """The links of the force table's cells to the warnings that touch them."""
    out: dict[tuple[int, str], list[tuple[str, str]]] = {}
    es = electrostatic.reset_index(drop=True)
    waves = es["waveform"].fillna("").astype(str)
    freqs = pd.to_numeric(es.get("frequency_Hz", pd.Series(math.nan, index=es.index)),
                          errors="coerce")
    for i, row in enumerate(headline.table.to_dict("records")):
        for j in es.index[(es["subject"].astype(str) == str(row["Subject"]))
                          & (waves == ("" if row["Waveform"] == "—" else row["Waveform"]))]:
            if frequency(freqs[j]) != row["Frequency"]:
                continue
            ks = marks.by_row[j]
            if ks:
                out[(i, voltage(es.loc[j, "amplitude_V"]))] = [(f"W{k}", f"#w{k}") for k in ks]
    return out


def add_headline(report: Report, tables: ResultTables, fit: pd.DataFrame,
                 fit_doc: FitDocument, marks: Marks | None = None) -> list[Headline]:
    """The sections of F_el by subject and voltage (with what was analysed and how), and of
    the fit.

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
    marks : Marks, optional
        The warnings touching each cell (linked from the force table's cells).

    Returns
    -------
    list of Headline
        The two headline tables (what ``--tables`` exports).
    """
    forces, summary = force_table(tables.electrostatic), fit_summary(fit, fit_doc)
    links = _force_marks(forces, tables.electrostatic, marks) if marks is not None else {}
    every = ", ".join(f"W{k}" for k in marks.everywhere) if marks is not None else ""
    _add(report, forces if not every else Headline(
        forces.stem, forces.title, forces.caption + f" Every cell: see {every}.",
        forces.table), SECTIONS["forces"], marks=links, anchor="forces")
    methods = {str(v.get("interval", {}).get("method", "jacobian"))
               for v in fit_doc.subjects.values() if isinstance(v, dict)}
    add_analysed(report, tables, SECTIONS["forces"], bootstrap=methods == {"bootstrap"})
    _add(report, summary, SECTIONS["fit"])
    how = {"bootstrap": "refits to the bootstrap replicates of the electrostatic forces",
           "jacobian": "the fit's Jacobian (each point's error taken as independent)"}
    intervals = " or ".join(how.get(m, m) for m in sorted(methods)) or how["jacobian"]
    report.add_html(f'<p class="caption">95 % intervals of the fitted parameters from '
                    f"{escape(intervals)}.</p>", section=SECTIONS["fit"])
    _cite(report, SECTIONS["fit"], "Model:")
    _add(report, parameter_roles(fit_doc, fit), SECTIONS["fit"])
    return [forces, summary]


def add_all_subjects(report: Report, figures: Sequence[Mapping[str, Any]],
                     subjects: Sequence[str] = ()) -> None:
    """The measured figures of no one subject (all subjects' F_el first) and, with
    :data:`GRID_FROM` subjects or more, each kind of per-subject figure as one grid.

    Parameters
    ----------
    report : Report
        The page.
    figures : sequence of mapping
        fit.json's figure records, each with its ``file``.
    subjects : sequence of str
        The subjects, in order.

    Returns
    -------
    None
    """
    for f in placed(figures, "all"):
        _figure(report, f, SECTIONS["all"])
    if len(subjects) < GRID_FROM:
        return
    for kind, (title, caption) in _grids(figures).items():
        panels = [f for s in subjects for f in figures
                  if f.get("kind") == kind and f.get("subject") == s]
        if panels:
            report.add_figure_grid([(f["file"], str(f.get("subject"))) for f in panels],
                                   title, caption=caption, section=SECTIONS["all"],
                                   links=[p for f in panels for p in figure_files(f)])


def add_predictions(report: Report, figures: Sequence[Mapping[str, Any]]) -> None:
    """The model's predictions, apart from the measured results (``area_increase``).

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
    for f in placed(figures, "predictions"):
        _figure(report, f, SECTIONS["predictions"])


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
    responses = placed(figures, "models")
    if models is None and not responses:
        return
    sec = SECTIONS["models"]
    _cite(report, sec, "The paper's model and its variants; the paper:")
    if models is not None:
        _add(report, model_ranking(models), sec)
    for f in responses:  # of no one subject
        if f.get("subject") is None:
            _figure(report, f, sec)
    have = [s for s in subjects if models is not None
            and (models["subject"].astype(str) == s).any()]
    if models is not None and len(have) >= GRID_FROM:  # one table, a subject's rows together
        tables = [model_comparison(models, s) for s in have]
        joined = pd.concat([t.table.assign(subject=s) for s, t in zip(have, tables,
                                                                      strict=True)])
        joined = joined[["subject", *tables[0].table.columns]]
        _add(report, Headline("models_subjects", "Models compared per subject",
                              tables[0].caption, joined), sec)
        have = []
    for s in subjects:
        if models is not None and s in have:
            _add(report, model_comparison(models, s), sec)
        for f in responses:
            if f.get("subject") == s:
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
    analysed, total = to_float(row.get("analysed_s")), to_float(row.get("duration_s"))
    if math.isfinite(analysed) and math.isfinite(total) and total > 0:
        parts.append(f"analysed {significant(analysed, 3)} s of {significant(total, 3)} s")
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
                 figures: Sequence[Mapping[str, Any]], *, grid: bool = False) -> None:
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
    grid : bool
        The per-subject figures are in the grids of all subjects (not repeated here).

    Returns
    -------
    None
    """
    failed = {str(f.get("trial")): str(f.get("error")) for f in tables.summary.failed_trials}
    gridded = set(_grids(figures)) if grid else set()
    own, checked = placed(figures, "subject"), placed(figures, "checks")
    for subject in tables.all_subjects:
        sec = f"Subject {subject}"
        es = tables.electrostatic[tables.electrostatic["subject"].astype(str) == subject]
        mine = trials[trials["subject"].astype(str) == subject]
        if es.empty:  # no ON windows to compare: the friction coefficient of each trial
            add_trial_mu(report, mine, tables.windows, sec)
        else:
            report.add_table(_forces_of(es), "Electrostatic force", section=sec, wrap=True)
        for f in own:
            if f.get("subject") == subject and f.get("kind") not in gridded:
                _figure(report, f, sec)
        report.add_table(trials_view(mine), "Trials", section=sec, wrap=True)
        checks = {str(f.get("trial")): f for f in checked if f.get("subject") == subject}
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


def trials_view(trials: pd.DataFrame) -> pd.DataFrame:
    """trials.csv for people: forces' offsets in mN, frequencies with their unit.

    Parameters
    ----------
    trials : DataFrame
        ``trials.csv`` (with the sidecars' notes, when the study is at hand).

    Returns
    -------
    DataFrame
        One row per trial, its columns worded and its numbers printed for people.
    """
    view = pd.DataFrame({"trial": trials["trial"].astype(str)})
    if "waveform" in trials.columns:
        nan = pd.Series([math.nan] * len(trials), index=trials.index)
        view["drive"] = [f"{w} {frequency(f)}, {voltage(a)}" for w, f, a in zip(
            trials["waveform"].astype(str), trials.get("frequency_Hz", nan),
            trials.get("amplitude_V", nan), strict=True)]
    names = {"condition": "condition", "duration_s": "duration (s)",
             "analysed_s": "analysed (s)", "frames": "frames",
             "dropped_frames": "dropped frames", "skipped_lines": "damaged lines"}
    for col, name in names.items():
        if col in trials.columns:
            view[name] = [significant(v, 3) if col.endswith("_s") else
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
