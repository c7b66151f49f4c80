"""Every reader on arbitrary bytes and on damaged real logs: frames, counted skips, or a
:class:`~evtribo.errors.LogFormatError` naming the file; never another exception.

The number of examples follows the hypothesis profile (``HYPOTHESIS_PROFILE=thorough``).
"""

from __future__ import annotations

import numpy as np
import pytest
from _fuzz_seeds import (
    FORMATS,
    TEXT_FORMATS,
    byte_mutations,
    line_mutations,
    plain_bytes,
    seed_bytes,
    write,
)
from hypothesis import given
from hypothesis import strategies as st

from evtribo.canlog.io import read_frames
from evtribo.errors import LogFormatError


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    return str(tmp_path_factory.mktemp("seeds"))


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


def check_read(path, *, strict=False):
    """Read *path*; the outcome must be frames and counted skips, or a LogFormatError
    naming the file. Returns the frames (None on an error)."""
    try:
        frames, report = read_frames(path, strict=strict)
    except LogFormatError as err:
        assert str(path) in str(err)
        assert err.path == str(path)
        return None
    n = len(frames)
    for name in ("arbitration_id", "is_extended", "is_remote", "is_error", "is_fd", "dlc"):
        assert getattr(frames, name).shape == (n,), name
    assert frames.data.shape[0] == n and frames.data.shape[1] in (8, 64)
    assert report.frames == n
    assert report.skipped_lines >= 0
    assert report.skipped_lines == 0 or not strict
    assert len(report.skipped) == min(report.skipped_lines, 1000)
    assert np.isfinite(frames.timestamp).all(), "a frame with a timestamp that is no number"
    assert (frames.dlc <= frames.data.shape[1]).all()
    return frames


@pytest.mark.parametrize("fmt", FORMATS)
def test_seed_logs_read_without_skips(seeds, work, fmt):
    path = work / f"seed{fmt}"
    path.write_bytes(seed_bytes(fmt, seeds))
    frames, report = read_frames(path)
    assert report.skipped_lines == 0
    assert len(frames) > 100


@pytest.mark.parametrize("fmt", FORMATS)
@given(data=st.binary(max_size=4096))
def test_arbitrary_bytes(seeds, work, fmt, data):
    path = work / f"bytes{fmt}"
    write(path, data, compress=False)   # .log.gz: not even gzip
    check_read(path)
    check_read(path, strict=True)


@pytest.mark.parametrize("fmt", FORMATS)
@given(data=st.data())
def test_damaged_bytes_of_a_real_log(seeds, work, fmt, data):
    """Truncated, bit-flipped, overwritten: for .log.gz the compressed bytes themselves."""
    damaged = data.draw(byte_mutations(seed_bytes(fmt, seeds)))
    path = work / f"damaged{fmt}"
    write(path, damaged, compress=False)
    check_read(path)
    check_read(path, strict=True)


@pytest.mark.parametrize("fmt", [*TEXT_FORMATS, ".log.gz"])
@given(data=st.data())
def test_damaged_lines_of_a_real_log(seeds, work, fmt, data):
    """Lines cut mid-way, repeated, swapped, blank; NaN, huge values, wrong DLC, garbage."""
    damaged = data.draw(line_mutations(plain_bytes(fmt, seeds)))
    path = work / f"lines{fmt}"
    write(path, damaged, compress=fmt.endswith(".gz"))
    frames = check_read(path)
    check_read(path, strict=True)
    assert frames is not None or fmt in (".trc",), "a text log with damaged lines is still read"


@pytest.mark.parametrize("fmt", FORMATS)
def test_empty_file(work, fmt):
    path = work / f"empty{fmt}"
    write(path, b"", compress=fmt.endswith(".gz"))
    check_read(path)


@pytest.mark.parametrize("fmt", TEXT_FORMATS)
def test_a_frame_line_cut_anywhere_is_read_or_counted(seeds, work, fmt):
    """No frame vanishes in silence: a frame line cut at any position is still read (a
    shorter payload), or counted as a damaged line. python-can's .asc and .trc readers pass
    such lines over without a word; evtribo reports them."""
    lines = plain_bytes(fmt, seeds).split(b"\n")
    path = work / f"cut{fmt}"
    path.write_bytes(b"\n".join(lines))
    n0 = len(read_frames(path)[0])
    body = [i for i, ln in enumerate(lines) if ln.strip() and not ln.startswith((b";", b"//"))]
    for i in (body[1], body[len(body) // 2], body[-1]):
        for cut in range(len(lines[i].rstrip(b"\r"))):
            kept = lines[i][:cut]
            if not kept.strip():
                continue  # a blank line is no frame
            if fmt == ".trc" and kept.split()[-1] == b"D":
                continue  # the type column cut to 'D': a record type python-can skips
            damaged = [*lines[:i], kept, *lines[i + 1:]]
            path.write_bytes(b"\n".join(damaged))
            frames, report = read_frames(path)
            assert len(frames) + report.skipped_lines == n0, (cut, kept)
