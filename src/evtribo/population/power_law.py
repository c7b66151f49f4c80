"""One condition's population: the power law across subjects on the linear scale (every
subject in), the subjects far from the others with the estimates without each, and the
meta-analysis of log F_el at the amplitudes where it is valid.

Rows of population.csv, by ``analysis``:

``primary``
    The nonlinear mixed model (:mod:`evtribo.population.nonlinear_fit`) of every subject's
    cells, negative ones included: the population's F_el at each amplitude measured (its
    power law there: the geometric mean over subjects), the exponent and the prefactor
    (F_el at 1 V), each with its prediction interval for a new subject, the between-subject
    SD with its interval and I^2, and the convergence checks.
``without <subject>``
    The same model without a subject named as far from the others (its own power law, level
    or exponent, outside the others' prediction interval; :func:`~evtribo.population.stats.
    find_outliers`): how much the estimates lean on it. Nobody is left out of the primary
    rows.
``meta-analysis``
    The random-effects meta-analysis of log F_el at one amplitude, where it is valid: every
    subject measured there has a force whose 95 % interval lies above zero and whose
    standard error on the log scale is at most :data:`META_MAX_LOG_SE` (else a cell's log
    standard error, its interval's width over the force, would be correlated with how high it
    came out, and the weights would favour cells that came out high).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np

from evtribo.population.data import (
    META,
    PRIMARY,
    Collector,
    Condition,
    SubjectData,
    condition_label,
    exp_or_nan,
)
from evtribo.population.nonlinear import NonlinearData, nonlinear_data, subject_fits
from evtribo.population.nonlinear_fit import NonlinearFit, fit_nonlinear
from evtribo.population.stats import (
    MIN_SUBJECTS,
    POOL_METHOD,
    find_outliers,
    i_squared,
    typical_variance,
)

log = logging.getLogger(__name__)

__all__ = ["META_MAX_LOG_SE", "condition_estimates"]

#: The largest standard error of a cell's log F_el for the meta-analysis of log F_el.
META_MAX_LOG_SE = 0.2


def _data(subjects: Sequence[SubjectData], condition: Condition) -> NonlinearData | None:
    names, cells = [], []
    for s in subjects:
        lu, f, cov = s.on_linear_scale(condition)
        if f.size:
            names.append(s.name)
            cells.append((lu, f, cov))
    return nonlinear_data(names, cells) if names else None


def _fit(data: NonlinearData, rows: Collector, label: str) -> NonlinearFit | None:
    """The mixed model, with random exponents where at least three subjects have three
    amplitudes or more (else, or when that fit fails, random levels only)."""
    rich = int(np.sum([np.unique(np.round(data.x[i, :n], 9)).size >= 3
                       for i, n in enumerate(data.n_cells)]))
    for slopes in ((True, False) if rich >= MIN_SUBJECTS else (False,)):
        try:
            return fit_nonlinear(data, random_slopes=slopes)
        except np.linalg.LinAlgError as err:
            rows.notes.append(f"{label}: the mixed model with random "
                              f"{'exponents' if slopes else 'levels'} could not be fitted "
                              f"({err})")
    return None


def _extra(fit: NonlinearFit, c: np.ndarray, own: np.ndarray, *, log_scale: bool
           ) -> dict[str, float | str]:
    """Prediction interval, the between-subject SD's interval, I^2 (against the typical
    variance of the subjects' own estimates, *own*: their covariances) and the checks."""
    f = exp_or_nan if log_scale else float
    lo, hi = fit.prediction_interval(c)
    tau = fit.between_sd_of(c)
    t_lo, t_hi = fit.between_sd_interval(c)
    typical = typical_variance(np.einsum("i,kij,j->k", c, own, c)) if own.size else math.nan
    return {"pi_low": f(lo) if math.isfinite(lo) else math.nan,
            "pi_high": f(hi) if math.isfinite(hi) else math.nan,
            "between_sd_low": t_lo, "between_sd_high": t_hi,
            "i2": i_squared(tau, typical), "i2_low": i_squared(t_lo, typical),
            "i2_high": i_squared(t_hi, typical), "checks": fit.convergence.summary()}


def _rows_of(rows: Collector, data: NonlinearData, fit: NonlinearFit, condition: Condition,
             *, amps: Sequence[float], analysis: str) -> None:
    """The forces at *amps*, the exponent and the prefactor of *fit*."""
    n = len(fit.subjects)
    _, cov, ok = subject_fits(data, fit.modes)
    own = cov[ok]
    for amp in amps:
        c = np.array([1.0, math.log(amp) - fit.log_u0])
        e = fit.estimate(c)
        lo, hi = e.interval()
        rows.add("electrostatic_force_N", condition, amp,
                 (exp_or_nan(e.value), exp_or_nan(lo), exp_or_nan(hi)),
                 between_sd=fit.between_sd_of(c), n=n, method=fit.method + ", of F_el",
                 analysis=analysis, extra=_extra(fit, c, own, log_scale=True))
    c = np.array([0.0, 1.0])
    e = fit.estimate(c)
    rows.add("exponent", condition, math.nan, (e.value, *e.interval()),
             between_sd=fit.between_sd_of(c), n=n, method=fit.method, analysis=analysis,
             extra=_extra(fit, c, own, log_scale=False))
    c = np.array([1.0, -fit.log_u0])
    e = fit.estimate(c)
    lo, hi = e.interval()
    rows.add("prefactor_N", condition, math.nan, (exp_or_nan(e.value), exp_or_nan(lo),
                                                  exp_or_nan(hi)),
             between_sd=fit.between_sd_of(c), n=n, method=fit.method + ", at 1 V, of log k",
             analysis=analysis, extra=_extra(fit, c, own, log_scale=True))


