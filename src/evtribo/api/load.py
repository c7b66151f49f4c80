"""A result folder read back from Python: :func:`load_results`, with the fit when
``evtribo compare`` has fitted it (:class:`evtribo.api.fit.Fit`)."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import pandas as pd

from evtribo.api.fit import Fit
from evtribo.api.results import _TABLES, Results, read_table
from evtribo.documents.fit import read_fit
from evtribo.errors import UserInputError
from evtribo.fit.tables import check_analysis, check_out_folder, read_summary
from evtribo.results.outputs import FIT_CSV, FIT_JSON, SUMMARY_FILE
from evtribo.store.files import sha256_file
from evtribo.store.resultdir import locked, pending, recover

__all__ = ["load_results"]


def load_results(out: str | os.PathLike[str]) -> Results:
    """Read a result folder written by ``evtribo analyze`` (or :meth:`Results.save`).

    Parameters
    ----------
    out : path-like
        The result folder.

    Returns
    -------
    Results
        The same tables as :func:`analyze` gave, with :attr:`Results.out` set and
        :attr:`Results.fit` when ``evtribo compare`` has fitted these results.

    Raises
    ------
    UserInputError
        No such folder, or it holds no analysis (no ``summary.json``), or a table is missing
        or lacks a column.
    ResultFolderError
        The folder is not one analysis's complete results (a table changed since, or of
        another analysis): run the analysis again with ``--force``.
    OutputBusyError
        Another process is writing the folder.
    """
    folder = check_out_folder(Path(out))
    if pending(folder):  # a write interrupted after its commit: finish it first
        with locked(folder, "evtribo (reading results)"):
            recover(folder)
    summary = read_summary(folder)
    if not summary.data:
        raise UserInputError("missing: the folder holds no results of evtribo analyze (run "
                             f"`evtribo analyze STUDY --out {folder}`)",
                             path=folder / SUMMARY_FILE)
    check_analysis(folder, summary)
    tables: dict[str, pd.DataFrame | None] = {}
    for name, (file, columns) in _TABLES.items():
        path = folder / file
        if path.is_file():
            tables[name] = read_table(path, columns)
        elif name in ("bootstrap", "sine_trace"):
            tables[name] = None
        else:
            raise UserInputError("missing: not a complete result folder of evtribo analyze",
                                 path=path)
    results = Results(_required(tables, "trials"), _required(tables, "windows"),
                      _required(tables, "electrostatic"), _required(tables, "exponents"),
                      summary=summary.data, bootstrap=tables["bootstrap"],
                      sine_trace=tables["sine_trace"], out=folder)
    results.fit = _fit_of(folder, results)
    return results


def _required(tables: dict[str, pd.DataFrame | None], name: str) -> pd.DataFrame:
    table = tables[name]
    assert table is not None
    return table


def _fit_of(folder: Path, results: Results) -> Fit | None:
    """The folder's fit when ``evtribo compare`` fitted these results (a warning and None
    when its fit is of another analysis, or its fit.csv changed since)."""
    if not (folder / FIT_JSON).is_file():
        return None
    doc = read_fit(folder / FIT_JSON)
    run_id = results.summary.get("run_id")
    recorded = (doc.get("output_sha256") or {}).get(FIT_CSV)
    if doc.get("run_id") != run_id:
        why = f"it fitted analysis {doc.get('run_id')}, not these results ({run_id})"
    elif not (folder / FIT_CSV).is_file():
        why = f"{FIT_CSV} is missing"
    elif recorded is not None and sha256_file(folder / FIT_CSV) != recorded:
        why = f"{FIT_CSV} changed since compare wrote it"
    else:
        return Fit.from_folder(folder, doc, results)
    warnings.warn(f"{folder / FIT_JSON}: not used ({why}); run `evtribo compare {folder} "
                  "--force` to fit these results", UserWarning, stacklevel=3)
    return None
