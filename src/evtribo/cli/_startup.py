"""How the command line's process is set up before it imports the scientific libraries.

- **One BLAS thread** (``OPENBLAS_NUM_THREADS=1`` unless set): evtribo's parallel work is
  processes, one trial each, and its linear algebra is small; OpenBLAS's threads would only
  compete with those processes, and they spin on a core for a while after numpy and scipy
  load them (0.1-0.2 s of CPU per command on a 2-core machine). Set the variable to have
  more.
- **The imports without the cyclic garbage collector** (:func:`heavy_imports`): importing
  numpy, pandas, scipy and cantools allocates hundreds of thousands of objects and no
  garbage cycles worth collecting, yet sets the collector off hundreds of times, each
  collection of the oldest generation walking every object imported so far. What was
  imported is then frozen (:func:`gc.freeze`): never walked again, here or in the worker
  processes forked from here (which then leave those pages shared with this one).
- **A quick exit** (:func:`quick_exit`): once a command is done and has said so, the exit
  handlers run and the output is flushed, but the interpreter's teardown (freeing every
  object, module by module: 0.05-0.1 s after an analysis) is skipped, as mypy does.
"""

from __future__ import annotations

import atexit
import gc
import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NoReturn

__all__ = ["BLAS_THREADS_ENV", "heavy_imports", "one_blas_thread", "quick_exit"]

#: The variable OpenBLAS (numpy's and scipy's wheels) reads for its thread count.
BLAS_THREADS_ENV = "OPENBLAS_NUM_THREADS"


def one_blas_thread() -> None:
    """Have OpenBLAS start no threads of its own, unless :data:`BLAS_THREADS_ENV` says
    otherwise; before numpy is imported (it takes effect when the library loads)."""
    os.environ.setdefault(BLAS_THREADS_ENV, "1")


@contextmanager
def heavy_imports() -> Iterator[None]:
    """Import in the ``with`` block with the cyclic garbage collector paused; then freeze
    what exists (:func:`gc.freeze`) and let the collector run again (if it ran before)."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if was_enabled:
            gc.enable()


def quick_exit(code: int) -> NoReturn:
    """End the process with exit status *code*, as :func:`sys.exit` would but without the
    interpreter's teardown: the exit handlers run (logging's flush, multiprocessing's
    joins, temporary folders' removal), standard output and error are flushed, then
    :func:`os._exit`. While a thread that an exit waits for still runs, a plain
    :func:`sys.exit` instead.

    Parameters
    ----------
    code : int
        The exit status.
    """
    if any(t is not threading.main_thread() and not t.daemon for t in threading.enumerate()):
        sys.exit(code)
    try:
        atexit._run_exitfuncs()  # what an exit runs, without the teardown
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                if stream is not None:
                    stream.flush()
            except (OSError, ValueError):  # closed, or a closed pipe: nothing more to say
                pass
        os._exit(code)
