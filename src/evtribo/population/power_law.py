"""One drive's population: the primary model's rows (every subject in), the subjects it names
as far from the others with its rows without each, and the meta-analysis of log F_el at the
amplitudes where it is valid.

Rows of population.csv, by ``analysis``:

``primary``
    The model study.toml's ``[population] model`` chooses (:mod:`evtribo.population.models`),
    every subject's cells in. The default, ``mixed``, is the nonlinear mixed model of the
    power law across subjects on the linear scale (:mod:`evtribo.population.models.mixed`),
    negative cells included: the population's F_el at each amplitude measured (its power law
    there: the geometric mean over subjects), the exponent and the prefactor (F_el at 1 V),
    each with its prediction interval for a new subject, the between-subject SD with its
    interval and I^2, and the convergence checks.
``without <subject>``
    The same model without a subject it names as far from the others (for the mixed model:
    its own power law, level or exponent, outside the others' prediction interval;
    :func:`~evtribo.population.stats.find_outliers`): how much the estimates lean on it.
    Nobody is left out of the primary rows.
``meta-analysis``
    The random-effects meta-analysis of log F_el at one amplitude, where it is valid
    (:mod:`evtribo.population.models.meta`): the second method, unless it is the primary
    one; the only one of a drive of fewer amplitudes than the primary model needs.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence
from typing import Any

from evtribo.population.data import (
    META,
    PRIMARY,
    Collector,
    Condition,
    SubjectData,
    condition_label,
    drive_scope,
)
from evtribo.population.models import (
    DEFAULT_MODEL,
    META_ANALYSIS,
    MODELS,
    DriveCells,
    ModelFit,
    PopulationModel,
)
from evtribo.population.nonlinear import NonlinearData, nonlinear_data
from evtribo.population.stats import MIN_SUBJECTS
from evtribo.warning.collect import emitter
from evtribo.warning.record import WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["condition_estimates"]


def _data(subjects: Sequence[SubjectData], condition: Condition) -> NonlinearData | None:
    names, cells = [], []
    for s in subjects:
        lu, f, cov = s.on_linear_scale(condition)
        if f.size:
            names.append(s.name)
            cells.append((lu, f, cov))
    return nonlinear_data(names, cells) if names else None


def _add(rows: Collector, cells: DriveCells, fit: ModelFit, analysis: str) -> None:
    for row in fit.rows:
        rows.add_row(cells.condition, row, analysis=analysis)


def _records(said: Iterable[Any], cells: DriveCells, model: PopulationModel
             ) -> list[WarningRecord]:
    """What a model said of a drive, as records (a plug-in's text as a
    ``population-model-note``)."""
    return [s if isinstance(s, WarningRecord) else emit.record(
        "population-model-note", drive_scope(cells.condition), model=model.name, text=str(s))
        for s in said]


def _fitted(rows: Collector, cells: DriveCells, model: PopulationModel) -> ModelFit | None:
    """The model fitted to *cells*, what it said of them kept with the population's."""
    said: list[Any] = []
    fit = model.fit(cells, said)
    rows.notes += _records(said, cells, model)
    return fit


def _second(rows: Collector, cells: DriveCells, model: PopulationModel) -> None:
    """The meta-analysis's rows, where it is not the primary model."""
    if model is not META_ANALYSIS:
        _add(rows, cells, META_ANALYSIS.fit(cells, []), META)


def _far(rows: Collector, cells: DriveCells, model: PopulationModel, fit: ModelFit
         ) -> list[str]:
    """The subjects the model names as far from the others, flagged; named, never left
    out."""
    far: list[str] = []
    for named in model.far(fit, cells, rows.alpha):
        rows.flag(named.quantity, named.found, named.unit)
        far += [o.subject for o in named.found if o.subject not in far]
    return far


def condition_estimates(rows: Collector, subjects: Sequence[SubjectData],
                        condition: Condition, model: PopulationModel | None = None) -> None:
    """Every row of *condition*: the primary model's, without each subject far from the
    others, and the meta-analysis's where valid.

    Parameters
    ----------
    rows : Collector
        Where the rows, notes, subjects far from the others and lines go.
    subjects : sequence of SubjectData
        Every subject of the study (but those excluded beforehand).
    condition : (str, float)
        The waveform and drive frequency, Hz.
    model : PopulationModel, optional
        The primary model (default: the mixed model).

    Returns
    -------
    None
    """
    model = MODELS[DEFAULT_MODEL] if model is None else model
    label = condition_label(*condition)
    data = _data(subjects, condition)
    amps = sorted({float(a) for s in subjects
                   for a in s.linear["amplitude_V"].to_numpy(float)[s.select_linear(condition)]})
    scope = drive_scope(condition)
    if data is None or data.k < MIN_SUBJECTS:
        rows.notes.append(emit.record("population-drive-few", scope, drive=label,
                                      subjects=0 if data is None else data.k,
                                      needed=MIN_SUBJECTS))
        return
    cells = DriveCells(condition, list(subjects), data, amps, label)
    if len(amps) < model.min_amplitudes:
        rows.notes.append(emit.record("population-one-amplitude", scope, drive=label)
                          if len(amps) == 1 else
                          emit.record("population-amplitudes-few", scope, drive=label,
                                      amplitudes=len(amps), model=model.name,
                                      needed=model.min_amplitudes))
        _second(rows, cells, model)
        return
    fit = _fitted(rows, cells, model)
    if fit is None:
        _second(rows, cells, model)
        return
    rows.notes += _records(fit.notes, cells, model)
    if fit.line is not None:
        rows.lines[condition] = fit.line
    if fit.modes:
        rows.subject_lines[condition] = dict(fit.modes)
    _add(rows, cells, fit, PRIMARY)
    far = _far(rows, cells, model, fit)
    rows.far[condition] = set(far)
    for name in far:
        rest = cells.without(name)
        if rest.data.k < MIN_SUBJECTS:
            continue
        other = _fitted(rows, rest, model)
        if other is not None:
            _add(rows, rest, other, f"without {name}")
    _second(rows, cells, model)
