"""Work mapped over the workers of an existing ``dask.distributed`` cluster.

``dask[distributed]`` is an optional extra (``pip install 'evtribo[dask]'``), imported only
when a scheduler is named: on the command line ``--dask tcp://HOST:PORT``, or
:data:`SCHEDULER_ENV`. The cluster is the user's (a ``dask scheduler`` and ``dask worker``
processes, or any deployment of them); evtribo only connects to it, sends it work and
collects the results. The workers run the same functions as a local run, on the same
inputs, so they give the same results; they read the study and the decoded-trial cache
themselves, so both must be on storage every worker sees, at the same absolute path.

:func:`connect` opens a client (a clear error when the extra is missing or the scheduler is
unreachable), :func:`check_workers` asks every worker whether it sees the paths the work
needs, and :func:`map_unordered` sends a function over a list of items and yields the
results as they finish; stopped (an error, Ctrl-C, SIGTERM), it cancels what has not run.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from types import ModuleType
from typing import Any, TypeVar

import evtribo
from evtribo.errors import AnalysisError, UserInputError

__all__ = ["CONNECT_TIMEOUT_S", "INSTALL_HINT", "SCHEDULER_ENV", "check_workers", "connect",
           "import_distributed", "map_unordered", "scheduler_address", "total_threads"]

#: The environment variable that names the scheduler when ``--dask`` is not given.
SCHEDULER_ENV = "EVTRIBO_DASK_SCHEDULER"
#: What installs the extra.
INSTALL_HINT = "pip install 'evtribo[dask]'"
#: Seconds to wait for the scheduler before giving up.
CONNECT_TIMEOUT_S = 5.0

T = TypeVar("T")
R = TypeVar("R")


def scheduler_address(option: str | None) -> str | None:
    """The scheduler to use: the option's, else :data:`SCHEDULER_ENV`'s, else none.

    Parameters
    ----------
    option : str or None
        The ``--dask`` option's value.

    Returns
    -------
    str or None
        The address (``tcp://HOST:PORT``), or None for a local run.
    """
    value = option if option is not None else os.environ.get(SCHEDULER_ENV)
    value = (value or "").strip()
    return value or None


def import_distributed(key: str = "--dask") -> ModuleType:
    """The ``distributed`` package, or a clear error when the extra is not installed.

    Parameters
    ----------
    key : str
        What named the scheduler (the option, or :data:`SCHEDULER_ENV`), for the message.

    Returns
    -------
    module
        ``distributed``.

    Raises
    ------
    UserInputError
        ``dask[distributed]`` cannot be imported (the message gives the install command).
    """
    try:
        import distributed
    except ImportError as err:
        raise UserInputError(f"running on a Dask cluster needs the dask extra: "
                             f"{INSTALL_HINT} ({err})", key=key) from err
    return distributed


@contextmanager
def connect(address: str, timeout: float = CONNECT_TIMEOUT_S, *,
            key: str = "--dask") -> Iterator[Any]:
    """A client of the scheduler at *address*, closed on leaving.

    Parameters
    ----------
    address : str
        The scheduler (``tcp://HOST:PORT``).
    timeout : float
        Seconds to wait for it.
    key : str
        What named the scheduler (the option, or :data:`SCHEDULER_ENV`), for the messages.

    Returns
    -------
    contextmanager of distributed.Client
        The connected client.

    Raises
    ------
    UserInputError
        The extra is missing, or no scheduler answered at *address* within *timeout*.
    """
    distributed = import_distributed(key)
    try:
        client = distributed.Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as err:
        raise UserInputError(f"no Dask scheduler answered at {address} within {timeout:g} s "
                             f"({type(err).__name__}: {err}); start one with "
                             "`dask scheduler`, or check the address", key=key) from err
    try:
        yield client
    finally:
        client.close()


def total_threads(client: Any) -> int:
    """The threads of all the cluster's workers (at least 1).

    Parameters
    ----------
    client : distributed.Client
        A connected client.

    Returns
    -------
    int
    """
    return max(1, sum(client.nthreads().values()))


def _worker_view(paths: Sequence[str]) -> tuple[str, list[str]]:
    """On a worker: its evtribo version and which of *paths* it does not see."""
    return evtribo.__version__, [p for p in paths if not os.path.exists(p)]


def _check_scheduler(client: Any, key: str) -> None:
    """The scheduler loads evtribo's tasks (it unpickles them): the same evtribo there."""
    try:
        version, _ = client.run_on_scheduler(_worker_view, [])
    except Exception as err:
        raise UserInputError(f"the Dask scheduler {client.scheduler.address} cannot load "
                             f"evtribo's tasks ({type(err).__name__}: {err}); install evtribo "
                             f"{evtribo.__version__} in the scheduler's environment too",
                             key=key) from err
    if version != evtribo.__version__:
        raise UserInputError(f"the Dask scheduler {client.scheduler.address} runs evtribo "
                             f"{version}, this is {evtribo.__version__}; install the same there",
                             key=key)


def check_workers(client: Any, paths: Sequence[str], *, key: str = "--dask") -> int:
    """Check that the scheduler and every worker run this evtribo and that the workers see
    *paths*; return the workers' count.

    Parameters
    ----------
    client : distributed.Client
        A connected client.
    paths : sequence of str
        Absolute paths every worker must see (the study folder, the cache's parent).
    key : str
        What named the scheduler (the option, or :data:`SCHEDULER_ENV`), for the messages.

    Returns
    -------
    int
        The number of workers.

    Raises
    ------
    UserInputError
        A scheduler that cannot load evtribo's tasks (evtribo is not installed there) or
        runs another version of it; no worker, a worker that cannot run evtribo or runs
        another version of it, or a worker that does not see one of *paths* (naming the
        worker and the path).
    """
    _check_scheduler(client, key)
    views = client.run(_worker_view, list(paths), on_error="return")
    if not views:
        raise UserInputError("the Dask cluster has no worker; start some with "
                             "`dask worker SCHEDULER`", key=key)
    for worker, view in sorted(views.items()):
        if isinstance(view, BaseException):
            raise UserInputError(f"Dask worker {worker} cannot run evtribo "
                                 f"({type(view).__name__}: {view}); install evtribo "
                                 f"{evtribo.__version__} on every worker", key=key)
        version, missing = view
        if version != evtribo.__version__:
            raise UserInputError(f"Dask worker {worker} runs evtribo {version}, this is "
                                 f"{evtribo.__version__}; install the same on every worker",
                                 key=key)
        if missing:
            raise UserInputError(f"Dask worker {worker} does not see {missing[0]}: the study "
                                 "and the cache must be on storage every worker sees, at "
                                 "the same absolute path", key=key)
    return len(views)


def _lost(err: BaseException, distributed: ModuleType) -> bool:
    """Whether *err* says a worker or the scheduler went away (not the function's own)."""
    lost = (distributed.KilledWorker, distributed.comm.CommClosedError,
            distributed.client.FutureCancelledError)
    return isinstance(err, lost)


def map_unordered(client: Any, func: Callable[..., R], items: Sequence[T], *shared: Any,
                  name: Callable[[T], str] = str) -> Iterator[tuple[int, R]]:
    """``func(item, *shared)`` for each item on the cluster, as they finish.

    Parameters
    ----------
    client : distributed.Client
        A connected client.
    func : callable
        An importable function (the workers import it by name).
    items : sequence
        One call each.
    *shared : object
        Arguments every call gets, sent to each worker once.
    name : callable
        Names an item in the error when its worker is lost.

    Returns
    -------
    iterator of (int, object)
        Each item's index in *items* and its result, in the order they finish; a call's
        exception is raised as it was on the worker. Stopped early, the calls not yet
        finished are cancelled.

    Raises
    ------
    AnalysisError
        A worker died while it held an item (naming the item; Dask gives up on an item
        after ``distributed.scheduler.allowed-failures`` such deaths), or the scheduler
        went away.
    """
    distributed = import_distributed()
    sent = [client.scatter(s, broadcast=True, hash=False) for s in shared]
    futures = [client.submit(func, item, *sent, pure=False) for item in items]
    index = {f.key: i for i, f in enumerate(futures)}
    try:
        for fut in distributed.as_completed(futures, loop=client.loop):
            i = index[fut.key]
            try:
                result = fut.result()
            except Exception as err:
                if not _lost(err, distributed):
                    raise
                raise AnalysisError(f"{name(items[i])}: the Dask worker it was given to was "
                                    f"lost ({type(err).__name__}: {err})") from err
            yield i, result
    finally:
        client.cancel([f for f in futures if not f.done()])
        client.cancel(sent)
