"""``analyze_study``: a study folder in, the result tables of the study format out.

Every input (study.toml, the DBC, each log and sidecar) is hashed once, when the analysis
starts; each worker process gets the trials it is to analyse (their paths, sidecars and log
hashes), reads them through the decoded-trial cache, aligns them and cuts them into windows;
the per-subject estimates are then computed from all windows together. A log identical to
another trial's is the same recording: it is counted once (``duplicate_trials`` and a
warning in ``summary.json``). Warnings (the analysis's own, and the readers': damaged lines,
unknown frames...) are collected per trial into ``summary.json``.

The output folder is written as one unit (:mod:`evtribo.resultdir`): locked, written into a
new folder beside it and swapped in at the end, with a ``run_id`` in ``summary.json`` and the
SHA-256 of every table under ``output_sha256``. Nothing already in it is overwritten unless
``force`` is given; ``force`` replaces analyze's files and those of ``compare`` and
``report`` (:mod:`evtribo.analysis.outputs`), and no others.

Besides the study format's tables, ``electrostatic_bootstrap.csv`` holds the first
:data:`~evtribo.analysis.aggregate.N_BOOTSTRAP_SAVED` bootstrap replicates of every row of
``electrostatic.csv`` (columns subject, waveform, amplitude_V, replicate,
electrostatic_force_N; one row per electrostatic.csv row and replicate). The replicates are
the ones the intervals are the percentiles of (calibrated for few windows, see
:mod:`evtribo.analysis.estimate`), and replicate ``i`` of all a subject's rows comes from one
resampling of its windows, so they carry the correlation between points that share an OFF
reference. ``evtribo compare`` refits the model to each replicate for its intervals.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import signal
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from evtribo import __version__
from evtribo.analysis.aggregate import (
    BOOTSTRAP_COLUMNS,
    ELECTROSTATIC_COLUMNS,
    EXPONENT_COLUMNS,
    summarize,
)
from evtribo.analysis.outputs import (
    ANALYSIS_FILES,
    BOOTSTRAP_FILE,
    OUTPUT_FILES,
    SINE_TRACE_FILE,
    SUMMARY_FILE,
    check_out_dir,
    check_overwrite,
    compare_files,
    report_files,
)
from evtribo.analysis.provenance import changed_since, input_files, provenance
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import (
    SINE_TRACE_CSV_COLUMNS,
    TRIAL_COLUMNS,
    WINDOW_CSV_COLUMNS,
    TrialMeta,
    analyze_signals,
    empty_windows,
    failed_row,
)
from evtribo.cache import load_trial
from evtribo.errors import AnalysisError, SidecarError, StudyError, UserInputError
from evtribo.resultdir import Staging, locked, recover, release_inherited_locks
from evtribo.rig import Rig
from evtribo.signals import TrialSignals
from evtribo.study import STUDY_FILE, Study, TrialRef, load_study

log = logging.getLogger(__name__)

#: Most warnings kept per trial in summary.json (the rest are counted).
MAX_WARNINGS_PER_TRIAL = 20

_INT_COLUMNS = ("frames", "dropped_frames", "skipped_lines", "n_on", "n_off")

ProgressCallback = Callable[[int, int], None]


@dataclass
class StudyResults:
    """What :func:`analyze_study` wrote.

    Attributes
    ----------
    out_dir : Path
    trials, windows, electrostatic, exponents : pandas.DataFrame
        The tables of the CSV files.
    summary : dict
        The content of summary.json.
    """

    out_dir: Path
    trials: pd.DataFrame
    windows: pd.DataFrame
    electrostatic: pd.DataFrame
    exponents: pd.DataFrame
    summary: dict[str, Any]


class _Collector(logging.Handler):
    """Keeps the warnings other evtribo modules log while one trial is processed."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if not record.name.startswith("evtribo.analysis"):
            self.messages.append(record.getMessage())


_WORKER: dict[str, Any] = {}


@dataclass(frozen=True)
class _Task:
    """One trial for a worker: its place in the study, where it is, what its sidecar says,
    and its log as hashed when the analysis started (sha256, size, modification time ns)."""

    index: int
    ref: TrialRef
    log: tuple[str, int, int]


def _setup(rig: Rig, cache_dir: str | None, strict: bool, settings: AnalysisSettings) -> None:
    _WORKER.update(rig=rig, cache_dir=cache_dir, strict=strict, settings=settings)


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(0.5)
    os._exit(1)  # the analysis was killed (SIGKILL, a crash): nobody wants our results


