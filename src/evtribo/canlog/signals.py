"""The decoded trial: what decoding (:func:`evtribo.canlog.decode.decode_trial`) and the cache
(:func:`evtribo.canlog.cache.load_trial`) hand to the analysis
(:func:`evtribo.analysis.trial.analyze_signals`).

One frozen dataclass, :class:`TrialSignals`, holds the two load cells' samples
(:class:`CellSignals`: times, forces, counters, frames missing), the amplifier's status
(:class:`ExcitationSignals`, waveforms already named), the counts of frames decoded,
ignored, dropped and of damaged lines skipped, the channel, the decoder's warnings, and where
the trial came from (:class:`TrialProvenance`). A step that changes a trial (the cache adding
the lines skipped while reading, the analysis cutting a trial into pieces) makes a new one
with :func:`dataclasses.replace`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from evtribo.warning.record import WarningRecord

__all__ = ["FALLBACK_WAVEFORMS", "CellSignals", "ExcitationSignals", "TrialProvenance",
           "TrialSignals"]

Array = npt.NDArray[np.float64]

#: Names of a waveform signal's codes when the rig's DBC gives it no value table: the default
#: rig's (``VAL_ ... HvWave 0 "sine" 1 "square" 2 "triangle" 3 "dc"``). Other codes keep
#: their number as their name; a DBC's own value table always takes precedence.
FALLBACK_WAVEFORMS: dict[int, str] = {0: "sine", 1: "square", 2: "triangle", 3: "dc"}


@dataclass(frozen=True)
class CellSignals:
    """One load cell's samples.

    Attributes
    ----------
    t : ndarray of float64, s
        Frame timestamps as logged, in increasing order.
    value : ndarray of float64, N
    counter : ndarray of int64 or None
        The cell's rolling frame counter, when the rig names one and it counts.
    dropped : int
        Frames missing, by the counter (wrap-around aware) and by timing gaps.
    dropped_method : str
        How they were counted (:class:`evtribo.canlog.dropped.DropCount`'s ``method``; why
        the count may be unreliable is said as the trial is decoded).
    duplicates : int
        Frames received twice (the counter and the payload of a frame just before), left
        out of the samples (:mod:`evtribo.canlog.sequence`).
    counter_period : int or None
        Frames after which *counter* repeats: its values are its places, 0 to
        ``counter_period - 1``, ``+1`` a frame (:mod:`evtribo.canlog.counters.law`). None:
        the next power of two above its largest value.
    """

    t: Array
    value: Array
    counter: npt.NDArray[np.int64] | None
    dropped: int
    dropped_method: str = "counter"
    duplicates: int = 0
    counter_period: int | None = None


@dataclass(frozen=True)
class ExcitationSignals:
    """The amplifier's status frames (roles the rig does not name are None).

    Attributes
    ----------
    t : ndarray of float64, s
    enabled : ndarray of bool or None
    amplitude : ndarray of float64, V, or None
    frequency : ndarray of float64, Hz, or None
    waveform : ndarray of str or None (object)
        Names of the waveform codes: the DBC's value table, else
        :data:`evtribo.canlog.signals.FALLBACK_WAVEFORMS`; None where a multiplexed frame does not
        carry the signal.
    """

    t: Array
    enabled: npt.NDArray[np.bool_] | None = None
    amplitude: Array | None = None
    frequency: Array | None = None
    waveform: npt.NDArray[np.object_] | None = None


@dataclass(frozen=True)
class TrialProvenance:
    """Where a decoded trial came from.

    Attributes
    ----------
    log_path : str or None
        The raw log, as given to :func:`evtribo.canlog.cache.load_trial` (None: decoded from frames
        in memory).
    log_sha256 : str or None
        SHA-256 of the log's bytes, when they were hashed.
    rig_fingerprint : str or None
        :meth:`evtribo.canlog.rig.Rig.fingerprint` of the rig it was decoded with.
    from_cache : bool
        Read from the decoded-trial cache rather than decoded from the log.
    """

    log_path: str | None = None
    log_sha256: str | None = None
    rig_fingerprint: str | None = None
    from_cache: bool = False


@dataclass(frozen=True)
class TrialSignals:
    """What a trial's log says about the forces and the excitation: what the decoder and the
    cache hand to the analysis.

    Attributes
    ----------
    normal, tangential : CellSignals
    excitation : ExcitationSignals or None
        None when the rig names no ``excitation_*`` signal.
    frames : int
        Frames of the rig's messages decoded.
    ignored_frames : int
        Other frames: other IDs, other channels, error and remote frames, CAN XL frames,
        frames too short, frames cantools refuses (a multiplexer value the DBC does not know).
    skipped_lines : int
        Damaged lines skipped while reading (set by the reader's caller).
    skipped_detail : tuple of (int or None, str)
        Line number and reason of the first damaged lines (as many as the reader warns of),
        so that a trial read from the cache warns of them as the reader did.
    channel : str or None
        The channel the rig's frames were decoded from (None: the log names none).
    logger_dropped : int
        Frames the recording tool said it dropped on that channel (candump's ``DROPCOUNT``
        notices): frames of any ID, lost before they were logged.
    warnings : tuple of WarningRecord
        What the decoder found worth saying about this trial (the rig's IDs on several
        channels, frames whose kind of ID is not the DBC's, a waveform without value table,
        the logger's clock steps, frames lost...), as records; the analysis says them of
        the trial that reads them (:func:`evtribo.warning.collect.rescoped`).
    provenance : TrialProvenance
        Where the trial came from (set by :func:`evtribo.canlog.cache.load_trial`).
    """

    normal: CellSignals
    tangential: CellSignals
    excitation: ExcitationSignals | None
    frames: int
    ignored_frames: int
    skipped_lines: int = 0
    skipped_detail: tuple[tuple[int | None, str], ...] = ()
    channel: str | None = None
    logger_dropped: int = 0
    warnings: tuple[WarningRecord, ...] = ()
    provenance: TrialProvenance = field(default_factory=TrialProvenance)

    @property
    def dropped_frames(self) -> int:
        """Frames lost: those missing from both load cells (counters, timing), or those the
        recording tool said it dropped when it says more (a frame it dropped is also missing
        from its cell's counter: the two counts overlap, so the larger is taken, not the
        sum)."""
        return max(self.normal.dropped + self.tangential.dropped, self.logger_dropped)

    @property
    def duplicate_frames(self) -> int:
        """Frames of the load cells received twice, left out of their samples."""
        return self.normal.duplicates + self.tangential.duplicates
