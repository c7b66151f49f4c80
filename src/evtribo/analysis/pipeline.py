"""``analyze_study``: a study folder in, the result tables of the study format out.

Trials are read (through the decoded-trial cache), aligned and cut into windows in worker
processes, one trial per task; the per-subject estimates are then computed from all windows
together. Warnings (the analysis's own, and the readers': damaged lines, unknown frames...)
are collected per trial into ``summary.json``. Nothing already in the output folder is
overwritten unless ``force`` is given.

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

import json
import logging
import os
import time
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
from evtribo.analysis.provenance import provenance
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
from evtribo.errors import AnalysisError, OutputExistsError, StudyError, UserInputError
from evtribo.study import STUDY_FILE, Study, load_study

log = logging.getLogger(__name__)

#: The files ``analyze_study`` writes into its output folder.
OUTPUT_FILES = ("trials.csv", "windows.csv", "electrostatic.csv", "exponents.csv",
                "summary.json", "electrostatic_bootstrap.csv")
#: The bootstrap replicates of electrostatic.csv (an addition to the study format).
BOOTSTRAP_FILE = "electrostatic_bootstrap.csv"
#: Written too when the study has sine trials: a stretch of each one's forces around a
#: switch from OFF to ON, for the model comparison (columns in evtribo.compare.tables).
SINE_TRACE_FILE = "sine_trace.csv"
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


def _init_worker(root: str, cache_dir: str | None, strict: bool,
                 settings: AnalysisSettings) -> None:
    study = load_study(root)
    _WORKER.update(study=study, cache_dir=cache_dir, strict=strict, settings=settings)


_Result = tuple[int, dict[str, Any], pd.DataFrame, list[str], str | None, pd.DataFrame | None]


def _analyze_one(index: int) -> _Result:
    study, strict = _WORKER["study"], _WORKER["strict"]
    ref = study.trials[index]
    sc = ref.sidecar
    tare_s = sc.extra.get("tare_s")
    meta = TrialMeta(subject=ref.subject, trial=ref.name, waveform=sc.waveform,
                     frequency_Hz=sc.frequency_Hz, amplitude_V=sc.amplitude_V,
                     condition=sc.condition,
                     tare_s=float(tare_s) if isinstance(tare_s, int | float) else None)
    trace: pd.DataFrame | None = None
    collector = _Collector()
    root_logger = logging.getLogger("evtribo")
    root_logger.addHandler(collector)
    try:
        signals = load_trial(ref.log_path, study.rig, _WORKER["cache_dir"], strict)
        result = analyze_signals(signals, meta, settings=_WORKER["settings"],
                                 calibration=study.rig.calibration)
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
    return index, row, windows, details + warnings, error, trace


def _check_outputs(out_dir: Path, force: bool) -> None:
    if force:
        return
    for name in (*OUTPUT_FILES, SINE_TRACE_FILE):
        if (out_dir / name).exists():
            raise OutputExistsError("already exists; give --force to overwrite the results",
                                    path=out_dir / name)


def _write_csv(df: pd.DataFrame, path: Path) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    df.to_csv(tmp, index=False, encoding="utf-8")
    os.replace(tmp, path)


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
        Overwrite existing outputs.
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
    StudyError, SidecarError, RigConfigError
        The study folder is wrong.
    LogFormatError
        A damaged line under ``strict``.
    """
    started = time.perf_counter()
    started_at = time.time()
    out = Path(out_dir)
    _check_outputs(out, force)
    study = load_study(study_dir)
    settings = study_settings(study, overrides, settings)
    if not study.trials:
        raise StudyError("the study holds no trials (no <subject>/<trial>.log files)",
                         path=study.root)
    n = len(study.trials)
    jobs = (os.cpu_count() or 1) if jobs is None else max(1, int(jobs))
    jobs = min(jobs, n)
    cache = None if cache_dir is None else os.fspath(cache_dir)
    results: list[_Result] = []
    init_args = (os.fspath(study.root), cache, strict, settings)
    if jobs == 1:
        _init_worker(*init_args)
        for i in range(n):
            results.append(_analyze_one(i))
            if progress:
                progress(len(results), n)
    else:
        with ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker,
                                 initargs=init_args) as pool:
            futures = [pool.submit(_analyze_one, i) for i in range(n)]
            try:
                for fut in as_completed(futures):
                    results.append(fut.result())
                    if progress:
                        progress(len(results), n)
            except BaseException:
                for f in futures:
                    f.cancel()
                raise
    results.sort(key=lambda r: r[0])

    warnings = list(study.warnings)
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
    traces = [r[5] for r in results if r[5] is not None and not r[5].empty]
    trace = (pd.concat(traces, ignore_index=True).reindex(columns=list(SINE_TRACE_CSV_COLUMNS))
             if traces else None)
    electrostatic = _typed(electrostatic, ELECTROSTATIC_COLUMNS)
    exponents = _typed(exponents, EXPONENT_COLUMNS)

    def total(col: str) -> int:
        return int(pd.to_numeric(trials[col], errors="coerce").fillna(0).sum())

    summary: dict[str, Any] = {
        "study": study.name,
        "evtribo_version": __version__,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        **provenance(study, started_at),
        "subjects": study.subjects,
        "trials": n,
        "trials_analysed": n - len(failed),
        "failed_trials": failed,
        "windows_on": int(np.count_nonzero(windows.condition == "on")),
        "windows_off": int(np.count_nonzero(windows.condition == "off")),
        "frames": total("frames"),
        "dropped_frames": total("dropped_frames"),
        "skipped_lines": total("skipped_lines"),
        "strict": strict,
        "jobs": jobs,
        "calibration": study.rig.calibration.to_dict() if study.rig is not None else {},
        "settings": {**settings.to_dict(), "mu_estimator": "ratio of means",
                     "interval": "percentile bootstrap over windows, stretched by a "
                                 "Welch-Satterthwaite Student-t factor for few windows",
                     "bootstrap_replicates_saved": int(bootstrap.replicate.nunique())
                     if not bootstrap.empty else 0},
        "warnings": warnings,
        "outputs": list(OUTPUT_FILES) + ([SINE_TRACE_FILE] if trace is not None else []),
        "elapsed_s": None,
    }
    out.mkdir(parents=True, exist_ok=True)
    _check_outputs(out, force)
    _write_csv(trials, out / "trials.csv")
    _write_csv(windows, out / "windows.csv")
    _write_csv(electrostatic, out / "electrostatic.csv")
    _write_csv(exponents, out / "exponents.csv")
    _write_csv(bootstrap.reindex(columns=list(BOOTSTRAP_COLUMNS)), out / BOOTSTRAP_FILE)
    if trace is not None:
        _write_csv(trace, out / SINE_TRACE_FILE)
    elif force and (out / SINE_TRACE_FILE).exists():  # stale: from an earlier analysis
        (out / SINE_TRACE_FILE).unlink()
    summary["elapsed_s"] = round(time.perf_counter() - started, 3)
    tmp = out / ".summary.json.tmp"
    tmp.write_text(json.dumps(summary, indent=2, ensure_ascii=False, default=str) + "\n",
                   encoding="utf-8")
    os.replace(tmp, out / "summary.json")
    log.info("analysed %d of %d trials of %s into %s", n - len(failed), n, study.root, out)
    return StudyResults(out_dir=out, trials=trials, windows=windows,
                        electrostatic=electrostatic, exponents=exponents, summary=summary)


__all__ = ["BOOTSTRAP_FILE", "OUTPUT_FILES", "SINE_TRACE_FILE", "StudyResults", "analyze_study",
           "study_settings"]
