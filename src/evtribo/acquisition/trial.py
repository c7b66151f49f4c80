"""Record one trial from an open python-can bus into a study folder.

``STUDY/SUBJECT/TRIAL.log`` receives every frame (candump ``-L``), written as
``TRIAL.log.part`` and renamed when the trial ends; ``STUDY/SUBJECT/TRIAL.json`` is the
sidecar (spec §1 plus the recording's facts). The sidecar is first written when recording
starts, with ``"ended": "recording"``, so a trial whose process was killed still says what it
is; it is rewritten, atomically, when the trial ends. While it records, the trial is locked
(``TRIAL.lock``: PID, host, command; :mod:`evtribo.lock`), and ``.TRIAL.reserve`` holds a
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
              ``rig_data_timeout`` (3 s): the wrong bus, or a study
              whose DBC is not this rig's; the log keeps what came
recording     (only in a sidecar left by a killed process)
============  =====================================================  =========

Keys the recording adds to the sidecar (besides spec §1's and the bus settings):

========================  ===============================================================
key                       meaning
========================  ===============================================================
frames, frames_by_id      frames written to the log, in all and per identifier
error_frames              CAN error frames received
damaged_lines             lines the adapter's driver could not parse (``t0CZ8...``); each
                          is skipped and the recording goes on
dropped_frames(_by_...)   frames missing by the load cells' rolling counters
bus_errors                error_frames + damaged_lines (+ 1 when the bus failed)
bus_exceptions            the first damaged lines' errors, and the one that ended a trial
                          as bus-error
ended, end_detail         how the trial ended (above), and why
========================  ===============================================================
"""

from __future__ import annotations

import datetime as dt
import logging
import math
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import can

import evtribo
from evtribo.acquisition.bus import BusSettings
from evtribo.acquisition.logger import CounterTracker, LogWriter, ReceiveResult, receive
from evtribo.acquisition.rigfile import AcquisitionRig, check_name, open_study
from evtribo.acquisition.trialdata import (
    RESERVE_BYTES,
    StopFlag,
    TrialInfo,
    TrialPaths,
    TrialResult,
    keep_reserve,
    refuse_existing,
    trial_lock,
)
from evtribo.documents.sidecar import CONDITIONS, WAVEFORMS, rig_entry, write_sidecar
from evtribo.errors import (
    AcquisitionError,
    ConfigError,
    EvtriboError,
    OutputExistsError,
)
from evtribo.frames.ids import key_id

log = logging.getLogger(__name__)

#: Exit code of the command line for each way a trial ends.
EXIT_CODES = {"completed": 0, "interrupted": 0, "bus-error": 1, "disk-error": 1,
              "no-rig-data": 1}
#: Time within which the rig's load cells must be heard from, s (else ``no-rig-data``).
RIG_DATA_TIMEOUT_S = 3.0


def _iso(t: float) -> str:
    return dt.datetime.fromtimestamp(t, dt.UTC).isoformat(timespec="microseconds") \
        .replace("+00:00", "Z")


def _write_json(path: Path, data: dict[str, Any]) -> None:
    write_sidecar(path, data, force=True)  # atomic: temporary file, fsync, rename


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


