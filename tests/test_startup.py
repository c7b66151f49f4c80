"""The command line's process set-up before its heavy imports (evtribo.cli._startup)."""

from __future__ import annotations

import gc
import os
import subprocess
import sys

import pytest

from evtribo.cli import _startup


def _python(code: str, **env: str) -> str:
    base = {k: v for k, v in os.environ.items() if k != _startup.BLAS_THREADS_ENV}
    done = subprocess.run([sys.executable, "-c", code], env={**base, **env},
                          capture_output=True, text=True, timeout=120, check=True)
    return done.stdout


THREADS = ("import os, numpy, scipy.special; "
           "print(len(os.listdir('/proc/self/task')))")


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts threads in /proc")
def test_the_command_line_starts_no_blas_threads_unless_asked():
    """After one_blas_thread, numpy and scipy load with no thread of their own; a user's
    OPENBLAS_NUM_THREADS is left as it is."""
    one = _python("from evtribo.cli._startup import one_blas_thread; one_blas_thread(); "
                  + THREADS)
    assert int(one) == 1
    if int(_python(THREADS)) > 1:  # this OpenBLAS starts its threads as it loads (on 2 cores
        # or more; some builds only at their first large product, and then none here)
        asked = _python("from evtribo.cli._startup import one_blas_thread; "
                        "one_blas_thread(); " + THREADS, OPENBLAS_NUM_THREADS="2")
        assert int(asked) > 1


def test_the_console_entry_sets_one_blas_thread():
    """``python -m evtribo`` (and the console script, the same entry) sets the variable
    before anything is imported."""
    out = _python("import atexit, os, runpy, sys; "
                  "atexit.register(lambda: print('blas', os.environ.get("
                  f"{_startup.BLAS_THREADS_ENV!r}), 'numpy' in sys.modules)); "
                  "sys.argv = ['evtribo', '--version']; "
                  "runpy.run_module('evtribo', run_name='__main__')")
    assert out.splitlines()[-1] == "blas 1 False"
    kept = _python("import atexit, os, runpy, sys; "
                   "atexit.register(lambda: print('blas', os.environ.get("
                   f"{_startup.BLAS_THREADS_ENV!r}))); "
                   "sys.argv = ['evtribo', '--version']; "
                   "runpy.run_module('evtribo', run_name='__main__')",
                   OPENBLAS_NUM_THREADS="3")
    assert kept.splitlines()[-1] == "blas 3"


@pytest.mark.parametrize("enabled", [True, False])
def test_heavy_imports_pause_the_collector_and_freeze_what_they_made(enabled):
    """Inside, the collector is paused; after, what exists is frozen and the collector is
    as it was, also when the block raises."""
    was = gc.isenabled()
    (gc.enable if enabled else gc.disable)()
    try:
        with pytest.raises(ZeroDivisionError), _startup.heavy_imports():
            assert not gc.isenabled()
            made = [[i] for i in range(1000)]
            1 / 0  # noqa: B018
        assert gc.isenabled() is enabled
        assert gc.get_freeze_count() >= len(made)
        first = made[0]
        assert not any(o is first for o in gc.get_objects())  # frozen: never walked again
    finally:
        gc.unfreeze()
        (gc.enable if was else gc.disable)()


def _evtribo(*args: str, before: str = "", **env: str) -> subprocess.CompletedProcess[str]:
    code = (f"import atexit, runpy, sys\n{before}\n"
            "atexit.register(lambda: print('atexit ran', flush=True))\n"
            f"sys.argv = ['evtribo', *{list(args)!r}]\n"
            "runpy.run_module('evtribo', run_name='__main__')\n")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False,
                          timeout=120, env={**os.environ, **env})


def test_the_exit_runs_the_exit_handlers_and_keeps_the_status_and_output(tmp_path):
    """The exit handlers run, everything printed arrives (a long listing, piped), and the
    status is the command's: 0 done, 2 bad input (its message on standard error)."""
    done = _evtribo("model", "--list")
    assert done.returncode == 0, done.stderr
    plain = subprocess.run([sys.executable, "-c", "import sys; from evtribo.cli import main; "
                            "sys.exit(main(['model', '--list']))"],
                           capture_output=True, text=True, timeout=120, check=True)
    assert len(plain.stdout) > 500
    assert done.stdout == plain.stdout + "atexit ran\n"
    bad = _evtribo("analyze", str(tmp_path / "no-study"), "--out", str(tmp_path / "out"))
    assert bad.returncode == 2
    assert "no-study" in bad.stderr and bad.stdout.strip() == "atexit ran"


def test_the_exit_waits_for_a_thread_still_running(tmp_path):
    """A thread that is not a daemon still running: the exit waits for it."""
    started = ("import threading, time\n"
               "threading.Thread(target=lambda: (time.sleep(1.5), print('thread done', "
               "flush=True))).start()")
    out = _evtribo("analyze", str(tmp_path / "no-study"), "--out", str(tmp_path / "out"),
                   before=started)
    assert out.returncode == 2
    assert out.stdout.split() == ["thread", "done", "atexit", "ran"]
