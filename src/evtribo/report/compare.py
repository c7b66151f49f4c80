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
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from evtribo import __version__
from evtribo.documents.fit import write_fit
from evtribo.errors import OutputExistsError
from evtribo.figures.frequency_plots import write_models
from evtribo.figures.friction_only import NOTE, friction_figures
from evtribo.figures.plots import (
    plot_area_increase,
    plot_electrostatic_force,
    plot_electrostatic_force_all,
    plot_friction_normal_force,
    plot_friction_time,
    safe_name,
    save_figure,
)
from evtribo.figures.population_plots import draw_population
from evtribo.figures.style import (
    journal_style,
    parse_dpi,
    parse_figure_formats,
    parse_figure_width,
)
from evtribo.figures.trial_checks import write_trial_checks
from evtribo.fit.fit import SubjectFit, fit_study, interval_notes
from evtribo.fit.fit_csv import fit_table
from evtribo.fit.models import resolve_models
from evtribo.fit.params import load_parameters, resolve_fit_names
from evtribo.fit.tables import ResultTables, check_out_folder, read_results
from evtribo.guard import refuse_in_study, refuse_input
from evtribo.model.params import ModelParameters
from evtribo.population.estimates import Population, population
from evtribo.results.outputs import FIGURES, FIT_CSV, FIT_JSON, compare_files
from evtribo.store.files import atomic_write, sha256_file
from evtribo.store.resultdir import Staging, locked, recover

log = logging.getLogger(__name__)

__all__ = ["FIGURES", "FIT_CSV", "FIT_JSON", "CompareResult", "FigureRecord", "compare",
           "figure_stems"]


#: The citation of the model's paper, for captions and help texts.
PAPER = ("Voltage-Induced Friction with Application to Electrovibration, Lubricants 2019, "
         "7(12), 102, doi:10.3390/lubricants7120102")


