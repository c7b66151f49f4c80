"""Record one trial from an open python-can bus into a study folder.

``STUDY/SUBJECT/TRIAL.log`` receives every frame (candump ``-L``), written as
``TRIAL.log.part`` and renamed when the trial ends; ``STUDY/SUBJECT/TRIAL.json`` is the
sidecar (spec §1 plus the recording's facts). The sidecar is first written when recording
starts, with ``"ended": "recording"``, so a trial whose process was killed still says what it
is; it is rewritten, atomically, when the trial ends.

How a trial ends (``ended`` in the sidecar):

============  =====================================================  =========
ended         cause                                                  exit code
============  =====================================================  =========
completed     the duration elapsed                                   0
interrupted   Ctrl-C, SIGTERM, or the caller's stop request          0
bus-error     the bus raised on receive (adapter unplugged, pty      1
              closed, driver error)
disk-error    the log could not be written (disk full...)            1
recording     (only in a sidecar left by a killed process)
============  =====================================================  =========
"""

from __future__ import annotations

import datetime as dt
import logging
import math
import os
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import can

import evtribo
from evtribo.acquisition.bus import BusSettings
from evtribo.acquisition.logger import CounterTracker, LogWriter, receive
from evtribo.acquisition.rigfile import AcquisitionRig, check_name, open_study
from evtribo.errors import AcquisitionError, ConfigError, OutputExistsError, SidecarError
from evtribo.study import CONDITIONS, WAVEFORMS, write_sidecar

log = logging.getLogger(__name__)

#: Exit code of the command line for each way a trial ends.
EXIT_CODES = {"completed": 0, "interrupted": 0, "bus-error": 1, "disk-error": 1}


@dataclass
class TrialInfo:
    """What the experimenter says about a trial (spec §1's sidecar keys).

    Attributes
    ----------
    waveform : str or None
        ``"sine"`` or ``"square"``.
    frequency_Hz : float or None, Hz
    amplitude_V : float or None, V
    condition : str or None
        ``"on"``, ``"off"`` or ``"alternating"``.
    notes : str or None
    tare_s : float or None, s
        The finger was kept off the screen for this long at the start (the tare stretch
        the analysis takes the load cells' zero offsets from).
    """

    waveform: str | None = None
    frequency_Hz: float | None = None
    amplitude_V: float | None = None
    condition: str | None = None
    notes: str | None = None
    tare_s: float | None = None

    def check(self) -> None:
        """Raise SidecarError (with the key) for a value outside what spec §1 allows."""
        if self.waveform is not None and self.waveform not in WAVEFORMS:
            raise SidecarError(f"unknown waveform {self.waveform!r}; allowed: "
                               f"{', '.join(WAVEFORMS)}", key="waveform")
        if self.condition is not None and self.condition not in CONDITIONS:
            raise SidecarError(f"unknown condition {self.condition!r}; allowed: "
                               f"{', '.join(CONDITIONS)}", key="condition")
        for key in ("frequency_Hz", "amplitude_V", "tare_s"):
            value = getattr(self, key)
            if value is not None and not (isinstance(value, (int, float))
                                          and math.isfinite(value) and value >= 0):
                raise SidecarError(f"expected a finite number >= 0, got {value!r}", key=key)

    def as_dict(self) -> dict[str, Any]:
        """The keys that were given (absent ones are left to the excitation signals)."""
        return {k: v for k, v in vars(self).items() if v is not None}


@dataclass
class TrialPaths:
    """Where a trial's files go."""

    folder: Path
    log: Path
    part: Path
    sidecar: Path

    @classmethod
    def of(cls, study: Path, subject: str, trial: str) -> TrialPaths:
        """Paths of *trial* of *subject* in *study*."""
        folder = Path(study) / subject
        return cls(folder=folder, log=folder / f"{trial}.log",
                   part=folder / f"{trial}.log.part", sidecar=folder / f"{trial}.json")

    def existing(self) -> list[Path]:
        """The files of this trial already on disk."""
        return [p for p in (self.log, self.part, self.sidecar) if p.exists()]


