"""The seed paper's model fitted to a study's results, from Python: :func:`compare`.

The fit is ``evtribo compare``'s (:func:`evtribo.fit.fit.fit_study`, its table
:func:`evtribo.fit.fit_csv.fit_table`), made in memory from the :class:`Results`; the
figures are drawn by the plot functions of :mod:`evtribo.figures.plots` and kept as
matplotlib figures. :meth:`Fit.save` runs ``evtribo compare`` on the results' folder, which
writes ``fit.csv``, ``fit.json`` and the figure files.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from evtribo.api.results import Results
from evtribo.documents.fit import FitDocument
from evtribo.documents.result_folder import ResultFolder
from evtribo.documents.tables import FIT, FIT_CSV, WINDOWS
from evtribo.errors import FORCE, UserInputError
from evtribo.figures.friction_only import friction_figures
from evtribo.figures.population_plots import draw_population
from evtribo.figures.style import journal_style
from evtribo.fit.fit import SubjectFit, fit_study
from evtribo.fit.fit_csv import fit_table
from evtribo.fit.params import load_parameters, resolve_fit_names
from evtribo.fit.tables import ResultTables
from evtribo.population.estimates import (
    CONTRAST_COLUMNS,
    POPULATION_COLUMNS,
    Population,
    PopulationOutlier,
    population,
)
from evtribo.population.exclusions import population_rule
from evtribo.report.compare import CompareResult, draw_figures
from evtribo.report.compare import compare as compare_folder
from evtribo.report.population import read_population
from evtribo.results.outputs import FIGURES

__all__ = ["FIT_TEXT_COLUMNS", "Fit", "compare"]

#: The text columns of ``fit.csv`` (the others are numbers: :data:`evtribo.documents.tables.FIT`).
FIT_TEXT_COLUMNS = tuple(c.name for c in FIT.columns if c.kind == "text")


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
    population : pandas.DataFrame
        ``population.csv`` (study format §10): the population's F_el at each amplitude,
        exponent, prefactor, μ and air gap with 95 % intervals and the between-subject
        spread; with fewer than three subjects with electrostatic forces, μ's row alone
        (three subjects with OFF windows, a study of OFF trials too) or empty (with its
        columns).
    population_contrasts : pandas.DataFrame
        ``population_contrasts.csv``: ratios and differences between conditions.
    population_notes : list of str
        What could not be estimated and why, and the subjects left out as outliers.
    """

    table: pd.DataFrame
    figures: dict[str, Figure]
    records: list[dict[str, Any]]
    fits: list[SubjectFit]
    fitted: tuple[str, ...]
    params_file: Path | None = None
    out: Path | None = None
    files: dict[str, list[Path]] = field(default_factory=dict)
    population: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=list(POPULATION_COLUMNS)))
    population_contrasts: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=list(CONTRAST_COLUMNS)))
    population_notes: list[str] = field(default_factory=list)
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
            ``fit.json`` is damaged, or ``fit.csv`` or a population table cannot be read.
        UserInputError
            ``fit.csv`` is missing.
        """
        folder = Path(folder)
        source = ResultFolder.compare_documents(folder) if results is None or \
            results.out != folder else results
        doc = source.fit_doc if doc is None else doc
        table = source.fit_table
        if table is None:
            raise UserInputError(f"missing beside fit.json; run `evtribo compare {folder} "
                                 f"{FORCE}`", path=folder / FIT_CSV)
        pfile = doc.parameters_file
        pop, contrasts = read_population(source)
        return cls(table=table, figures={}, records=doc.figures, fits=[],
                   fitted=tuple(doc.fit), params_file=None if pfile is None
                   else Path(pfile["path"]), out=folder, files=_files(folder, doc.figures),
                   population=_or_empty(pop, POPULATION_COLUMNS),
                   population_contrasts=_or_empty(contrasts, CONTRAST_COLUMNS),
                   population_notes=_population_notes(doc.population), _results=results)

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
        results.forget()  # compare's documents are new
        written = Fit.from_folder(results.out, results=results)
        self.out, self.files, self.records = written.out, written.files, written.records
        results.fit = self
        return results.out


def _or_empty(frame: pd.DataFrame | None, columns: tuple[str, ...]) -> pd.DataFrame:
    return pd.DataFrame(columns=list(columns)) if frame is None else frame


def _population_notes(doc: dict[str, Any]) -> list[str]:
    """fit.json's population notes, then one line per outlier."""
    notes = [str(n) for n in doc.get("notes") or []]
    for o in doc.get("outliers") or []:
        if isinstance(o, dict):
            notes.append(PopulationOutlier(str(o.get("subject")), str(o.get("quantity")),
                                           float(o.get("value") or math.nan),
                                           float(o.get("low") or math.nan),
                                           float(o.get("high") or math.nan),
                                           str(o.get("unit") or "")).describe())
    return notes


