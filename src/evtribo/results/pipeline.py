"""``analyze_study``: a study folder in, the result tables of the study format out, in two
steps: :func:`compute_study` (in memory) and :func:`write_results` (the result folder).

Every input (study.toml, the DBC, each log and sidecar) is hashed once, when the analysis
starts; each worker process gets the trials it is to analyse (their paths, sidecars and log
hashes), reads them through the decoded-trial cache, aligns them and cuts them into windows;
the per-subject estimates are then computed from all windows together. A log identical to
another trial's is the same recording: it is counted once (``duplicate_trials`` and a
warning in ``summary.json``). Warnings are collected per trial into ``summary.json``.

The output folder is written as one unit (:mod:`evtribo.store.resultdir`): locked, written into a
new folder beside it and swapped in at the end, with a ``run_id`` in ``summary.json`` and the
SHA-256 of every table under ``output_sha256``. Nothing already in it is overwritten unless
``force`` is given; ``force`` replaces analyze's files and those of ``compare`` and
``report`` (:mod:`evtribo.results.outputs`), and no others.

Besides the study format's tables, ``electrostatic_bootstrap.csv`` holds the first
:data:`~evtribo.results.aggregate.N_BOOTSTRAP_SAVED` bootstrap replicates of every row of
``electrostatic.csv`` (columns subject, waveform, amplitude_V, replicate,
electrostatic_force_N), those the intervals are the percentiles of (see
:mod:`evtribo.analysis.friction.estimate`); replicate ``i`` of a subject's rows comes from one
resampling of its windows, so they carry the correlation of points that share an OFF
reference. ``evtribo compare`` refits the model to each replicate for its intervals.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import hashlib
import logging
import os
import time
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from evtribo import __version__
from evtribo.analysis.friction.estimate import INTERVAL, MU_ESTIMATOR
from evtribo.analysis.settings import AnalysisSettings, study_settings
from evtribo.analysis.trial import empty_windows, failed_row
from evtribo.documents.result_folder import ResultFolder
from evtribo.documents.summary import SUMMARY_VERSION, Summary
from evtribo.documents.tables import (
    BOOTSTRAP,
    BOOTSTRAP_FILE,
    ELECTROSTATIC,
    EXPONENTS,
    OUTPUT_FILES,
    SINE_TRACE,
    SINE_TRACE_FILE,
    TRIALS,
    WINDOWS,
    TableSchema,
)
from evtribo.errors import StudyError
from evtribo.guard import refuse_cache_in_study
from evtribo.results.aggregate import summarize_study
from evtribo.results.outputs import check_out_dir, check_overwrite, write_analysis
from evtribo.results.provenance import changed_since, input_files, provenance
from evtribo.results.reuse import OutcomeStore, analysis_context, keep_outcome, kept_outcomes
from evtribo.results.workers import (
    ProgressCallback,
    TrialOutcome,
    TrialTask,
    WorkerContext,
    run_tasks,
    say_outcome,
    trial_meta,
)
from evtribo.store.memo import HashMemo, default_cache_dir
from evtribo.store.resultdir import locked, recover
from evtribo.study import StudyFolder, TrialRef, load_study
from evtribo.util.docstrings import fill_doc
from evtribo.warning.collect import collecting, emitter
from evtribo.warning.record import Scope, WarningRecord

log = logging.getLogger(__name__)
emit = emitter(__name__)



@dataclass(eq=False)
class StudyResults(ResultFolder):
    """A study's results (:class:`~evtribo.documents.result_folder.ResultFolder`: the
    tables as computed, what :func:`write_results` writes, and summary.json, its
    ``output_sha256`` filled in when written): computed by :func:`compute_study`, written by
    :func:`write_results` (:func:`analyze_study` does both).

    Attributes
    ----------
    compute_s : float
        Seconds the computation took (``elapsed_s`` adds the writing's).
    """

    compute_s: float = 0.0

    @property
    def out_dir(self) -> Path | None:
        """The folder the results were written to (None: in memory only)."""
        return self.out


def _plan(study: StudyFolder, inputs: list[dict[str, Any]]
          ) -> tuple[list[TrialTask], list[TrialOutcome], list[dict[str, Any]]]:
    """The trials to analyse, as hashed; those not analysed: logs being written while
    hashed (failed) and logs identical to another trial's (counted once, as that trial,
    said: ``same-log``).

    Returns (tasks, failed outcomes, duplicates)."""
    by_path = {r["_path"]: r for r in inputs}
    tasks: list[TrialTask] = []
    failed: list[TrialOutcome] = []
    duplicates: list[dict[str, Any]] = []
    first: dict[str, TrialRef] = {}
    for index, ref in enumerate(study.trials):
        rec = by_path[os.path.abspath(ref.log_path)]
        if rec["_mtime_ns"] < 0:
            failed.append(TrialOutcome(
                index, failed_row(trial_meta(ref)),
                error=f"{ref.log_path}: was being written while the analysis read it "
                      "(a recording in progress?); not analysed"))
            continue
        same = first.setdefault(rec["sha256"], ref)
        if same is not ref:
            duplicates.append({"trial": ref.key, "same_as": same.key, "sha256": rec["sha256"]})
            diff = [k for k in ("waveform", "frequency_Hz", "amplitude_V", "condition")
                    if getattr(same.sidecar, k) != getattr(ref.sidecar, k)]
            differ = (f"; their sidecars differ in {', '.join(diff)} ({same.key}'s values "
                      "are used)") if diff else ""
            emit("same-log", Scope(ref.subject, ref.name), log=str(ref.log_path),
                 same=same.key, same_log=str(same.log_path), sha256=rec["sha256"][:12],
                 differ=differ)
            continue
        tasks.append(TrialTask(index, ref, (rec["sha256"], rec["bytes"], rec["_mtime_ns"])))
    return tasks, failed, duplicates


def _write_csv(schema: TableSchema, df: pd.DataFrame, path: Path) -> str:
    """Write a table; return the SHA-256 of the bytes written."""
    data = schema.text(df).encode("utf-8")
    path.write_bytes(data)
    return hashlib.sha256(data).hexdigest()


def _typed(df: pd.DataFrame, schema: TableSchema) -> pd.DataFrame:
    """*df* with the table's columns in order, the counts as nullable integers (what is
    written: the rest as computed)."""
    df = df.reindex(columns=list(schema.names()))
    for c in schema.columns:
        if c.kind == "count":
            df[c.name] = pd.to_numeric(df[c.name], errors="coerce").astype("Int64")
    return df


@fill_doc
def analyze_study(
    study_dir: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    jobs: int | None = None,
    strict: bool = False,
    force: bool = False,
    *,
    cache_dir: str | os.PathLike[str] | None = None,
    settings: AnalysisSettings | None = None,
    overrides: Mapping[str, Any] | None = None,
    progress: ProgressCallback | None = None,
    scheduler: Any = None,
    reuse: bool = True,
) -> StudyResults:
    """Analyse every trial of a study and write the study format's result tables.

    Parameters
    ----------
    %(study_dir)s
    out_dir : path-like
        Where ``trials.csv``, ``windows.csv``, ``electrostatic.csv``, ``exponents.csv`` and
        ``summary.json`` go (created if needed).
    %(jobs)s
    %(strict)s
    force : bool
        Replace the results in *out_dir*: analyze's, and the model fit, figures and reports
        of ``evtribo compare`` and ``evtribo report`` (their files only).
    %(cache_dir)s
    settings : AnalysisSettings, optional
        The settings to start from (default: the package's defaults); the study's
        ``[analysis]`` table and *overrides* apply on top.
    overrides : mapping, optional
        Settings that take precedence over the study's (``{"tare": "none"}``).
    %(progress)s
    scheduler : distributed.Client, optional
        A Dask cluster to run the trials on (:mod:`evtribo.results.distributed`); every
        path absolute, seen by every worker.
    %(reuse)s

    Returns
    -------
    StudyResults

    Raises
    ------
    OutputExistsError
        An output exists and ``force`` is False.
    OutputBusyError
        Another process is writing *out_dir*.
    StudyError, SidecarError, RigConfigError
        The study folder is wrong.
    UserInputError
        *out_dir* is inside the study folder.
    LogFormatError
        A damaged line under ``strict``.
    OutputWriteError
        The results could not be written (a full disk); *out_dir* is left as it was.

    Notes
    -----
    *out_dir* is written as one unit (:mod:`evtribo.store.resultdir`): under a lock, into a new
    folder beside it, swapped in at the end; killed at any moment, it holds the results it
    held before or all of the new ones. Each input is hashed once, when the analysis starts;
    ``summary.json`` records those hashes and a ``run_id`` that ``compare`` and ``report``
    check the rest of the folder against.
    """
    out = Path(out_dir)
    check_overwrite(out, force)
    study, settings = _prepare(study_dir, overrides, settings)
    check_out_dir(out, study.root)
    refuse_cache_in_study(cache_dir, study.root)
    with locked(out, "evtribo analyze"):
        recover(out)
        check_overwrite(out, force)
        results = _analyze_locked(study, settings, jobs=jobs, strict=strict,
                                  cache_dir=cache_dir, progress=progress, scheduler=scheduler,
                                  reuse=reuse)
        return write_results(results, out, force=force)


@fill_doc
def compute_study(study: StudyFolder | str | os.PathLike[str], *, jobs: int | None = None,
                  strict: bool = False, cache_dir: str | os.PathLike[str] | None = None,
                  settings: AnalysisSettings | None = None,
                  overrides: Mapping[str, Any] | None = None,
                  progress: ProgressCallback | None = None,
                  scheduler: Any = None, reuse: bool = True) -> StudyResults:
    """Analyse every trial of a study in memory, writing nothing (but the decoded-trial
    cache; the errors are :func:`analyze_study`'s); :func:`write_results` writes them.

    Parameters
    ----------
    study : StudyFolder or path-like
        The study (:func:`evtribo.study.load_study`) or its folder.
    %(jobs)s
    %(strict)s
    %(cache_dir)s
    settings : AnalysisSettings, optional
        The settings to start from; the study's ``[analysis]`` table applies on top.
    overrides : mapping, optional
        Settings over the study's (``{"tare": "none"}``).
    %(progress)s
    scheduler : distributed.Client, optional
        A Dask cluster to run the trials on.
    %(reuse)s

    Returns
    -------
    StudyResults
        With ``out_dir`` None.
    """
    study, settings = _prepare(study, overrides, settings)
    return _analyze_locked(study, settings, jobs=jobs, strict=strict, cache_dir=cache_dir,
                           progress=progress, scheduler=scheduler, reuse=reuse)


def _prepare(study: StudyFolder | str | os.PathLike[str], overrides: Mapping[str, Any] | None,
             settings: AnalysisSettings | None) -> tuple[StudyFolder, AnalysisSettings]:
    """The study loaded, its settings, and a refusal of a study without trials."""
    study = study if isinstance(study, StudyFolder) else load_study(study)
    settings = study_settings(study, overrides, settings)
    if not study.trials:
        raise StudyError("the study holds no trials (no <subject>/<trial>.log files)",
                         path=study.root)
    return study, settings


def _analyze_locked(study: StudyFolder, settings: AnalysisSettings, *, jobs: int | None,
                    strict: bool, cache_dir: str | os.PathLike[str] | None,
                    progress: ProgressCallback | None, scheduler: Any = None,
                    reuse: bool = True) -> StudyResults:
    """The analysis in memory (:func:`analyze_study`'s under the output folder's lock)."""
    started = time.perf_counter()
    started_at = time.time()
    folder = default_cache_dir() if cache_dir is None else cache_dir
    memo = HashMemo(folder, study.root)
    inputs = input_files(study, memo)  # each input hashed once, here (or when it last changed)
    memo.save()
    with collecting() as planned:
        tasks, not_run, duplicates = _plan(study, inputs)
    assert study.rig is not None
    store = OutcomeStore(folder if reuse else None,
                         analysis_context(study.rig, settings, strict), sketches=folder)
    kept, tasks = kept_outcomes(store, tasks)
    jobs = (os.cpu_count() or 1) if jobs is None else max(1, int(jobs))
    jobs = max(1, min(jobs, len(tasks)))
    if scheduler is not None and not isinstance(scheduler, str):
        from evtribo.results.distributed import total_threads
        jobs = total_threads(scheduler)
    context = WorkerContext(study.rig, None if cache_dir is None else os.fspath(cache_dir),
                            strict, settings)
    by_index = {t.index: t for t in tasks}
    done = run_tasks(tasks, jobs, context, progress, scheduler=scheduler,  # each kept at once
                     on_outcome=lambda outcome: keep_outcome(store, by_index[outcome.index],
                                                             outcome))
    outcomes = sorted([*kept, *done, *not_run], key=lambda r: r.index)  # the study's order
    tables = _Tables.of(outcomes, settings)
    with collecting() as changed:
        changed_since(inputs)
    warnings = [*study.warnings, *planned, *tables.warnings, *changed]
    summary = _summary(study, tables, settings, started_at=started_at, inputs=inputs,
                       duplicates=duplicates, warnings=warnings, strict=strict, jobs=jobs)
    log.info("analysed %d of %d trials of %s", summary["trials_analysed"],
             len(study.trials), study.root)
    return StudyResults(out=None, trials=tables.trials, windows=tables.windows,
                        electrostatic=tables.electrostatic, exponents=tables.exponents,
                        summary=Summary(summary), bootstrap=tables.bootstrap,
                        sine_trace=tables.trace, compute_s=time.perf_counter() - started)


def write_results(results: StudyResults, out_dir: str | os.PathLike[str], *,
                  force: bool = False) -> StudyResults:
    """Write a study's results into *out_dir* as one unit, as ``evtribo analyze`` does.

    Parameters
    ----------
    results : StudyResults
    out_dir : path-like
        The result folder (created if needed), outside the study folder.
    force : bool
        As :func:`analyze_study`'s.

    Returns
    -------
    StudyResults
        *results* with ``out_dir`` set and the summary as written (``output_sha256``,
        ``elapsed_s``); *results* itself is left as it was.

    Raises
    ------
    OutputExistsError, OutputBusyError, UserInputError, OutputWriteError
        As :func:`analyze_study`; *out_dir* is left as it was.
    """
    started = time.perf_counter()
    out = Path(out_dir)
    check_overwrite(out, force)
    check_out_dir(out, Path(results.summary["study_dir"]))
    summary = copy.deepcopy(results.summary.data)
    summary["output_sha256"] = {}
    with locked(out, "evtribo analyze"):
        recover(out)
        check_overwrite(out, force)
        _write(out, _files(results), summary,
               results.compute_s + time.perf_counter() - started)
    return dataclasses.replace(results, out=out, summary=Summary(summary))


def _files(results: StudyResults) -> dict[str, tuple[TableSchema, pd.DataFrame]]:
    """The CSV files to write, by name, each with its schema."""
    files = {TRIALS.file: (TRIALS, results.trials), WINDOWS.file: (WINDOWS, results.windows),
             ELECTROSTATIC.file: (ELECTROSTATIC, results.electrostatic),
             EXPONENTS.file: (EXPONENTS, results.exponents),
             BOOTSTRAP.file: (BOOTSTRAP, BOOTSTRAP.empty() if results.bootstrap is None
                              else results.bootstrap)}
    if results.sine_trace is not None:
        files[SINE_TRACE.file] = (SINE_TRACE, results.sine_trace)
    return files


@dataclass
class _Tables:
    """The result tables of a study's trials, and what gathering them found to say."""

    trials: pd.DataFrame
    windows: pd.DataFrame
    electrostatic: pd.DataFrame
    exponents: pd.DataFrame
    bootstrap: pd.DataFrame
    trace: pd.DataFrame | None
    failed: list[dict[str, str]]
    warnings: list[WarningRecord]

    @classmethod
    def of(cls, outcomes: list[TrialOutcome], settings: AnalysisSettings) -> _Tables:
        """The trials' rows, windows and traces gathered (in the study's order), the
        per-subject estimates computed from all windows together, the trials' warnings
        and errors collected."""
        with collecting() as warnings:
            for o in outcomes:  # each trial's warnings said here, once, in the study's order
                say_outcome(o)
            trials = _typed(pd.DataFrame([o.row for o in outcomes]), TRIALS)
            frames = [o.windows for o in outcomes if not o.windows.empty]
            windows = (pd.concat(frames, ignore_index=True) if frames else empty_windows())
            windows = windows.reindex(columns=list(WINDOWS.names()))
            found = summarize_study(windows, trials, n_boot=settings.n_boot,
                                    seed=settings.seed, confidence=settings.confidence,
                                    friction_law=settings.friction_law)
            warnings.extend(found.warnings)  # said as they were found
            if found.electrostatic.empty and not windows.empty:
                if not (windows.condition == "on").any():
                    emit("no-on-window", windows=len(windows))
                else:
                    emit("no-force-anywhere")
        failed = [{"trial": f"{o.row['subject']}/{o.row['trial']}", "error": o.error}
                  for o in outcomes if o.error is not None]
        windows = windows.assign(mu_reference=found.window_mu.reindex(windows.index))
        trials = trials.assign(mu_change_per_10s=pd.Series([
            found.mu_change.get(k) for k in zip(trials.subject, trials.trial, strict=True)],
            index=trials.index, dtype=float))
        traces = [o.trace for o in outcomes if o.trace is not None and not o.trace.empty]
        trace = (pd.concat(traces, ignore_index=True)
                 .reindex(columns=list(SINE_TRACE.names())) if traces else None)
        return cls(trials, windows, _typed(found.electrostatic, ELECTROSTATIC),
                   _typed(found.exponents, EXPONENTS),
                   found.bootstrap.reindex(columns=list(BOOTSTRAP.names())), trace, failed,
                   list(warnings))


def _summary(study: StudyFolder, tables: _Tables, settings: AnalysisSettings, *, started_at: float,
             inputs: list[dict[str, Any]], duplicates: list[dict[str, Any]],
             warnings: list[WarningRecord], strict: bool, jobs: int) -> dict[str, Any]:
    """The content of summary.json (``output_sha256`` and ``elapsed_s`` filled in when the
    tables are written)."""
    n = len(study.trials)
    trials, windows, bootstrap = tables.trials, tables.windows, tables.bootstrap
    assert study.rig is not None

    def total(col: str) -> int:
        return int(pd.to_numeric(trials[col], errors="coerce").fillna(0).sum())

    return {
        "study": study.name,
        "run_id": uuid.uuid4().hex,
        "evtribo_version": __version__,
        "summary_version": SUMMARY_VERSION,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        **provenance(study, started_at, inputs),
        "subjects": study.subjects,
        "trials": n,
        "trials_analysed": n - len(tables.failed) - len(duplicates),
        "failed_trials": tables.failed,
        "duplicate_trials": duplicates,
        "windows_on": int(np.count_nonzero(windows.condition == "on")),
        "windows_off": int(np.count_nonzero(windows.condition == "off")),
        "frames": total("frames"),
        "dropped_frames": total("dropped_frames"),
        "skipped_lines": total("skipped_lines"),
        "strict": strict,
        "jobs": jobs,
        "calibration": study.rig.calibration.to_dict(),
        "settings": {**settings.to_dict(), "mu_estimator": MU_ESTIMATOR,
                     "interval": INTERVAL,
                     "bootstrap_replicates_saved": int(bootstrap.replicate.nunique())
                     if not bootstrap.empty else 0},
        "warnings": [w.as_json() for w in warnings],
        "outputs": list(OUTPUT_FILES) + ([SINE_TRACE_FILE] if tables.trace is not None
                                         else []),
        "output_sha256": {},
        "elapsed_s": None,
    }


def _write(out: Path, files: dict[str, tuple[TableSchema, pd.DataFrame]],
           summary: dict[str, Any], elapsed: float) -> None:
    """The tables and summary.json written into *out* as one unit
    (:func:`~evtribo.results.outputs.write_analysis`)."""
    write_analysis(out, {name: functools.partial(_write_csv, schema, table)
                         for name, (schema, table) in files.items()}, summary, elapsed)


__all__ = ["BOOTSTRAP_FILE", "OUTPUT_FILES", "SINE_TRACE_FILE", "StudyResults", "analyze_study",
           "compute_study", "study_settings", "write_results"]
