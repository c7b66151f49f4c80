"""From subjects to the population: ``population.csv`` and ``population_contrasts.csv``.

What a paper reports of a study (study format §10), from the result folder's tables and the
subjects' fits, with the statistics of :mod:`evtribo.compare.population_stats`:

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
is no row and the notes say why. A subject outside the prediction interval of the others
is named an outlier and left out of that estimate (:func:`~evtribo.compare.
population_stats.find_outliers`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy import stats

from evtribo.compare.fit import SubjectFit
from evtribo.compare.population_stats import (
    MIN_SUBJECTS,
    POOL_METHOD,
    PowerLawFit,
    SubjectCells,
    find_outliers,
    fit_power_law,
    pool,
)
from evtribo.compare.tables import ResultTables, replicate_matrix

log = logging.getLogger(__name__)

__all__ = ["CONTRAST_COLUMNS", "POPULATION_COLUMNS", "Population", "PopulationOutlier",
           "condition_label", "population"]

#: Columns of population.csv (study format §10).
POPULATION_COLUMNS = ("quantity", "waveform", "frequency_Hz", "amplitude_V", "estimate",
                      "ci_low", "ci_high", "between_subject_sd", "n_subjects", "method")
#: Columns of population_contrasts.csv (study format §10).
CONTRAST_COLUMNS = ("condition_a", "condition_b", "quantity", "ratio", "difference",
                    "ci_low", "ci_high", "n_subjects")
_Z95 = float(stats.norm.ppf(0.975))
_REPLICATES = 200

Condition = tuple[str, float]


def condition_label(waveform: str, frequency_Hz: float) -> str:
    """A condition as population_contrasts.csv names it: ``square 10000 Hz``.

    Parameters
    ----------
    waveform : str
    frequency_Hz : float, Hz
        NaN when the results have no drive frequency.

    Returns
    -------
    str
    """
    return f"{waveform} {frequency_Hz:g} Hz" if math.isfinite(frequency_Hz) else waveform


@dataclass(frozen=True)
class PopulationOutlier:
    """A subject left out of an estimate: where, its value and the others' interval.

    Attributes
    ----------
    subject : str
    quantity : str
        ``electrostatic_force_N at 60 V, square 10000 Hz``, ``exponent, ...``, ``mu``.
    value, low, high : float
        Its value and the others' prediction interval, in the quantity's units.
    """

    subject: str
    quantity: str
    value: float
    low: float
    high: float

    def describe(self) -> str:
        """One sentence for people."""
        return (f"{self.subject}: {self.quantity} {self.value:.3g}, outside the other "
                f"subjects' prediction interval [{self.low:.3g}, {self.high:.3g}]")


@dataclass
class Population:
    """The population's estimates of a study.

    Attributes
    ----------
    table : DataFrame
        population.csv (:data:`POPULATION_COLUMNS`); empty with fewer than three subjects.
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
    """

    table: pd.DataFrame
    contrasts: pd.DataFrame
    n_subjects: int
    notes: list[str] = field(default_factory=list)
    outliers: list[PopulationOutlier] = field(default_factory=list)
    lines: dict[Condition, PowerLawFit] = field(default_factory=dict)

    def as_json(self) -> dict[str, Any]:
        """What fit.json records of it: subjects, notes and outliers.

        Returns
        -------
        dict
        """
        return {"n_subjects": self.n_subjects, "min_subjects": MIN_SUBJECTS,
                "notes": list(self.notes),
                "outliers": [{"subject": o.subject, "quantity": o.quantity,
                              "value": o.value, "low": o.low, "high": o.high}
                             for o in self.outliers]}


@dataclass(frozen=True)
class _Subject:
    """One subject's usable cells, all conditions: keys, log forces, their covariance."""

    name: str
    cells: pd.DataFrame  # waveform, frequency_Hz, amplitude_V, log_f
    cov: NDArray[np.float64]

    def select(self, condition: Condition) -> NDArray[np.int64]:
        """Positions of the cells of *condition*, by amplitude."""
        c = self.cells
        hit = (c["waveform"] == condition[0]) & _same(c["frequency_Hz"], condition[1])
        idx = np.flatnonzero(hit.to_numpy())
        return idx[np.argsort(c["amplitude_V"].to_numpy(float)[idx], kind="stable")]

    def condition(self, condition: Condition) -> SubjectCells:
        """Its cells in *condition*."""
        idx = self.select(condition)
        c = self.cells.iloc[idx]
        return SubjectCells(self.name, np.log(c["amplitude_V"].to_numpy(float)),
                            c["log_f"].to_numpy(float), self.cov[np.ix_(idx, idx)])


def _same(values: pd.Series, target: float) -> pd.Series:
    v = values.to_numpy(float)
    return pd.Series(np.isnan(v) if math.isnan(target) else np.isclose(v, target),
                     index=values.index)


