"""How a recorded trial ends: the last sidecar, the log saved under its name, and, for a
trial recorded again over itself, the new trial taking the old one's place or the old one
kept (:mod:`evtribo.acquisition.replace`). :mod:`evtribo.acquisition.trial` records; this
module saves what it recorded."""

from __future__ import annotations

import dataclasses
import datetime as dt
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from evtribo.acquisition.buses.bus import ReceiveCare
from evtribo.acquisition.logger import LogStats, LogWriter
from evtribo.acquisition.receive import ReceiveResult
from evtribo.acquisition.replace import commit, discard
from evtribo.acquisition.rigfile import AcquisitionRig
from evtribo.acquisition.trialdata import RecordingOutcome, TrialPaths
from evtribo.canlog.io.ids import id_text, key_id
from evtribo.documents.replacing import committed
from evtribo.documents.sidecar import write_sidecar
from evtribo.errors import AcquisitionError

log = logging.getLogger(__name__)

__all__ = ["EXIT_CODES"]

#: Exit code of the command line for each way a trial ends.
EXIT_CODES = {"completed": 0, "interrupted": 0, "bus-error": 1, "disk-error": 1,
              "no-rig-data": 1}


def _iso(t: float) -> str:
    return dt.datetime.fromtimestamp(t, dt.UTC).isoformat(timespec="microseconds") \
        .replace("+00:00", "Z")


def _write_json(path: Path, data: dict[str, Any]) -> None:
    write_sidecar(path, data, force=True)  # atomic: temporary file, fsync, rename


@dataclass
class _Recording:
    """A trial whose log is open: what :func:`~evtribo.acquisition.trial.record_trial` needs to
    record and end it (*paths*: where it records, in *stage* for a trial recorded again over itself;
    *final*: the trial's)."""

    paths: TrialPaths
    final: TrialPaths
    stage: Path | None
    fh: BinaryIO
    sidecar: dict[str, Any]
    channel: str
    care: ReceiveCare = dataclasses.field(default_factory=ReceiveCare)
    t_start: float = 0.0
    discarded: int | None = None


@dataclass
class _Received:
    """What the receive loop left: how it ended, the writer and the time it took."""

    result: ReceiveResult
    writer: LogWriter
    elapsed: float
    t_end: float
    t_start: float
    care: ReceiveCare


def _how_it_ended(rec: _Recording, got: _Received) -> tuple[str, BaseException | None]:
    """How the trial ended and the error that ended it: the receive loop's word, unless
    the log could not be written or closed (``disk-error``)."""
    ended, error = got.result.reason, got.result.error
    if got.writer.error is not None and ended != "bus-error":
        ended, error = "disk-error", got.writer.error
    try:
        rec.fh.close()
    except OSError as err:  # the final flush failed (disk full)
        log.error("closing the log failed: %s", err)
        ended, error = "disk-error", err
    return ended, error


