"""``compare --models``: the candidate models fitted to every subject, ``models.csv``'s table,
and what compare notes of them (the study's verdict, fits that failed, parameters left at a
bound, subjects whose drives were each measured at one frequency).

:func:`compare_models` computes; compare's writer writes the table
(:func:`evtribo.report.compare.run_comparison`), and its figures of F_el against the drive's
frequency (kind ``frequency_response``) are drawn for the subjects with a drive measured at
:data:`MIN_FREQUENCIES` frequencies or more (:func:`frequencies_of`); with fewer, the models
are told apart by the voltage alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from evtribo.fit.models import ModelFit, fit_models, models_table, study_ranking, verdict
from evtribo.fit.tables import ResultTables
from evtribo.model.params import ModelParameters
from evtribo.warning.collect import emitter
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["MIN_FREQUENCIES", "ModelComparison", "compare_models", "frequencies_of",
           "models_text"]

#: Fewer drive frequencies than this: no figure of F_el against the frequency.
MIN_FREQUENCIES = 2

emit = emitter(__name__)


@dataclass(frozen=True)
class ModelComparison:
    """The candidate models compared over a study.

    Attributes
    ----------
    table : DataFrame
        ``models.csv`` (:data:`~evtribo.fit.models.MODELS_COLUMNS`).
    notes : list of WarningRecord
        What compare says of the comparison (made, not said: compare says them in its
        order; fit.json's warnings).
    fits : list of ModelFit
        Each candidate fitted to each subject (:func:`~evtribo.fit.models.fit_models`).
    """

    table: pd.DataFrame
    notes: list[WarningRecord]
    fits: list[ModelFit]


def compare_models(tables: ResultTables, models: Sequence[str],
                   base: ModelParameters) -> ModelComparison:
    """Fit the candidate *models* to each subject, rank them, and say what compare notes.

    Parameters
    ----------
    tables : ResultTables
        The result folder's tables.
    models : sequence of str
        Names of :data:`evtribo.fit.models.CANDIDATES` (validated).
    base : ModelParameters
        Starting values and the fixed parameters.

    Returns
    -------
    ModelComparison
        The table of ``models.csv``, the notes and the fits.
    """
    fits = fit_models(tables, models, base)
    table = models_table(fits)
    crit = {f.criterion for f in fits if f.params is not None}
    notes = []
    said = verdict(study_ranking(table))
    if said:
        notes.append(emit.record("models-ranked", criterion=models_text(crit), verdict=said))
    for subject in tables.subjects:
        notes += [emit.record("model-not-fitted", Scope(str(subject)), model=f.model,
                              subject=str(subject), why=f.note)
                  for f in fits if f.subject == str(subject) and f.params is None]
    bound: dict[tuple[str, str], list[str]] = {}
    for f in fits:
        for name in f.at_bound:
            bound.setdefault((f.model, name), []).append(f.subject)
    notes += [emit.record("model-at-bound", model=model, parameter=name,
                          subjects=", ".join(subjects))
              for (model, name), subjects in bound.items()]
    elec = tables.electrostatic
    few = [str(s) for s in tables.subjects if frequencies_of(
        elec[elec["subject"].astype(str) == str(s)]) < MIN_FREQUENCIES]
    if few:
        notes.append(emit.record("models-one-frequency", subjects=len(few)))
    return ModelComparison(table, notes, fits)


def frequencies_of(rows: pd.DataFrame) -> int:
    """How many drive frequencies the most swept drive (waveform and amplitude) of
    electrostatic.csv's rows was measured at.

    Parameters
    ----------
    rows : DataFrame
        Rows of ``electrostatic.csv``.

    Returns
    -------
    int
        0 without a known frequency; 1 when every drive had a single frequency (a square
        drive at 10 kHz and a sine at 10 Hz are two drives of one frequency each).
    """
    if rows.empty or "frequency_Hz" not in rows.columns:
        return 0
    f = pd.to_numeric(rows["frequency_Hz"], errors="coerce")
    known = rows.assign(_f=f)[np.isfinite(f.to_numpy(float)) & (f.to_numpy(float) > 0)]
    if known.empty:
        return 0
    per = known.groupby([known["waveform"].astype(str),
                         known["amplitude_V"].astype(float)])["_f"].nunique()
    return int(per.max())


def models_text(criteria: set[str]) -> str:
    """How models.csv's ``aic`` column was computed, for a note.

    Parameters
    ----------
    criteria : set of str
        Of ``"AIC"`` and ``"AICc"``.

    Returns
    -------
    str
    """
    if criteria == {"AICc"}:
        return "aic is the small-sample AICc: fewer than 40 points per parameter"
    if "AICc" in criteria:
        return ("aic is the small-sample AICc for the subjects with fewer than 40 points per "
                "parameter, AIC for the others")
    return "aic is AIC"
