"""Per-subject results from every trial's windows: electrostatic.csv and exponents.csv.

Each ON window is compared with a *reference* set of OFF windows:

- in a trial that alternates, its own OFF windows (same finger state, same session);
- otherwise the OFF windows of the subject's whole-OFF trials; if the subject has none,
  every OFF window of the subject (reported as a warning).

The estimates and their bootstrap are
:func:`evtribo.analysis.friction.estimate.estimate_electrostatic`,
run once per subject over all its (waveform, frequency, amplitude) groups, so that the
replicates are
shared by the subject's points (an OFF reference serving several of them is resampled once
per replicate, and its error in ``mu`` is common to them, as in the data). They feed the
power law's interval (:func:`evtribo.analysis.friction.powerlaw.fit_power_law`, one per waveform and
frequency)
and, through ``electrostatic_bootstrap.csv`` (:data:`BOOTSTRAP_COLUMNS`), the model fit of
``evtribo compare``. Each subject gets its own seed (derived from its name and the settings'
seed), so the output does not depend on the order of the trials or on the number of
processes.
"""

from __future__ import annotations

import logging
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from evtribo.analysis.forces.crosstalk import crosstalk_notes
from evtribo.analysis.friction.drift import (
    TrialDrift,
    drift_notes,
    phase_notes,
    relative_scatter,
    stroke_notes,
    trial_confounding,
    trial_drifts,
    window_facts,
)
from evtribo.analysis.friction.estimate import (
    DEFAULT_N_BOOT,
    ElectrostaticEstimate,
    estimate_electrostatic,
)
from evtribo.analysis.friction.laws import untold_note
from evtribo.analysis.friction.plausible import implausible_rows
from evtribo.analysis.friction.powerlaw import fit_power_law
from evtribo.documents.tables import BOOTSTRAP, ELECTROSTATIC, EXPONENTS
from evtribo.errors import AnalysisError
from evtribo.warning.collect import collecting, emitter
from evtribo.warning.record import Scope, WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

#: Columns of electrostatic.csv, exponents.csv and electrostatic_bootstrap.csv
#: (:mod:`evtribo.documents.tables`); of electrostatic.csv beyond the study format's, the
#: subject's friction law (:mod:`evtribo.analysis.friction.laws`) and the force at
#: ``m = 0.75`` where the presses do not tell ``m`` (``friction_law = "auto"``).
ELECTROSTATIC_COLUMNS, EXPONENT_COLUMNS = ELECTROSTATIC.names(), EXPONENTS.names()
BOOTSTRAP_COLUMNS = BOOTSTRAP.names()
LAW_COLUMNS = ELECTROSTATIC_COLUMNS[ELECTROSTATIC_COLUMNS.index("friction_law"):]
#: Bootstrap replicates written to electrostatic_bootstrap.csv per row of electrostatic.csv.
N_BOOTSTRAP_SAVED = 200
#: Below this many ON or OFF windows behind an amplitude, summary.json says so. The
#: intervals are calibrated for small counts (Student-t widening, 95 % coverage measured at
#: 6 windows), so the warning is kept for counts where they become very wide.
MIN_WINDOWS = 5


#: Group key of windows whose trial's drive frequency is unknown.
_NO_FREQUENCY = -1.0


def _frequency(value: object) -> float:
    """A trial's drive frequency as a group key, Hz: to three significant digits (an
    amplifier reporting 9999.8 Hz and 10000.2 Hz in two trials drove them alike), or
    :data:`_NO_FREQUENCY`."""
    try:
        f = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return _NO_FREQUENCY
    return float(f"{f:.3g}") if np.isfinite(f) and f > 0 else _NO_FREQUENCY


def _where(subject: object, waveform: str, frequency: float,
           amplitude_V: float | None = None) -> Scope:
    """A subject's drive (``P01 (square, 10000 Hz)``), at an amplitude: where a warning is
    said."""
    return Scope(str(subject), None, waveform or None,
                 None if frequency == _NO_FREQUENCY else frequency, amplitude_V)


def _seed(base: int, *names: str) -> np.random.SeedSequence:
    """A subject's seed: the settings' *base* and its names' checksums."""
    return np.random.SeedSequence([base, *(zlib.crc32(n.encode()) for n in names)])


#: A trial's place in the study: (subject, trial) as the tables name them.
TrialKey = tuple[object, object]
#: A point of electrostatic.csv within a subject: (waveform, frequency key, amplitude V).
PointKey = tuple[str, float, float]


