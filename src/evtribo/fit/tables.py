"""The result folder as compare reads it, and the bootstrap replicates of its forces as a
matrix (:func:`replicate_matrix`).

The folder is :class:`evtribo.documents.result_folder.ResultFolder` (:data:`ResultTables`
names it here, :data:`read_results` its reader, for the modules that still import them from
here): analyze's tables and ``summary.json``, read only if the folder is one analysis's
complete results. The tables' columns, the ones compare needs, and the one typing are in
:mod:`evtribo.documents.tables`.

Besides the §2 tables the comparison reads an optional ``sine_trace.csv``: the raw signals of
one sine trial, for the friction-versus-time figure (the seed paper's Figure 5; its columns
:data:`~evtribo.documents.tables.SINE_TRACE`: a ``voltage_V`` column, the instantaneous
voltage, may stand in for the drive's amplitude and frequency, the sine's phase then taken as
the one that best matches the measured friction), and an optional
``electrostatic_bootstrap.csv`` (:data:`~evtribo.documents.tables.BOOTSTRAP`): bootstrap
replicates of every electrostatic.csv row, replicate ``i`` of one subject's rows coming from
one resampling of its windows. :mod:`evtribo.fit.fit` refits the model to them for its
intervals, and falls back to the Jacobian when the file is absent.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from evtribo.documents.result_folder import (
    ResultFolder,
    check_analysis,
    check_out_folder,
    folder_summary,
)

__all__ = ["MIN_REPLICATES", "ResultTables", "check_analysis", "check_out_folder",
           "read_results", "read_summary", "replicate_matrix"]

#: A result folder's tables (:class:`~evtribo.documents.result_folder.ResultFolder`).
ResultTables = ResultFolder
#: Read a result folder as compare reads it
#: (:meth:`~evtribo.documents.result_folder.ResultFolder.open`).
read_results = ResultFolder.open
#: A result folder's summary.json
#: (:func:`~evtribo.documents.result_folder.folder_summary`).
read_summary = folder_summary

#: Fewest replicates :func:`replicate_matrix` accepts.
MIN_REPLICATES = 20


def replicate_matrix(rows: pd.DataFrame, bootstrap: pd.DataFrame | None,
                     max_replicates: int = 200) -> NDArray[np.float64] | None:
    """The bootstrap replicates of *rows*' forces as a matrix (None when some row has none).

    Parameters
    ----------
    rows : DataFrame
        One subject's rows of ``electrostatic.csv``.
    bootstrap : DataFrame or None
        The subject's rows of ``electrostatic_bootstrap.csv``.
    max_replicates : int
        Replicates kept (the first ones).

    Returns None as well with fewer than :data:`MIN_REPLICATES` complete replicates, and
    when two rows share a waveform, frequency and amplitude (their replicates cannot be told
    apart).

    Returns
    -------
    ndarray, shape (n_replicates, len(rows)), N, or None
    """
    if bootstrap is None or bootstrap.empty or rows.empty:
        return None

    def keys(df: pd.DataFrame) -> pd.MultiIndex:
        freq = (df["frequency_Hz"].to_numpy(float) if "frequency_Hz" in df.columns
                else np.full(len(df), np.nan))  # a row per frequency, each its replicates
        return pd.MultiIndex.from_arrays(
            [df["waveform"].fillna("").astype(str).to_numpy(),
             np.nan_to_num(np.round(freq, 6), nan=-1.0),
             np.round(df["amplitude_V"].to_numpy(float), 6)])

    boot = bootstrap.assign(_key=keys(bootstrap))
    wide = boot.pivot_table(index="replicate", columns="_key",
                            values="electrostatic_force_N", aggfunc="first")
    want = list(keys(rows))
    if len(set(want)) < len(want) or any(k not in wide.columns for k in want):
        return None
    mat = wide[want].to_numpy(float)
    mat = mat[np.all(np.isfinite(mat), axis=1)][:max_replicates]
    return mat if mat.shape[0] >= MIN_REPLICATES else None
