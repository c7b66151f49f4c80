"""A second analysis takes from the cache what the first one did, and only that.

- an input unchanged since it was hashed (size, times, inode; its change time settled
  before the hashing) is not read again; one whose bytes changed is, whatever its mtime says;
- a trial's outcome is reused while its log, sidecar, rig, settings and evtribo's source
  are those it was computed with, and the tables are then byte for byte those of a run that
  analyses every trial; change any of these and that trial (only) is analysed again;
- a damaged kept outcome is said, removed and computed again.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import os
import shutil
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from _faults import fail_trial
from evtribo.acquisition.simulator import (
    SubjectParams,
    TrialConfig,
    default_subjects,
    simulate_study,
)
from evtribo.results import pipeline, provenance, reuse
from evtribo.results import workers as trial_workers
from evtribo.store import memo as hash_memo
from evtribo.study import load_study

TABLES = ("trials.csv", "windows.csv", "electrostatic.csv", "exponents.csv",
          "electrostatic_bootstrap.csv")


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("reuse") / "study"
    simulate_study(root, default_subjects(2),
                   amplitudes=(80.0, 140.0), config=TrialConfig(duration_s=5.0),
                   sine_trial=True, realistic=True)
    return root


def _counting(monkeypatch) -> list[str]:
    """The trials analysed (not reused) from now on, in this process."""
    analysed: list[str] = []
    real = trial_workers.analyze_signals

    def counted(signals, meta, **kw):
        analysed.append(f"{meta.subject}/{meta.trial}")
        return real(signals, meta, **kw)
    monkeypatch.setattr(trial_workers, "analyze_signals", counted)
    return analysed


def _tables(out: Path) -> dict[str, bytes]:
    return {name: (out / name).read_bytes() for name in TABLES if (out / name).exists()}


def _run(study: Path, out: Path, cache: Path, **kw):
    return pipeline.analyze_study(study, out, jobs=1, cache_dir=cache, force=True, **kw)


def test_kept_outcomes_give_the_tables_of_a_full_analysis_and_only_changes_are_redone(
        study, tmp_path, monkeypatch, caplog):
    root = tmp_path / "study"
    shutil.copytree(study, root)
    cache = tmp_path / "cache"
    analysed = _counting(monkeypatch)
    _run(root, tmp_path / "first", cache)
    everything = sorted(analysed)
    assert len(everything) == 6  # 2 subjects x (2 amplitudes, OFF, sine)
    analysed.clear()
    caplog.clear()
    res = _run(root, tmp_path / "again", cache)
    assert analysed == []
    assert _tables(tmp_path / "again") == _tables(tmp_path / "first")
    # the trials' warnings are said again, and recorded, as when they were analysed
    first = json.loads((tmp_path / "first" / "summary.json").read_text())["warnings"]
    assert res.summary["warnings"] == first and first
    assert all(w["text"] in caplog.text for w in first if w["subject"])
    # --recompute: every trial again, the same tables
    _run(root, tmp_path / "recomputed", cache, reuse=False)
    assert sorted(analysed) == everything
    assert _tables(tmp_path / "recomputed") == _tables(tmp_path / "first")
    # a sidecar changed: that trial only
    analysed.clear()
    sidecar = next(root.glob("P02/*.json"))
    doc = json.loads(sidecar.read_text())
    doc["notes"] = "re-read after the session"
    sidecar.write_text(json.dumps(doc))
    _run(root, tmp_path / "sidecar", cache)
    assert analysed == [f"P02/{sidecar.stem}"]
    # a setting changed: every trial
    analysed.clear()
    _run(root, tmp_path / "guard", cache, overrides={"guard_s": 0.07})
    assert sorted(analysed) == everything
    # a log changed (one damaged line more): that trial only, and its warning is new
    analysed.clear()
    log = root / "P01" / "run-01.log"
    with log.open("a") as fh:
        fh.write("this is not a candump line\n")
    res = _run(root, tmp_path / "log", cache)
    assert analysed == ["P01/run-01"]
    assert any("damaged line" in w["text"] for w in res.summary["warnings"])


def test_another_rig_calibration_or_strictness_is_another_analysis(study, tmp_path,
                                                                   monkeypatch):
    root = tmp_path / "study"
    shutil.copytree(study, root)
    cache = tmp_path / "cache"
    analysed = _counting(monkeypatch)
    _run(root, tmp_path / "a", cache)
    analysed.clear()
    _run(root, tmp_path / "strict", cache, strict=True)
    assert len(analysed) == 6
    analysed.clear()
    toml = root / "study.toml"
    toml.write_text(toml.read_text() + "\n[rig.calibration]\nnormal_offset_N = 0.01\n")
    _run(root, tmp_path / "calibrated", cache)
    assert len(analysed) == 6


def test_a_damaged_kept_outcome_is_said_removed_and_computed_again(study, tmp_path,
                                                                   monkeypatch, caplog):
    cache = tmp_path / "cache"
    _run(study, tmp_path / "a", cache)
    kept = sorted((cache / "results").glob("*.json"))
    assert len(kept) == 6
    data = bytearray(kept[0].read_bytes())
    data[len(data) // 2] ^= 0x04
    kept[0].write_bytes(bytes(data))
    analysed = _counting(monkeypatch)
    caplog.clear()
    _run(study, tmp_path / "b", cache)
    assert len(analysed) == 1
    assert "damaged kept outcome" in caplog.text
    assert _tables(tmp_path / "b") == _tables(tmp_path / "a")
    assert len(list((cache / "results").glob("*.json"))) == 6


def test_a_failed_trial_is_not_kept(tmp_path, monkeypatch):
    root = tmp_path / "study"
    simulate_study(root, [SubjectParams(name="P01")], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=4.0), sine_trial=False)
    fail_trial(monkeypatch, "run-02")
    res = _run(root, tmp_path / "a", tmp_path / "cache")
    assert res.summary["trials_analysed"] == 1
    monkeypatch.undo()
    res = _run(root, tmp_path / "b", tmp_path / "cache")
    assert res.summary["trials_analysed"] == 2


# --- the inputs' hashes -------------------------------------------------------------------

def _memo_counting(monkeypatch) -> list[str]:
    hashed: list[str] = []
    real = hash_memo.sha256_file

    def counted(path):
        hashed.append(os.fspath(path))
        return real(path)
    monkeypatch.setattr(hash_memo, "sha256_file", counted)
    return hashed


def _age(path: Path, seconds: float) -> None:
    """Make *path* look hashed *seconds* after its last change (the memo's clock moved)."""
    memo = json.loads(path.read_text())
    for rec in memo["files"].values():
        rec["hashed_ns"] += int(seconds * 1e9)
    path.write_text(json.dumps(memo))


def test_an_input_unchanged_since_it_was_hashed_is_not_read_again(tmp_path, monkeypatch):
    hashed = _memo_counting(monkeypatch)
    f = tmp_path / "a.log"
    f.write_bytes(b"(1.0) can0 123#00\n" * 100)
    memo = hash_memo.HashMemo(tmp_path / "cache", tmp_path)
    digest, _ = memo.sha256(f)
    memo.save()
    assert hashed == [str(f)]
    # hashed just after it was written: hashed again (it could still change in that tick)
    again = hash_memo.HashMemo(tmp_path / "cache", tmp_path)
    assert again.sha256(f)[0] == digest and len(hashed) == 2
    again.save()
    _age(again.path, hash_memo.SETTLED_S + 1)
    settled = hash_memo.HashMemo(tmp_path / "cache", tmp_path)
    assert settled.sha256(f)[0] == digest and len(hashed) == 2


def test_changed_bytes_are_hashed_again_even_under_the_same_size_and_mtime(tmp_path,
                                                                          monkeypatch):
    hashed = _memo_counting(monkeypatch)
    f = tmp_path / "a.log"
    f.write_bytes(b"A" * 1000)
    st = f.stat()
    memo = hash_memo.HashMemo(tmp_path / "cache", tmp_path)
    memo.sha256(f)
    memo.save()
    _age(memo.path, hash_memo.SETTLED_S + 1)
    time.sleep(0.01)
    f.write_bytes(b"B" * 1000)
    os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns))  # size and mtime as they were
    assert (f.stat().st_size, f.stat().st_mtime_ns) == (st.st_size, st.st_mtime_ns)
    fresh = hash_memo.HashMemo(tmp_path / "cache", tmp_path)
    digest, _ = fresh.sha256(f)
    assert len(hashed) == 2
    import hashlib
    assert digest == hashlib.sha256(b"B" * 1000).hexdigest()