def record_trial(
    bus: can.BusABC,
    study: str | Path,
    subject: str,
    trial: str,
    *,
    duration: float | None,
    info: TrialInfo | None = None,
    rig: str | Path | None = None,
    force: bool = False,
    settings: BusSettings | None = None,
    log_channel: str | None = None,
    should_stop: Callable[[], bool] | None = None,
    monitor: Any = None,
    started: Callable[[TrialPaths], None] | None = None,
    until: Callable[[], bool] | None = None,
    rig_data_timeout: float | None = RIG_DATA_TIMEOUT_S,
) -> TrialResult:
    """Record one trial from *bus* into *study* until *duration*, a stop, or a fault.

    The trial is locked while it records (``TRIAL.lock``, :class:`~evtribo.lock.WriteLock`):
    a second recording of it, by this process or another, is refused.

    Parameters
    ----------
    bus : can.BusABC
        An open bus (left open: the caller owns it).
    study : path
        The study folder; created, with a ``study.toml`` for *rig*, when it has none.
    subject, trial : str
        Plain names (letters, digits, ``-``, ``_``).
    duration : float or None, s
        Recording time; None records until *should_stop* returns True.
    info : TrialInfo, optional
        Waveform, frequency, amplitude, condition, notes for the sidecar.
    rig : path, optional
        Rig TOML for a new study (default: the simulator's rig).
    force : bool
        Replace an existing trial of that name. Its ``.log`` and ``.json`` are replaced only
        when the new trial ends (the new one is recorded to ``.log.part`` meanwhile, and the
        old ones stay if it ends in a fault before any frame arrived); a leftover
        ``.log.part`` of a killed recording is replaced at once. It never replaces a trial
        that another process is recording.
    settings : BusSettings, optional
        How the bus was opened (recorded in the sidecar).
    log_channel : str, optional
        Channel name written in the log (default: ``settings.channel``, the bus's channel).
    should_stop : callable, optional
        Polled about every 0.1 s; True stops the trial as ``interrupted``.
    monitor : Monitor, optional
        Live display, started with the writer's statistics.
    started : callable, optional
        Called with the trial's paths once the log file is open.
    until : callable, optional
        Polled when the bus is idle; True ends the trial as ``completed`` (for a source
        that knows when it is done, such as the simulated rig).
    rig_data_timeout : float or None, s
        The trial ends as ``no-rig-data`` when none of the rig's load-cell messages arrived
        within this time (None: never).

    Returns
    -------
    TrialResult
        Whatever the end; faults are in ``ended`` / ``error``, not raised.

    Raises
    ------
    StudyError, SidecarError, RigConfigError, ConfigError
        Bad names, metadata, duration or rig (nothing written).
    LockedError
        Another recording of this trial is under way (whatever *force* says).
    OutputExistsError
        The trial exists and *force* is False.
    AcquisitionError
        The log file cannot be created.
    """
    check_name(subject, "subject")
    check_name(trial, "trial")
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise ConfigError(f"expected a finite duration > 0 s, got {duration}", key="duration")
    if rig_data_timeout is not None and not rig_data_timeout > 0:
        raise ConfigError(f"expected a time > 0 s, got {rig_data_timeout}",
                          key="rig_data_timeout")
    info = info or TrialInfo()
    info.check()
    study = Path(study)
    paths = TrialPaths.of(study, subject, trial)
    lock = trial_lock(paths, subject, trial)
    lock.check()
    refuse_existing(paths, force)
    acq_rig: AcquisitionRig = open_study(study, rig)
    try:
        paths.folder.mkdir(parents=True, exist_ok=True)
        lock.acquire()
    except EvtriboError:
        raise
    except OSError as err:
        raise AcquisitionError(f"cannot create the trial's lock file: {err}",
                               path=paths.lock) from err
    try:
        refuse_existing(paths, force)  # again: now nobody else can record it
        recording = _start(bus, paths, acq_rig, info, duration=duration, force=force,
                           settings=settings, log_channel=log_channel, started=started)
        return _run(recording, bus, acq_rig, duration=duration, should_stop=should_stop,
                    monitor=monitor, until=until, rig_data_timeout=rig_data_timeout)
    finally:
        paths.reserve.unlink(missing_ok=True)
        lock.release()


@dataclass
class _Recording:
    """A trial whose log is open: what :func:`_run` needs to record and end it."""

    paths: TrialPaths
    fh: Any
    sidecar: dict[str, Any]
    previous: list[Path]
    channel: str


