"""Small real logs of every format (the simulated rig's frames), and ways to damage them.

The seed logs are a short trial of the default rig (load cells and amplifier status) written
by evtribo's candump writer and by python-can's writers, so every reader is fuzzed from a
file it really reads; the mutations are the damage a lab sees: files cut short, bits
flipped, lines cut mid-way, lines repeated or swapped (duplicate and non-monotonic
timestamps), fields replaced by NaN, huge numbers, wrong DLCs or garbage.
"""

from __future__ import annotations

import gzip
import os
from functools import cache
from pathlib import Path

import can
from hypothesis import strategies as st

from evtribo.acquisition.simulator import TrialConfig, simulate_trial
from evtribo.canlog.io import FrameTable, write_candump

#: Every format the fuzzing covers; ``.log.gz`` is candump gzipped.
FORMATS = (".log", ".log.gz", ".asc", ".blf", ".trc", ".csv")
TEXT_FORMATS = (".log", ".asc", ".trc", ".csv")

#: What a damaged field may hold instead of its value.
TOKENS = ("nan", "NaN", "inf", "-inf", "-1", "1e400", "9" * 40, "9" * 400, "", "0", "99",
          "FFFFFFFFF", "ZZ", "1.2.3", "#", "()", "\x00", "\xff", "é", "R", "15", "64", "-0",
          "0x7FF", "1e-400", "  ", "\t")


@cache
def trial_frames() -> FrameTable:
    """A 0.05 s simulated trial of the default rig (about 150 frames, three IDs)."""
    frames, _ = simulate_trial(config=TrialConfig(duration_s=0.05, seed=3))
    return frames


def messages(frames: FrameTable) -> list[can.Message]:
    """The frames as python-can messages."""
    return [can.Message(timestamp=float(frames.timestamp[i]),
                        arbitration_id=int(frames.arbitration_id[i]),
                        is_extended_id=bool(frames.is_extended[i]),
                        data=frames.data[i, :frames.dlc[i]].tobytes(), channel=0)
            for i in range(len(frames))]


@cache
def seed_bytes(fmt: str, tmp: str) -> bytes:
    """The seed trial written in format *fmt* (bytes of the file)."""
    path = Path(tmp) / f"seed{fmt}"
    frames = trial_frames()
    if fmt in (".log", ".log.gz"):
        write_candump(path, frames)
    else:
        with can.Logger(path) as writer:
            for msg in messages(frames):
                writer.on_message_received(msg)
    return path.read_bytes()


def plain_bytes(fmt: str, tmp: str) -> bytes:
    """The seed's uncompressed content."""
    data = seed_bytes(fmt, tmp)
    return gzip.decompress(data) if fmt.endswith(".gz") else data


@st.composite
def byte_mutations(draw: st.DrawFn, data: bytes) -> bytes:
    """*data* truncated, with bits flipped, runs overwritten or bytes inserted."""
    out = bytearray(data)
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.sampled_from(("truncate", "flip", "overwrite", "insert", "delete")))
        if not out:
            break
        pos = draw(st.integers(0, len(out) - 1))
        if op == "truncate":
            del out[pos:]
        elif op == "flip":
            out[pos] ^= 1 << draw(st.integers(0, 7))
        elif op == "overwrite":
            run = draw(st.binary(min_size=1, max_size=16))
            out[pos:pos + len(run)] = run
        elif op == "insert":
            out[pos:pos] = draw(st.binary(min_size=1, max_size=16))
        else:
            del out[pos:pos + draw(st.integers(1, 64))]
    return bytes(out)


@st.composite
def line_mutations(draw: st.DrawFn, data: bytes) -> bytes:
    """*data* (a text log) with lines cut, repeated, swapped, or a field replaced."""
    lines = data.split(b"\n")
    for _ in range(draw(st.integers(1, 6))):
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        op = draw(st.sampled_from(("cut", "duplicate", "swap", "field", "drop", "blank",
                                   "crlf")))
        if op == "cut":          # a line cut mid-way (power cut, copy interrupted)
            lines[i] = lines[i][:draw(st.integers(0, max(len(lines[i]) - 1, 0)))]
        elif op == "duplicate":  # duplicate timestamps
            lines.insert(i, lines[i])
        elif op == "swap":       # timestamps going backwards
            j = draw(st.integers(0, len(lines) - 1))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == "field":      # NaN, a huge value, a wrong DLC, garbage in one field
            sep = b"," if b"," in lines[i] else b" "
            fields = lines[i].split(sep)
            k = draw(st.integers(0, len(fields) - 1))
            fields[k] = draw(st.sampled_from(TOKENS)).encode("utf-8")
            lines[i] = sep.join(fields)
        elif op == "drop":
            del lines[i]
        elif op == "blank":
            lines[i] = b""
        else:
            lines[i] = lines[i] + b"\r"
    return b"\n".join(lines)


def write(path: str | os.PathLike[str], content: bytes, *, compress: bool) -> None:
    """Write *content* (gzipped when *compress*)."""
    Path(path).write_bytes(gzip.compress(content, mtime=0) if compress else content)
