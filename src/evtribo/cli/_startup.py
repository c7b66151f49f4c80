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

A command ends with :func:`sys.exit`: its exit handlers, its output flushed, the
interpreter's own teardown.
"""

from __future__ import annotations

import gc
import os
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["BLAS_THREADS_ENV", "heavy_imports", "one_blas_thread"]

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
