"""``evtribo compare``: fit the model to a result folder and draw the comparison figures.

Writes into the result folder:

- ``fit.csv``: one row per subject and fitted parameter
  (:data:`~evtribo.compare.fit_csv.FIT_COLUMNS`);
- ``fit.json``: what was fitted, the fixed parameters, each subject's full parameter set,
  how its intervals were obtained (``interval``: ``bootstrap``, refits to the force
  replicates of ``electrostatic_bootstrap.csv``, or ``jacobian``, the fallback that takes
  the points' errors as independent), the figures and notes (read by ``evtribo report``);
- ``figures/``: each figure as PNG and SVG.

``fit.json`` also records the ``run_id`` of the analysis it fitted (from ``summary.json``)
and the SHA-256 of every file compare wrote (``output_sha256``), which ``evtribo report``
checks. The folder is locked and written as one unit (:mod:`evtribo.resultdir`); it is read
only if it is one analysis's complete results (:func:`~evtribo.compare.tables.read_results`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from evtribo import __version__
from evtribo.analysis.outputs import FIGURES, FIT_CSV, FIT_JSON, compare_files
from evtribo.compare.fit import SubjectFit, fit_study
from evtribo.compare.fit_csv import fit_table
from evtribo.compare.params import load_parameters, resolve_fit_names
from evtribo.compare.plots import (
    plot_area_increase,
    plot_electrostatic_force,
    plot_friction_normal_force,
    plot_friction_time,
    safe_name,
    save_figure,
)
from evtribo.compare.tables import ResultTables, check_out_folder, read_results
from evtribo.documents.fit import write_fit
from evtribo.errors import OutputExistsError
from evtribo.files import atomic_write, sha256_file
from evtribo.model.params import ModelParameters
from evtribo.resultdir import Staging, locked, recover

log = logging.getLogger(__name__)

__all__ = ["FIGURES", "FIT_CSV", "FIT_JSON", "CompareResult", "FigureRecord", "compare",
           "figure_stems"]


@dataclass(frozen=True)
class FigureRecord:
    """One figure written by :func:`compare`: its kind, subject (or None) and files."""

    kind: str
    title: str
    stem: str
    subject: str | None
    caption: str


@dataclass
class CompareResult:
    """What :func:`compare` did."""

    out: Path
    fits: list[SubjectFit]
    files: list[Path] = field(default_factory=list)
    figures: list[FigureRecord] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def figure_stems(subjects: Iterable[str]) -> list[str]:
    """File stems of the figures :func:`compare` writes for these subjects.

    Parameters
    ----------
    subjects : iterable of str
        The subjects, in order.

    Returns
    -------
    list of str
        The two figures of the whole study, then two per subject.
    """
    stems = ["friction_time", "area_increase"]
    for s in subjects:
        stems += [f"electrostatic_force_{safe_name(s)}", f"friction_normal_force_{safe_name(s)}"]
    return stems


def _check_outputs(out: Path, force: bool) -> None:
    existing = compare_files(out)
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
            params: str | Path | None = None, force: bool = False, dpi: float = 150,
            formats: tuple[str, ...] = ("png", "svg"),
            scheduler: Any = None) -> CompareResult:
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
    dpi : float
        Resolution of the PNG figures, dots per inch.
    formats : tuple of str
        Figure formats.
    scheduler : distributed.Client, optional
        A Dask cluster for the bootstrap refits (the same results as here).

    Returns
    -------
    CompareResult

    Raises
    ------
    UserInputError
        Missing folder or tables, bad ``fit`` names or parameter file (exit code 2).
    OutputExistsError
        When outputs exist and *force* is False.
    OutputBusyError
        Another process is writing the folder.
    ResultFolderError
        The folder is not one analysis's complete results (exit code 2).
    AnalysisError
        When a fit cannot be made.
    """
    names = resolve_fit_names(fit)
    base = load_parameters(params)
    folder = check_out_folder(out)
    _check_outputs(folder, force)  # before the lock: a refusal writes nothing
    with locked(folder, "evtribo compare"):
        recover(folder)
        tables = read_results(folder)
        _check_outputs(folder, force)
        stale = compare_files(folder)
        with Staging(folder) as stage:
            result = _compare(tables, stage, names, base, dpi=dpi, formats=formats,
                              scheduler=scheduler)
            _write_json(stage, result, names, base, params,
                        run_id=tables.summary.run_id)
            stage.commit(remove=stale, last=[FIT_JSON])
    result.files = [folder / rel for rel in result.files]
    log.info("compare: wrote %d files into %s", len(result.files), folder)
    return result