def _references(subject: str, on: pd.DataFrame, off: pd.DataFrame, whole_off: pd.DataFrame,
                *, condition_of: Mapping[TrialKey, object]
                ) -> tuple[list[pd.DataFrame], npt.NDArray[np.int64], list[bool]]:
    """The OFF reference of each ON window: the sets of OFF windows, each one's index, and
    whether each set is one trial's (its mu may follow the trial's time)."""
    subject_ref = whole_off if len(whole_off) else off
    refs: list[pd.DataFrame] = []
    ref_index: dict[str, int] = {}
    on_ref = np.empty(len(on), dtype=np.int64)
    owns: dict[object, pd.DataFrame] = {}  # each trial's OFF windows, selected once
    said: set[tuple[str, object, object]] = set()
    for k, (trial, waveform) in enumerate(zip(on.trial, on.waveform, strict=True)):
        if trial not in owns:
            owns[trial] = off[off.trial == trial]
        own = owns[trial]
        if condition_of.get((subject, trial)) == "alternating" and len(own):
            key, frame = f"trial:{trial}", own
        else:
            kind = ("other-off" if condition_of.get((subject, trial)) == "alternating"
                    else "whole-off" if not len(whole_off) else "")
            if kind and (kind, waveform, trial) not in said:
                said.add((kind, waveform, trial))
                emit(kind, Scope(subject, None, waveform or None), trial=str(trial))
            key, frame = "subject", subject_ref
        if key not in ref_index:
            ref_index[key] = len(refs)
            refs.append(frame)
        on_ref[k] = ref_index[key]
    return refs, on_ref, [key.startswith("trial:") for key in ref_index]


@dataclass(frozen=True)
class _TrialFacts:
    """What the trials table tells the aggregation: each trial's condition and drive
    frequency key, each frequency key's reported frequency (the median of its trials'),
    and each trial's duration (s: the time analysed, its pieces' total when its log's clock
    jumped or its recording paused)."""

    condition_of: dict[TrialKey, object]
    frequency_of: dict[TrialKey, float]
    shown: dict[float, float]
    duration_of: dict[TrialKey, float]


def _trial_facts(trials: pd.DataFrame) -> _TrialFacts:
    """Each trial's condition and frequency key, and the frequencies to report."""
    keys = list(zip(trials.subject, trials.trial, strict=True))
    condition_of: dict[TrialKey, object] = dict(zip(keys, trials.condition, strict=True))
    reported_Hz = (trials.frequency_Hz.tolist() if "frequency_Hz" in trials.columns
                   else [None] * len(keys))
    frequency_of = {k: _frequency(f) for k, f in zip(keys, reported_Hz, strict=True)}
    reported: dict[float, list[float]] = {}
    for k, f in zip(keys, reported_Hz, strict=True):
        if frequency_of[k] != _NO_FREQUENCY:
            reported.setdefault(frequency_of[k], []).append(float(f))
    durations = (pd.to_numeric(trials.duration_s, errors="coerce").tolist()
                 if "duration_s" in trials.columns else [None] * len(keys))
    return _TrialFacts(condition_of, frequency_of,
                       {k: float(np.median(v)) for k, v in reported.items()},
                       {k: float(d) for k, d in zip(keys, durations, strict=True)
                        if d is not None and np.isfinite(d) and d > 0})


@dataclass
class _Tables:
    """The rows of electrostatic.csv and exponents.csv, and the parts of the bootstrap
    table, as the subjects add them."""

    electrostatic: list[dict[str, object]] = field(default_factory=list)
    exponents: list[dict[str, object]] = field(default_factory=list)
    bootstrap: list[pd.DataFrame] = field(default_factory=list)


@dataclass(frozen=True)
class _SubjectEstimate:
    """A subject's estimate, its points, the coefficient each window was compared with (or,
    for an OFF window, its reference's model there) and the trials' drifts."""

    est: ElectrostaticEstimate
    points: list[PointKey]
    window_mu: pd.Series
    drifts: dict[object, TrialDrift]
    sensitivity: ElectrostaticEstimate | None = None


