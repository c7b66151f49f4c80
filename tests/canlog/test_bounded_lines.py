"""A log whose line no frame can have (a gzip bomb: a few hundred kB holding hundreds of MiB
of zeros on one line) is read in bounded memory: the line is damaged, never held, and the
frames around it are kept."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
import zlib
from pathlib import Path

import pytest

ZEROS = 256 << 20  # bytes of the one line of zeros

LINES = {
    ".log.gz": ("(1763700000.000000) vcan0 0C1#0000000000000000\n",
                "(1763700000.002000) vcan0 0C2#0000000000000000\n", "", ""),
    ".asc.gz": ("   0.000000 1  0C1             Rx   d 8 00 00 00 00 00 00 00 00\n",
                "   0.002000 1  0C2             Rx   d 8 00 00 00 00 00 00 00 00\n",
                "date Mon Nov 23 06:19:31.000 am 2026\nbase hex  timestamps absolute\n"
                "internal events logged\nBegin Triggerblock Mon Nov 23 06:19:31.000 am 2026\n",
                "End TriggerBlock\n"),
    # candump's screen output with absolute times (candump -ta), read by its own reader
    ".text.log.gz": (" (1763700000.000000)  vcan0  0C1   [8]  00 00 00 00 00 00 00 00\n",
                     " (1763700000.002000)  vcan0  0C2   [8]  00 00 00 00 00 00 00 00\n", "",
                     ""),
}


def _bomb(path: Path, first: str, last: str, head: str, tail: str) -> None:
    """*head*, a frame, a line of :data:`ZEROS` zero bytes, a frame, *tail*, gzipped."""
    z = zlib.compressobj(9, zlib.DEFLATED, 31)
    chunk = bytes(1 << 20)
    parts = [z.compress((head + first).encode())]
    parts += [z.compress(chunk) for _ in range(ZEROS >> 20)]
    parts += [z.compress(("\n" + last + tail).encode()), z.flush()]
    path.write_bytes(b"".join(parts))


PROBE = r"""
import json, resource, sys
from evtribo.canlog.io import read_frames
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
frames, report = read_frames(sys.argv[1])
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"grew_kib": after - before, "frames": len(frames),
                  "ids": [int(i) for i in frames.arbitration_id],
                  "skipped": report.skipped_lines, "why": [r for _, r in report.skipped]}))
"""


@pytest.mark.slow
@pytest.mark.parametrize("suffix", list(LINES))
def test_a_line_of_hundreds_of_mib_is_damaged_in_bounded_memory(tmp_path, suffix):
    path = tmp_path / ("run-01" + suffix.replace(".text", ""))
    _bomb(path, *LINES[suffix])
    assert path.stat().st_size < 2 << 20
    with gzip.open(path, "rb") as fh:  # the file is what it says: frames around the zeros
        assert fh.read(1000).count(b"\x00") > 500
    proc = subprocess.run([sys.executable, "-c", PROBE, str(path)], capture_output=True,
                          text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    got = json.loads(proc.stdout)
    assert got["ids"] == [0x0C1, 0x0C2] and got["skipped"] == 1, got
    assert got["why"][0].startswith("a line of 268,435,4"), got["why"]
    assert "longer than any frame's (65,536 at most): not read" in got["why"][0]
    assert got["grew_kib"] < 64 << 10, got  # the line is 256 MiB; memory grew < 64 MiB
