"""Log readers: one conformance test over every format, peer tools' logs, damaged lines."""

import gzip
import logging
import shutil
from pathlib import Path

import can
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.canlog.io import FrameTable, frames_from_messages, read_frames, write_candump
from evtribo.canlog.io.candump import read_candump
from evtribo.errors import LogFormatError

DATA = Path(__file__).parent.parent / "data" / "logs"
PEER_LOGS = sorted(p for p in DATA.iterdir() if p.suffix != ".md")
T0 = 1763700000.0


def _trace(fd: bool) -> list[can.Message]:
    rng = np.random.default_rng(7)
    msgs = []
    for i in range(60):
        ext = i % 5 == 1
        n = int(rng.integers(0, 9))
        msgs.append(can.Message(
            timestamp=T0 + i * 0.001234 + int(rng.integers(0, 1000)) * 1e-6,
            arbitration_id=int(rng.integers(0, 0x1FFFFFFF if ext else 0x7FF)),
            is_extended_id=ext, data=rng.integers(0, 256, n, dtype=np.uint8).tobytes(),
            channel=0))
    msgs.append(can.Message(timestamp=T0 + 0.2, arbitration_id=0x123, is_remote_frame=True,
                            dlc=0, is_extended_id=False, channel=0))
    if fd:
        msgs.append(can.Message(timestamp=T0 + 0.3, arbitration_id=0x7A0, is_fd=True,
                                bitrate_switch=True, data=bytes(range(64)),
                                is_extended_id=False, channel=0))
        msgs.append(can.Message(timestamp=T0 + 0.4, arbitration_id=0x1ABCDE, is_fd=True,
                                data=bytes(range(12)), is_extended_id=True, channel=0))
    return msgs


def assert_same_frames(ours: FrameTable, ref: FrameTable, *, error_ids: bool = True,
                       relative: bool = False) -> None:
    assert len(ours) == len(ref)
    if relative:  # formats that store times relative to the start of the measurement
        np.testing.assert_allclose(ours.timestamp - ours.timestamp[0],
                                   ref.timestamp - ref.timestamp[0], rtol=0, atol=1e-6)
    else:
        np.testing.assert_allclose(ours.timestamp, ref.timestamp, rtol=0, atol=1e-6)
    for name in ("is_extended", "is_remote", "is_error", "is_fd", "dlc"):
        np.testing.assert_array_equal(getattr(ours, name), getattr(ref, name), err_msg=name)
    keep = ~ref.is_error if not error_ids else slice(None)
    np.testing.assert_array_equal(ours.arbitration_id[keep], ref.arbitration_id[keep])
    width = max(ours.data.shape[1], ref.data.shape[1])
    a = np.zeros((len(ours), width), np.uint8)
    b = np.zeros((len(ref), width), np.uint8)
    a[:, :ours.data.shape[1]] = ours.data
    b[:, :ref.data.shape[1]] = ref.data
    np.testing.assert_array_equal(a[keep], b[keep])


FORMATS = [".log", ".log.gz", ".asc", ".asc.gz", ".blf", ".trc", ".trc.gz", ".csv", ".db"]
FD_FORMATS = {".log", ".log.gz", ".asc", ".asc.gz", ".blf"}


@pytest.mark.parametrize("suffix", FORMATS)
def test_every_format_round_trips_a_recorded_trace(tmp_path, suffix):
    """Written by python-can's writer, read by evtribo: same frames, timestamps to the µs."""
    msgs = _trace(fd=suffix in FD_FORMATS)
    path = tmp_path / f"trace{suffix}"
    with can.Logger(path) as writer:
        for m in msgs:
            writer.on_message_received(m)
    if suffix.startswith(".trc"):  # python-can's TRC writer leaves remote frames out
        msgs = [m for m in msgs if not m.is_remote_frame]
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    assert report.frames == len(msgs)
    relative = suffix.startswith((".asc", ".trc"))
    assert_same_frames(frames, frames_from_messages(msgs), relative=relative)


@pytest.mark.parametrize("path", PEER_LOGS, ids=lambda p: p.name)
def test_peer_tool_logs_read_as_python_can_reads_them(path):
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    ref = frames_from_messages(can.LogReader(path))
    assert len(frames) > 0
    assert_same_frames(frames, ref)


