"""``evtribo analyze`` of an unchanged study writes the last analysis' results again, without
importing the analysis; any change (an input's bytes, a file added, an option, a damaged
entry) and the study is analysed as usual.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import evtribo
from evtribo.acquisition.simulator import TrialConfig, default_subjects, simulate_study
from evtribo.cli import main
from evtribo.errors import OutputExistsError
from evtribo.results import unchanged
from evtribo.store import memo

TABLES = ("trials.csv", "windows.csv", "electrostatic.csv", "exponents.csv",
          "electrostatic_bootstrap.csv", "sine_trace.csv")
#: summary.json's keys that differ from one run to the next.
VOLATILE = {"run_id", "created", "started", "elapsed_s"}
OPTIONS = {"set": [], "strict": False, "tare": None, "guard_s": None, "confidence": None,
           "n_boot": None, "seed": None}


@pytest.fixture
def study(tmp_path):
    root = tmp_path / "study"
    simulate_study(root, default_subjects(2), amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=4.0), sine_trial=True, realistic=True)
    return root


def _summary(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


def _tables(out: Path) -> dict[str, bytes]:
    return {name: (out / name).read_bytes() for name in TABLES if (out / name).exists()}


# the command the tests run, in a fresh interpreter: which heavy modules it imported
_PROBE = """
import sys
from evtribo.cli import main
code = main(sys.argv[1:])
print({m: m in sys.modules for m in ("numpy", "pandas", "scipy", "cantools", "can",
                                     "importlib.metadata")})
sys.exit(code)
"""


def _analyze(*args: str) -> tuple[int, dict[str, bool], str]:
    proc = subprocess.run([sys.executable, "-c", _PROBE, "analyze", *args],
                          capture_output=True, text=True, check=False)
    imported = eval(proc.stdout.strip().splitlines()[-1])  # the dict printed last
    return proc.returncode, imported, proc.stderr


def test_an_unchanged_study_is_written_again_without_the_analysis(study, tmp_path):
    """The second run imports none of numpy, pandas, scipy, cantools, python-can or
    importlib.metadata (the libraries are followed by their metadata folders); its tables
    are the first run's byte for byte, and its summary.json is a full analysis' but for the
    run's own id, times and jobs; the warnings are said again, each kind once."""
    cache = tmp_path / "cache"
    code, first_imports, _ = _analyze(str(study), "--out", str(tmp_path / "a"),
                                      "--cache-dir", str(cache))
    assert code == 0 and first_imports["pandas"]
    code, imports, err = _analyze(str(study), "--out", str(tmp_path / "b"),
                                  "--cache-dir", str(cache))
    assert code == 0
    assert not any(imports.values()), imports
    assert _tables(tmp_path / "b") == _tables(tmp_path / "a")
    assert "sine_trace.csv" in _tables(tmp_path / "b")
    # a full analysis in which every trial's outcome is reused (the entry removed)
    shutil.rmtree(cache / unchanged.ENTRIES)
    assert main(["analyze", str(study), "--out", str(tmp_path / "c"),
                 "--cache-dir", str(cache)]) == 0
    full, again = _summary(tmp_path / "c"), _summary(tmp_path / "b")
    assert list(full) == list(again)
    assert {k for k in full if full[k] != again[k]} <= VOLATILE
    assert again["run_id"] != full["run_id"] and again["jobs"] == 1
    assert again["output_sha256"] == full["output_sha256"]
    from evtribo.documents.summary import Summary
    from evtribo.warning.render import group

    for said in group(Summary(again).warnings):
        assert f"] {said.title}: " in err  # each kind said again, once


def _remembered(study: Path, tmp_path: Path, options=OPTIONS) -> Path:
    cache = tmp_path / "cache"
    assert main(["analyze", str(study), "--out", str(tmp_path / "first"),
                 "--cache-dir", str(cache)]) == 0
    assert unchanged.rerun(study, tmp_path / "again", options=options,
                           cache_dir=cache) is not None
    return cache


@pytest.mark.parametrize("change", ["sidecar", "log", "new file", "removed file", "option",
                                    "strict", "study.toml"])
def test_any_change_analyses_the_study(study, tmp_path, change):
    cache = _remembered(study, tmp_path)
    options = dict(OPTIONS)
    sidecar = sorted(study.glob("*/*.json"))[0]
    if change == "sidecar":
        sidecar.write_text(sidecar.read_text() + " ")
    elif change == "log":
        log = sorted(study.glob("*/*.log"))[0]
        data = bytearray(log.read_bytes())
        data[-3] = ord("0") if data[-3] != ord("0") else ord("1")  # same size, new bytes
        log.write_bytes(bytes(data))
    elif change == "new file":
        (sidecar.parent / "notes.txt").write_text("a note")
    elif change == "removed file":
        sidecar.unlink()
    elif change == "option":
        options["set"] = ["min_window_s=0.3"]
    elif change == "strict":
        options["strict"] = True
    else:
        (study / "study.toml").write_text((study / "study.toml").read_text() + "\n")
    out = tmp_path / "changed"
    assert unchanged.rerun(study, out, options=options, cache_dir=cache) is None
    assert not out.exists()  # nothing written: the analysis will write it


def test_a_damaged_entry_is_removed_and_the_study_analysed(study, tmp_path, caplog):
    cache = _remembered(study, tmp_path)
    [entry] = (cache / unchanged.ENTRIES).iterdir()
    entry.write_bytes(entry.read_bytes()[:-10])
    assert unchanged.rerun(study, tmp_path / "out", options=OPTIONS, cache_dir=cache) is None
    assert not entry.exists() and "damaged entry" in caplog.text


