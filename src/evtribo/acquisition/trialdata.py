"""What a trial is while it records: its metadata, its files and lock, how it ended."""

from __future__ import annotations

import dataclasses
import errno
import logging
import math
import os
import signal
import stat
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from evtribo.acquisition.buses.bus import BusSettings
from evtribo.errors import ConfigError, OutputExistsError, SidecarError
from evtribo.store.files import partial_path
from evtribo.store.lock import WriteLock
from evtribo.study import CONDITIONS, WAVEFORMS

if TYPE_CHECKING:  # pragma: no cover
    from evtribo.acquisition.live.monitor import Monitor

log = logging.getLogger(__name__)

#: Time within which the rig's load cells must be heard from, s (else ``no-rig-data``).
RIG_DATA_TIMEOUT_S = 3.0
#: Disk space held while recording, freed to write the last sidecar on a full disk, bytes.
RESERVE_BYTES = 256 * 1024


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
class TrialOptions:
    """How to record a trial: :func:`~evtribo.acquisition.trial.record_trial` takes these
    as one object or as keyword arguments of the same names.

    Attributes
    ----------
    duration : float or None, s
        Recording time; None records until *should_stop* returns True.
    info : TrialInfo, optional
        Waveform, frequency, amplitude, condition, notes for the sidecar.
    rig : path, optional
        Rig TOML for a new study (default: the simulator's rig).
    force : bool
        Replace an existing trial of that name (its ``.log`` or the ``.log.part`` of a
        killed recording, and its ``.json``). The new trial is recorded in a folder of its
        own beside the old one, and replaces it only once it has ended holding frames of the
        rig's load cells: until then, and if it ends without any (a wrong bus, a fault, a
        stop), the old trial stays as it was (:mod:`evtribo.acquisition.replace`). It never
        replaces a trial that another process is recording.
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
    """

    duration: float | None
    info: TrialInfo | None = None
    rig: str | Path | None = None
    force: bool = False
    settings: BusSettings | None = None
    log_channel: str | None = None
    should_stop: Callable[[], bool] | None = None
    monitor: Monitor | None = None
    started: Callable[[TrialPaths], None] | None = None
    until: Callable[[], bool] | None = None
    rig_data_timeout: float | None = RIG_DATA_TIMEOUT_S

    def check(self) -> None:
        """Raise ConfigError (with the key) for a duration or timeout that is not > 0, and
        SidecarError for metadata outside spec §1."""
        duration = self.duration
        if duration is not None and not (math.isfinite(duration) and duration > 0):
            raise ConfigError(f"expected a finite duration > 0 s, got {duration}",
                              key="duration")
        timeout = self.rig_data_timeout
        if timeout is not None and not timeout > 0:
            raise ConfigError(f"expected a time > 0 s, got {timeout}", key="rig_data_timeout")
        (self.info or TrialInfo()).check()


@dataclass
class TrialPaths:
    """Where a trial's files go."""

    folder: Path
    log: Path
    part: Path
    sidecar: Path
    lock: Path
    reserve: Path

    @classmethod
    def of(cls, study: str | Path, subject: str, trial: str) -> TrialPaths:
        """Paths of *trial* of *subject* in *study*."""
        folder = Path(study) / subject
        return cls(folder=folder, log=folder / f"{trial}.log",
                   part=partial_path(folder / f"{trial}.log"), sidecar=folder / f"{trial}.json",
                   lock=folder / f"{trial}.lock", reserve=folder / f".{trial}.reserve")

    def staged(self, stage: Path) -> TrialPaths:
        """These paths with the log, its partial name and the sidecar in *stage* (a forced
        re-recording's folder: :mod:`evtribo.acquisition.replace`); the folder, the lock and
        the reserve stay the trial's.

        Parameters
        ----------
        stage : Path

        Returns
        -------
        TrialPaths
        """
        return dataclasses.replace(self, log=stage / self.log.name, part=stage / self.part.name,
                                   sidecar=stage / self.sidecar.name)

    def existing(self) -> list[Path]:
        """The files of this trial already on disk."""
        return [p for p in (self.log, self.part, self.sidecar) if p.exists()]