def test_candump_reader_matches_python_can_on_every_frame_kind(tmp_path):
    path = tmp_path / "kinds.log"
    path.write_text(
        "(1763700000.000123) vcan0 0C1#1122334455667788\n"
        "(1763700000.000223) vcan0 1ABCDEF0#0102\n"
        "(1763700000.000323) vcan0 123#R\n"
        "(1763700000.000423) vcan0 123#R4\n"
        "(1763700000.000523) vcan0 7FF##1000102030405060708090A0B\n"
        "(1763700000.000623) vcan0 20000080#\n"
        "(1763700000.000723) vcan0 000#\n"
        "(1763700000.000823) vcan0 1A0#0102030405060708 R\n"
        "\n"
        "(99.5) can1 001#00\n")
    frames, report = read_frames(path)
    ref = frames_from_messages(can.LogReader(path))
    assert report.skipped_lines == 0 and report.lines == 10
    # python-can reports error frames with ID 0; evtribo keeps the error class (0x80)
    assert_same_frames(frames, ref, error_ids=False)
    assert frames.arbitration_id[frames.is_error].tolist() == [0x80]
    assert frames.channel == "vcan0"


def test_fast_and_slow_paths_agree_on_a_large_mixed_log(tmp_path):
    """Fixed-width blocks, mixed lengths, odd lines: the column parser equals python-can."""
    rng = np.random.default_rng(3)
    msgs = []
    for i in range(5000):
        ext = bool(rng.integers(0, 2))
        msgs.append(can.Message(timestamp=T0 + i * 1e-4 if i % 7 else i * 1e-4,
                                arbitration_id=int(rng.integers(0, 0x7FF)), is_extended_id=ext,
                                data=rng.integers(0, 256, int(rng.integers(0, 9)),
                                                  dtype=np.uint8).tobytes()))
    path = tmp_path / "mixed.log"
    with can.CanutilsLogWriter(path) as w:
        for m in msgs:
            w.on_message_received(m)
    frames, lines = read_candump(path, lambda *a: pytest.fail(f"damaged {a}"), block_size=4096)
    assert lines == len(msgs)
    assert_same_frames(frames, frames_from_messages(can.LogReader(path)))


def test_write_candump_reads_back_identically(tmp_path):
    msgs = [*_trace(fd=True), can.Message(timestamp=T0 + 1, is_error_frame=True)]
    frames = frames_from_messages(msgs)
    for name in ("out.log", "out.log.gz"):
        path = tmp_path / name
        write_candump(path, frames, block_frames=17)
        ref = frames_from_messages(can.LogReader(path))
        assert_same_frames(ref, frames, error_ids=False)
        ours, _ = read_frames(path)
        assert_same_frames(ours, frames, error_ids=False)
    text = gzip.open(tmp_path / "out.log.gz", "rt").read().splitlines()
    assert text[0].startswith(f"({msgs[0].timestamp:.6f}) vcan0 ")


def test_write_candump_matches_python_can_writer_text(tmp_path):
    msgs = [m for m in _trace(fd=False) if not m.is_remote_frame]
    ours = tmp_path / "ours.log"
    write_candump(ours, frames_from_messages(msgs), channel="can0")
    ref = tmp_path / "ref.log"
    with can.CanutilsLogWriter(ref) as w:
        for m in msgs:
            w.on_message_received(m)
    assert ours.read_text().splitlines() == [
        line.removesuffix(" R") for line in ref.read_text().splitlines()]


DAMAGED = """(1763700000.000100) vcan0 0C1#1122334455667788
(1763700000.000200) vcan0 0C1#11223344556677ZZ
(17637000x0.000300) vcan0 0C1#1122334455667788
(1763700000.000400) vcan0 0C1#112233445566778
(1763700000.000500) vcan0 0C1#1122334455667788
(1763700000.0006
"""


def test_damaged_lines_are_skipped_with_file_and_line(tmp_path, caplog):
    path = tmp_path / "damaged.log"
    path.write_text(DAMAGED)
    with caplog.at_level(logging.WARNING, logger="evtribo.canlog.io"):
        frames, report = read_frames(path)
    assert len(frames) == 2
    assert report.skipped_lines == 4
    assert [line for line, _ in report.skipped] == [2, 3, 4, 6]
    for line in (2, 3, 4, 6):
        assert f"{path}:{line}: skipped damaged line" in caplog.text
    np.testing.assert_allclose(frames.timestamp - T0, [1e-4, 5e-4], rtol=0, atol=1e-6)