def _files(folder: Path, records: list[dict[str, Any]]) -> dict[str, list[Path]]:
    """The figure files in *folder* of each record, by stem."""
    out: dict[str, list[Path]] = {}
    for r in records:
        stem = str(r.get("stem"))
        found = sorted((folder / FIGURES).glob(f"{stem}.*"))
        out[stem] = [p for p in found if p.stem == stem]
    return out


def _comparable(results: Results) -> Results:
    """The results, refused when they hold no window at all."""
    if results.electrostatic.empty and results.windows.empty:
        raise UserInputError("no steady-sliding window in any trial (its summary says why): "
                             "nothing to compare", path=None if results.out is None
                             else results.out / WINDOWS.file)
    return results


class _Kept:
    """Keeps compare's figures in memory (the sink of
    :func:`~evtribo.report.compare.draw_figures`)."""

    def __init__(self, tables: ResultTables, fits: list[SubjectFit]) -> None:
        self.result = CompareResult(out=tables.out or Path(), fits=fits)
        self.drawn: list[tuple[dict[str, Any], Axes]] = []

    def emit(self, ax: Axes, kind: str, title: str, stem: str, *, subject: str | None = None,
             caption: str = "", extra: dict[str, Any] | None = None, **_: Any) -> None:
        self.drawn.append(({"kind": kind, "title": title, "stem": stem, "subject": subject,
                            "caption": caption, **(extra or {})}, ax))


def _figures(tables: ResultTables, fits: list[SubjectFit], names: tuple[str, ...],
             pop: Population) -> list[tuple[dict[str, Any], Axes]]:
    """compare's figures of the fit, in the journal style, as ``evtribo compare`` draws them
    (without the trial checks, which need the study, and the models')."""
    kept = _Kept(tables, fits)
    with journal_style("single"):
        if tables.electrostatic.empty:  # OFF trials only: each subject's friction
            friction_figures(tables, kept.emit)
        else:
            draw_figures(tables, fits, names, kept)
            draw_population(tables.electrostatic, pop, kept.emit)
    return kept.drawn


def compare(results: Results, fit: str | Iterable[str] | None = ("h_L",), *,
            params: str | os.PathLike[str] | None = None) -> Fit:
    """Fit the seed paper's model to each subject's electrostatic forces, in memory.

    The same fit as ``evtribo compare`` (weighted least squares, intervals from refits to
    the bootstrap replicates), and the population's estimates (``.population``, study
    format §10) with their figure; nothing is written: :meth:`Fit.save` writes it once the
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
        The results hold no window at all (results without electrostatic forces, a study
        of OFF trials, give an empty table and each subject's friction figure).
    AnalysisError
        A fit cannot be made.
    """
    names = resolve_fit_names(fit)
    base = load_parameters(None if params is None else Path(params))
    tables = _comparable(results)
    rule = population_rule(tables)
    fits = fit_study(tables, base, names)
    pop = population(tables, fits, exclude=rule.exclude, rule_notes=rule.notes,
                     model=rule.model)
    figures = _figures(tables, fits, names, pop)
    out = Fit(table=FIT.typed(fit_table(fits, tables)),
              figures={r["stem"]: ax.figure for r, ax in figures if isinstance(ax.figure,
                                                                                Figure)},
              records=[r for r, _ in figures], fits=fits, fitted=names,
              params_file=None if params is None else Path(params),
              population=pop.table, population_contrasts=pop.contrasts,
              population_notes=[*pop.notes, *(o.describe() for o in pop.outliers)],
              _results=results)
    results.fit = out
    return out
