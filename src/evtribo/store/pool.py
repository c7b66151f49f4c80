"""The worker processes of a pool (analyze's trials, compare's fits and figures): they keep
none of the parent's locks on result folders (:mod:`evtribo.store.resultdir`), the parent
stops them, they end when it is gone, and they are stopped at once when it fails.

Kept apart from the analysis (:mod:`evtribo.results.workers`) so that a pool that draws
figures starts without importing it.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from evtribo.store.resultdir import release_inherited_locks

__all__ = ["Mapper", "init_worker", "stop_workers"]

#: ``mapper(func, items)``: ``func`` of each item, in order (a pool's workers, or here).
Mapper = Callable[[Callable[[Any], Any], list[Any]], list[Any]]


def _watch_parent(parent: int) -> None:
    """End this worker when its parent is gone."""
    while os.getppid() == parent:
        time.sleep(0.5)
    os._exit(1)  # the analysis was killed (SIGKILL, a crash): nobody wants our results


def init_worker() -> None:
    """Make this process a worker of its parent's pool: the parent stops it (Ctrl-C reaches
    the whole process group, the parent handles it; SIGTERM ends it, whatever handler the
    parent had when it was forked), it ends when the parent is gone, and
    it does not keep the parent's locks (a pool's initializer: analyze's, and compare's for
    its figures).

    Returns
    -------
    None
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler: stopped, it ends
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True,
                     name="evtribo-parent-watch").start()
    release_inherited_locks()


def stop_workers(pool: ProcessPoolExecutor) -> None:
    """Stop a pool's worker processes now (they would finish their task otherwise).

    Parameters
    ----------
    pool : ProcessPoolExecutor
        A pool whose workers run :func:`init_worker`.

    Returns
    -------
    None
    """
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        proc.terminate()
    for proc in processes:
        proc.join(10)
