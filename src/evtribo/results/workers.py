"""The trials of a study analysed one by one, in worker processes or in this one.

Each worker process is started with a :class:`WorkerContext` (the rig, the cache, the
settings: what every trial needs), handed to the pool's initializer once; each
:class:`TrialTask` then names one trial (its place in the study, where it is, its log as
hashed when the analysis started) and comes back as a :class:`TrialOutcome` (its row of
trials.csv, its windows, its warnings, its error, its sine trace). One trial's fault is
that trial's outcome, never the study's (unless ``strict``). A worker stops with its parent:
Ctrl-C and SIGTERM reach the parent, which stops the workers; a parent killed outright
leaves workers that notice it within half a second and exit.

Given a ``dask.distributed`` client (:mod:`evtribo.results.distributed`), the same tasks run
on that cluster's workers instead, with the same context sent to each worker once: the same
outcomes, gathered the same way. Every path must then be absolute and name the same file on
every worker (shared storage); the decoded-trial cache is the one this process would use.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field, replace
from typing import Any

import pandas as pd

from evtribo.analysis.piece_observer import PieceState
from evtribo.analysis.settings import AnalysisSettings
from evtribo.analysis.trial import (
    TrialMeta,
    analyze_signals,
    empty_windows,
    failed_row,
    trial_start,
)
from evtribo.canlog.cache import default_cache_dir, load_trial
from evtribo.canlog.rig import Rig
from evtribo.canlog.signals import TrialSignals
from evtribo.errors import AnalysisError, SidecarError, UserInputError
from evtribo.results.exclusions import TrialSeconds
from evtribo.results.trial_sketch import Sketcher
from evtribo.store.pool import init_worker, stop_workers
from evtribo.study import TrialRef
from evtribo.warning.collect import collected, collecting, emitter, replay
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["MAX_WARNINGS_PER_TRIAL", "SINE_WORK", "TrialOutcome", "TrialTask", "WorkerContext",
           "analyze_in", "analyze_task", "init_worker", "longest_first", "run_tasks",
           "say_outcome", "stop_workers", "trial_meta"]

log = logging.getLogger(__name__)
emit = emitter(__name__)

#: Most warnings of a trial's reading kept in summary.json (the rest are counted, one
#: ``more-warnings``); its decoding's and analysis's are all kept.
MAX_WARNINGS_PER_TRIAL = 20

ProgressCallback = Callable[[int, int], None]


@dataclass(frozen=True)
class WorkerContext:
    """What every trial's analysis needs, given to each worker process once.

    Attributes
    ----------
    rig : Rig
        The study's rig.
    cache_dir : str or None
        The decoded-trial cache (None: the default).
    strict : bool
        A damaged line, or any fault, is the study's error, not the trial's.
    settings : AnalysisSettings
        The analysis settings.
    """

    rig: Rig
    cache_dir: str | None
    strict: bool
    settings: AnalysisSettings


@dataclass(frozen=True)
class TrialTask:
    """One trial for a worker: its place in the study, where it is (its sidecar with it),
    and its log as hashed when the analysis started (sha256, size, modification time ns)."""

    index: int
    ref: TrialRef
    log: tuple[str, int, int]


@dataclass
class TrialOutcome:
    """What one trial gives the study.

    Attributes
    ----------
    index : int
        The trial's place in the study.
    row : dict
        Its row of trials.csv (names and sidecar values only when it failed).
    windows : pandas.DataFrame
        Its windows (none when it failed).
    warnings : list of WarningRecord
        What its reading, decoding and analysis said of it, in order.
    error : str or None
        Why it was not analysed.
    trace : pandas.DataFrame or None
        Its rows of sine_trace.csv.
    sketch : bytes or None
        What its check's figure draws (:class:`~evtribo.results.trial_sketch.TrialSketch`'s
        bytes), kept beside the outcome for ``evtribo compare``.
    """

    index: int
    row: dict[str, Any]
    windows: pd.DataFrame = field(default_factory=empty_windows)
    warnings: list[WarningRecord] = field(default_factory=list)
    error: str | None = None
    trace: pd.DataFrame | None = None
    sketch: bytes | None = None


def trial_meta(ref: TrialRef) -> TrialMeta:
    """The trial's names and its sidecar's values.

    Parameters
    ----------
    ref : TrialRef
        The trial in the study.

    Returns
    -------
    TrialMeta
    """
    return TrialMeta.from_sidecar(ref.subject, ref.name, ref.sidecar)


#: This process's context: set by :func:`_enter` (each worker's initializer, or
#: :func:`run_tasks` in this process), read by :func:`analyze_task`.
_context: WorkerContext | None = None


def _enter(context: WorkerContext) -> None:
    """Make *context* the one :func:`analyze_task` uses in this process."""
    global _context  # noqa: PLW0603 - a process pool's initializer has no other way
    _context = context


def _init_process(context: WorkerContext) -> None:
    """A worker process of analyze's pool (:func:`init_worker`), with its context."""
    init_worker()
    _enter(context)