def _init_process(*args: Any) -> None:
    """A worker process: the parent stops it (Ctrl-C reaches the whole process group, the
    parent handles it), it ends when the parent is gone, and it does not keep the parent's
    locks."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True,
                     name="evtribo-parent-watch").start()
    release_inherited_locks()
    _setup(*args)


_Result = tuple[int, dict[str, Any], pd.DataFrame, list[str], str | None, pd.DataFrame | None]


def _meta(ref: TrialRef) -> TrialMeta:
    """The trial's names and its sidecar's values."""
    return TrialMeta.from_sidecar(ref.subject, ref.name, ref.sidecar)


def _load(ref: TrialRef, rig: Rig, strict: bool, expect: tuple[str, int, int] | None
          ) -> TrialSignals:
    """The trial's signals, from the channel its sidecar's ``log_channel`` names when the log
    holds several."""
    channel = ref.sidecar.extra.get("log_channel")
    channel = channel if isinstance(channel, str) and channel else None
    try:
        return load_trial(ref.log_path, rig, _WORKER["cache_dir"], strict, expect=expect,
                          channel=channel)
    except UserInputError as err:
        if channel is None or err.key != "channel":
            raise
        raise SidecarError(err.message, path=ref.sidecar_path, key="log_channel") from err


def _analyze_one(task: _Task) -> _Result:
    strict, rig = _WORKER["strict"], _WORKER["rig"]
    ref = task.ref
    meta = _meta(ref)
    trace: pd.DataFrame | None = None
    collector = _Collector()
    root_logger = logging.getLogger("evtribo")
    root_logger.addHandler(collector)
    try:
        signals = _load(ref, rig, strict, task.log)
        result = analyze_signals(signals, meta, settings=_WORKER["settings"],
                                 calibration=rig.calibration)
        row, windows, warnings, error = result.row, result.windows, result.warnings, None
        trace = result.trace
        if row.get("skipped_lines"):
            warnings.append(f"{ref.key}: {row['skipped_lines']} damaged line(s) skipped in "
                            f"{ref.log_path}")
    except AnalysisError as err:
        row, windows, warnings, error = failed_row(meta), empty_windows(), [], str(err)
    except UserInputError as err:
        if strict:
            raise
        row, windows, warnings, error = failed_row(meta), empty_windows(), [], str(err)
    except Exception as err:  # one trial's fault must not cost the others their results
        if strict:
            raise
        log.debug("%s: analysis failed", ref.key, exc_info=True)
        row, windows, warnings = failed_row(meta), empty_windows(), []
        error = f"{ref.log_path}: {type(err).__name__}: {err} (run with --strict --debug " \
                "for the traceback)"
    finally:
        root_logger.removeHandler(collector)
    details = [f"{ref.key}: {m}" for m in collector.messages]
    if len(details) > MAX_WARNINGS_PER_TRIAL:
        extra = len(details) - MAX_WARNINGS_PER_TRIAL
        details = [*details[:MAX_WARNINGS_PER_TRIAL], f"{ref.key}: ... and {extra} more"]
    return task.index, row, windows, details + warnings, error, trace


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """Stop a pool's worker processes now (they would finish their trial otherwise)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        proc.terminate()
    for proc in processes:
        proc.join(10)