def _last_sidecar(rec: _Recording, got: _Received, ended: str, error: BaseException | None,
                  should_stop: Callable[[], bool] | None) -> dict[str, Any]:
    """The sidecar as the trial ends: the first one, plus the recording's facts."""
    stats = got.writer.stats
    exceptions = [*got.result.damaged_examples]
    if ended == "bus-error":
        exceptions.append(f"{type(error).__name__}: {error}")
    sidecar = rec.sidecar
    sidecar.update({
        "start_time": _iso(got.t_start),
        "end_time": _iso(got.t_end),
        "duration_s": round(got.elapsed, 6),
        "log": rec.paths.log.name,
        "frames": stats.frames,
        "frames_by_id": dict(sorted(stats.frames_by_id.items())),
        "first_frame_time": None if stats.first_timestamp is None
        else _iso(stats.first_timestamp),
        "discarded_before_start": got.result.stale,
        "error_frames": stats.error_frames,
        "error_frames_by_kind": dict(sorted(stats.errors.by_kind.items())),
        "controller_state": stats.errors.state,
        "worst_controller_state": stats.errors.worst,
        "damaged_lines": stats.damaged_lines,
        "dropped_frames": max(stats.dropped, stats.queue_dropped or 0),
        "queue_dropped_frames": stats.queue_dropped,
        "receive": got.care.as_dict(),
        "dropped_frames_by_message": stats.dropped_by_message,
        "duplicate_frames": stats.duplicates,
        "counter_restarts_s": got.writer.counters.restarts_by_message(stats.first_timestamp),
        "counter_notes": got.writer.counters.notes_by_message(),
        "longest_gap_s_by_message": got.writer.counters.longest_gap_by_message(),
        "bus_errors": stats.error_frames + stats.damaged_lines + int(ended == "bus-error"),
        "bus_exceptions": exceptions,
        "ended": ended,
    })
    if error is not None:
        sidecar["end_detail"] = _detail(error, ended,
                                        max(got.result.frames - stats.frames, 0))
    elif ended == "interrupted":
        sidecar["end_detail"] = getattr(should_stop, "reason", None) or "stop requested"
    return sidecar


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


def _rig_frames(stats: LogStats, acq_rig: AcquisitionRig) -> int:
    """Frames of the rig's load cells in the log."""
    return sum(stats.frames_by_id.get(id_text(*key_id(k)), 0)
               for k in acq_rig.role_messages().values())


def _keep_previous(rec: _Recording, ended: str, error: BaseException | None,
                   got: _Received) -> RecordingOutcome:
    """The forced trial ended without any frame of the rig's load cells: nothing of it is
    kept, and the one recorded before stays."""
    assert rec.stage is not None
    paths = rec.final
    discard(rec.stage, paths.log.stem)
    paths.reserve.unlink(missing_ok=True)
    frames = got.writer.stats.frames
    why = _detail(error, ended, 0) if error is not None else "stopped"
    log.error("%s/%s: %s before any frame of the rig's load cells arrived (%d other frames); "
              "the trial recorded before is kept", paths.folder.name, paths.log.stem, ended,
              frames)
    sidecar = rec.sidecar
    sidecar.update({"ended": ended, "frames": frames, "duration_s": round(got.elapsed, 6),
                    "dropped_frames": 0, "damaged_lines": 0,
                    "bus_errors": int(ended == "bus-error"), "end_detail": why, "log": None})
    return RecordingOutcome(ended=ended, exit_code=EXIT_CODES[ended], paths=paths,
                            sidecar=sidecar, error=error, kept_previous=True)


def _commit(rec: _Recording) -> None:
    """The whole re-recording takes the old trial's place."""
    assert rec.stage is not None
    folder, trial = rec.final.folder, rec.final.log.stem
    try:
        commit(folder, trial, rec.stage)
    except OSError as err:
        if committed(rec.stage):
            raise AcquisitionError(
                f"the new trial replaced the one recorded before, but its files could not be "
                f"moved into {folder} ({err}): the next `evtribo acquire` of {trial} (or "
                "`evtribo session`) finishes it; `evtribo analyze` reads it meanwhile",
                path=rec.stage) from err
        raise AcquisitionError(
            f"the new trial is whole in {rec.stage}, but could not replace the one recorded "
            f"before ({err}), which is kept", path=rec.stage) from err


def _save_sidecar(rec: _Recording, sidecar: dict[str, Any]) -> None:
    """Write the last sidecar, with the reserved disk space freed for it."""
    paths = rec.paths
    paths.reserve.unlink(missing_ok=True)
    try:
        _write_json(paths.sidecar, sidecar)
    except OSError as err:
        raise AcquisitionError(
            f"the log is saved in {rec.final.log} ({sidecar['frames']} frames, whole lines), but "
            f"its sidecar could not be updated ({err}): it says how the trial started, "
            f"and the trial ended as {sidecar['ended']!r}", path=paths.sidecar) from err
