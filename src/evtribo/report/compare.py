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
- ``figures/``: each figure once per format asked (``<stem>.svg`` and ``<stem>.png`` by
  default, ``<stem>.pdf`` too on request), in the journal style of
  :mod:`evtribo.figures.style` (a single column or a page wide, no titles: fit.json's
  captions carry them). The first is ``electrostatic_force_all``, every subject's
  electrostatic force and fitted model in one figure.

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

import numpy as np
import pandas as pd

from evtribo import __version__
from evtribo.documents.fit import write_fit
from evtribo.documents.tables import FIT
from evtribo.figures.frequency_plots import write_models
from evtribo.figures.friction_only import NOTE, friction_figures
from evtribo.figures.plots import (
    plot_area_increase,
    plot_electrostatic_force,
    plot_electrostatic_force_all,
    plot_friction_normal_force,
    plot_friction_time,
    safe_name,
)
from evtribo.figures.population_plots import draw_population
from evtribo.figures.style import (
    journal_style,
    parse_dpi,
    parse_figure_formats,
    parse_figure_width,
)
from evtribo.figures.trial_checks import parse_which
from evtribo.fit.fit import SubjectFit, fit_study, interval_notes
from evtribo.fit.fit_csv import fit_table
from evtribo.fit.models import resolve_models
from evtribo.fit.params import load_parameters, resolve_fit_names
from evtribo.fit.tables import ResultTables, check_out_folder, read_results
from evtribo.guard import refuse_in_study, refuse_input
from evtribo.model.params import ModelParameters
from evtribo.population.estimates import Population, population
from evtribo.population.exclusions import PopulationRule, population_rule
from evtribo.report.drawing import Drawing, FigureRecord, Figures, Look, Runner, emit_checks
from evtribo.report.kept import FigureStore, compare_key, last_fit, options_text
from evtribo.results.outputs import (
    FIGURES,
    FIT_CSV,
    FIT_JSON,
    check_compare,
    compare_files,
    earlier_results,
)
from evtribo.store.files import atomic_write, sha256_file
from evtribo.store.memo import default_cache_dir
from evtribo.store.resultdir import Staging, locked, recover

log = logging.getLogger(__name__)

__all__ = ["FIGURES", "FIT_CSV", "FIT_JSON", "CompareResult", "FigureRecord", "compare",
           "figure_stems"]


#: The citation of the model's paper, for captions and help texts.
PAPER = ("Voltage-Induced Friction with Application to Electrovibration, Lubricants 2019, "
         "7(12), 102, doi:10.3390/lubricants7120102")


@dataclass
class CompareResult:
    """What :func:`compare` did."""

    out: Path
    fits: list[SubjectFit]
    files: list[Path] = field(default_factory=list)
    figures: list[FigureRecord] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    population: Population | None = None
    sha256: dict[str, str] = field(default_factory=dict)
    """The SHA-256 of each figure file (relative), those kept as they were included."""
    kept: set[str] = field(default_factory=set)
    """The figure files (relative) left as they were: their figures had not changed."""


def figure_stems(subjects: Iterable[str], *, sine: bool = True) -> list[str]:
    """File stems of the figures :func:`compare` writes for these subjects.

    Parameters
    ----------
    subjects : iterable of str
        The subjects, in order.
    sine : bool
        Whether the results hold a measured sine trace (``sine_trace.csv``): the
        friction-versus-time figure is drawn only then.

    Returns
    -------
    list of str
        The figure of all subjects, those of the whole study, then two per subject.
    """
    stems = ["electrostatic_force_all", *(["friction_time"] if sine else []), "area_increase"]
    for s in subjects:
        stems += [f"electrostatic_force_{safe_name(s)}", f"friction_normal_force_{safe_name(s)}"]
    return stems


def _check_outputs(out: Path, force: bool, figures: Iterable[str] = ()) -> None:
    refuse_in_study(out, command="evtribo compare")
    for rel in check_compare(out, force, figures):  # nor a study's input or a raw log
        refuse_input(out / rel, command="evtribo compare")