def test_existing_results_are_kept_without_force(study, tmp_path):
    cache = _remembered(study, tmp_path)
    before = _tables(tmp_path / "again")
    with pytest.raises(OutputExistsError):
        unchanged.rerun(study, tmp_path / "again", options=OPTIONS, cache_dir=cache)
    assert _tables(tmp_path / "again") == before
    assert main(["analyze", str(study), "--out", str(tmp_path / "again"),
                 "--cache-dir", str(cache)]) == 2
    assert unchanged.rerun(study, tmp_path / "again", options=OPTIONS, cache_dir=cache,
                           force=True) is not None


def test_recompute_analyses_an_unchanged_study(study, tmp_path, monkeypatch):
    cache = _remembered(study, tmp_path)
    called = []
    monkeypatch.setattr(unchanged, "rerun", lambda *a, **k: called.append(a))
    assert main(["analyze", str(study), "--out", str(tmp_path / "r"), "--cache-dir",
                 str(cache), "--recompute"]) == 0
    assert not called
    assert _summary(tmp_path / "r")["jobs"] >= 1


def test_a_study_with_a_failed_trial_is_always_analysed(study, tmp_path):
    """A trial's failure is not kept (it may not happen again: a log being copied)."""
    log = sorted(study.glob("*/*.log"))[0]
    log.write_text("garbage\n")
    cache = tmp_path / "cache"
    assert main(["analyze", str(study), "--out", str(tmp_path / "first"),
                 "--cache-dir", str(cache)]) == 0
    assert _summary(tmp_path / "first")["failed_trials"]
    assert not (cache / unchanged.ENTRIES).exists()
    assert unchanged.rerun(study, tmp_path / "again", options=OPTIONS, cache_dir=cache) is None


def test_the_software_fingerprint_follows_the_libraries_metadata_folders(tmp_path,
                                                                         monkeypatch):
    """Another version of a library the analysis runs on, found first on sys.path, is
    another software (so another key for every kept result); a folder that holds no
    library's metadata is not."""
    before = memo.software_fingerprint()
    memo.software_fingerprint.cache_clear()
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "unrelated-1.0.dist-info").mkdir()
    monkeypatch.syspath_prepend(str(tmp_path / "other"))
    assert memo.software_fingerprint() == before
    memo.software_fingerprint.cache_clear()
    (tmp_path / "numpy-0.0.1.dist-info").mkdir()
    monkeypatch.syspath_prepend(str(tmp_path))
    assert memo.software_fingerprint() != before
    memo.software_fingerprint.cache_clear()


def test_the_software_fingerprint_follows_every_source_file_of_evtribo(monkeypatch):
    """The analysis's code, not only the store's: a change to any module of evtribo (a
    checkout pulled, the version unchanged) is another software."""
    hashed = []
    monkeypatch.setattr(memo, "tree_digest", lambda folder: hashed.append(folder) or "")
    memo.software_fingerprint.cache_clear()
    memo.software_fingerprint()
    memo.software_fingerprint.cache_clear()
    assert hashed == [Path(evtribo.__file__).resolve().parent]


def test_a_trial_recorded_while_analyze_runs_is_analysed_next_time(study, tmp_path,
                                                                   monkeypatch, capsys):
    """The study's listing that keys the kept results is the one taken before the analysis:
    a trial recorded meanwhile (a session still recording) is not filed as already seen."""
    from evtribo.acquisition.simulator import SubjectParams, write_trial
    from evtribo.results import pipeline

    cache = tmp_path / "cache"
    real = pipeline.analyze_study
    recorded = []

    def recording_meanwhile(*args, **kwargs):
        result = real(*args, **kwargs)
        if not recorded:  # a trial lands while the analysis is finishing
            write_trial(study, "run-99", SubjectParams(name="P01"),
                        TrialConfig(duration_s=4.0, amplitude_V=100.0))
            recorded.append(True)
        return result

    monkeypatch.setattr(pipeline, "analyze_study", recording_meanwhile)
    before = len(list(study.glob("*/*.log")))
    args = [str(study), "--cache-dir", str(cache), "--force"]
    assert main(["analyze", *args, "--out", str(tmp_path / "a")]) == 0
    assert f"analysed {before} of {before} trials" in capsys.readouterr().out
    assert main(["analyze", *args, "--out", str(tmp_path / "b")]) == 0
    assert f"of {before + 1} trials" in capsys.readouterr().out
    assert "P01/run-99" in (tmp_path / "b" / "trials.csv").read_text().replace(",", "/")


def test_an_unchanged_comparison_is_said_without_the_libraries(study, tmp_path):
    """compare again on results, options and software unchanged writes nothing and imports
    none of numpy, pandas, scipy, matplotlib, cantools or python-can (it reads fit.json and
    the files' hashes alone)."""
    out = tmp_path / "out"
    cache = ["--cache-dir", str(tmp_path / "cache")]
    assert main(["analyze", str(study), "--out", str(out), *cache]) == 0
    assert main(["compare", str(out), *cache]) == 0
    proc = subprocess.run([sys.executable, "-c", _PROBE.replace('"importlib.metadata"',
                                                                '"matplotlib"'),
                           "compare", str(out), "--force", *cache],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    assert "nothing written" in proc.stdout
    imported = eval(proc.stdout.strip().splitlines()[-1])  # the dict printed last
    assert not any(imported.values()), imported
