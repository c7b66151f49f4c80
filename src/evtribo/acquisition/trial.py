"""Record one trial from an open python-can bus into a study folder.

``STUDY/SUBJECT/TRIAL.log`` receives every frame (candump ``-L``), written as
``TRIAL.log.part`` and renamed when the trial ends; ``STUDY/SUBJECT/TRIAL.json`` is the
sidecar (spec §1 plus the recording's facts). The sidecar is first written when recording
starts, with ``"ended": "recording"``, so a trial whose process was killed still says what it
is; it is rewritten, atomically, when the trial ends (:mod:`.ending`). A trial recorded
again over itself (``force``) is recorded beside the old one, which it replaces once whole
(:mod:`.replace`). While it records, the trial is locked
(``TRIAL.lock``: PID, host, command; :mod:`evtribo.store.lock`), and ``.TRIAL.reserve`` holds a
little disk space, freed to write the last sidecar even when the disk has filled up.

How a trial ends (``ended`` in the sidecar):

============  =====================================================  =========
ended         cause                                                  exit code
============  =====================================================  =========
completed     the duration elapsed                                   0
interrupted   Ctrl-C, SIGTERM, or the caller's stop request          0
bus-error     the bus raised on receive (adapter unplugged, pty      1
              closed, driver error)
disk-error    the log could not be written (disk full...); the log   1
              ends with the last whole line written
no-rig-data   none of the rig's load-cell messages arrived within    1
              ``rig_data_timeout`` (3 s), or in a shorter trial:
              the wrong bus, or a study whose DBC is not this
              rig's; the log keeps what came
recording     (only in a sidecar left by a killed process)
============  =====================================================  =========

Keys the recording adds to the sidecar (besides spec §1's and the bus settings):

==========================  ===============================================================
key                         meaning
==========================  ===============================================================
frames, frames_by_id        frames written to the log, in all and per identifier
discarded_before_start      frames the bus held when the trial started (queued before it:
                            an adapter that went on sending after a killed recording),
                            discarded; no frame stamped before ``start_time`` is in the log
error_frames, ..._by_kind   CAN error frames received, in all and by kind (``bus-off``,
                            ``controller rx-error-passive``...: :mod:`.errorframes`)
controller_state            the CAN controller's last state the error frames reported:
                            error-active, error-warning, error-passive, bus-off
worst_controller_state      the worst of them during the trial
damaged_lines               lines the adapter's driver could not parse (``t0CZ8...``); each
                            is skipped and the recording goes on
dropped_frames              frames lost before the log, at least: the larger of the load
                            cells' counters' count and ``queue_dropped_frames``
dropped_frames_by_message   frames missing by the load cells' rolling counters, counted as
                            ``evtribo analyze`` counts the log
duplicate_frames            frames of the load cells received twice: no loss
counter_restarts_s          by message, when its counter restarted (back to 0 or a low
                            value, or any other; s from the first frame): no wrap of frames
                            lost there
counter_notes               by message, what its counter does where that is worth saying
                            (a period learnt from its frames, or that it does not count)
queue_dropped_frames        frames the receiving side dropped from its full receive queue
                            (SocketCAN: the kernel's count, ``SO_RXQ_OVFL``); null when the
                            bus does not count them
receive                     how the bus receives: ``timestamps`` (``kernel``: the kernel's
                            time of reception), ``queue`` (the receive queue asked for and
                            granted), ``drop_counter``
bus_errors                  error_frames + damaged_lines (+ 1 when the bus failed)
bus_exceptions              the first damaged lines' errors, and the one that ended a trial
                            as bus-error
ended, end_detail           how the trial ended (above), and why
==========================  ===============================================================
"""

from __future__ import annotations

import dataclasses
import logging
import os
import sys
import time
from collections.abc import Callable
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import can