def _compare(tables: ResultTables, stage: Staging, names: tuple[str, ...],
             base: ModelParameters, *, dpi: float, formats: tuple[str, ...],
             scheduler: Any = None) -> CompareResult:
    """The fits and figures, written into *stage* (``result.files`` relative to it)."""
    folder = tables.out
    subjects = tables.subjects
    fits = fit_study(tables, base, names, scheduler=scheduler)
    result = CompareResult(out=folder, fits=fits)
    result.notes += _interval_notes(fits, has_bootstrap=tables.bootstrap is not None)
    table = fit_table(fits, tables)
    atomic_write(stage.path(FIT_CSV), table.to_csv(index=False))
    result.files.append(Path(FIT_CSV))

    by_subject = {f.subject: f for f in fits}
    fig_dir = stage.folder / FIGURES

    def emit(ax: Any, kind: str, title: str, stem: str, *, subject: str | None,
             caption: str) -> None:
        written = save_figure(ax.figure, fig_dir, stem, dpi=dpi, formats=formats)
        result.files += [Path(FIGURES) / p.name for p in written]
        result.figures.append(FigureRecord(kind, title, stem, subject, caption))

    mu_how = "fitted." if "mu" in names else "from the measured OFF windows."
    for s in subjects:
        f = by_subject[s]
        rows = tables.electrostatic[tables.electrostatic["subject"] == s]
        emit(plot_electrostatic_force(rows, f.params, subject=s), "electrostatic_force",
             f"Electrostatic force vs voltage, {s}", f"electrostatic_force_{safe_name(s)}",
             subject=s,
             caption="Inferred electrostatic force (95 % intervals) and the fitted model at "
                     "the subject's mean normal force ON; dotted: a U² power law for "
                     "reference.")
        win = tables.windows[tables.windows["subject"] == s]
        emit(plot_friction_normal_force(win, f.params, subject=s), "friction_normal_force",
             f"Friction vs normal force, {s}", f"friction_normal_force_{safe_name(s)}",
             subject=s,
             caption="Steady-sliding windows OFF and ON and the model (eq. 5, cf. the "
                     f"paper's Figure 6); μ {mu_how}")

    trace, trace_subject = _first_trace(tables)
    pick = by_subject.get(trace_subject or "", fits[0])
    sine_rows = tables.electrostatic[tables.electrostatic["waveform"].astype(str) == "sine"]
    amp = float(sine_rows["amplitude_V"].max()) if not sine_rows.empty else 140.0
    fn_mean = float(np.nanmean(tables.electrostatic["normal_force_on_N"].to_numpy(float)))
    if trace is None:
        result.notes.append("No sine_trace.csv in the result folder: the friction-versus-time "
                            "figure shows the model alone (10 Hz sine, "
                            f"{amp:g} V, {fn_mean:.2g} N), without a measured trace.")
        caption = ("Model only (no measured sine trace was available): friction with the "
                   "voltage ON and OFF, cf. the paper's Figure 5.")
    else:
        voltage = ("measured voltage" if "voltage_V" in trace.columns else
                   "drive's amplitude and frequency (its phase, which the rig does not record, "
                   "chosen to match the measured friction)")
        caption = (f"Measured sine trial of {pick.subject} and the model evaluated at its "
                   f"measured normal force and the {voltage}, cf. the paper's Figure 5.")
    emit(plot_friction_time(trace, pick.params, amplitude=amp,
                            normal_force=fn_mean, subject=pick.subject),
         "friction_time", "Friction vs time, sine drive", "friction_time", subject=None,
         caption=caption)

    mean_fn = {s: float(np.nanmean(tables.electrostatic.loc[
        tables.electrostatic["subject"] == s, "normal_force_on_N"].to_numpy(float)))
        for s in subjects}
    u_max = max(150.0, float(tables.electrostatic["amplitude_V"].max()))
    emit(plot_area_increase(mean_fn, {s: by_subject[s].params for s in subjects},
                            u_max=u_max),
         "area_increase", "Predicted contact-area increase", "area_increase", subject=None,
         caption="JKR over Hertz contact area at each subject's mean normal force ON with "
                 "the fitted parameters, cf. the paper's Figure 7.")

    return result


def _interval_notes(fits: list[SubjectFit], *, has_bootstrap: bool) -> list[str]:
    """What fit.json's notes say about how the intervals were obtained."""
    jac = [f for f in fits if f.interval_method != "bootstrap"]
    boot = [f for f in fits if f.interval_method == "bootstrap"]
    notes = []
    if boot:
        notes.append(f"Intervals of {', '.join(f.subject for f in boot)}: 2.5-97.5 % "
                     "percentiles of the parameters refitted to the bootstrap replicates of "
                     f"the electrostatic forces ({boot[0].n_replicates} replicates, "
                     "electrostatic_bootstrap.csv), which carry the errors the points share "
                     "through a common OFF reference.")
    if jac and not has_bootstrap:
        notes.append("No electrostatic_bootstrap.csv in the result folder (results of an "
                     "older evtribo analyze?): intervals from the Jacobian, with each "
                     "point's error taken as independent; they are too narrow when several "
                     "amplitudes share an OFF reference. Re-run evtribo analyze to get the "
                     "replicates.")
    elif jac:
        for f in jac:
            why = f.interval_note or "no replicates for some of its points"
            notes.append(f"Intervals of {f.subject} from the Jacobian (each point's error "
                         f"taken as independent): {why}.")
    return notes


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
        "figures": [{"kind": r.kind, "title": r.title, "stem": r.stem, "subject": r.subject,
                     "caption": r.caption} for r in result.figures],
        "notes": result.notes,
        "output_sha256": {rel.as_posix(): sha256_file(stage.path(rel.as_posix()))
                          for rel in result.files},
    }
    write_fit(stage.path(FIT_JSON), doc)
    result.files.append(Path(FIT_JSON))