def test_damaged_line_is_an_error_when_strict(tmp_path):
    path = tmp_path / "damaged.log"
    path.write_text(DAMAGED)
    with pytest.raises(LogFormatError) as exc:
        read_frames(path, strict=True)
    assert exc.value.line == 2 and exc.value.path == str(path)
    assert f"{path}:2:" in str(exc.value)


def test_damaged_asc_line_is_skipped_and_reading_goes_on(tmp_path, caplog):
    src = DATA / "logfile.asc"
    lines = src.read_text().splitlines(keepends=True)
    bad = next(i for i, t in enumerate(lines) if "6F9" in t)
    lines[bad] = lines[bad].replace("05 0C", "0Z 0C")
    path = tmp_path / "bad.asc"
    path.write_text("".join(lines))
    with caplog.at_level(logging.WARNING):
        frames, report = read_frames(path)
    assert report.skipped_lines == 1 and report.skipped[0][0] == bad + 1
    assert len(frames) == len(list(can.LogReader(src))) - 1
    with pytest.raises(LogFormatError) as exc:
        read_frames(path, strict=True)
    assert exc.value.line == bad + 1


def test_unknown_suffix_lists_supported_formats(tmp_path):
    path = tmp_path / "trial.lgo"
    path.write_text("")
    with pytest.raises(LogFormatError) as exc:
        read_frames(path)
    msg = str(exc.value)
    assert str(path) in msg and ".log" in msg and ".asc" in msg and ".blf" in msg
    assert "did you mean '.log'" in msg


def test_missing_file_is_a_log_format_error(tmp_path):
    with pytest.raises(LogFormatError, match="no such file"):
        read_frames(tmp_path / "nope.log")


def test_gzipped_peer_log_copy(tmp_path):
    path = tmp_path / "copy.blf"
    shutil.copy(DATA / "test_CanMessage.blf", path)
    frames, _ = read_frames(path)
    assert_same_frames(frames, frames_from_messages(can.LogReader(DATA / "test_CanMessage.blf")))


def test_write_candump_keeps_a_remote_frames_length(tmp_path):
    msgs = [can.Message(timestamp=T0 + k, arbitration_id=0x123, is_remote_frame=True, dlc=k,
                        is_extended_id=bool(k % 2)) for k in range(9)]
    path = tmp_path / "remote.log"
    write_candump(path, frames_from_messages(msgs))
    lines = path.read_text().splitlines()
    assert lines[0].endswith(" 123#R") and lines[4].endswith(" 123#R4")
    assert lines[3].endswith(" 00000123#R3")
    back, _ = read_frames(path)
    assert back.dlc.tolist() == list(range(9)) and back.is_remote.all()
    ref = list(can.CanutilsLogReader(path))
    assert [m.dlc for m in ref] == list(range(9))


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 40), st.integers(1, 64), st.data())
def test_taking_frames_by_mask_or_index_is_indexing_each_column(n, width, data):
    """FrameTable.take (which copies payload rows whole) gives each column indexed as numpy
    indexes it, for a mask or for integers (repeated, negative, any order); a mask of
    another length is refused as numpy refuses it."""
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    table = FrameTable(timestamp=rng.random(n), arbitration_id=rng.integers(0, 2**29, n,
                                                                              dtype=np.uint32),
                       is_extended=rng.random(n) < 0.5, is_remote=rng.random(n) < 0.1,
                       is_error=rng.random(n) < 0.1, is_fd=rng.random(n) < 0.5,
                       dlc=rng.integers(0, 9, n, dtype=np.uint8),
                       data=rng.integers(0, 256, (n, width), dtype=np.uint8))
    if data.draw(st.booleans()):
        index = rng.random(n) < 0.5
    else:
        index = np.array(data.draw(st.lists(st.integers(-n, n - 1), max_size=50)) if n else [],
                         dtype=np.intp)
    got = table.take(index)
    for name in ("timestamp", "arbitration_id", "is_extended", "is_remote", "is_error",
                 "is_fd", "dlc", "data", "channels"):
        np.testing.assert_array_equal(getattr(got, name), getattr(table, name)[index],
                                      err_msg=name)
    with pytest.raises(IndexError):
        table.take(np.ones(n + 1, dtype=bool))
