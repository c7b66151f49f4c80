"""A trial's candump log: the cells' frames, the amplifier's status, foreign traffic.

Each node sends on its own clock; the logger stamps a frame when it arrives: after the
frame's time on the bus (about 130 µs at 1 Mbit/s), a delay drawn uniformly in [0, j]
(a USB adapter and a busy host: 0.1-1 ms), optionally in batches (every frame of a batch
stamped at the batch's delivery, a microsecond apart), on the host's own clock.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import canframes
from .cells import CellStream
from .config import StudyConfig

BUS_FRAME_S = 130e-6


@dataclass
class Stream:
    """Frames of one kind before stamping: true send times, ids, payloads."""

    t: np.ndarray
    frame_id: int
    extended: bool
    payload: np.ndarray
    dlc: int


@dataclass
class LogInfo:
    """What the log's clock did, to map the truth onto the log's time."""

    epoch_s: float          # host time of the trial's true time 0
    host_ppm: float
    first_stamp_s: float    # the first line's timestamp
    frames: int
    jitter_s: float


def cell_streams(streams: list[CellStream]) -> list[Stream]:
    """The two cells' frames: force and rolling counter."""
    db = canframes.database()
    out = []
    for stream, name, sig in zip(streams, ("PadNormal", "PadShear"), ("Normal", "Shear"),
                                 strict=True):
        msg = db.get_message_by_name(name)
        width = msg.get_signal_by_name("Seq").length
        values = {sig: stream.value, "Seq": stream.counter % (1 << width)}
        if name == "PadShear":
            values["TempC"] = np.full(stream.t.size, 31.5)
        payload = canframes.pack(msg, values, stream.t.size)
        out.append(Stream(stream.t, msg.frame_id, False, payload, 8))
    return out


def status_stream(t: np.ndarray, on: np.ndarray, cfg: StudyConfig, amplitude: float,
                  rng: np.random.Generator) -> Stream:
    """The amplifier's status: periodic on its own clock, and at once on every switch."""
    d = cfg.drive
    period = 1.0 / (d.status_rate_Hz * (1.0 + rng.uniform(-100, 100) * 1e-6))
    times = rng.uniform(0, period) + period * np.arange(int(t[-1] / period))
    switches = t[1:][np.diff(on.astype(np.int8)) != 0]
    times = np.sort(np.concatenate([times, switches + 1e-4]))
    state = on[np.clip(np.searchsorted(t, times, side="right") - 1, 0, t.size - 1)]
    msg = canframes.database().get_message_by_name("HvMonitor")
    values = {"Active": state.astype(float), "Shape": canframes.WAVE_CODE[d.waveform],
              "Volts": amplitude, "Hertz": d.frequency_Hz}
    return Stream(times, msg.frame_id, True, canframes.pack(msg, values, times.size), 8)


def heartbeat_stream(duration: float, rate: float, rng: np.random.Generator) -> Stream:
    """A CANopen-style heartbeat of a node the rig's DBC does not describe."""
    n = int(duration * rate)
    times = rng.uniform(0, 1.0 / rate) + np.arange(n) / rate if n else np.zeros(0)
    payload = np.zeros((times.size, 8), dtype=np.uint8)
    payload[:, 0] = 0x05
    return Stream(times, canframes.HEARTBEAT_ID, False, payload, 1)


def _stamps(t: np.ndarray, cfg: StudyConfig, jitter: float,
            rng: np.random.Generator) -> np.ndarray:
    """Arrival times at the host (true time, s) of frames sent at ``t``."""
    arrival = t + BUS_FRAME_S + rng.uniform(0.0, jitter, t.size)
    batch = cfg.logger.batch_s
    if batch <= 0:
        return arrival
    delivered = np.ceil(arrival / batch) * batch
    order = np.argsort(arrival, kind="stable")
    rank = np.zeros(t.size)
    sorted_delivery = delivered[order]
    starts = np.r_[0, np.flatnonzero(np.diff(sorted_delivery)) + 1]
    within = np.arange(t.size) - np.repeat(starts, np.diff(np.r_[starts, t.size]))
    rank[order] = within
    return delivered + rank * 1e-6


def write(path: Path, streams: list[Stream], cfg: StudyConfig, epoch_s: float,
          rng: np.random.Generator) -> LogInfo:
    """Stamp every frame, order them by stamp and write the candump ``-L`` log."""
    jitter = rng.uniform(*cfg.logger.jitter_s)
    host_ppm = rng.uniform(-20, 20)
    t = np.concatenate([s.t for s in streams])
    ids = np.concatenate([np.full(s.t.size, s.frame_id, dtype=np.int64) for s in streams])
    ext = np.concatenate([np.full(s.t.size, s.extended) for s in streams])
    dlc = np.concatenate([np.full(s.t.size, s.dlc, dtype=np.int64) for s in streams])
    payload = np.concatenate([s.payload for s in streams])
    arrival = _stamps(t, cfg, jitter, rng)
    host = epoch_s + arrival * (1.0 + host_ppm * 1e-6)
    stamps_us = np.rint(host * 1e6).astype(np.int64)
    order = np.argsort(stamps_us, kind="stable")
    text = canframes.candump_lines(stamps_us[order], ids[order] & 0x1FFFFFFF, ext[order],
                                   payload[order], dlc[order])
    path.write_bytes(text)
    return LogInfo(epoch_s, host_ppm, float(stamps_us[order][0]) / 1e6, int(t.size), jitter)
