"""The result folder is one unit (study-format §5): ``analyze``, ``compare`` and ``report``
never leave a mix of two analyses, a half-written file, or a fit of data no longer there.

- ``analyze --force`` replaces compare's and report's files too (their files only);
- ``report`` refuses a fit of another analysis, and warns when an input changed since;
- ``--out`` inside the study is refused;
- killed at random moments (SIGKILL), stopped (SIGTERM) or starved of disk, each command
  leaves OUT with the results it had or all of the new ones, and no worker behind;
- a second process writing the same OUT is refused, naming the first.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import time
from pathlib import Path

import pytest

from _forked import alive, children, file_size_limit, run, run_id, start, tree
from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.cli import main
from evtribo.results import workers as trial_workers
from evtribo.store.owned import MANIFEST
from evtribo.store.resultdir import holder, lock_path, locked, pending, recover


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("result-folder") / "study"
    simulate_study(root, [SubjectParams(name="P01")], amplitudes=(80.0, 140.0),
                   config=TrialConfig(duration_s=6.0), sine_trial=False)
    return root


def _analyze(study, out, *more):
    return ["analyze", str(study), "--out", str(out), "--jobs", "1", *more]


@pytest.fixture(scope="module")
def complete(study, tmp_path_factory):
    """A result folder with an analysis, its fit, a report in it, and a user's files."""
    out = tmp_path_factory.mktemp("complete") / "out"
    assert main(_analyze(study, out)) == 0
    assert main(["compare", str(out), "--dpi", "30"]) == 0
    assert main(["report", str(out)]) == 0
    (out / "notes.txt").write_text("my notes\n")
    (out / "figures" / "my-sketch.png").write_bytes(b"not evtribo's")
    (out / "my-page.html").write_text("<html><body>mine</body></html>\n")
    return out


USER_FILES = {"notes.txt", "figures/my-sketch.png", "my-page.html"}


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst, symlinks=True)
    return dst


def _new_results(out: Path, old_run: str) -> None:
    """*out* holds a complete analysis other than *old_run*, no fit and no report, and the
    user's files."""
    from evtribo.fit.tables import check_analysis

    files = set(tree(out))
    assert not files & {"fit.csv", "fit.json", "report.html"}, "a fit or report left behind"
    assert not [f for f in files if f.startswith(("figures/", "report_files/"))
                and f not in USER_FILES], "figures left behind"
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert summary["run_id"] != old_run
    check_analysis(out, summary)  # every table as that analysis wrote it
    assert files == {*summary["output_sha256"], "summary.json", MANIFEST, *USER_FILES}


# --- item 4: analyze --force replaces the fit and the report; report checks the fit ---------

def test_force_replaces_the_fit_and_report_of_the_results_it_replaces(study, complete,
                                                                       tmp_path):
    out = _copy(complete, tmp_path / "out")
    before = tree(out)
    assert {"fit.csv", "fit.json", "report.html"} <= set(before)
    assert main(_analyze(study, out)) == 2  # without --force: nothing changes
    assert tree(out) == before
    assert main(_analyze(study, out, "--force")) == 0
    _new_results(out, run_id(complete))
    for name in USER_FILES:
        assert tree(out)[name] == before[name]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # nothing left beside it


def test_report_refuses_a_fit_of_another_analysis(study, complete, tmp_path, capsys):
    out = _copy(complete, tmp_path / "out")
    old_fit = {n: (out / n).read_bytes() for n in ("fit.csv", "fit.json")}
    figures = _copy(out / "figures", tmp_path / "old-figures")
    assert main(_analyze(study, out, "--force", "--set", "seed=3")) == 0
    for name, data in old_fit.items():  # the old fit back beside the new forces
        (out / name).write_bytes(data)
    shutil.copytree(figures, out / "figures", dirs_exist_ok=True)
    capsys.readouterr()
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 2
    err = capsys.readouterr().err
    assert f"evtribo compare {out} --force" in err and "fit.json" in err
    assert "another analysis" in err and "Traceback" not in err
    assert not (tmp_path / "r.html").exists()
    assert main(["compare", str(out), "--force", "--dpi", "30"]) == 0
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 0
    fit = json.loads((out / "fit.json").read_text())
    assert fit["run_id"] == run_id(out)


