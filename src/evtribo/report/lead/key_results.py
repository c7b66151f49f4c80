"""What the report leads with: the study's answer in a sentence and two small tables.

- :func:`key_results`: one sentence; a table per voltage (the population's F_el, the relative
  friction increase ΔF_t/F_t,OFF over the subjects, how many subjects, the cells flagged by a
  warning) and one per subject (the air gap h_L, the exponent n of F_el ∝ U^n, the friction
  law's exponent m when the analysis gives it, the model verdict, the flagged cells),
  with the warnings (``W1``...) that touch each cell (:mod:`evtribo.report.lead.marks`).

The relative friction increase of a cell is ``100 (friction_on_N / friction_off_N - 1)`` of
electrostatic.csv: the mean friction of its ON windows over that of the OFF windows they
were compared with.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import special

from evtribo.fit.models import INDISTINGUISHABLE, study_ranking, verdict
from evtribo.fit.tables import ResultTables
from evtribo.report.headline import Headline
from evtribo.report.lead.marks import Marks, cell_marks, warning_anchor
from evtribo.util.numbers import (
    frequency,
    quantity,
    r_squared,
    significant,
    to_float,
    voltage,
    with_interval,
)
from evtribo.warning.render import WarningGroup

__all__ = ["FRICTION_EXPONENT", "KeyResults", "key_results", "relative_increase"]

#: Column of a per-subject table (electrostatic.csv or fit.csv) holding the exponent m of the
#: friction law F_t = c·W^m, with ``_ci_low`` and ``_ci_high``: a column of the per-subject
#: key table when present.
FRICTION_EXPONENT = "friction_exponent"
_NBSP = "\u00a0"


def relative_increase(electrostatic: pd.DataFrame) -> pd.Series:
    """Each cell's relative friction increase ΔF_t/F_t,OFF, %.

    Parameters
    ----------
    electrostatic : DataFrame
        electrostatic.csv (``friction_on_N``, ``friction_off_N``).

    Returns
    -------
    Series
        ``100 (friction_on_N / friction_off_N - 1)``, NaN where either is missing.
    """
    if not {"friction_on_N", "friction_off_N"} <= set(electrostatic.columns):
        return pd.Series(np.nan, index=electrostatic.index)
    on = pd.to_numeric(electrostatic["friction_on_N"], errors="coerce")
    off = pd.to_numeric(electrostatic["friction_off_N"], errors="coerce")
    return 100.0 * (on / off.where(off > 0) - 1.0)


def _links(ks: Sequence[int]) -> list[tuple[str, str]]:
    return [(f"W{k}", f"#{warning_anchor(k)}") for k in ks]


def _mean_ci(values: np.ndarray, confidence: float = 0.95) -> str:
    """Mean [Student-t interval] of the subjects' values; the value alone for one."""
    v = values[np.isfinite(values)]
    if v.size == 0:
        return "—"
    if v.size == 1:
        return significant(v[0])
    mean, se = float(np.mean(v)), float(np.std(v, ddof=1) / math.sqrt(v.size))
    half = float(special.stdtrit(v.size - 1, 0.5 + confidence / 2)) * se
    return _nb(with_interval(mean, mean - half, mean + half))


def _nb(text: str) -> str:
    """An interval whose brackets never break across lines."""
    return text.replace(" [", f"{_NBSP}[").replace(", ", f",{_NBSP}") if "[" in text else text


def _population_rows(population: pd.DataFrame | None, name: str) -> pd.DataFrame:
    if population is None or population.empty:
        return pd.DataFrame()
    return population[population["quantity"].astype(str) == name]


def _same(a: Any, b: Any) -> bool:
    x, y = to_float(a), to_float(b)
    return (math.isnan(x) and math.isnan(y)) or math.isclose(x, y, rel_tol=1e-9)


def _freqs(table: pd.DataFrame) -> np.ndarray:
    """A table's drive frequencies, Hz (NaN where unknown)."""
    if "frequency_Hz" not in table.columns:
        return np.full(len(table), np.nan)
    return pd.to_numeric(table["frequency_Hz"], errors="coerce").to_numpy(float)


def _at(table: pd.DataFrame, wave: str, freq: float) -> np.ndarray:
    """Which rows of *table* are of this waveform and frequency."""
    waves = table["waveform"].fillna("").astype(str).to_numpy()
    same = np.array([_same(f, freq) for f in _freqs(table)], dtype=bool)
    return (waves == wave) & same


def _interval(row: Any, factor: float = 1.0) -> str:
    """A population row's ``estimate [ci_low, ci_high]`` times *factor*."""
    return _nb(with_interval(*(factor * np.asarray(
        [to_float(row["estimate"]), to_float(row["ci_low"]), to_float(row["ci_high"])]))))


def _drives(elec: pd.DataFrame) -> list[tuple[str, float]]:
    pairs = dict.fromkeys(zip(elec["waveform"].fillna("").astype(str), _freqs(elec),
                              strict=True))
    return sorted(pairs, key=lambda d: (d[0] != "square", d[0], d[1]))


