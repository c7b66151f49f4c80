"""``evtribo compare``: fit the model to a result folder and draw the comparison figures.

Writes into the result folder:

- ``fit.csv``: one row per subject and fitted parameter
  (:data:`~evtribo.fit.fit_csv.FIT_COLUMNS`);
- ``fit.json``: what was fitted, the fixed parameters, each subject's full parameter set,
  how its intervals were obtained (``interval``: ``bootstrap``, refits to the force
  replicates of ``electrostatic_bootstrap.csv``, or ``jacobian``, the fallback that takes
  the points' errors as independent), the figures and notes (read by ``evtribo report``);
- ``population.csv`` and ``population_contrasts.csv`` (study format §10) when the study has
  at least three subjects with electrostatic forces (:mod:`evtribo.population.estimates`),
  with a ``population_<waveform>_<frequency>Hz`` figure per condition;
- ``models.csv`` with ``--models``: each candidate model fitted to each subject and ranked
  (:func:`evtribo.fit.model_comparison.compare_models`);
- ``figures/``: each figure of the figure registry (:mod:`evtribo.figures.registry`) once
  per format asked (``<stem>.svg`` and ``<stem>.png`` by default, ``<stem>.pdf`` too on
  request), in the journal style of :mod:`evtribo.figures.style` (a single column or a
  page wide, no titles: fit.json's captions carry them). The first is
  ``electrostatic_force_all``, every subject's electrostatic force and fitted model in one
  figure.

The sequence (the fits, the trials' checks, the population, the models, each figure as soon
as what it shows is known) is :func:`run_comparison`, which ``evtribo.compare`` runs too,
keeping the figures in memory.

``fit.json`` also records the ``run_id`` of the analysis it fitted (from ``summary.json``)
and the SHA-256 of every file compare wrote (``output_sha256``), which ``evtribo report``
checks. The folder is locked and written as one unit (:mod:`evtribo.store.resultdir`); it is read
only if it is one analysis's complete results (:func:`~evtribo.fit.tables.read_results`).
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from evtribo import __version__
from evtribo.documents.fit import FIT_VERSION, write_fit
from evtribo.documents.tables import FIT
from evtribo.figures.registry import FigureContext, FigureSink, absent_notes, planned, stems
from evtribo.figures.style import parse_dpi, parse_figure_formats, parse_figure_width
from evtribo.figures.trial_checks import CheckFigure, parse_which, trial_checks
from evtribo.fit.fit import SubjectFit, fit_study, interval_notes
from evtribo.fit.fit_csv import fit_table
from evtribo.fit.model_comparison import compare_models
from evtribo.fit.models import resolve_models
from evtribo.fit.params import load_parameters, resolve_fit_names
from evtribo.fit.tables import ResultTables, check_out_folder, read_results
from evtribo.guard import refuse_in_study, refuse_input
from evtribo.model.params import ModelParameters
from evtribo.population.estimates import Population, population
from evtribo.population.exclusions import PopulationRule, population_rule
from evtribo.report.compare_cache import FigureStore, compare_key, last_fit, options_text
from evtribo.report.drawing import FigureRecord, Figures, Look, Runner, trials_to_check
from evtribo.results.outputs import (
    FIGURES,
    FIT_CSV,
    FIT_JSON,
    MODELS_CSV,
    check_compare,
    compare_files,
    earlier_results,
)
from evtribo.store.files import atomic_write, sha256_file
from evtribo.store.memo import default_cache_dir
from evtribo.store.pool import Mapper
from evtribo.store.resultdir import Staging, locked, recover
from evtribo.warning.collect import collecting, emitter, replay
from evtribo.warning.record import WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)

__all__ = ["FIGURES", "FIT_CSV", "FIT_JSON", "CompareResult", "CompareSetup", "FigureRecord",
           "compare", "run_comparison"]


@dataclass
class CompareResult:
    """What :func:`compare` (or :func:`run_comparison`, in memory) did."""

    out: Path
    fits: list[SubjectFit]
    files: list[Path] = field(default_factory=list)
    figures: list[FigureRecord] = field(default_factory=list)
    notes: list[WarningRecord] = field(default_factory=list)
    """What the comparison said (fit.json's ``warnings``), in the order said."""
    population: Population | None = None
    sha256: dict[str, str] = field(default_factory=dict)
    """The SHA-256 of each figure file (relative), those kept as they were included."""
    kept: set[str] = field(default_factory=set)
    """The figure files (relative) left as they were: their figures had not changed."""
    fit_table: pd.DataFrame | None = None
    """``fit.csv``'s table."""
    models_table: pd.DataFrame | None = None
    """``models.csv``'s table (None: no models compared)."""


def _check_outputs(out: Path, force: bool, figures: Iterable[str] = ()) -> None:
    refuse_in_study(out, command="evtribo compare")
    for rel in check_compare(out, force, figures):  # nor a study's input or a raw log
        refuse_input(out / rel, command="evtribo compare")


def _jsonable(x: float) -> float | None:
    return x if math.isfinite(x) else None


def compare(out: str | Path, *, fit: str | Iterable[str] | None = None,
            params: str | Path | None = None, force: bool = False,
            dpi: float | None = None, formats: str | Iterable[str] | None = None,
            width: str = "single",
            models: str | Iterable[str] | None = None,
            trial_checks: bool | str | None = None, scheduler: Any = None,
            progress: Callable[[str], None] | None = None, jobs: int | None = None,
            cache_dir: str | Path | None = None) -> CompareResult:
    """Fit the model to the results in *out* and write ``fit.csv``, ``fit.json``, figures.

    Parameters
    ----------
    out : str or Path
        Folder written by ``evtribo analyze``.
    fit : str or iterable of str, optional
        Parameters to fit per subject (``"h_L,E_star"``); default ``h_L``.
    params : str or Path, optional
        TOML file of fixed parameters (SI units); Table 1 for those it does not set.
    force : bool
        Replace the outputs of a previous comparison: a figure whose data and settings
        have not changed is left as it is (not drawn, not written).
    dpi : float, optional
        Resolution of the PNG figures, dots per inch (300 by default).
    formats : str or iterable of str, optional
        Figure formats, ``"pdf,svg,png"`` or a sequence of them (default ``svg,png``).
    width : {"single", "double"}
        Width of the figures: a journal's single column (85 mm) or a page (175 mm).
    models : str or iterable of str, optional
        Candidate models to fit and rank per subject (``"paper,hertz,maugis,circuit"``):
        writes ``models.csv`` and a ``frequency_response`` figure per subject.
    trial_checks : bool or str, optional
        Which trials' checks to draw (kind ``trial``): ``"all"`` (True), ``"none"``
        (False), ``"auto"`` (None): :func:`~evtribo.figures.trial_checks.chosen_trials`.
    scheduler : distributed.Client, optional
        A Dask cluster for the bootstrap refits and the figures (the same results as here).
    progress : callable, optional
        Told what is being done, stage by stage (and trial by trial for the checks).
    jobs : int, optional
        Worker processes drawing the figures (default: the number of CPUs; 1: here).
    cache_dir : str or Path, optional
        The analysis's cache folder (its sketches), keeping the figures drawn too.

    Returns
    -------
    CompareResult

    Raises
    ------
    UserInputError
        Missing folder or tables, bad ``fit`` names, parameter file, figure format, width,
        resolution or ``trial_checks`` (exit code 2).
    OutputExistsError
        When outputs exist and *force* is False.
    OutputBusyError
        Another process is writing the folder.
    ResultFolderError
        The folder is not one analysis's complete results (exit code 2).
    AnalysisError
        When a fit cannot be made.
    """
    setup = CompareSetup.of(fit=fit, params=params, formats=formats, dpi=dpi, width=width,
                      models=models, trial_checks=trial_checks, cache_dir=cache_dir)
    folder = check_out_folder(out)
    _check_outputs(folder, force)  # before the lock: a refusal writes nothing
    runner = Runner((os.cpu_count() or 1) if jobs is None else jobs, scheduler)
    try:
        with locked(folder, "evtribo compare"):
            recover(folder)
            tables = read_results(folder)
            result = _run(folder, tables, setup, params, runner, force=force,
                          progress=progress or (lambda _: None), scheduler=scheduler)
    except BaseException:
        runner.close(failed=True)  # no worker outlives the comparison
        raise
    runner.close()
    result.files = [folder / rel for rel in result.files]
    log.info("compare: wrote %d files into %s (%d figure files as they were)",
             len(result.files) - len(result.kept), folder, len(result.kept))
    return result


@dataclass(frozen=True)
class CompareSetup:
    """What a comparison is asked to do.

    Attributes
    ----------
    names : tuple of str
        The parameters fitted per subject.
    base : ModelParameters
        Starting values and the fixed parameters.
    look : Look
        Formats, resolution and width of the figures.
    models : tuple of str
        The candidate models to compare (empty: none).
    checks : str
        Which trials' checks to draw (:data:`~evtribo.figures.trial_checks.WHICH`).
    cache : Path
        The analysis's cache folder (its sketches, the figures kept).
    options : dict
        The options as the comparison's key holds them.
    """

    names: tuple[str, ...]
    base: ModelParameters
    look: Look
    models: tuple[str, ...]
    checks: str
    cache: Path
    options: dict[str, Any]

    @classmethod
    def of(cls, *, fit: Any = None, params: Any = None, formats: Any = None, dpi: Any = None,
           width: str = "single", models: Any = None, trial_checks: Any = None,
           cache_dir: Any = None) -> CompareSetup:
        """compare's options checked (each bad one an error naming it).

        Parameters
        ----------
        fit, params, formats, dpi, width, models, trial_checks, cache_dir
            As :func:`compare` takes them.

        Returns
        -------
        CompareSetup
        """
        look = Look(dpi=parse_dpi(dpi),
                    formats=parse_figure_formats(formats), width=parse_figure_width(width))
        return cls(names=resolve_fit_names(fit), base=load_parameters(params), look=look,
                   models=resolve_models(models) if models is not None else (),
                   checks=parse_which(trial_checks),
                   cache=Path(cache_dir) if cache_dir is not None else default_cache_dir(),
                   options=options_text(fit=fit, params=params, formats=formats, dpi=dpi,
                                        width=width, models=models,
                                        trial_checks=trial_checks))


def _run(folder: Path, tables: ResultTables, setup: CompareSetup,
         params: str | Path | None, runner: Runner, *, force: bool,
         progress: Callable[[str], None], scheduler: Any) -> CompareResult:
    """The comparison, under the folder's lock: written as one unit, the figures that did
    not change left as they are."""
    known = stems(FigureContext(tables, names=setup.names, models=setup.models))
    _check_outputs(folder, force, [f"{FIGURES}/{stem}.{fmt}" for fmt in setup.look.formats
                                   for stem in known])
    exclude = population_rule(tables)  # a bad [population] rule: before any write
    stale = compare_files(folder)
    previous = last_fit(folder)
    with Staging(folder, by="compare", also=earlier_results(folder)) as stage:
        figures = Figures(stage, setup.look, runner, FigureStore(setup.cache),
                          previous=previous, progress=progress)
        result = run_comparison(tables, setup, figures, scheduler=scheduler,
                                mapper=runner.map, progress=progress, exclude=exclude)
        tables_written = _write_tables(stage, result)
        figures.finish()
        result.files = [*tables_written, *figures.files]
        result.figures, result.sha256, result.kept = figures.records, figures.sha256, figures.kept
        _write_json(stage, result, setup.names, setup.base, params,
                    run_id=tables.summary.run_id,
                    key=compare_key(tables.summary, setup.options))
        stage.commit(remove=[rel for rel in stale if rel not in result.kept],
                     last=[FIT_JSON])
    return result


def _write_tables(stage: Staging, result: CompareResult) -> list[Path]:
    """fit.csv, the population's files and models.csv, into *stage*."""
    texts = {} if result.fit_table is None else {FIT_CSV: FIT.text(result.fit_table)}
    if result.population is not None:
        texts.update(result.population.files())
    if result.models_table is not None:
        texts[MODELS_CSV] = result.models_table.to_csv(index=False)
    for name, text in texts.items():
        atomic_write(stage.path(name), text)
    return [Path(name) for name in texts]


def _quiet(_: str) -> None:
    pass


def run_comparison(tables: ResultTables, setup: CompareSetup, sink: FigureSink, *,
                   scheduler: Any = None, mapper: Mapper | None = None,
                   progress: Callable[[str], None] = _quiet,
                   exclude: PopulationRule | None = None) -> CompareResult:
    """compare's sequence, for ``evtribo compare`` and ``evtribo.compare`` alike: the
    subjects' fits, the trials' checks, the population, the candidate models, and each
    figure of :data:`~evtribo.figures.registry.FIGURES` handed to *sink* as soon as what it
    shows is known (the figures of the fits drawn while the population is estimated).

    Parameters
    ----------
    tables : ResultTables
        The results.
    setup : CompareSetup
        What the comparison is asked to do.
    sink : FigureSink
        Takes each figure (``sink.emit(figure)``): writes it, or keeps it in memory.
    scheduler : distributed.Client, optional
        A Dask cluster for the bootstrap refits.
    mapper : callable, optional
        ``mapper(func, items)`` (compare's worker processes): the subjects fitted and the
        trials sketched again side by side (default: here).
    progress : callable, optional
        Told what is being done, stage by stage.
    exclude : PopulationRule, optional
        The study's ``[population]`` rule: its exclusions, its model and the notes on them
        (:func:`~evtribo.population.exclusions.population_rule`; default: none, the mixed
        model).

    Returns
    -------
    CompareResult
        The fits, ``fit_table``, ``population``, ``models_table`` and what the comparison
        said (``notes``: the records of the fits, the intervals, the population, the
        models, the figures not drawn and the trials' checks, in that order, each once;
        said quietly: the caller shows them); nothing written (no ``files``, ``figures``
        or ``sha256``: the sink's). When a step raises, what was said before it is said
        (logged) before the error goes on.
    """
    try:
        with collecting(quiet=True) as said:
            result = _sequence(tables, setup, sink, scheduler=scheduler, mapper=mapper,
                               progress=progress, exclude=exclude)
    except BaseException:
        replay(said)  # what was said before the comparison stopped: said, nothing lost
        raise
    result.notes = list(dict.fromkeys(said))
    return result


def _sequence(tables: ResultTables, setup: CompareSetup, sink: FigureSink, *,
              scheduler: Any, mapper: Mapper | None, progress: Callable[[str], None],
              exclude: PopulationRule | None) -> CompareResult:
    """:func:`run_comparison`'s steps, each warning said (into its collector) in order."""
    ctx = FigureContext(tables, names=setup.names, models=setup.models)
    only_mu = ctx.only_mu  # a study of OFF trials: its friction, no fit
    if not only_mu:
        replicates = ("" if tables.bootstrap is None else
                      ", refitted to each bootstrap replicate for its interval")
        progress(f"fitting {', '.join(setup.names)} to each of {len(tables.subjects)} "
                 f"subjects{replicates}")
        ctx.fits = fit_study(tables, setup.base, setup.names, scheduler=scheduler,
                             mapper=mapper if scheduler is None else None)
    # the trials' checks go to the workers after the fits (which they would hold up there),
    # drawn while the population is estimated here
    ctx.checks, check_notes = _checks(tables, setup, mapper, progress)
    result = CompareResult(out=tables.out or Path(), fits=ctx.fits,
                           fit_table=fit_table(ctx.fits, tables))
    replay([emit.record("fit-none")] if only_mu else interval_notes(
        ctx.fits, has_bootstrap=tables.bootstrap is not None))
    progress("drawing the figures of the fit" if not only_mu else
             "drawing each subject's friction")
    _emit(ctx, "fits", sink)
    if not only_mu:
        progress("estimating the population (a mixed model per condition, checked with "
                 "several optimisers)")
    rule = exclude or PopulationRule()
    ctx.population = result.population = population(tables, ctx.fits, exclude=rule.exclude,
                                                    rule_notes=rule.notes, model=rule.model)
    replay([*rule.notes, *result.population.notes])
    _emit(ctx, "population", sink)
    if setup.models and not only_mu:
        progress(f"fitting and ranking the models {', '.join(setup.models)}")
        compared = compare_models(tables, setup.models, setup.base)
        result.models_table, ctx.model_fits = compared.table, compared.fits
        replay(compared.notes)
    _emit(ctx, "models", sink)
    replay(check_notes)
    return result


def _emit(ctx: FigureContext, stage: str, sink: FigureSink) -> None:
    """The figures of a stage handed to the sink; what is said of those not drawn."""
    for figure in planned(ctx, stage):
        sink.emit(figure)
    replay(absent_notes(ctx, stage))


def _checks(tables: ResultTables, setup: CompareSetup, mapper: Mapper | None,
            progress: Callable[[str], None]) -> tuple[list[CheckFigure], list[WarningRecord]]:
    """The trials whose checks are drawn (:func:`~evtribo.figures.trial_checks.trial_checks`;
    ``auto`` in a large study: those with a warning not only for information,
    :func:`~evtribo.report.drawing.trials_to_check`, or not analysed) and the notes on
    them."""
    if setup.checks == "none":
        return [], []
    trials = list(zip(tables.trials["subject"].astype(str), tables.trials["trial"].astype(str),
                      strict=True)) if not tables.trials.empty else []
    checks, notes = trial_checks(tables, setup.checks, cache_dir=setup.cache, mapper=mapper,
                                 flagged=trials_to_check(tables.summary.warnings, trials))
    if checks:
        progress(f"drawing the check of {len(checks)} trial(s) from what analyze kept of "
                 "each, beside the figures of the fit (--trial-checks none leaves them out)")
    return checks, notes


def _write_json(stage: Staging, result: CompareResult, names: tuple[str, ...],
                base: ModelParameters, params_file: str | Path | None, *,
                run_id: str | None, key: str) -> None:
    """fit.json, into *stage*, naming the analysis fitted, what the comparison was made
    from (its key) and the files written."""
    pfile: dict[str, Any] | None = None if params_file is None else {
        "path": str(Path(params_file)), "sha256": sha256_file(Path(params_file))}
    doc = {
        "run_id": run_id,
        "software": {"evtribo": __version__},
        "fit_version": FIT_VERSION,
        "fit": list(names),
        "parameters_file": pfile,
        "fixed_parameters": base.as_dict(),
        "subjects": {
            f.subject: {
                "parameters": f.params.as_dict(),
                "estimates": {e.name: {"value": e.value, "stderr": _jsonable(e.stderr),
                                       "ci_low": _jsonable(e.ci_low),
                                       "ci_high": _jsonable(e.ci_high), "unit": e.unit}
                              for e in f.estimates},
                "correlation": [[_jsonable(float(c)) for c in row] for row in f.correlation],
                "rmse_N": _jsonable(f.rmse_N), "r2": _jsonable(f.r2),
                "chi2_reduced": _jsonable(f.chi2_reduced), "n_points": f.n_points,
                "mu_measured": _jsonable(f.mu_measured),
                "interval": {"method": f.interval_method, "replicates": f.n_replicates,
                             "note": f.interval_note},
            } for f in result.fits},
        "figures": [r.as_dict() for r in result.figures],
        "notes": [n.text for n in result.notes],
        "warnings": [n.as_json() for n in result.notes],
        "population": None if result.population is None else result.population.as_json(),
        "compare_key": key,
        "output_sha256": {rel.as_posix(): result.sha256.get(rel.as_posix())
                          or sha256_file(stage.path(rel.as_posix())) for rel in result.files},
    }
    write_fit(stage.path(FIT_JSON), doc)
    result.files.append(Path(FIT_JSON))