@dataclass(frozen=True)
class FigureRecord:
    """One figure written by :func:`compare`: its kind, subject (or None) and files.

    Parameters
    ----------
    kind : str
        What the figure shows (``electrostatic_force_all``, ``electrostatic_force``...).
    title : str
        A short title (the figure itself has none).
    stem : str
        The files' name in ``figures/`` without suffix.
    subject : str or None
        The subject shown, None for a figure of the whole study.
    caption : str
        What a reader needs to read the figure.
    extra : mapping
        Further keys of the record in fit.json (``trial`` for a trial's figure).

    Returns
    -------
    FigureRecord
    """

    kind: str
    title: str
    stem: str
    subject: str | None
    caption: str
    extra: Mapping[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """The record as fit.json lists it.

        Returns
        -------
        dict
            ``kind``, ``title``, ``stem``, ``subject``, ``caption``, then the extra keys.
        """
        return {"kind": self.kind, "title": self.title, "stem": self.stem,
                "subject": self.subject, "caption": self.caption, **self.extra}


@dataclass
class CompareResult:
    """What :func:`compare` did."""

    out: Path
    fits: list[SubjectFit]
    files: list[Path] = field(default_factory=list)
    figures: list[FigureRecord] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    population: Population | None = None


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


def _check_outputs(out: Path, force: bool) -> None:
    refuse_in_study(out, command="evtribo compare")
    existing = compare_files(out)
    for rel in existing:  # a study's input or a raw log is never written over
        refuse_input(out / rel, command="evtribo compare")
    if existing and not force:
        raise OutputExistsError(f"{len(existing)} output file(s) of a previous comparison "
                                "exist; use {force} to overwrite them", path=out / existing[0])


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
            trial_checks: bool = True, scheduler: Any = None,
            progress: Callable[[str], None] | None = None) -> CompareResult:
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
        Overwrite the outputs of a previous comparison.
    dpi : float, optional
        Resolution of the PNG figures, dots per inch (300 by default).
    formats : str or iterable of str, optional
        Figure formats, ``"pdf,svg,png"`` or a sequence of them (default ``svg,png``).
    width : {"single", "double"}
        Width of the figures: a journal's single column (85 mm) or a page (175 mm).
    models : str or iterable of str, optional
        Candidate models to fit and rank per subject (``"paper,hertz,maugis,circuit"``):
        writes ``models.csv`` and a ``frequency_response`` figure per subject.
    trial_checks : bool
        Draw the check of every trial (kind ``trial``) when the study folder is there.
    scheduler : distributed.Client, optional
        A Dask cluster for the bootstrap refits (the same results as here).
    progress : callable, optional
        Told what is being done, stage by stage (and trial by trial for the checks).

    Returns
    -------
    CompareResult

    Raises
    ------
    UserInputError
        Missing folder or tables, bad ``fit`` names, parameter file, figure format, width
        or resolution (exit code 2).
    OutputExistsError
        When outputs exist and *force* is False.
    OutputBusyError
        Another process is writing the folder.
    ResultFolderError
        The folder is not one analysis's complete results (exit code 2).
    AnalysisError
        When a fit cannot be made.
    """
    look = _Look(dpi=parse_dpi(dpi),
                 formats=parse_figure_formats(formats), width=parse_figure_width(width))
    names = resolve_fit_names(fit)
    candidates = resolve_models(models) if models is not None else ()
    base = load_parameters(params)
    folder = check_out_folder(out)
    _check_outputs(folder, force)  # before the lock: a refusal writes nothing
    with locked(folder, "evtribo compare"):
        recover(folder)
        tables = read_results(folder)
        _check_outputs(folder, force)
        stale = compare_files(folder)
        with Staging(folder) as stage:
            result = _compare(tables, stage, names, base, look, models=candidates,
                              trial_checks=trial_checks, scheduler=scheduler,
                              progress=progress or (lambda _: None))
            _write_json(stage, result, names, base, params,
                        run_id=tables.summary.run_id)
            stage.commit(remove=stale, last=[FIT_JSON])
    result.files = [folder / rel for rel in result.files]
    log.info("compare: wrote %d files into %s", len(result.files), folder)
    return result


@dataclass(frozen=True)
class _Look:
    """How the figures are written: resolution, formats, width."""

    dpi: float
    formats: tuple[str, ...]
    width: str


@dataclass
class _Figures:
    """Writes figures into a staging folder and records them in a :class:`CompareResult`."""

    folder: Path
    look: _Look
    result: CompareResult

    def emit(self, ax: Any, kind: str, title: str, stem: str, *, subject: str | None = None,
             caption: str = "", extra: Mapping[str, Any] | None = None,
             formats: tuple[str, ...] | None = None, dpi: float | None = None) -> None:
        """Write the figure of *ax* once per format as ``figures/<stem>.<fmt>``, record it.

        Parameters
        ----------
        ax : Axes
            The figure's (first) Axes.
        kind, title, stem, subject, caption : str
            The record in fit.json (:class:`FigureRecord`).
        extra : mapping, optional
            Further keys of the record (``{"trial": "run-01"}``).
        formats : tuple of str, optional
            Formats of this figure (default: those asked for).
        dpi : float, optional
            Resolution of this figure's PNG (default: the one asked for).

        Returns
        -------
        None
        """
        written = save_figure(ax.figure, self.folder, stem, dpi=dpi or self.look.dpi,
                              formats=formats or self.look.formats)
        self.result.files += [Path(FIGURES) / p.name for p in written]
        self.result.figures.append(FigureRecord(kind, title, stem, subject, caption,
                                                dict(extra or {})))


def _compare(tables: ResultTables, stage: Staging, names: tuple[str, ...],
             base: ModelParameters, look: _Look, *, models: tuple[str, ...] = (),
             trial_checks: bool = True, scheduler: Any = None,
             progress: Callable[[str], None]) -> CompareResult:
    """The fits and figures, written into *stage* (``result.files`` relative to it)."""
    only_mu = tables.electrostatic.empty  # a study of OFF trials: its friction, no fit
    if not only_mu:
        replicates = ("" if tables.bootstrap is None else
                      ", refitted to each bootstrap replicate for its interval")
        progress(f"fitting {', '.join(names)} to each of {len(tables.subjects)} subjects"
                 f"{replicates}")
    fits = [] if only_mu else fit_study(tables, base, names, scheduler=scheduler)
    result = CompareResult(out=tables.out, fits=fits)
    result.notes += [NOTE] if only_mu else interval_notes(
        fits, has_bootstrap=tables.bootstrap is not None)
    table = fit_table(fits, tables)
    atomic_write(stage.path(FIT_CSV), table.to_csv(index=False))
    result.files.append(Path(FIT_CSV))
    result.population = pop = population(tables, fits)
    for name, text in pop.files().items():
        atomic_write(stage.path(name), text)
        result.files.append(Path(name))
    figures = _Figures(stage.folder / FIGURES, look, result)
    progress("drawing the figures of the fit" if not only_mu else
             "drawing each subject's friction")
    with journal_style(look.width):
        if only_mu:
            friction_figures(tables, figures.emit)
        else:
            draw_figures(tables, fits, names, figures)
            draw_population(tables.electrostatic, pop, figures.emit)
        if models and not only_mu:
            progress(f"fitting and ranking the models {', '.join(models)}")
            files, notes = write_models(tables, stage, models, base, figures.emit)
            result.files += files
            result.notes += notes
        if trial_checks:
            progress("drawing each trial's check (each trial analysed again, as analyze "
                     "did; --no-trial-checks leaves them out)")
            result.notes += write_trial_checks(tables, figures.emit, look.formats,
                                               progress=progress)
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
        figure) and ``result`` (a :class:`CompareResult`, for notes).

    Returns
    -------
    None
    """
    _all_subjects_figure(tables, fits, figures)
    _subject_figures(tables, fits, names, figures)
    _study_figures(tables, fits, figures)


