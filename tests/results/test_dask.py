"""``analyze --dask`` and ``compare --dask`` on a LocalCluster of worker processes: the same
tables as the local run, byte for byte; errors as the local run gives them; a stopped run
leaves nothing half-written and nothing running; the missing extra is exit 2 with a message
that says what to do (an unreachable scheduler: tests/test_bad_input.py, the errors page's
row analyze-dask-unreachable)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from evtribo.acquisition.simulator import SubjectParams, TrialConfig, simulate_study
from evtribo.cli import main
from evtribo.errors import AnalysisError, UserInputError
from evtribo.results import distributed as evdist
from evtribo.results.pipeline import analyze_study

distributed = pytest.importorskip("distributed")

#: summary.json's keys that differ between two runs of the same analysis.
RUN_KEYS = {"run_id", "created", "started", "elapsed_s", "jobs"}


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes of one thread each, and a client of their scheduler."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as local, \
            distributed.Client(local, set_as_default=False) as client:
        yield local, client


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Two subjects, a damaged line in one log (a warning the workers must report)."""
    root = tmp_path_factory.mktemp("dask") / "study"
    simulate_study(root, [SubjectParams(name="P01", h_L=3e-6), SubjectParams(name="P02")],
                   amplitudes=(80.0, 160.0), config=TrialConfig(duration_s=6.0))
    log = root / "P01" / "run-02.log"
    lines = log.read_text(encoding="ascii").splitlines(keepends=True)
    lines.insert(100, "(1763700000.100000) vcan0 0C1#ZZ\n")
    log.write_text("".join(lines), encoding="ascii")
    return root


def _same_results(a: Path, b: Path) -> None:
    """Every CSV equal byte for byte, summary.json equal but for the run's own keys."""
    names = sorted(p.name for p in a.glob("*.csv"))
    assert names == sorted(p.name for p in b.glob("*.csv"))
    assert "windows.csv" in names and "electrostatic_bootstrap.csv" in names
    for name in names:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    assert {k: v for k, v in sa.items() if k not in RUN_KEYS} == \
        {k: v for k, v in sb.items() if k not in RUN_KEYS}
    assert sa["run_id"] != sb["run_id"]


def test_analyze_dask_gives_the_local_run_s_tables(cluster, study, tmp_path, capsys):
    local, _ = cluster
    assert main(["analyze", str(study), "--out", str(tmp_path / "local"), "--jobs", "2",
                 "--cache-dir", str(tmp_path / "cache-local")]) == 0
    assert main(["analyze", str(study), "--out", str(tmp_path / "dask"), "--dask",
                 local.scheduler_address, "--cache-dir", str(tmp_path / "cache-dask")]) == 0
    _same_results(tmp_path / "local", tmp_path / "dask")
    summary = json.loads((tmp_path / "dask" / "summary.json").read_text())
    assert summary["jobs"] == 2  # the cluster's worker threads
    assert any("damaged line" in w["text"] for w in summary["warnings"])
    # the workers wrote the cache where this process named it
    assert list((tmp_path / "cache-dask").glob("*.arrow"))


def test_the_environment_names_the_scheduler_and_relative_paths_are_made_absolute(
        cluster, study, tmp_path, monkeypatch):
    local, _ = cluster
    monkeypatch.setenv(evdist.SCHEDULER_ENV, local.scheduler_address)
    monkeypatch.chdir(study.parent)
    assert main(["analyze", study.name, "--out", str(tmp_path / "dask"), "--cache-dir",
                 os.path.relpath(tmp_path / "c1")]) == 0
    assert list((tmp_path / "c1").glob("*.arrow"))
    monkeypatch.delenv(evdist.SCHEDULER_ENV)
    # the same paths as the cluster run saw them (warnings name the logs as given)
    assert main(["analyze", str(study), "--out", str(tmp_path / "local"), "--jobs", "1",
                 "--cache-dir", str(tmp_path / "c2")]) == 0
    _same_results(tmp_path / "local", tmp_path / "dask")


def test_a_strict_error_on_a_worker_is_the_local_run_s_error(cluster, study, tmp_path,
                                                            capsys):
    local, _ = cluster
    code = main(["analyze", str(study), "--out", str(tmp_path / "a"), "--strict",
                 "--jobs", "1", "--cache-dir", str(tmp_path / "c1")])
    local_err = capsys.readouterr().err
    code_dask = main(["analyze", str(study), "--out", str(tmp_path / "b"), "--strict",
                      "--dask", local.scheduler_address, "--cache-dir", str(tmp_path / "c2")])
    dask_err = capsys.readouterr().err
    assert code == code_dask == 2
    assert "run-02.log" in local_err and "Traceback" not in dask_err
    assert local_err.splitlines()[-1] == dask_err.splitlines()[-1]
    assert not (tmp_path / "b").exists()


