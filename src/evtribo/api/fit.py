"""The seed paper's model fitted to a study's results, from Python: :func:`compare`.

The fit is ``evtribo compare``'s (:func:`evtribo.compare.fit.fit_study`, its table
:func:`evtribo.compare.fit_csv.fit_table`), made in memory from the :class:`Results`; the
figures are drawn by the plot functions of :mod:`evtribo.compare.plots` and kept as
matplotlib figures. :meth:`Fit.save` runs ``evtribo compare`` on the results' folder, which
writes ``fit.csv``, ``fit.json`` and the figure files.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from evtribo.analysis.outputs import FIGURES, FIT_CSV
from evtribo.api.results import CSV_EXACT, Results, typed_table
from evtribo.compare.fit import SubjectFit, fit_study
from evtribo.compare.fit_csv import fit_table
from evtribo.compare.params import load_parameters, resolve_fit_names
from evtribo.compare.plots import (
    plot_area_increase,
    plot_electrostatic_force,
    plot_friction_normal_force,
    plot_friction_time,
    safe_name,
)
from evtribo.compare.run import compare as compare_folder
from evtribo.compare.tables import ResultTables
from evtribo.documents.fit import FitDocument, read_fit
from evtribo.documents.summary import Summary
from evtribo.errors import UserInputError

__all__ = ["FIT_TEXT_COLUMNS", "Fit", "compare"]

#: The text columns of ``fit.csv`` (the others are numbers).
FIT_TEXT_COLUMNS = ("subject", "parameter", "unit", "waveform")


@dataclass(eq=False)
class Fit:
    """The model fitted to a study's results.

    Attributes
    ----------
    table : pandas.DataFrame
        ``fit.csv``: one row per subject and fitted parameter (value, 95 % interval, unit,
        goodness of fit, measured and model exponents).
    figures : dict of str to matplotlib.figure.Figure
        The comparison figures, by file stem (``electrostatic_force_P01``,
        ``area_increase``...); empty for a fit read from a folder (its files are in
        :attr:`files`).
    records : list of dict
        One per figure: ``kind``, ``title``, ``stem``, ``subject``, ``caption``.
    fits : list of SubjectFit
        Each subject's fit in full (parameters, correlation, residuals); empty for a fit
        read from a folder (``fit.json`` holds them).
    fitted : tuple of str
        The parameters fitted per subject (``("h_L",)``).
    params_file : Path or None
        The TOML file of fixed parameters (None: the paper's Table 1).
    out : Path or None
        The result folder where ``fit.csv`` and the figures are (None: in memory only).
    files : dict of str to list of Path
        The figure files written, by stem (empty in memory).
    """

    table: pd.DataFrame
    figures: dict[str, Figure]
    records: list[dict[str, Any]]
    fits: list[SubjectFit]
    fitted: tuple[str, ...]
    params_file: Path | None = None
    out: Path | None = None
    files: dict[str, list[Path]] = field(default_factory=dict)
    _results: Results | None = field(default=None, repr=False)

    @classmethod
    def from_folder(cls, folder: str | os.PathLike[str], doc: FitDocument | None = None,
                    results: Results | None = None) -> Fit:
        """The fit ``evtribo compare`` wrote into a result folder.

        Parameters
        ----------
        folder : path-like
            The result folder.
        doc : FitDocument, optional
            Its ``fit.json``, as read (read here when None).
        results : Results, optional
            The results it fitted.

        Returns
        -------
        Fit
            With :attr:`figures` and :attr:`fits` empty and :attr:`files` listing the
            figure files.

        Raises
        ------
        ResultFolderError
            ``fit.json`` is damaged.
        UserInputError
            ``fit.csv`` cannot be read.
        """
        folder = Path(folder)
        doc = read_fit(folder / "fit.json") if doc is None else doc
        try:
            table = pd.read_csv(folder / FIT_CSV, dtype=dict.fromkeys(FIT_TEXT_COLUMNS, str),
                                keep_default_na=False, na_values=[""], **CSV_EXACT)
        except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError) as err:
            raise UserInputError(f"cannot read this CSV table: {err}",
                                 path=folder / FIT_CSV) from err
        records = [dict(r) for r in doc.get("figures") or [] if isinstance(r, dict)]
        pfile = doc.get("parameters_file")
        return cls(table=typed_table(table, text=FIT_TEXT_COLUMNS), figures={},
                   records=records, fits=[], fitted=tuple(doc.get("fit") or ()),
                   params_file=Path(pfile["path"]) if isinstance(pfile, dict) else None,
                   out=folder, files=_files(folder, records), _results=results)

    def __repr__(self) -> str:
        where = "in memory" if self.out is None else f"in {str(self.out)!r}"
        subjects = list(dict.fromkeys(self.table["subject"]))
        return (f"Fit({'+'.join(self.fitted)} of {subjects!r}, {where}, "
                f"{len(self.records)} figures)")

    def save(self, *, force: bool = False) -> Path:
        """Write the fit into the results' folder: ``evtribo compare OUT`` with the same
        parameters (``fit.csv``, ``fit.json``, ``figures/``).

        Parameters
        ----------
        force : bool
            Replace the outputs of a previous comparison in the folder.

        Returns
        -------
        Path
            The result folder.

        Raises
        ------
        UserInputError
            The results are in memory only (save them first: ``results.save(OUT)``).
        OutputExistsError
            The folder holds a comparison and *force* is False.
        OutputBusyError
            Another process is writing the folder.
        """
        results = self._results
        if results is None or results.out is None:
            raise UserInputError("the results of this fit are in memory only; save them "
                                 "first (results.save(OUT)), then fit.save()")
        compare_folder(results.out, fit=self.fitted, params=self.params_file, force=force)
        written = Fit.from_folder(results.out, results=results)
        self.out, self.files, self.records = written.out, written.files, written.records
        results.fit = self
        return results.out


def _files(folder: Path, records: list[dict[str, Any]]) -> dict[str, list[Path]]:
    """The figure files in *folder* of each record, by stem."""
    out: dict[str, list[Path]] = {}
    for r in records:
        stem = str(r.get("stem"))
        found = sorted((folder / FIGURES).glob(f"{stem}.*"))
        out[stem] = [p for p in found if p.stem == stem]
    return out


def _tables(results: Results) -> ResultTables:
    """The results as compare reads a result folder."""
    if results.electrostatic.empty:
        raise UserInputError("no electrostatic results (no ON data?): nothing to compare",
                             path=None if results.out is None
                             else results.out / "electrostatic.csv")
    return ResultTables(out=results.out or Path(), electrostatic=results.electrostatic,
                        windows=results.windows, exponents=results.exponents,
                        trials=results.trials, summary=Summary(dict(results.summary)),
                        sine_trace=results.sine_trace, bootstrap=results.bootstrap)


def _record(kind: str, stem: str, subject: str | None, caption: str) -> dict[str, Any]:
    title = kind.replace("_", " ").capitalize() + (f", {subject}" if subject else "")
    return {"kind": kind, "title": title, "stem": stem, "subject": subject,
            "caption": caption}


def _figures(tables: ResultTables, fits: list[SubjectFit]
             ) -> list[tuple[dict[str, Any], Axes]]:
    """The comparison figures: per subject F_el vs U and friction vs normal force, then the
    friction over time of a sine trial and the contact area's increase."""
    out = []
    es, win = tables.electrostatic, tables.windows
    for f in fits:
        s, stem = f.subject, safe_name(f.subject)
        out.append((_record("electrostatic_force", f"electrostatic_force_{stem}", s,
                            "Inferred electrostatic force (95 % intervals) and the fitted "
                            "model at the subject's mean normal force ON."),
                    plot_electrostatic_force(es[es["subject"] == s], f.params, subject=s)))
        out.append((_record("friction_normal_force", f"friction_normal_force_{stem}", s,
                            "Steady-sliding windows OFF and ON and the model (eq. 5)."),
                    plot_friction_normal_force(win[win["subject"] == s], f.params,
                                               subject=s)))
    trace = tables.sine_trace
    pick = fits[0]
    if trace is not None and not trace.empty:
        first = trace["trial"].astype(str) == str(trace["trial"].iloc[0])
        trace = trace[first & (trace["subject"].astype(str) == str(trace["subject"].iloc[0]))]
        pick = next((f for f in fits if f.subject == str(trace["subject"].iloc[0])), pick)
    sine = es[es["waveform"].astype(str) == "sine"]
    amp = float(sine["amplitude_V"].max()) if not sine.empty else 140.0
    fn = float(np.nanmean(es["normal_force_on_N"].to_numpy(float)))
    out.append((_record("friction_time", "friction_time", None,
                        "Friction with the voltage ON and OFF, measured sine trial and "
                        "model (model only without a measured trace)."),
                plot_friction_time(trace, pick.params, amplitude=amp, normal_force=fn,
                                   subject=pick.subject)))
    mean_fn = {f.subject: float(np.nanmean(es.loc[es["subject"] == f.subject,
                                                  "normal_force_on_N"].to_numpy(float)))
               for f in fits}
    out.append((_record("area_increase", "area_increase", None,
                        "JKR over Hertz contact area at each subject's mean normal force "
                        "ON with the fitted parameters."),
                plot_area_increase(mean_fn, {f.subject: f.params for f in fits},
                                   u_max=max(150.0, float(es["amplitude_V"].max())))))
    return out


def compare(results: Results, fit: str | Iterable[str] | None = ("h_L",), *,
            params: str | os.PathLike[str] | None = None) -> Fit:
    """Fit the seed paper's model to each subject's electrostatic forces, in memory.

    The same fit as ``evtribo compare`` (weighted least squares, intervals from refits to
    the bootstrap replicates); nothing is written: :meth:`Fit.save` writes it once the
    results are in a folder.

    Parameters
    ----------
    results : Results
        From :func:`evtribo.analyze` or :func:`evtribo.load_results`.
    fit : str or iterable of str, optional
        The parameters fitted per subject (``"h_L,E_star"`` or ``("h_L", "E_star")``);
        None: ``("h_L",)``.
    params : path-like, optional
        TOML file of fixed parameters in SI units (the paper's Table 1 for the others).

    Returns
    -------
    Fit
        Also set as ``results.fit``.

    Raises
    ------
    ConfigError
        An unknown parameter name, or a bad parameter file.
    UserInputError
        The results hold no electrostatic force (no ON data).
    AnalysisError
        A fit cannot be made.
    """
    names = resolve_fit_names(fit)
    base = load_parameters(None if params is None else Path(params))
    tables = _tables(results)
    fits = fit_study(tables, base, names)
    figures = _figures(tables, fits)
    out = Fit(table=typed_table(fit_table(fits, tables), text=FIT_TEXT_COLUMNS),
              figures={r["stem"]: ax.figure for r, ax in figures if isinstance(ax.figure,
                                                                                Figure)},
              records=[r for r, _ in figures], fits=fits, fitted=names,
              params_file=None if params is None else Path(params), _results=results)
    results.fit = out
    return out
