"""What the report leads with: the study's answer in a sentence and two small tables.

- :func:`key_results`: one sentence (:func:`~evtribo.report.lead.claims.key_sentence`, a
  clause per drive); a table per voltage (the population's F_el, the subjects' range, the
  relative friction increase, how many subjects, the cells flagged by a warning) and one
  per subject (the air gap h_L, the exponent n of F_el ∝ U^n, the friction law's exponent m
  when the analysis gives it, the model verdict, the flagged cells), with the warnings
  (``W1``...) that touch each cell (:mod:`evtribo.report.lead.marks`).

The sentence, the table per voltage and the population's line of the table per subject show
the same claims (:func:`~evtribo.report.lead.claims.key_claims`): population.csv's primary
cells by key, "undetermined" where the mixed model's checks they rest on failed. The
relative friction increase is the one of
:data:`~evtribo.documents.quantities.FRICTION_INCREASE_DEFINITION`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from evtribo.documents.population_table import EXPONENT, FORCE, Drive, PopulationTable
from evtribo.documents.quantities import FRICTION_INCREASE_DEFINITION, FRICTION_INCREASE_HEADING
from evtribo.fit.models import INDISTINGUISHABLE, study_ranking, verdict
from evtribo.fit.tables import ResultTables
from evtribo.report.headline import Headline
from evtribo.report.lead.claims import AIR_GAP, INCREASE, Quoted, key_claims, key_sentence, nb
from evtribo.report.lead.marks import Marks, cell_marks, warning_anchor
from evtribo.util.numbers import (
    amplitude_key,
    r_squared,
    significant,
    to_float,
    voltage,
    with_interval,
)
from evtribo.warning.render import WarningGroup

__all__ = ["FRICTION_EXPONENT", "KeyResults", "key_results"]

#: Column of a per-subject table (electrostatic.csv or fit.csv) holding the exponent m of the
#: friction law F_t = c·W^m, with ``_ci_low`` and ``_ci_high``: a column of the per-subject
#: key table when present.
FRICTION_EXPONENT = "friction_exponent"
#: The headings of the population's F_el in the table per voltage and of n in the one per
#: subject.
_POPULATION, _N = "F_el (mN), population [95 %]", "n of F_el ∝ U^n [95 %]"


def _links(ks: Sequence[int]) -> list[tuple[str, str]]:
    return [(f"W{k}", f"#{warning_anchor(k)}") for k in ks]


def _f_el_cell(claim: Quoted | None) -> str:
    if claim is None:
        return "—"
    return {"quoted": claim.text, "undetermined": "undetermined"}.get(claim.state, "—")


def _increase_cell(claim: Quoted | None) -> str:
    if claim is None:
        return "—"
    return {"quoted": claim.text, "range": f"{claim.text} (subjects)"}.get(claim.state, "—")


def _by_voltage(tables: ResultTables, claims: Sequence[Quoted], marks: Marks
                ) -> tuple[Headline, dict[tuple[int, str], list[tuple[str, str]]]]:
    elec = tables.electrostatic.reset_index(drop=True)
    keys = [(Drive.of(w, f), amplitude_key(a)) for w, f, a in zip(
        elec["waveform"], elec["frequency_Hz"] if "frequency_Hz" in elec.columns
        else [None] * len(elec), elec["amplitude_V"], strict=True)]
    by_key = {(c.drive, c.amplitude_V, c.quantity): c for c in claims}
    drives = list(dict.fromkeys(c.drive for c in claims if c.drive is not None))
    rows: list[dict[str, str]] = []
    links: dict[tuple[int, str], list[tuple[str, str]]] = {}
    for drive in drives:
        for amp in [c.amplitude_V for c in claims if c.drive == drive
                    and c.quantity == FORCE]:
            sel = [i for i, k in enumerate(keys) if k == (drive, amp)]
            force = 1e3 * elec.loc[sel, "electrostatic_force_N"].to_numpy(float)
            flagged = sorted({k for i in sel for k in marks.by_row[i]})
            n_flagged = sum(bool(marks.by_row[i]) for i in sel)
            rows.append({
                "drive": drive.label(), "U": voltage(amp),
                _POPULATION: _f_el_cell(by_key.get((drive, amp, FORCE))),
                "F_el (mN), subjects' range":
                    f"{significant(np.nanmin(force))} to {significant(np.nanmax(force))}"
                    if len(force) > 1 else significant(force[0]) if len(force) else "—",
                FRICTION_INCREASE_HEADING: _increase_cell(by_key.get((drive, amp, INCREASE))),
                "subjects": str(len(sel)),
                "flagged cells": f"{n_flagged} of {len(sel)}" if flagged else "—"})
            links[(len(rows) - 1, "flagged cells")] = _links(flagged)
    table = pd.DataFrame(rows, columns=["drive", "U", _POPULATION, "F_el (mN), subjects' range",
                                        FRICTION_INCREASE_HEADING, "subjects", "flagged cells"])
    if len(drives) == 1:
        table = table.drop(columns="drive")
    if not any(c.quantity == FORCE and c.row is not None for c in claims):
        table = table.drop(columns=_POPULATION)
    every = ", ".join(f"W{k}" for k in marks.everywhere)
    return Headline(
        "key_results", "Key results by voltage",
        "F_el: the population's geometric mean [95 % interval] (population.csv's primary "
        "row: every subject in; three subjects or more; undetermined where the mixed model's "
        "checks failed) and the subjects' lowest and highest; the "
        f"{FRICTION_INCREASE_DEFINITION}: the population's mean [95 % interval] "
        "(population.csv), or with fewer than three subjects their lowest to highest; flagged "
        "cells: the subjects' cells a warning that may change a number or widen an interval "
        "touches (links to the warnings)" + (f"; every cell: {every}" if every else "") + ".",
        table), links


def _fit_value(fit: pd.DataFrame, subject: str, name: str, factor: float) -> str:
    hit = fit[(fit["subject"].astype(str) == subject) & (fit["parameter"].astype(str) == name)]
    if hit.empty:
        return "—"
    r = hit.iloc[0]
    return nb(with_interval(factor * to_float(r["value"]), factor * to_float(r["ci_low"]),
                             factor * to_float(r["ci_high"])))


def _subject_models(models: pd.DataFrame | None, subject: str, fit: pd.DataFrame) -> str:
    if models is not None and not models.empty:
        mine = models[models["subject"].astype(str) == subject]
        delta = pd.to_numeric(mine["delta_aic"], errors="coerce")
        best = mine.loc[delta == 0, "model"].astype(str).tolist()
        near = mine.loc[(delta > 0) & (delta < INDISTINGUISHABLE), "model"].astype(str).tolist()
        if best:
            return best[0] + (f" (≈ {', '.join(near)})" if near else "")
        return "—"
    hit = fit[fit["subject"].astype(str) == subject]
    return f"paper's, R² {r_squared(hit.iloc[0].get('r2'))}" if len(hit) else "—"


def _m_of(tables: ResultTables, fit: pd.DataFrame, subject: str) -> str | None:
    """The friction law's exponent m of a subject, when a table holds it (None otherwise)."""
    for table in (tables.electrostatic, fit):
        if FRICTION_EXPONENT in table.columns:
            rows = table[table["subject"].astype(str) == subject]
            if rows.empty:
                return "—"
            r = rows.iloc[0]
            return nb(with_interval(r.get(FRICTION_EXPONENT),
                                     r.get(f"{FRICTION_EXPONENT}_ci_low"),
                                     r.get(f"{FRICTION_EXPONENT}_ci_high")))
    return None


