"""A log's suffix picks its reader whatever its case, dots in its name, gzip or ``.part``
(as python-can's tests of ``LogReader``/``Logger`` suffixes): the registry, the readers and
the study's discovery agree on every such name."""

from __future__ import annotations

import gzip
from pathlib import Path

import can
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from evtribo.canlog.io import read_frames
from evtribo.canlog.io.candump import write_candump
from evtribo.canlog.io.pycan import frames_from_messages
from evtribo.canlog.io.registry import log_suffix, supported_suffixes
from evtribo.study import log_stem

FORMATS = (".log", ".asc", ".blf", ".csv", ".trc")
MESSAGES = [can.Message(timestamp=1763700000.0 + i * 1e-3, arbitration_id=0xC1 + i,
                        is_extended_id=False, data=bytes([i] * 8), channel="vcan0")
            for i in range(3)]


def _log_bytes(fmt: str, tmp: Path) -> bytes:
    """The three frames written as a *fmt* log (candump by evtribo, the rest by python-can)."""
    path = tmp / f"source{fmt}"
    if fmt == ".log":
        write_candump(path, frames_from_messages(MESSAGES), "vcan0")
    else:
        with can.Logger(path) as writer:
            for msg in MESSAGES:
                writer.on_message_received(msg)
    return path.read_bytes()


def _case(text: str, pattern: str) -> str:
    return {"lower": text.lower(), "upper": text.upper(),
            "title": text[:2].upper() + text[2:].lower()}[pattern]


NAMES = [
    # (how the name is made from the format's suffix, whether its content is gzipped)
    ("run-01{fmt}", False), ("RUN-01{FMT}", False), ("run-01{Fmt}", False),
    ("run.1{fmt}", False), ("2026.11.23.run{fmt}", False),
    ("run-01{fmt}.gz", True), ("run-01{Fmt}.GZ", True), ("run.1{fmt}.gz", True),
    ("run-01{fmt}.part", False), ("run-01{FMT}.PART", False), ("run-01{fmt}.gz.part", True),
    ("run.1{Fmt}.Gz.Part", True),
]


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_name_of_a_log_reads_the_same_frames(tmp_path, fmt):
    raw = _log_bytes(fmt, tmp_path)
    for template, gz in NAMES:
        name = template.format(fmt=fmt, FMT=fmt.upper(), Fmt=_case(fmt, "title"))
        path = tmp_path / name
        path.write_bytes(gzip.compress(raw, mtime=0) if gz else raw)
        assert log_suffix(path) == fmt + (".gz" if gz else ""), name
        frames, report = read_frames(path)
        assert len(frames) == len(MESSAGES), name
        np.testing.assert_array_equal(frames.arbitration_id, [m.arbitration_id
                                                              for m in MESSAGES])
        np.testing.assert_array_equal(frames.data[:, :8], [list(m.data) for m in MESSAGES])
        assert report.format == fmt + (".gz" if gz else "")
        path.unlink()


suffixes = st.sampled_from(supported_suffixes())
cases = st.sampled_from(["lower", "upper", "title"])
stems = st.text(st.sampled_from("abcXYZ019-_."), min_size=1, max_size=12).filter(
    lambda s: not s.startswith(".") and not s.endswith("."))


def _cased(text: str) -> st.SearchStrategy[str]:
    return cases.map(lambda pattern: _case(text, pattern))


#: ``(name, its format, whether it is a .part)``: a stem, a suffix, maybe .gz, maybe .part,
#: each in any case.
names = st.tuples(stems, suffixes, st.booleans(), st.booleans()).flatmap(
    lambda t: st.tuples(st.just(t[0]), _cased(t[1]), _cased(".gz") if t[2] else st.just(""),
                        _cased(".part") if t[3] else st.just("")).map(
        lambda p: ("".join(p), t[1] + (".gz" if t[2] else ""), t[3], t[0])))


@settings(max_examples=200, deadline=None)
@given(case=names)
def test_the_registry_and_the_study_split_a_name_alike(case):
    name, fmt, part, stem = case
    assert log_suffix(name) == fmt
    split = log_stem(Path(name))
    assert split is not None, name
    trial, found = split
    assert trial == stem
    assert found.lower() == fmt + (".part" if part else "")