def _estimate_subject(subject: str, sub: pd.DataFrame, facts: _TrialFacts, *, n_boot: int,
                      seed: int, confidence: float,
                      friction_law: str = "auto") -> _SubjectEstimate | None:
    """A subject's electrostatic force per point (waveform, frequency, amplitude), each ON
    window against its OFF reference; None when the subject has no ON window with an
    amplitude, or no OFF windows to compare them with."""
    off = sub[sub.condition == "off"]
    whole_off = off[[facts.condition_of.get((subject, t)) == "off" for t in off.trial]]
    on = sub[(sub.condition == "on") & np.isfinite(sub.amplitude_V.to_numpy(float))]
    if on.empty:
        return None
    refs, on_ref, trends = _references(subject, on, off, whole_off,
                                       condition_of=facts.condition_of)
    if any(r.empty for r in refs):
        emit("no-mu", Scope(subject))
        return None
    window_points: list[PointKey] = list(zip(on.waveform, on.frequency_Hz,
                                             on.amplitude_V.to_numpy(float), strict=True))
    points = sorted(set(window_points))  # numbered in sorted order: the estimator's groups
    group_number = {p: i for i, p in enumerate(points)}
    off_facts = [window_facts(r) for r in refs]
    args = ([r.normal_force_N.to_numpy(float) for r in refs],
            [r.friction_force_N.to_numpy(float) for r in refs],
            on.normal_force_N.to_numpy(float), on.friction_force_N.to_numpy(float),
            on_ref, [group_number[p] for p in window_points])
    options: dict[str, Any] = {"n_boot": n_boot, "confidence": confidence,
               "off_facts": off_facts,
               "on_facts": window_facts(on), "time_trend": trends}
    est = estimate_electrostatic(*args, seed=_seed(seed, subject), friction_law=friction_law,
                                 **options)
    sensitivity = None
    if est.law.sensitivity is not None:  # the law chosen says what m may rather be
        sensitivity = estimate_electrostatic(*args, seed=_seed(seed, subject),
                                             exponent=est.law.sensitivity, **options)
        untold_note(subject, est.law.fitted)
    window_mu = pd.Series(est.on_mu, index=on.index)
    own = {}
    for r, model in est.models.items():
        window_mu = pd.concat([window_mu, pd.Series(model.at(off_facts[r]),
                                                    index=refs[r].index)])
        if trends[r]:
            own[refs[r].trial.iloc[0]] = model
    window_mu = window_mu[~window_mu.index.duplicated()]
    drifts = trial_drifts(off, own, rate_slope=est.law.fitted.rate_slope, law=est.law.law)
    alone = sorted({t for t in on.trial if facts.condition_of.get((subject, t)) == "on"},
                   key=str)
    drift_notes(subject, drifts, compared_in_trial=any(trends), on_trials_alone=alone)
    ratios = {r: (refs[r].friction_force_N / refs[r].normal_force_N).to_numpy(float)
              for r in est.models}
    rate_on, rate_off = window_facts(on).rate, window_facts(off).rate
    gap = (float(np.exp(np.nanmean(rate_on) - np.nanmean(rate_off))) - 1.0
           if np.isfinite(rate_on).any() and np.isfinite(rate_off).any() else None)
    stroke_notes(subject, est.models, relative_scatter(est.models, ratios), gap)
    alternating = [t for t in sub.trial.unique()
                   if facts.condition_of.get((subject, t)) == "alternating"]
    # a trial's span as analysed: a jump of its log's clock between pieces is no time
    confounded = {t: (f, min(span, facts.duration_of.get((subject, t), span)))
                  for t, (f, span) in trial_confounding(sub[sub.trial.isin(alternating)]).items()}
    phase_notes(subject, confounded)
    return _SubjectEstimate(est, [points[int(g)] for g in est.groups], window_mu, drifts,
                            sensitivity)


def _law_columns(est: ElectrostaticEstimate, sensitivity: ElectrostaticEstimate | None,
                 j: int) -> dict[str, object]:
    """A row's columns of :data:`LAW_COLUMNS`."""
    # the interval of m where the forces carry its uncertainty
    low, high = est.law.shown_interval
    out: dict[str, object] = {"friction_law": est.law.label,
                              "friction_exponent": est.law.exponent,
                              "friction_exponent_ci_low": low,
                              "friction_exponent_ci_high": high}
    found = sensitivity is not None and j < sensitivity.force_N.size
    for col, values in (("electrostatic_force_m075_N", "force_N"),
                        ("electrostatic_force_m075_ci_low_N", "ci_low_N"),
                        ("electrostatic_force_m075_ci_high_N", "ci_high_N")):
        out[col] = float(getattr(sensitivity, values)[j]) if found else np.nan
    return out


