"""Logs that are not candump -L: candump's screen output (-ta, -tz, -td, -tA) read; what
cannot be read (no timestamps, another format under a log suffix, .db.gz, a damaged .db, .mf4
without asammdf) refused with the file, what it looks like and what to do."""

import gzip
import logging
import shutil
from pathlib import Path

import can
import numpy as np
import pytest
from _candump_screen import screen_log
from test_readers import DATA, assert_same_frames

from evtribo.canlog.io import frames_from_messages, read_frames, write_candump
from evtribo.errors import LogFormatError

TEXT = Path(__file__).parent.parent / "data" / "candump-text"
T0 = 1763700000.0


def _messages() -> list[can.Message]:
    """Every kind of frame candump prints, on two buses, as python-can reads them back."""
    rng = np.random.default_rng(5)
    msgs = []
    for i in range(80):
        ext = i % 7 == 3
        fd = i % 11 == 5
        n = int(rng.choice([12, 16, 64])) if fd else int(rng.integers(0, 9))
        msgs.append(can.Message(
            timestamp=T0 + i * 0.0012 + int(rng.integers(0, 900)) * 1e-6,
            arbitration_id=int(rng.integers(0, 0x1FFFFFFF if ext else 0x7FF)),
            is_extended_id=ext, is_fd=fd, data=rng.integers(0, 256, n, np.uint8).tobytes(),
            channel="vcan0" if i % 3 else "can1"))
    msgs.insert(10, can.Message(timestamp=msgs[9].timestamp, arbitration_id=0x123,
                                is_remote_frame=True, is_extended_id=False, channel="vcan0"))
    msgs.insert(20, can.Message(timestamp=msgs[19].timestamp, is_error_frame=True,
                                channel="vcan0"))
    return msgs


@pytest.fixture
def reference(tmp_path):
    """The frames written as candump -L by python-can, and python-can's reading of them."""
    path = tmp_path / "ref.log"
    with can.CanutilsLogWriter(path) as writer:
        for m in _messages():
            writer.on_message_received(m)
    msgs = list(can.LogReader(path))
    return msgs, frames_from_messages(msgs)


@pytest.mark.parametrize(("mode", "extra", "ascii_view"),
                         [("a", False, False), ("z", False, False), ("d", False, False),
                          ("A", False, False), ("a", True, True), ("d", True, False)])
def test_screen_output_reads_as_python_can_reads_the_same_frames(tmp_path, reference, mode,
                                                                 extra, ascii_view):
    msgs, ref = reference
    path = tmp_path / "screen.log"
    path.write_text(screen_log(msgs, mode, extra=extra, ascii_view=ascii_view))
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    relative = mode in ("z", "d")
    assert_same_frames(frames, ref, error_ids=False, relative=relative)
    if relative:
        assert frames.timestamp[0] == 0
    data = ~ref.is_error
    names = np.array(frames.channel_names)[frames.channels]
    ref_names = np.array(ref.channel_names)[ref.channels[data]]
    assert names[data].tolist() == ref_names.tolist()
    assert report.time_base == {"a": "", "z": "-tz", "d": "-td", "A": "-tA"}[mode]


def _as_log(src: Path, tmp: Path) -> Path:
    """A .txt sample copied as the .log it would be saved as."""
    path = tmp / (src.stem + ".log")
    shutil.copy(src, path)
    return path


def _printed_times(src: Path) -> list[str]:
    return [line.split("(")[1].split(")")[0] for line in src.read_text().splitlines()]


def test_td_times_are_the_sum_of_the_printed_deltas_and_the_warning_bounds_them(tmp_path,
                                                                                 caplog):
    src = TEXT / "candump-td.txt"
    deltas = [int(t.replace(".", "")) for t in _printed_times(src)]
    with caplog.at_level(logging.WARNING):
        frames, _ = read_frames(_as_log(src, tmp_path))
    np.testing.assert_array_equal(frames.timestamp, np.cumsum(deltas) / 1e6)
    assert f"up to {len(deltas) - 1} µs" in caplog.text


