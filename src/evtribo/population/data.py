"""The population's inputs: each subject's cells with their covariance, and a collector of
population.csv's rows (:mod:`evtribo.population.estimates` and
:mod:`evtribo.population.contrasts` fill it).

A subject's cells are its rows of electrostatic.csv with a positive force and an interval:
log F_el, each with the standard error its 95 % interval gives (on the log scale where the
interval is positive, else the delta method), correlated as the subject's bootstrap
replicates are (``electrostatic_bootstrap.csv``; independent without them). A cell without a
logarithm is left out, and named in the notes.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy import stats

from evtribo.fit.tables import MIN_REPLICATES, ResultTables
from evtribo.population.model import PowerLawFit, SubjectCells
from evtribo.population.stats import MIN_SUBJECTS, OUTLIER_ALPHA, Outlier, find_outliers, pool
from evtribo.util.numbers import quantity

__all__ = ["CONTRAST_COLUMNS", "POPULATION_COLUMNS", "Collector", "Condition",
           "PopulationOutlier", "SubjectData", "condition_label", "conditions_of",
           "subject_data"]

POPULATION_COLUMNS = ("quantity", "waveform", "frequency_Hz", "amplitude_V", "estimate",
                      "ci_low", "ci_high", "between_subject_sd", "n_subjects", "method")
#: Columns of population_contrasts.csv (study format §10).
CONTRAST_COLUMNS = ("condition_a", "condition_b", "quantity", "ratio", "difference",
                    "ci_low", "ci_high", "n_subjects")
#: Bootstrap replicates read per subject for its cells' correlation.
REPLICATES = 200
_Z95 = float(stats.norm.ppf(0.975))

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
        ``F_el at 60 V, square 10000 Hz``, ``exponent, square 10000 Hz``, ``mu``.
    value, low, high : float
        Its value and the other subjects' prediction interval (SI units: N, m).
    unit : str
        ``N``, ``m`` or ``""``.
    """

    subject: str
    quantity: str
    value: float
    low: float
    high: float
    unit: str = ""

    def describe(self) -> str:
        """One sentence for people: ``S03: F_el at 60 V, square 10000 Hz, 263 mN, outside
        the other subjects' prediction interval [12.8 mN, 97.3 mN]``."""
        def q(x: float) -> str:
            return quantity(x, self.unit)

        return (f"{self.subject}: {self.quantity}, {q(self.value)}, outside the other "
                f"subjects' prediction interval [{q(self.low)}, {q(self.high)}]")


@dataclass(frozen=True)
class SubjectData:
    """One subject's usable cells, all conditions: keys, log forces, their covariance."""

    name: str
    cells: pd.DataFrame  # waveform, frequency_Hz, amplitude_V, log_f
    cov: NDArray[np.float64]

    def select(self, condition: Condition) -> NDArray[np.int64]:
        """Positions of the cells of *condition*, by amplitude."""
        f = self.cells["frequency_Hz"].to_numpy(float)
        same = np.isnan(f) if math.isnan(condition[1]) else np.isclose(f, condition[1])
        idx = np.flatnonzero((self.cells["waveform"].to_numpy() == condition[0]) & same)
        return idx[np.argsort(self.amplitudes[idx], kind="stable")]

    @property
    def amplitudes(self) -> NDArray[np.float64]:
        """Each cell's amplitude, V."""
        return np.asarray(self.cells["amplitude_V"].to_numpy(float))

    @property
    def log_f(self) -> NDArray[np.float64]:
        """Each cell's log F_el (N)."""
        return np.asarray(self.cells["log_f"].to_numpy(float))

    def condition(self, condition: Condition) -> SubjectCells:
        """Its cells in *condition*."""
        idx = self.select(condition)
        c = self.cells.iloc[idx]
        return SubjectCells(self.name, np.log(c["amplitude_V"].to_numpy(float)),
                            c["log_f"].to_numpy(float), self.cov[np.ix_(idx, idx)])


