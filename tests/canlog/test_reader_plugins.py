"""A lab's log format read through an entry point (``evtribo.log_readers``), as python-can
finds its readers: the suffix is the entry point's name, the reader is found by
:func:`evtribo.canlog.io.read_frames` and by a study's discovery, and a study recorded in it
is analysed as the same study in candump's format."""

from __future__ import annotations

import hashlib
import logging
import shutil
import sys

import pandas as pd
import pytest

from _plugins import install
from _small_study import analyse, small_study
from evtribo import study
from evtribo.canlog.cache import CACHE_VERSION, cache_key
from evtribo.canlog.io import read_frames
from evtribo.canlog.io.registry import READERS, sha256_log, supported_suffixes
from evtribo.canlog.rig import default_rig
from evtribo.store import memo
from evtribo.util import plugins

#: The lab's format: one frame a line, ``time_s id_hex payload_hex`` (``-``: none); ``#`` a
#: comment.
LAB_READER = '''
import numpy as np

from evtribo.canlog.io.table import FrameTable


def read_mylog(path, on_bad):
    times, ids, payloads, lines = [], [], [], 0
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            lines += 1
            if line.startswith("#"):
                continue
            try:
                t, can_id, data = line.split()
                times.append(float(t))
                ids.append(int(can_id, 16))
                payloads.append(b"" if data == "-" else bytes.fromhex(data))
            except ValueError as err:
                on_bad(number, f"not a frame: {err}")
    n = len(times)
    table = np.zeros((n, 8), dtype=np.uint8)
    for i, p in enumerate(payloads):
        table[i, :len(p)] = np.frombuffer(p, dtype=np.uint8)
    no = np.zeros(n, dtype=bool)
    ids = np.array(ids, dtype=np.uint32)
    return FrameTable(np.array(times, dtype=np.float64), ids, ids > 0x7FF, no, no.copy(),
                      no.copy(), np.array([len(p) for p in payloads], dtype=np.uint8),
                      table), lines
'''


@pytest.fixture(autouse=True)
def _lab_reader(tmp_path, monkeypatch):
    install(tmp_path, monkeypatch, "mylab_reader", LAB_READER,
            entry_points={"evtribo.log_readers": {".mylog": "mylab_reader:read_mylog",
                                                  ".log": "mylab_reader:read_mylog"}})
    study.log_suffixes.cache_clear()
    yield
    plugins.forget()
    study.log_suffixes.cache_clear()


def _as_mylog(log, target) -> None:
    frames, _ = read_frames(log)
    with open(target, "w", encoding="utf-8") as f:
        f.write("# mylab logger v1\n")
        for t, i, n, d in zip(frames.timestamp, frames.arbitration_id, frames.dlc, frames.data,
                              strict=True):
            f.write(f"{float(t)!r} {int(i):X} {bytes(d[:n]).hex() or '-'}\n")


def test_a_lab_s_format_is_read_by_its_suffix(tmp_path, caplog):
    log = tmp_path / "run-01.mylog"
    log.write_text("# mylab logger v1\n1.5 0C1 0102\n1.6 1ABCDEF0 ff\nbroken line here x\n",
                   encoding="utf-8")
    with caplog.at_level(logging.WARNING):
        frames, report = read_frames(log)
    assert frames.timestamp.tolist() == [1.5, 1.6]
    assert frames.arbitration_id.tolist() == [0xC1, 0x1ABCDEF0]
    assert frames.is_extended.tolist() == [False, True]
    assert frames.data[0, :2].tolist() == [1, 2] and frames.dlc.tolist() == [2, 1]
    assert report.format == ".mylog" and report.skipped_lines == 1
    assert f"{log}:4: skipped damaged line" in caplog.text
    assert ".mylog" in supported_suffixes() and ".mylog.gz" in study.log_suffixes()


def test_a_suffix_evtribo_reads_stays_evtribo_s(caplog):
    with caplog.at_level(logging.WARNING, logger="evtribo.util.plugins"):
        assert READERS[".log"].__module__ == "evtribo.canlog.io.candump"
        assert ".mylog" in READERS
    assert "log reader '.log' is registered already" in caplog.text


def test_a_study_recorded_in_a_lab_s_format_is_analysed_as_in_candump_s(tmp_path):
    plain = small_study(tmp_path / "plain")
    lab = tmp_path / "lab"
    shutil.copytree(plain, lab)
    for log in sorted(lab.glob("P*/run-*.log")):
        _as_mylog(log, log.with_suffix(".mylog"))
        log.unlink()
    assert not list(lab.glob("P*/*.log")) and len(list(lab.glob("P*/*.mylog"))) == 9
    mine = pd.read_csv(analyse(lab, tmp_path / "out-lab") / "electrostatic.csv")
    theirs = pd.read_csv(analyse(plain, tmp_path / "out-plain") / "electrostatic.csv")
    assert len(mine) == 9
    pd.testing.assert_frame_equal(mine, theirs)


def test_a_decoded_trial_is_kept_under_the_plug_ins_that_read_it(tmp_path, monkeypatch):
    """A lab's reader decodes a log as evtribo's own readers do: its distribution (name,
    version, where) is in the key of the decoded trial, so that a new version of it reads
    the log again; without plug-ins the key is the one evtribo always gave."""
    log = tmp_path / "run-01.log"
    log.write_text("(1.000000) vcan0 0C1#00\n", encoding="utf-8")
    rig = default_rig()
    memo.plugin_distributions.cache_clear()
    plugged = cache_key(log, rig)
    assert any("mylab_plugin-1.0.dist-info" in p for p in memo.plugin_distributions())
    monkeypatch.setattr(sys, "path", [p for p in sys.path if "mylab_plugin" not in p
                                      and not p.startswith(str(tmp_path))])
    memo.plugin_distributions.cache_clear()
    alone = cache_key(log, rig)
    memo.plugin_distributions.cache_clear()
    assert plugged != alone
    assert alone == hashlib.sha256(b"v%d" % CACHE_VERSION + sha256_log(log).encode()
                                   + rig.fingerprint().encode()).hexdigest()[:40]
