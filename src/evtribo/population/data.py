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
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import special

from evtribo.documents.tables import CONTRASTS, POPULATION
from evtribo.fit.tables import MIN_REPLICATES, ResultTables
from evtribo.population.nonlinear_fit import NonlinearFit
from evtribo.population.stats import (
    MIN_SUBJECTS,
    OUTLIER_ALPHA,
    Outlier,
    Pooled,
    find_outliers,
    pool,
)
from evtribo.util.numbers import quantity
from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["CONTRAST_COLUMNS", "LINEAR_COLUMNS", "META", "POPULATION_COLUMNS", "PRIMARY",
           "Collector", "Condition", "ModelRow", "PopulationOutlier", "SubjectData",
           "condition_label", "conditions_of", "drive_scope", "exp_or_nan", "subject_data"]

emit = emitter(__name__)

#: Columns of population.csv and population_contrasts.csv (study format §10;
#: :mod:`evtribo.documents.tables`).
POPULATION_COLUMNS, CONTRAST_COLUMNS = POPULATION.names(), CONTRASTS.names()
#: ``analysis`` of the rows every subject is in (but those the study excluded beforehand).
PRIMARY = "primary"
#: ``analysis`` of the rows of a meta-analysis of log F_el at each amplitude.
META = "meta-analysis"
#: Bootstrap replicates read per subject for its cells' correlation.
REPLICATES = 200
_Z95 = float(special.ndtri(0.975))
#: The largest logarithm whose exp is a float.
_LOG_MAX = math.log(sys.float_info.max)

Condition = tuple[str, float]


def exp_or_nan(x: float) -> float:
    """``exp(x)``, or NaN (absent) where it is beyond any float: the end of an interval on
    the log scale that the data do not bound (an exponent read as unknown, ``exp`` of
    millions), said by the fit's checks rather than written as a number.

    Parameters
    ----------
    x : float
        A logarithm (of a force in N, of a length in m...).

    Returns
    -------
    float
        ``exp(x)`` in the same unit; NaN for a NaN or for x above about 709.78.
    """
    return math.exp(x) if x <= _LOG_MAX else math.nan


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
        the other subjects' prediction interval [12.8 mN, 97.3 mN]`` (:meth:`record`'s
        text)."""
        return self.record().text

    def record(self) -> WarningRecord:
        """The warning (``population-outlier``) saying it, made and not said.

        Returns
        -------
        WarningRecord
        """
        def q(x: float) -> str:
            return quantity(x, self.unit)

        return emit.record("population-outlier", Scope(self.subject),
                           quantity=self.quantity, value_text=q(self.value),
                           low_text=q(self.low), high_text=q(self.high), value=self.value,
                           low=self.low, high=self.high, unit=self.unit)


#: Columns of a subject's linear cells.
LINEAR_COLUMNS = ("waveform", "frequency_Hz", "amplitude_V", "force_N", "ci_low_N",
                  "ci_high_N", "normal_force_N")


def _positions(cells: pd.DataFrame, condition: Condition) -> NDArray[np.int64]:
    """Positions of the rows of *cells* in *condition*, by amplitude."""
    f = cells["frequency_Hz"].to_numpy(float)
    same = np.isnan(f) if math.isnan(condition[1]) else np.isclose(f, condition[1])
    idx = np.flatnonzero((cells["waveform"].to_numpy() == condition[0]) & same)
    return idx[np.argsort(cells["amplitude_V"].to_numpy(float)[idx], kind="stable")]


@dataclass(frozen=True)
class SubjectData:
    """One subject's usable cells, all conditions.

    ``cells`` and ``cov``: the cells with a logarithm (a positive force and interval), their
    log forces and covariance, for the meta-analysis and the contrasts; ``linear`` and
    ``linear_cov``: every cell with a force and an interval (negative ones too), its
    force and covariance in N, for the mixed model on the linear scale.
    """

    name: str
    cells: pd.DataFrame  # waveform, frequency_Hz, amplitude_V, log_f
    cov: NDArray[np.float64]
    linear: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=LINEAR_COLUMNS))
    linear_cov: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))

    def select(self, condition: Condition) -> NDArray[np.int64]:
        """Positions of the log cells of *condition*, by amplitude."""
        return _positions(self.cells, condition)

    def select_linear(self, condition: Condition) -> NDArray[np.int64]:
        """Positions of the linear cells of *condition*, by amplitude."""
        return _positions(self.linear, condition)

    @property
    def amplitudes(self) -> NDArray[np.float64]:
        """Each log cell's amplitude, V."""
        return np.asarray(self.cells["amplitude_V"].to_numpy(float))

    @property
    def log_f(self) -> NDArray[np.float64]:
        """Each log cell's log F_el (N)."""
        return np.asarray(self.cells["log_f"].to_numpy(float))

    def on_linear_scale(self, condition: Condition
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                   NDArray[np.float64]]:
        """Its cells in *condition* on the linear scale: ln U (V), F_el (N), covariance
        (N^2)."""
        idx = self.select_linear(condition)
        c = self.linear.iloc[idx]
        return (np.log(c["amplitude_V"].to_numpy(float)), c["force_N"].to_numpy(float),
                self.linear_cov[np.ix_(idx, idx)])


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


