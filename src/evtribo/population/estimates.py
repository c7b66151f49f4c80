"""From subjects to the population: ``population.csv`` and ``population_contrasts.csv``.

What a paper reports of a study (study format §10), from the result folder's tables and the
subjects' fits, with the statistics of :mod:`evtribo.population.stats`:

- per condition (waveform x drive frequency) the population's electrostatic force at each
  measured amplitude (the geometric mean: the random-effects mean of log F_el over the
  subjects measured there, each cell weighted by its own interval), and the power law
  ``F_el = k U^n`` fitted across subjects (a mixed model, subjects as random effects):
  its exponent n and prefactor k (in N at 1 V, the geometric mean);
- the friction coefficient mu (each subject's from its OFF windows, with the standard
  error of that ratio of means) and the fitted air gap h_L (geometric mean; each subject's
  interval from its fit);
- for two conditions the subjects were measured in both: the ratio of their forces (each
  subject's geometric mean ratio over the amplitudes it has in both) and the difference of
  their exponents (each subject's own power laws), paired within subjects.

Each subject's log forces are correlated between amplitudes and conditions (a shared OFF
reference moves them together): their covariance is taken from the subject's bootstrap
replicates (``electrostatic_bootstrap.csv``) when the folder has them, each cell's variance
from its interval. A cell whose force is not positive has no logarithm and is left out
(named in the notes). A subject with one amplitude in a condition contributes to that
amplitude's estimate only. Every estimate needs at least three subjects; with fewer, there
is no row and the notes say why.

Outliers (:func:`~evtribo.population.stats.find_outliers`): in each condition, a
subject whose own power law (its force at the centre of the log amplitudes, or its
exponent; subjects with two amplitudes or more, five subjects or more) lies outside the
prediction interval of the other subjects' is named and left out of that condition's
estimates and of the contrasts with it; mu and h_L are checked each on its own. The
study's 5 % is shared (Bonferroni) among the quantities checked, so that a study of a
population without outliers names one about once in twenty.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from evtribo.fit.fit import SubjectFit
from evtribo.fit.tables import ResultTables
from evtribo.population.contrasts import contrast
from evtribo.population.data import (
    CONTRAST_COLUMNS,
    POPULATION_COLUMNS,
    Collector,
    Condition,
    PopulationOutlier,
    SubjectData,
    condition_label,
    conditions_of,
    subject_data,
)
from evtribo.population.model import PowerLawFit, SubjectCells, fit_power_law
from evtribo.population.stats import MIN_SUBJECTS, OUTLIER_ALPHA, POOL_METHOD, find_outliers
from evtribo.results.outputs import POPULATION_CONTRASTS_CSV, POPULATION_CSV

log = logging.getLogger(__name__)

__all__ = ["CONTRAST_COLUMNS", "POPULATION_COLUMNS", "Condition", "Population",
           "PopulationOutlier", "condition_label", "population"]

_Z95 = float(stats.norm.ppf(0.975))


@dataclass
class Population:
    """The population's estimates of a study.

    Attributes
    ----------
    table : DataFrame
        population.csv (:data:`POPULATION_COLUMNS`); with fewer than three subjects with
        electrostatic forces, only the friction coefficient mu's row (when three subjects
        or more have OFF windows), else empty.
    contrasts : DataFrame
        population_contrasts.csv (:data:`CONTRAST_COLUMNS`).
    n_subjects : int
        Subjects with electrostatic forces.
    notes : list of str
        What could not be estimated and why; cells left out.
    outliers : list of PopulationOutlier
        The subjects left out of an estimate as outliers.
    lines : dict
        The power law fitted per condition (``(waveform, frequency_Hz)``), for the figure.
    subject_lines : dict
        Per condition with a power law: each subject's own ``(log F at the fit's centre,
        exponent)`` (weighted by its cells' covariance), outliers included.
    left_out : dict
        Per condition, the subjects left out of its estimates as outliers.
    """

    table: pd.DataFrame
    contrasts: pd.DataFrame
    n_subjects: int
    notes: list[str] = field(default_factory=list)
    outliers: list[PopulationOutlier] = field(default_factory=list)
    lines: dict[Condition, PowerLawFit] = field(default_factory=dict)
    subject_lines: dict[Condition, dict[str, tuple[float, float]]] = field(
        default_factory=dict)
    left_out: dict[Condition, set[str]] = field(default_factory=dict)

    def files(self) -> dict[str, str]:
        """The text of population.csv and population_contrasts.csv, by name; none when
        nothing was estimated (fewer than three subjects: study format §10).

        Returns
        -------
        dict of str to str
        """
        if self.table.empty:
            return {}
        return {POPULATION_CSV: self.table.to_csv(index=False),
                POPULATION_CONTRASTS_CSV: self.contrasts.to_csv(index=False)}

    def as_json(self) -> dict[str, Any]:
        """What fit.json records of it: subjects, notes and outliers.

        Returns
        -------
        dict
        """
        return {"n_subjects": self.n_subjects, "min_subjects": MIN_SUBJECTS,
                "notes": list(self.notes),
                "outliers": [{"subject": o.subject, "quantity": o.quantity,
                              "value": o.value, "low": o.low, "high": o.high,
                              "unit": o.unit} for o in self.outliers]}


def _forces(rows: Collector, subjects: Sequence[SubjectData], condition: Condition,
            outliers: set[str]) -> None:
    """The geometric-mean force at each amplitude of *condition*, without *outliers*."""
    label = condition_label(*condition)
    picked = [(s, s.select(condition)) for s in subjects]
    amps = sorted({float(a) for s, idx in picked for a in s.amplitudes[idx]})
    for amp in amps:
        names, y, v = [], [], []
        for s, idx in picked:
            hit = idx[np.isclose(s.amplitudes[idx], amp)]
            if hit.size:
                names.append(s.name)
                y.append(float(s.log_f[hit[0]]))
                v.append(float(s.cov[hit[0], hit[0]]))
        got = rows.pooled(f"F_el at {amp:g} V, {label}", names, np.array(y), np.array(v),
                          "N", exclude=outliers)
        if got is not None:
            p, gone = got
            rows.add("electrostatic_force_N", condition, amp,
                     (math.exp(p.estimate), math.exp(p.ci_low), math.exp(p.ci_high)),
                     between_sd=p.between_sd, n=p.n_subjects,
                     method=f"{POOL_METHOD}, of log F_el", left_out=gone)


def _cells(subjects: Sequence[SubjectData], condition: Condition) -> list[SubjectCells]:
    """The subjects' cells of *condition*, of those with two amplitudes or more."""
    return [c for c in (s.condition(condition) for s in subjects)
            if np.unique(c.log_u).size >= 2]


def _centre(cells: Sequence[SubjectCells]) -> float:
    return float(np.mean(np.concatenate([c.log_u for c in cells])))


def _outliers(rows: Collector, subjects: Sequence[SubjectData], condition: Condition
              ) -> set[str]:
    """Subjects whose own power law in *condition* (its force at the centre of the log
    amplitudes, or its exponent) lies outside the others' prediction interval: left out of
    the condition's estimates."""
    cells = _cells(subjects, condition)
    if not cells:
        return set()
    log_u0, label = _centre(cells), condition_label(*condition)
    fits = [c.own_fit(log_u0) for c in cells]
    names = [c.subject for c in cells]
    gone: set[str] = set()
    for j, what, unit in ((0, f"F_el of its power law at {math.exp(log_u0):.3g} V, {label}",
                           "N"), (1, f"exponent, {label}", None)):
        found = find_outliers(np.array([b[j] for b, _ in fits]),
                              np.array([cov[j, j] for _, cov in fits]), names,
                              alpha=rows.alpha)
        rows.flag(what, found, unit)
        gone |= {o.subject for o in found}
    return gone


def _power_law(rows: Collector, subjects: Sequence[SubjectData], condition: Condition,
               gone: set[str]) -> None:
    """The exponent and prefactor of *condition* from the mixed model, without *gone*."""
    label = condition_label(*condition)
    cells = _cells(subjects, condition)
    if len(cells) < MIN_SUBJECTS:
        amps = {float(u) for s in subjects for u in s.condition(condition).log_u}
        rows.notes.append(f"{label}: one amplitude only, no power law" if len(amps) < 2 else
                          f"{label}: {len(cells)} subject(s) with two amplitudes or more; "
                          f"a population power law needs at least {MIN_SUBJECTS}")
        return
    kept = [c for c in cells if c.subject not in gone]
    if len(kept) < MIN_SUBJECTS:
        rows.notes.append(f"{label}: {len(kept)} subject(s) left after the outliers; a "
                          f"population power law needs at least {MIN_SUBJECTS}")
        return
    try:
        fit = fit_power_law(kept)
    except np.linalg.LinAlgError as err:
        rows.notes.append(f"{label}: the power law across subjects could not be fitted "
                          f"({err})")
        return
    rows.lines[condition] = fit
    rows.subject_lines[condition] = {c.subject: (float(b[0]), float(b[1])) for c in cells
                                     for b in (c.own_fit(fit.log_u0)[0],)}
    left = sorted(gone & {c.subject for c in cells})
    n_hat = fit.estimate([0.0, 1.0])
    rows.add("exponent", condition, math.nan, (n_hat.value, *n_hat.interval()),
             between_sd=float(fit.between_sd[1]), n=len(kept), method=fit.method,
             left_out=left)
    c_k = np.array([1.0, -fit.log_u0])
    k_hat = fit.estimate(c_k)
    lo, hi = k_hat.interval()
    rows.add("prefactor_N", condition, math.nan,
             (math.exp(k_hat.value), math.exp(lo), math.exp(hi)),
             between_sd=fit.between_sd_of(c_k), n=len(kept),
             method=fit.method + ", at 1 V, of log k", left_out=left)


def _mu(rows: Collector, tables: ResultTables, subjects: Sequence[str]) -> None:
    """The friction coefficient: each subject's from its OFF windows (ratio of the mean
    friction to the mean normal force, the delta method's standard error)."""
    win = tables.windows
    off = win[win["condition"].astype(str).str.lower() == "off"]
    names, y, v = [], [], []
    for s in subjects:
        w = off[off["subject"].astype(str) == s]
        ft, fn = w["friction_force_N"].to_numpy(float), w["normal_force_N"].to_numpy(float)
        ok = np.isfinite(ft) & np.isfinite(fn)
        ft, fn = ft[ok], fn[ok]
        if ft.size < 2 or fn.sum() <= 0:
            continue
        mu = ft.sum() / fn.sum()
        var = float(np.sum((ft - mu * fn) ** 2) / (ft.size - 1) / ft.size / fn.mean() ** 2)
        if var > 0:
            names.append(s)
            y.append(mu)
            v.append(var)
    got = rows.pooled("friction coefficient mu", names, np.array(y), np.array(v))
    if got is not None:
        p, gone = got
        rows.add("mu", None, math.nan, (p.estimate, p.ci_low, p.ci_high),
                 between_sd=p.between_sd, n=p.n_subjects,
                 method=f"{POOL_METHOD}, of each subject's mu from its OFF windows",
                 left_out=gone)


def _air_gap(rows: Collector, fits: Sequence[SubjectFit]) -> None:
    """The fitted air gap's geometric mean (each subject's interval from its fit)."""
    names, y, v = [], [], []
    if not fits:
        return
    for f in fits:
        try:
            e = f["h_L"]
        except KeyError:
            return
        if 0 < e.ci_low < e.value < e.ci_high < math.inf:
            names.append(f.subject)
            y.append(math.log(e.value))
            v.append(((math.log(e.ci_high) - math.log(e.ci_low)) / (2 * _Z95)) ** 2)
        else:
            rows.notes.append(f"{f.subject}: its fitted air gap has no finite interval: "
                              "left out of the population's")
    got = rows.pooled("air gap h_L", names, np.array(y), np.array(v), "m")
    if got is not None:
        p, gone = got
        rows.add("h_L_m", None, math.nan,
                 (math.exp(p.estimate), math.exp(p.ci_low), math.exp(p.ci_high)),
                 between_sd=p.between_sd, n=p.n_subjects,
                 method=f"{POOL_METHOD}, of log h_L", left_out=gone)


def population(tables: ResultTables, fits: Sequence[SubjectFit] = ()) -> Population:
    """The population's estimates of a study (study format §10).

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables.
    fits : sequence of SubjectFit
        The subjects' model fits (for the air gap h_L; none: no h_L row).

    Returns
    -------
    Population
        With fewer than three subjects with electrostatic forces: only mu's row (from
        the OFF windows of every subject, a study of OFF trials too), and a note saying
        why there is no other.
    """
    rows = Collector()
    boot = tables.bootstrap
    by_subject = {} if boot is None else {
        str(k): g for k, g in boot.groupby(boot["subject"].astype(str))}
    subjects = [s for s in (subject_data(
        tables, name, rows.notes,
        bootstrap=None if boot is None else by_subject.get(str(name), boot.iloc[:0]))
        for name in tables.subjects) if s is not None]
    if len(subjects) < MIN_SUBJECTS:
        rows.notes.insert(0, f"{len(subjects)} subject(s) with electrostatic forces: a "
                             f"population estimate needs at least {MIN_SUBJECTS}, so none "
                             "was made of F_el, its power law or h_L")
        _mu(rows, tables, tables.all_subjects)  # mu needs OFF windows only
        return Population(_frame(rows.rows, POPULATION_COLUMNS),
                          _frame([], CONTRAST_COLUMNS), len(subjects),
                          list(dict.fromkeys(rows.notes)), rows.outliers)
    conditions = conditions_of(subjects)
    # the study's 5 %, shared by the quantities checked: each condition's level and
    # exponent, mu, and h_L when it was fitted
    checked = 2 * len(conditions) + 1 + any("h_L" in (e.name for e in f.estimates)
                                            for f in fits)
    rows.alpha = OUTLIER_ALPHA / checked
    for condition in conditions:
        outliers = rows.left_out[condition] = _outliers(rows, subjects, condition)
        _forces(rows, subjects, condition, outliers)
        _power_law(rows, subjects, condition, outliers)
    _mu(rows, tables, tables.all_subjects)
    _air_gap(rows, fits)
    for a, b in combinations(conditions, 2):
        contrast(rows, subjects, a, b)
    return Population(_frame(rows.rows, POPULATION_COLUMNS),
                      _frame(rows.contrasts, CONTRAST_COLUMNS), len(subjects),
                      list(dict.fromkeys(rows.notes)), rows.outliers, rows.lines,
                      rows.subject_lines, {c: s for c, s in rows.left_out.items() if s})


def _frame(rows: list[dict[str, Any]], columns: Sequence[str]) -> pd.DataFrame:
    return pd.DataFrame(rows, columns=list(columns))
