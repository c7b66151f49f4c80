"""Streamed reading and decoding equal the whole-file result, whatever the block size."""

import gzip
import logging
import tempfile
from pathlib import Path

import cantools
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evtribo.canlog.decode_table import decoded_table, write_decoded
from evtribo.canlog.io import FrameStream, FrameTable, read_frames
from evtribo.canlog.io.candump import iter_candump, read_candump
from evtribo.errors import LogFormatError, UserInputError

T0 = 1763700000.0

DBC = '''VERSION ""
NS_ :
BS_:
BU_: Cell1 Cell2 Amp
BO_ 257 Cell1: 8 Cell1
 SG_ Fn : 0|24@1- (1e-05,0) [-80|80] "N" Vector__XXX
 SG_ FnCount : 56|8@1+ (1,0) [0|255] "" Vector__XXX
BO_ 2566848770 Cell2: 6 Cell2
 SG_ Ft : 7|16@0- (0.0001,0) [-3|3] "N" Vector__XXX
 SG_ FnCount : 23|8@0+ (1,0) [0|255] "" Vector__XXX
BO_ 416 AmpStatus: 3 Amp
 SG_ On : 0|1@1+ (1,0) [0|1] "" Vector__XXX
 SG_ Volts : 8|16@1+ (0.01,0) [0|655.35] "V" Vector__XXX
VAL_ 416 On 0 "off" 1 "on" ;
'''

# (id text, payload bytes) of the frames a line may hold: the DBC's messages (one of them
# sometimes too short), foreign IDs of both kinds, a remote frame
_IDS = ["101", "18FF0102", "1A0", "0F0", "7E8", "1ABCDE01", "101"]
_DAMAGE = ["(1763700000.5) vcan0 101#12345", "garbage", "(17637x0000.000100) vcan0 0F0#00",
           "(1763700000.000100) vcan0 0F0#0", ""]


@st.composite
def logs(draw):
    """Lines of a candump -L log: mixed lengths, extended IDs, two buses, damaged lines."""
    n = draw(st.integers(1, 120))
    buses = draw(st.sampled_from([["vcan0"], ["vcan0", " can1"], ["can1"]]))
    lines = []
    for i in range(n):
        if draw(st.integers(0, 15)) == 0:
            lines.append(draw(st.sampled_from(_DAMAGE)))
            continue
        can_id = draw(st.sampled_from(_IDS))
        bus = draw(st.sampled_from(buses))
        if draw(st.integers(0, 30)) == 0:
            body = "R"
        else:
            body = draw(st.binary(min_size=0, max_size=8)).hex().upper()
        lines.append(f"({T0 + i * 1e-4:.6f}) {bus} {can_id}#{body}")
    return lines


def _write_log(path: Path, lines: list[str], crlf: bool, final_newline: bool) -> None:
    end = "\r\n" if crlf else "\n"
    text = end.join(lines) + (end if final_newline else "")
    if path.suffix == ".gz":
        with gzip.open(path, "wt", newline="") as fh:
            fh.write(text)
    else:
        path.write_bytes(text.encode())