def _correlation(rows: pd.DataFrame, bootstrap: pd.DataFrame | None
                 ) -> NDArray[np.float64]:
    """The correlation of *rows*' forces, from their replicates (independent without)."""
    corr: NDArray[np.float64] = np.eye(len(rows))
    if bootstrap is not None:
        reps = _replicates(rows, bootstrap)
        if reps is not None:
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = np.atleast_2d(np.nan_to_num(np.corrcoef(reps, rowvar=False)))
            np.fill_diagonal(corr, 1.0)
    return corr


def _covariance(corr: NDArray[np.float64], se: NDArray[np.float64],
                idx: NDArray[np.int64]) -> NDArray[np.float64]:
    """The covariance of the cells *idx*; the correlation dropped when it is not positive
    definite (replicates too few for the cells)."""
    cov = corr[np.ix_(idx, idx)] * np.outer(se[idx], se[idx])
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        cov = np.diag(se[idx] ** 2)
    return cov


def _cell_record(kind_id: str, subject: str, r: pd.Series) -> WarningRecord:
    """A warning about one of a subject's cells (made, not said)."""
    wave, freq, amp = str(r["waveform"]), float(r["frequency_Hz"]), float(r["amplitude_V"])
    return emit.record(kind_id, Scope(subject, None, wave, freq, amp), subject=subject,
                       drive=condition_label(wave, freq), amplitude_V=amp)


def drive_scope(condition: Condition) -> Scope:
    """The scope of a warning about a drive of the population (no subject's).

    Parameters
    ----------
    condition : (str, float)
        The waveform and drive frequency, Hz.

    Returns
    -------
    Scope
    """
    return Scope(None, None, condition[0] or None, condition[1])