@dataclass
class TrialResult:
    """What :func:`record_trial` did.

    Attributes
    ----------
    ended : str
        ``completed``, ``interrupted``, ``bus-error``, ``disk-error``.
    exit_code : int
        0 for a deliberate end, 1 for a fault.
    paths : TrialPaths
    sidecar : dict
        The sidecar as written (or, with *kept_previous*, as it would have been).
    error : BaseException or None
    kept_previous : bool
        With ``force``, the new trial failed before receiving any frame: nothing of it was
        kept, and the trial recorded before stays as it was.
    """

    ended: str
    exit_code: int
    paths: TrialPaths
    sidecar: dict[str, Any] = field(default_factory=dict)
    error: BaseException | None = None
    kept_previous: bool = False


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
) -> TrialResult:
    """Record one trial from *bus* into *study* until *duration*, a stop, or a fault.

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
        ``.log.part`` of a killed recording is replaced at once.
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

    Returns
    -------
    TrialResult
        Whatever the end; faults are in ``ended`` / ``error``, not raised.

    Raises
    ------
    StudyError, SidecarError, RigConfigError, ConfigError
        Bad names, metadata, duration or rig (nothing written).
    OutputExistsError
        The trial exists and *force* is False.
    AcquisitionError
        The log file cannot be created.
    """
    check_name(subject, "subject")
    check_name(trial, "trial")
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise ConfigError(f"expected a finite duration > 0 s, got {duration}", key="duration")
    info = info or TrialInfo()
    info.check()
    study = Path(study)
    paths = TrialPaths.of(study, subject, trial)
    if not force and paths.existing():
        raise OutputExistsError(
            "trial already recorded (use --force to replace it): "
            + ", ".join(str(p) for p in paths.existing()), path=paths.existing()[0])
    acq_rig: AcquisitionRig = open_study(study, rig)
    settings = settings or BusSettings(channel=str(getattr(bus, "channel", None) or "") or None)
    settings.interface = settings.interface or type(bus).__name__
    channel = _log_channel(log_channel or settings.channel, bus)
    # with force, the previous trial's log and sidecar stay until this one has ended
    previous = [p for p in (paths.log, paths.sidecar) if p.exists()]
    try:
        paths.folder.mkdir(parents=True, exist_ok=True)
        fh = paths.part.open("wb" if force else "xb", buffering=0)
    except FileExistsError as err:
        raise OutputExistsError("another recording of this trial is in progress",
                                path=paths.part) from err
    except OSError as err:
        raise AcquisitionError(f"cannot create the log: {err}", path=paths.part) from err

    t_start = time.time()
    sidecar: dict[str, Any] = {"subject": subject, "trial": trial, **info.as_dict()}
    sidecar.update({
        "rig": {"name": acq_rig.name, "dbc": os.path.relpath(acq_rig.dbc_path, study),
                "dbc_version": acq_rig.database.version},
        **settings.as_dict(),
        "log_channel": channel,
        "evtribo_version": evtribo.__version__,
        "python_can_version": can.__version__,
        "cantools_version": _pkg_version("cantools"),
        "python_version": sys.version.split()[0],
        "start_time": _iso(t_start),
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
        if started is not None:
            started(paths)
    except BaseException:
        # nothing of this trial may stay behind to block the next attempt
        fh.close()
        paths.part.unlink(missing_ok=True)
        if paths.sidecar not in previous:
            paths.sidecar.unlink(missing_ok=True)
        raise

    writer = LogWriter(fh, channel, CounterTracker(acq_rig.counters)).start()
    t0 = time.monotonic()
    if monitor is not None:
        monitor.start(writer.stats, t0)
    stop = should_stop or (lambda: False)
    flag = should_stop if isinstance(should_stop, StopFlag) else None
    log.info("recording %s/%s from %s %s into %s", subject, trial, settings.interface,
             settings.channel, paths.part)
    try:
        if flag is not None:
            flag.interruptible = True
        result = receive(bus, writer, duration=duration, should_stop=stop, until=until)
        if flag is not None:
            flag.interruptible = False  # from here on, the trial is saved whatever comes
        ended, error = result.reason, result.error
    except KeyboardInterrupt:
        ended, error = "interrupted", None
    finally:
        if flag is not None:
            flag.interruptible = False
        elapsed = time.monotonic() - t0
        t_end = time.time()
        _close_writer(writer)
        if monitor is not None:
            monitor.stop()
    if writer.error is not None and ended not in ("bus-error",):
        ended, error = "disk-error", writer.error
    try:
        fh.close()
    except OSError as err:  # the final flush failed (disk full)
        log.error("closing the log failed: %s", err)
        ended, error = "disk-error", err
    if previous and error is not None and writer.stats.frames == 0:
        paths.part.unlink(missing_ok=True)
        log.error("%s/%s: %s before any frame arrived; the trial recorded before is kept",
                  subject, trial, ended)
        sidecar.update({"ended": ended, "frames": 0, "duration_s": round(elapsed, 6),
                        "dropped_frames": 0, "bus_errors": int(ended == "bus-error"),
                        "end_detail": f"{type(error).__name__}: {error}", "log": None})
        return TrialResult(ended=ended, exit_code=EXIT_CODES[ended], paths=paths,
                           sidecar=sidecar, error=error, kept_previous=True)
    paths.part.replace(paths.log)

    stats = writer.stats
    exceptions = [f"{type(error).__name__}: {error}"] if ended == "bus-error" else []
    sidecar.update({
        "end_time": _iso(t_end),
        "duration_s": round(elapsed, 6),
        "log": paths.log.name,
        "frames": stats.frames,
        "frames_by_id": dict(sorted(stats.frames_by_id.items())),
        "first_frame_time": None if stats.first_timestamp is None
        else _iso(stats.first_timestamp),
        "error_frames": stats.error_frames,
        "dropped_frames": stats.dropped,
        "dropped_frames_by_message": stats.dropped_by_message,
        "longest_gap_s_by_message": writer.counters.longest_gap_by_message(),
        "bus_errors": stats.error_frames + len(exceptions),
        "bus_exceptions": exceptions,
        "ended": ended,
    })
    if error is not None:
        sidecar["end_detail"] = f"{type(error).__name__}: {error}"
    elif ended == "interrupted":
        sidecar["end_detail"] = getattr(should_stop, "reason", None) or "stop requested"
    try:
        _write_json(paths.sidecar, sidecar)
    except OSError as err:
        raise AcquisitionError(f"the log is complete in {paths.log}, but its sidecar could "
                               f"not be written: {err}", path=paths.sidecar) from err
    log.info("%s/%s %s: %d frames in %.1f s, %d dropped, %d bus errors", subject, trial,
             ended, stats.frames, elapsed, stats.dropped, sidecar["bus_errors"])
    return TrialResult(ended=ended, exit_code=EXIT_CODES[ended], paths=paths, sidecar=sidecar,
                       error=error)


class StopFlag:
    """A stop request settable from a signal handler or another thread.

    Attributes
    ----------
    reason : str or None
        Why the stop was requested (the sidecar's ``end_detail``).
    interruptible : bool
        True while :func:`record_trial` receives frames: only then may a signal handler
        raise ``KeyboardInterrupt`` to cut a receive that hangs. Once it is False the
        trial's log and sidecar are being saved, and must not be interrupted.
    """

    def __init__(self) -> None:
        self._event = threading.Event()
        self.reason: str | None = None
        self.interruptible = False

    def set(self, reason: str = "stop requested") -> None:
        """Ask the recording to stop."""
        self.reason = self.reason or reason
        self._event.set()

    def __call__(self) -> bool:
        return self._event.is_set()


__all__ = ["EXIT_CODES", "StopFlag", "TrialInfo", "TrialPaths", "TrialResult", "record_trial"]
