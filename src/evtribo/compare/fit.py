"""Fitting the seed paper's model to per-subject results by weighted least squares.

For each subject the free parameters (the equivalent air gap ``h_L`` by default) are chosen so
that the model's electrostatic force (eq. 11) at each measured point (mean normal force ON,
voltage amplitude) matches the inferred electrostatic force of ``electrostatic.csv``. Each
point is weighted by its standard error, taken from the width of its 95 % interval
(``(ci_high - ci_low) / (2 * 1.96)``).

The friction coefficient does not enter eq. 11, so when ``mu`` is fitted the friction forces
of the subject's steady-sliding windows (``windows.csv``, eq. 5 with U = 0 OFF and the
amplitude ON) are added to the residuals; their weight is the RMS misfit of a first pass
(one step of iterative reweighting), since windows carry no interval of their own.

Uncertainties. Points sharing an OFF reference share its error in ``mu`` (every force moves
by about ``-F_n dmu/mu``), so they are not independent and an interval that treats them so
is too narrow (Monte Carlo through the real estimator, one shared reference: 85 % coverage
of h_L's 95 % interval). When the result folder has ``electrostatic_bootstrap.csv``
(bootstrap replicates of the forces, one resampling of a subject's windows per replicate,
so with their true correlation) the free parameters are refitted to each of the first
:data:`N_REFITS` replicates (Gauss-Newton from the solution, same weights) and the
interval is the replicates' 2.5-97.5 % percentiles: this propagates the correlated errors
through the nonlinear model without assuming a covariance form. Otherwise (no file, ``mu``
fitted with the windows, which have no replicates, or a parameter undetermined) they come
from the Jacobian at the solution (``cov = (J^T J)^-1``, as in
``scipy.optimize.curve_fit``), which takes each point's interval as an independent error;
``SubjectFit.interval_method`` and ``fit.json`` say which was used. Either way, when the
model misfits by more than the weights allow (reduced chi-square > 1) the spread is
inflated by the reduced chi-square and the interval uses Student's t, never shrunk. A
parameter the data cannot determine (a zero singular value, e.g. ``h_L`` and ``E_star``
together, which enter eq. 11 almost only through the same combination) gets an infinite
interval and a warning.

Sine-wave points are compared with the model averaged over one period of U(t) = A sin(wt),
square-wave points with the model at U = A (U^2 is constant for a square wave).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy import optimize, stats

from evtribo.compare.intervals import covariance, refit_replicates
from evtribo.compare.model_points import (
    mean_electrostatic_force,
    mean_friction_force,
    model_exponent,
)
from evtribo.compare.params import DEFAULT_FIT, parameter_unit
from evtribo.compare.tables import MIN_REPLICATES, ResultTables, replicate_matrix
from evtribo.errors import AnalysisError
from evtribo.model.params import TABLE_1, ModelParameters

log = logging.getLogger(__name__)

__all__ = ["N_REFITS", "ParameterEstimate", "SubjectFit", "fit_study", "fit_subject",
           "mean_electrostatic_force", "mean_friction_force", "model_exponent"]

_Z95 = float(stats.norm.ppf(0.975))
#: Bootstrap replicates refitted per subject (the first ones of electrostatic_bootstrap.csv).
N_REFITS = 200
#: Replicates per call of a Dask worker when the refits run on a cluster.
REFIT_CHUNK = 25
#: Fewest converged refits for a bootstrap interval (else the Jacobian's).
MIN_REFITS = MIN_REPLICATES


@dataclass(frozen=True)
class ParameterEstimate:
    """One fitted parameter: value, standard error and 95 % interval, SI units."""

    name: str
    value: float
    stderr: float
    ci_low: float
    ci_high: float
    unit: str

    def contains(self, value: float) -> bool:
        """Whether *value* lies inside the 95 % interval."""
        return self.ci_low <= value <= self.ci_high


@dataclass(frozen=True)
class SubjectFit:
    """The fit for one subject.

    Attributes
    ----------
    subject : str
    params : ModelParameters
        Fixed parameters with the fitted ones replaced (``mu`` is the measured one unless
        fitted).
    estimates : tuple of ParameterEstimate
    correlation : ndarray
        Correlation matrix of the fitted parameters (NaN where undetermined).
    rmse_N : float
        Root-mean-square misfit of the electrostatic force, N.
    r2 : float
        Coefficient of determination of the electrostatic force.
    chi2_reduced : float
        Weighted sum of squares per degree of freedom (NaN without a free degree).
    n_points : int
        Electrostatic points fitted.
    mu_measured : float
        Friction coefficient from the OFF windows (``electrostatic.csv``'s ``mu``).
    interval_method : str
        ``"bootstrap"`` (refits to the force replicates) or ``"jacobian"``.
    n_replicates : int
        Replicates refitted (0 for the Jacobian).
    interval_note : str
        Why the Jacobian was used although replicates were given ("" otherwise).
    """

    subject: str
    params: ModelParameters
    estimates: tuple[ParameterEstimate, ...]
    correlation: NDArray[np.float64]
    rmse_N: float
    r2: float
    chi2_reduced: float
    n_points: int
    mu_measured: float
    interval_method: str = "jacobian"
    n_replicates: int = 0
    interval_note: str = ""

    def __getitem__(self, name: str) -> ParameterEstimate:
        for e in self.estimates:
            if e.name == name:
                return e
        raise KeyError(name)


def _sigmas(rows: pd.DataFrame, subject: str) -> NDArray[np.float64]:
    width = (rows["electrostatic_force_ci_high_N"].to_numpy(float)
             - rows["electrostatic_force_ci_low_N"].to_numpy(float))
    sigma = width / (2.0 * _Z95)
    ok = np.isfinite(sigma) & (sigma > 0)
    if not ok.all():
        if ok.any():
            fill = float(np.median(sigma[ok]))
            log.warning("subject %s: %d point(s) without a usable interval; weighted like "
                        "the median point (%.3g N)", subject, int((~ok).sum()), fill)
        else:
            fill = 1.0
            log.warning("subject %s: no usable intervals in electrostatic.csv; fitting "
                        "unweighted, uncertainty from the scatter", subject)
        sigma = np.where(ok, sigma, fill)
    return sigma


@dataclass(frozen=True)
class _Points:
    """A subject's usable electrostatic points and the windows fitted with them."""

    fn: NDArray[np.float64]
    amp: NDArray[np.float64]
    wave: NDArray[np.object_]
    measured: NDArray[np.float64]
    sigma: NDArray[np.float64]
    good: NDArray[np.bool_]
    mu_measured: float
    w_fn: NDArray[np.float64]
    w_ft: NDArray[np.float64]
    w_amp: NDArray[np.float64]
    w_wave: NDArray[np.object_]


def _points(subject: str, rows: pd.DataFrame,
            windows: pd.DataFrame | None, use_windows: bool) -> _Points:
    """The rows' finite points with their weights, and the windows when *use_windows*."""
    fn = rows["normal_force_on_N"].to_numpy(float)
    amp = rows["amplitude_V"].to_numpy(float)
    wave = rows["waveform"].astype(str).to_numpy(object)
    measured = rows["electrostatic_force_N"].to_numpy(float)
    good = np.isfinite(fn) & np.isfinite(amp) & np.isfinite(measured) & (fn > 0)
    if not good.all():
        log.warning("subject %s: %d point(s) with missing values left out", subject,
                    int((~good).sum()))
    mus = rows["mu"].to_numpy(float)
    mu_measured = float(np.nanmean(mus)) if np.isfinite(mus).any() else math.nan
    empty = np.empty(0)
    w_fn, w_ft, w_amp, w_wave = empty, empty, empty, np.empty(0, object)
    if use_windows:
        if windows is None or windows.empty:
            raise AnalysisError(f"subject {subject}: fitting mu needs its windows "
                                "(windows.csv has none)")
        w_fn = windows["normal_force_N"].to_numpy(float)
        w_ft = windows["friction_force_N"].to_numpy(float)
        w_on = windows["condition"].astype(str).str.lower().to_numpy() == "on"
        w_amp = np.where(w_on, windows["amplitude_V"].to_numpy(float), 0.0)
        w_wave = windows["waveform"].astype(str).to_numpy(object)
        keep = np.isfinite(w_fn) & np.isfinite(w_ft) & np.isfinite(w_amp) & (w_fn > 0)
        w_fn, w_ft, w_amp, w_wave = w_fn[keep], w_ft[keep], w_amp[keep], w_wave[keep]
    return _Points(fn[good], amp[good], wave[good], measured[good],
                   _sigmas(rows[good], subject), good, mu_measured,
                   w_fn, w_ft, w_amp, w_wave)


class _Problem:
    """The least-squares problem of one subject, in parameters scaled by their start."""

    def __init__(self, subject: str, names: tuple[str, ...], base: ModelParameters,
                 pts: _Points, use_windows: bool) -> None:
        self.subject, self.names, self.base, self.pts = subject, names, base, pts
        self.use_windows = use_windows
        self.n_res = len(pts.measured) + (len(pts.w_fn) if use_windows else 0)
        if self.n_res < len(names) or len(pts.measured) == 0:
            raise AnalysisError(f"subject {subject}: {len(pts.measured)} usable point(s) "
                                f"for {len(names)} parameter(s) ({', '.join(names)})")
        start = np.array([getattr(base, n) for n in names], dtype=float)
        self.start = np.where(start > 0, start,
                              [getattr(TABLE_1, n) or 1e-6 for n in names])
        self.lower = np.array([0.0 if n.startswith("h_") else 1e-6 for n in names])
        self.w_sigma = 1.0

    def params_at(self, x: NDArray[np.float64]) -> ModelParameters:
        """The model's parameters at the scaled values *x*."""
        return self.base.with_values(dict(zip(self.names, (self.start * x).tolist(),
                                              strict=True)))

    def model_at(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The model's electrostatic force at the points, N."""
        p = self.pts
        return mean_electrostatic_force(p.fn, p.amp, p.wave, self.params_at(x))

    def residuals(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Weighted residuals of the points (and of the windows when they are fitted)."""
        p, params = self.pts, self.params_at(x)
        r = (p.measured - mean_electrostatic_force(p.fn, p.amp, p.wave, params)) / p.sigma
        if self.use_windows:
            rw = (p.w_ft - mean_friction_force(p.w_fn, p.w_amp, p.w_wave, params)) \
                / self.w_sigma
            r = np.concatenate([r, rw])
        return np.nan_to_num(r, nan=1e6, posinf=1e6, neginf=-1e6)

    def _least_squares(self, x0: NDArray[np.float64]) -> optimize.OptimizeResult:
        res = optimize.least_squares(self.residuals, x0, jac="3-point",
                                     bounds=(self.lower, np.inf), method="trf",
                                     x_scale=1.0, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                     max_nfev=2000)
        if not res.success:
            raise AnalysisError(f"subject {self.subject}: the fit did not converge: "
                                f"{res.message}")
        return res

    def solve(self) -> optimize.OptimizeResult:
        """The solution; with windows, weighted by their own misfit and solved once more."""
        res = self._least_squares(np.ones(len(self.names)))
        if self.use_windows:
            rw = res.fun[len(self.pts.measured):] * self.w_sigma
            self.w_sigma = max(float(np.sqrt(np.mean(rw**2))), 1e-9)
            res = self._least_squares(res.x)
        return res


def _refit_chunk(targets: NDArray[np.float64], problem: _Problem,
                 x0: NDArray[np.float64]) -> NDArray[np.float64]:
    """The converged refits of some replicates (one call of a Dask worker)."""
    return refit_replicates(problem.model_at, x0, targets, problem.pts.sigma, problem.lower)


def _refits(problem: _Problem, x0: NDArray[np.float64], targets: NDArray[np.float64],
            scheduler: Any) -> NDArray[np.float64]:
    """The converged refits, here or in chunks of :data:`REFIT_CHUNK` on a Dask cluster
    (each replicate's refit is its own, so the chunks give the same refits in order)."""
    if scheduler is None or len(targets) == 0:
        return _refit_chunk(targets, problem, x0)
    from evtribo.analysis.distributed import map_unordered

    chunks = [targets[i:i + REFIT_CHUNK] for i in range(0, len(targets), REFIT_CHUNK)]
    done = dict(map_unordered(scheduler, _refit_chunk, chunks, problem, x0,
                              name=lambda _: f"subject {problem.subject}'s refits"))
    return np.concatenate([done[i] for i in range(len(chunks))])


def _bootstrap(problem: _Problem, res: optimize.OptimizeResult, cov_x: NDArray[np.float64],
               replicates: ArrayLike, *, n_rows: int, stretch: float,
               scheduler: Any = None) -> tuple[NDArray[np.float64] | None, str]:
    """The parameters refitted to the replicates (scaled back, stretched like the
    Jacobian's spread when the model misfits), or None and why the Jacobian is used."""
    subject, pts = problem.subject, problem.pts
    reps = np.asarray(replicates, dtype=float)
    if reps.ndim != 2 or reps.shape[1] != n_rows:
        raise ValueError(f"subject {subject}: replicates need one column per row")
    boot, note = None, ""
    if problem.use_windows:
        note = "mu is fitted with the windows, which have no bootstrap replicates"
    elif not np.all(np.isfinite(cov_x)):
        note = "a parameter is not determined by the data"
    else:
        refits = _refits(problem, res.x, reps[:, pts.good], scheduler)
        if refits.shape[0] >= MIN_REFITS:
            values = problem.start * res.x
            boot = values + stretch * (problem.start * refits - values)
        else:
            note = f"only {refits.shape[0]} of {reps.shape[0]} refits converged"
    if note:
        log.log(logging.WARNING if note.startswith("only") else logging.INFO,
                "subject %s: intervals from the Jacobian (points taken as "
                "independent): %s", subject, note)
    return boot, note


def _estimates(problem: _Problem, values: NDArray[np.float64], cov: NDArray[np.float64],
               boot: NDArray[np.float64] | None,
               quantile: float) -> list[ParameterEstimate]:
    """Each parameter's value, standard error and 95 % interval (the replicates'
    percentiles, else the value plus or minus *quantile* standard errors)."""
    floor = problem.start * problem.lower
    if boot is not None:
        q_lo, q_hi = np.quantile(boot, [0.025, 0.975], axis=0)
    estimates = []
    for i, name in enumerate(problem.names):
        se = float(np.sqrt(cov[i, i])) if np.isfinite(cov[i, i]) else math.inf
        if boot is not None:
            lo, hi = max(float(q_lo[i]), floor[i]), float(q_hi[i])
        else:
            lo = max(values[i] - quantile * se, floor[i]) if math.isfinite(se) \
                else -math.inf
            hi = values[i] + quantile * se
        if not math.isfinite(se):
            log.warning("subject %s: %s is not determined by these data (its effect cannot "
                        "be told apart from the other fitted parameters'); interval is "
                        "infinite", problem.subject, name)
        estimates.append(ParameterEstimate(name, float(values[i]), se, float(lo), float(hi),
                                           parameter_unit(name)))
    return estimates


def _correlation(subject: str, names: Sequence[str],
                 cov: NDArray[np.float64]) -> NDArray[np.float64]:
    """The correlation matrix of *cov*, with a warning for each pair beyond 0.99."""
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.sqrt(np.diag(cov))
        corr = cov / np.outer(d, d)
    n = len(names)
    for i in range(n):
        for j in range(i + 1, n):
            if np.isfinite(corr[i, j]) and abs(corr[i, j]) > 0.99:
                log.warning("subject %s: %s and %s are strongly correlated (r = %.3f): the "
                            "data hardly tell them apart", subject, names[i], names[j],
                            corr[i, j])
    return np.asarray(corr, float)


def fit_subject(subject: str, rows: pd.DataFrame, base: ModelParameters = TABLE_1,
                fit: Sequence[str] = DEFAULT_FIT,
                windows: pd.DataFrame | None = None, *,
                replicates: ArrayLike | None = None, scheduler: Any = None) -> SubjectFit:
    """Fit the model's parameters *fit* to one subject's electrostatic results.

    Parameters
    ----------
    subject : str
        The subject's name (for messages).
    rows : DataFrame
        The subject's rows of ``electrostatic.csv``.
    base : ModelParameters
        Starting values and the fixed parameters.
    fit : sequence of str
        Names of the parameters to fit (validated by
        :func:`evtribo.compare.params.resolve_fit_names`).
    windows : DataFrame, optional
        The subject's rows of ``windows.csv``; needed when ``mu`` is fitted.
    replicates : array_like, shape (n_replicates, len(rows)), optional
        Bootstrap replicates of the rows' electrostatic forces, N
        (:func:`evtribo.compare.tables.replicate_matrix`); the intervals then come from
        refits to them.
    scheduler : distributed.Client, optional
        A Dask cluster to run the refits on (:mod:`evtribo.analysis.distributed`).

    Returns
    -------
    SubjectFit
        The estimates, their correlation and the quality of the fit.

    Raises
    ------
    AnalysisError
        When there are fewer points than parameters or the optimiser fails.
    """
    names = tuple(fit)
    rows = rows.reset_index(drop=True)
    use_windows = "mu" in names
    pts = _points(subject, rows, windows, use_windows)
    if not use_windows and pts.mu_measured > 0:
        base = base.with_values(mu=pts.mu_measured)
    problem = _Problem(subject, names, base, pts, use_windows)
    res = problem.solve()

    dof = problem.n_res - len(names)
    chi2_red = float(np.sum(res.fun**2)) / dof if dof > 0 else math.nan
    cov_x = covariance(res.jac, res.x)
    scale = max(1.0, chi2_red) if math.isfinite(chi2_red) else 1.0
    quantile = float(stats.t.ppf(0.975, dof)) if scale > 1.0 else _Z95
    cov = cov_x * scale * np.outer(problem.start, problem.start)
    values = problem.start * res.x
    boot, note = None, ""
    if replicates is not None:
        # replicate spread, inflated like the Jacobian's when the model misfits
        boot, note = _bootstrap(problem, res, cov_x, replicates, n_rows=len(rows),
                                stretch=math.sqrt(scale) * quantile / _Z95,
                                scheduler=scheduler)
    if boot is not None:
        cov = np.atleast_2d(np.cov(boot, rowvar=False))
    estimates = _estimates(problem, values, cov, boot, quantile)
    corr = _correlation(subject, names, cov)
    fitted = problem.params_at(res.x)
    resid = pts.measured - mean_electrostatic_force(pts.fn, pts.amp, pts.wave, fitted)
    ss_tot = float(np.sum((pts.measured - pts.measured.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else math.nan
    log.info("subject %s: %s (chi2_red %.3g, %d points)", subject,
             ", ".join(f"{e.name} = {e.value:.4g} {e.unit}" for e in estimates), chi2_red,
             len(pts.measured))
    return SubjectFit(subject=subject, params=fitted, estimates=tuple(estimates),
                      correlation=corr, rmse_N=float(np.sqrt(np.mean(resid**2))), r2=r2,
                      chi2_reduced=chi2_red, n_points=len(pts.measured),
                      mu_measured=pts.mu_measured,
                      interval_method="jacobian" if boot is None else "bootstrap",
                      n_replicates=0 if boot is None else int(boot.shape[0]),
                      interval_note=note)


def fit_study(tables: ResultTables, base: ModelParameters = TABLE_1,
              fit: Sequence[str] = DEFAULT_FIT, *, scheduler: Any = None) -> list[SubjectFit]:
    """Fit every subject of a result folder (see :func:`fit_subject`).

    The intervals come from refits to ``electrostatic_bootstrap.csv``'s replicates when the
    folder has them for all of a subject's points, else from the Jacobian.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables (:func:`evtribo.compare.tables.read_results`).
    base : ModelParameters
        Starting values and the fixed parameters.
    fit : sequence of str
        Names of the parameters to fit per subject.
    scheduler : distributed.Client, optional
        A Dask cluster to run the bootstrap refits on (the same results as here).

    Returns
    -------
    list of SubjectFit
        One per subject, in the order of ``electrostatic.csv``.
    """
    fits = []
    boot = tables.bootstrap
    for subject in tables.subjects:
        rows = tables.electrostatic[tables.electrostatic["subject"] == subject]
        win = tables.windows[tables.windows["subject"] == subject]
        reps = None
        if boot is not None:
            reps = replicate_matrix(rows, boot[boot["subject"].astype(str) == str(subject)],
                                    max_replicates=N_REFITS)
            if reps is None:
                log.warning("subject %s: electrostatic_bootstrap.csv lacks replicates of "
                            "some of its points; intervals from the Jacobian", subject)
        fits.append(fit_subject(subject, rows, base, fit, win, replicates=reps,
                                scheduler=scheduler))
    return fits
