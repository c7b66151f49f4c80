"""What journals ask of each subject and of the population besides the forces: the relative
friction increase, and whether each subject's F_el is above zero.

The relative friction increase at a voltage is ``100 F_el / F_n,ON`` (in %,
:func:`~evtribo.documents.quantities.friction_increase_pct`): with Coulomb friction, the
friction the voltage adds at the same normal force (eq. 5 of the seed paper: ``F_t = mu (F_n
+ F_el)``). Each subject's at each amplitude is its cell's F_el over its mean normal force
ON, with its interval scaled alike; the
population's is the random-effects mean over subjects on the linear scale (every subject in,
negative cells too: an arithmetic mean of percentages has no logarithm to lose).

Whether a subject responds: a one-sided test of ``F_el > 0`` per subject and condition, its
cells weighted as the seed paper's square law expects them to grow (``U^2``, eq. 13: the
most powerful direction when that law holds, and a valid test whatever the law, since the
weights do not look at the data): ``z = g'C^-1 F / sqrt(g'C^-1 g)`` with ``g_j = (U_j /
U_max)^2`` and C the cells' covariance, p from the standard normal. The p values of all the
study's tests are adjusted by Holm's step-down method (family-wise 5 %);
``population_subjects.csv`` gives each with its adjusted p and the verdict.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

# scipy.stats' distributions' functions are scipy.special's (the same numbers, without its import)
from scipy import special

from evtribo.documents.quantities import friction_increase_pct
from evtribo.documents.tables import POPULATION_SUBJECTS
from evtribo.population.data import PRIMARY, Collector, Condition, SubjectData, condition_label
from evtribo.population.stats import MIN_SUBJECTS
from evtribo.util.numbers import frequency, significant, voltage, with_interval

__all__ = ["HOLM_ALPHA", "INCREASE_METHOD", "SUBJECT_COLUMNS", "friction_increase", "holm",
           "subject_table", "subjects_view"]

#: Columns of population_subjects.csv (:data:`evtribo.documents.tables.POPULATION_SUBJECTS`).
SUBJECT_COLUMNS = POPULATION_SUBJECTS.names()
#: The family-wise level of the subjects' tests.
HOLM_ALPHA = 0.05
INCREASE_METHOD = ("random-effects meta-analysis on the linear scale (Paule-Mandel, "
                   "Hartung-Knapp) of each subject's F_el / F_n,ON in %: the mean over "
                   "subjects")
_Z95 = float(special.ndtri(0.975))


def _test(cells: pd.DataFrame, cov: np.ndarray) -> tuple[float, float]:
    """z and the one-sided p of ``F_el > 0`` for one subject's cells of a condition."""
    u = cells["amplitude_V"].to_numpy(float)
    g = (u / u.max()) ** 2
    w = np.linalg.solve(cov, g)
    z = float(w @ cells["force_N"].to_numpy(float)) / math.sqrt(float(w @ g))
    return z, float(special.ndtr(-z))