def _scheduler_tasks(client) -> int:
    return client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))


def test_a_stopped_run_leaves_the_old_results_and_nothing_running(cluster, study, tmp_path):
    _, client = cluster
    out = tmp_path / "out"
    analyze_study(study, out, jobs=1, cache_dir=tmp_path / "cache")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    seen = []

    def stop(done, total):
        seen.append((done, total))
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        analyze_study(study, out, force=True, cache_dir=tmp_path / "cache2", progress=stop,
                      scheduler=client)
    assert seen == [(1, 6)]
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    deadline = time.monotonic() + 60  # ends a hang only: a loaded scheduler forgets late
    while _scheduler_tasks(client) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _scheduler_tasks(client) == 0


def test_a_worker_that_does_not_see_the_study_is_named(cluster, tmp_path):
    _, client = cluster
    missing = str(tmp_path / "elsewhere" / "study")
    with pytest.raises(UserInputError, match=r"Dask worker tcp://.* does not see .*elsewhere"):
        evdist.check_workers(client, [str(tmp_path), missing])
    assert evdist.check_workers(client, [str(tmp_path)]) == 2


def test_relative_paths_are_refused_on_a_cluster(cluster, study, tmp_path, monkeypatch):
    _, client = cluster
    monkeypatch.chdir(study.parent)
    with pytest.raises(UserInputError, match="must be absolute"):
        analyze_study(study.name, tmp_path / "out", scheduler=client)
    assert not (tmp_path / "out").exists()


def _exit_on(item: int) -> int:
    """Kill the worker process on item 1."""
    if item == 1:
        os._exit(3)
    return item * 10


def test_a_lost_worker_is_an_analysis_error_naming_the_item():
    import dask

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                     dashboard_address=":0") as local, \
            distributed.Client(local, set_as_default=False) as client:
        assert dict(evdist.map_unordered(client, _exit_on, [0, 2])) == {0: 0, 1: 20}
        with pytest.raises(AnalysisError, match=r"trial-1: the Dask worker it was given to "
                                                r"was lost \(KilledWorker"):
            list(evdist.map_unordered(client, _exit_on, [1], name=lambda x: f"trial-{x}"))


def test_map_unordered_gives_every_item_s_result_with_shared_arguments(cluster):
    _, client = cluster
    got = dict(evdist.map_unordered(client, pow, [2, 3, 4], 3))
    assert got == {0: 8, 1: 27, 2: 64}


