"""Which model the data support: each candidate fitted per subject, ranked by AIC.

Candidates (:data:`CANDIDATES`), each fitted to a subject's points of ``electrostatic.csv``
(every point at its waveform, drive frequency and amplitude) by weighted least squares:

- ``paper``: the seed paper's eq. (11), sigma_0 times the JKR area (``h_L`` fitted; no
  frequency dependence: ``r_sc = r_g = inf``);
- ``hertz``: sigma_0 times Hertz's area, which does not grow with the voltage (``h_L``);
- ``maugis``: the full Maugis-Dugdale contact, sigma_0 pi c^2 (``h_L``);
- ``circuit``: the paper's model with the gap's leakage (``h_L`` and ``r_g``, the study
  format's section 9; ``r_sc`` as given by the parameters).

Criteria. The points' intervals give their relative weights w_i; with the common scale of the
errors unknown, the Gaussian likelihood gives ``AIC = n ln(WRSS / n) + 2 K`` and ``BIC = n
ln(WRSS / n) + K ln n``, WRSS the weighted sum of squares and ``K`` the fitted parameters plus
one (the scale). With few points per parameter (``n < 40 K`` for the subject's largest K,
Burnham and Anderson's rule) the ``aic`` column holds the small-sample AICc, ``AIC + 2 K (K +
1) / (n - K - 1)``, for every model of that subject (NaN when ``n <= K + 1``);
:attr:`ModelFit.criterion` says which. ``delta_aic`` is the difference to the subject's best
and ``akaike_weight`` is ``exp(-delta / 2)`` normalised over the subject's models. ``rss_N2``
is the unweighted sum of squared residuals, N^2. ``criterion`` says which of AIC and AICc
``aic`` is; ``at_bound`` names the fitted parameters the optimiser left at a bound of their
search range (the data do not set them: ``fitted`` then holds the bound, not an estimate).

Over the study (:func:`study_ranking`), each model's criterion is summed over the subjects
where every model has one (the subjects are independent data sets, each with its own
parameters), and the sums ranked: Δ to the lowest, Akaike weights, and a model within
:data:`INDISTINGUISHABLE` of the lowest said to be indistinguishable from it (Burnham and
Anderson: Δ < 2 has substantial support).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from evtribo.documents.tables import MODELS, MODELS_CSV
from evtribo.errors import AnalysisError, ConfigError
from evtribo.fit.model_points import ForceFunction, mean_electrostatic_force
from evtribo.fit.params import name_list
from evtribo.fit.problem import fit_points
from evtribo.fit.tables import ResultTables
from evtribo.model.contact import contact_area_hertz
from evtribo.model.electrostatics import adhesion_stress
from evtribo.model.friction import electrostatic_force
from evtribo.model.maugis import electrostatic_force_md
from evtribo.model.params import TABLE_1, ModelParameters
from evtribo.warning.collect import emitter

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["CANDIDATES", "INDISTINGUISHABLE", "MODELS_COLUMNS", "MODELS_CSV", "RANKING_COLUMNS",
           "Candidate", "ModelFit", "electrostatic_force_hertz", "fit_models", "models_table",
           "resolve_models", "study_ranking", "verdict"]

#: Its columns (:data:`evtribo.documents.tables.MODELS`).
MODELS_COLUMNS = MODELS.names()
#: Fewer points than this per parameter: AICc instead of AIC.
AICC_RATIO = 40
#: Models whose criterion is within this of the lowest are indistinguishable from the best.
INDISTINGUISHABLE = 2.0
#: The columns of :func:`study_ranking`.
RANKING_COLUMNS = ("model", "subjects", "aic_sum", "delta", "akaike_weight", "best_in",
                   "indistinguishable_in", "criterion", "at_bound_in")


def electrostatic_force_hertz(normal_force: ArrayLike, voltage: ArrayLike,
                              params: ModelParameters = TABLE_1) -> NDArray[np.float64]:
    """sigma_0 times Hertz's contact area: the electrostatic force if the area did not grow
    with the voltage, N.

    Parameters
    ----------
    normal_force : float or ndarray
        External normal force, N.
    voltage : float or ndarray
        Applied voltage U, V.
    params : ModelParameters

    Returns
    -------
    ndarray
        The force, N (proportional to U^2).
    """
    return np.asarray(adhesion_stress(voltage, params), dtype=float) * np.asarray(
        contact_area_hertz(normal_force, params), dtype=float)


@dataclass(frozen=True)
class Candidate:
    """A model the data may support.

    Attributes
    ----------
    name : str
    fit : tuple of str
        Its parameters fitted per subject.
    force : callable
        Its electrostatic force ``(normal_force, voltage, params)``, N.
    circuit : bool
        Whether the layers' resistances apply (else ``r_sc = r_g = inf``).
    description : str
    """

    name: str
    fit: tuple[str, ...]
    force: ForceFunction
    circuit: bool
    description: str


#: The candidates, by name.
CANDIDATES: dict[str, Candidate] = {c.name: c for c in (
    Candidate("paper", ("h_L",), electrostatic_force, False,
              "the paper's eq. (11): sigma_0 times the JKR area"),
    Candidate("hertz", ("h_L",), electrostatic_force_hertz, False,
              "sigma_0 times Hertz's area (no voltage dependence of the area)"),
    Candidate("maugis", ("h_L",), electrostatic_force_md, False,
              "the full Maugis-Dugdale contact, sigma_0 pi c^2"),
    Candidate("circuit", ("h_L", "r_g"), electrostatic_force, True,
              "the paper's model with a leaky gap (r_g fitted)"),
)}


def resolve_models(names: str | Iterable[str]) -> tuple[str, ...]:
    """Validate the names of the models to compare.

    Parameters
    ----------
    names : str or iterable of str
        ``"paper,hertz"`` or a list of names.

    Returns
    -------
    tuple of str
        The names, without duplicates, in the order given.

    Raises
    ------
    ConfigError
        Naming the unknown models and the known ones (``key="models"``).
    """
    wanted = name_list(names)
    if not wanted:
        raise ConfigError(f"no model to compare; known: {', '.join(CANDIDATES)}",
                          key="models")
    unknown = [n for n in wanted if n not in CANDIDATES]
    if unknown:
        raise ConfigError(f"unknown model(s) {', '.join(map(repr, unknown))}; known: "
                          f"{', '.join(CANDIDATES)}", key="models")
    return tuple(wanted)


@dataclass
class ModelFit:
    """One candidate fitted to one subject.

    Attributes
    ----------
    subject, model : str
    params : ModelParameters or None
        The fitted parameters (None when the fit failed).
    fitted : dict
        The fitted parameters' values, SI units.
    n_params, n_points : int
    rss_N2 : float
        Unweighted sum of squared residuals, N^2.
    wrss : float
        Weighted sum of squared residuals.
    aic, bic, delta_aic, akaike_weight : float
        See the module's text (``aic`` is AICc when :attr:`criterion` says so).
    criterion : str
        ``"AIC"`` or ``"AICc"``.
    note : str
        Why the fit failed ("" otherwise).
    at_bound : tuple of str
        The fitted parameters left at a bound of their search range.
    """

    subject: str
    model: str
    params: ModelParameters | None
    fitted: dict[str, float] = field(default_factory=dict)
    n_params: int = 0
    n_points: int = 0
    rss_N2: float = math.nan
    wrss: float = math.nan
    aic: float = math.nan
    bic: float = math.nan
    delta_aic: float = math.nan
    akaike_weight: float = math.nan
    criterion: str = "AIC"
    note: str = ""
    at_bound: tuple[str, ...] = ()

    def force(self, normal_force: ArrayLike, amplitude: ArrayLike, waveform: ArrayLike,
              frequency: ArrayLike | None) -> NDArray[np.float64]:
        """The fitted model's mean electrostatic force at these drives, N.

        Parameters
        ----------
        normal_force, amplitude, waveform, frequency : array_like
            As in :func:`evtribo.fit.model_points.mean_electrostatic_force`.

        Returns
        -------
        ndarray
            NaN when the fit failed.
        """
        fn, amp, freq = np.broadcast_arrays(
            np.asarray(normal_force, dtype=float), np.asarray(amplitude, dtype=float),
            np.asarray(np.nan if frequency is None else frequency, dtype=float))
        if self.params is None:
            return np.full(fn.shape, np.nan)
        return mean_electrostatic_force(fn, amp, waveform, self.params,
                                        frequency=None if frequency is None else freq,
                                        force=CANDIDATES[self.model].force)


def _base_for(candidate: Candidate, base: ModelParameters) -> ModelParameters:
    return base if candidate.circuit else base.with_values(r_sc=math.inf, r_g=math.inf)


def _fit_one(subject: str, rows: pd.DataFrame, candidate: Candidate,
             base: ModelParameters) -> ModelFit:
    """One candidate's fit to one subject's rows (a failed fit is a row with a note)."""
    try:
        problem, res = fit_points(subject, rows, candidate.fit, _base_for(candidate, base),
                                  force=candidate.force, frequency=candidate.circuit)
    except AnalysisError as err:
        emit("model-failed", model=candidate.name, subject=subject, error=err.message)
        return ModelFit(subject, candidate.name, None, n_params=len(candidate.fit),
                        note=err.message)
    pts = problem.pts
    resid = pts.measured - problem.model_at(res.x)
    values = problem.to_values(res.x)
    return ModelFit(subject, candidate.name, problem.params_at(res.x),
                    dict(zip(candidate.fit, values.tolist(), strict=True)),
                    n_params=len(candidate.fit), n_points=len(pts.measured),
                    rss_N2=float(np.sum(resid**2)), wrss=float(np.sum(res.fun**2)),
                    at_bound=_at_bound(candidate.fit, res.x, problem.lower, problem.upper))


def _at_bound(names: Sequence[str], x: NDArray[np.float64], lower: NDArray[np.float64],
              upper: NDArray[np.float64]) -> tuple[str, ...]:
    """The parameters whose scaled value lies on a finite bound of its range (within a
    millionth of the range, or of 1 where it is unbounded above)."""
    out = []
    for name, xi, lo, hi in zip(names, x, lower, upper, strict=True):
        tol = 1e-6 * ((hi - lo) if math.isfinite(hi - lo) else 1.0)
        if (math.isfinite(lo) and xi - lo <= tol) or (math.isfinite(hi) and hi - xi <= tol):
            out.append(str(name))
    return tuple(out)


def _criteria(fits: Sequence[ModelFit]) -> None:
    """AIC (or AICc), BIC, delta and weight of one subject's fits, in place."""
    ok = [f for f in fits if f.params is not None and f.n_points > 0]
    if not ok:
        return
    k_max = max(f.n_params + 1 for f in ok)
    small = min(f.n_points for f in ok) < AICC_RATIO * k_max
    for f in ok:
        n, k = f.n_points, f.n_params + 1
        base = n * math.log(max(f.wrss, 1e-300) / n)
        f.criterion = "AICc" if small else "AIC"
        f.aic = base + 2 * k
        if small:
            f.aic = f.aic + 2 * k * (k + 1) / (n - k - 1) if n - k - 1 > 0 else math.nan
        f.bic = base + k * math.log(n)
    finite = [f.aic for f in ok if math.isfinite(f.aic)]
    if not finite:
        return
    best = min(finite)
    for f in ok:
        f.delta_aic = f.aic - best
    total = sum(math.exp(-f.delta_aic / 2) for f in ok if math.isfinite(f.delta_aic))
    for f in ok:
        if math.isfinite(f.delta_aic):
            f.akaike_weight = math.exp(-f.delta_aic / 2) / total