def holm(p: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjusted p-values (Holm 1979), in the order given.

    The adjustment of ``statsmodels.stats.multitest.multipletests(p, method="holm")``, the
    same numbers (``tests/population/test_population.py`` holds them to it): the sorted
    p-values times m, m - 1, ... 1, each at least the one before, at most 1. Not the
    library's call, which collects the garbage of the whole process on each call (0.04 s in
    a fresh process, more in one holding many objects; once per population estimated).

    Parameters
    ----------
    p : sequence of float
        One-sided p-values, NaN where a subject has none.

    Returns
    -------
    ndarray
        The adjusted p-values (NaN from the first NaN in sorted order on).
    """
    values = np.asarray(p, dtype=float)
    order = np.argsort(values)
    adjusted = np.maximum.accumulate(values[order] * np.arange(values.size, 0, -1))
    adjusted[adjusted > 1] = 1.0
    out = np.empty_like(adjusted)
    out[order] = adjusted
    return out


def subject_table(subjects: Sequence[SubjectData], conditions: Sequence[Condition]
                  ) -> pd.DataFrame:
    """population_subjects.csv: each subject's cells with its relative friction increase,
    and its test of ``F_el > 0`` per condition (Holm-adjusted over the study).

    Parameters
    ----------
    subjects : sequence of SubjectData
    conditions : sequence of (str, float)

    Returns
    -------
    DataFrame
        :data:`SUBJECT_COLUMNS`, a row per subject, condition and amplitude.
    """
    rows: list[dict[str, Any]] = []
    tests: list[tuple[int, int, float, float]] = []  # first row, rows, z, p
    for s in subjects:
        for cond in conditions:
            idx = s.select_linear(cond)
            if not idx.size:
                continue
            cells = s.linear.iloc[idx]
            z, p = _test(cells, s.linear_cov[np.ix_(idx, idx)])
            tests.append((len(rows), idx.size, z, p))
            for _, c in cells.iterrows():
                fn = float(c["normal_force_N"])
                force, low, high = (float(c[k]) for k in ("force_N", "ci_low_N", "ci_high_N"))
                rows.append({"subject": s.name, "waveform": cond[0], "frequency_Hz": cond[1],
                             "amplitude_V": float(c["amplitude_V"]),
                             "electrostatic_force_N": force, "ci_low_N": low,
                             "ci_high_N": high, "normal_force_N": fn,
                             "friction_increase_pct": friction_increase_pct(force, fn),
                             "increase_ci_low_pct": friction_increase_pct(low, fn),
                             "increase_ci_high_pct": friction_increase_pct(high, fn)})
    adjusted = holm([t[3] for t in tests]) if tests else np.zeros(0)
    for (first, n, z, p), p_adj in zip(tests, adjusted, strict=True):
        for r in rows[first:first + n]:
            r.update(z_positive=z, p_one_sided=p, p_holm=float(p_adj),
                     responds=bool(p_adj < HOLM_ALPHA))
    return pd.DataFrame(rows, columns=list(SUBJECT_COLUMNS))


def friction_increase(rows: Collector, table: pd.DataFrame, condition: Condition) -> None:
    """The population's relative friction increase at each amplitude of *condition* (rows
    ``friction_increase_pct``, every subject in).

    Parameters
    ----------
    rows : Collector
    table : DataFrame
        :func:`subject_table`'s.
    condition : (str, float)

    Returns
    -------
    None
    """
    label = condition_label(*condition)
    f = table["frequency_Hz"].to_numpy(float)
    same = np.isnan(f) if math.isnan(condition[1]) else np.isclose(f, condition[1])
    mine = table[(table["waveform"] == condition[0]) & same]
    for amp in sorted(set(mine["amplitude_V"].astype(float))):
        at = mine[np.isclose(mine["amplitude_V"].to_numpy(float), amp)]
        y = at["friction_increase_pct"].to_numpy(float)
        se = (at["increase_ci_high_pct"].to_numpy(float)
              - at["increase_ci_low_pct"].to_numpy(float)) / (2 * _Z95)
        ok = np.isfinite(y) & np.isfinite(se) & (se > 0)
        if ok.sum() < MIN_SUBJECTS:
            continue
        got = rows.pooled(f"friction increase at {amp:g} V, {label}",
                          list(at["subject"][ok]), y[ok], se[ok] ** 2, check=False)
        if got is not None:
            rows.add_pooled("friction_increase_pct", condition, amp, got[0],
                            method=INCREASE_METHOD, analysis=PRIMARY)


def subjects_view(subjects: pd.DataFrame) -> pd.DataFrame:
    """population_subjects.csv for people: per subject and condition, the relative friction
    increase at each amplitude (%, 95 % interval) and the test of F_el > 0.

    Parameters
    ----------
    subjects : DataFrame
        :func:`subject_table`'s (or population_subjects.csv as read).

    Returns
    -------
    DataFrame
        Text cells: ``subject``, ``condition``, one column per amplitude (``80 V``),
        ``p (Holm)`` and ``F_el > 0`` (``yes`` or ``not shown``).
    """
    amps = sorted({float(a) for a in subjects["amplitude_V"]})
    rows = []
    for (name, wave, freq), g in subjects.groupby(["subject", "waveform", "frequency_Hz"],
                                                  sort=False, dropna=False):
        row = {"subject": str(name), "condition": f"{wave} {frequency(freq)}"}
        for a in amps:
            hit = g[np.isclose(g["amplitude_V"].to_numpy(float), a)]
            row[voltage(a)] = "—" if hit.empty else with_interval(
                hit["friction_increase_pct"].iloc[0], hit["increase_ci_low_pct"].iloc[0],
                hit["increase_ci_high_pct"].iloc[0])
        p = float(g["p_holm"].iloc[0])
        row["p (Holm)"] = "< 0.001" if p < 0.001 else significant(p, 2)
        row["F_el > 0"] = "yes" if bool(g["responds"].iloc[0]) else "not shown"
        rows.append(row)
    return pd.DataFrame(rows, columns=["subject", "condition", *(voltage(a) for a in amps),
                                       "p (Holm)", "F_el > 0"])