def _far(rows: Collector, data: NonlinearData, fit: NonlinearFit, label: str) -> list[str]:
    """The subjects whose own power law (level at the centre, or exponent) lies outside the
    others' prediction interval; named, never left out."""
    own, cov, ok = subject_fits(data, fit.modes)
    names = [s for s, good in zip(data.subjects, ok, strict=True) if good]
    far: list[str] = []
    for j, what, unit in ((0, f"F_el of its power law at {math.exp(data.log_u0):.3g} V, "
                              f"{label}", "N"), (1, f"exponent, {label}", None)):
        found = find_outliers(own[ok, j], cov[ok, j, j], names, alpha=rows.alpha)
        rows.flag(what, found, unit)
        far += [o.subject for o in found if o.subject not in far]
    return far


def _meta(rows: Collector, subjects: Sequence[SubjectData], condition: Condition,
          amps: Sequence[float]) -> None:
    """The meta-analysis rows of log F_el, at the amplitudes where they are valid."""
    label = condition_label(*condition)
    for amp in amps:
        y, v, names, valid = [], [], [], True
        for s in subjects:
            idx = s.select_linear(condition)
            hit = idx[np.isclose(s.linear["amplitude_V"].to_numpy(float)[idx], amp)]
            if not hit.size:
                continue
            cell = s.linear.iloc[hit[0]]
            f, lo, hi = (float(cell["force_N"]), float(cell["ci_low_N"]),
                         float(cell["ci_high_N"]))
            se = (math.log(hi) - math.log(lo)) / (2 * 1.959964) if lo > 0 else math.inf
            valid &= lo > 0 and se <= META_MAX_LOG_SE
            names.append(s.name)
            y.append(math.log(f) if f > 0 else math.nan)
            v.append(se * se)
        if not valid or len(names) < MIN_SUBJECTS:
            continue
        got = rows.pooled(f"F_el at {amp:g} V, {label}", names, np.array(y), np.array(v),
                          "N", check=False)
        if got is not None:
            rows.add_pooled("electrostatic_force_N", condition, amp, got[0],
                            method=f"{POOL_METHOD}, of log F_el", analysis=META, log=True)


def condition_estimates(rows: Collector, subjects: Sequence[SubjectData],
                        condition: Condition) -> None:
    """Every row of *condition*: the mixed model's (primary), without each subject far from
    the others, and the meta-analysis's where valid.

    Parameters
    ----------
    rows : Collector
        Where the rows, notes, subjects far from the others and lines go.
    subjects : sequence of SubjectData
        Every subject of the study (but those excluded beforehand).
    condition : (str, float)
        The waveform and drive frequency, Hz.

    Returns
    -------
    None
    """
    label = condition_label(*condition)
    data = _data(subjects, condition)
    amps = sorted({float(a) for s in subjects
                   for a in s.linear["amplitude_V"].to_numpy(float)[s.select_linear(condition)]})
    if data is None or data.k < MIN_SUBJECTS:
        rows.notes.append(f"{label}: {0 if data is None else data.k} subject(s) with "
                          f"electrostatic forces; a population estimate needs at least "
                          f"{MIN_SUBJECTS}")
        return
    if len(amps) < 2:
        rows.notes.append(f"{label}: one amplitude only, no power law; the force there from "
                          "the meta-analysis of log F_el where it is valid")
        _meta(rows, subjects, condition, amps)
        return
    fit = _fit(data, rows, label)
    if fit is None:
        _meta(rows, subjects, condition, amps)
        return
    if not fit.convergence.ok:
        rows.notes.append(f"{label}: the mixed model's checks failed: "
                          f"{fit.convergence.summary()}; read its rows with care")
    if fit.convergence.singular:
        rows.notes.append(f"{label}: {fit.convergence.singular}")
    rows.lines[condition] = fit
    rows.subject_lines[condition] = {s: (float(b[0]), float(b[1]))
                                     for s, b in zip(fit.subjects, fit.modes, strict=True)}
    _rows_of(rows, data, fit, condition, amps=amps, analysis=PRIMARY)
    far = _far(rows, data, fit, label)
    rows.far[condition] = set(far)
    for name in far:
        rest = data.without(name)
        if rest.k < MIN_SUBJECTS:
            continue
        other = _fit(rest, rows, f"{label} without {name}")
        if other is not None:
            _rows_of(rows, rest, other, condition, amps=amps, analysis=f"without {name}")
    _meta(rows, subjects, condition, amps)
