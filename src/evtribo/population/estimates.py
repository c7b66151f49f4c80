"""From subjects to the population: ``population.csv``, ``population_contrasts.csv`` and
``population_subjects.csv``.

What a paper reports of a study (study format §10), from the result folder's tables and the
subjects' fits. Every subject is in the primary rows (``analysis`` ``primary``), but those the
study excluded beforehand by a rule written in study.toml (``[population] exclude``,
:mod:`evtribo.population.exclusions`), which are named with their reason:

- per condition (waveform x drive frequency), the model study.toml's ``[population] model``
  chooses (:mod:`evtribo.population.models`; :mod:`evtribo.population.power_law` runs it):
  by default the power law ``F_el = k U^n`` across subjects on the linear scale, a nonlinear
  mixed model in which each cell counts with its own error, negative ones too: the
  population's F_el at each measured amplitude (the geometric mean over subjects), its
  exponent n and prefactor k, with the prediction interval for a new subject, the
  between-subject SD with its interval, I^2 and the convergence checks; a subject far from
  the others is named, with rows of the same estimates without it (``without S03``); where
  valid, the meta-analysis of log F_el at each amplitude (``meta-analysis``);
- the relative friction increase ``100 F_el / F_n,ON`` per amplitude
  (:mod:`evtribo.population.per_subject`), each subject's in population_subjects.csv with its
  Holm-adjusted one-sided test of ``F_el > 0``;
- the friction coefficient mu (each subject's from its OFF windows, with the standard error of
  that ratio of means) and the fitted air gap h_L (geometric mean; each subject's interval from
  its fit), random-effects meta-analyses;
- for two conditions the subjects were measured in both: the ratio of their forces (each
  subject's geometric mean ratio over the amplitudes it has in both, positive cells) and the
  difference of their exponents, paired within subjects.

Every estimate needs at least three subjects; with fewer, there is no row and the notes say
why. The study's 5 % of the test that names a subject far from the others is shared
(Bonferroni) among the quantities checked, so that a study of a population without such a
subject names one about once in twenty.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import special

from evtribo.documents.population_table import Drive, PopulationTable
from evtribo.documents.tables import CONTRASTS, POPULATION, POPULATION_SUBJECTS
from evtribo.fit.fit import SubjectFit
from evtribo.fit.tables import ResultTables
from evtribo.population.contrasts import contrast
from evtribo.population.data import (
    CONTRAST_COLUMNS,
    POPULATION_COLUMNS,
    PRIMARY,
    Collector,
    Condition,
    PopulationOutlier,
    condition_label,
    conditions_of,
    subject_data,
)
from evtribo.population.models import DEFAULT_MODEL, MODELS
from evtribo.population.nonlinear_fit import NonlinearFit
from evtribo.population.per_subject import SUBJECT_COLUMNS, friction_increase, subject_table
from evtribo.population.power_law import condition_estimates
from evtribo.population.stats import MIN_SUBJECTS, OUTLIER_ALPHA, POOL_METHOD, Pooled
from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["CONTRAST_COLUMNS", "POPULATION_COLUMNS", "SUBJECT_COLUMNS", "Condition",
           "Population", "PopulationOutlier", "condition_label", "population"]

_Z95 = float(special.ndtri(0.975))


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
        Subjects with electrostatic forces (those excluded beforehand not counted).
    notes : list of WarningRecord
        What could not be estimated and why; cells left out; failed checks (made, not
        said: compare says them, fit.json keeps them).
    outliers : list of PopulationOutlier
        The subjects named as far from the others (in every primary row all the same).
    lines : dict
        The mixed model fitted per condition (``(waveform, frequency_Hz)``), for the figure.
    subject_lines : dict
        Per condition with a power law: each subject's own ``(log F at the fit's centre,
        exponent)`` (its conditional mode in the mixed model).
    far : dict
        Per condition, the subjects named as far from the others (each with its rows
        ``without <subject>``).
    subjects : DataFrame
        population_subjects.csv (:data:`~evtribo.population.per_subject.SUBJECT_COLUMNS`).
    excluded : dict
        The subjects the study excluded beforehand, with the reason its rule gives.
    rule_notes : list of WarningRecord
        What was said of that rule (its study.toml not read).
    model : str
        The population model of the primary rows (study.toml's ``[population] model``).
    """

    table: pd.DataFrame
    contrasts: pd.DataFrame
    n_subjects: int
    notes: list[WarningRecord] = field(default_factory=list)
    outliers: list[PopulationOutlier] = field(default_factory=list)
    lines: dict[Condition, NonlinearFit] = field(default_factory=dict)
    subject_lines: dict[Condition, dict[str, tuple[float, float]]] = field(
        default_factory=dict)
    far: dict[Condition, set[str]] = field(default_factory=dict)
    subjects: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=list(SUBJECT_COLUMNS)))
    excluded: dict[str, str] = field(default_factory=dict)
    rule_notes: list[WarningRecord] = field(default_factory=list)
    model: str = DEFAULT_MODEL

    @property
    def primary(self) -> pd.DataFrame:
        """The rows every subject is in (``analysis`` ``primary``).

        Returns
        -------
        DataFrame
        """
        return self.table[self.table["analysis"].astype(str) == PRIMARY]

    def files(self) -> dict[str, str]:
        """The text of population.csv, population_contrasts.csv and (with electrostatic
        forces) population_subjects.csv, by name; none when nothing was estimated (fewer
        than three subjects: study format §10).

        Returns
        -------
        dict of str to str
        """
        if self.table.empty:
            return {}
        out = {POPULATION.file: POPULATION.text(self.table),
               CONTRASTS.file: CONTRASTS.text(self.contrasts)}
        if not self.subjects.empty:
            out[POPULATION_SUBJECTS.file] = POPULATION_SUBJECTS.text(self.subjects)
        return out

    def as_json(self) -> dict[str, Any]:
        """What fit.json records of it: subjects, notes (their texts: fit.json's
        ``warnings`` holds them as records), the subjects far from the others, those
        excluded beforehand and the model of the primary rows.

        Returns
        -------
        dict
        """
        return {"n_subjects": self.n_subjects, "min_subjects": MIN_SUBJECTS,
                "notes": [n.text for n in self.notes],
                "outliers": [{"subject": o.subject, "quantity": o.quantity,
                              "value": o.value, "low": o.low, "high": o.high,
                              "unit": o.unit} for o in self.outliers],
                "excluded": [{"subject": k, "reason": v} for k, v in self.excluded.items()],
                "exclusion_rule": [n.text for n in self.rule_notes], "model": self.model,
                "checks": {condition_label(*c): {
                    **f.convergence.as_checks().as_json(), "waveform": c[0],
                    "frequency_Hz": c[1] if math.isfinite(c[1]) else None}
                    for c, f in self.lines.items()}}

    def population_table(self) -> PopulationTable:
        """population.csv's rows by key, with each drive's checks as fields.

        Returns
        -------
        PopulationTable
        """
        return PopulationTable(self.table, checks={
            Drive.of(*c): f.convergence.as_checks() for c, f in self.lines.items()})


