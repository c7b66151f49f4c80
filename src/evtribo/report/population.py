"""The report's "Population" section: what a paper reports of the whole study.

After the per-subject fit: the population's electrostatic force at each amplitude (mN, 95 %
intervals; every subject in, from the nonlinear mixed model on the linear scale), its power
law's exponent against the seed paper's limits (2 when the normal force dominates the
contact, eq. 13; 10/3 when the voltage does, eq. 12), its prefactor, friction coefficient and
air gap with the prediction intervals for a new subject and the model's checks; the relative
friction increase; each subject's test of F_el > 0 (Holm); the spread between subjects (tau
and I^2 with their intervals); the estimates without each subject far from the others; the
meta-analysis of log F_el where it is valid, as a second method; the contrasts between
conditions; the subjects excluded beforehand; what could not be estimated and why; a
paragraph for a methods section; and the population's figures. It reads compare's
population.csv, population_contrasts.csv, population_subjects.csv and fit.json's population.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo.documents.fit import FitDocument
from evtribo.documents.population_table import (
    EXPONENT,
    FORCE,
    META,
    PREFACTOR,
    PRIMARY,
    Drive,
    PopulationRow,
    PopulationTable,
)
from evtribo.documents.quantities import FRICTION_INCREASE_DEFINITION, FRICTION_INCREASE_HEADING
from evtribo.documents.result_folder import ResultFolder
from evtribo.errors import FORCE as FORCE_OPTION
from evtribo.population.data import PopulationOutlier
from evtribo.population.per_subject import subjects_view
from evtribo.population.stats import MIN_SUBJECTS
from evtribo.report.headline import Headline
from evtribo.report.lead.population_methods import methods_paragraph
from evtribo.report.page import Report
from evtribo.util.numbers import frequency, quantity, significant, to_float, voltage, with_interval

__all__ = ["INCREASE_CAPTION", "INCREASE_TITLE", "SECTION", "SUBJECTS_CAPTION", "SUBJECTS_TITLE",
           "add_population", "exponent_verdict", "population_headline",
           "read_population", "read_subjects"]

#: The section's title.
SECTION = "Population"
#: "times or divided by", before a factor of spread.
_TIMES = "\u00d7/\u00f7"
#: The seed paper's limits of the exponent (eqs. 13 and 12).
LIMITS = ((Fraction(2), "the square law of a contact set by the normal force (eq. 13)"),
          (Fraction(10, 3), "the limit of a contact set by the voltage (eq. 12)"))
#: population.csv's quantity of the relative friction increase.
INCREASE = "friction_increase_pct"
#: Tables 9 and 10: the population's relative friction increase and each subject's.
INCREASE_TITLE = FRICTION_INCREASE_HEADING[:1].upper() + FRICTION_INCREASE_HEADING[1:]
INCREASE_CAPTION = (f"The {FRICTION_INCREASE_DEFINITION}. The population's: the mean over "
                    "subjects [95 % interval], every subject in (population.csv).")
SUBJECTS_TITLE = f"Each subject: {FRICTION_INCREASE_HEADING} and F_el > 0"
SUBJECTS_CAPTION = (f"The {FRICTION_INCREASE_DEFINITION}. Each subject's [95 % interval] at "
                    "each amplitude (population_subjects.csv), and the one-sided test of "
                    "F_el > 0 (its forces weighted as U^2) with Holm's correction over the "
                    "study's subjects and conditions (family-wise 5 %).")


def _as_read(frame: pd.DataFrame | None) -> pd.DataFrame | None:
    """A population table as the section reads it: "" where a waveform, the checks or the
    analysis is missing (mu's and h_L's rows), as in memory."""
    if frame is None:
        return None
    frame = frame.copy()
    for col in ("waveform", "checks", "analysis"):
        if col in frame.columns:
            frame[col] = frame[col].fillna("").astype(str)
    return frame


def read_population(folder: Path | ResultFolder
                    ) -> tuple[pd.DataFrame | None, pd.DataFrame | None]:
    """population.csv and population_contrasts.csv of a result folder (None when absent).

    Parameters
    ----------
    folder : Path or ResultFolder
        The result folder (read through :class:`~evtribo.documents.result_folder.ResultFolder`).

    Returns
    -------
    (DataFrame or None, DataFrame or None)

    Raises
    ------
    ResultFolderError
        A file that cannot be read or lacks a column.
    """
    results = folder if isinstance(folder, ResultFolder) \
        else ResultFolder.compare_documents(folder)
    table = results.population
    return _as_read(None if table is None else table.frame), _as_read(results.contrasts)


def read_subjects(folder: Path | ResultFolder) -> pd.DataFrame | None:
    """population_subjects.csv of a result folder (None when absent).

    Parameters
    ----------
    folder : Path or ResultFolder
        The result folder.

    Returns
    -------
    DataFrame or None
        Raises ResultFolderError as :func:`read_population` does.
    """
    results = folder if isinstance(folder, ResultFolder) \
        else ResultFolder.compare_documents(folder)
    return _as_read(results.population_subjects)


def _drives(table: PopulationTable) -> list[Drive]:
    """The table's drives as the key results order them: those of more amplitudes first,
    then by waveform and frequency."""
    amps = {d: len({r.amplitude_V for r in table if r.drive == d}) for d in table.drives()}
    return sorted(amps, key=lambda d: -amps[d])


def _amps(rows: Sequence[PopulationRow]) -> list[float]:
    return sorted({r.amplitude_V for r in rows if r.amplitude_V is not None})


def _by_amplitude(table: PopulationTable, key: tuple[str, Drive, str], amps: Sequence[float],
                  cell: Callable[[PopulationRow], str]) -> dict[str, str]:
    """A drive's cells of *quantity_name* at each amplitude, by key ("—" where none)."""
    out = {}
    for a in amps:
        hit = table.row(key[0], key[1], a, key[2])
        out[voltage(a)] = "—" if hit is None else cell(hit)
    return out


