"""``fit.csv``: one row per subject and fitted parameter, with the measured and the fitted
model's power-law exponents (written by :func:`evtribo.report.compare.compare`)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from evtribo.documents.tables import FIT
from evtribo.fit.fit import SubjectFit
from evtribo.fit.model_points import model_exponent
from evtribo.fit.tables import ResultTables

__all__ = ["FIT_COLUMNS", "fit_table"]

#: Columns of ``fit.csv``, one row per subject and fitted parameter
#: (:data:`evtribo.documents.tables.FIT`).
FIT_COLUMNS: tuple[str, ...] = FIT.names()


def _exponent_row(tables: ResultTables, subject: str) -> pd.Series | None:
    ex = tables.exponents[tables.exponents["subject"] == subject]
    if ex.empty:
        return None
    square = ex[ex["waveform"].astype(str).str.lower() == "square"]
    return (square if not square.empty else ex).iloc[0]


def fit_table(fits: Sequence[SubjectFit], tables: ResultTables) -> pd.DataFrame:
    """The rows of ``fit.csv`` (:data:`FIT_COLUMNS`) for *fits*.

    The exponent columns compare the measured power law of ``exponents.csv`` (the square
    wave's when the subject has one) with the fitted model's exponent over the same
    waveform's measured amplitude range, at the subject's mean normal force ON.

    Parameters
    ----------
    fits : sequence of SubjectFit
        The fits (:func:`~evtribo.fit.fit.fit_study`).
    tables : ResultTables
        The tables they were fitted to.

    Returns
    -------
    DataFrame
        One row per subject and fitted parameter.
    """
    records = []
    for f in fits:
        rows = tables.electrostatic[tables.electrostatic["subject"] == f.subject]
        ex = _exponent_row(tables, f.subject)
        waveform = str(ex["waveform"]) if ex is not None else str(rows["waveform"].iloc[0])
        sel = rows[rows["waveform"].astype(str) == waveform]
        sel = sel if not sel.empty else rows
        amps = sel["amplitude_V"].to_numpy(float)
        slope = model_exponent(float(np.nanmean(sel["normal_force_on_N"].to_numpy(float))),
                               float(np.nanmin(amps)), float(np.nanmax(amps)), f.params,
                               waveform)
        for e in f.estimates:
            records.append({
                "subject": f.subject, "parameter": e.name, "value": e.value,
                "ci_low": e.ci_low, "ci_high": e.ci_high, "stderr": e.stderr,
                "unit": e.unit, "rmse_N": f.rmse_N, "r2": f.r2,
                "chi2_reduced": f.chi2_reduced, "n_points": f.n_points,
                "waveform": waveform,
                "exponent": float(ex["exponent"]) if ex is not None else math.nan,
                "exponent_ci_low": float(ex["exponent_ci_low"]) if ex is not None
                else math.nan,
                "exponent_ci_high": float(ex["exponent_ci_high"]) if ex is not None
                else math.nan,
                "exponent_model": slope, "mu_measured": f.mu_measured})
    return pd.DataFrame.from_records(records, columns=list(FIT_COLUMNS))