def _sensitivity(rows: Collector, what: str, names: Sequence[str], values: np.ndarray,
                 variances: np.ndarray, *, far: Sequence[str], add: Any) -> None:
    """The pooled value without each subject in *far* (``analysis`` ``without S03``)."""
    for name in far:
        keep = np.array([n != name for n in names])
        got = rows.pooled(f"{what} without {name}", [n for n in names if n != name],
                          values[keep], variances[keep], check=False)
        if got is not None:
            add(got[0], f"without {name}")


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
    method = f"{POOL_METHOD}, of each subject's mu from its OFF windows"

    def add(p: Pooled, analysis: str) -> None:
        rows.add_pooled("mu", None, math.nan, p, method=method, analysis=analysis)

    got = rows.pooled("friction coefficient mu", names, np.array(y), np.array(v))
    if got is not None:
        add(got[0], PRIMARY)
        _sensitivity(rows, "friction coefficient mu", names, np.array(y), np.array(v),
                     far=got[1], add=add)


def _air_gap(rows: Collector, fits: Sequence[SubjectFit], excluded: Mapping[str, str]
             ) -> None:
    """The fitted air gap's geometric mean (each subject's interval from its fit)."""
    names, y, v = [], [], []
    if not fits:
        return
    for f in fits:
        if f.subject in excluded:
            continue
        try:
            e = f["h_L"]
        except KeyError:
            return
        if 0 < e.ci_low < e.value < e.ci_high < math.inf:
            names.append(f.subject)
            y.append(math.log(e.value))
            v.append(((math.log(e.ci_high) - math.log(e.ci_low)) / (2 * _Z95)) ** 2)
        else:
            rows.notes.append(emit.record("population-air-gap-undetermined",
                                          Scope(f.subject)))
    method = f"{POOL_METHOD}, of log h_L"

    def add(p: Pooled, analysis: str) -> None:
        rows.add_pooled("h_L_m", None, math.nan, p, method=method, analysis=analysis,
                        log=True)

    got = rows.pooled("air gap h_L", names, np.array(y), np.array(v), "m")
    if got is not None:
        add(got[0], PRIMARY)
        _sensitivity(rows, "air gap h_L", names, np.array(y), np.array(v), far=got[1],
                     add=add)