def _mN(r: PopulationRow) -> str:
    return with_interval(1e3 * r.estimate, 1e3 * r.ci_low, 1e3 * r.ci_high)


def _pct(r: PopulationRow) -> str:
    return with_interval(r.estimate, r.ci_low, r.ci_high)


def population_headline(table: PopulationTable) -> Headline:
    """The population's F_el in mN with its 95 % interval: a row per drive.

    Parameters
    ----------
    table : PopulationTable
        ``population.csv`` (its primary rows are shown).

    Returns
    -------
    Headline
        Columns ``Waveform``, ``Frequency``, then one per amplitude (``80 V``), then the
        spread between subjects and the subjects counted.
    """
    drives = [d for d in _drives(table) if table.rows(FORCE, d)]
    amps = _amps([r for d in drives for r in table.rows(FORCE, d)])
    rows = []
    for drive in drives:
        mine = table.rows(FORCE, drive)
        row = {"Waveform": drive.waveform or "", "Frequency": frequency(drive.frequency_Hz),
               **_by_amplitude(table, (FORCE, drive, PRIMARY), amps, _mN)}
        sd = pd.Series([r.between_subject_sd for r in mine], dtype=float)
        row["spread between subjects"] = (f"{_TIMES} {significant(math.exp(sd.median()))}"
                                          if len(sd) else "—")
        n = [r.n_subjects or 0 for r in mine]
        row["subjects"] = (str(min(n)) if min(n) == max(n) else f"{min(n)}-{max(n)}") \
            if n else "—"
        rows.append(row)
    return Headline(
        "population", "The population's electrostatic force F_el (mN)",
        "Geometric mean over the subjects of the inferred electrostatic force at each "
        "amplitude [95 % interval], in mN: the power law across every subject of a nonlinear "
        "mixed model on the linear scale, each subject's force with its own error (forces "
        "near or below zero count); the spread between subjects as the factor of one "
        "standard deviation of log F_el (median over the amplitudes).",
        pd.DataFrame(rows, columns=["Waveform", "Frequency", *(voltage(a) for a in amps),
                                    "spread between subjects", "subjects"]))


def exponent_verdict(estimate: float, low: float, high: float) -> str:
    """What the population's exponent says of the seed paper's two limits.

    Parameters
    ----------
    estimate, low, high : float
        The exponent and its 95 % interval.

    Returns
    -------
    str
        E.g. ``n = 2.05 [1.98, 2.12]: the interval holds 2 (...); it lies below 10/3 (...)``.
    """
    parts = []
    for limit, what in LIMITS:
        shown = str(limit)
        if low <= float(limit) <= high:
            parts.append(f"the interval holds {shown}, {what}")
        elif high < float(limit):
            parts.append(f"it lies below {shown}, {what}")
        else:
            parts.append(f"it lies above {shown}, {what}")
    return f"n = {with_interval(estimate, low, high)}: " + "; ".join(parts)


