"""``[population] model = "mixed"`` (the default): the nonlinear mixed model of the power law
across subjects on the linear scale (:mod:`evtribo.population.nonlinear`,
:mod:`evtribo.population.nonlinear_fit`), every subject's cells in, negative ones included.

Its rows: the population's F_el at each amplitude measured (its power law there: the
geometric mean over subjects), the exponent and the prefactor (F_el at 1 V), each with its
prediction interval for a new subject, the between-subject SD with its interval and I^2, and
the convergence checks (:mod:`evtribo.population.convergence`). Random exponents where at
least three subjects have three amplitudes or more (else, or when that fit fails, random
levels only). A subject whose own power law (level at the centre, or exponent) lies outside
the others' prediction interval is named (:func:`~evtribo.population.stats.find_outliers`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from evtribo.population.data import ModelRow, drive_scope, exp_or_nan
from evtribo.population.models.interface import DriveCells, FarSubjects, ModelFit
from evtribo.population.nonlinear import NonlinearData, subject_fits
from evtribo.population.nonlinear_fit import NonlinearFit, fit_nonlinear
from evtribo.population.stats import MIN_SUBJECTS, find_outliers, i_squared, typical_variance
from evtribo.warning.collect import emitter

__all__ = ["MixedModel"]

emit = emitter(__name__)


def _fit(cells: DriveCells, notes: list[Any]) -> NonlinearFit | None:
    """The mixed model, with random exponents where at least three subjects have three
    amplitudes or more (else, or when that fit fails, random levels only)."""
    data = cells.data
    rich = int(np.sum([np.unique(np.round(data.x[i, :n], 9)).size >= 3
                       for i, n in enumerate(data.n_cells)]))
    for slopes in ((True, False) if rich >= MIN_SUBJECTS else (False,)):
        try:
            return fit_nonlinear(data, random_slopes=slopes)
        except np.linalg.LinAlgError as err:
            notes.append(emit.record("population-model-failed", drive_scope(cells.condition),
                                     drive=cells.label,
                                     effects="exponents" if slopes else "levels",
                                     error=str(err)))
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


def _rows_of(data: NonlinearData, fit: NonlinearFit, amps: Sequence[float]) -> list[ModelRow]:
    """The forces at *amps*, the exponent and the prefactor of *fit*."""
    n = len(fit.subjects)
    _, cov, ok = subject_fits(data, fit.modes)
    own = cov[ok]
    rows = []
    for amp in amps:
        c = np.array([1.0, math.log(amp) - fit.log_u0])
        e = fit.estimate(c)
        lo, hi = e.interval()
        rows.append(ModelRow("electrostatic_force_N", amp,
                             (exp_or_nan(e.value), exp_or_nan(lo), exp_or_nan(hi)),
                             fit.between_sd_of(c), n, fit.method + ", of F_el",
                             _extra(fit, c, own, log_scale=True)))
    c = np.array([0.0, 1.0])
    e = fit.estimate(c)
    rows.append(ModelRow("exponent", math.nan, (e.value, *e.interval()),
                         fit.between_sd_of(c), n, fit.method,
                         _extra(fit, c, own, log_scale=False)))
    c = np.array([1.0, -fit.log_u0])
    e = fit.estimate(c)
    lo, hi = e.interval()
    rows.append(ModelRow("prefactor_N", math.nan,
                         (exp_or_nan(e.value), exp_or_nan(lo), exp_or_nan(hi)),
                         fit.between_sd_of(c), n, fit.method + ", at 1 V, of log k",
                         _extra(fit, c, own, log_scale=True)))
    return rows


class MixedModel:
    """The nonlinear mixed model of the power law across subjects."""

    name = "mixed"
    min_amplitudes = 2

    def fit(self, cells: DriveCells, notes: list[Any]) -> ModelFit | None:
        """The mixed model of one drive's cells, checked.

        Parameters
        ----------
        cells : DriveCells
        notes : list
            Where a fit that cannot be made is said (a record, made and not said).

        Returns
        -------
        ModelFit or None
            Its notes say the checks that failed (records, made and not said); None when
            no fit could be made.
        """
        fit = _fit(cells, notes)
        if fit is None:
            return None
        said: list[Any] = []
        scope = drive_scope(cells.condition)
        if not fit.convergence.ok:
            said.append(emit.record("population-checks-failed", scope, drive=cells.label,
                                    checks=fit.convergence.summary()))
        if fit.convergence.singular:
            said.append(emit.record("population-singular", scope, drive=cells.label,
                                    singular=fit.convergence.singular))
        return ModelFit(_rows_of(cells.data, fit, cells.amplitudes), said, fit,
                        {s: (float(b[0]), float(b[1]))
                         for s, b in zip(fit.subjects, fit.modes, strict=True)})

    def far(self, fit: ModelFit, cells: DriveCells, alpha: float) -> list[FarSubjects]:
        """The subjects whose own power law (level at the centre, or exponent) lies outside
        the others' prediction interval.

        Parameters
        ----------
        fit : ModelFit
        cells : DriveCells
        alpha : float

        Returns
        -------
        list of FarSubjects
        """
        line = fit.line
        if line is None:
            return []
        data = cells.data
        own, cov, ok = subject_fits(data, line.modes)
        names = [s for s, good in zip(data.subjects, ok, strict=True) if good]
        return [FarSubjects(what, find_outliers(own[ok, j], cov[ok, j, j], names, alpha=alpha),
                            unit)
                for j, what, unit in ((0, f"F_el of its power law at {math.exp(data.log_u0):.3g}"
                                          f" V, {cells.label}", "N"),
                                      (1, f"exponent, {cells.label}", None))]