def fit_models(tables: ResultTables | pd.DataFrame, models: Sequence[str],
               base: ModelParameters = TABLE_1) -> list[ModelFit]:
    """Fit each of *models* to each subject and rank them.

    Parameters
    ----------
    tables : ResultTables or DataFrame
        A result folder's tables, or ``electrostatic.csv``'s rows.
    models : sequence of str
        Names of :data:`CANDIDATES` (:func:`resolve_models`).
    base : ModelParameters
        Starting values and the fixed parameters.

    Returns
    -------
    list of ModelFit
        One per subject and model, sorted by subject (in the table's order) and AIC.
    """
    elec = tables.electrostatic if isinstance(tables, ResultTables) else tables
    subjects = list(dict.fromkeys(elec["subject"].astype(str)))
    out: list[ModelFit] = []
    for subject in subjects:
        rows = elec[elec["subject"].astype(str) == subject]
        fits = [_fit_one(subject, rows, CANDIDATES[m], base) for m in models]
        _criteria(fits)
        fits.sort(key=lambda f: (not math.isfinite(f.aic), f.aic))
        out += fits
    return out


def models_table(fits: Sequence[ModelFit]) -> pd.DataFrame:
    """``models.csv``: one row per subject and model (:data:`MODELS_COLUMNS`).

    Parameters
    ----------
    fits : sequence of ModelFit
        From :func:`fit_models` (kept in its order).

    Returns
    -------
    DataFrame
        ``fitted`` as text (``h_L=3.21e-06; r_g=0.012``); NaN where a number is not known.
    """
    rows = [{"subject": f.subject, "model": f.model,
             "fitted": "; ".join(f"{k}={v:.3g}" for k, v in f.fitted.items()),
             "n_params": f.n_params, "n_points": f.n_points, "rss_N2": f.rss_N2,
             "aic": f.aic, "bic": f.bic, "delta_aic": f.delta_aic,
             "akaike_weight": f.akaike_weight,
             "criterion": f.criterion if f.params is not None else None,
             "at_bound": ";".join(f.at_bound)} for f in fits]
    return pd.DataFrame(rows, columns=list(MODELS_COLUMNS))