def _value(r: PopulationRow, unit: str, *, prediction: bool = False) -> str:
    est = r.estimate
    lo, hi = (r.pi_low, r.pi_high) if prediction else (r.ci_low, r.ci_high)
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "—"
    if unit:
        return f"{quantity(est, unit)} [{quantity(lo, unit)}, {quantity(hi, unit)}]"
    return with_interval(est, lo, hi)


_NAMES = {FORCE: "F_el", INCREASE: FRICTION_INCREASE_HEADING}
_SHOWN = {EXPONENT: ("exponent n", "", False), PREFACTOR: ("prefactor k at 1 V", "N", True),
          "mu": ("friction coefficient μ", "", False), "h_L_m": ("air gap h_L", "m", True)}


def _condition(drive: Drive | None) -> str:
    return "all" if drive is None else drive.label()


def _quantities(table: PopulationTable) -> pd.DataFrame:
    """Exponent, prefactor, μ and h_L: one row each (per drive where it applies), with
    the prediction interval for a new subject and the model's checks."""
    rows = []
    for drive in [*_drives(table), None]:
        for name, (label, unit, log_normal) in _SHOWN.items():
            r = table.row(name, drive)
            if r is None:
                continue
            sd = r.between_subject_sd
            rows.append({"quantity": label, "condition": _condition(drive),
                         "population [95 %]": _value(r, unit),
                         "a new subject [95 %]": _value(r, unit, prediction=True),
                         "spread between subjects": (f"{_TIMES} {significant(math.exp(sd))}"
                                                     if log_normal else f"SD {significant(sd)}"),
                         "subjects": "—" if r.n_subjects is None else str(r.n_subjects),
                         "checks": r.checks or "—",
                         "method": r.method})
    return pd.DataFrame(rows, columns=["quantity", "condition", "population [95 %]",
                                       "a new subject [95 %]", "spread between subjects",
                                       "subjects", "checks", "method"])


def _per_amplitude(table: PopulationTable, quantity_name: str, analysis: str,
                   cell: Callable[[PopulationRow], str]) -> pd.DataFrame:
    """A row per drive, a column per amplitude, of *quantity_name*'s rows."""
    drives = [d for d in _drives(table) if table.rows(quantity_name, d, analysis)]
    amps = _amps([r for d in drives for r in table.rows(quantity_name, d, analysis)])
    out = [{"condition": d.label(),
            **_by_amplitude(table, (quantity_name, d, analysis), amps, cell)} for d in drives]
    return pd.DataFrame(out, columns=["condition", *(voltage(a) for a in amps)])


def _where(r: PopulationRow) -> dict[str, str]:
    """A row's quantity (with its amplitude) and drive, for people."""
    name = _NAMES.get(r.quantity, _SHOWN.get(r.quantity, (r.quantity,))[0])
    return {"quantity": name + ("" if r.amplitude_V is None else f" at {voltage(r.amplitude_V)}"),
            "condition": _condition(r.drive)}


def _spread(table: PopulationTable) -> pd.DataFrame:
    """tau and I^2 with their intervals, for every row that has them."""
    rows = [{**_where(r), "analysis": r.analysis,
             "τ [95 %]": with_interval(r.between_subject_sd, r.between_sd_low,
                                       r.between_sd_high),
             "I² (%) [95 %]": with_interval(100 * r.i2, 100 * r.i2_low, 100 * r.i2_high)}
            for r in table if math.isfinite(r.i2) and r.analysis in (PRIMARY, META)]
    return pd.DataFrame(rows, columns=["quantity", "condition", "analysis", "τ [95 %]",
                                       "I² (%) [95 %]"])


def _sensitivity(table: PopulationTable) -> pd.DataFrame:
    """Every primary estimate beside the same without each subject far from the others."""
    rows = []
    for r in table:
        if not r.analysis.startswith("without "):
            continue
        unit = "N" if r.quantity == FORCE else _SHOWN.get(r.quantity, ("", ""))[1]
        same = table.row(r.quantity, r.drive, r.amplitude_V, PRIMARY)
        rows.append({**_where(r), "every subject [95 %]": "—" if same is None else
                     _value(same, unit), "analysis": r.analysis,
                     "sensitivity [95 %]": _value(r, unit)})
    return pd.DataFrame(rows, columns=["quantity", "condition", "every subject [95 %]",
                                       "analysis", "sensitivity [95 %]"])


