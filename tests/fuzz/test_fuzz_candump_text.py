"""candump's screen output (-ta, -tz, -td, -tA) damaged every way the other text logs are:
frames and counted skips, or a LogFormatError naming the file; never another exception."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from _fuzz_seeds import byte_mutations, line_mutations, messages, trial_frames
from hypothesis import given
from hypothesis import strategies as st
from test_fuzz_readers import check_read

sys.path.insert(0, str(Path(__file__).parents[1] / "canlog"))
from _candump_screen import screen_log


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("screen")


def seed(mode: str) -> bytes:
    msgs = messages(trial_frames())
    for m in msgs:
        m.channel = "vcan0"
    return screen_log(msgs, mode, extra=mode == "d", ascii_view=mode == "a").encode()


@pytest.mark.parametrize("mode", ["a", "z", "d", "A"])
def test_screen_seed_reads_without_skips(work, mode):
    path = work / f"seed-{mode}.log"
    path.write_bytes(seed(mode))
    frames = check_read(path, strict=True)
    assert frames is not None and len(frames) == len(trial_frames())


@pytest.mark.parametrize("mode", ["a", "z", "d", "A"])
@given(data=st.data())
def test_damaged_lines_of_screen_output(work, mode, data):
    damaged = data.draw(line_mutations(seed(mode)))
    path = work / f"lines-{mode}.log"
    path.write_bytes(damaged)
    assert check_read(path) is not None, "a screen log with damaged lines is still read"
    check_read(path, strict=True)


@pytest.mark.parametrize("mode", ["a", "d"])
@given(data=st.data())
def test_damaged_bytes_of_screen_output(work, mode, data):
    path = work / f"bytes-{mode}.log"
    path.write_bytes(data.draw(byte_mutations(seed(mode))))
    check_read(path)
    check_read(path, strict=True)