def _start(bus: can.BusABC, paths: TrialPaths, acq_rig: AcquisitionRig, info: TrialInfo, *,
           duration: float | None, force: bool, settings: BusSettings | None,
           log_channel: str | None, started: Callable[[TrialPaths], None] | None
           ) -> _Recording:
    """Open the log, write the first sidecar, keep disk space for the last one."""
    settings = settings or BusSettings(channel=str(getattr(bus, "channel", None) or "") or None)
    settings.interface = settings.interface or type(bus).__name__
    channel = _log_channel(log_channel or settings.channel, bus)
    # with force, the previous trial's log and sidecar stay until this one has ended
    previous = [p for p in (paths.log, paths.sidecar) if p.exists()]
    try:
        fh = paths.part.open("wb" if force else "xb", buffering=0)
    except FileExistsError as err:
        raise OutputExistsError("another recording of this trial is in progress",
                                path=paths.part) from err
    except OSError as err:
        raise AcquisitionError(f"cannot create the log: {err}", path=paths.part) from err
    study = paths.folder.parent
    sidecar: dict[str, Any] = {"subject": paths.folder.name, "trial": paths.log.stem,
                               **info.as_dict()}
    sidecar.update({
        "rig": rig_entry(os.path.relpath(acq_rig.dbc_path, study), name=acq_rig.name,
                         dbc_version=acq_rig.database.version),
        **settings.as_dict(),
        "log_channel": channel,
        "evtribo_version": evtribo.__version__,
        "python_can_version": can.__version__,
        "cantools_version": _pkg_version("cantools"),
        "python_version": sys.version.split()[0],
        "start_time": _iso(time.time()),
        "requested_duration_s": duration,
        "log": paths.part.name,
        "ended": "recording",
    })
    try:
        if paths.sidecar in previous:
            log.info("%s is kept until the new trial has ended", paths.sidecar)
        else:
            try:
                _write_json(paths.sidecar, sidecar)
            except OSError as err:
                raise AcquisitionError(f"cannot write the sidecar: {err}",
                                       path=paths.sidecar) from err
        try:
            keep_reserve(paths.reserve)
        except OSError as err:
            raise AcquisitionError(
                f"the disk is full: not even {RESERVE_BYTES // 1024} KiB are free for the "
                f"trial ({err.strerror or err}); nothing was recorded",
                path=paths.reserve) from err
        if started is not None:
            started(paths)
    except BaseException:
        # nothing of this trial may stay behind to block the next attempt
        fh.close()
        paths.part.unlink(missing_ok=True)
        paths.reserve.unlink(missing_ok=True)
        if paths.sidecar not in previous:
            paths.sidecar.unlink(missing_ok=True)
        raise
    return _Recording(paths=paths, fh=fh, sidecar=sidecar, previous=previous,
                      channel=channel)


def _run(rec: _Recording, bus: can.BusABC, acq_rig: AcquisitionRig, *,
         duration: float | None, should_stop: Callable[[], bool] | None, monitor: Any,
         until: Callable[[], bool] | None, rig_data_timeout: float | None) -> TrialResult:
    """Record into the open log until the trial ends; save the log and the sidecar."""
    paths = rec.paths
    writer = LogWriter(rec.fh, rec.channel, CounterTracker(acq_rig.counters)).start()
    t0 = time.monotonic()
    if monitor is not None:
        monitor.start(writer.stats, t0)
    stop = should_stop or (lambda: False)
    flag = should_stop if isinstance(should_stop, StopFlag) else None
    expect = frozenset(acq_rig.role_messages().values()) or None
    log.info("recording %s/%s from %s %s into %s", paths.folder.name, paths.log.stem,
             rec.sidecar["interface"], rec.sidecar["channel"], paths.part)
    result = ReceiveResult(reason="interrupted")
    try:
        if flag is not None:
            flag.interruptible = True
        result = receive(bus, writer, duration=duration, should_stop=stop, until=until,
                         expect=expect, expect_within=rig_data_timeout)
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
    ended, error = result.reason, result.error
    if writer.error is not None and ended != "bus-error":
        ended, error = "disk-error", writer.error
    try:
        rec.fh.close()
    except OSError as err:  # the final flush failed (disk full)
        log.error("closing the log failed: %s", err)
        ended, error = "disk-error", err
    if ended == "no-rig-data":
        error = AcquisitionError(_no_rig_data(acq_rig, rig_data_timeout))
    sidecar = rec.sidecar
    if rec.previous and error is not None and writer.stats.frames == 0:
        return _keep_previous(rec, ended, error, elapsed)
    paths.part.replace(paths.log)
    stats = writer.stats
    exceptions = [*result.damaged_examples]
    if ended == "bus-error":
        exceptions.append(f"{type(error).__name__}: {error}")
    sidecar.update({
        "end_time": _iso(t_end),
        "duration_s": round(elapsed, 6),
        "log": paths.log.name,
        "frames": stats.frames,
        "frames_by_id": dict(sorted(stats.frames_by_id.items())),
        "first_frame_time": None if stats.first_timestamp is None
        else _iso(stats.first_timestamp),
        "error_frames": stats.error_frames,
        "damaged_lines": stats.damaged_lines,
        "dropped_frames": stats.dropped,
        "dropped_frames_by_message": stats.dropped_by_message,
        "longest_gap_s_by_message": writer.counters.longest_gap_by_message(),
        "bus_errors": stats.error_frames + stats.damaged_lines + int(ended == "bus-error"),
        "bus_exceptions": exceptions,
        "ended": ended,
    })
    if error is not None:
        sidecar["end_detail"] = _detail(error, ended, max(result.frames - stats.frames, 0))
    elif ended == "interrupted":
        sidecar["end_detail"] = getattr(should_stop, "reason", None) or "stop requested"
    _save_sidecar(rec, sidecar)
    log.info("%s/%s %s: %d frames in %.1f s, %d dropped, %d bus errors", paths.folder.name,
             paths.log.stem, ended, stats.frames, elapsed, stats.dropped,
             sidecar["bus_errors"])
    return TrialResult(ended=ended, exit_code=EXIT_CODES[ended], paths=paths, sidecar=sidecar,
                       error=error)


