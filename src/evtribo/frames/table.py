"""Raw CAN frames as columns: the common currency of readers, writers and the decoder."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

#: Payload width of a :class:`FrameTable` holding only classic CAN frames.
CLASSIC_WIDTH = 8
#: Payload width once any CAN FD frame is present.
FD_WIDTH = 64


@dataclass
class FrameTable:
    """CAN frames, one array per field, all of length ``n``.

    Attributes
    ----------
    timestamp : ndarray of float64, s
        Reception time as logged (usually seconds since the Unix epoch).
    arbitration_id : ndarray of uint32
        11-bit or 29-bit identifier.
    is_extended, is_remote, is_error, is_fd : ndarray of bool
        Frame kind flags.
    dlc : ndarray of uint8
        Payload length in bytes (0 to 64), not the DLC code.
    data : ndarray of uint8, shape (n, 8) or (n, 64)
        Payload, zero past ``dlc``.
    channel : str or None
        Channel name of the log (``vcan0``), when there is one.
    """

    timestamp: npt.NDArray[np.float64]
    arbitration_id: npt.NDArray[np.uint32]
    is_extended: npt.NDArray[np.bool_]
    is_remote: npt.NDArray[np.bool_]
    is_error: npt.NDArray[np.bool_]
    is_fd: npt.NDArray[np.bool_]
    dlc: npt.NDArray[np.uint8]
    data: npt.NDArray[np.uint8]
    channel: str | None = None
    extras: dict[str, object] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.timestamp.shape[0])

    @classmethod
    def empty(cls, width: int = CLASSIC_WIDTH, channel: str | None = None) -> FrameTable:
        """A table with no frames."""
        b = np.zeros(0, dtype=bool)
        return cls(
            timestamp=np.zeros(0, dtype=np.float64),
            arbitration_id=np.zeros(0, dtype=np.uint32),
            is_extended=b, is_remote=b.copy(), is_error=b.copy(), is_fd=b.copy(),
            dlc=np.zeros(0, dtype=np.uint8),
            data=np.zeros((0, width), dtype=np.uint8),
            channel=channel,
        )

    def take(self, index: npt.ArrayLike) -> FrameTable:
        """The frames selected by a boolean mask or an integer index."""
        idx = np.asarray(index)
        return FrameTable(
            timestamp=self.timestamp[idx],
            arbitration_id=self.arbitration_id[idx],
            is_extended=self.is_extended[idx],
            is_remote=self.is_remote[idx],
            is_error=self.is_error[idx],
            is_fd=self.is_fd[idx],
            dlc=self.dlc[idx],
            data=self.data[idx],
            channel=self.channel,
        )

    @staticmethod
    def concat(tables: list[FrameTable]) -> FrameTable:
        """Frames of several tables one after the other (payloads widened as needed)."""
        if not tables:
            return FrameTable.empty()
        width = max(t.data.shape[1] for t in tables)

        def widen(d: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
            if d.shape[1] == width:
                return d
            out = np.zeros((d.shape[0], width), dtype=np.uint8)
            out[:, : d.shape[1]] = d
            return out

        return FrameTable(
            timestamp=np.concatenate([t.timestamp for t in tables]),
            arbitration_id=np.concatenate([t.arbitration_id for t in tables]),
            is_extended=np.concatenate([t.is_extended for t in tables]),
            is_remote=np.concatenate([t.is_remote for t in tables]),
            is_error=np.concatenate([t.is_error for t in tables]),
            is_fd=np.concatenate([t.is_fd for t in tables]),
            dlc=np.concatenate([t.dlc for t in tables]),
            data=np.concatenate([widen(t.data) for t in tables]),
            channel=tables[0].channel,
        )

    def sorted_by_time(self) -> FrameTable:
        """The frames in order of timestamp (stable for equal timestamps)."""
        return self.take(np.argsort(self.timestamp, kind="stable"))