def test_the_memo_is_a_cache_not_a_requirement(tmp_path):
    f = tmp_path / "a.log"
    f.write_bytes(b"x")
    (tmp_path / "file").write_text("")
    memo = hash_memo.HashMemo(tmp_path / "file" / "cache", tmp_path)  # cannot be written
    memo.sha256(f)
    memo.save()
    nothing = hash_memo.HashMemo(None, tmp_path)
    assert nothing.sha256(f)[0] == memo.sha256(f)[0]
    bad = hash_memo.HashMemo(tmp_path / "cache", tmp_path)
    assert bad.path is not None
    bad.path.parent.mkdir(parents=True)
    for junk in ("{not json", '{"version": 1, "files": [1, 2]}',
                 json.dumps({"version": 1, "files": {str(f): 3}})):
        bad.path.write_text(junk)
        assert hash_memo.HashMemo(tmp_path / "cache", tmp_path).sha256(f)[0] == memo.sha256(f)[0]


def test_the_source_fingerprint_follows_every_source_file(tmp_path):
    tree = tmp_path / "pkg"
    (tree / "sub").mkdir(parents=True)
    (tree / "a.py").write_text("x = 1\n")
    (tree / "sub" / "b.py").write_text("y = 2\n")
    first = hash_memo.tree_digest(tree)
    assert hash_memo.tree_digest(tree) == first
    (tree / "sub" / "b.py").write_text("y = 3\n")
    assert hash_memo.tree_digest(tree) != first
    (tree / "sub" / "b.py").write_text("y = 2\n")
    assert hash_memo.tree_digest(tree) == first
    (tree / "c.py").write_text("")
    assert hash_memo.tree_digest(tree) != first