def _contrasts_view(contrasts: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for _, r in contrasts.iterrows():
        ratio = str(r["quantity"]) == "electrostatic_force_N"
        value = float(r["ratio"] if ratio else r["difference"])
        rows.append({"compared": f"{r['condition_b']} against {r['condition_a']}",
                     "quantity": "F_el ratio" if ratio else "exponent difference",
                     "value [95 %]": with_interval(value, r["ci_low"], r["ci_high"]),
                     "subjects": str(int(r["n_subjects"]))})
    return pd.DataFrame(rows, columns=["compared", "quantity", "value [95 %]", "subjects"])


def _outliers(doc: Mapping[str, Any]) -> list[str]:
    """One line per subject far from the others: its values outside the others'
    prediction intervals."""
    by_subject: dict[str, list[str]] = {}
    for o in doc.get("outliers") or []:
        if isinstance(o, Mapping):
            found = PopulationOutlier(str(o.get("subject")), str(o.get("quantity")),
                                      to_float(o.get("value")), to_float(o.get("low")),
                                      to_float(o.get("high")), str(o.get("unit") or ""))
            by_subject.setdefault(found.subject, []).append(
                found.describe().removeprefix(f"{found.subject}: "))
    return [f"{subject} lies far from the other subjects: {'; '.join(items)}. It is in every "
            "estimate above; the table of sensitivity gives them without it. Check its "
            "trials (a load cell, the finger's posture, a note) before reading it as a real "
            "difference." for subject, items in by_subject.items()]


def _excluded(doc: Mapping[str, Any]) -> list[dict[str, str]]:
    return [{"subject": str(e.get("subject")), "reason": str(e.get("reason"))}
            for e in doc.get("excluded") or [] if isinstance(e, Mapping)]


def _why_not(notes: Sequence[str], what: str = "") -> str:
    """Why *what* (default: anything) was not estimated: the first note, or a re-run hint."""
    if notes:
        return f"No population estimate{f' of {what}' if what else 's'}: {notes[0]}."
    return ("No population estimates: this comparison was made by an older evtribo compare; "
            f"run `evtribo compare OUT {FORCE_OPTION}` for them (they need at least "
            f"{MIN_SUBJECTS} "
            "subjects with electrostatic forces).")


def _has_forces(table: PopulationTable) -> bool:
    return any(r.quantity == FORCE for r in table)


def _exponent_text(report: Report, table: PopulationTable, drive: Drive) -> None:
    """A drive's exponent against the seed paper's limits, or that its checks failed."""
    r = table.row(EXPONENT, drive)
    if r is None:
        return
    checks = table.checks(drive) if r.checks else None
    if checks is not None and not checks.holds(EXPONENT):
        report.add_text(f"{drive.label()}: the population's exponent is undetermined: the "
                        f"mixed model's checks failed ({checks.text}); its value in the table "
                        "below is no evidence for either of the seed paper's limits.",
                        section=SECTION)
        return
    report.add_text(f"{drive.label()}: the population's exponent "
                    + exponent_verdict(r.estimate, r.ci_low, r.ci_high) + ".", section=SECTION)


def add_population(report: Report, table: PopulationTable | None,
                   contrasts: pd.DataFrame | None, fit_doc: FitDocument,
                   figures: Sequence[Mapping[str, Any]], *, friction_only: bool = False
                   ) -> list[Headline]:
    """The "Population" section (nothing, or why not, when there are no estimates).

    Parameters
    ----------
    report : Report
        The page.
    table : PopulationTable or None
        ``population.csv``, with fit.json's checks of each drive (None when absent).
    contrasts : DataFrame or None
        ``population_contrasts.csv`` (None when absent).
    fit_doc : FitDocument
        ``fit.json`` (its ``population``: subjects, notes, outliers, exclusions);
        ``population_subjects.csv`` is read beside it.
    figures : sequence of mapping
        fit.json's records of this section's figures, each with its ``file``.
    friction_only : bool
        A study of OFF trials: the population's μ only, or why there is none.

    Returns
    -------
    list of Headline
        The population's table (for ``--tables``), or none.
    """
    doc = fit_doc.population
    notes = [n for n in doc.get("notes") or [] if isinstance(n, str)]
    headlines: list[Headline] = []
    if table is None or not _has_forces(table):
        # fewer than three subjects with F_el: at most mu's row
        notes = notes[1:] if friction_only else notes
        if not friction_only or table is None or not len(table):
            report.add_text(_why_not(notes, "μ" if friction_only else ""), section=SECTION)
        if table is None or not len(table):
            return []
    else:
        headline = population_headline(table)
        report.add_table(headline.table, headline.title, caption=headline.caption,
                         section=SECTION, wrap=True)
        headlines.append(headline)
    for drive in _drives(table):
        _exponent_text(report, table, drive)
    _tables(report, table, contrasts, fit_doc, only_mu={r.quantity for r in table} == {"mu"})
    for title, items in (("Far from the other subjects", _outliers(doc)),
                         ("Excluded beforehand", [f"{e['subject']}: {e['reason']}"
                                                  for e in _excluded(doc)])):
        if items:
            report.add_list(items, title, section=SECTION)
    for f in figures:
        report.add_figure(f["file"], str(f.get("title") or f.get("stem")),
                          caption=str(f.get("caption") or ""), section=SECTION)
    report.add_text(methods_paragraph(table, doc, _excluded(doc)), "For a methods section",
                    section=SECTION)
    return headlines


def _subjects_of(fit_doc: FitDocument) -> pd.DataFrame:
    """population_subjects.csv beside fit.json (empty when there is none)."""
    if fit_doc.path is None:
        return pd.DataFrame()
    subjects = read_subjects(fit_doc.path.parent)
    return pd.DataFrame() if subjects is None or subjects.empty else subjects_view(subjects)


def _tables(report: Report, table: PopulationTable, contrasts: pd.DataFrame | None,
            fit_doc: FitDocument, *, only_mu: bool) -> None:
    """The section's tables after the headline."""
    report.add_table(_quantities(table), "The population's friction coefficient μ" if only_mu
                     else "The population's power law, μ and air gap",
                     caption="Population value [95 % interval], and where a new subject's "
                             "value would lie [95 % prediction interval]; the spread as the "
                             "standard deviation of the subjects' μ." if only_mu else
                     "Population value [95 % interval], and where a new subject's value "
                     "would lie [95 % prediction interval]; for k and h_L the geometric mean, "
                     "the spread as the factor of one standard deviation of their log; "
                     "checks: the mixed model's (finite log-likelihood, positive-definite "
                     "Hessian, the optimisers' agreement, a determined exponent).",
                     section=SECTION, wrap=True)
    views = [
        (_per_amplitude(table, INCREASE, PRIMARY, _pct), INCREASE_TITLE, INCREASE_CAPTION),
        (_subjects_of(fit_doc), SUBJECTS_TITLE, SUBJECTS_CAPTION),
        (_spread(table), "Spread between subjects: τ and I²",
         "τ: the between-subject SD (of log F_el for forces) [95 % interval: Satterthwaite's "
         "for the mixed model, Q-profile for the meta-analyses]; I²: its share of the "
         "subjects' scatter beyond their measurements' errors."),
        (_sensitivity(table), "Sensitivity: without each subject far from the others",
         "Each estimate with every subject (as above) and without the subject named far "
         "from the others."),
        (_per_amplitude(table, FORCE, META, _mN),
         "A second method: meta-analysis of log F_el (mN)",
         "At the amplitudes where every subject's force has an interval above zero and "
         "a standard error of its log of at most 0.2: a random-effects meta-analysis of log "
         "F_el (Paule-Mandel, Hartung-Knapp), for comparison with the mixed model's."),
    ]
    for frame, title, caption in views:
        if not frame.empty and len(frame.columns) > 1:
            report.add_table(frame, title, caption=caption, section=SECTION, wrap=True)
    if contrasts is not None and not contrasts.empty:
        report.add_table(_contrasts_view(contrasts), "Between conditions",
                         caption="Within subjects measured in both: the ratio of F_el (over "
                                 "the amplitudes each has in both) and the difference of the "
                                 "exponents, pooled over subjects.", section=SECTION)