import evtribo
from evtribo.acquisition.buses.bus import BusSettings, receive_care
from evtribo.acquisition.ending import (
    EXIT_CODES,
    _commit,
    _how_it_ended,
    _iso,
    _keep_previous,
    _last_sidecar,
    _no_rig_data,
    _Received,
    _Recording,
    _rig_frames,
    _save_sidecar,
    _write_json,
)
from evtribo.acquisition.logger import CounterTracker, LogWriter
from evtribo.acquisition.receive import ReceiveResult, receive
from evtribo.acquisition.replace import discard, finish, new_stage
from evtribo.acquisition.rigfile import AcquisitionRig, check_name, open_study
from evtribo.acquisition.trialdata import (
    RESERVE_BYTES,
    RIG_DATA_TIMEOUT_S,
    RecordingOutcome,
    StopFlag,
    TrialInfo,
    TrialOptions,
    TrialPaths,
    keep_reserve,
    refuse_existing,
    trial_lock,
)
from evtribo.documents.sidecar import CONDITIONS, WAVEFORMS, rig_entry
from evtribo.errors import (
    AcquisitionError,
    EvtriboError,
    OutputExistsError,
)
from evtribo.store.lock import WriteLock

log = logging.getLogger(__name__)

def _log_channel(name: str | None, bus: can.BusABC) -> str:
    name = name or str(getattr(bus, "channel", None) or "can0")
    return "_".join(name.split()) or "can0"


def _close_writer(writer: LogWriter) -> None:
    """Wait until the writer has written every queued batch, even through Ctrl-C."""
    while True:
        try:
            writer.close()
            return
        except KeyboardInterrupt:
            log.warning("interrupted while saving the log; finishing it first")