def test_report_warns_when_a_study_input_changed_since_the_analysis(study, tmp_path):
    root = _copy(study, tmp_path / "study")
    out = tmp_path / "out"
    assert main(_analyze(root, out)) == 0
    assert main(["compare", str(out), "--dpi", "30"]) == 0
    sidecar = root / "P01" / "run-02.json"
    sidecar.write_text(sidecar.read_text().replace('"notes": ""', '"notes": "edited"'))
    with (root / "P01" / "run-01.log").open("a") as fh:
        fh.write("(1763700099.000000) vcan0 7FF#00\n")
    shutil.copy(root / "P01" / "run-02.log", root / "P01" / "run-09.log")
    report = tmp_path / "r.html"
    assert main(["report", str(out), "-o", str(report)]) == 0
    html = report.read_text()
    assert "P01/run-01.log: changed since the analysis" in html
    assert "P01/run-02.json: changed since the analysis" in html
    assert "P01/run-09.log: in the study folder but not in the analysis" in html
    assert "P01/run-02.log: changed" not in html


# --- item 7: --out inside the study ---------------------------------------------------------

@pytest.mark.parametrize("inside", ["results", "P01", ".", "P01/deeper/results"])
def test_out_inside_the_study_is_refused(study, inside, tmp_path, capsys):
    root = _copy(study, tmp_path / "study")
    before = tree(root)
    assert main(_analyze(root, root / inside, "--force")) == 2
    err = capsys.readouterr().err
    assert "inside the study folder" in err and "--out" in err
    assert tree(root) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study"]


# --- item 5: one writer at a time --------------------------------------------------------------

def _slow_analysis(release):
    def setup():
        real = trial_workers.analyze_signals

        def slow(*args, **kwargs):
            release.wait(60)
            return real(*args, **kwargs)
        trial_workers.analyze_signals = slow
    return setup


def test_a_second_writer_of_the_same_out_is_refused_naming_the_first(study, complete,
                                                                     tmp_path, capsys):
    from _forked import FORK

    out = _copy(complete, tmp_path / "out")
    release = FORK.Event()
    first = start(_analyze(study, out, "--force", "--recompute"), tmp_path / "first.log",
                  _slow_analysis(release))
    try:
        deadline = time.monotonic() + 60
        while (holder(out) or {}).get("pid") != first.pid:
            assert time.monotonic() < deadline and first.is_alive()
            time.sleep(0.02)
        before = tree(out)
        for argv in (_analyze(study, out, "--force"), ["compare", str(out), "--force"],
                     ["report", str(out), "-o", str(tmp_path / "r.html")]):
            capsys.readouterr()
            assert main(argv) == 2, argv
            err = capsys.readouterr().err
            assert f"being written by process {first.pid} (evtribo analyze" in err, err
            assert tree(out) == before
    finally:
        release.set()
        first.join(60)
    assert first.exitcode == 0, (tmp_path / "first.log").read_text()
    _new_results(out, run_id(complete))
    assert not lock_path(out).exists()


def test_a_stale_lock_of_a_dead_process_is_cleared(study, complete, tmp_path):
    from _forked import FORK

    out = _copy(complete, tmp_path / "out")
    dead = FORK.Process(target=os._exit, args=(0,))  # a process that has ended
    dead.start()
    dead.join()
    lock_path(out).write_text(json.dumps({"pid": dead.pid, "command": "evtribo analyze"}))
    assert main(_analyze(study, out, "--force")) == 0
    assert not lock_path(out).exists()


# --- item 5: killed at random moments -------------------------------------------------------