@pytest.mark.parametrize("name", ["candump-tz.txt", "candump-tA.txt"])
def test_tz_and_ta_samples_read_as_printed(tmp_path, name):
    src = TEXT / name
    lines = src.read_text().splitlines()
    frames, report = read_frames(_as_log(src, tmp_path))
    assert len(frames) == len(lines) and report.skipped_lines == 0
    payloads = [bytes.fromhex("".join(line.split("]")[1].split())) for line in lines]
    assert [frames.data[i, :frames.dlc[i]].tobytes() for i in range(len(frames))] == payloads
    assert frames.is_extended.all() and (frames.arbitration_id == 0x343).all()
    assert frames.channel_names == ("vcan0",)
    if name == "candump-tz.txt":
        np.testing.assert_allclose(frames.timestamp, [float(t) for t in _printed_times(src)],
                                   rtol=0, atol=1e-9)
    else:  # 2020-12-27 11:59:14.820230, read as UTC
        assert frames.timestamp[0] == pytest.approx(1609070354.820230, abs=1e-6)
        assert np.diff(frames.timestamp)[0] == pytest.approx(1.001765, abs=1e-6)


def test_screen_output_without_timestamps_is_refused_with_how_to_record(tmp_path):
    path = tmp_path / "run-01.log"
    shutil.copy(TEXT / "candump-plain.txt", path)
    with pytest.raises(LogFormatError) as exc:
        read_frames(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}: ")
    assert "without timestamps" in msg and "candump -L can0 > run-01.log" in msg


def _asc(tmp):
    return (DATA / "logfile.asc").read_bytes()


def _savvycan(tmp):
    return (b"Time Stamp,ID,Extended,Dir,Bus,LEN,D1,D2,D3,D4,D5,D6,D7,D8\n"
            b"166064000,000000C1,false,Rx,0,8,FE,36,12,FE,69,05,07,AD,\n"
            b"166065000,000000C2,false,Rx,0,2,01,02,\n")


def _blf(tmp):
    return (DATA / "test_CanMessage.blf").read_bytes()


def _candump(tmp):
    return b"(1763700000.000100) vcan0 0C1#1122334455667788\n"


def _decoded(tmp):
    return b"timestamp,message,Fz\n1763700000.0001,FzCell,0.5\n"


def _gzipped(tmp):
    return gzip.compress(_candump(tmp))


@pytest.mark.parametrize(("name", "content", "looks", "todo"), [
    ("run-01.log", _asc, "a Vector ASC log", "rename it to run-01.asc"),
    ("run-01.csv", _savvycan, "a SavvyCAN/GVRET CSV log", "'Candump/Kayak (*.log)'"),
    ("run-01.log", _blf, "a Vector BLF binary log", "rename it to run-01.blf"),
    ("run-01.asc", _candump, "a candump -L log", "rename it to run-01.log"),
    ("run-01.csv", _candump, "a candump -L log", "rename it to run-01.log"),
    ("run-01.trc", _candump, "a candump -L log", "rename it to run-01.log"),
    ("run-01.csv", _decoded, "decoded signals", "the raw CAN log it was decoded from"),
    ("run-01.log", _gzipped, "gzip-compressed a candump -L log", "rename it to run-01.log.gz"),
    ("run-01.txt", _candump, "a candump -L log", "rename it to run-01.log"),
])
def test_a_log_of_another_format_than_its_suffix_is_refused(tmp_path, name, content, looks,
                                                            todo):
    """Today's alternative: zero frames, a damaged line per line (or none), exit 0."""
    path = tmp_path / name
    path.write_bytes(content(tmp_path))
    before = path.read_bytes()
    with pytest.raises(LogFormatError) as exc:
        read_frames(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}: ") and looks in msg and todo in msg
    assert path.read_bytes() == before


def test_a_text_log_without_a_single_frame_is_refused(tmp_path):
    path = tmp_path / "run-01.log"
    path.write_text("this is a lab notebook\nnot a log\n")
    with pytest.raises(LogFormatError, match="no line of it is a frame"):
        read_frames(path)


