"""candump -L details held against python-can's reader: each frame's channel, raw DLC
suffixes, DROPCOUNT notices, CAN XL frames, over-long classic frames."""

import io
from pathlib import Path

import can
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_readers import T0, assert_same_frames

from evtribo.canlog.io import frames_from_messages, read_frames
from evtribo.canlog.io.candump import iter_blocks, read_candump

TEXT = Path(__file__).parent.parent / "data" / "candump-text"


def _names(frames):
    return np.array(frames.channel_names, dtype=object)[frames.channels].tolist()


def _python_can(path):
    msgs = list(can.LogReader(path))
    return msgs, frames_from_messages(msgs)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.sampled_from(["vcan0", "can1", "vcan10", "x"]),
                          st.integers(0, 0x7FF), st.binary(max_size=8)),
                min_size=1, max_size=300),
       st.booleans(), st.sampled_from([64, 4096, 1 << 22]))
def test_each_frame_keeps_its_channel_as_python_can_reads_it(tmp_path, rows, padded,
                                                            block_size):
    """Lines of several buses, mixed in any order (candump pads the names to one width):
    the fast and the slow path give each frame python-can's channel."""
    width = max(len(ch) for ch, _, _ in rows)
    path = tmp_path / "buses.log"
    path.write_text("".join(
        f"({T0 + i * 1e-4:.6f}) {ch.rjust(width) if padded else ch} {can_id:03X}#"
        f"{data.hex().upper()}\n" for i, (ch, can_id, data) in enumerate(rows)))
    frames, lines = read_candump(path, lambda *a: pytest.fail(f"damaged {a}"),
                                 block_size=block_size)
    msgs, ref = _python_can(path)
    assert lines == len(rows)
    assert_same_frames(frames, ref)
    assert _names(frames) == [str(m.channel) for m in msgs] == [ch for ch, _, _ in rows]
    assert frames.channel == rows[0][0]
    assert list(frames.channel_names) == list(dict.fromkeys(ch for ch, _, _ in rows))


def test_the_same_id_on_two_buses_stays_two_streams(tmp_path):
    path = tmp_path / "two.log"
    path.write_text("".join(f"({T0 + i * 1e-3:.6f}) {'can0' if i % 2 else 'can1'} 0C1#"
                            f"{i:016X}\n" for i in range(1000)))
    frames, report = read_frames(path)
    assert report.channels == {"can1": 500, "can0": 500}
    assert frames.channel_counts() == {"can1": 500, "can0": 500}
    on0 = frames.take(frames.on_channel("can0"))
    assert (on0.data[:, 7] % 2 == 1).all() and len(on0) == 500


def test_raw_dlc_suffixes_are_frames_of_8_bytes(tmp_path):
    """``_9``...``_F`` after 8 data bytes (and ``R8_F``) is candump's raw DLC code: the frame
    is python-can's frame without it; python-can cannot read the suffix itself."""
    lines = ["(1763700000.000100) vcan0 123#1122334455667788_9",
             "(1763700000.000200) vcan0 123#1122334455667788_F",
             "(1763700000.000300) vcan0 1ABCDEF0#0102030405060708_A",
             "(1763700000.000400) vcan0 123#R8_F",
             "(1763700000.000500) vcan0 123#1122334455667788"]
    path = tmp_path / "dlc.log"
    path.write_text("\n".join(lines) + "\n")
    plain = tmp_path / "plain.log"
    plain.write_text("\n".join(ln.split("_")[0] for ln in lines) + "\n")
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    assert_same_frames(frames, _python_can(plain)[1])
    # a fixed-width block of them takes the column parser
    def line(i, suffix):
        return f"({T0 + i * 1e-4:.6f}) vcan0 {i % 0x800:03X}#{i:016X}{suffix}\n"

    many, many_plain = tmp_path / "many.log", tmp_path / "many-plain.log"
    many.write_text("".join(line(i, "_" + "9ABCDEF"[i % 7]) for i in range(5000)))
    many_plain.write_text("".join(line(i, "") for i in range(5000)))
    frames, report = read_frames(many)
    assert report.skipped_lines == 0
    assert_same_frames(frames, _python_can(many_plain)[1])