def study_ranking(models: pd.DataFrame) -> pd.DataFrame:
    """The models ranked over the study: each one's criterion summed over the subjects where
    every model ranked has one (a model without a criterion in any of them is not ranked).

    Parameters
    ----------
    models : DataFrame
        ``models.csv`` (:data:`MODELS_COLUMNS`; ``criterion`` and ``at_bound`` may be
        missing, as in the files of an older evtribo).

    Returns
    -------
    DataFrame
        :data:`RANKING_COLUMNS`, best first: ``subjects`` summed over, ``aic_sum``,
        ``delta`` to the lowest sum, ``akaike_weight`` of the sums, ``best_in`` and
        ``indistinguishable_in`` (how many subjects each model was best in, or within
        :data:`INDISTINGUISHABLE` of the best), ``criterion`` (``AICc`` if any subject's was)
        and ``at_bound_in`` (subjects where a parameter stayed at its bound). Empty when no
        subject has every model's criterion.
    """
    table = models.copy()
    table["aic"] = pd.to_numeric(table["aic"], errors="coerce")
    table["delta_aic"] = pd.to_numeric(table["delta_aic"], errors="coerce")
    names, complete = _ranked_set(table)
    used = table[table["subject"].astype(str).isin(complete)
                 & table["model"].astype(str).isin(names)]
    if used.empty:
        return pd.DataFrame(columns=list(RANKING_COLUMNS))
    sums = used.groupby(used["model"].astype(str), sort=False)["aic"].sum()
    delta = sums - float(sums.min())
    weight = np.exp(-delta / 2.0)
    weight = weight / float(weight.sum())
    crit = set(used.get("criterion", pd.Series(["AIC"] * len(used))).dropna().astype(str))
    bound = used.get("at_bound", pd.Series([""] * len(used), index=used.index)).astype(
        object)  # read back from a models.csv with none at a bound: numbers, all NaN
    rows = []
    for name in sums.index:
        mine = used[used["model"].astype(str) == name]
        rows.append({"model": name, "subjects": len(complete), "aic_sum": float(sums[name]),
                     "delta": float(delta[name]), "akaike_weight": float(weight[name]),
                     "best_in": int((mine["delta_aic"] <= 1e-12).sum()),
                     "indistinguishable_in": int((mine["delta_aic"] < INDISTINGUISHABLE)
                                                 .sum()),
                     "criterion": "AICc" if "AICc" in crit else "AIC",
                     "at_bound_in": int(bound.loc[mine.index].fillna("").astype(str)
                                        .str.len().gt(0).sum())})
    out = pd.DataFrame(rows, columns=list(RANKING_COLUMNS))
    return out.sort_values("aic_sum", kind="stable").reset_index(drop=True)