def _pkg_version(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def record_trial(bus: can.BusABC, study: str | Path, subject: str, trial: str,
                 options: TrialOptions | None = None, **fields: Any) -> RecordingOutcome:
    """Record one trial from *bus* into *study* until its duration, a stop, or a fault.

    The trial is locked while it records (``TRIAL.lock``, :class:`~evtribo.store.lock.WriteLock`):
    a second recording of it, by this process or another, is refused.

    Parameters
    ----------
    bus : can.BusABC
        An open bus (left open: the caller owns it).
    study : path
        The study folder; created, with a ``study.toml`` for the rig, when it has none.
    subject, trial : str
        Plain names (letters, digits, ``-``, ``_``).
    options : TrialOptions, optional
        How to record (duration, metadata, rig, force, bus settings, stop and display
        hooks). Its fields may be given as keyword arguments instead (``duration=1.0,
        force=True``), or as both (the keywords win).
    **fields
        Fields of :class:`~evtribo.acquisition.trialdata.TrialOptions`.

    Returns
    -------
    RecordingOutcome
        Whatever the end; faults are in ``ended`` / ``error``, not raised.

    Raises
    ------
    StudyError, SidecarError, RigConfigError, ConfigError
        Bad names, metadata, duration or rig (nothing written).
    LockedError
        Another recording of this trial is under way (whatever ``force`` says).
    OutputExistsError
        The trial exists and ``force`` is False.
    AcquisitionError
        The log file cannot be created.
    """
    opts = TrialOptions(**fields) if options is None else dataclasses.replace(options, **fields)
    check_name(subject, "subject")
    check_name(trial, "trial")
    opts.check()
    paths = TrialPaths.of(study, subject, trial)
    lock = trial_lock(paths, subject, trial)
    lock.check()
    refuse_existing(paths, opts.force)
    acq_rig = open_study(Path(study), opts.rig)
    _lock(paths, lock)
    try:
        _finish_replacing(paths)
        refuse_existing(paths, opts.force)  # again: now nobody else can record it
        return _run(_start(bus, paths, acq_rig, opts), bus, acq_rig, opts)
    finally:
        paths.reserve.unlink(missing_ok=True)
        lock.release()


def _finish_replacing(paths: TrialPaths) -> None:
    """Finish what a killed process left of a re-recording it had made the trial."""
    try:
        if finish(paths.folder, paths.log.stem):
            log.warning("%s/%s: finished replacing the trial recorded before (its "
                        "re-recording had been cut short while it took its place)",
                        paths.folder.name, paths.log.stem)
    except OSError as err:
        raise AcquisitionError(f"cannot finish replacing the trial: {err}",
                               path=paths.folder) from err


def _lock(paths: TrialPaths, lock: WriteLock) -> None:
    """Create the subject's folder and take the trial's lock."""
    try:
        paths.folder.mkdir(parents=True, exist_ok=True)
        lock.acquire()
    except EvtriboError:
        raise
    except OSError as err:
        raise AcquisitionError(f"cannot create the trial's lock file: {err}",
                               path=paths.lock) from err


def _start(bus: can.BusABC, paths: TrialPaths, acq_rig: AcquisitionRig,
           opts: TrialOptions) -> _Recording:
    """Open the log, write the first sidecar, keep disk space for the last one."""
    settings = opts.settings or BusSettings(
        channel=str(getattr(bus, "channel", None) or "") or None)
    settings.interface = settings.interface or type(bus).__name__
    channel = _log_channel(opts.log_channel or settings.channel, bus)
    stage = None
    if opts.force and paths.existing():  # the old trial stays until this one is whole
        try:
            stage = new_stage(paths.folder, paths.log.stem)
        except OSError as err:
            raise AcquisitionError(f"cannot create the new recording's folder: {err}",
                                   path=paths.folder) from err
    where = paths if stage is None else paths.staged(stage)
    try:  # never through a link planted at the partial log's name
        fh = os.fdopen(os.open(where.part, os.O_WRONLY | os.O_CREAT | os.O_EXCL
                               | getattr(os, "O_NOFOLLOW", 0), 0o644), "wb", buffering=0)
    except OSError as err:
        if stage is not None:
            discard(stage, paths.log.stem)
        if isinstance(err, FileExistsError):
            raise OutputExistsError("another recording of this trial is in progress",
                                    path=where.part) from err
        raise AcquisitionError(f"cannot create the log: {err}", path=where.part) from err
    rec = _Recording(paths=where, final=paths, stage=stage, fh=fh, channel=channel,
                     sidecar=_first_sidecar(where, acq_rig, opts, settings, channel))
    try:
        _prepare(rec, bus, opts.started)
    except BaseException:  # nothing of this trial may stay behind to block the next attempt
        fh.close()
        for path in (where.part, paths.reserve, where.sidecar):  # its own: none was there
            path.unlink(missing_ok=True)
        if stage is not None:
            discard(stage, paths.log.stem)
        raise
    return rec


def _first_sidecar(paths: TrialPaths, acq_rig: AcquisitionRig, opts: TrialOptions,
                   settings: BusSettings, channel: str) -> dict[str, Any]:
    """The sidecar as the recording starts (``"ended": "recording"``): the experimenter's
    metadata, the rig, the bus, the software and the start time."""
    info = opts.info or TrialInfo()
    return {
        "subject": paths.folder.name, "trial": paths.log.stem, **info.as_dict(),
        "rig": rig_entry(os.path.relpath(acq_rig.dbc_path, paths.folder.parent),
                         name=acq_rig.name, dbc_version=acq_rig.database.version),
        **settings.as_dict(),
        "log_channel": channel,
        "evtribo_version": evtribo.__version__,
        "python_can_version": can.__version__,
        "cantools_version": _pkg_version("cantools"),
        "python_version": sys.version.split()[0],
        "start_time": _iso(time.time()),
        "requested_duration_s": opts.duration,
        "log": paths.part.name,
        "ended": "recording",
    }


def _prepare(rec: _Recording, bus: can.BusABC,
             started: Callable[[TrialPaths], None] | None) -> None:
    """Write the first sidecar, hold the disk space for the last one, start the trial (what
    the bus held before is discarded: :func:`_begin`) and tell the caller (with the trial's
    paths)."""
    paths = rec.paths
    try:
        _write_json(paths.sidecar, rec.sidecar)
    except OSError as err:
        raise AcquisitionError(f"cannot write the sidecar: {err}", path=paths.sidecar) from err
    try:
        keep_reserve(paths.reserve)
    except OSError as err:
        raise AcquisitionError(
            f"the disk is full: not even {RESERVE_BYTES // 1024} KiB are free for the "
            f"trial ({err.strerror or err}); nothing was recorded",
            path=paths.reserve) from err
    _begin(rec, bus)
    if started is not None:
        started(rec.final)


def _begin(rec: _Recording, bus: can.BusABC) -> None:
    """The trial starts now: what the bus holds was queued before it. A bus that stamps
    frames as this machine receives them (SocketCAN) has its older frames discarded as they
    are read (:func:`receive`'s ``not_before``); an slcan adapter or a virtual bus is read
    empty now; any other cannot tell (``discarded_before_start`` is null)."""
    rec.care = receive_care(bus)
    rec.discarded = rec.care.discard() if rec.care.discard is not None else None
    rec.t_start = time.time()


def _run(rec: _Recording, bus: can.BusABC, acq_rig: AcquisitionRig,
         opts: TrialOptions) -> RecordingOutcome:
    """Record into the open log until the trial ends; save the log and the sidecar."""
    got = _receive(rec, bus, acq_rig, opts)
    ended, error = _how_it_ended(rec, got)
    if ended == "no-rig-data":
        error = AcquisitionError(_no_rig_data(acq_rig, min(opts.rig_data_timeout or 0.0,
                                                           round(got.elapsed, 1))))
    if rec.stage is not None and not _rig_frames(got.writer.stats, acq_rig):
        return _keep_previous(rec, ended, error, got)
    paths = rec.paths
    paths.part.replace(paths.log)
    sidecar = _last_sidecar(rec, got, ended, error, opts.should_stop)
    try:
        _save_sidecar(rec, sidecar)
    finally:  # a whole log with its first sidecar replaces the old trial too
        if rec.stage is not None:
            _commit(rec)
    paths = rec.final
    stats = got.writer.stats
    log.info("%s/%s %s: %d frames in %.1f s, %d dropped, %d bus errors", paths.folder.name,
             paths.log.stem, ended, stats.frames, got.elapsed, stats.dropped,
             sidecar["bus_errors"])
    return RecordingOutcome(ended=ended, exit_code=EXIT_CODES[ended], paths=paths, sidecar=sidecar,
                            error=error)


def _receive(rec: _Recording, bus: can.BusABC, acq_rig: AcquisitionRig,
             opts: TrialOptions) -> _Received:
    """Receive into the log through a writer thread (and the display) until the trial ends,
    whatever ends it; the writer is closed, every queued frame written."""
    writer = LogWriter(rec.fh, rec.channel, CounterTracker(acq_rig.counters)).start()
    care, t0 = rec.care, time.monotonic()
    monitor = opts.monitor
    if monitor is not None:
        monitor.start(writer.stats, t0)
    should_stop = opts.should_stop
    flag = should_stop if isinstance(should_stop, StopFlag) else None
    expect = frozenset(acq_rig.role_messages().values()) or None
    log.info("recording %s/%s from %s %s into %s", rec.paths.folder.name, rec.paths.log.stem,
             rec.sidecar["interface"], rec.sidecar["channel"], rec.paths.part)
    result = ReceiveResult(reason="interrupted")
    try:
        if flag is not None:
            flag.interruptible = True
        result = receive(bus, writer, duration=opts.duration,
                         should_stop=should_stop or (lambda: False), until=opts.until,
                         expect=expect, expect_within=opts.rig_data_timeout,
                         not_before=rec.t_start if care.local_clock else None,
                         dropped=care.dropped)
        if flag is not None:
            flag.interruptible = False  # from here on, the trial is saved whatever comes
    except KeyboardInterrupt:
        result.reason = "interrupted"
    except Exception as err:  # never leave the sidecar at "recording"
        log.exception("receiving failed")
        result.reason, result.error = "bus-error", err
    finally:
        if flag is not None:
            flag.interruptible = False
        elapsed = time.monotonic() - t0
        t_end = time.time()
        _close_writer(writer)
        if monitor is not None:
            monitor.stop()
    if rec.discarded is not None or rec.care.local_clock:
        result.stale = (result.stale or 0) + (rec.discarded or 0)
        log.info("discarded %d frames queued before the trial started", result.stale)
    else:
        result.stale = None
    return _Received(result=result, writer=writer, elapsed=elapsed, t_end=t_end,
                     t_start=rec.t_start, care=care)


__all__ = ["CONDITIONS", "EXIT_CODES", "RIG_DATA_TIMEOUT_S", "WAVEFORMS", "RecordingOutcome",
           "StopFlag", "TrialInfo", "TrialOptions", "TrialPaths", "record_trial", "trial_lock"]
