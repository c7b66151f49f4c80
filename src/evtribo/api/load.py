"""A result folder read back from Python: :func:`load_results`, with the fit when
``evtribo compare`` has fitted it (:class:`evtribo.api.fit.Fit`)."""

from __future__ import annotations

import os
import warnings

from evtribo.api.fit import Fit
from evtribo.api.results import Results
from evtribo.documents.fit import FIT_JSON
from evtribo.documents.tables import FIT_CSV
from evtribo.store.files import sha256_file

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
        The same tables as :func:`~evtribo.api.results.analyze` gave, with :attr:`Results.out` set
        and :attr:`Results.fit` when ``evtribo compare`` has fitted these results.

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
    results = Results.open(out, complete=True)
    results.fit = _fit_of(results)
    return results


def _fit_of(results: Results) -> Fit | None:
    """The folder's fit when ``evtribo compare`` fitted these results (a warning and None
    when its fit is of another analysis, or its fit.csv changed since)."""
    folder = results.out
    assert folder is not None
    if not (folder / FIT_JSON).is_file():
        return None
    doc = results.fit_doc
    run_id = results.summary.run_id
    recorded = doc.output_sha256.get(FIT_CSV)
    if doc.run_id != run_id:
        why = f"it fitted analysis {doc.run_id}, not these results ({run_id})"
    elif not (folder / FIT_CSV).is_file():
        why = f"{FIT_CSV} is missing"
    elif recorded is not None and sha256_file(folder / FIT_CSV) != recorded:
        why = f"{FIT_CSV} changed since compare wrote it"
    else:
        return Fit.from_folder(folder, doc, results)
    warnings.warn(f"{folder / FIT_JSON}: not used ({why}); run `evtribo compare {folder} "
                  "--force` to fit these results", UserWarning, stacklevel=3)
    return None