def _add_points(tables: _Tables, subject: str, found: _SubjectEstimate, *,
                shown: Mapping[float, float], n_saved: int) -> None:
    """A subject's rows of electrostatic.csv and of the bootstrap table, with a warning for
    a point resting on few windows."""
    est, points = found.est, found.points
    keep = min(n_saved, est.replicates_N.shape[0])
    for j, (waveform, freq, amp) in enumerate(points):
        names = {"subject": subject, "waveform": waveform or None,
                 "frequency_Hz": shown.get(freq), "amplitude_V": amp}
        tables.electrostatic.append({
            **names, "mu": est.mu[j], "normal_force_on_N": est.normal_on_N[j],
            "normal_force_off_N": est.normal_off_N[j],
            "friction_on_N": est.friction_on_N[j],
            "friction_off_N": est.friction_off_N[j],
            "electrostatic_force_N": est.force_N[j],
            "electrostatic_force_ci_low_N": est.ci_low_N[j],
            "electrostatic_force_ci_high_N": est.ci_high_N[j],
            "n_on": int(est.n_on[j]), "n_off": int(est.n_off[j]),
            **_law_columns(est, found.sensitivity, j)})
        tables.bootstrap.append(pd.DataFrame({
            **names, "replicate": np.arange(keep),
            "electrostatic_force_N": est.replicates_N[:keep, j]}))
        if est.n_on[j] < MIN_WINDOWS or est.n_off[j] < MIN_WINDOWS:
            emit("few-windows", _where(subject, waveform, freq, amp), on=int(est.n_on[j]),
                 off=int(est.n_off[j]), min_windows=MIN_WINDOWS)


def _add_power_laws(tables: _Tables, subject: str, est: ElectrostaticEstimate, *,
                    points: list[PointKey], shown: Mapping[float, float], confidence: float
                    ) -> None:
    """A subject's rows of exponents.csv: a power law per drive (waveform, frequency) with
    two positive amplitudes or more, fitted on the log scale to the cells whose force's
    interval lies above zero: a cell whose interval reaches zero has no logarithm the data
    determine (its force is below its error), and is left out, said."""
    for waveform, freq in dict.fromkeys((w, f) for w, f, _ in points):
        in_drive = np.array([w == waveform and f == freq and a > 0 for w, f, a in points])
        if np.count_nonzero(in_drive) < 2:
            continue
        amps = np.array([a for _, _, a in points])
        near_zero = in_drive & ~(est.ci_low_N > 0)
        for j in np.flatnonzero(near_zero):
            emit("power-law-near-zero", _where(subject, waveform, freq, float(amps[j])),
                 low_mN=1e3 * est.ci_low_N[j], high_mN=1e3 * est.ci_high_N[j])
        in_drive &= ~near_zero
        if np.count_nonzero(in_drive) < 2:
            if near_zero.any():
                emit("no-power-law", _where(subject, waveform, freq),
                     error="fewer than two amplitudes whose F_el's interval lies above zero")
            continue
        amplitudes_V = amps[in_drive]
        try:
            fit = fit_power_law(amplitudes_V, est.force_N[in_drive],
                                replicates_N=est.replicates_N[:, in_drive],
                                confidence=confidence)
        except AnalysisError as err:
            emit("no-power-law", _where(subject, waveform, freq), error=str(err))
            continue
        tables.exponents.append({"subject": subject, "waveform": waveform or None,
                                 "frequency_Hz": shown.get(freq),
                                 "exponent": fit.exponent,
                                 "exponent_ci_low": fit.exponent_ci_low,
                                 "exponent_ci_high": fit.exponent_ci_high,
                                 "prefactor_N": fit.prefactor_N})


@dataclass(frozen=True)
class StudySummary:
    """The per-subject results of a study's windows.

    Attributes
    ----------
    electrostatic, exponents, bootstrap : pandas.DataFrame
        electrostatic.csv, exponents.csv and electrostatic_bootstrap.csv
        (:data:`BOOTSTRAP_COLUMNS`: the calibrated bootstrap replicates of every
        electrostatic.csv row, replicate ``i`` of a subject's rows coming from the same
        resampling).
    warnings : list of WarningRecord
        What the aggregation found worth saying (missing references, few windows, no
        power law, friction that changed within trials or between strokes).
    window_mu : pandas.Series
        By the windows' index: the friction coefficient each ON window was compared with,
        and each OFF window's reference model at its place (windows.csv's
        ``mu_reference``).
    mu_change : dict
        ``{(subject, trial): change of mu per 10 s}`` (trials.csv's ``mu_change_per_10s``).
    """

    electrostatic: pd.DataFrame
    exponents: pd.DataFrame
    bootstrap: pd.DataFrame
    warnings: list[WarningRecord]
    window_mu: pd.Series
    mu_change: dict[TrialKey, float]


