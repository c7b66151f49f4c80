"""``[population] model = "meta-analysis"``: the random-effects meta-analysis of log F_el at
each amplitude, where it is valid (:func:`~evtribo.population.stats.pool`).

Valid at an amplitude where every subject measured there has a force whose 95 % interval
lies above zero and whose standard error on the log scale is at most
:data:`META_MAX_LOG_SE` (else a cell's log standard error, its interval's width over the
force, would be correlated with how high it came out, and the weights would favour cells that
came out high), and at least three subjects are. It is the second method of every drive
whatever the primary model (population.csv's ``analysis`` ``meta-analysis``), and the only
one of a drive of one amplitude; chosen as the primary model, its rows are the primary ones
(F_el at each amplitude, no power law), and an amplitude where it is not valid is said.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from evtribo.population.data import ModelRow, drive_scope
from evtribo.population.models.interface import DriveCells, FarSubjects, ModelFit
from evtribo.population.stats import MIN_SUBJECTS, POOL_METHOD, pool
from evtribo.warning.collect import emitter

__all__ = ["META_MAX_LOG_SE", "MetaAnalysis"]

emit = emitter(__name__)

#: The largest standard error of a cell's log F_el for the meta-analysis of log F_el.
META_MAX_LOG_SE = 0.2


class MetaAnalysis:
    """The meta-analysis of log F_el at each amplitude."""

    name = "meta-analysis"
    min_amplitudes = 1

    def fit(self, cells: DriveCells, notes: list[Any]) -> ModelFit:
        """The pooled log F_el at each amplitude where the meta-analysis is valid.

        Parameters
        ----------
        cells : DriveCells
        notes : list
            Where an amplitude without a valid meta-analysis is said (a record, made and
            not said).

        Returns
        -------
        ModelFit
        """
        rows = []
        for amp in cells.amplitudes:
            y, v, names, valid = [], [], [], True
            for s in cells.subjects:
                idx = s.select_linear(cells.condition)
                hit = idx[np.isclose(s.linear["amplitude_V"].to_numpy(float)[idx], amp)]
                if not hit.size:
                    continue
                cell = s.linear.iloc[hit[0]]
                f, lo, hi = (float(cell["force_N"]), float(cell["ci_low_N"]),
                             float(cell["ci_high_N"]))
                se = (math.log(hi) - math.log(lo)) / (2 * 1.959964) if lo > 0 else math.inf
                valid &= lo > 0 and se <= META_MAX_LOG_SE
                names.append(s.name)
                y.append(math.log(f) if f > 0 else math.nan)
                v.append(se * se)
            if not valid or len(names) < MIN_SUBJECTS:
                scope = drive_scope(cells.condition)
                notes.append(emit.record(
                    "population-meta-few", scope, drive=cells.label, amplitude_V=amp,
                    subjects=len(names), needed=MIN_SUBJECTS) if valid else emit.record(
                    "population-meta-invalid", scope, drive=cells.label, amplitude_V=amp,
                    max_log_se=META_MAX_LOG_SE))
                continue
            rows.append(ModelRow.pooled("electrostatic_force_N", amp,
                                        pool(np.array(y), np.array(v)),
                                        method=f"{POOL_METHOD}, of log F_el", log=True))
        return ModelFit(rows)

    def far(self, fit: ModelFit, cells: DriveCells, alpha: float) -> list[FarSubjects]:
        """None named: the meta-analysis's rows are each one amplitude's.

        Parameters
        ----------
        fit : ModelFit
        cells : DriveCells
        alpha : float

        Returns
        -------
        list of FarSubjects
            Empty.
        """
        return []