def test_the_python_api_reuses_and_recomputes_as_the_command_does(study, tmp_path,
                                                                  monkeypatch):
    import evtribo

    cache = tmp_path / "cache"
    analysed = _counting(monkeypatch)
    first = evtribo.analyze(study, jobs=1, cache_dir=cache)
    assert len(analysed) == 6
    analysed.clear()
    again = evtribo.analyze(study, jobs=1, cache_dir=cache)
    assert analysed == []
    evtribo.analyze(study, jobs=1, cache_dir=cache, recompute=True)
    assert len(analysed) == 6
    assert again.electrostatic.equals(first.electrostatic)


@pytest.mark.parametrize("fork", [True, False], ids=["process", "thread"])
def test_inputs_hashed_ahead_are_those_the_analysis_reads(study, tmp_path, monkeypatch, fork):
    """prehash (run by the command line while it imports the analysis) hashes exactly the
    study's inputs into the memo: an analysis after it hashes none of them again; and
    stopped at once it leaves them to the analysis, with the same results. In a forked
    process, or a thread where there is no fork."""
    if not fork:
        import multiprocessing

        def no_fork(method=None):
            raise ValueError(f"cannot find context for {method!r}")

        monkeypatch.setattr(multiprocessing, "get_context", no_fork)
    cache = tmp_path / "cache"
    ahead = hash_memo.prehash(study, cache)
    ahead.join()
    memo_file = hash_memo.HashMemo(cache, study).path
    _age(memo_file, hash_memo.SETTLED_S + 1)
    hashed = _memo_counting(monkeypatch)
    first = _run(study, tmp_path / "a", cache)
    assert hashed == []
    inputs = provenance.input_files(load_study(study))
    assert set(json.loads(memo_file.read_text())["files"]) == {r["_path"] for r in inputs}
    assert not ahead.is_alive()
    stopped = hash_memo.prehash(study, tmp_path / "cache2")
    stopped.finish()
    assert not stopped.is_alive()
    second = _run(study, tmp_path / "b", tmp_path / "cache2")
    assert second.summary["inputs"] == first.summary["inputs"]


def test_hashing_ahead_never_fails_the_analysis(tmp_path):
    (tmp_path / "file").write_text("")
    broken = hash_memo.prehash(tmp_path / "no-study", tmp_path / "file" / "cache")
    broken.finish()  # no study, a cache that cannot be written: nothing raised
    assert not broken.is_alive()


@dataclasses.dataclass(frozen=True)
class _Part:
    name: str
    extra: dict
    note: str = dataclasses.field(default="", compare=False)


@settings(max_examples=100, deadline=None)
@given(st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False)
                    | st.text(max_size=5),
                    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(
                        st.text(max_size=3) | st.integers() | st.tuples(st.integers()),
                        inner, max_size=3), max_leaves=12),
       st.text(max_size=3))
def test_the_context_text_tells_values_apart(extra, note):
    """The text a kept outcome's key is made from: the same for equal values (a compared
    field only), different when any nested value differs, whatever the keys (tuples too,
    which JSON cannot hold)."""
    text = reuse.context_text(part=_Part("a", {"x": extra}, note))
    assert text == reuse.context_text(part=_Part("a", {"x": copy.deepcopy(extra)}, "other"))
    assert text != reuse.context_text(part=_Part("a", {"x": [extra]}))
    assert text != reuse.context_text(part=_Part("b", {"x": extra}))
    assert json.loads(text)["part"]["name"] == "a"