def subject_data(tables: ResultTables, subject: str, notes: list[WarningRecord], *,
                 bootstrap: pd.DataFrame | None = None) -> SubjectData | None:
    """A subject's usable cells and their covariance (correlation from its replicates).

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables (electrostatic.csv, and its replicates when present).
    subject : str
        Whose cells.
    notes : list of WarningRecord
        Where a cell left out (no interval; no logarithm, for the log-scale estimates) is
        named (made, not said).
    bootstrap : DataFrame, optional
        The subject's rows of the bootstrap table (default: picked from *tables*).

    Returns
    -------
    SubjectData or None
        None when no cell of the subject has a force and an interval.
    """
    es = tables.electrostatic
    rows = es[es["subject"].astype(str) == subject].reset_index(drop=True)
    if "frequency_Hz" not in rows.columns:
        rows = rows.assign(frequency_Hz=math.nan)
    f = rows["electrostatic_force_N"].to_numpy(float)
    lo = rows["electrostatic_force_ci_low_N"].to_numpy(float)
    hi = rows["electrostatic_force_ci_high_N"].to_numpy(float)
    with np.errstate(invalid="ignore"):
        lin_se = (hi - lo) / (2 * _Z95)
        usable = np.isfinite(f) & np.isfinite(lin_se) & (lin_se > 0)
    se = _log_se(f, lo, hi)
    logged = usable & (f > 0) & np.isfinite(se) & (se > 0)
    for _, r in rows[~usable].iterrows():
        notes.append(_cell_record("population-cell-no-interval", subject, r))
    for _, r in rows[usable & ~logged].iterrows():
        notes.append(_cell_record("population-cell-not-positive", subject, r))
    if not usable.any():
        return None
    boot = tables.bootstrap
    if bootstrap is None and boot is not None:
        bootstrap = boot[boot["subject"].astype(str) == subject]
    corr = _correlation(rows, bootstrap)
    idx, lin = np.flatnonzero(logged), np.flatnonzero(usable)
    wave = rows["waveform"].fillna("").astype(str).to_numpy()
    freq = rows["frequency_Hz"].to_numpy(float)
    amp = rows["amplitude_V"].to_numpy(float)
    cells = pd.DataFrame({"waveform": wave[idx], "frequency_Hz": freq[idx],
                          "amplitude_V": amp[idx], "log_f": np.log(f[idx])})
    fn = rows["normal_force_on_N"].to_numpy(float) if "normal_force_on_N" in rows.columns \
        else np.full(len(rows), math.nan)
    linear = pd.DataFrame({"waveform": wave[lin], "frequency_Hz": freq[lin],
                           "amplitude_V": amp[lin], "force_N": f[lin], "ci_low_N": lo[lin],
                           "ci_high_N": hi[lin], "normal_force_N": fn[lin]},
                          columns=list(LINEAR_COLUMNS))
    return SubjectData(subject, cells, _covariance(corr, se, idx), linear,
                       _covariance(corr, lin_se, lin))


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
             for w, f in zip(s.linear["waveform"], s.linear["frequency_Hz"], strict=True)}
    unique: list[Condition] = []
    for c in sorted(found, key=lambda c: (c[0] != "square", c[0],
                                          math.inf if math.isnan(c[1]) else c[1])):
        if not any(c[0] == u[0] and (c[1] == u[1] or (math.isnan(c[1]) and math.isnan(u[1])))
                   for u in unique):
            unique.append(c)
    return unique


@dataclass(frozen=True)
class ModelRow:
    """One estimate of a population model, a row of population.csv but for its drive and
    its analysis (:meth:`Collector.add_row` sets them).

    Attributes
    ----------
    quantity : str
        ``electrostatic_force_N``, ``exponent``, ``prefactor_N``...
    amplitude_V : float, V
        NaN for a quantity of no amplitude.
    values : (float, float, float)
        The estimate and its 95 % interval, in the quantity's unit.
    between_sd : float
        The between-subject SD (of the log where the quantity is pooled on the log scale).
    n : int
        Subjects.
    method : str
        population.csv's ``method``.
    extra : mapping
        Its other columns (prediction interval, the SD's interval, I^2, ``checks``).
    """

    quantity: str
    amplitude_V: float
    values: tuple[float, float, float]
    between_sd: float
    n: int
    method: str
    extra: Mapping[str, float | str] = field(default_factory=dict)

    @classmethod
    def pooled(cls, quantity: str, amplitude_V: float, p: Pooled, *, method: str,
               log: bool = False) -> ModelRow:
        """The row of a random-effects meta-analysis (*log*: of the quantity's logarithm).

        Parameters
        ----------
        quantity : str
        amplitude_V : float, V
        p : Pooled
        method : str
        log : bool

        Returns
        -------
        ModelRow
        """
        f = exp_or_nan if log else float
        return cls(quantity, amplitude_V, (f(p.estimate), f(p.ci_low), f(p.ci_high)),
                   p.between_sd, p.n_subjects, method,
                   {"pi_low": f(p.pi_low), "pi_high": f(p.pi_high),
                    "between_sd_low": p.tau_low, "between_sd_high": p.tau_high,
                    "i2": p.i2, "i2_low": p.i2_low, "i2_high": p.i2_high})