def _jsonable(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _first_trace(tables: ResultTables) -> tuple[pd.DataFrame | None, str | None]:
    """The first trial of ``sine_trace.csv`` (when it holds several) and its subject."""
    trace = tables.sine_trace
    if trace is None or trace.empty:
        return None, None
    for col in ("subject", "trial"):
        if col in trace.columns:
            trace = trace[trace[col].astype(str) == str(trace[col].iloc[0])]
    subject = str(trace["subject"].iloc[0]) if "subject" in trace.columns else None
    return trace, subject


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
    setup = _Setup.of(fit=fit, params=params, formats=formats, dpi=dpi, width=width,
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
class _Setup:
    """What a comparison is asked to do."""

    names: tuple[str, ...]
    base: ModelParameters
    look: Look
    models: tuple[str, ...]
    checks: str
    cache: Path
    options: dict[str, Any]

    @classmethod
    def of(cls, *, fit: Any, params: Any, formats: Any, dpi: Any, width: str, models: Any,
           trial_checks: Any, cache_dir: Any) -> _Setup:
        """compare's options checked (each bad one an error naming it)."""
        look = Look(dpi=parse_dpi(dpi),
                    formats=parse_figure_formats(formats), width=parse_figure_width(width))
        return cls(names=resolve_fit_names(fit), base=load_parameters(params), look=look,
                   models=resolve_models(models) if models is not None else (),
                   checks=parse_which(trial_checks),
                   cache=Path(cache_dir) if cache_dir is not None else default_cache_dir(),
                   options=options_text(fit=fit, params=params, formats=formats, dpi=dpi,
                                        width=width, models=models,
                                        trial_checks=trial_checks))


def _run(folder: Path, tables: ResultTables, setup: _Setup, params: str | Path | None,
         runner: Runner, *, force: bool, progress: Callable[[str], None],
         scheduler: Any) -> CompareResult:
    """The comparison, under the folder's lock: written as one unit, the figures that did
    not change left as they are."""
    _check_outputs(folder, force, [
        f"{FIGURES}/{stem}.{fmt}" for fmt in setup.look.formats
        for stem in figure_stems(tables.subjects, sine=tables.sine_trace is not None)])
    exclude = population_rule(tables)  # a bad [population] rule: before any write
    stale = compare_files(folder)
    previous = last_fit(folder)
    with Staging(folder, by="compare", also=earlier_results(folder)) as stage:
        figures = Figures(stage, setup.look, CompareResult(out=folder, fits=[]), runner,
                          FigureStore(setup.cache), previous=previous, progress=progress)
        result = _compare(tables, stage, setup, figures, scheduler=scheduler,
                          progress=progress, exclude=exclude)
        _write_json(stage, result, setup.names, setup.base, params,
                    run_id=tables.summary.run_id,
                    key=compare_key(tables.summary, setup.options))
        stage.commit(remove=[rel for rel in stale if rel not in result.kept],
                     last=[FIT_JSON])
    return result


def _compare(tables: ResultTables, stage: Staging, setup: _Setup, figures: Figures, *,
             scheduler: Any = None, progress: Callable[[str], None],
             exclude: PopulationRule | None = None) -> CompareResult:
    """The fits and figures, written into *stage* (``result.files`` relative to it);
    *exclude*: the study's ``[population]`` rule (its exclusions, its model) and notes on
    it."""
    names = setup.names
    only_mu = tables.electrostatic.empty  # a study of OFF trials: its friction, no fit
    if not only_mu:
        replicates = ("" if tables.bootstrap is None else
                      ", refitted to each bootstrap replicate for its interval")
        progress(f"fitting {', '.join(names)} to each of {len(tables.subjects)} subjects"
                 f"{replicates}")
    fits = [] if only_mu else fit_study(  # the subjects side by side on the workers
        tables, setup.base, names, scheduler=scheduler,
        mapper=figures.runner.map if scheduler is None else None)
    # the trials' checks go to the workers after the fits (which they would hold up there),
    # drawn while the population is estimated here
    check_notes = emit_checks(figures, tables, setup.checks, setup.cache, progress)
    result = figures.result
    result.fits = fits
    result.notes += [NOTE] if only_mu else interval_notes(
        fits, has_bootstrap=tables.bootstrap is not None)
    table = fit_table(fits, tables)
    atomic_write(stage.path(FIT_CSV), FIT.text(table))
    result.files.append(Path(FIT_CSV))
    progress("drawing the figures of the fit" if not only_mu else
             "drawing each subject's friction")
    with journal_style(setup.look.width):  # drawn by the workers while the population is
        if only_mu:                        # estimated here
            friction_figures(tables, figures.emit)
        else:
            draw_figures(tables, fits, names, figures)
    if not only_mu:
        progress("estimating the population (a mixed model per condition, checked with "
                 "several optimisers)")
    rule = exclude or PopulationRule()
    result.population = pop = population(tables, fits, exclude=rule.exclude,
                                         rule_notes=rule.notes, model=rule.model)
    for name, text in pop.files().items():
        atomic_write(stage.path(name), text)
        result.files.append(Path(name))
    with journal_style(setup.look.width):
        if not only_mu:
            draw_population(tables.electrostatic, pop, figures.emit)
        if setup.models and not only_mu:
            progress(f"fitting and ranking the models {', '.join(setup.models)}")
            files, notes = write_models(tables, stage, setup.models, setup.base,
                                        figures.emit)
            result.files += files
            result.notes += notes
    figures.finish()
    result.notes += check_notes
    result.sha256, result.kept = figures.sha256, figures.kept
    return result


def draw_figures(tables: ResultTables, fits: list[SubjectFit], names: tuple[str, ...],
                 figures: Any) -> None:
    """Draw compare's figures of the fit (all but the trial checks and the models').

    Parameters
    ----------
    tables : ResultTables
        The results.
    fits : list of SubjectFit
        The subjects' fits.
    names : tuple of str
        The fitted parameters.
    figures : object
        Has ``emit(ax, kind, title, stem, *, subject, caption)`` (writes or keeps one
        figure) and ``result`` (a :class:`CompareResult`, for notes); with a true ``lazy``
        attribute, it is given a :class:`~evtribo.report.drawing.Drawing` instead of an
        Axes (drawn where and when it is needed).

    Returns
    -------
    None
    """
    _all_subjects_figure(tables, fits, figures)
    _subject_figures(tables, fits, names, figures)
    _study_figures(tables, fits, figures)


def _drawn(figures: Any, drawing: Drawing) -> Any:
    """A figure as *figures* takes it: the drawing itself when *figures* draws where and
    when needed (``lazy``), else drawn here (its Axes)."""
    return drawing if getattr(figures, "lazy", False) else drawing.draw()


def _all_subjects_figure(tables: ResultTables, fits: list[SubjectFit],
                         figures: Any) -> None:
    """``electrostatic_force_all``: every subject's F_el and fitted model."""
    ax = _drawn(figures, Drawing(plot_electrostatic_force_all, (
        tables.electrostatic, {f.subject: f.params for f in fits})))
    waves = set(tables.electrostatic["waveform"].astype(str))
    fill = " (filled markers: square drive; open: sine)" if len(waves) > 1 else ""
    figures.emit(ax, "electrostatic_force_all", "Electrostatic force vs voltage, all subjects",
                 "electrostatic_force_all", subject=None,
                 caption="Inferred electrostatic force of every subject against the voltage "
                         f"amplitude: points with 95 % intervals{fill}, spread by up to ±3 % "
                         "in voltage so that they do not hide one another; lines: each "
                         "subject's fitted model at its mean normal force ON "
                         f"({PAPER}).")


def _subject_figures(tables: ResultTables, fits: list[SubjectFit], names: tuple[str, ...],
                     figures: Any) -> None:
    """Per subject: F_el against U, and friction against normal force."""
    mu_how = "fitted." if "mu" in names else "from the measured OFF windows."
    for f in fits:
        s = f.subject
        rows = tables.electrostatic[tables.electrostatic["subject"] == s]
        ax = _drawn(figures, Drawing(plot_electrostatic_force, (rows, f.params),
                                     {"subject": s}))
        figures.emit(ax, "electrostatic_force", f"Electrostatic force vs voltage, {s}",
                     f"electrostatic_force_{safe_name(s)}", subject=s,
                     caption=f"{s}: inferred electrostatic force (points, 95 % intervals) "
                             "and the fitted model (lines) at the subject's mean normal force "
                             "ON, over the amplitudes measured.")
        win = tables.windows[tables.windows["subject"] == s]
        ax = _drawn(figures, Drawing(plot_friction_normal_force, (win, f.params),
                                     {"subject": s}))
        figures.emit(ax, "friction_normal_force", f"Friction vs normal force, {s}",
                     f"friction_normal_force_{safe_name(s)}", subject=s,
                     caption=f"{s}: steady-sliding windows OFF and ON (points) and the model "
                             "(lines, eq. 5, cf. the paper's Figure 6) over the normal forces "
                             f"each drive's windows span; axes zoomed to the windows; μ {mu_how}")


def _study_figures(tables: ResultTables, fits: list[SubjectFit], figures: Any) -> None:
    """Friction against time (a measured sine trial, or the model alone) and the predicted
    contact-area increase."""
    by_subject = {f.subject: f for f in fits}
    trace, trace_subject = _first_trace(tables)
    pick = by_subject.get(trace_subject or "", fits[0])
    elec = tables.electrostatic
    sine_rows = elec[elec["waveform"].astype(str) == "sine"]
    amp = float(sine_rows["amplitude_V"].max()) if not sine_rows.empty else 140.0
    fn_mean = float(np.nanmean(elec["normal_force_on_N"].to_numpy(float)))
    if trace is None:  # no sine trial: the paper's Figure 5 has nothing measured to show
        figures.result.notes.append(
            "No measured sine trace (sine_trace.csv: the study has no sine trial with ON and "
            "OFF phases): no friction-versus-time figure; `evtribo model --figures DIR` draws "
            "the model's.")
    else:
        voltage = ("measured voltage" if "voltage_V" in trace.columns else
                   "drive's amplitude and frequency (its phase, which the rig does not record, "
                   "chosen to match the measured friction)")
        ax = _drawn(figures, Drawing(plot_friction_time, (trace, pick.params), {
            "amplitude": amp, "normal_force": fn_mean, "subject": pick.subject}))
        figures.emit(ax, "friction_time", "Friction vs time, sine drive", "friction_time",
                     subject=None,
                     caption=f"Measured sine trial of {pick.subject} and the model evaluated "
                             f"at its measured normal force and the {voltage}, cf. the "
                             "paper's Figure 5.")
    mean_fn = {f.subject: float(np.nanmean(elec.loc[elec["subject"] == f.subject,
                                                    "normal_force_on_N"].to_numpy(float)))
               for f in fits}
    amps = elec["amplitude_V"].to_numpy(float)
    ax = _drawn(figures, Drawing(plot_area_increase, (
        mean_fn, {f.subject: f.params for f in fits}), {
        "u_max": max(150.0, float(np.nanmax(amps))),
        "amplitudes": sorted(set(amps[np.isfinite(amps)].tolist()))}))
    figures.emit(ax, "area_increase", "Predicted contact-area increase", "area_increase",
                 subject=None,
                 caption="A prediction of the model, nothing measured: JKR over Hertz "
                         "contact area at each subject's mean normal force ON with the fitted "
                         "parameters, cf. the paper's Figure 7.")


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
        "notes": result.notes,
        "population": None if result.population is None else result.population.as_json(),
        "compare_key": key,
        "output_sha256": {rel.as_posix(): result.sha256.get(rel.as_posix())
                          or sha256_file(stage.path(rel.as_posix())) for rel in result.files},
    }
    write_fit(stage.path(FIT_JSON), doc)
    result.files.append(Path(FIT_JSON))