def _load(ref: TrialRef, context: WorkerContext, expect: tuple[str, int, int] | None
          ) -> TrialSignals:
    """The trial's signals, from the channel its sidecar's ``log_channel`` names when the log
    holds several."""
    channel = ref.sidecar.extra.get("log_channel")
    channel = channel if isinstance(channel, str) and channel else None
    try:
        return load_trial(ref.log_path, context.rig, context.cache_dir, context.strict,
                          expect=expect, channel=channel)
    except UserInputError as err:
        if channel is None or err.key != "channel":
            raise
        raise SidecarError(err.message, path=ref.sidecar_path, key="log_channel") from err


class _Observer:
    """What a worker keeps of each piece of a trial as it is analysed: the seconds of
    trials.csv, and the check's sketch (whose fault only costs the sketch)."""

    def __init__(self) -> None:
        self.seconds = TrialSeconds()
        self.sketcher: Sketcher | None = None

    def __call__(self, piece: PieceState) -> None:
        self.seconds(piece)
        if self.sketcher is not None:
            try:
                self.sketcher(piece)
            except Exception:  # the check is drawn from a new analysis instead
                log.debug("no sketch of this trial", exc_info=True)
                self.sketcher = None

    def sketch(self, meta: TrialMeta, row: dict[str, Any]) -> bytes | None:
        """The sketch's bytes, None when it could not be made."""
        try:
            return None if self.sketcher is None else \
                self.sketcher.sketch(meta.subject, meta.trial, row).to_bytes()
        except Exception:
            log.debug("no sketch of %s/%s", meta.subject, meta.trial, exc_info=True)
            return None


def _outcome(task: TrialTask, context: WorkerContext) -> TrialOutcome:
    """The trial analysed, or why not: an :class:`AnalysisError` or a user's mistake is the
    trial's error; any other fault too, unless ``strict``."""
    ref = task.ref
    meta = trial_meta(ref)
    observer = _Observer()
    try:
        signals = _load(ref, context, task.log)
        observer.sketcher = Sketcher(trial_start(signals))
        result = analyze_signals(signals, meta, settings=context.settings,
                                 calibration=context.rig.calibration, observe=observer)
    except AnalysisError as err:
        return TrialOutcome(task.index, failed_row(meta), error=str(err))
    except UserInputError as err:
        if context.strict:
            raise
        return TrialOutcome(task.index, failed_row(meta), error=str(err))
    except Exception as err:  # one trial's fault must not cost the others their results
        if context.strict:
            raise
        log.debug("%s: analysis failed", ref.key, exc_info=True)
        return TrialOutcome(task.index, failed_row(meta),
                            error=f"{ref.log_path}: {type(err).__name__}: {err} (run with "
                                  "--strict --debug for the traceback)")
    result.row.update(observer.seconds.columns())
    warnings = result.warnings
    if result.row.get("skipped_lines"):
        warnings.append(_kept("damaged-lines", Scope(ref.subject, ref.name),
                              lines=int(result.row["skipped_lines"]), log=str(ref.log_path)))
    return TrialOutcome(task.index, result.row, result.windows, warnings, None, result.trace,
                        observer.sketch(meta, result.row))


def _kept(kind_id: str, scope: Scope, **values: object) -> WarningRecord:
    """A warning of a trial's outcome, kept with it (said when the outcome is)."""
    with collecting(scope, quiet=True):
        return emit(kind_id, **values)


def say_outcome(outcome: TrialOutcome) -> list[WarningRecord]:
    """Say a trial's warnings, and why it was not analysed (``not-analysed``), here: kept
    by the innermost collector, on the analysis's console (each under the logger of the
    module that said it); return them for ``summary.json``.

    Parameters
    ----------
    outcome : TrialOutcome
        The trial's outcome, from a worker or from the cache.

    Returns
    -------
    list of WarningRecord
        Its warnings, then ``<subject>/<trial>: not analysed: <why>`` when it failed.
    """
    said = list(outcome.warnings)
    replay(said)
    if outcome.error is not None:
        said.append(emit("not-analysed", Scope(outcome.row["subject"], outcome.row["trial"]),
                         error=outcome.error))
    return said


def analyze_task(task: TrialTask) -> TrialOutcome:
    """One trial analysed with this process's context, with what other modules warned of
    meanwhile (at most :data:`MAX_WARNINGS_PER_TRIAL` of them).

    Parameters
    ----------
    task : TrialTask
        The trial.

    Returns
    -------
    TrialOutcome
    """
    if _context is None:
        raise RuntimeError("analyze_task runs in a process started by run_tasks")
    return analyze_in(task, _context)