def _no_rig_data(acq_rig: AcquisitionRig, within: float | None) -> str:
    names = ", ".join(f"{n} (0x{key_id(k)[0]:03X})"
                      for n, k in acq_rig.role_messages().items())
    return (f"none of the rig's load-cell messages ({names}) arrived within {within:g} s "
            f"(the wrong bus, or the study's DBC {acq_rig.dbc_path.name} is not this rig's)")


def _detail(error: BaseException, ended: str, unwritten: int) -> str:
    if ended == "no-rig-data":
        return str(error)
    text = f"{type(error).__name__}: {error}"
    if ended == "disk-error":
        text += (f"; the log ends with the last whole line written ({unwritten} frames "
                 "received after it are not in it)")
    return text


def _keep_previous(rec: _Recording, ended: str, error: BaseException,
                   elapsed: float) -> TrialResult:
    """The forced trial failed before any frame arrived: the one recorded before stays."""
    paths = rec.paths
    paths.part.unlink(missing_ok=True)
    paths.reserve.unlink(missing_ok=True)
    log.error("%s/%s: %s before any frame arrived; the trial recorded before is kept",
              paths.folder.name, paths.log.stem, ended)
    sidecar = rec.sidecar
    sidecar.update({"ended": ended, "frames": 0, "duration_s": round(elapsed, 6),
                    "dropped_frames": 0, "damaged_lines": 0,
                    "bus_errors": int(ended == "bus-error"),
                    "end_detail": _detail(error, ended, 0), "log": None})
    return TrialResult(ended=ended, exit_code=EXIT_CODES[ended], paths=paths,
                       sidecar=sidecar, error=error, kept_previous=True)


def _save_sidecar(rec: _Recording, sidecar: dict[str, Any]) -> None:
    """Write the last sidecar, with the reserved disk space freed for it."""
    paths = rec.paths
    paths.reserve.unlink(missing_ok=True)
    try:
        _write_json(paths.sidecar, sidecar)
    except OSError as err:
        raise AcquisitionError(
            f"the log is saved in {paths.log} ({sidecar['frames']} frames, whole lines), but "
            f"its sidecar could not be updated ({err}): it says how the trial started, "
            f"and the trial ended as {sidecar['ended']!r}", path=paths.sidecar) from err


__all__ = ["CONDITIONS", "EXIT_CODES", "RIG_DATA_TIMEOUT_S", "WAVEFORMS", "StopFlag",
           "TrialInfo", "TrialPaths", "TrialResult", "record_trial", "trial_lock"]