def _by_voltage(tables: ResultTables, population: pd.DataFrame | None, marks: Marks
                ) -> tuple[Headline, dict[tuple[int, str], list[tuple[str, str]]]]:
    elec = tables.electrostatic.reset_index(drop=True)
    rel = relative_increase(elec)
    pop = _population_rows(population, "electrostatic_force_N")
    confidence = to_float(tables.summary.settings.get("confidence", 0.95))
    confidence = confidence if 0 < confidence < 1 else 0.95
    drives = _drives(elec)
    rows: list[dict[str, str]] = []
    links: dict[tuple[int, str], list[tuple[str, str]]] = {}
    for wave, freq in drives:
        in_drive = _at(elec, wave, freq)
        amps = elec["amplitude_V"].to_numpy(float)
        for amp in sorted(set(amps[in_drive].tolist())):
            sel = elec.index[in_drive & (amps == amp)]
            force = 1e3 * elec.loc[sel, "electrostatic_force_N"].to_numpy(float)
            hit = pop[_at(pop, wave, freq) & (pop["amplitude_V"].to_numpy(float) == amp)] \
                if not pop.empty else pop
            est = _interval(hit.iloc[0], 1e3) if len(hit) else "—"
            flagged = sorted({k for i in sel for k in marks.by_row[i]})
            n_flagged = sum(bool(marks.by_row[i]) for i in sel)
            row = {"drive": f"{wave} {frequency(freq)}".strip(), "U": voltage(amp),
                   "F_el (mN), population [95 %]": est,
                   "F_el (mN), subjects' range":
                       f"{significant(np.nanmin(force))} to {significant(np.nanmax(force))}"
                       if len(force) > 1 else significant(force[0]),
                   "ΔF_t/F_t,OFF (%), mean [95 %]": _mean_ci(rel.loc[sel].to_numpy(float),
                                                             confidence),
                   "subjects": str(len(sel)),
                   "flagged cells": f"{n_flagged} of {len(sel)}" if flagged else "—"}
            links[(len(rows), "flagged cells")] = _links(flagged)
            rows.append(row)
    columns = ["drive", "U", "F_el (mN), population [95 %]", "F_el (mN), subjects' range",
               "ΔF_t/F_t,OFF (%), mean [95 %]", "subjects", "flagged cells"]
    table = pd.DataFrame(rows, columns=columns)
    if len(drives) == 1:
        table = table.drop(columns="drive")
    if pop.empty:
        table = table.drop(columns="F_el (mN), population [95 %]")
    every = ", ".join(f"W{k}" for k in marks.everywhere)
    return Headline(
        "key_results", "Key results by voltage",
        "F_el: the population's geometric mean [95 % interval] (population.csv; three "
        "subjects or more) and the subjects' lowest and highest; ΔF_t/F_t,OFF: the friction "
        "of the ON windows over that of the OFF windows they were compared with, less 1, "
        "the mean over the subjects [95 % Student-t interval]; flagged cells: the subjects' "
        "cells a warning that may change a number or widen an interval touches (links to "
        "the warnings)" + (f"; every cell: {every}" if every else "") + ".", table), links


