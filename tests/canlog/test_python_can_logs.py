"""python-can's own test logs (tests/data/python-can: every log of its test data, in ASC,
BLF and TRC, gzipped too) read by evtribo as ``can.LogReader`` reads them, frame for frame.
(Every format python-can writes is round-tripped in test_readers.py.)"""

from __future__ import annotations

import logging
from pathlib import Path

import can
import numpy as np
import pytest

from evtribo.canlog.io import FrameStream, frames_from_messages, read_frames

DATA = Path(__file__).parent.parent / "data" / "python-can"
LOGS = sorted(p for p in DATA.iterdir() if p.name not in ("README.md", "LICENSE.txt"))


def _same(ours, ref) -> None:
    """The frames of two tables equal: times to the µs, IDs (error frames: python-can gives
    ID 0, evtribo keeps the error class), kinds, lengths, payloads, channels."""
    assert len(ours) == len(ref)
    np.testing.assert_allclose(ours.timestamp, ref.timestamp, rtol=0, atol=1e-6)
    for name in ("is_extended", "is_remote", "is_error", "is_fd", "dlc"):
        np.testing.assert_array_equal(getattr(ours, name), getattr(ref, name), err_msg=name)
    data = ~ref.is_error
    np.testing.assert_array_equal(ours.arbitration_id[data], ref.arbitration_id[data])
    width = max(ours.data.shape[1], ref.data.shape[1])
    a, b = (np.pad(t.data, ((0, 0), (0, width - t.data.shape[1]))) for t in (ours, ref))
    np.testing.assert_array_equal(a[data], b[data])
    assert [ours.channel_names[k] if k >= 0 else None for k in ours.channels] == \
        [ref.channel_names[k] if k >= 0 else None for k in ref.channels]


def test_the_folder_holds_python_cans_logs_and_its_licence():
    assert len(LOGS) == 25
    assert {p.name.split(".", 1)[1] for p in LOGS} == {"asc", "asc.gz", "blf", "trc"}
    assert "GNU LESSER GENERAL PUBLIC LICENSE" in (DATA / "LICENSE.txt").read_text()


@pytest.mark.parametrize("path", LOGS, ids=lambda p: p.name)
def test_each_log_reads_as_python_can_reads_it(path, caplog):
    with can.LogReader(path) as reader:
        ref = frames_from_messages(list(reader))
    with caplog.at_level(logging.WARNING):
        frames, report = read_frames(path)
    assert len(ref) > 0
    _same(frames, ref)
    assert report.frames == len(ref) and report.skipped_lines == 0, report.skipped
    streamed = list(FrameStream(path))  # decode's block-by-block reading: the same
    assert sum(len(t) for t in streamed) == len(ref)