@dataclass
class RecordingOutcome:
    """What :func:`~evtribo.acquisition.trial.record_trial` did.

    Attributes
    ----------
    ended : str
        ``completed``, ``interrupted``, ``bus-error``, ``disk-error``, ``no-rig-data``.
    exit_code : int
        0 for a deliberate end, 1 for a fault.
    paths : TrialPaths
    sidecar : dict
        The sidecar as written (or, with *kept_previous*, as it would have been).
    error : BaseException or None
    kept_previous : bool
        With ``force``, the new trial ended without any frame of the rig's load cells:
        nothing of it was kept, and the trial recorded before stays as it was.
    """

    ended: str
    exit_code: int
    paths: TrialPaths
    sidecar: dict[str, Any] = field(default_factory=dict)
    error: BaseException | None = None
    kept_previous: bool = False


def trial_lock(paths: TrialPaths, subject: str, trial: str) -> WriteLock:
    """The lock of a trial (``TRIAL.lock``), held by whoever writes it.

    Parameters
    ----------
    paths : TrialPaths
    subject, trial : str
        The names, for the message another process gets.

    Returns
    -------
    WriteLock
    """
    return WriteLock(paths.lock, f"the trial {subject}/{trial}", "recorded")


def refuse_existing(paths: TrialPaths, force: bool) -> None:
    """Raise OutputExistsError, naming the files, if the trial has any and not *force*.

    Parameters
    ----------
    paths : TrialPaths
    force : bool
        Existing files are to be replaced.
    """
    existing = paths.existing()
    if existing and not force:
        raise OutputExistsError("trial already recorded (use {force} to replace it): "
                                + ", ".join(str(p) for p in existing), path=existing[0])


def keep_reserve(path: Path) -> None:
    """Take :data:`RESERVE_BYTES` of disk in *path*, to be freed for the last sidecar.

    Parameters
    ----------
    path : Path
        The reserve file (``.TRIAL.reserve``).

    Raises
    ------
    OSError
        The disk has not that much room left (nothing is left behind).
    """
    try:  # one left by a killed recording (of its size), or a link (the link only)
        st = os.lstat(path)
        if stat.S_ISLNK(st.st_mode) or (stat.S_ISREG(st.st_mode)
                                        and st.st_size == RESERVE_BYTES):
            path.unlink()
    except FileNotFoundError:
        pass
    try:  # created here, never through a link planted at its foreseeable name
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0),
                     0o600)
        with os.fdopen(fd, "wb") as fh:
            fallocate = getattr(os, "posix_fallocate", None)
            try:
                if fallocate is None:
                    raise OSError(errno.EOPNOTSUPP, "no posix_fallocate")
                fallocate(fh.fileno(), 0, RESERVE_BYTES)
            except OSError as err:
                if err.errno == errno.ENOSPC:
                    raise
                fh.write(bytes(RESERVE_BYTES))  # a system or file system without it
            fh.flush()
            os.fsync(fh.fileno())
    except BaseException:
        path.unlink(missing_ok=True)
        raise


class StopFlag:
    """A stop request settable from a signal handler or another thread.

    Attributes
    ----------
    reason : str or None
        Why the stop was requested (the sidecar's ``end_detail``).
    interruptible : bool
        True while :func:`~evtribo.acquisition.trial.record_trial` receives frames: only then may a
        signal handler raise ``KeyboardInterrupt`` to cut a receive that hangs. Once it is False the
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


__all__ = ["RESERVE_BYTES", "RIG_DATA_TIMEOUT_S", "RecordingOutcome", "StopFlag", "StopOnSignals",
           "TrialInfo", "TrialOptions", "TrialPaths", "keep_reserve", "refuse_existing",
           "trial_lock"]


class StopOnSignals:
    """While it is entered (in the main thread), SIGINT and SIGTERM set the stop flag: the
    trial ends as ``interrupted`` with its log and sidecar saved.

    A second SIGINT while frames are being received raises KeyboardInterrupt (to cut a
    receive that hangs in a driver); once the receive has ended, further signals are only
    logged: the trial's log and sidecar are being saved.
    """

    def __init__(self, flag: StopFlag) -> None:
        self.flag = flag
        self.saved: dict[int, Any] = {}

    def _handler(self, signum: int, _frame: Any) -> None:
        name = signal.Signals(signum).name
        if not self.flag():
            self.flag.set(f"stopped by {name}")
        elif signum == signal.SIGINT and self.flag.interruptible:
            self.flag.interruptible = False
            raise KeyboardInterrupt
        else:
            log.warning("%s ignored: saving the trial's log and sidecar", name)

    def __enter__(self) -> StopOnSignals:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self.saved[sig] = signal.signal(sig, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self.saved.items():
            signal.signal(sig, old)
