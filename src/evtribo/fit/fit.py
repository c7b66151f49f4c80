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
together, which enter eq. 11 almost only through the same combination) gets an interval
open above and a warning. A subject whose forces do not differ from zero (every point
within its error of it: the fit runs to where the model gives no force) has no value, only
the interval of the values its points exclude (:mod:`evtribo.fit.estimates`).

Sine-wave points are compared with the model averaged over one period of U(t) = A sin(wt),
square-wave points with the model at U = A (U^2 is constant for a square wave).

The drive's frequency. With finite resistances of the layers (``r_sc``, ``r_g``, fixed or
fitted) each point is evaluated at its own drive frequency: A becomes the effective
amplitude the gap sees (:mod:`evtribo.model.circuit`), and a window (``mu`` fitted) takes
its trial's frequency from ``trials.csv``. The resistances are fitted in log space
(:mod:`evtribo.fit.problem`), and their intervals come from the likelihood profile
(the sum of squares with the resistance held, the others refitted, reaching the minimum
plus the quantile squared): an end the data cannot exclude is open (0 or infinity), as for
a gap that does not leak. With bootstrap replicates (matched to the rows by waveform,
frequency and amplitude) the interval is their percentiles, still open where the profile
says so.
"""

from __future__ import annotations

import logging
import math
import traceback
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import optimize, special

from evtribo.fit.estimates import (
    ParameterEstimate,
    parameter_estimates,
    profile_intervals,
    sees_no_force,
)
from evtribo.fit.intervals import covariance, refit_replicates
from evtribo.fit.model_points import mean_electrostatic_force, mean_friction_force, model_exponent
from evtribo.fit.params import DEFAULT_FIT
from evtribo.fit.problem import LOG_PARAMETERS, Points, Problem, with_friction_law
from evtribo.fit.tables import MIN_REPLICATES, ResultTables, replicate_matrix
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.store.pool import Mapper
from evtribo.warning.collect import collected, emitter, replay
from evtribo.warning.record import Scope, WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["N_REFITS", "ParameterEstimate", "SubjectFit", "fit_study", "fit_subject",
           "interval_notes", "mean_electrostatic_force", "mean_friction_force",
           "model_exponent"]

_Z95 = float(special.ndtri(0.975))
#: Bootstrap replicates refitted per subject (the first ones of electrostatic_bootstrap.csv).
N_REFITS = 200
#: Replicates per call of a Dask worker when the refits run on a cluster.
REFIT_CHUNK = 25
#: Fewest converged refits for a bootstrap interval (else the Jacobian's).
MIN_REFITS = MIN_REPLICATES


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
        ``"bootstrap"`` (refits to the force replicates), ``"jacobian"``, or ``"profile"``
        (forces that do not differ from zero: no value, the interval the profile's).
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


def _refit_chunk(targets: NDArray[np.float64], problem: Problem,
                 x0: NDArray[np.float64]) -> NDArray[np.float64]:
    """The converged refits of some replicates (one call of a Dask worker)."""
    return refit_replicates(problem.model_at, x0, targets, problem.pts.sigma, problem.lower,
                            upper=problem.upper,
                            many=problem.model_many if problem.side_by_side else None)


def _refits(problem: Problem, x0: NDArray[np.float64], targets: NDArray[np.float64],
            scheduler: Any) -> NDArray[np.float64]:
    """The converged refits, here or in chunks of :data:`REFIT_CHUNK` on a Dask cluster
    (each replicate's refit is its own, so the chunks give the same refits in order)."""
    if scheduler is None or len(targets) == 0:
        return _refit_chunk(targets, problem, x0)
    from evtribo.results.distributed import map_unordered

    chunks = [targets[i:i + REFIT_CHUNK] for i in range(0, len(targets), REFIT_CHUNK)]
    done = dict(map_unordered(scheduler, _refit_chunk, chunks, problem, x0,
                              name=lambda _: f"subject {problem.subject}'s refits"))
    return np.concatenate([done[i] for i in range(len(chunks))])


def _bootstrap(problem: Problem, res: optimize.OptimizeResult, cov_x: NDArray[np.float64],
               replicates: ArrayLike, *, n_rows: int, stretch: float,
               scheduler: Any = None) -> tuple[NDArray[np.float64] | None, str]:
    """The scaled parameters refitted to the replicates (stretched like the Jacobian's
    spread when the model misfits), or None and why the Jacobian is used."""
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
            with np.errstate(invalid="ignore", over="ignore"):  # an infinite refit stays so
                boot = res.x + stretch * (np.minimum(refits, problem.upper) - res.x)
        else:
            note = f"only {refits.shape[0]} of {reps.shape[0]} refits converged"
    if note:
        log.log(logging.WARNING if note.startswith("only") else logging.INFO,
                "subject %s: intervals from the Jacobian (points taken as "
                "independent): %s", subject, note)
    return boot, note


def _intervals(problem: Problem, res: optimize.OptimizeResult, chi2_red: float,
               replicates: ArrayLike | None, *, n_rows: int, scheduler: Any
               ) -> tuple[list[ParameterEstimate], NDArray[np.float64],
                          NDArray[np.float64] | None, str, str]:
    """The estimates, the covariance their correlation is read from, the refits (None:
    the Jacobian's or the profile's intervals), why the replicates were not used and the
    intervals' method (SubjectFit's ``interval_method``)."""
    dof = problem.n_res - len(problem.names)
    cov_x = covariance(res.jac, problem.magnitudes(res.x))
    scale = max(1.0, chi2_red) if math.isfinite(chi2_red) else 1.0
    quantile = float(special.stdtrit(dof, 0.975)) if scale > 1.0 else _Z95
    cov_x = cov_x * scale
    absent = [i for i, n in enumerate(problem.names) if n != "mu"] \
        if sees_no_force(problem, res.x) else []
    boot, note = None, ""
    if absent:
        note = (f"{', '.join(problem.names[i] for i in absent)} is not determined by these "
                "data: its forces do not differ from zero (every point within its error of "
                "it); no value, the interval holds the values whose forces the points would "
                "have seen excluded (profile)")
        emit("forces-zero", subject=problem.subject,
             parameters=", ".join(problem.names[i] for i in absent))
    elif replicates is not None:
        # replicate spread, inflated like the Jacobian's when the model misfits
        boot, note = _bootstrap(problem, res, cov_x, replicates, n_rows=n_rows,
                                stretch=math.sqrt(scale) * quantile / _Z95,
                                scheduler=scheduler)
    with np.errstate(invalid="ignore", over="ignore"):  # an infinite refit: no correlation
        cov_corr = cov_x if boot is None else np.atleast_2d(np.cov(boot, rowvar=False))
    which = sorted({*np.flatnonzero(problem.is_log).tolist(), *absent})
    profile = profile_intervals(problem, res.x, float(np.sum(res.fun**2)),
                                scale * quantile**2, which)
    estimates = parameter_estimates(problem, res.x, cov_x if boot is None else cov_corr,
                                    boot, quantile, profile=profile, absent=absent)
    method = "profile" if absent else "jacobian" if boot is None else "bootstrap"
    return estimates, cov_corr, boot, note, method


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
                emit("parameters-correlated", subject=subject, first=names[i],
                     second=names[j], r=float(corr[i, j]))
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
        :func:`evtribo.fit.params.resolve_fit_names`).
    windows : DataFrame, optional
        The subject's rows of ``windows.csv``; needed when ``mu`` is fitted.
    replicates : array_like, shape (n_replicates, len(rows)), optional
        Bootstrap replicates of the rows' electrostatic forces, N
        (:func:`evtribo.fit.tables.replicate_matrix`); the intervals then come from
        refits to them.
    scheduler : distributed.Client, optional
        A Dask cluster for the bootstrap refits (the same refits as here).

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
    need_f = (any(n in LOG_PARAMETERS for n in names)
              or not (math.isinf(base.r_sc) and math.isinf(base.r_g)))
    pts = Points.of(subject, rows, windows, use_windows=use_windows, need_frequency=need_f)
    if not use_windows and pts.mu_measured > 0:
        base = base.with_values(mu=pts.mu_measured)
    base = with_friction_law(base, rows)
    problem = Problem(subject, names, base, pts, use_windows)
    res = problem.solve()
    dof = problem.n_res - len(names)
    chi2_red = float(np.sum(res.fun**2)) / dof if dof > 0 else math.nan
    estimates, cov_corr, boot, note, method = _intervals(
        problem, res, chi2_red, replicates, n_rows=len(rows), scheduler=scheduler)
    corr = _correlation(subject, names, cov_corr)
    fitted = problem.params_at(res.x)
    resid = pts.measured - problem.model_at(res.x)
    ss_tot = float(np.sum((pts.measured - pts.measured.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else math.nan
    return SubjectFit(subject=subject, params=fitted, estimates=tuple(estimates),
                      correlation=corr, rmse_N=float(np.sqrt(np.mean(resid**2))), r2=r2,
                      chi2_reduced=chi2_red, n_points=len(pts.measured),
                      mu_measured=pts.mu_measured,
                      interval_method=method,
                      n_replicates=0 if boot is None else int(boot.shape[0]),
                      interval_note=note)


def _with_frequency(windows: pd.DataFrame, trials: pd.DataFrame) -> pd.DataFrame:
    """The windows with their trial's drive frequency (``trials.csv``), for the circuit."""
    if "frequency_Hz" in windows.columns or not {"subject", "trial", "frequency_Hz"} <= set(
            trials.columns) or "trial" not in windows.columns:
        return windows
    freq = trials[["subject", "trial", "frequency_Hz"]].astype({"subject": str, "trial": str})
    freq = freq.drop_duplicates(["subject", "trial"])
    keyed = windows.astype({"subject": str, "trial": str})
    return keyed.merge(freq, on=["subject", "trial"], how="left", validate="many_to_one")


def fit_study(tables: ResultTables, base: ModelParameters = TABLE_1,
              fit: Sequence[str] = DEFAULT_FIT, *, scheduler: Any = None,
              mapper: Mapper | None = None) -> list[SubjectFit]:
    """Fit every subject of a result folder (see :func:`fit_subject`).

    The intervals come from refits to ``electrostatic_bootstrap.csv``'s replicates when the
    folder has them for all of a subject's points, else from the Jacobian.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables (:func:`evtribo.fit.tables.read_results`).
    base : ModelParameters
        Starting values and the fixed parameters.
    fit : sequence of str
        Names of the parameters to fit per subject.
    scheduler : distributed.Client, optional
        A Dask cluster for the bootstrap refits (the same refits as here).
    mapper : callable, optional
        ``mapper(func, items)``: the results of ``func`` on each item, in order (compare's
        worker processes): the subjects fitted side by side, what each fit logged said
        here, in the subjects' order (without a *scheduler* only).

    Returns
    -------
    list of SubjectFit
        One per subject, in the order of ``electrostatic.csv``.
    """
    jobs = []
    boot = tables.bootstrap
    for subject in tables.subjects:
        rows = tables.electrostatic[tables.electrostatic["subject"] == subject]
        win = _with_frequency(tables.windows[tables.windows["subject"] == subject],
                              tables.trials)
        reps = None
        if boot is not None:
            reps = replicate_matrix(rows, boot[boot["subject"].astype(str) == str(subject)],
                                    max_replicates=N_REFITS)
            if reps is None:
                emit("replicates-missing", Scope(str(subject)), subject=subject)
        jobs.append((subject, rows, base, tuple(fit), win, reps))
    if mapper is None or scheduler is not None or len(jobs) < 2:
        return [_fit_here(job, scheduler) for job in jobs]
    fits = []
    for done, said in mapper(_fit_logged, jobs):
        replay(said)  # what each fit said, here, in the subjects' order
        if isinstance(done, Exception):
            raise done  # after what it and the subjects before it said
        fits.append(_said(done))
    return fits


def _said(fit: SubjectFit) -> SubjectFit:
    """*fit*, its estimates said (logged: ``-v``) where the subjects' fits are gathered."""
    log.info("subject %s: %s (chi2_red %.3g, %d points)", fit.subject,
             ", ".join(f"{e.name} = {e.value:.4g} {e.unit}" for e in fit.estimates),
             fit.chi2_reduced, fit.n_points)
    return fit


def _fit_here(job: tuple[Any, ...], scheduler: Any) -> SubjectFit:
    """One subject's fit here, what it said said of the subject (before its error, if it
    raises)."""
    subject, rows, base, names, win, reps = job
    try:
        fit, said = collected(fit_subject, subject, rows, base, names, win, replicates=reps,
                              scheduler=scheduler, scope=Scope(str(subject)))
    except Exception as err:
        replay(err.__dict__.pop("records", []))
        raise
    replay(said)
    return _said(fit)


def _fit_logged(job: tuple[Any, ...]
                ) -> tuple[SubjectFit | Exception, list[WarningRecord]]:
    """One subject's fit (a worker's job), or the error that stopped it, and the warnings
    it said, for the caller to say in the subjects' order before it raises the first
    error."""
    subject, rows, base, names, win, reps = job
    try:
        return collected(fit_subject, subject, rows, base, names, win, replicates=reps,
                         scope=Scope(str(subject)))
    except Exception as err:  # returned: the subjects fitted before it are said first
        where = "".join(traceback.format_tb(err.__traceback__))
        err.add_note(f"(raised in the fit of subject {subject}, at:\n{where})")
        return err, err.__dict__.pop("records", [])


def interval_notes(fits: list[SubjectFit], *, has_bootstrap: bool) -> list[WarningRecord]:
    """What compare says of how the intervals were obtained (made, not said: compare says
    them in its order).

    Parameters
    ----------
    fits : list of SubjectFit
        The subjects' fits.
    has_bootstrap : bool
        Whether the result folder has ``electrostatic_bootstrap.csv``.

    Returns
    -------
    list of WarningRecord
        Of kinds ``intervals-bootstrap``, ``bootstrap-missing``, ``intervals-jacobian`` and
        ``intervals-profile``.
    """
    jac = [f for f in fits if f.interval_method == "jacobian"]
    boot = [f for f in fits if f.interval_method == "bootstrap"]
    notes = []
    if boot:
        notes.append(emit.record("intervals-bootstrap", subjects=", ".join(
            f.subject for f in boot), replicates=boot[0].n_replicates))
    if jac and not has_bootstrap:
        notes.append(emit.record("bootstrap-missing"))
    elif jac:
        notes += [emit.record("intervals-jacobian", Scope(f.subject), subject=f.subject,
                              why=f.interval_note or "no replicates for some of its points")
                  for f in jac]
    notes += [emit.record("intervals-profile", Scope(f.subject), why=f.interval_note)
              for f in fits if f.interval_method == "profile"]
    return notes