def _log_se(f: NDArray[np.float64], lo: NDArray[np.float64],
            hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Standard errors of log F from 95 % intervals: on the log scale where the interval
    is positive, else its width over the force (the delta method)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        on_log = (np.log(hi) - np.log(lo)) / (2 * _Z95)
        linear = (hi - lo) / (2 * _Z95 * f)
    return np.where(lo > 0, on_log, linear)


def _subject_data(tables: ResultTables, subject: str, notes: list[str]) -> _Subject | None:
    """A subject's usable cells and their covariance (correlation from its replicates)."""
    es = tables.electrostatic
    rows = es[es["subject"].astype(str) == subject].reset_index(drop=True)
    if "frequency_Hz" not in rows.columns:
        rows = rows.assign(frequency_Hz=math.nan)
    f = rows["electrostatic_force_N"].to_numpy(float)
    se = _log_se(f, rows["electrostatic_force_ci_low_N"].to_numpy(float),
                 rows["electrostatic_force_ci_high_N"].to_numpy(float))
    good = (f > 0) & np.isfinite(f) & np.isfinite(se) & (se > 0)
    for _, r in rows[~good].iterrows():
        notes.append(f"{subject}, {condition_label(str(r['waveform']), float(r['frequency_Hz']))}"
                     f", {float(r['amplitude_V']):g} V: F_el not positive or without an "
                     "interval (no logarithm): left out of the population estimates")
    if not good.any():
        return None
    corr = np.eye(len(rows))
    boot = tables.bootstrap
    if boot is not None:
        reps = replicate_matrix(rows, boot[boot["subject"].astype(str) == subject],
                                max_replicates=_REPLICATES)
        if reps is not None:
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = np.nan_to_num(np.corrcoef(reps, rowvar=False))
            np.fill_diagonal(corr, 1.0)
    idx = np.flatnonzero(good)
    cov = corr[np.ix_(idx, idx)] * np.outer(se[idx], se[idx])
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:  # replicates too few for the cells: correlation dropped
        cov = np.diag(se[idx] ** 2)
    cells = pd.DataFrame({"waveform": rows["waveform"].fillna("").astype(str).to_numpy()[idx],
                          "frequency_Hz": rows["frequency_Hz"].to_numpy(float)[idx],
                          "amplitude_V": rows["amplitude_V"].to_numpy(float)[idx],
                          "log_f": np.log(f[idx])})
    return _Subject(subject, cells, cov)


def _conditions(subjects: Sequence[_Subject]) -> list[Condition]:
    """Every (waveform, frequency) of the subjects' cells, square first."""
    found = {(str(w), float(f)) for s in subjects
             for w, f in zip(s.cells["waveform"], s.cells["frequency_Hz"], strict=True)}
    unique: list[Condition] = []
    for c in sorted(found, key=lambda c: (c[0] != "square", c[0],
                                          math.inf if math.isnan(c[1]) else c[1])):
        if not any(c[0] == u[0] and (c[1] == u[1] or (math.isnan(c[1]) and math.isnan(u[1])))
                   for u in unique):
            unique.append(c)
    return unique


class _Rows:
    """Collects population.csv's rows, the notes and the outliers."""

    def __init__(self) -> None:
        self.rows: list[dict[str, Any]] = []
        self.contrasts: list[dict[str, Any]] = []
        self.notes: list[str] = []
        self.outliers: list[PopulationOutlier] = []

    def pooled(self, what: str, subjects: Sequence[str], values: NDArray[np.float64],
               variances: NDArray[np.float64]) -> tuple[Any, list[str]] | None:
        """Pool the subjects' values, leaving out outliers; None (and a note) when fewer
        than three remain."""
        out = find_outliers(values, variances, subjects)
        self.outliers += [PopulationOutlier(o.subject, what, o.value, o.low, o.high)
                          for o in out]
        gone = {o.subject for o in out}
        keep = np.array([s not in gone for s in subjects], dtype=bool)
        if keep.sum() < MIN_SUBJECTS:
            self.notes.append(f"{what}: {int(keep.sum())} subject(s) to pool; a population "
                              f"estimate needs at least {MIN_SUBJECTS}")
            return None
        return pool(values[keep], variances[keep]), sorted(gone)

    def add(self, quantity: str, condition: Condition | None, amplitude: float,
            values: tuple[float, float, float], between_sd: float, n: int, method: str,
            left_out: Sequence[str] = ()) -> None:
        """One row of population.csv."""
        wave, freq = condition if condition is not None else ("", math.nan)
        if left_out:
            method += f"; left out as outliers: {', '.join(left_out)}"
        self.rows.append({"quantity": quantity, "waveform": wave, "frequency_Hz": freq,
                          "amplitude_V": amplitude, "estimate": values[0],
                          "ci_low": values[1], "ci_high": values[2],
                          "between_subject_sd": between_sd, "n_subjects": n,
                          "method": method})


def _forces(rows: _Rows, subjects: Sequence[_Subject], condition: Condition) -> None:
    """The geometric-mean force at each amplitude of *condition*."""
    label = condition_label(*condition)
    amps = sorted({float(a) for s in subjects for a in
                   s.cells["amplitude_V"].to_numpy(float)[s.select(condition)]})
    for amp in amps:
        names, y, v = [], [], []
        for s in subjects:
            idx = s.select(condition)
            hit = idx[np.isclose(s.cells["amplitude_V"].to_numpy(float)[idx], amp)]
            if hit.size:
                names.append(s.name)
                y.append(float(s.cells["log_f"].iloc[hit[0]]))
                v.append(float(s.cov[hit[0], hit[0]]))
        got = rows.pooled(f"F_el at {amp:g} V, {label}", names, np.array(y), np.array(v))
        if got is not None:
            p, gone = got
            rows.add("electrostatic_force_N", condition, amp,
                     (math.exp(p.estimate), math.exp(p.ci_low), math.exp(p.ci_high)),
                     p.between_sd, p.n_subjects, f"{POOL_METHOD}, of log F_el", gone)


def _own_outliers(rows: _Rows, cells: Sequence[SubjectCells], label: str,
                  log_u0: float) -> set[str]:
    """Subjects whose own power law (log F at the centre, or exponent) lies outside the
    others' prediction interval."""
    fits = [c.own_fit(log_u0) for c in cells]
    names = [c.subject for c in cells]
    gone: set[str] = set()
    for j, what in ((0, f"log F_el at {math.exp(log_u0):.3g} V, {label}"),
                    (1, f"exponent, {label}")):
        found = find_outliers(np.array([b[j] for b, _ in fits]),
                              np.array([cov[j, j] for _, cov in fits]), names)
        rows.outliers += [PopulationOutlier(o.subject, what, o.value, o.low, o.high)
                          for o in found]
        gone |= {o.subject for o in found}
    return gone


def _power_law(rows: _Rows, subjects: Sequence[_Subject], condition: Condition
               ) -> PowerLawFit | None:
    """The exponent and prefactor of *condition* from the mixed model."""
    label = condition_label(*condition)
    cells = [c for c in (s.condition(condition) for s in subjects)
             if np.unique(c.log_u).size >= 2]
    if len(cells) < MIN_SUBJECTS:
        rows.notes.append(f"{label}: {len(cells)} subject(s) with two amplitudes or more; "
                          f"a population power law needs at least {MIN_SUBJECTS}")
        return None
    centre = float(np.mean(np.concatenate([c.log_u for c in cells])))
    gone = _own_outliers(rows, cells, label, centre)
    kept = [c for c in cells if c.subject not in gone]
    if len(kept) < MIN_SUBJECTS:
        rows.notes.append(f"{label}: {len(kept)} subject(s) left after the outliers; a "
                          f"population power law needs at least {MIN_SUBJECTS}")
        return None
    try:
        fit = fit_power_law(kept)
    except np.linalg.LinAlgError as err:
        rows.notes.append(f"{label}: the power law across subjects could not be fitted "
                          f"({err})")
        return None
    left = sorted(gone)
    n_hat = fit.estimate([0.0, 1.0])
    rows.add("exponent", condition, math.nan, (n_hat.value, *n_hat.interval()),
             float(fit.between_sd[1]), len(kept), fit.method, left)
    c_k = np.array([1.0, -fit.log_u0])
    k_hat = fit.estimate(c_k)
    lo, hi = k_hat.interval()
    rows.add("prefactor_N", condition, math.nan,
             (math.exp(k_hat.value), math.exp(lo), math.exp(hi)), fit.between_sd_of(c_k),
             len(kept), fit.method + ", at 1 V, of log k", left)
    return fit


def _mu(rows: _Rows, tables: ResultTables, subjects: Sequence[str]) -> None:
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
    got = rows.pooled("mu", names, np.array(y), np.array(v))
    if got is not None:
        p, gone = got
        rows.add("mu", None, math.nan, (p.estimate, p.ci_low, p.ci_high), p.between_sd,
                 p.n_subjects, f"{POOL_METHOD}, of each subject's mu from its OFF windows",
                 gone)


def _air_gap(rows: _Rows, fits: Sequence[SubjectFit]) -> None:
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
    got = rows.pooled("h_L", names, np.array(y), np.array(v))
    if got is not None:
        p, gone = got
        rows.add("h_L_m", None, math.nan,
                 (math.exp(p.estimate), math.exp(p.ci_low), math.exp(p.ci_high)),
                 p.between_sd, p.n_subjects, f"{POOL_METHOD}, of log h_L", gone)


def _pairs(subjects: Sequence[_Subject], a: Condition, b: Condition
           ) -> Iterator[tuple[str, NDArray[np.int64], NDArray[np.int64]]]:
    """Each subject's cells of *a* and *b* at the amplitudes it has in both."""
    for s in subjects:
        ia, ib = s.select(a), s.select(b)
        amp = s.cells["amplitude_V"].to_numpy(float)
        common = [x for x in amp[ia] if np.isclose(amp[ib], x).any()]
        if common:
            ia = np.array([i for i in ia if np.isclose(common, amp[i]).any()])
            ib = np.array([i for i in ib if np.isclose(common, amp[i]).any()])
            yield s.name, ia, ib


def _contrast(rows: _Rows, subjects: Sequence[_Subject], a: Condition, b: Condition) -> None:
    """The ratio of the forces of *b* to *a*, and the difference of their exponents."""
    la, lb = condition_label(*a), condition_label(*b)
    by_name = {s.name: s for s in subjects}
    ratio: tuple[list[str], list[float], list[float]] = ([], [], [])
    slope: tuple[list[str], list[float], list[float]] = ([], [], [])
    for name, ia, ib in _pairs(subjects, a, b):
        s = by_name[name]
        w = np.concatenate([-np.ones(ia.size), np.ones(ib.size)]) / ia.size
        idx = np.concatenate([ia, ib])
        _append(ratio, name, float(w @ s.cells["log_f"].to_numpy(float)[idx]),
                float(w @ s.cov[np.ix_(idx, idx)] @ w))
        if ia.size >= 2:
            log_u = np.log(s.cells["amplitude_V"].to_numpy(float)[ia])
            wd = np.concatenate([-_slope_weights(log_u, s.cov[np.ix_(ia, ia)]),
                                 _slope_weights(log_u, s.cov[np.ix_(ib, ib)])])
            _append(slope, name, float(wd @ s.cells["log_f"].to_numpy(float)[idx]),
                    float(wd @ s.cov[np.ix_(idx, idx)] @ wd))
    for quantity, (names, y, v), exp in (("electrostatic_force_N", ratio, True),
                                         ("exponent", slope, False)):
        if not names:
            continue
        got = rows.pooled(f"{quantity}: {lb} against {la}", names, np.array(y), np.array(v))
        if got is None:
            continue
        p = got[0]
        f = math.exp if exp else float
        rows.contrasts.append({"condition_a": la, "condition_b": lb, "quantity": quantity,
                               "ratio": f(p.estimate) if exp else math.nan,
                               "difference": math.nan if exp else p.estimate,
                               "ci_low": f(p.ci_low), "ci_high": f(p.ci_high),
                               "n_subjects": p.n_subjects})


def _slope_weights(log_u: NDArray[np.float64], cov: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
    """The weights that give a subject's weighted power-law exponent from its log forces."""
    x = np.column_stack([np.ones(log_u.size), log_u - log_u.mean()])
    cx = np.linalg.solve(cov, x)
    return np.asarray(np.linalg.solve(x.T @ cx, cx.T)[1], dtype=float)


def _append(into: tuple[list[str], list[float], list[float]], name: str, value: float,
            variance: float) -> None:
    if math.isfinite(value) and math.isfinite(variance) and variance > 0:
        into[0].append(name)
        into[1].append(value)
        into[2].append(variance)


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
        Empty tables, and a note saying why, with fewer than three subjects.
    """
    rows = _Rows()
    subjects = [s for s in (_subject_data(tables, name, rows.notes)
                            for name in tables.subjects) if s is not None]
    if len(subjects) < MIN_SUBJECTS:
        rows.notes.insert(0, f"{len(subjects)} subject(s) with electrostatic forces: a "
                             f"population estimate needs at least {MIN_SUBJECTS}, so none "
                             "was made")
        return Population(_frame([], POPULATION_COLUMNS), _frame([], CONTRAST_COLUMNS),
                          len(subjects), rows.notes)
    lines: dict[Condition, PowerLawFit] = {}
    conditions = _conditions(subjects)
    for condition in conditions:
        _forces(rows, subjects, condition)
        line = _power_law(rows, subjects, condition)
        if line is not None:
            lines[condition] = line
    _mu(rows, tables, [s.name for s in subjects])
    _air_gap(rows, fits)
    for a, b in combinations(conditions, 2):
        _contrast(rows, subjects, a, b)
    return Population(_frame(rows.rows, POPULATION_COLUMNS),
                      _frame(rows.contrasts, CONTRAST_COLUMNS), len(subjects),
                      list(dict.fromkeys(rows.notes)), rows.outliers, lines)


def _frame(rows: list[dict[str, Any]], columns: Sequence[str]) -> pd.DataFrame:
    return pd.DataFrame(rows, columns=list(columns))