def _run_tasks(tasks: list[_Task], jobs: int, init_args: tuple[Any, ...],
               progress: ProgressCallback | None) -> list[_Result]:
    """Each task's result, in worker processes (*jobs* > 1) or here."""
    results: list[_Result] = []
    if jobs == 1:
        _setup(*init_args)
        for task in tasks:
            results.append(_analyze_one(task))
            if progress:
                progress(len(results), len(tasks))
        return results
    pool = ProcessPoolExecutor(max_workers=jobs, initializer=_init_process,
                               initargs=init_args)
    try:
        futures = [pool.submit(_analyze_one, task) for task in tasks]
        for fut in as_completed(futures):
            results.append(fut.result())
            if progress:
                progress(len(results), len(tasks))
    except BaseException:  # an error, Ctrl-C, SIGTERM: no worker outlives the analysis
        _stop_workers(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return results


def _plan(study: Study, inputs: list[dict[str, Any]]
          ) -> tuple[list[_Task], list[_Result], list[dict[str, Any]], list[str]]:
    """The trials to analyse, as hashed; those not analysed: logs being written while
    hashed (failed) and logs identical to another trial's (counted once, as that trial).

    Returns (tasks, failed results, duplicates, warnings)."""
    by_path = {r["_path"]: r for r in inputs}
    tasks: list[_Task] = []
    failed: list[_Result] = []
    duplicates: list[dict[str, Any]] = []
    warnings: list[str] = []
    first: dict[str, TrialRef] = {}
    for index, ref in enumerate(study.trials):
        rec = by_path[os.path.abspath(ref.log_path)]
        if rec["_mtime_ns"] < 0:
            failed.append((index, failed_row(_meta(ref)), empty_windows(), [],
                           f"{ref.log_path}: was being written while the analysis read it "
                           "(a recording in progress?); not analysed", None))
            continue
        same = first.setdefault(rec["sha256"], ref)
        if same is not ref:
            duplicates.append({"trial": ref.key, "same_as": same.key, "sha256": rec["sha256"]})
            diff = [k for k in ("waveform", "frequency_Hz", "amplitude_V", "condition")
                    if getattr(same.sidecar, k) != getattr(ref.sidecar, k)]
            differ = (f"; their sidecars differ in {', '.join(diff)} ({same.key}'s values "
                      "are used)") if diff else ""
            warnings.append(
                f"{ref.key}: its log {ref.log_path} is identical to {same.key}'s "
                f"({same.log_path}, sha256 {rec['sha256'][:12]}...): the same recording under "
                f"two names, counted once, as {same.key}{differ}")
            continue
        tasks.append(_Task(index, ref, (rec["sha256"], rec["bytes"], rec["_mtime_ns"])))
    return tasks, failed, duplicates, warnings


def _write_csv(df: pd.DataFrame, path: Path) -> str:
    """Write a table; return the SHA-256 of the bytes written."""
    data = df.to_csv(index=False).encode("utf-8")
    path.write_bytes(data)
    return hashlib.sha256(data).hexdigest()


def _typed(df: pd.DataFrame, columns: tuple[str, ...]) -> pd.DataFrame:
    df = df.reindex(columns=list(columns))
    for c in _INT_COLUMNS:
        if c in df.columns:
            df[c] = pd.to_numeric(df[c], errors="coerce").astype("Int64")
    return df


def study_settings(study: Study, overrides: Mapping[str, Any] | None = None,
                   base: AnalysisSettings | None = None) -> AnalysisSettings:
    """The analysis settings of a study: *base* (default: the package's defaults), then the
    ``[analysis]`` table of its study.toml, then *overrides* (the command line's).

    Raises
    ------
    ConfigError
        An unknown key or a bad value, naming study.toml's line and key (or the option).
    """
    settings = base or AnalysisSettings()
    table = study.config.get("analysis") or {}
    if table:
        path = study.root / STUDY_FILE
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            text = None
        settings = settings.updated(table, source=path, text=text)
    if overrides:
        settings = settings.updated(overrides, table="")
    return settings


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
) -> StudyResults:
    """Analyse every trial of a study and write the study format's result tables.

    Parameters
    ----------
    study_dir : path-like
        The study folder.
    out_dir : path-like
        Where ``trials.csv``, ``windows.csv``, ``electrostatic.csv``, ``exponents.csv`` and
        ``summary.json`` go (created if needed).
    jobs : int, optional
        Worker processes (default: the number of CPUs; 1 analyses in this process).
    strict : bool
        A damaged line in a log is an error instead of a warning.
    force : bool
        Replace the results in *out_dir*: analyze's, and the model fit, figures and reports
        of ``evtribo compare`` and ``evtribo report`` (their files only).
    cache_dir : path-like, optional
        Cache of decoded trials (default: :func:`evtribo.cache.default_cache_dir`).
    settings : AnalysisSettings, optional
        The settings to start from (default: the package's defaults); the study's
        ``[analysis]`` table and *overrides* apply on top.
    overrides : mapping, optional
        Settings that take precedence over the study's (``{"tare": "none"}``).
    progress : callable, optional
        Called as ``progress(done, total)`` after each trial.

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
    *out_dir* is written as one unit (:mod:`evtribo.resultdir`): under a lock, into a new
    folder beside it, swapped in at the end; killed at any moment, it holds the results it
    held before or all of the new ones. Each input is hashed once, when the analysis starts;
    ``summary.json`` records those hashes and a ``run_id`` that ``compare`` and ``report``
    check the rest of the folder against.
    """
    started = time.perf_counter()
    started_at = time.time()
    out = Path(out_dir)
    check_overwrite(out, force)
    study = load_study(study_dir)
    check_out_dir(out, study.root)
    settings = study_settings(study, overrides, settings)
    if not study.trials:
        raise StudyError("the study holds no trials (no <subject>/<trial>.log files)",
                         path=study.root)
    with locked(out, "evtribo analyze"):
        recover(out)
        check_overwrite(out, force)
        return _analyze_locked(study, out, settings, started, started_at, jobs=jobs,
                               strict=strict, cache_dir=cache_dir, progress=progress)