BLOCK_DASK = textwrap.dedent("""
    import sys

    class Block:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in ("dask", "distributed"):
                raise ImportError(f"No module named {name!r} (blocked)")
            return None

    sys.meta_path.insert(0, Block())
    from evtribo.cli import main
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.parametrize("command", ["analyze", "compare", "analyze-env"])
def test_the_missing_extra_is_exit_2_with_the_install_command(study, tmp_path, command):
    argv = (["compare", str(tmp_path / "out")] if command == "compare"
            else ["analyze", str(study), "--out", str(tmp_path / "out")])
    env = dict(os.environ)
    if command == "analyze-env":
        env[evdist.SCHEDULER_ENV] = "tcp://127.0.0.1:8786"
    else:
        argv += ["--dask", "tcp://127.0.0.1:8786"]
    proc = subprocess.run([sys.executable, "-c", BLOCK_DASK, *argv], capture_output=True,
                          text=True, timeout=120, check=False, env=env)
    assert proc.returncode == 2, proc.stderr
    key = evdist.SCHEDULER_ENV if command == "analyze-env" else "--dask"
    assert f"error: key '{key}': running on a Dask cluster needs the dask extra: " \
           "pip install 'evtribo[dask]'" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()


def test_compare_dask_refits_give_the_local_fit(cluster, study, tmp_path):
    import shutil

    local, client = cluster
    analyze_study(study, tmp_path / "results", jobs=1, cache_dir=tmp_path / "cache")
    for name in ("here", "dask"):
        shutil.copytree(tmp_path / "results", tmp_path / name)
    assert main(["compare", str(tmp_path / "here")]) == 0
    with distributed.get_task_stream(client) as stream:
        assert main(["compare", str(tmp_path / "dask"), "--dask",
                     local.scheduler_address]) == 0
    # 2 subjects x 200 replicates in chunks of 25, on the workers
    assert sum("_refit_chunk" in t["key"] for t in stream.data) == 16
    here, there = (tmp_path / d / "fit.csv" for d in ("here", "dask"))
    assert here.read_bytes() == there.read_bytes()
    fits = json.loads((tmp_path / "dask" / "fit.json").read_text())
    text = json.dumps(fits)
    assert '"bootstrap"' in text  # the intervals are the refits' (not the Jacobian's)


def _hold(event_name: str) -> None:
    """Keep a worker busy until the named event is set."""
    distributed.Event(event_name).wait(60)


def test_sigterm_cancels_the_trials_on_the_cluster_and_keeps_the_old_results(
        cluster, study, tmp_path):
    """Both workers held busy, the command's trials wait on the scheduler; SIGTERM then
    ends the command as a local run's (exit 143, the old results kept) and takes its
    trials off the cluster: none of them ever runs."""
    import signal

    from _process import kill_and_reap

    local, client = cluster
    out = tmp_path / "out"
    analyze_study(study, out, jobs=1, cache_dir=tmp_path / "cache")
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    event = distributed.Event(f"hold-{tmp_path.name}", client=client)
    holds = [client.submit(_hold, event.name, workers=[w], allow_other_workers=False,
                           pure=False) for w in client.nthreads()]
    proc = subprocess.Popen([sys.executable, "-m", "evtribo", "analyze", str(study), "--out",
                             str(out), "--force", "--dask", local.scheduler_address,
                             "--cache-dir", str(tmp_path / "cache2")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        with distributed.get_task_stream(client) as stream:
            deadline = time.monotonic() + 60
            waiting = 0
            while waiting < 6 and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.05)
                waiting = client.run_on_scheduler(lambda dask_scheduler: sum(
                    k.startswith("analyze_in") for k in map(str, dask_scheduler.tasks)))
            assert waiting == 6, proc.poll()
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=60)
            event.set()
            client.gather(holds)
            client.cancel(holds)
        assert proc.returncode == 143, err
        assert "terminated" in err and "nothing half-written" in err
        assert "Traceback" not in err
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before
        assert not [t for t in stream.data if "analyze_in" in t["key"]]
        deadline = time.monotonic() + 60  # ends a hang only
        while _scheduler_tasks(client) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _scheduler_tasks(client) == 0
    finally:
        event.set()
        kill_and_reap(proc)


def test_threads_of_one_worker_keep_each_trial_s_warnings_apart(study, tmp_path):
    """Three trials at once in the threads of one worker (in this process): each trial's
    warnings are its own, the tables the local run's."""
    with distributed.LocalCluster(n_workers=1, threads_per_worker=3, processes=False,
                                  dashboard_address=":0") as local, \
            distributed.Client(local, set_as_default=False) as client:
        analyze_study(study, tmp_path / "dask", cache_dir=tmp_path / "c1", scheduler=client)
    analyze_study(study, tmp_path / "local", jobs=1, cache_dir=tmp_path / "c2")
    _same_results(tmp_path / "local", tmp_path / "dask")
    summary = json.loads((tmp_path / "dask" / "summary.json").read_text())
    assert summary["jobs"] == 3


BLOCKED_SCHEDULER = textwrap.dedent("""
    import sys

    class Block:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] == "evtribo":
                raise ImportError("No module named 'evtribo'")
            return None

    sys.meta_path.insert(0, Block())
    from distributed.cli.dask_scheduler import main
    sys.argv = ["dask-scheduler", "--scheduler-file", sys.argv[1], "--port", "0",
                "--dashboard-address", ":0"]
    main()
""")


def _address(file: Path) -> str | None:
    """The scheduler's address from its file, once the file is there and whole."""
    try:
        return json.loads(file.read_text())["address"]
    except (OSError, ValueError, KeyError):
        return None


def test_a_scheduler_without_evtribo_is_exit_2_before_anything_runs(study, tmp_path, capsys):
    """A `dask scheduler` in an environment without evtribo cannot load its tasks: said at
    once, naming the scheduler, instead of a failure in the middle of the run."""
    from _process import kill_and_reap

    file = tmp_path / "scheduler.json"
    proc = subprocess.Popen([sys.executable, "-c", BLOCKED_SCHEDULER, str(file)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not (address := _address(file)) and time.monotonic() < deadline:
            time.sleep(0.1)  # until the file is there and written whole
        assert address, "the scheduler wrote no address"
        code = main(["analyze", str(study), "--out", str(tmp_path / "out"), "--dask", address])
        err = capsys.readouterr().err
    finally:
        proc.terminate()
        kill_and_reap(proc, timeout=30)
    assert code == 2, err
    assert (f"key '--dask': the Dask scheduler {address} cannot load evtribo's tasks "
            "(ImportError: No module named 'evtribo'); install evtribo") in err
    assert not (tmp_path / "out").exists()