def _fit_value(fit: pd.DataFrame, subject: str, name: str, factor: float) -> str:
    hit = fit[(fit["subject"].astype(str) == subject) & (fit["parameter"].astype(str) == name)]
    if hit.empty:
        return "—"
    r = hit.iloc[0]
    return _nb(with_interval(factor * to_float(r["value"]), factor * to_float(r["ci_low"]),
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
            return _nb(with_interval(r.get(FRICTION_EXPONENT),
                                     r.get(f"{FRICTION_EXPONENT}_ci_low"),
                                     r.get(f"{FRICTION_EXPONENT}_ci_high")))
    return None


def _by_subject(tables: ResultTables, fit: pd.DataFrame, population: pd.DataFrame | None,
                models: pd.DataFrame | None, marks: Marks
                ) -> tuple[Headline, dict[tuple[int, str], list[tuple[str, str]]]]:
    elec = tables.electrostatic.reset_index(drop=True)
    subjects = list(dict.fromkeys(elec["subject"].astype(str)))
    ex = tables.exponents
    rows: list[dict[str, str]] = []
    links: dict[tuple[int, str], list[tuple[str, str]]] = {}
    for s in subjects:
        mine = elec.index[elec["subject"].astype(str) == s]
        e = ex[ex["subject"].astype(str) == s] if not ex.empty else ex
        row: dict[str, str] = {
            "subject": s, "h_L (µm) [95 %]": _fit_value(fit, s, "h_L", 1e6),
            "n of F_el ∝ U^n [95 %]": _nb(with_interval(*e.iloc[0][[
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
    pop = {q: _population_rows(population, q) for q in ("h_L_m", "exponent", "mu")}
    if any(not v.empty for v in pop.values()):
        def shown(q: str, factor: float = 1.0) -> str:
            return "—" if pop[q].empty else _interval(pop[q].iloc[0], factor)
        rows.append({"subject": "population", "h_L (µm) [95 %]": shown("h_L_m", 1e6),
                     "n of F_el ∝ U^n [95 %]": shown("exponent"), "μ": shown("mu")})
    table = pd.DataFrame(rows).astype(object).fillna("—")
    return Headline(
        "key_subjects", "Key results by subject",
        "h_L: the equivalent air gap of the seed paper's model fitted per subject [95 % "
        "interval]; n: the exponent of the power law F_el = k·U^n over the amplitudes; "
        + ("m: the exponent of the friction law F_t = c·W^m from the OFF windows; "
           if FRICTION_EXPONENT in table.columns or any("m of" in c for c in table.columns)
           else "")
        + "μ: the mean friction coefficient of the OFF references; "
        + ("lowest criterion: the model of lowest AICc (≈ those within ΔAICc "
           f"{INDISTINGUISHABLE:g}, indistinguishable from it); " if models is not None
           else "model: the paper's, with its R²; ")
        + "population: the random-effects estimates (population.csv).", table), links


def _sentence(tables: ResultTables, population: pd.DataFrame | None,
              models: pd.DataFrame | None, fit: pd.DataFrame,
              groups: Sequence[WarningGroup]) -> str:
    elec = tables.electrostatic
    subjects = elec["subject"].astype(str).nunique()
    wave, freq = _drives(elec)[0]
    drive = elec[(elec["waveform"].fillna("").astype(str) == wave)]
    rel = relative_increase(drive)
    by_amp = rel.groupby(drive["amplitude_V"].astype(float)).mean()
    parts = [f"{subjects} subject{'s' if subjects != 1 else ''}, {wave} drive at "
             f"{frequency(freq)}".replace(" at —", "")]
    if len(by_amp) and by_amp.notna().any():
        lo, hi = by_amp.index.min(), by_amp.index.max()
        parts.append(f"the voltage raised the friction by {significant(by_amp[lo], 2)} % at "
                     f"{voltage(lo)} to {significant(by_amp[hi], 2)} % at {voltage(hi)} "
                     "(mean over the subjects)")
    pop_f = _population_rows(population, "electrostatic_force_N")
    if not pop_f.empty:
        top = pop_f.sort_values("amplitude_V").iloc[-1]
        parts.append(f"the population's electrostatic force was {_interval(top, 1e3)} mN at "
                     f"{voltage(top['amplitude_V'])}")
    expo = _population_rows(population, "exponent")
    if not expo.empty:
        r = expo.iloc[0]
        parts.append(f"F_el grew as U^n with n = {_interval(r)}")
    h = _population_rows(population, "h_L_m")
    if not h.empty:
        r = h.iloc[0]
        parts.append(f"the model's air gap h_L = {_interval(r, 1e6)} µm")
    elif not fit.empty and (fit["parameter"] == "h_L").any():
        v = 1e6 * fit.loc[fit["parameter"] == "h_L", "value"].to_numpy(float)
        parts.append(f"the model's air gap h_L from {quantity(v.min() * 1e-6, 'm', prefix='µ')}"
                     f" to {quantity(v.max() * 1e-6, 'm', prefix='µ')}")
    said = verdict(study_ranking(models)) if models is not None else ""
    if said:
        parts.append(f"models: {said}")
    text = parts[0] + ": " + "; ".join(parts[1:]) + "."
    flagged = [f"W{k}" for k, g in enumerate(groups, start=1) if g.effect == "number"]
    if flagged:
        text += (f" {len(flagged)} kind(s) of warning may change these numbers "
                 f"({', '.join(flagged)}).")
    return text


@dataclass
class KeyResults:
    """The report's first section: a sentence and two tables, with their warnings' links."""

    sentence: str
    by_voltage: Headline
    voltage_links: dict[tuple[int, str], list[tuple[str, str]]]
    by_subject: Headline
    subject_links: dict[tuple[int, str], list[tuple[str, str]]]
    marks: Marks


def key_results(tables: ResultTables, fit: pd.DataFrame, population: pd.DataFrame | None,
                models: pd.DataFrame | None, groups: Sequence[WarningGroup]) -> KeyResults:
    """The study's answer: a sentence, a table per voltage and one per subject.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables.
    fit : DataFrame
        fit.csv.
    population : DataFrame or None
        population.csv.
    models : DataFrame or None
        models.csv.
    groups : sequence of WarningGroup
        The warnings grouped by kind, in the page's order.

    Returns
    -------
    KeyResults
    """
    marks = cell_marks(tables.electrostatic.reset_index(drop=True), tables.trials, groups)
    by_v, v_links = _by_voltage(tables, population, marks)
    by_s, s_links = _by_subject(tables, fit, population, models, marks)
    return KeyResults(_sentence(tables, population, models, fit, groups), by_v, v_links,
                      by_s, s_links, marks)