def _exponents(tables: ResultTables, drive: Drive | None) -> pd.DataFrame:
    """exponents.csv's rows of a drive (every row when the claims name none)."""
    ex = tables.exponents
    if ex.empty or drive is None:
        return ex
    freq = ex["frequency_Hz"] if "frequency_Hz" in ex.columns else [None] * len(ex)
    return ex[[Drive.of(w, f) == drive for w, f in zip(ex["waveform"], freq, strict=True)]]


def _population_line(population: PopulationTable | None, claims: Sequence[Quoted],
                     exponent: Quoted | None) -> dict[str, str] | None:
    """Table 2's population line: the claims' h_L and n, population.csv's μ."""
    if population is None or not len(population):
        return None
    gap = next((c for c in claims if c.quantity == AIR_GAP), None)
    mu = population.row("mu")
    return {"subject": "population",
            "h_L (µm) [95 %]": gap.text if gap is not None and gap.state == "quoted" else "—",
            _N: "—" if exponent is None else {"quoted": exponent.text, "undetermined":
                                              "undetermined"}.get(exponent.state, "—"),
            "μ": "—" if mu is None else nb(with_interval(mu.estimate, mu.ci_low, mu.ci_high))}


def _by_subject(tables: ResultTables, fit: pd.DataFrame, claims: Sequence[Quoted],
                models: pd.DataFrame | None, marks: Marks
                ) -> tuple[Headline, dict[tuple[int, str], list[tuple[str, str]]]]:
    elec = tables.electrostatic.reset_index(drop=True)
    subjects = list(dict.fromkeys(elec["subject"].astype(str)))
    exponent = next((c for c in claims if c.quantity == EXPONENT and c.state != "absent"),
                    None)
    ex = _exponents(tables, None if exponent is None else exponent.drive)
    rows: list[dict[str, str]] = []
    links: dict[tuple[int, str], list[tuple[str, str]]] = {}
    for s in subjects:
        mine = elec.index[elec["subject"].astype(str) == s]
        e = ex[ex["subject"].astype(str) == s] if not ex.empty else ex
        row: dict[str, str] = {
            "subject": s, "h_L (µm) [95 %]": _fit_value(fit, s, "h_L", 1e6),
            _N: nb(with_interval(*e.iloc[0][[
                "exponent", "exponent_ci_low", "exponent_ci_high"]].to_numpy(float)))
            if len(e) else "—"}
        m = _m_of(tables, fit, s)
        if m is not None:
            row["m of F_t ∝ W^m [95 %]"] = m
        row["μ"] = significant(np.nanmean(elec.loc[mine, "mu"].to_numpy(float)))
        row["lowest criterion" if models is not None else "model"] = _subject_models(
            models, s, fit)
        flagged = sorted({k for i in mine for k in marks.by_row[i]})
        row["flagged cells"] = (f"{sum(bool(marks.by_row[i]) for i in mine)} of {len(mine)}"
                                if flagged else "—")
        links[(len(rows), "flagged cells")] = _links(flagged)
        rows.append(row)
    line = _population_line(tables.population, claims, exponent)
    if line is not None:
        rows.append(line)
    table = pd.DataFrame(rows).astype(object).fillna("—")
    of_drive = "" if exponent is None or exponent.drive is None or len(
        {c.drive for c in claims if c.drive is not None}) < 2 else \
        f" (the {exponent.drive.label()} drive's)"
    return Headline(
        "key_subjects", "Key results by subject",
        "h_L: the equivalent air gap of the seed paper's model fitted per subject [95 % "
        f"interval]; n: the exponent of the power law F_el = k·U^n over the amplitudes{of_drive}; "
        + ("m: the exponent of the friction law F_t = c·W^m from the OFF windows; "
           if FRICTION_EXPONENT in table.columns or any("m of" in c for c in table.columns)
           else "")
        + "μ: the mean friction coefficient of the OFF references; "
        + ("lowest criterion: the model of lowest AICc (≈ those within ΔAICc "
           f"{INDISTINGUISHABLE:g}, indistinguishable from it); " if models is not None
           else "model: the paper's, with its R²; ")
        + "population: the estimates of population.csv's primary rows (undetermined where "
          "the mixed model's checks failed).", table), links


