"""A log after a power cut (a run of NUL bytes where the file system lost its blocks, a
junk line) is still a log: whatever any reader of evtribo reads frames from, the guard
protects as a raw CAN log (no command writes over it, ``--force`` included)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.canlog.io import read_frames
from evtribo.cli import main
from evtribo.errors import LogFormatError
from evtribo.guard import what_input


def _frames(n: int) -> bytes:
    return b"".join(f"({1763700000 + i * 1e-3:.6f}) can0 0C1#{i % 256:02X}00000000000000\n"
                    .encode() for i in range(n))


CUT = {
    "NULs before the frames": b"\x00" * 300_000 + _frames(2999),
    "a junk line before the frames": bytes(range(32, 127)) * 1400 + b"\n" + _frames(2999),
    "NULs in the middle": _frames(1500) + b"\x00" * 300_000 + _frames(1499),
}


@pytest.mark.parametrize("case", sorted(CUT))
def test_a_log_after_a_power_cut_is_never_written_over(case, tmp_path, capsys):
    from synthetic import make_out

    log = tmp_path / "bench.log"
    log.write_bytes(CUT[case])
    frames, _ = read_frames(log)
    assert len(frames) >= 1499  # what inspect and analyze read of it
    assert what_input(log) == "a CAN log (a candump -L log)"
    out = make_out(tmp_path / "out")
    assert main(["report", str(out), "-o", str(log), "--force"]) == 2
    err = capsys.readouterr().err
    assert f"{log}: key '-o': is a CAN log (a candump -L log)" in err, err
    assert log.read_bytes() == CUT[case]


#: What precedes or follows the frames: (kind, size); built by :func:`_junk`.
junk = st.tuples(st.sampled_from(["nul", "line", "bytes"]), st.integers(0, 300_000))


def _junk(kind: str, n: int) -> bytes:
    if kind == "nul":
        return b"\x00" * n
    if kind == "line":
        return b"#" * n + b"\n"
    return bytes((i * 37 + n) % 256 for i in range(n % 3000)).replace(b"#", b"")


@settings(max_examples=30, deadline=None)
@given(before=st.lists(junk, max_size=3), after=st.lists(junk, max_size=2),
       n=st.integers(1, 40), suffix=st.sampled_from([".log", ".log.part"]))
def test_whatever_a_reader_reads_frames_from_the_guard_protects(before, after, n, suffix):
    data = (b"".join(_junk(*j) for j in before) + _frames(n)
            + b"".join(_junk(*j) for j in after))
    with tempfile.TemporaryDirectory() as d:
        log = Path(d) / f"run-01{suffix}"
        log.write_bytes(data)
        try:
            frames, _ = read_frames(log)
        except LogFormatError:
            return  # not read as a log: nothing to protect as one
        if len(frames):
            said = what_input(log)
            assert said is not None and said.startswith("a CAN log"), said