def population(tables: ResultTables, fits: Sequence[SubjectFit] = (), *,
               exclude: Mapping[str, str] | None = None,
               rule_notes: Sequence[WarningRecord] = (), model: str = DEFAULT_MODEL
               ) -> Population:
    """The population's estimates of a study (study format §10).

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables.
    fits : sequence of SubjectFit
        The subjects' model fits (for the air gap h_L; none: no h_L row).
    exclude : mapping of str to str, optional
        Subjects the study excluded beforehand, with the reason (study.toml's
        ``[population] exclude``): left out of every estimate, and named.
    rule_notes : sequence of WarningRecord
        What was said of that rule (study.toml not read), for fit.json and the methods.
    model : str
        The model of each condition's primary rows (study.toml's ``[population] model``: a
        name of :data:`~evtribo.population.models.MODELS`).

    Returns
    -------
    Population
        With fewer than three subjects with electrostatic forces: only mu's row (from
        the OFF windows of every subject, a study of OFF trials too), and a note saying
        why there is no other.

    Raises
    ------
    ValueError
        A *model* that is no population model's name.
    """
    if model not in MODELS:
        raise ValueError(f"population model must be one of {', '.join(MODELS)}, got "
                         f"{model!r}")
    primary = MODELS[model]
    rows = Collector()
    excluded = dict(exclude or {})
    for name, reason in excluded.items():
        rows.notes.append(emit.record("population-excluded", Scope(name), reason=reason))
    boot = tables.bootstrap
    by_subject = {} if boot is None else {
        str(k): g for k, g in boot.groupby(boot["subject"].astype(str))}
    subjects = [s for s in (subject_data(
        tables, name, rows.notes,
        bootstrap=None if boot is None else by_subject.get(str(name), boot.iloc[:0]))
        for name in tables.subjects if str(name) not in excluded) if s is not None]
    everyone = [s for s in tables.all_subjects if str(s) not in excluded]
    if len(subjects) < MIN_SUBJECTS:
        rows.notes.insert(len(excluded), emit.record(
            "population-too-few", subjects=len(subjects), needed=MIN_SUBJECTS))
        _mu(rows, tables, everyone)  # mu needs OFF windows only
        return Population(_frame(rows.rows, POPULATION_COLUMNS),
                          _frame([], CONTRAST_COLUMNS), len(subjects),
                          list(dict.fromkeys(rows.notes)), rows.outliers, excluded=excluded,
                          rule_notes=list(rule_notes), model=model)
    conditions = conditions_of(subjects)
    # the study's 5 %, shared by the quantities checked: each condition's level and
    # exponent, mu, and h_L when it was fitted
    checked = 2 * len(conditions) + 1 + any("h_L" in (e.name for e in f.estimates)
                                            for f in fits)
    rows.alpha = OUTLIER_ALPHA / checked
    per_subject = subject_table(subjects, conditions)
    for condition in conditions:
        condition_estimates(rows, subjects, condition, primary)
        friction_increase(rows, per_subject, condition)
    _mu(rows, tables, everyone)
    _air_gap(rows, fits, excluded)
    for a, b in combinations(conditions, 2):
        contrast(rows, subjects, a, b)
    return Population(_frame(rows.rows, POPULATION_COLUMNS),
                      _frame(rows.contrasts, CONTRAST_COLUMNS), len(subjects),
                      list(dict.fromkeys(rows.notes)), rows.outliers, rows.lines,
                      rows.subject_lines, {c: s for c, s in rows.far.items() if s},
                      per_subject, excluded, list(rule_notes), model)


def _frame(rows: list[dict[str, Any]], columns: Sequence[str]) -> pd.DataFrame:
    return pd.DataFrame(rows, columns=list(columns))