def test_gzipped_db_and_unreadable_db_are_refused(tmp_path):
    db = tmp_path / "run-01.db"
    with can.SqliteWriter(db) as writer:
        writer.on_message_received(can.Message(timestamp=T0, arbitration_id=0xC1, data=b"\1"))
    gz = tmp_path / "run-02.db.gz"
    gz.write_bytes(gzip.compress(db.read_bytes()))
    with pytest.raises(LogFormatError, match=r"gzipped SQLite database .*gunzip"):
        read_frames(gz)
    junk = tmp_path / "run-03.db"
    junk.write_text("not a database\n")
    empty = tmp_path / "run-04.db"
    empty.write_bytes(b"")
    other = tmp_path / "run-05.db"
    import sqlite3
    with sqlite3.connect(other) as conn:
        conn.execute("CREATE TABLE frames (t REAL)")
    conn.close()
    for path, why in ((junk, "not an SQLite database"), (empty, "empty file"),
                      (other, "without python-can's 'messages' table")):
        with pytest.raises(LogFormatError, match=why) as exc:
            read_frames(path)
        assert exc.value.path == str(path)


def test_db_is_read_read_only_as_python_can_reads_it(tmp_path):
    path = tmp_path / "run-01.db"
    msgs = [m for m in _messages() if not m.is_fd and not m.is_error_frame]
    with can.SqliteWriter(path) as writer:
        for m in msgs:
            writer.on_message_received(m)
    path.chmod(0o444)
    before = (path.read_bytes(), path.stat().st_mtime_ns)
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    reader = can.SqliteReader(str(path))
    ref = frames_from_messages(list(reader))
    reader.stop()
    assert_same_frames(frames, ref)
    assert (path.read_bytes(), path.stat().st_mtime_ns) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run-01.db"]


def _mf4(tmp_path):
    pytest.importorskip("asammdf")
    path = tmp_path / "run-01.mf4"
    msgs = [m for m in _messages() if not m.is_error_frame and not m.is_remote_frame]
    for m in msgs:
        m.channel = 0 if m.channel == "vcan0" else 1
    with can.Logger(path) as writer:
        for m in msgs:
            writer.on_message_received(m)
    return path


def test_mf4_is_read_as_python_can_reads_it(tmp_path):
    path = _mf4(tmp_path)
    frames, report = read_frames(path)
    with can.LogReader(path) as reader:
        ref = frames_from_messages(reader)
    assert report.skipped_lines == 0 and len(frames) > 50
    assert_same_frames(frames, ref)


def test_mf4_without_asammdf_names_the_extra_to_install(tmp_path, monkeypatch):
    import importlib.util

    path = tmp_path / "run-01.mf4"
    path.write_bytes(b"MDF     4.10    " + bytes(48))
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "asammdf" else real(name, *a))
    with pytest.raises(LogFormatError) as exc:
        read_frames(path)
    assert str(exc.value) == (f"{path}: reading .mf4 logs needs the optional package "
                              "asammdf: pip install 'evtribo[mf4]'")


def test_candump_logs_written_by_evtribo_and_python_can_are_not_refused(tmp_path, reference):
    """The look at the content never refuses a log of the format its suffix says."""
    msgs, ref = reference
    for suffix in (".log", ".log.gz", ".asc", ".trc", ".csv", ".blf"):
        path = tmp_path / f"x{suffix}"
        if suffix.startswith(".log"):
            write_candump(path, ref)
        else:
            with can.Logger(path) as writer:
                for m in msgs:
                    if not m.is_fd or suffix in (".asc", ".blf"):
                        writer.on_message_received(m)
        frames, _ = read_frames(path)
        assert len(frames) > 50


@pytest.mark.parametrize("mode", ["d", None])
def test_a_run_of_nul_bytes_does_not_hide_what_a_text_log_is(tmp_path, reference, mode):
    """A power cut can leave a text log with a run of NUL bytes: it stays a damaged line of
    the log it is (candump -td screen output here, candump -L written by evtribo)."""
    msgs, ref = reference
    path = tmp_path / "run-01.log"
    if mode is None:
        write_candump(path, ref)
        text = path.read_bytes()
    else:
        text = screen_log(msgs, mode).encode()
    path.write_bytes(b"\x00" * 300 + text[:2000] + b"\x00" * 3000 + b"\n" + text[2000:])
    frames, report = read_frames(path)
    assert report.skipped_lines >= 1 and len(frames) >= len(ref) - 3