def _analyze_locked(study: Study, out: Path, settings: AnalysisSettings, started: float,
                    started_at: float, *, jobs: int | None, strict: bool,
                    cache_dir: str | os.PathLike[str] | None,
                    progress: ProgressCallback | None) -> StudyResults:
    """:func:`analyze_study` once the output folder is locked."""
    n = len(study.trials)
    inputs = input_files(study)  # each input hashed once, here
    tasks, not_run, duplicates, warnings = _plan(study, inputs)
    jobs = (os.cpu_count() or 1) if jobs is None else max(1, int(jobs))
    jobs = max(1, min(jobs, len(tasks)))
    cache = None if cache_dir is None else os.fspath(cache_dir)
    assert study.rig is not None
    results = _run_tasks(tasks, jobs, (study.rig, cache, strict, settings), progress)
    results = sorted([*results, *not_run], key=lambda r: r[0])  # the study's order

    warnings = [*study.warnings, *warnings]
    failed = []
    for _, row, _, warns, error, _ in results:
        warnings.extend(warns)
        if error is not None:
            key = f"{row['subject']}/{row['trial']}"
            failed.append({"trial": key, "error": error})
            warnings.append(f"{key}: not analysed: {error}")
    trials = _typed(pd.DataFrame([r[1] for r in results]), TRIAL_COLUMNS)
    frames = [r[2] for r in results if not r[2].empty]
    windows = (pd.concat(frames, ignore_index=True) if frames else empty_windows())
    windows = windows.reindex(columns=list(WINDOW_CSV_COLUMNS))
    electrostatic, exponents, bootstrap, agg_warnings = summarize(
        windows, trials, n_boot=settings.n_boot, seed=settings.seed,
        confidence=settings.confidence)
    warnings.extend(agg_warnings)
    warnings.extend(changed_since(inputs))
    traces = [r[5] for r in results if r[5] is not None and not r[5].empty]
    trace = (pd.concat(traces, ignore_index=True).reindex(columns=list(SINE_TRACE_CSV_COLUMNS))
             if traces else None)
    electrostatic = _typed(electrostatic, ELECTROSTATIC_COLUMNS)
    exponents = _typed(exponents, EXPONENT_COLUMNS)

    def total(col: str) -> int:
        return int(pd.to_numeric(trials[col], errors="coerce").fillna(0).sum())

    summary: dict[str, Any] = {
        "study": study.name,
        "run_id": uuid.uuid4().hex,
        "evtribo_version": __version__,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        **provenance(study, started_at, inputs),
        "subjects": study.subjects,
        "trials": n,
        "trials_analysed": n - len(failed) - len(duplicates),
        "failed_trials": failed,
        "duplicate_trials": duplicates,
        "windows_on": int(np.count_nonzero(windows.condition == "on")),
        "windows_off": int(np.count_nonzero(windows.condition == "off")),
        "frames": total("frames"),
        "dropped_frames": total("dropped_frames"),
        "skipped_lines": total("skipped_lines"),
        "strict": strict,
        "jobs": jobs,
        "calibration": study.rig.calibration.to_dict(),
        "settings": {**settings.to_dict(), "mu_estimator": "ratio of means",
                     "interval": "percentile bootstrap over windows, stretched by a "
                                 "Welch-Satterthwaite Student-t factor for few windows",
                     "bootstrap_replicates_saved": int(bootstrap.replicate.nunique())
                     if not bootstrap.empty else 0},
        "warnings": warnings,
        "outputs": list(OUTPUT_FILES) + ([SINE_TRACE_FILE] if trace is not None else []),
        "output_sha256": {},
        "elapsed_s": None,
    }
    tables = {"trials.csv": trials, "windows.csv": windows,
              "electrostatic.csv": electrostatic, "exponents.csv": exponents,
              BOOTSTRAP_FILE: bootstrap.reindex(columns=list(BOOTSTRAP_COLUMNS))}
    if trace is not None:
        tables[SINE_TRACE_FILE] = trace
    # what this analysis replaces: analyze's files, and compare's and report's of them
    stale = [n for n in ANALYSIS_FILES if (out / n).is_file()]
    stale += [*compare_files(out), *report_files(out)] if out.is_dir() else []
    with Staging(out) as stage:
        for name, table in tables.items():
            summary["output_sha256"][name] = _write_csv(table, stage.path(name))
        summary["elapsed_s"] = round(time.perf_counter() - started, 3)
        stage.path(SUMMARY_FILE).write_text(
            json.dumps(summary, indent=2, ensure_ascii=False, default=str) + "\n",
            encoding="utf-8")
        stage.commit(remove=stale, last=[SUMMARY_FILE])
    log.info("analysed %d of %d trials of %s into %s", summary["trials_analysed"], n,
             study.root, out)
    return StudyResults(out_dir=out, trials=trials, windows=windows,
                        electrostatic=electrostatic, exponents=exponents, summary=summary)


__all__ = ["BOOTSTRAP_FILE", "OUTPUT_FILES", "SINE_TRACE_FILE", "StudyResults", "analyze_study",
           "study_settings"]