def _all_subjects_figure(tables: ResultTables, fits: list[SubjectFit],
                         figures: _Figures) -> None:
    """``electrostatic_force_all``: every subject's F_el and fitted model."""
    ax = plot_electrostatic_force_all(tables.electrostatic, {f.subject: f.params for f in fits})
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
                     figures: _Figures) -> None:
    """Per subject: F_el against U, and friction against normal force."""
    mu_how = "fitted." if "mu" in names else "from the measured OFF windows."
    for f in fits:
        s = f.subject
        rows = tables.electrostatic[tables.electrostatic["subject"] == s]
        ax = plot_electrostatic_force(rows, f.params, subject=s)
        figures.emit(ax, "electrostatic_force", f"Electrostatic force vs voltage, {s}",
                     f"electrostatic_force_{safe_name(s)}", subject=s,
                     caption=f"{s}: inferred electrostatic force (points, 95 % intervals) "
                             "and the fitted model (lines) at the subject's mean normal force "
                             "ON, over the amplitudes measured.")
        win = tables.windows[tables.windows["subject"] == s]
        ax = plot_friction_normal_force(win, f.params, subject=s)
        figures.emit(ax, "friction_normal_force", f"Friction vs normal force, {s}",
                     f"friction_normal_force_{safe_name(s)}", subject=s,
                     caption=f"{s}: steady-sliding windows OFF and ON (points) and the model "
                             "(lines, eq. 5, cf. the paper's Figure 6) over the normal forces "
                             f"each drive's windows span; axes zoomed to the windows; μ {mu_how}")


def _study_figures(tables: ResultTables, fits: list[SubjectFit], figures: _Figures) -> None:
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
        ax = plot_friction_time(trace, pick.params, amplitude=amp, normal_force=fn_mean,
                                subject=pick.subject)
        figures.emit(ax, "friction_time", "Friction vs time, sine drive", "friction_time",
                     subject=None,
                     caption=f"Measured sine trial of {pick.subject} and the model evaluated "
                             f"at its measured normal force and the {voltage}, cf. the "
                             "paper's Figure 5.")
    mean_fn = {f.subject: float(np.nanmean(elec.loc[elec["subject"] == f.subject,
                                                    "normal_force_on_N"].to_numpy(float)))
               for f in fits}
    amps = elec["amplitude_V"].to_numpy(float)
    ax = plot_area_increase(mean_fn, {f.subject: f.params for f in fits},
                            u_max=max(150.0, float(np.nanmax(amps))),
                            amplitudes=sorted(set(amps[np.isfinite(amps)].tolist())))
    figures.emit(ax, "area_increase", "Predicted contact-area increase", "area_increase",
                 subject=None,
                 caption="A prediction of the model, nothing measured: JKR over Hertz "
                         "contact area at each subject's mean normal force ON with the fitted "
                         "parameters, cf. the paper's Figure 7.")


def _write_json(stage: Staging, result: CompareResult, names: tuple[str, ...],
                base: ModelParameters, params_file: str | Path | None, *,
                run_id: str | None) -> None:
    """fit.json, into *stage*, naming the analysis fitted and the files written."""
    pfile: dict[str, Any] | None = None
    if params_file is not None:
        p = Path(params_file)
        pfile = {"path": str(p), "sha256": sha256_file(p)}
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
        "output_sha256": {rel.as_posix(): sha256_file(stage.path(rel.as_posix()))
                          for rel in result.files},
    }
    write_fit(stage.path(FIT_JSON), doc)
    result.files.append(Path(FIT_JSON))
