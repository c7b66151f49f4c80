"""What a call logged, kept and said again elsewhere: a worker process's fit logs its
warnings into a list returned with its result, and the caller says them in its own order,
through its own handlers (the console, a test's log capture)."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["logged", "say_again"]

T = TypeVar("T")


class _Keep(logging.Handler):
    """Keeps each record, its message formatted (a record crosses processes as text)."""

    def __init__(self) -> None:
        super().__init__()
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        record.msg, record.args = record.getMessage(), None
        record.exc_info = record.exc_text = None
        self.records.append(record)


def logged(func: Callable[..., T], *args: Any, **kwargs: Any
           ) -> tuple[T, list[logging.LogRecord]]:
    """``func(*args, **kwargs)`` and what it logged under the ``evtribo`` logger, kept
    instead of said (none of this process's handlers sees it).

    Parameters
    ----------
    func : callable
    *args, **kwargs
        Its arguments.

    Returns
    -------
    (object, list of logging.LogRecord)
        Its result; the records, for :func:`say_again`. When *func* raises, its exception
        is raised with the records logged before it as its ``said`` attribute (they cross
        processes with it).
    """
    keep, top = _Keep(), logging.getLogger("evtribo")
    propagate = top.propagate
    top.addHandler(keep)
    top.propagate = False
    try:
        return func(*args, **kwargs), keep.records
    except Exception as err:
        err.said = keep.records  # type: ignore[attr-defined]
        raise
    finally:
        top.removeHandler(keep)
        top.propagate = propagate


def say_again(records: list[logging.LogRecord]) -> None:
    """Say records kept by :func:`logged` here, each by its own logger.

    Parameters
    ----------
    records : list of logging.LogRecord

    Returns
    -------
    None
    """
    for record in records:
        logger = logging.getLogger(record.name)
        if logger.isEnabledFor(record.levelno):
            logger.handle(record)