def _log_se(f: NDArray[np.float64], lo: NDArray[np.float64],
            hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Standard errors of log F from 95 % intervals: on the log scale where the interval
    is positive, else its width over the force (the delta method)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        on_log = (np.log(hi) - np.log(lo)) / (2 * _Z95)
        linear = (hi - lo) / (2 * _Z95 * f)
    return np.where(lo > 0, on_log, linear)


def _keys(frame: pd.DataFrame) -> pd.Index:
    """Each row's waveform, frequency and amplitude as one key (as replicate_matrix
    matches them)."""
    freq = (frame["frequency_Hz"].to_numpy(float) if "frequency_Hz" in frame.columns
            else np.full(len(frame), np.nan))
    return pd.Index([f"{w}|{f:.6f}|{a:.6f}" for w, f, a in zip(
        frame["waveform"].fillna("").astype(str), np.nan_to_num(freq, nan=-1.0),
        frame["amplitude_V"].to_numpy(float), strict=True)])


def _replicates(rows: pd.DataFrame, boot: pd.DataFrame) -> NDArray[np.float64] | None:
    """The replicates of *rows*' forces, shape (n, len(rows)): the first complete ones, up
    to :data:`REPLICATES`; None when a row has none, two rows share a key, or fewer than
    MIN_REPLICATES are complete (:func:`~evtribo.fit.tables.replicate_matrix`'s rules,
    without its pivot table: a subject at a time in compare's population)."""
    want = _keys(rows)
    if boot.empty or want.has_duplicates:
        return None
    col = want.get_indexer(_keys(boot))
    reps = boot["replicate"].to_numpy(int)
    ok = col >= 0
    if not ok.any() or len(set(col[ok])) < len(want):
        return None
    mat = np.full((int(reps.max()) + 1, len(want)), np.nan)
    mat[reps[ok], col[ok]] = boot["electrostatic_force_N"].to_numpy(float)[ok]
    mat = mat[np.all(np.isfinite(mat), axis=1)][:REPLICATES]
    return mat if mat.shape[0] >= MIN_REPLICATES else None


def subject_data(tables: ResultTables, subject: str, notes: list[str], *,
                 bootstrap: pd.DataFrame | None = None) -> SubjectData | None:
    """A subject's usable cells and their covariance (correlation from its replicates).

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables (electrostatic.csv, and its replicates when present).
    subject : str
        Whose cells.
    notes : list of str
        Where a cell left out (no logarithm, no interval) is named.
    bootstrap : DataFrame, optional
        The subject's rows of the bootstrap table (default: picked from *tables*).

    Returns
    -------
    SubjectData or None
        None when no cell of the subject is usable.
    """
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
    corr: NDArray[np.float64] = np.eye(len(rows))
    boot = tables.bootstrap
    if bootstrap is None and boot is not None:
        bootstrap = boot[boot["subject"].astype(str) == subject]
    if bootstrap is not None:
        reps = _replicates(rows, bootstrap)
        if reps is not None:
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = np.atleast_2d(np.nan_to_num(np.corrcoef(reps, rowvar=False)))
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
    return SubjectData(subject, cells, cov)


def conditions_of(subjects: Sequence[SubjectData]) -> list[Condition]:
    """Every (waveform, frequency) of the subjects' cells, square first.

    Parameters
    ----------
    subjects : sequence of SubjectData

    Returns
    -------
    list of (str, float)
        Each condition once (frequencies compared as numbers; NaN: no frequency).
    """
    found = {(str(w), float(f)) for s in subjects
             for w, f in zip(s.cells["waveform"], s.cells["frequency_Hz"], strict=True)}
    unique: list[Condition] = []
    for c in sorted(found, key=lambda c: (c[0] != "square", c[0],
                                          math.inf if math.isnan(c[1]) else c[1])):
        if not any(c[0] == u[0] and (c[1] == u[1] or (math.isnan(c[1]) and math.isnan(u[1])))
                   for u in unique):
            unique.append(c)
    return unique


class Collector:
    """Collects population.csv's rows, the notes and the outliers."""

    def __init__(self) -> None:
        self.rows: list[dict[str, Any]] = []
        self.contrasts: list[dict[str, Any]] = []
        self.notes: list[str] = []
        self.outliers: list[PopulationOutlier] = []
        self.lines: dict[Condition, PowerLawFit] = {}
        self.subject_lines: dict[Condition, dict[str, tuple[float, float]]] = {}
        self.left_out: dict[Condition, set[str]] = {}
        #: The level of each quantity's outlier test (the study's, shared among them).
        self.alpha = OUTLIER_ALPHA

    def flag(self, what: str, found: Sequence[Outlier], unit: str | None) -> None:
        """Record outliers; *unit*: their values are logs of a quantity in that unit."""
        f = math.exp if unit is not None else float
        self.outliers += [PopulationOutlier(o.subject, what, f(o.value), f(o.low),
                                            f(o.high), unit or "") for o in found]

    def pooled(self, what: str, subjects: Sequence[str], values: NDArray[np.float64],
               variances: NDArray[np.float64], unit: str | None = None, *,
               exclude: Collection[str] | None = None) -> tuple[Any, list[str]] | None:
        """Pool the subjects' values, leaving out outliers; None (and a note) when fewer
        than three remain. *unit*: the values are logs of a quantity in that unit.
        *exclude*: the outliers, found elsewhere (else they are looked for here)."""
        if exclude is None:
            found = find_outliers(values, variances, subjects, alpha=self.alpha)
            self.flag(what, found, unit)
            exclude = {o.subject for o in found}
        gone = sorted(set(subjects) & set(exclude))
        keep = np.array([s not in exclude for s in subjects], dtype=bool)
        if keep.sum() < MIN_SUBJECTS:
            self.notes.append(f"{what}: {int(keep.sum())} subject(s) to pool; a population "
                              f"estimate needs at least {MIN_SUBJECTS}")
            return None
        return pool(values[keep], variances[keep]), gone

    def add(self, quantity: str, condition: Condition | None, amplitude: float,
            values: tuple[float, float, float], *, between_sd: float, n: int, method: str,
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
