"""The seed paper's model fitted to a study's results, from Python: :func:`compare`.

The comparison is ``evtribo compare``'s, its sequence run in memory from the
:class:`Results` (:func:`evtribo.report.compare.run_comparison`: the fits, the trials'
checks, the population, the candidate models asked for), and its figures are those of the
figure registry (:mod:`evtribo.figures.registry`), kept as matplotlib figures.
:meth:`Fit.save` runs ``evtribo compare`` on the results' folder, which writes ``fit.csv``,
``fit.json``, ``models.csv`` and the figure files.
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
from evtribo.documents.tables import CONTRASTS, FIT, FIT_CSV, MODELS, POPULATION, WINDOWS
from evtribo.errors import FORCE, UserInputError
from evtribo.figures.registry import PlannedFigure
from evtribo.figures.style import journal_style
from evtribo.fit.fit import SubjectFit
from evtribo.population.estimates import (
    CONTRAST_COLUMNS,
    POPULATION_COLUMNS,
    PopulationOutlier,
)
from evtribo.population.exclusions import population_rule
from evtribo.report.compare import CompareSetup, run_comparison
from evtribo.report.compare import compare as compare_folder
from evtribo.report.population import read_population
from evtribo.results.outputs import FIGURES
from evtribo.warning.record import WarningRecord

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
    population_notes : list of WarningRecord
        What could not be estimated and why, then each subject far from the others
        (``population-outlier``): records (:class:`~evtribo.warning.record.WarningRecord`:
        ``kind``, ``effect``, ``text``...).
    models : pandas.DataFrame or None
        ``models.csv``: each candidate model fitted to each subject and ranked (None: no
        models compared).
    notes : list of WarningRecord
        What the comparison said, in the order said (fit.json's ``warnings``: the fits'
        parameters not determined, how the intervals were obtained, the population's
        notes, the models' ranking, figures left out and why), each a record
        (:class:`~evtribo.warning.record.WarningRecord`: ``kind``, ``effect``, ``text``,
        the subject or trial it concerns).
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
    population_notes: list[WarningRecord] = field(default_factory=list)
    models: pd.DataFrame | None = None
    notes: list[WarningRecord] = field(default_factory=list)
    _results: Results | None = field(default=None, repr=False)
    _asked: dict[str, Any] = field(default_factory=dict, repr=False)

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
                   population_notes=_population_notes(doc),
                   models=source.models, notes=doc.warnings, _results=results)

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
        compare_folder(results.out, fit=self.fitted, params=self.params_file, force=force,
                       **self._asked)
        results.forget()  # compare's documents are new
        written = Fit.from_folder(results.out, results=results)
        self.out, self.files, self.records = written.out, written.files, written.records
        self.notes = written.notes
        results.fit = self
        return results.out


def _or_empty(frame: pd.DataFrame | None, columns: tuple[str, ...]) -> pd.DataFrame:
    return pd.DataFrame(columns=list(columns)) if frame is None else frame


def _population_notes(doc: FitDocument) -> list[WarningRecord]:
    """fit.json's population's warnings, then one per outlier."""
    pop = doc.population
    texts = {str(n) for n in pop.get("notes") or []}
    notes = [w for w in doc.warnings if w.text in texts]
    for o in pop.get("outliers") or []:
        if isinstance(o, dict):
            notes.append(PopulationOutlier(str(o.get("subject")), str(o.get("quantity")),
                                           float(o.get("value") or math.nan),
                                           float(o.get("low") or math.nan),
                                           float(o.get("high") or math.nan),
                                           str(o.get("unit") or "")).record())
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
    """Keeps compare's figures in memory, drawn as they come, those to look at (a trial's
    check) after the others (the sink of :func:`~evtribo.report.compare.run_comparison`)."""

    def __init__(self) -> None:
        self.drawn: list[tuple[dict[str, Any], Axes]] = []
        self._late: list[tuple[dict[str, Any], Axes]] = []

    def emit(self, figure: PlannedFigure) -> None:
        record = {"kind": figure.spec.kind, "title": figure.title, "stem": figure.stem,
                  "subject": figure.subject, "caption": figure.caption, **figure.placed()}
        (self._late if figure.spec.screen else self.drawn).append(
            (record, figure.drawing.draw()))

    def figures(self) -> list[tuple[dict[str, Any], Axes]]:
        return [*self.drawn, *self._late]


def _models(table: pd.DataFrame | None) -> pd.DataFrame | None:
    """models.csv as compare computes it, typed as when read back (an empty name missing;
    None: no models compared)."""
    if table is None:
        return None
    text = [c.name for c in MODELS.columns if c.kind == "text" and c.name in table]
    return MODELS.typed(table.assign(**{c: table[c].mask(table[c].eq("")) for c in text}))


def compare(results: Results, fit: str | Iterable[str] | None = ("h_L",), *,
            params: str | os.PathLike[str] | None = None,
            models: str | Iterable[str] | None = None,
            trial_checks: bool | str | None = None) -> Fit:
    """Fit the seed paper's model to each subject's electrostatic forces, in memory.

    The same comparison as ``evtribo compare`` (weighted least squares, intervals from
    refits to the bootstrap replicates; the population's estimates, ``.population``, study
    format §10; the candidate models asked for, ranked, ``.models``) and the same figures,
    kept as matplotlib figures: the trials' checks too, from what the analysis kept of each
    or, where it kept nothing, from the study folder (when it is not there, a note says
    they are left out). Nothing is written: :meth:`Fit.save` writes it once the results
    are in a folder.

    Parameters
    ----------
    results : Results
        From :func:`evtribo.analyze` or :func:`evtribo.load_results`.
    fit : str or iterable of str, optional
        The parameters fitted per subject (``"h_L,E_star"`` or ``("h_L", "E_star")``);
        None: ``("h_L",)``.
    params : path-like, optional
        TOML file of fixed parameters in SI units (the paper's Table 1 for the others).
    models : str or iterable of str, optional
        Candidate models to fit and rank per subject (``"paper,hertz,maugis,circuit"``):
        ``.models`` and a ``frequency_response`` figure per subject with a drive at
        several frequencies.
    trial_checks : bool or str, optional
        Which trials' checks to draw: ``"all"`` (True), ``"none"`` (False), ``"auto"``
        (None: every trial of a small study, else those with a warning that may change a
        number or widens an interval).

    Returns
    -------
    Fit
        Also set as ``results.fit``.

    Raises
    ------
    ConfigError
        An unknown parameter or model name, or a bad parameter file.
    UserInputError
        The results hold no window at all (results without electrostatic forces, a study
        of OFF trials, give an empty table and each subject's friction figure); a bad
        ``trial_checks``.
    AnalysisError
        A fit cannot be made.
    """
    setup = CompareSetup.of(fit=fit, params=None if params is None else Path(params),
                            models=models, trial_checks=trial_checks)
    tables = _comparable(results)
    kept = _Kept()
    with journal_style(setup.look.width):
        done = run_comparison(tables, setup, kept, exclude=population_rule(tables))
    figures = kept.figures()
    pop = done.population
    assert pop is not None and done.fit_table is not None  # run_comparison gives both
    out = Fit(table=FIT.typed(done.fit_table),
              figures={r["stem"]: ax.figure for r, ax in figures
                       if isinstance(ax.figure, Figure)},
              records=[r for r, _ in figures], fits=done.fits, fitted=setup.names,
              params_file=None if params is None else Path(params),
              population=POPULATION.typed(pop.table),
              population_contrasts=CONTRASTS.typed(pop.contrasts),
              population_notes=[*pop.notes, *(o.record() for o in pop.outliers)],
              models=_models(done.models_table), notes=done.notes, _results=results,
              _asked={"models": models, "trial_checks": trial_checks})
    results.fit = out
    return out