@dataclass
class KeyResults:
    """The report's first section: a sentence and two tables, with their warnings' links."""

    sentence: str
    by_voltage: Headline
    voltage_links: dict[tuple[int, str], list[tuple[str, str]]]
    by_subject: Headline
    subject_links: dict[tuple[int, str], list[tuple[str, str]]]
    marks: Marks
    claims: list[Quoted]


def key_results(tables: ResultTables, fit: pd.DataFrame, models: pd.DataFrame | None,
                groups: Sequence[WarningGroup]) -> KeyResults:
    """The study's answer: a sentence, a table per voltage and one per subject.

    Parameters
    ----------
    tables : ResultTables
        The result folder (its tables, population.csv with fit.json's checks, fit.json's
        subjects excluded beforehand).
    fit : DataFrame
        fit.csv.
    models : DataFrame or None
        models.csv.
    groups : sequence of WarningGroup
        The warnings grouped by kind, in the page's order.

    Returns
    -------
    KeyResults
    """
    marks = cell_marks(tables.electrostatic.reset_index(drop=True), tables.trials, groups)
    claims = key_claims(tables.population, tables.electrostatic, fit)
    by_v, v_links = _by_voltage(tables, claims, marks)
    by_s, s_links = _by_subject(tables, fit, claims, models, marks)
    excluded = [str(e.get("subject")) for e in tables.fit_doc.population.get("excluded") or []
                if isinstance(e, dict)]
    sentence = key_sentence(
        claims, n_subjects=tables.electrostatic["subject"].astype(str).nunique(),
        excluded=excluded,
        models_verdict=verdict(study_ranking(models)) if models is not None else "",
        flagged=[f"W{k}" for k, g in enumerate(groups, start=1) if g.effect == "number"])
    return KeyResults(sentence, by_v, v_links, by_s, s_links, marks, claims)
