"""The references an estimate compares its ON windows with, and the bootstrap of its forces
(:mod:`evtribo.analysis.friction.estimate` says what they are and how they are calibrated).

:class:`References` fits each reference's model of ``mu`` (with the subject's friction law,
:mod:`evtribo.analysis.friction.law`) and draws its replicates; :func:`group_force` gives a
group's force and its calibrated replicates; :func:`small_sample_scale` is the calibration of
a percentile-bootstrap interval for few windows (a Welch-Satterthwaite Student factor).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import special  # stats.t.ppf is special.stdtrit, stats.norm.ppf special.ndtri

from evtribo.analysis.friction.balance import balanced_weights
from evtribo.analysis.friction.facts import WindowFacts
from evtribo.analysis.friction.law import FrictionLaw, fit_subject_law, force_of
from evtribo.analysis.friction.reference import MuModel, fit_mu_model, fit_trial_model
from evtribo.errors import AnalysisError

__all__ = ["DEFAULT_CONFIDENCE", "small_sample_scale"]

FloatArray = npt.NDArray[np.float64]

DEFAULT_CONFIDENCE = 0.95
#: Lowest exponent a replicate of the law's is drawn at.
MIN_EXPONENT = 0.3


def small_sample_scale(variances: npt.ArrayLike, counts: npt.ArrayLike,
                       confidence: float = DEFAULT_CONFIDENCE, *,
                       dofs: npt.ArrayLike | None = None) -> tuple[float, float]:
    """Stretch of a percentile-bootstrap interval for few windows (Welch-Satterthwaite).

    Parameters
    ----------
    variances : array_like of float, N^2
        Bootstrap (plug-in) variance of each independent error source of the estimate.
    counts : array_like of int
        Windows (or strokes) behind each source.
    confidence : float
        Coverage of the interval.
    dofs : array_like of float, optional
        Degrees of freedom of each source (default: ``counts - 1``, a mean's).

    Returns
    -------
    scale : float
        ``sqrt(sum w_i / sum v_i) * t(q, nu) / z(q)`` with ``w_i = v_i n_i / f_i`` and
        ``f_i`` the source's degrees of freedom (1 when the variances are all zero).
    dof : float
        ``nu = (sum w_i)^2 / sum(w_i^2 / f_i)`` (inf when the variances are zero).
    """
    v = np.asarray(variances, dtype=np.float64).ravel()
    n = np.asarray(counts, dtype=np.float64).ravel()
    f = n - 1.0 if dofs is None else np.asarray(dofs, dtype=np.float64).ravel()
    use = np.isfinite(v) & (v > 0) & (f > 0)
    if not use.any():
        return 1.0, float("inf")
    v, n, f = v[use], n[use], f[use]
    w = v * n / f
    dof = float(np.sum(w) ** 2 / np.sum(w**2 / f))
    q = 1.0 - (1.0 - confidence) / 2.0
    ratio = float(special.stdtrit(dof, q) / special.ndtri(q))  # t and normal quantiles
    return float(np.sqrt(np.sum(w) / np.sum(v))) * ratio, dof


def subject_law(w: Windows, offs: list[WindowFacts], ons: WindowFacts, friction_law: str,
         exponent: float | None) -> FrictionLaw:
    """The subject's friction law from the OFF windows of the references used and all its
    ON windows (:func:`~evtribo.analysis.friction.law.fit_subject_law`), or at the exponent
    given."""
    used = [int(x) for x in np.unique(w.on_ref)]
    law = fit_subject_law(
        [(w.off_normal[r], w.off_friction[r], offs[r], np.full(w.off_normal[r].size, np.nan))
         for r in used] + [(w.on_normal, w.on_friction, ons, w.on_group)],
        law=friction_law)
    if exponent is not None:
        law = law.with_exponent(float(exponent), "amontons" if exponent == 1 else "power")
        law = FrictionLaw(law.exponent, law.kind, law.estimate, float("nan"), law.told, 0.0,
                          law.rate_slope, law.rate_se, law.load_ref_N, law.press_spread)
    return law


@dataclass(frozen=True)
class Windows:
    """The windows of one estimate as flat float arrays (see
    :func:`estimate_electrostatic`'s parameters)."""

    off_normal: list[FloatArray]
    off_friction: list[FloatArray]
    on_normal: FloatArray
    on_friction: FloatArray
    on_ref: npt.NDArray[np.int64]
    on_group: FloatArray


def checked_windows(off_normal_N: Sequence[npt.ArrayLike], off_friction_N: Sequence[npt.ArrayLike],
             *, on_normal_N: npt.ArrayLike, on_friction_N: npt.ArrayLike,
             on_reference: npt.ArrayLike, on_group: npt.ArrayLike) -> Windows:
    """The windows as arrays, checked: ON windows there are, of one length, each referring
    to a reference given."""
    w = Windows([np.asarray(a, dtype=np.float64).ravel() for a in off_normal_N],
                 [np.asarray(a, dtype=np.float64).ravel() for a in off_friction_N],
                 np.asarray(on_normal_N, dtype=np.float64).ravel(),
                 np.asarray(on_friction_N, dtype=np.float64).ravel(),
                 np.asarray(on_reference, dtype=np.int64).ravel(),
                 np.asarray(on_group, dtype=np.float64).ravel())
    if w.on_normal.size == 0:
        raise AnalysisError("no ON windows to infer the electrostatic force from")
    if not (w.on_normal.size == w.on_friction.size == w.on_ref.size == w.on_group.size):
        raise ValueError("the ON windows' arrays differ in length")
    if w.on_ref.min() < 0 or w.on_ref.max() >= len(w.off_normal):
        raise ValueError("on_reference holds an index with no OFF windows given")
    return w


@dataclass(frozen=True)
class References:
    """The references' models of ``mu``, what they give each ON window, and their
    bootstrap replicates at each ON window."""

    models: dict[int, MuModel]
    mu_on: FloatArray  # (n_on,)
    mu_on_b: FloatArray  # (n_boot, n_on)
    off_clusters: dict[int, int]  # strokes behind each model
    law: FrictionLaw
    exponent_b: FloatArray  # (n_boot, 1): the law's exponent in each replicate
    law_shift: FloatArray  # (n_on,): d log mu / d m at each ON window

    @classmethod
    def fit(cls, w: Windows, offs: list[WindowFacts], ons: WindowFacts, trends: list[bool],
            *, rng: np.random.Generator, n_boot: int, law: FrictionLaw) -> References:
        """Each used reference's model (a trial's from its OFF and ON windows together,
        :func:`~evtribo.analysis.friction.reference.fit_trial_model`), and its replicates."""
        models: dict[int, MuModel] = {}
        mu_on = np.empty(w.on_normal.size)
        mu_on_b = np.empty((n_boot, w.on_normal.size))
        shift = np.zeros(w.on_normal.size)
        clusters = {}
        rate, m = law.rate_slope, law.exponent
        slope_b = rng.normal(rate, law.rate_se, n_boot) if rate else np.zeros(n_boot)
        m_b = np.full(n_boot, m)
        if law.kind == "power" and np.isfinite(law.estimate_se):
            m_b = np.maximum(m + law.estimate_se * rng.standard_t(max(law.dof, 1.0), n_boot),
                             MIN_EXPONENT)
        given = {"rate_slope": rate, "exponent": m, "load_ref_N": law.load_ref_N}
        for r in (int(x) for x in np.unique(w.on_ref)):
            if w.off_normal[r].size == 0:
                raise AnalysisError("no OFF windows to estimate the friction coefficient from")
            sel = w.on_ref == r
            here = ons.take(sel)
            if trends[r]:
                model = fit_trial_model((w.off_normal[r], w.off_friction[r], offs[r]),
                                        (w.on_normal[sel], w.on_friction[sel], here,
                                         w.on_group[sel]), **given)
            else:
                model = fit_mu_model(w.off_normal[r], w.off_friction[r], offs[r],
                                     time_trend=False, **given)
            load = model.load_factor(w.on_normal[sel])
            mu_on[sel] = model.at(here) * load
            mu_on_b[:, sel] = model.replicates_at(here, rng, n_boot) * load
            if model.rate:  # the rate's slope is uncertain too
                centred = np.where(np.isfinite(here.rate), here.rate - model.rate_mean, 0.0)
                mu_on_b[:, sel] *= np.exp(np.outer(slope_b - rate, centred))
            # the exponent is uncertain too: the coefficient at the ON window's load moves
            # with it, about the load where the OFF windows hold it
            shift[sel] = np.log(w.on_normal[sel] / law.load_ref_N) - model.log_load_mean
            clusters[r] = int(np.unique(model.cluster).size)
            models[r] = model
        if not np.all(mu_on > 0):
            raise AnalysisError("the OFF windows' friction coefficient is not positive")
        mu_on_b *= np.exp(np.outer(m_b - m, shift))
        # a replicate's coefficient at or below zero is no coefficient: held at a tenth
        np.maximum(mu_on_b, 0.1 * mu_on, out=mu_on_b)
        return cls(models, mu_on, mu_on_b, clusters, law, m_b[:, None], shift)


@dataclass(frozen=True)
class GroupForce:
    """One group's force, its ``mu``, its calibrated replicates and their stretch."""

    force_N: float
    mu: float
    replicates_N: FloatArray
    scale: float
    dof: float


@dataclass(frozen=True)
class Pooled:
    """A subject's scatter pooled over all its windows, for a group whose own windows are
    too few to show any (one stroke ON, one OFF window): the ON windows' ``F_t/mu - F_n``
    about their trial's mean (N^2), and the OFF windows' relative scatter about
    their references' models; each with its degrees of freedom."""

    on_var: float
    on_dof: int
    mu_rel_var: float
    mu_dof: int

    @classmethod
    def of(cls, w: Windows, refs: References, ons: WindowFacts) -> Pooled:
        e = force_of(w.on_normal, w.on_friction, refs.mu_on, refs.law.exponent)
        ss, dof = 0.0, 0
        for s in np.unique(ons.stratum):  # about each trial's mean (both directions)
            part = e[ons.stratum == s]
            ss, dof = ss + float(np.sum((part - part.mean()) ** 2)), dof + part.size - 1
        mu_ss, mu_dof = 0.0, 0
        for r, model in refs.models.items():
            free = refs.off_clusters[r] - model.coef.size
            if free > 0:
                scale = 1.0 if model.log else float(np.mean(w.off_friction[r] / w.off_normal[r]))
                mu_ss += float(np.sum((model.resid / scale) ** 2))
                mu_dof += free
        return cls(ss / dof if dof else np.nan, dof, mu_ss / mu_dof if mu_dof else np.nan,
                   mu_dof)


def group_force(rng: np.random.Generator, w: Windows, sel: npt.NDArray[np.bool_], *,
                 refs: References, facts: WindowFacts, n_boot: int, confidence: float,
                 pooled: Pooled) -> GroupForce:
    """The force of the ON windows *sel* (the balanced mean of each window's force under
    the law, :func:`force_of`) and its bootstrap replicates: the strokes resampled within
    each trial (the two directions averaged alike in every replicate), each reference's
    ``mu`` from its wild bootstrap, the law's exponent from its own distribution, stretched
    by the small-sample calibration (one error source for the ON windows, one per
    reference's ``mu``, one for the exponent). A source with too few strokes to show its
    scatter (one ON stroke, an OFF reference its model fits exactly) takes the subject's
    pooled scatter instead."""
    idx = np.flatnonzero(sel)
    trial, direction = facts.stratum[idx], np.sign(facts.direction[idx])
    weight = balanced_weights(np.ones((1, idx.size)), trial, direction)[0]
    fn, ft = w.on_normal[sel], w.on_friction[sel]
    mu, mu_b = refs.mu_on[sel], refs.mu_on_b[:, sel]
    m, m_b = refs.law.exponent, refs.exponent_b
    force = float(weight @ force_of(fn, ft, mu, m))
    counts = np.ones((n_boot, fn.size))
    n_clusters = 0
    trials = np.unique(trial)
    for s in trials:
        part = np.flatnonzero(trial == s)
        _, which = np.unique(facts.cluster[idx[part]], return_inverse=True)
        k = int(which.max()) + 1
        n_clusters += k
        counts[:, part] = rng.multinomial(k, np.full(k, 1.0 / k), size=n_boot)[:, which]
    weights_b = balanced_weights(counts, trial, direction)

    def replicate(mu_rep: FloatArray, wts: FloatArray, m_rep: float | FloatArray = m
                  ) -> FloatArray:
        return (force_of(fn, ft, mu_rep, m_rep) * wts).sum(axis=-1)

    acc = replicate(mu_b, weights_b, m_b)
    variances = [float(np.var(replicate(mu, weights_b)))]
    counts_n = [n_clusters]
    dofs = [max(n_clusters - trials.size, 1)]
    if n_clusters - trials.size < 1 and pooled.on_dof > 0:  # one stroke: the subject's
        extra = np.sqrt(pooled.on_var * float(weight @ weight))
        acc = acc + extra * rng.standard_normal(n_boot)
        variances[0], counts_n[0], dofs[0] = extra**2, pooled.on_dof, pooled.on_dof
    if refs.law.kind == "power" and np.ptp(m_b) > 0:  # the exponent alone
        alone = mu * np.exp((m_b - m) * refs.law_shift[sel])
        variances.append(float(np.var(replicate(alone, weight, m_b))))
        counts_n.append(max(int(refs.law.dof), 1))
        dofs.append(max(int(refs.law.dof), 1))
    refs_here = w.on_ref[sel]
    for r in np.unique(refs_here):
        part = refs_here == r
        one = np.where(part, mu_b / np.exp((m_b - m) * refs.law_shift[sel]), mu)
        model = refs.models[int(r)]
        free = refs.off_clusters[int(r)] - model.coef.size
        if free < 1 and pooled.mu_dof > 0:  # the model fits exactly: the subject's scatter
            load = float((weight[part] * ft[part] / mu[part]).sum()) / m
            extra = load * np.sqrt(pooled.mu_rel_var / max(w.off_normal[int(r)].size, 1))
            acc = acc + extra * rng.standard_normal(n_boot)
            variances.append(extra**2)
            free = pooled.mu_dof
        else:
            variances.append(float(np.var(replicate(one, weight))))
        counts_n.append(max(free, 1))  # HC2 residuals: the bootstrap variance is not plug-in
        dofs.append(max(free, 1))
    scale, nu = small_sample_scale(variances, counts_n, confidence, dofs=dofs)
    return GroupForce(force, float(weight @ mu), force + scale * (acc - force), scale, nu)