def _slow_commit():
    """Each file-system step of the swap takes a little longer, so that random kill times
    land in it too (the analysis itself takes a fraction of a second here)."""
    import evtribo.store.resultdir as rd

    real_replace, real_fsync = os.replace, os.fsync

    def replace(*args, **kwargs):
        time.sleep(0.01)
        return real_replace(*args, **kwargs)

    def fsync(fd):
        time.sleep(0.005)
        return real_fsync(fd)
    rd.os.replace, rd.os.fsync = replace, fsync


def _outcome(out: Path, old: dict[str, bytes], old_run: str) -> str:
    if pending(out):  # killed mid-swap: the next command finishes it
        with locked(out, "test"):
            recover(out)
        _new_results(out, old_run)
        return "finished"
    if tree(out) == old:
        return "old"
    _new_results(out, old_run)
    return "new"


def test_analyze_killed_at_random_moments_leaves_the_old_or_the_new_results(
        study, complete, tmp_path):
    pristine = complete
    old, old_run = tree(pristine), run_id(pristine)
    argv = [*_analyze(study, tmp_path / "out", "--force", "--set", "seed=5")]
    _copy(pristine, tmp_path / "out")
    t0 = time.monotonic()
    code, log = run(argv, tmp_path / "timing.log", _slow_commit)
    duration = time.monotonic() - t0
    assert code == 0, log
    rng = random.Random()
    seed = rng.randrange(10**6)
    rng.seed(seed)
    outcomes = []
    for k in range(8):
        shutil.rmtree(tmp_path / "out")
        _copy(pristine, tmp_path / "out")
        proc = start(argv, tmp_path / f"kill-{k}.log", _slow_commit)
        time.sleep(duration * (k + rng.random()) / 8)  # spread over the whole run
        os.kill(proc.pid, signal.SIGKILL)
        proc.join(30)
        outcomes.append(_outcome(tmp_path / "out", old, old_run))
    # the next command on OUT clears what killed runs left beside it
    assert main(_analyze(study, tmp_path / "out", "--force")) == 0
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".log")) == \
        ["out"], (seed, outcomes)


def _compare_outcome(out: Path, old: dict[str, bytes]) -> str:
    from evtribo.documents.result_folder import ResultFolder
    from evtribo.report.study_report import _fit_doc

    if pending(out):
        with locked(out, "test"):
            recover(out)
    now = tree(out)
    if now == old:
        return "old"
    doc = _fit_doc(ResultFolder.open(out))  # fit.json of this analysis, its files as written
    fit_files = {f for f in now if f in ("fit.csv", "fit.json") or (
        f.startswith("figures/") and f not in USER_FILES)}
    assert fit_files == {*doc.output_sha256, "fit.json"}
    ours = {*fit_files, ".evtribo-manifest.json"}  # the manifest lists the new files
    assert {k: v for k, v in now.items() if k not in ours} == \
        {k: v for k, v in old.items() if k not in ours}  # nothing else touched
    return "new"


def _report_outcome(out: Path, old: dict[str, bytes]) -> str:
    if pending(out):  # the report in OUT is written as part of OUT
        with locked(out, "test"):
            recover(out)
    now = tree(out)
    if now == old:
        return "old"
    assert set(now) == set(old)  # the same files, each whole
    assert now["report.html"].rstrip().endswith(b"</html>")
    for name, data in now.items():
        if name.startswith("report_files/"):
            assert data.endswith(b"IEND\xaeB`\x82" if name.endswith(".png") else b"</svg>\n")
    return "new"


