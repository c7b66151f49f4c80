"""The checks of a fit of the population's mixed model, in words (what population.csv's
``checks`` column says) and as fields (:meth:`Convergence.as_checks`, fit.json's).

A fit is *checked*: its deviance is finite, the Hessian of the deviance at the optimum is
positive-definite (its correlation form's smallest eigenvalue above 1e-8; at a variance's
boundary, the fixed effects' profile curvature), the other optimisers reached the
same estimates (within a fifth of a standard error of the population's level and exponent),
and the exponent is determined by the data (its 95 % interval within +/- 1 with three degrees
of freedom or more). Each failed check is said, with every optimiser's deviance and exponent
where they disagree: a disagreement is reported, never averaged away. A variance at zero (a
singular fit, as lme4 calls it) is no failure; it is said in the notes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from evtribo.documents.population_table import Checks

__all__ = ["AGREE_SE", "MAX_HALF_WIDTH", "MIN_DF", "OPTIMISERS", "PD_TOLERANCE",
           "Convergence", "OptimiserRun", "checks", "determined", "positive_definite",
           "singular"]

Array = NDArray[np.float64]

#: The optimisers each fit is run with, the first being the primary.
OPTIMISERS = ("L-BFGS-B", "Nelder-Mead", "Powell")
#: Estimates of two optimisers that differ by more than this many standard errors disagree.
AGREE_SE = 0.2
#: The fewest degrees of freedom of a determined exponent, and its widest 95 % half-interval.
MIN_DF, MAX_HALF_WIDTH = 3.0, 1.0
#: The smallest eigenvalue of a positive-definite Hessian in its correlation form.
PD_TOLERANCE = 1e-8


@dataclass(frozen=True)
class OptimiserRun:
    """One optimiser's end: its deviance, the population's level and exponent there.

    Attributes
    ----------
    method : str
    deviance : float
    beta : tuple of float
        ``(a, n)``.
    reported : bool
        Whether the optimiser reported convergence itself.
    """

    method: str
    deviance: float
    beta: tuple[float, float]
    reported: bool


@dataclass(frozen=True)
class Convergence:
    """The checks of a fit.

    Attributes
    ----------
    finite : bool
        The deviance at the optimum is finite.
    hessian_pd : bool
        The deviance's Hessian there is positive-definite.
    agree : bool
        Every optimiser reached the same estimates.
    runs : tuple of OptimiserRun
    problems : tuple of str
        Each failed check, in words.
    singular : str
        A variance at zero, in words ("" when none).
    determined : bool
        The exponent is determined by the data: its 95 % interval within +/- 1 and
        Satterthwaite's degrees of freedom at least :data:`MIN_DF` (else the fit is no
        failure of the optimisers, but its exponent says next to nothing).
    """

    finite: bool
    hessian_pd: bool
    agree: bool
    runs: tuple[OptimiserRun, ...]
    problems: tuple[str, ...] = ()
    singular: str = ""
    determined: bool = True

    @property
    def ok(self) -> bool:
        """Every check passed."""
        return self.finite and self.hessian_pd and self.agree and self.determined

    def summary(self) -> str:
        """``ok`` or the problems, for population.csv's ``checks`` column."""
        if self.ok:
            return f"ok ({len(self.runs)} optimisers agree)"
        return "; ".join(self.problems)

    def as_checks(self) -> Checks:
        """The checks as fields, with :meth:`summary`'s words (what fit.json records and the
        report's key results read: the force at an amplitude may hold where the exponent
        does not).

        Returns
        -------
        Checks
        """
        return Checks(finite=self.finite, hessian_pd=self.hessian_pd, agree=self.agree,
                      determined=self.determined, text=self.summary())


def positive_definite(m: Array) -> bool:
    """Whether the symmetric matrix *m* is positive-definite: its diagonal positive and the
    smallest eigenvalue of its correlation form (scaled by its diagonal, so that parameters
    on different scales do not count) above :data:`PD_TOLERANCE`.

    Parameters
    ----------
    m : ndarray, shape (p, p)

    Returns
    -------
    bool
    """
    sym = (m + m.T) / 2.0
    d = np.diag(sym)
    if not (np.all(np.isfinite(sym)) and np.all(d > 0)):
        return False
    scaled = sym / np.sqrt(np.outer(d, d))
    return bool(np.linalg.eigvalsh(scaled).min() > PD_TOLERANCE)