def _ranked_set(table: pd.DataFrame) -> tuple[list[str], list[str]]:
    """The models ranked and the subjects summed over: the most models that have a
    criterion in a common subject (those with it in most subjects first), and the subjects
    where all of them have one (a model that no subject's points can rank, AICc with
    ``n <= K + 1``, is left out rather than every subject)."""
    finite = table[table["aic"].notna()]
    counts = finite.groupby(finite["model"].astype(str), sort=False).size()
    order = sorted(counts.index, key=lambda m: -int(counts[m]))
    for k in range(len(order), 0, -1):
        names = order[:k]
        subjects = [s for s, g in finite.groupby(finite["subject"].astype(str), sort=False)
                    if set(g["model"].astype(str)) >= set(names)]
        if subjects:
            return names, subjects
    return [], []


def verdict(ranking: pd.DataFrame) -> str:
    """The study's ranking in one sentence: the best model, those indistinguishable from it,
    the others' Δ.

    Parameters
    ----------
    ranking : DataFrame
        :func:`study_ranking`'s table.

    Returns
    -------
    str
        E.g. ``paper lowest summed AICc over 8 subjects; maugis indistinguishable from it
        (ΔAICc 1.2 < 2); hertz ΔAICc 8.5, circuit ΔAICc 19.9``; "" without a ranking.
    """
    if ranking.empty:
        return ""
    crit = str(ranking["criterion"].iloc[0])
    best = ranking.iloc[0]
    same = ranking[(ranking["delta"] < INDISTINGUISHABLE) & (ranking.index > 0)]
    worse = ranking[ranking["delta"] >= INDISTINGUISHABLE]
    text = f"{best['model']} lowest summed {crit} over {int(best['subjects'])} subject(s)"
    if not same.empty:
        text += "; " + ", ".join(f"{r.model} indistinguishable from it (\u0394{crit} "
                                 f"{r.delta:.1f} < {INDISTINGUISHABLE:g})"
                                 for r in same.itertuples())
    if not worse.empty:
        text += "; " + ", ".join(f"{r.model} \u0394{crit} {r.delta:.1f}"
                                 for r in worse.itertuples())
    return text