@pytest.mark.parametrize("bad", ["123#1122_9", "123#112233445566778899_9", "123#R4_F",
                                 "123#1122334455667788_", "123##1112233445566778_9"])
def test_a_raw_dlc_suffix_where_candump_writes_none_is_damage(tmp_path, bad):
    path = tmp_path / "bad.log"
    path.write_text(f"(1763700000.000100) vcan0 123#00\n(1763700000.000200) vcan0 {bad}\n")
    frames, report = read_frames(path)
    assert len(frames) == 1 and report.skipped_lines == 1


def test_dropcount_notices_are_counted_as_dropped_frames_not_damage(tmp_path):
    path = tmp_path / "drops.log"
    path.write_text(
        "(1763700000.000100) can0 0C1#1122334455667788\n"
        "DROPCOUNT: dropped 1 CAN frame on 'can0' socket (total drops 1)\n"
        "(1763700000.000300) can0 0C1#1122334455667788\n"
        "DROPCOUNT: dropped 12 CAN frames on 'can0' socket (total drops 13)\n"
        "DROPCOUNT: dropped 3 CAN frames on 'can1' socket (total drops 3)\n"
        "(1763700000.000500) can1 0C2#1122334455667788\n")
    frames, report = read_frames(path, strict=True)
    assert len(frames) == 3 and report.skipped_lines == 0
    assert report.dropped_frames == 16
    assert frames.reported_drops == {"can0": 13, "can1": 3}


def test_can_xl_frames_are_counted_not_damage(tmp_path):
    path = tmp_path / "xl.log"
    path.write_text(
        "(1763700000.000100) can0 0C1#1122334455667788\n"
        "(1763700000.000200) can0 45123#80:00:00000000#11223344\n"
        "(1763700000.000300) can0 00242#81:01:12345678#" + "AB" * 100 + "\n")
    frames, report = read_frames(path, strict=True)
    assert len(frames) == 1 and report.xl_frames == 2 and report.skipped_lines == 0


def test_over_long_classic_frame_is_kept_as_python_can_keeps_it(tmp_path):
    path = tmp_path / "long.log"
    src = (TEXT / "candump-L-suffixes.log").read_text()
    path.write_text(src.replace("(1594172462.127684) vcan0 ERROR\n", ""))
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    ref = _python_can(path)[1]
    assert_same_frames(frames, ref)
    row = int(np.flatnonzero(frames.arbitration_id == 0x064)[0])
    assert frames.dlc[row] == 10 and not frames.is_fd[row]
    assert frames.data[row, :10].tobytes() == bytes.fromhex("F001FFFFFFFFFFFFFFFF")


class _ReadOnly:
    """A stream that has read() and nothing else (no readinto)."""

    def __init__(self, data: bytes) -> None:
        self._io = io.BytesIO(data)

    def read(self, n: int = -1) -> bytes:
        return self._io.read(n)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.binary(max_size=30).map(lambda b: b.replace(b"\n", b"")), max_size=40),
       st.booleans(), st.integers(1, 64), st.booleans())
def test_blocks_are_the_stream_cut_after_newlines(lines, last_newline, block_size, read_only):
    """iter_blocks (which reads into one buffer again and again) gives the stream's bytes
    whole, in order, each block but the last ending with a newline, each kept block intact
    after the next ones are read, whatever the block size against the lines' lengths."""
    data = b"\n".join(lines) + (b"\n" if last_newline and lines else b"")
    stream = _ReadOnly(data) if read_only else io.BytesIO(data)
    blocks = list(iter_blocks(stream, block_size))
    assert b"".join(blocks) == data
    assert all(b.endswith(b"\n") for b in blocks[:-1])
    assert all(blocks)