def summarize_study(windows: pd.DataFrame, trials: pd.DataFrame, *,
                    n_boot: int = DEFAULT_N_BOOT, seed: int = 0, confidence: float = 0.95,
                    n_saved: int = N_BOOTSTRAP_SAVED, friction_law: str = "auto"
                    ) -> StudySummary:
    """Electrostatic force per subject, waveform, frequency and amplitude, and the power laws
    (per subject, waveform and frequency).

    Parameters
    ----------
    windows : pandas.DataFrame
        All trials' windows (windows.csv columns).
    trials : pandas.DataFrame
        All trials' rows (trials.csv columns); ``condition`` tells alternating trials.
    n_boot : int
        Bootstrap replicates.
    seed : int
        Base seed.
    confidence : float
        Coverage of the intervals.
    n_saved : int
        Replicates kept in the bootstrap table (the first ones; at most *n_boot*).
    friction_law : str
        How the friction grows with the load (``[analysis] friction_law``: a name of
        :data:`~evtribo.analysis.friction.laws.LAWS`).

    Returns
    -------
    StudySummary
    """
    with collecting() as warnings:
        return _summarize(windows, trials, warnings, n_boot=n_boot, seed=seed,
                          confidence=confidence, n_saved=n_saved, friction_law=friction_law)


def _summarize(windows: pd.DataFrame, trials: pd.DataFrame, warnings: list[WarningRecord], *,
               n_boot: int, seed: int, confidence: float, n_saved: int, friction_law: str
               ) -> StudySummary:
    """:func:`summarize_study` within its collector of warnings (*warnings*)."""
    facts = _trial_facts(trials)
    tables = _Tables()
    window_mu: list[pd.Series] = []
    mu_change: dict[TrialKey, float] = {}
    if not windows.empty:
        tagged = windows.assign(
            waveform=windows.waveform.fillna(""),
            frequency_Hz=[facts.frequency_of.get((s, t), _NO_FREQUENCY)
                          for s, t in zip(windows.subject, windows.trial, strict=True)])
        for subject, sub in tagged.groupby("subject", sort=True):
            try:
                found = _estimate_subject(str(subject), sub, facts, n_boot=n_boot,
                                          seed=seed, confidence=confidence,
                                          friction_law=friction_law)
            except AnalysisError as err:
                emit("no-force", Scope(str(subject)), error=str(err))
                continue
            if found is None:
                continue
            window_mu.append(found.window_mu)
            mu_change.update({(subject, t): d.change_per_10s for t, d in found.drifts.items()})
            _add_points(tables, str(subject), found, shown=facts.shown, n_saved=n_saved)
            _add_power_laws(tables, str(subject), found.est, points=found.points,
                            shown=facts.shown, confidence=confidence)
    electrostatic = pd.DataFrame(tables.electrostatic, columns=list(ELECTROSTATIC_COLUMNS))
    implausible_rows(electrostatic)
    crosstalk_notes(trials)
    boot = (pd.concat(tables.bootstrap, ignore_index=True)
            .reindex(columns=list(BOOTSTRAP_COLUMNS)) if tables.bootstrap
            else pd.DataFrame(columns=list(BOOTSTRAP_COLUMNS)))
    return StudySummary(
        electrostatic, pd.DataFrame(tables.exponents, columns=list(EXPONENT_COLUMNS)), boot,
        list(warnings),
        pd.concat(window_mu) if window_mu else pd.Series(dtype=float), mu_change)


def summarize(windows: pd.DataFrame, trials: pd.DataFrame, *, n_boot: int = DEFAULT_N_BOOT,
              seed: int = 0, confidence: float = 0.95, n_saved: int = N_BOOTSTRAP_SAVED,
              friction_law: str = "auto"
              ) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame, list[WarningRecord]]:
    """:func:`summarize_study`'s tables and warnings.

    Parameters
    ----------
    windows, trials : pandas.DataFrame
        As :func:`summarize_study`'s.
    n_boot : int
        Bootstrap replicates.
    seed : int
        Base seed.
    confidence : float
        Coverage of the intervals.
    n_saved : int
        Replicates kept in the bootstrap table.
    friction_law : str
        As :func:`summarize_study`'s.

    Returns
    -------
    electrostatic, exponents, bootstrap : pandas.DataFrame
    warnings : list of WarningRecord
    """
    out = summarize_study(windows, trials, n_boot=n_boot, seed=seed, confidence=confidence,
                          n_saved=n_saved, friction_law=friction_law)
    return out.electrostatic, out.exponents, out.bootstrap, out.warnings


__all__ = ["BOOTSTRAP_COLUMNS", "ELECTROSTATIC_COLUMNS", "EXPONENT_COLUMNS", "LAW_COLUMNS",
           "MIN_WINDOWS",
           "N_BOOTSTRAP_SAVED", "StudySummary", "summarize", "summarize_study"]
