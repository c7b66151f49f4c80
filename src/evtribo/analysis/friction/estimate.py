"""Friction coefficient and inferred electrostatic force, with bootstrap intervals.

Friction coefficient
    Each reference (the OFF windows of an alternating trial, or of a subject's whole-OFF
    trials) gives a model of ``mu`` (:mod:`evtribo.analysis.friction.reference`): the ratio of
    means ``sum(F_t,off) / sum(F_n,off)`` when nothing more is known or supported, else a
    weighted least-squares fit of the windows' ``F_t / F_n`` to their time in the trial,
    sliding direction and stroke rate. The ratio of means is the estimator the
    electrostatic force is defined against (``F_off = mu * F_n,off``): with no voltage
    effect and Amontons' law the inferred force is exactly zero whatever the spread of
    normal forces, and it is the maximum-likelihood estimate when the friction's noise
    grows with the load; the model keeps that weighting. The subject's friction law
    ``F_t = c W**m`` (:mod:`evtribo.analysis.friction.laws`) enters as a known factor
    ``(F_n / W_0)**(m - 1)``, as the stroke rate's does.

Electrostatic force
    The mean over the ON windows of the law inverted, ``F_n ((F_t,on / (mu F_n))**(1/m) -
    1)`` (``F_t,on / mu - F_n,on`` as the study format defines it when ``m = 1``), where
    ``mu`` is the ON window's own reference at the window's time, direction, stroke rate
    and normal force. The mean gives each trial its share of the ON windows and, within a
    trial, both sliding directions the same share, so that a difference between the
    directions (of the finger's friction, or the normal cell read into the tangential one)
    cancels instead of following how many strokes went each way.

Uncertainty
    One wild cluster bootstrap of everything a force rests on (Cameron, Gelbach & Miller
    2008, for few clusters; the clusters are strokes): the design held (the windows, their
    normal forces, their weights in the mean), each window's ``log F_t`` perturbed by its
    model's residual, scaled as the CR2 variance scales it (Bell & McCaffrey 2002), times
    a standard normal weight drawn per stroke; every reference refitted to its perturbed
    windows (its terms chosen again by AICc), the force computed again from the perturbed
    ON windows and the refitted ``mu``. An alternating trial's ON windows are fitted with
    its OFF windows (:func:`~evtribo.analysis.friction.reference.fit_trial_model`), so their
    perturbations move its ``mu`` and its ON windows together, as their errors do; the ON
    windows of other trials than their reference's are perturbed about a model of their
    own (each trial and group's level, its change with ``log F_n``, direction:
    :func:`~evtribo.analysis.friction.bootstrap.on_residuals`). The law's exponent and the
    stroke rate's slope are drawn from their own distributions. Replicates are shared by
    the amplitudes of a subject (a reference serving several of them is drawn once per
    replicate: their errors are correlated, as in the data), and feed the power-law
    exponent's interval and the model fit of ``evtribo compare``. The generator is seeded
    for reproducible output.

    Small-sample calibration. A trial gives 4-10 windows per condition. The residuals'
    CR2 scaling makes each source's bootstrap variance unbiased, and the normal weights make
    the percentile interval of a mean the normal one; what remains is Student's tails: the
    replicates of each amplitude are stretched about the point estimate by

        ``c = t(1-alpha/2, nu) / z(1-alpha/2)``

    with ``nu`` the Welch-Satterthwaite degrees of freedom ``(sum v_i)^2 / sum v_i^2/f_i``
    over the force's independent error sources (each reference with the ON windows fitted
    with it, the ON windows of other trials, the law's exponent): ``v_i`` that source's
    bootstrap variance, ``f_i`` its strokes less the coefficients fitted to them
    (:func:`~evtribo.analysis.friction.bootstrap.small_sample_scale`). For one Gaussian mean
    this is the Student-t interval; for the difference of two groups Welch's. It keeps the
    bootstrap's shape (skew from ``1/mu`` and ``1/m``). Coverage of the 95 % interval,
    measured (Monte Carlo of windows, 600 repeats): 95.3 % at 6 windows per group, 95.5 %
    at 25, 94.5 % at 25 with the law's exponent measured (``tests/analysis/
    test_analysis_core.py``); over simulated studies, ``docs/analysis.md``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from evtribo.analysis.friction.bootstrap import (
    DEFAULT_CONFIDENCE,
    GroupForce,
    Pooled,
    References,
    Windows,
    checked_windows,
    group_force,
    small_sample_scale,
    subject_law,
)
from evtribo.analysis.friction.laws import ChosenLaw, FittedLaw
from evtribo.analysis.friction.laws.amontons import amontons
from evtribo.analysis.friction.reference import MuModel
from evtribo.analysis.friction.window_facts import WindowFacts
from evtribo.errors import AnalysisError

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

DEFAULT_N_BOOT = 2000


def friction_coefficient(normal_N: npt.ArrayLike, friction_N: npt.ArrayLike) -> float:
    """Friction coefficient as the ratio of mean friction to mean normal force.

    Parameters
    ----------
    normal_N : array_like of float, N
        Mean normal force of each OFF window.
    friction_N : array_like of float, N
        Mean friction magnitude of each OFF window.

    Returns
    -------
    float
        ``mu`` (dimensionless).

    Raises
    ------
    AnalysisError
        No windows, or a non-positive total normal force.
    """
    fn = np.asarray(normal_N, dtype=np.float64)
    ft = np.asarray(friction_N, dtype=np.float64)
    if fn.size == 0 or fn.size != ft.size:
        raise AnalysisError("no OFF windows to estimate the friction coefficient from")
    total = float(np.sum(fn))
    if not total > 0:
        raise AnalysisError("the OFF windows' normal force is not positive")
    return float(np.sum(ft)) / total


def mean_inferred_force(normal_on_N: npt.ArrayLike, friction_on_N: npt.ArrayLike,
                        mu: float | npt.ArrayLike) -> float:
    """The electrostatic force inferred from ON windows under Amontons' law: the mean of
    ``F_t,on / mu - F_n,on`` over them (the study format's definition; the model's force of
    a voltage is :func:`evtribo.model.electrostatic_force`).

    Parameters
    ----------
    normal_on_N, friction_on_N : array_like of float, N
        Mean normal force and friction magnitude of each ON window.
    mu : float or array_like of float
        The friction coefficient (one, or one per ON window).

    Returns
    -------
    float
        Force in N.

    Raises
    ------
    AnalysisError
        No ON windows.
    """
    fn = np.asarray(normal_on_N, dtype=np.float64)
    ft = np.asarray(friction_on_N, dtype=np.float64)
    if fn.size == 0:
        raise AnalysisError("no ON windows to infer the electrostatic force from")
    return float(np.mean(ft / np.asarray(mu, dtype=np.float64) - fn))


@dataclass(frozen=True)
class ElectrostaticEstimate:
    """Electrostatic force per group of ON windows (an amplitude, or any label the caller
    numbers its groups with) for one subject.

    Attributes
    ----------
    groups : ndarray
        Distinct group labels, ascending (amplitudes in V, when the groups are amplitudes).
    force_N, ci_low_N, ci_high_N : ndarray, N
        Point estimate and bootstrap interval per group.
    mu : ndarray
        The friction coefficient each group's ON windows were compared with, averaged as
        their forces are (each ON window's own, :mod:`evtribo.analysis.friction.reference`).
    normal_on_N, normal_off_N, friction_on_N, friction_off_N : ndarray, N
        Means over the ON windows and over their reference OFF windows.
    n_on, n_off : ndarray of int
        Windows used.
    replicates_N : ndarray, shape (n_boot, n_groups), N
        Bootstrap replicates of the forces (shared resampling across groups), stretched
        about ``force_N`` by ``interval_scale`` (the module's small-sample calibration); the
        intervals are their percentiles.
    interval_scale : ndarray
        The stretch ``c`` of each group's replicates (1 with no calibration).
    dof : ndarray
        Welch-Satterthwaite degrees of freedom of each group's force.
    on_mu : ndarray
        The coefficient each ON window was compared with, in the order given.
    models : dict
        Each used reference's :class:`~evtribo.analysis.friction.reference.MuModel`, by its index.
    law : ChosenLaw
        The subject's friction law the forces were inferred with
        (:mod:`evtribo.analysis.friction.laws`).
    """

    groups: FloatArray
    force_N: FloatArray
    ci_low_N: FloatArray
    ci_high_N: FloatArray
    mu: FloatArray
    normal_on_N: FloatArray
    normal_off_N: FloatArray
    friction_on_N: FloatArray
    friction_off_N: FloatArray
    n_on: npt.NDArray[np.int64]
    n_off: npt.NDArray[np.int64]
    replicates_N: FloatArray
    interval_scale: FloatArray
    dof: FloatArray
    on_mu: FloatArray = field(default_factory=lambda: np.empty(0))
    models: dict[int, MuModel] = field(default_factory=dict)
    law: ChosenLaw = field(default_factory=lambda: amontons(FittedLaw()))


def estimate_electrostatic(  # noqa: PLR0917 - one array per window attribute
    off_normal_N: Sequence[npt.ArrayLike],
    off_friction_N: Sequence[npt.ArrayLike],
    on_normal_N: npt.ArrayLike,
    on_friction_N: npt.ArrayLike,
    on_reference: npt.ArrayLike,
    on_group: npt.ArrayLike,
    *,
    n_boot: int = DEFAULT_N_BOOT,
    confidence: float = DEFAULT_CONFIDENCE,
    seed: int | np.random.SeedSequence | None = 0,
    off_facts: Sequence[WindowFacts] | None = None,
    on_facts: WindowFacts | None = None,
    time_trend: Sequence[bool] | None = None,
    friction_law: str = "auto",
    exponent: float | None = None,
) -> ElectrostaticEstimate:
    """Electrostatic force per group of ON windows, with bootstrap intervals that carry
    ``mu``'s error.

    Parameters
    ----------
    off_normal_N, off_friction_N : sequence of array_like of float, N
        For each reference ``r`` (an alternating trial, or a subject's OFF trials), the mean
        normal force and friction magnitude of its OFF windows.
    on_normal_N, on_friction_N : array_like of float, N
        Mean normal force and friction magnitude of each ON window.
    on_reference : array_like of int
        Index of each ON window's reference in ``off_*``.
    on_group : array_like of float
        Each ON window's group: one estimate per distinct value (its amplitude in V, or a
        group number the caller keeps the meaning of).
    n_boot : int
        Bootstrap replicates.
    confidence : float
        Interval's coverage (0.95 for 95 %).
    seed : int or SeedSequence, optional
        Seed of the bootstrap's generator.
    off_facts : sequence of WindowFacts, optional
        Each reference's OFF windows' times, directions, strokes' rates and strokes
        (default: none known: one ``mu`` per reference, the ratio of means).
    on_facts : WindowFacts, optional
        The same of the ON windows, and their trials.
    time_trend : sequence of bool, optional
        Per reference, whether its ``mu`` may change with time (its windows share a
        trial's clock); default: no.
    friction_law : str
        How the friction grows with the load (a name of
        :data:`~evtribo.analysis.friction.laws.LAWS`).
    exponent : float, optional
        Infer the forces with this ``m`` (a sensitivity; the law's other terms fitted).

    Returns
    -------
    ElectrostaticEstimate
        One entry per distinct group.

    Raises
    ------
    AnalysisError
        An ON window refers to a reference without OFF windows, or there are no ON windows.
    ValueError
        A *friction_law* that is no law's name.
    """
    w = checked_windows(off_normal_N, off_friction_N, on_normal_N=on_normal_N,
                 on_friction_N=on_friction_N, on_reference=on_reference, on_group=on_group)
    offs = list(off_facts) if off_facts is not None else [
        WindowFacts.plain(a.size) for a in w.off_normal]
    ons = on_facts if on_facts is not None else WindowFacts.plain(w.on_normal.size)
    trends = list(time_trend) if time_trend is not None else [False] * len(offs)
    rng = np.random.default_rng(seed)
    law = subject_law(w, offs, ons, friction_law, exponent)
    refs = References.fit(w, offs, ons, trends, rng=rng, n_boot=n_boot, law=law)
    labels = np.unique(w.on_group)
    pooled = Pooled.of(w, refs)
    forces = [group_force(rng, w, w.on_group == g, refs=refs, facts=ons,
                           confidence=confidence, pooled=pooled) for g in labels]
    return _estimate(labels, forces, [_group_means(w, w.on_group == g, refs.mu_on)
                                      for g in labels], refs, n_boot=n_boot,
                     confidence=confidence)


def _estimate(labels: FloatArray, forces: list[GroupForce], means: list[_GroupMeans],
              refs: References, *, n_boot: int, confidence: float) -> ElectrostaticEstimate:
    """The groups' forces, means and replicates gathered, with the intervals."""
    reps = np.column_stack([f.replicates_N for f in forces]) if forces \
        else np.empty((n_boot, 0))
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(reps, [alpha, 1.0 - alpha], axis=0)

    def column(values: list[float]) -> FloatArray:
        return np.asarray(values, dtype=np.float64)

    return ElectrostaticEstimate(
        groups=labels, force_N=column([f.force_N for f in forces]), ci_low_N=low,
        ci_high_N=high, mu=column([f.mu for f in forces]),
        normal_on_N=column([m.normal_on_N for m in means]),
        normal_off_N=column([m.normal_off_N for m in means]),
        friction_on_N=column([m.friction_on_N for m in means]),
        friction_off_N=column([m.friction_off_N for m in means]),
        n_on=np.asarray([m.n_on for m in means], dtype=np.int64),
        n_off=np.asarray([m.n_off for m in means], dtype=np.int64), replicates_N=reps,
        interval_scale=column([f.scale for f in forces]), dof=column([f.dof for f in forces]),
        on_mu=refs.mu_on, models=refs.models, law=refs.law)


@dataclass(frozen=True)
class _GroupMeans:
    """What electrostatic.csv shows of a group besides its force: the mean forces ON and
    OFF, the windows' counts."""

    normal_on_N: float
    friction_on_N: float
    normal_off_N: float
    friction_off_N: float
    n_on: int
    n_off: int


def _group_means(w: Windows, sel: npt.NDArray[np.bool_], mu_on: FloatArray) -> _GroupMeans:
    """The means of the ON windows *sel* and of the OFF windows of their references."""
    refs = np.unique(w.on_ref[sel])
    pool_n = np.concatenate([w.off_normal[r] for r in refs])
    pool_t = np.concatenate([w.off_friction[r] for r in refs])
    return _GroupMeans(normal_on_N=float(w.on_normal[sel].mean()),
                       friction_on_N=float(w.on_friction[sel].mean()),
                       normal_off_N=float(pool_n.mean()), friction_off_N=float(pool_t.mean()),
                       n_on=int(np.count_nonzero(sel)), n_off=int(pool_n.size))


__all__ = ["DEFAULT_CONFIDENCE", "DEFAULT_N_BOOT", "INTERVAL", "MU_ESTIMATOR",
           "ElectrostaticEstimate", "estimate_electrostatic", "friction_coefficient",
           "mean_inferred_force", "small_sample_scale"]

#: How each ON window's μ is found, as summary.json's settings say it.
MU_ESTIMATOR = ("each ON window's reference: the OFF windows' F_t/F_n at its time, sliding "
                "direction, stroke pace and normal force (their ratio of means when nothing "
                "more is supported); F_el = F_n ((F_t,on / (mu F_n))^(1/m) - 1) with the "
                "subject's friction law F_t = c W^m (friction_exponent in electrostatic.csv)")

#: How the intervals are found, as summary.json's settings say it.
INTERVAL = ("wild cluster bootstrap over strokes (CR2-scaled residuals, normal weights, every "
            "reference refitted), percentiles stretched by a Welch-Satterthwaite Student-t "
            "factor for few strokes")