def _agreement(runs: Sequence[OptimiserRun], best: OptimiserRun, se: Array
               ) -> list[str]:
    """Each optimiser whose estimates differ from the best's by more than :data:`AGREE_SE`
    standard errors, in words."""
    out = []
    for r in runs:
        diff = np.abs(np.array(r.beta) - np.array(best.beta))
        if np.any(diff > AGREE_SE * se):
            out.append(f"{r.method} ended at n = {r.beta[1]:.3f} (deviance "
                       f"{r.deviance - best.deviance:+.2f} from the best, {best.method}'s "
                       f"n = {best.beta[1]:.3f})")
    return out


def singular(cov_re: Array, q: int) -> str:
    """A variance at zero in the between-subject covariance, in words ("" when none).

    Parameters
    ----------
    cov_re : ndarray, shape (2, 2)
    q : int
        Random effects per subject (1 or 2).

    Returns
    -------
    str
    """
    eig = np.linalg.eigvalsh(cov_re[:q, :q]) if q else np.zeros(0)
    if eig.size and eig.max() <= 1e-10:
        return "no spread between subjects estimated (variance at zero: a singular fit)"
    if q == 2 and eig.min() <= 1e-8 * eig.max():
        return ("the subjects' levels and exponents vary along one line only (a singular "
                "fit: one variance at zero)")
    return ""


def checks(dev: float, hess: Array, runs: Sequence[OptimiserRun], best: OptimiserRun, *,
           cov_beta: Array, singular: str) -> Convergence:
    """The convergence checks of a fit.

    Parameters
    ----------
    dev : float
        The deviance at the optimum kept.
    hess : ndarray
        The deviance's Hessian there (the fixed effects first).
    runs : sequence of OptimiserRun
        Every optimiser's end.
    best : OptimiserRun
        The one kept.
    cov_beta : ndarray, shape (2, 2)
        The fixed effects' covariance.
    singular : str
        A variance at zero, in words ("" when none).

    Returns
    -------
    Convergence
    """
    problems: list[str] = []
    finite = math.isfinite(dev) and bool(np.all(np.isfinite(cov_beta)))
    if not finite:
        problems.append("the log-likelihood or the estimates' covariance is not finite")
    pd = bool(np.all(np.isfinite(hess))) and positive_definite(hess)
    if not pd and singular and np.all(np.isfinite(hess)):
        # at a variance's boundary the deviance is flat along it: the fixed effects' part
        # (their profile curvature) is what must be positive-definite
        hbb, hbt, htt = hess[:2, :2], hess[:2, 2:], hess[2:, 2:]
        pd = positive_definite(hbb - hbt @ np.linalg.pinv(htt, hermitian=True) @ hbt.T)
    if not pd:
        problems.append("the Hessian of the deviance is not positive-definite at the "
                        "optimum (a saddle or a flat ridge: the estimates are not determined)")
    se = np.sqrt(np.clip(np.diag(cov_beta), 0.0, None)) if finite else np.full(2, np.inf)
    differ = _agreement(runs, best, se)
    if differ:
        problems.append("the optimisers disagree: " + "; ".join(differ))
    if len(runs) < len(OPTIMISERS):
        problems.append(f"{len(OPTIMISERS) - len(runs)} of {len(OPTIMISERS)} optimisers "
                        "reached no finite deviance")
    return Convergence(finite, pd, not differ and len(runs) == len(OPTIMISERS), tuple(runs),
                       tuple(problems), singular)


def determined(convergence: Convergence, value: float, low: float, high: float,
               df: float) -> Convergence:
    """*convergence* with the exponent's determination checked.

    Parameters
    ----------
    convergence : Convergence
    value, low, high : float
        The exponent and its 95 % interval.
    df : float
        Its degrees of freedom.

    Returns
    -------
    Convergence
    """
    if df >= MIN_DF and (high - low) / 2.0 <= MAX_HALF_WIDTH:
        return convergence
    return dataclasses.replace(convergence, determined=False, problems=(
        *convergence.problems,
        f"the exponent is hardly determined by these data: n = {value:.2f} "
        f"[{low:.2f}, {high:.2f}] ({df:.1f} degrees of freedom): read it as unknown"))