@pytest.mark.slow
@pytest.mark.parametrize("command", ["compare", "report"])
def test_compare_and_report_killed_at_random_moments_leave_old_or_new_files(
        complete, tmp_path, command):
    out = tmp_path / "out"
    # compare at another resolution than the folder's: its figures are written again (with
    # nothing changed it would write nothing)
    argv = [command, str(out), "--force"] + (["--dpi", "31"] if command == "compare" else [])
    _copy(complete, out)
    t0 = time.monotonic()
    code, log = run(argv, tmp_path / "timing.log", _slow_commit)
    duration = time.monotonic() - t0
    assert code == 0, log
    rng = random.Random()
    outcomes = []
    for k in range(5):
        shutil.rmtree(out)
        _copy(complete, out)
        old = tree(out)
        proc = start(argv, tmp_path / f"kill-{k}.log", _slow_commit)
        time.sleep(duration * (k + rng.random()) / 5)
        os.kill(proc.pid, signal.SIGKILL)
        proc.join(30)
        check = _compare_outcome if command == "compare" else _report_outcome
        outcomes.append(check(out, old))
    assert main([command, str(out), "--force"]) == 0, outcomes
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".log")) == \
        ["out"], outcomes


@pytest.mark.parametrize("limit", [300, 1000, 10_000])
def test_analyze_on_a_full_disk_leaves_the_old_results(study, complete, tmp_path, limit):
    out = _copy(complete, tmp_path / "out")
    before = tree(out)
    code, log = run(_analyze(study, out, "--force"), tmp_path / "full.log",
                    file_size_limit(limit))
    assert tree(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full.log", "out"]
    assert code == 1, log
    assert "cannot write the results (File too large)" in log and "left as it was" in log
    assert "Traceback" not in log


@pytest.mark.parametrize(("command", "limit"), [("compare", 300), ("compare", 8_000),
                                                ("report", 8_000), ("report", 0.5)])
def test_compare_and_report_on_a_full_disk_leave_the_old_files(complete, tmp_path, command,
                                                               limit):
    out = _copy(complete, tmp_path / "out")
    before = tree(out)
    if isinstance(limit, float):  # a share of the report's size: it fails midway through
        limit = int(limit * (out / "report.html").stat().st_size)
    # compare at another resolution than the folder's: its figures are written again
    argv = [command, str(out), "--force"] + (["--dpi", "32"] if command == "compare" else [])
    code, log = run(argv, tmp_path / "full.log", file_size_limit(limit))
    assert tree(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["full.log", "out"]
    assert code == 1, log
    assert "cannot write the results (File too large)" in log and "Traceback" not in log


# --- item 11: SIGTERM stops the workers ---------------------------------------------------

def _workers_sleep():
    real = trial_workers.analyze_signals

    def slow(*args, **kwargs):
        time.sleep(60)
        return real(*args, **kwargs)
    trial_workers.analyze_signals = slow


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_a_stopped_analyze_leaves_no_worker_and_out_as_it_was(study, complete, tmp_path,
                                                              sig):
    out = _copy(complete, tmp_path / "out")
    before = tree(out)
    argv = ["analyze", str(study), "--out", str(out), "--jobs", "2", "--force", "--recompute"]
    proc = start(argv, tmp_path / "stop.log", _workers_sleep)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while len(workers) < 2:
            assert time.monotonic() < deadline and proc.is_alive()
            time.sleep(0.05)
            workers = [p for p in children(proc.pid) if alive(p)]
        time.sleep(0.2)  # the workers are in their trials
        os.kill(proc.pid, sig)
        proc.join(30)
        expected = 128 + signal.SIGTERM if sig == signal.SIGTERM else -signal.SIGKILL
        assert proc.exitcode == expected, (tmp_path / "stop.log").read_text()
        deadline = time.monotonic() + 60  # ends a hang only: a loaded machine reaps late
        while any(alive(p) for p in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(alive(p) for p in workers), "worker processes outlived analyze"
    finally:
        for p in workers:
            if alive(p):
                os.kill(p, signal.SIGKILL)
        if proc.is_alive():
            proc.kill()
    assert tree(out) == before
    log = (tmp_path / "stop.log").read_text()
    assert "Traceback" not in log
    if sig == signal.SIGTERM:  # it cleaned up: its message, nothing left beside OUT
        assert "terminated" in log
        assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "stop.log"]