def analyze_in(task: TrialTask, context: WorkerContext) -> TrialOutcome:
    """One trial analysed with *context* (what :func:`analyze_task` does with this
    process's context; a Dask worker is handed it with each task).

    Parameters
    ----------
    task : TrialTask
        The trial.
    context : WorkerContext
        What every trial needs.

    Returns
    -------
    TrialOutcome
    """
    scope = Scope(task.ref.subject, task.ref.name)
    # said by the analysis gathering the outcomes, in the study's order
    outcome, heard = collected(_outcome, task, context, scope=scope)
    if len(heard) > MAX_WARNINGS_PER_TRIAL:
        more = len(heard) - MAX_WARNINGS_PER_TRIAL
        heard = [*heard[:MAX_WARNINGS_PER_TRIAL], _kept("more-warnings", scope, more=more)]
    outcome.warnings = heard + outcome.warnings
    return outcome


def _on_cluster(tasks: list[TrialTask], context: WorkerContext,
                arrived: Callable[[TrialOutcome], None], scheduler: Any) -> None:
    """Each task's outcome from the workers of a Dask cluster (a client or its address),
    handed to *arrived*."""
    from evtribo.results import distributed

    if isinstance(scheduler, str):
        with distributed.connect(scheduler) as client:
            _on_cluster(tasks, context, arrived, client)
            return
    relative = [t.ref.log_path for t in tasks if not os.path.isabs(t.ref.log_path)]
    if relative:
        raise UserInputError(f"{relative[0]}: a relative path; on a Dask cluster every path "
                             "must be absolute (and name the same file on every worker)",
                             key="--dask")
    cache = os.path.abspath(context.cache_dir if context.cache_dir is not None
                            else default_cache_dir())
    context = replace(context, cache_dir=cache)
    paths = [os.fspath(t.ref.log_path) for t in tasks]
    distributed.check_workers(scheduler, paths + ([cache] if os.path.isdir(cache) else []))
    for _, outcome in distributed.map_unordered(scheduler, analyze_in, longest_first(tasks),
                                                context, name=lambda t: str(t.ref.key)):
        arrived(outcome)


#: How much longer a sine drive's trial takes than a square wave's of as many frames (its
#: friction's spectrum, its hum notched out): a guess, for the order of the trials only.
SINE_WORK = 1.5


def longest_first(tasks: Sequence[TrialTask]) -> list[TrialTask]:
    """The tasks, those that will likely take longest first (the log's size, by
    :data:`SINE_WORK` for a sine drive): the workers then end together, instead of one
    analysing the study's last long trial while the others wait. A guess; the outcomes do
    not depend on the order.

    Parameters
    ----------
    tasks : sequence of TrialTask

    Returns
    -------
    list of TrialTask
        Every task once (ties in the study's order).
    """
    def work(task: TrialTask) -> float:
        return task.log[1] * (SINE_WORK if trial_meta(task.ref).waveform == "sine" else 1.0)

    return sorted(tasks, key=work, reverse=True)


def run_tasks(tasks: list[TrialTask], jobs: int, context: WorkerContext,
              progress: ProgressCallback | None = None, *,
              scheduler: Any = None,
              on_outcome: Callable[[TrialOutcome], None] | None = None
              ) -> list[TrialOutcome]:
    """Each task's outcome, in worker processes (*jobs* > 1), here, or on a Dask cluster.

    Parameters
    ----------
    tasks : list of TrialTask
        The trials.
    jobs : int
        Worker processes (1: this process); not used with *scheduler*.
    context : WorkerContext
        What every trial needs.
    progress : callable, optional
        Called as ``progress(done, total)`` after each trial.
    scheduler : distributed.Client or str, optional
        A Dask cluster to run the trials on (a connected client, or the scheduler's
        address); its workers must see every path, which must be absolute.
    on_outcome : callable, optional
        Called with each outcome as it arrives, here, while the other trials are analysed.

    Returns
    -------
    list of TrialOutcome
        In the order they finished.

    Raises
    ------
    UserInputError
        With *scheduler*: the dask extra is missing, the scheduler does not answer, a path
        is relative, or a worker does not see the study or cannot run evtribo.
    AnalysisError
        With *scheduler*: a worker died while analysing a trial (naming the trial).
    """
    results: list[TrialOutcome] = []

    def arrived(outcome: TrialOutcome) -> None:
        results.append(outcome)
        if on_outcome is not None:
            on_outcome(outcome)
        if progress:
            progress(len(results), len(tasks))

    if scheduler is not None:
        _on_cluster(tasks, context, arrived, scheduler)
        return results
    if jobs == 1:
        _enter(context)
        for task in tasks:
            arrived(analyze_task(task))
        return results
    pool = ProcessPoolExecutor(max_workers=jobs, initializer=_init_process,
                               initargs=(context,))
    try:
        futures = [pool.submit(analyze_task, task) for task in longest_first(tasks)]
        for fut in as_completed(futures):
            arrived(fut.result())
    except BaseException:  # an error, Ctrl-C, SIGTERM: no worker outlives the analysis
        stop_workers(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return results