class Collector:
    """Collects population.csv's rows, the notes and the subjects far from the others."""

    def __init__(self) -> None:
        self.rows: list[dict[str, Any]] = []
        self.contrasts: list[dict[str, Any]] = []
        #: What the population's estimates say (made, not said: compare says them).
        self.notes: list[WarningRecord] = []
        self.outliers: list[PopulationOutlier] = []
        self.lines: dict[Condition, NonlinearFit] = {}
        self.subject_lines: dict[Condition, dict[str, tuple[float, float]]] = {}
        #: Per condition, the subjects named as far from the others (in every estimate).
        self.far: dict[Condition, set[str]] = {}
        #: The level of each quantity's outlier test (the study's, shared among them).
        self.alpha = OUTLIER_ALPHA

    def flag(self, what: str, found: Sequence[Outlier], unit: str | None) -> None:
        """Record subjects far from the others; *unit*: their values are logs of a
        quantity in that unit."""
        f = exp_or_nan if unit is not None else float
        self.outliers += [PopulationOutlier(o.subject, what, f(o.value), f(o.low),
                                            f(o.high), unit or "") for o in found]

    def pooled(self, what: str, subjects: Sequence[str], values: NDArray[np.float64],
               variances: NDArray[np.float64], unit: str | None = None, *,
               check: bool = True) -> tuple[Pooled, list[str]] | None:
        """Pool every subject's value, and name those far from the others (*check*); None
        (and a note) with fewer than three. *unit*: the values are logs of a quantity in
        that unit."""
        if len(subjects) < MIN_SUBJECTS:
            self.notes.append(emit.record("population-pool-few", what=what,
                                          subjects=len(subjects), needed=MIN_SUBJECTS))
            return None
        far: list[str] = []
        if check:
            found = find_outliers(values, variances, subjects, alpha=self.alpha)
            self.flag(what, found, unit)
            far = [o.subject for o in found]
        return pool(values, variances), far

    def add(self, quantity: str, condition: Condition | None, amplitude: float,
            values: tuple[float, float, float], *, between_sd: float, n: int, method: str,
            analysis: str = PRIMARY, extra: Mapping[str, float | str] | None = None) -> None:
        """One row of population.csv (*extra*: its other columns, NaN or "" when absent)."""
        wave, freq = condition if condition is not None else ("", math.nan)
        row: dict[str, Any] = dict.fromkeys(POPULATION_COLUMNS, math.nan)
        row.update({"quantity": quantity, "waveform": wave, "frequency_Hz": freq,
                    "amplitude_V": amplitude, "estimate": values[0], "ci_low": values[1],
                    "ci_high": values[2], "between_subject_sd": between_sd,
                    "n_subjects": n, "method": method, "analysis": analysis, "checks": ""})
        row.update(extra or {})
        self.rows.append(row)

    def add_row(self, condition: Condition | None, row: ModelRow, *,
                analysis: str = PRIMARY) -> None:
        """A model's row of *condition*, in the analysis *analysis*."""
        self.add(row.quantity, condition, row.amplitude_V, row.values,
                 between_sd=row.between_sd, n=row.n, method=row.method, analysis=analysis,
                 extra=row.extra)

    def add_pooled(self, quantity: str, condition: Condition | None, amplitude: float,
                   p: Pooled, *, method: str, analysis: str = PRIMARY,
                   log: bool = False) -> None:
        """A row from a meta-analysis (*log*: of the quantity's logarithm)."""
        self.add_row(condition, ModelRow.pooled(quantity, amplitude, p, method=method,
                                                log=log), analysis=analysis)
