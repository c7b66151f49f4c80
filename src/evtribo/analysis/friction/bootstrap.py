"""The references an estimate compares its ON windows with, and the bootstrap of its forces
(:mod:`evtribo.analysis.friction.estimate` says what they are and how they are calibrated).

:class:`References` fits each reference's model of ``mu`` (with the subject's friction law,
:mod:`evtribo.analysis.friction.laws`) and draws its replicates; :func:`group_force` gives a
group's force and its calibrated replicates; :func:`small_sample_scale` is the calibration of
a percentile-bootstrap interval for few windows (a Welch-Satterthwaite Student factor).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import special  # stats.t.ppf is special.stdtrit, stats.norm.ppf special.ndtri

from evtribo.analysis.friction.direction_weights import balanced_weights
from evtribo.analysis.friction.laws import ChosenLaw, at_exponent, fit_subject_law, law_choice
from evtribo.analysis.friction.reference import MuModel, fit_mu_model, fit_trial_model
from evtribo.analysis.friction.window_facts import WindowFacts, cr2_residuals
from evtribo.errors import AnalysisError
from evtribo.model.friction_law import added_load

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
                exponent: float | None) -> ChosenLaw:
    """The subject's friction law from the OFF windows of the references used and all its
    ON windows (:func:`~evtribo.analysis.friction.laws.fit.fit_subject_law`), as the choice
    *friction_law* makes it the forces' law, or at the exponent given (its uncertainty left
    out)."""
    choice = law_choice(friction_law)
    used = [int(x) for x in np.unique(w.on_ref)]
    fitted = fit_subject_law(
        [(w.off_normal[r], w.off_friction[r], offs[r], np.full(w.off_normal[r].size, np.nan))
         for r in used] + [(w.on_normal, w.on_friction, ons, w.on_group)])
    if exponent is not None:
        return at_exponent(fitted, float(exponent))
    return choice.choose(fitted)


@dataclass(frozen=True)
class Windows:
    """The windows of one estimate as flat float arrays (see
    :func:`~evtribo.analysis.friction.estimate.estimate_electrostatic`'s parameters)."""

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
class Source:
    """An independent source of a force's error: the ON windows whose ``mu`` it moves and
    those whose friction it perturbs, and its degrees of freedom (strokes less the
    coefficients fitted to them; with *cells*, the sum over the cells a group's windows
    lie in, each cell a model of its own)."""

    mu_part: npt.NDArray[np.bool_]
    noise_part: npt.NDArray[np.bool_]
    dof: float
    cells: dict[float, float] | None = None
    cell_of: FloatArray | None = None

    def dof_for(self, sel: npt.NDArray[np.bool_]) -> float:
        """The degrees of freedom of the windows *sel* of this source."""
        if self.cells is None or self.cell_of is None:
            return self.dof
        here = np.unique(self.cell_of[sel & self.noise_part])
        return float(sum(self.cells.get(float(c), 0.0) for c in here))


def _weights(rng: np.random.Generator, clusters: npt.NDArray[np.int64], n_boot: int
             ) -> FloatArray:
    """The wild bootstrap's weights of windows in *clusters*, one per replicate and stroke,
    shape (n_boot, windows). Standard normal: a cell rests on a few strokes, and the
    bounded weights of Rademacher or Webb give a replicate ruled by one stroke no tails
    beyond 1.2 standard deviations, so that its percentile interval is too narrow; with
    normal weights the percentile interval of a mean is the Student interval the
    calibration makes of it."""
    _, which = np.unique(clusters, return_inverse=True)
    return rng.standard_normal((n_boot, int(which.max()) + 1 if which.size else 0))[:, which]


def on_residuals(normal_N: FloatArray, friction_N: FloatArray, mu: FloatArray, m: float, *,
                 facts: WindowFacts, group: FloatArray
                 ) -> tuple[FloatArray, FloatArray, dict[float, float]]:
    """The ON windows' scatter, as perturbations of their ``log F_t``: each window's force
    under the law (:func:`~evtribo.model.friction_law.added_load`) about its cell's (trial
    and group) level and direction term (two windows each way or more), CR2-scaled
    (weighted least squares, weights ``F_n``), and divided by ``d F_el / d log F_t =
    (F_n + F_el) / m``.

    The force of a cell is its mean over its ON phases, of which the windows are a
    sample: whatever the windows' force varies with (noise, the press where ``F_el``
    follows the contact area) is part of the mean's error, and nothing that leaves the
    force unchanged is (a press that moves ``F_t`` and ``F_n`` together).

    Parameters
    ----------
    normal_N, friction_N : ndarray, N
        Each ON window's forces.
    mu : ndarray
        Each one's friction coefficient without the voltage.
    m : float
        The friction law's exponent.
    facts : WindowFacts
    group : ndarray
        Each window's group.

    Returns
    -------
    resid : ndarray
        The perturbations' scale, of ``log F_t``.
    cell : ndarray
        Each window's cell.
    dofs : dict
        Each cell's degrees of freedom (strokes less coefficients).
    """
    force = added_load(normal_N, friction_N, mu, m)
    load = np.maximum(normal_N + force, 1e-6 * normal_N) / m
    resid = np.zeros(force.size)
    dofs: dict[float, float] = {}
    cell = facts.stratum.astype(np.float64) * 1e6 + np.nan_to_num(group)
    for c in np.unique(cell):
        sel = np.flatnonzero(cell == c)
        fn, d = normal_N[sel], facts.direction[sel]
        cols = [np.ones(sel.size)]
        if np.sum(d > 0) >= 2 and np.sum(d < 0) >= 2:
            cols.append(d.astype(np.float64))
        sw = np.sqrt(fn)
        q, r = np.linalg.qr(np.column_stack(cols) * sw[:, None])
        keep = np.abs(np.diag(r)) > 1e-10 * np.max(np.abs(np.diag(r)))
        q = q[:, keep]
        yw = force[sel] * sw
        e = (yw - q @ (q.T @ yw)) / sw
        resid[sel] = cr2_residuals(q, e, fn, facts.cluster[sel]) / load[sel]
        dofs[float(c)] = max(float(np.unique(facts.cluster[sel]).size - int(keep.sum())), 0.0)
    return resid, cell, dofs


@dataclass(frozen=True)
class References:
    """The references' models of ``mu``, what they give each ON window, and one wild
    cluster bootstrap of them all: each replicate's ``mu`` at each ON window, and the
    perturbation of each ON window's ``log F_t`` drawn with the same weights."""

    models: dict[int, MuModel]
    mu_on: FloatArray  # (n_on,)
    mu_on_b: FloatArray  # (n_boot, n_on)
    noise_on_b: FloatArray  # (n_boot, n_on): log F_t's perturbation
    resid_on: FloatArray  # (n_on,): their scale (:func:`on_residuals`)
    off_clusters: dict[int, int]  # strokes behind each model
    law: ChosenLaw
    exponent_b: FloatArray  # (n_boot, 1): the law's exponent in each replicate
    law_shift: FloatArray  # (n_on,): d log mu / d m at each ON window
    sources: list[Source]
    on_dof: float = 0.0  # the ON windows' degrees of freedom about their cells' models

    @classmethod
    def fit(cls, w: Windows, offs: list[WindowFacts], ons: WindowFacts, trends: list[bool],
            *, rng: np.random.Generator, n_boot: int, law: ChosenLaw) -> References:
        """Each used reference's model (a trial's from its OFF and ON windows together,
        :func:`~evtribo.analysis.friction.reference.fit_trial_model`), and the replicates."""
        models: dict[int, MuModel] = {}
        n_on = w.on_normal.size
        mu_on, mu_on_b = np.empty(n_on), np.empty((n_boot, n_on))
        on_wts = np.zeros((n_boot, n_on))
        shift = np.zeros(n_on)
        coupled = np.zeros(n_on, dtype=bool)
        clusters, sources = {}, []
        fitted = law.fitted
        rate, m = fitted.rate_slope, law.exponent
        slope_b = rng.normal(rate, fitted.rate_se, n_boot) if rate else np.zeros(n_boot)
        m_b = np.full(n_boot, m)
        # m's uncertainty is in the interval wherever the choice of law carries it: about
        # the fitted m, or about 1 where its interval holds Amontons' 1 (a pad of m = 0.9
        # may be taken for one of m = 1: its forces are then about a tenth low, inside the
        # interval)
        if law.draw_exponent:
            m_b = np.maximum(m + fitted.estimate_se * rng.standard_t(max(fitted.dof, 1.0),
                                                                     n_boot), MIN_EXPONENT)
        for r in (int(x) for x in np.unique(w.on_ref)):
            if w.off_normal[r].size == 0:
                raise AnalysisError("no OFF windows to estimate the friction coefficient from")
            sel = w.on_ref == r
            here = ons.take(sel)
            if trends[r]:
                model = fit_trial_model((w.off_normal[r], w.off_friction[r], offs[r]),
                                        (w.on_normal[sel], w.on_friction[sel], here,
                                         w.on_group[sel]), rate_slope=rate, law=law.law)
            else:
                model = fit_mu_model(w.off_normal[r], w.off_friction[r], offs[r],
                                     time_trend=False, rate_slope=rate, law=law.law)
            wts = _weights(rng, model.cluster, n_boot)
            load = model.load_factor(w.on_normal[sel])
            mu_on[sel] = model.at(here) * load
            mu_on_b[:, sel] = model.replicates_given(here, wts * model.resid) * load
            n_off = w.off_normal[r].size
            if model.log and model.resid.size == n_off + int(sel.sum()):
                # the ON windows were fitted with the OFF ones: the same weights
                on_wts[:, sel] = wts[:, n_off:]
                coupled |= sel
            if model.rate:  # the rate's slope is uncertain too
                centred = np.where(np.isfinite(here.rate), here.rate - model.rate_mean, 0.0)
                mu_on_b[:, sel] *= np.exp(np.outer(slope_b - rate, centred))
            # the exponent is uncertain too: the coefficient at the ON window's load moves
            # with it, about the load where the OFF windows hold it
            shift[sel] = np.log(w.on_normal[sel] / law.law.load_ref_N) - model.log_load_mean
            clusters[r] = int(np.unique(model.cluster).size)
            sources.append(Source(sel, sel & coupled, clusters[r] - model.coef.size))
            models[r] = model
        if not np.all(mu_on > 0):
            raise AnalysisError("the OFF windows' friction coefficient is not positive")
        alone = ~coupled
        on_wts[:, alone] = _weights(rng, ons.cluster[alone], n_boot)
        resid_on, cell, dofs = on_residuals(w.on_normal, w.on_friction, mu_on, m, facts=ons,
                                            group=w.on_group)
        noise_on_b = on_wts * resid_on
        if alone.any():  # ON windows of other trials than their reference's
            cell_of = np.where(alone, cell, np.nan)
            sources.append(Source(np.zeros(n_on, dtype=bool), alone,
                                  sum(dofs[c] for c in np.unique(cell[alone])),
                                  dofs, cell_of))
        mu_on_b *= np.exp(np.outer(m_b - m, shift))
        # a replicate's coefficient at or below zero is no coefficient: held at a tenth
        np.maximum(mu_on_b, 0.1 * mu_on, out=mu_on_b)
        return cls(models, mu_on, mu_on_b, noise_on_b, resid_on, clusters, law, m_b[:, None],
                   shift, sources, float(sum(dofs.values())))


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
    too few to show any (one stroke ON, one OFF window): the ON windows' ``log F_t`` about
    their models, and the OFF windows' relative scatter about their references' models;
    each with its degrees of freedom."""

    on_var: float
    on_dof: float
    mu_rel_var: float
    mu_dof: int

    @classmethod
    def of(cls, w: Windows, refs: References) -> Pooled:
        on_dof = refs.on_dof
        on_var = float(np.sum(refs.resid_on**2)) / on_dof if on_dof > 0 else np.nan
        mu_ss, mu_dof = 0.0, 0
        for r, model in refs.models.items():
            free = refs.off_clusters[r] - model.coef.size
            if free > 0:
                scale = 1.0 if model.log else float(np.mean(w.off_friction[r] / w.off_normal[r]))
                mu_ss += float(np.sum((model.resid / scale) ** 2))
                mu_dof += free
        return cls(on_var, on_dof,
                   mu_ss / mu_dof if mu_dof else np.nan, mu_dof)


def _pooled_in(w: Windows, sel: npt.NDArray[np.bool_], src: Source, pooled: Pooled, *,
               sensitivity: FloatArray, acc: FloatArray, rng: np.random.Generator
               ) -> list[tuple[float, float]]:
    """A source's error from the subject's pooled scatter, added to the replicates *acc*
    in place: of ``mu`` (the OFF windows' relative scatter over its reference's windows)
    and of the ON windows' ``log F_t``; *sensitivity* is ``d F_el / d log F_t`` of each
    window of *sel*, times its weight. Returns each part's variance and degrees of
    freedom (none when the subject shows no scatter either)."""
    mu_part, noise_part = src.mu_part[sel], src.noise_part[sel]
    parts: list[tuple[float, float]] = []
    if mu_part.any() and pooled.mu_dof > 0:
        r = int(np.unique(w.on_ref[sel][mu_part])[0])
        extra = float(sensitivity[mu_part].sum()) * np.sqrt(
            pooled.mu_rel_var / max(w.off_normal[r].size, 1))
        acc += extra * rng.standard_normal(acc.size)
        parts.append((extra**2, float(pooled.mu_dof)))
    if noise_part.any() and pooled.on_dof > 0:
        extra = float(np.sqrt(pooled.on_var * np.sum(sensitivity[noise_part] ** 2)))
        acc += extra * rng.standard_normal(acc.size)
        parts.append((extra**2, pooled.on_dof))
    return parts


def group_force(rng: np.random.Generator, w: Windows, sel: npt.NDArray[np.bool_], *,
                refs: References, facts: WindowFacts, confidence: float,
                pooled: Pooled) -> GroupForce:
    """The force of the ON windows *sel* (the balanced mean of each window's force under
    the law, :func:`~evtribo.model.friction_law.added_load`) and its calibrated replicates.

    One wild cluster bootstrap (Cameron, Gelbach & Miller 2008): the design fixed (the ON
    windows, their normal forces and weights as they are), each window's ``log F_t``
    perturbed by its model's CR2-scaled residual times its stroke's weight, the
    references refitted (their terms chosen again by AICc), the law's exponent from its own
    distribution. An alternating trial's ON windows were fitted with its OFF windows, so
    their perturbations and their ``mu``'s move together, as their errors do. The
    replicates are stretched by the small-sample calibration (one source per reference,
    one for the ON windows of other trials, one for the exponent). A group whose ON windows
    show no scatter of their own (one stroke) or whose reference's model fits its windows
    exactly takes the subject's pooled scatter instead."""
    idx = np.flatnonzero(sel)
    trial, direction = facts.stratum[idx], np.sign(facts.direction[idx])
    weight = balanced_weights(np.ones((1, idx.size)), trial, direction)[0]
    fn, ft = w.on_normal[sel], w.on_friction[sel]
    mu, mu_b = refs.mu_on[sel], refs.mu_on_b[:, sel]
    noise = refs.noise_on_b[:, sel]
    m, m_b = refs.law.exponent, refs.exponent_b
    force = float(weight @ added_load(fn, ft, mu, m))

    def replicate(mu_rep: FloatArray, noise_rep: FloatArray | float,
                  m_rep: float | FloatArray = m) -> FloatArray:
        return np.asarray(added_load(fn, ft * np.exp(noise_rep), mu_rep, m_rep) @ weight)

    acc = replicate(mu_b, noise, m_b)
    without_m = mu_b / np.exp((m_b - m) * refs.law_shift[sel])
    variances: list[float] = []
    dofs: list[float] = []
    load = (fn + added_load(fn, ft, mu, m)) / m  # d F_el / d log F_t of each window
    for src in refs.sources:
        mu_part, noise_part = src.mu_part[sel], src.noise_part[sel]
        if not (mu_part.any() or noise_part.any()):
            continue
        v = float(np.var(replicate(np.where(mu_part, without_m, mu),
                                   np.where(noise_part, noise, 0.0))))
        dof = src.dof_for(sel)
        parts = [(v, dof)]
        if dof < 1:  # no scatter of its own (one stroke, a model that fits exactly)
            parts = _pooled_in(w, sel, src, pooled, sensitivity=weight * load, acc=acc,
                               rng=rng) or [(v, dof)]
        variances += [p[0] for p in parts]
        dofs += [max(p[1], 1.0) for p in parts]
    if refs.law.exponent_source and np.ptp(m_b) > 0:  # the exponent alone
        alone = mu * np.exp((m_b - m) * refs.law_shift[sel])
        variances.append(float(np.var(replicate(alone, 0.0, m_b))))
        dofs.append(max(float(refs.law.fitted.dof), 1.0))
    # HC2 residuals and the law's Student draws: no source's variance is a plug-in one
    scale, nu = small_sample_scale(variances, dofs, confidence, dofs=dofs)
    return GroupForce(force, float(weight @ mu), force + scale * (acc - force), scale, nu)