def _same(a: FrameTable, b: FrameTable) -> None:
    assert len(a) == len(b)
    for name in ("timestamp", "arbitration_id", "is_extended", "is_remote", "is_error",
                 "is_fd", "dlc", "data"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    names = [np.array([*t.channel_names, ""], dtype=object)[t.channels] for t in (a, b)]
    np.testing.assert_array_equal(names[0], names[1])
    assert a.channel_names == b.channel_names and a.channel == b.channel
    assert a.reported_drops == b.reported_drops


_ENDINGS = [(False, True), (False, False), (True, True), (True, False)]


def _fresh(tmp_path: Path) -> Path:
    """A new folder per example (hypothesis runs many in one test's tmp_path)."""
    return Path(tempfile.mkdtemp(dir=tmp_path))


@settings(max_examples=60, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(logs(), st.integers(8, 400), st.sampled_from(_ENDINGS), st.sampled_from([".log",
                                                                                ".log.gz"]))
def test_blocks_of_any_size_give_the_whole_file_read(tmp_path, lines, block_size, ending,
                                                     suffix):
    """Block boundaries anywhere (inside lines, at damaged lines, gz or not, CRLF or not, a
    last line with or without its newline): the frames, the line count and each damaged
    line's number and reason equal one read of the whole file."""
    path = _fresh(tmp_path) / f"run{suffix}"
    _write_log(path, lines, *ending)
    whole_bad: list = []
    whole, n_whole = read_candump(path, lambda *a: whole_bad.append(a), block_size=1 << 24)
    streamed_bad: list = []
    blocks = list(iter_candump(path, lambda *a: streamed_bad.append(a), block_size=block_size))
    assert sum(n for _, n in blocks) == n_whole
    assert streamed_bad == whole_bad
    if blocks:
        _same(FrameTable.concat([t for t, _ in blocks]), whole)
    stream = FrameStream(path, block_size=block_size)
    try:
        tables = list(stream)
    except LogFormatError:  # no line is a frame: so says read_frames too
        with pytest.raises(LogFormatError):
            read_frames(path)
        return
    frames, report = read_frames(path)
    assert stream.report == report
    if tables:
        _same(FrameTable.concat(tables), frames)


def _old(path: Path, db, out: Path, choices: bool, channel: str | None) -> None:
    """The table as the whole-file path wrote it."""
    frames, _ = read_frames(path)
    with_channel = len(frames.channel_names) > 1
    if channel is not None:
        frames, with_channel = frames.take(frames.on_channel(channel)), True
    table = decoded_table(frames, db, choices=choices, with_channel=with_channel)
    if out.suffix == ".parquet":
        table.to_parquet(out, index=False)
    else:
        table.to_csv(out, index=False)


def _streamed(path: Path, db, out: Path, block_size: int, **kw):
    return write_decoded(lambda warn: FrameStream(path, block_size=block_size, warn=warn), db,
                         str(out), **kw)


@settings(max_examples=40, deadline=None, suppress_health_check=[
    HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(logs(), st.integers(64, 2000), st.sampled_from(
    [(c, f) for c in (False, True) for f in (".parquet", ".csv")]),
       st.sampled_from([None, "vcan0"]))
def test_streamed_table_equals_the_whole_table(tmp_path, lines, block_size, output, channel):
    """Parquet and CSV written block by block hold decoded_table's rows and columns (CSV:
    byte for byte), also when the columns change after the first block."""
    choices, fmt = output
    tmp_path = _fresh(tmp_path)
    path = tmp_path / "run.log"
    _write_log(path, lines, crlf=False, final_newline=True)
    db = cantools.database.load_string(DBC)
    try:
        frames, _ = read_frames(path)
    except LogFormatError:
        return
    old, new = tmp_path / f"old{fmt}", tmp_path / f"new{fmt}"
    if channel is not None and channel not in frames.channel_names:
        with pytest.raises(UserInputError, match="no channel"):
            _streamed(path, db, new, block_size, choices=choices, channel=channel)
        assert not new.exists()
        return
    _old(path, db, old, choices, channel)
    done = _streamed(path, db, new, block_size, choices=choices, channel=channel)
    if fmt == ".csv":
        assert new.read_bytes() == old.read_bytes()
    else:
        pd.testing.assert_frame_equal(pd.read_parquet(new), pd.read_parquet(old))
    assert done.rows == len(pd.read_parquet(new) if fmt == ".parquet" else pd.read_csv(new))


def test_a_message_first_seen_late_reads_the_log_twice_and_warns_once(tmp_path, caplog):
    lines = [f"({T0 + i * 1e-3:.6f}) vcan0 101#{i:016X}" for i in range(3000)]
    lines += [f"({T0 + 3 + i * 1e-3:.6f}) vcan0 1A0#01{i:04X}" for i in range(10)]
    lines += [f"({T0 + 4:.6f}) vcan0 1A0#01", "damaged"]
    path = tmp_path / "run.log"
    _write_log(path, lines, crlf=False, final_newline=True)
    db = cantools.database.load_string(DBC)
    with caplog.at_level(logging.WARNING):
        done = _streamed(path, db, tmp_path / "new.parquet", 4096, choices=True)
    assert done.passes == 2 and done.rows == 3010 and done.report.skipped_lines == 1
    assert [r.getMessage() for r in caplog.records] == [
        f"{path}:3012: skipped damaged line: not a candump -L line '(time) channel id#data'",
        "1 frames of AmpStatus (0x1A0) are shorter than its 3 bytes: not decoded"]
    _old(path, db, tmp_path / "old.parquet", True, None)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "new.parquet"),
                                  pd.read_parquet(tmp_path / "old.parquet"))
    table = pd.read_parquet(tmp_path / "new.parquet")
    assert table["On"].iloc[-1] == "on" and table["message"].iloc[0] == "Cell1"


def test_parquet_is_written_by_row_groups(tmp_path):
    import pyarrow.parquet as pq
    lines = [f"({T0 + i * 1e-3:.6f}) vcan0 101#{i:016X}" for i in range(5000)]
    path = tmp_path / "run.log"
    _write_log(path, lines, crlf=False, final_newline=True)
    db = cantools.database.load_string(DBC)
    done = _streamed(path, db, tmp_path / "new.parquet", 1 << 15)
    meta = pq.ParquetFile(tmp_path / "new.parquet").metadata
    assert done.passes == 1 and meta.num_rows == 5000
    assert meta.num_row_groups == -(-path.stat().st_size // (1 << 15))


def test_a_log_that_changes_between_the_two_readings_is_an_error_and_nothing_is_written(
        tmp_path):
    """The columns planned from the first reading must hold the second: a log grown by a
    message in between (a recording still writing it) stops decode, output untouched."""
    lines = [f"({T0 + i * 1e-3:.6f}) vcan0 101#{i:016X}" for i in range(3000)]
    first = tmp_path / "first.log"
    _write_log(first, [*lines, f"({T0 + 4:.6f}) vcan0 1A0#010203"], False, True)
    grown = tmp_path / "grown.log"
    _write_log(grown, [*lines, f"({T0 + 4:.6f}) vcan0 1A0#010203",
                       f"({T0 + 5:.6f}) vcan0 18FF0102#010203040506"], False, True)
    db = cantools.database.load_string(DBC)
    out = tmp_path / "new.parquet"
    out.write_bytes(b"kept")
    readings = iter([first, grown])
    with pytest.raises(LogFormatError, match="changed while it was decoded"):
        write_decoded(lambda warn: FrameStream(next(readings), block_size=4096, warn=warn),
                      db, str(out))
    assert out.read_bytes() == b"kept"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["first.log", "grown.log",
                                                          "new.parquet"]
