"""The one way a warning is said: a module emits a record, the innermost collector keeps
it, and the console hears it unless the collector is quiet.

A module makes its emitter once, at its top::

    emit = emitter(__name__)

and says each warning by its kind's id and values::

    emit("offset", cell="normal", offset_mN=-44.9, share_pct=18, force_N=0.254)

:class:`Emit` renders the kind's wording (a field without a value, or an id the catalogue
lacks, raises), gives the record the scope it was handed or else the innermost collector's
(the trial a worker analyses; none: the study), keeps it in the innermost collector
(:func:`collecting`) and logs its text at WARNING under the module's logger, unless a
collector is quiet. A collector inside a quiet one is quiet too.

A collector keeps what is said within it and hands nothing on by itself: the caller says
its records again where it decides (:func:`replay`), in its own order. So a worker process,
a Dask task or a thread does the same as a call in this process: :func:`collected` runs a
call quietly and returns its records with its result (a record is plain data and crosses
processes as it is); the caller replays them, trial after trial in the study's order.

The collectors are held by a :class:`~contextvars.ContextVar`: each thread and each asyncio
task has its own.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar

from evtribo.warning.catalogue import kind
from evtribo.warning.record import Scope, WarningRecord

__all__ = ["Emit", "collected", "collecting", "emitter", "replay", "rescoped"]

T = TypeVar("T")


@dataclass
class _Collector:
    scope: Scope | None
    quiet: bool
    records: list[WarningRecord] = field(default_factory=list)


_COLLECTORS: ContextVar[tuple[_Collector, ...]] = ContextVar("evtribo_warning_collectors",
                                                             default=())


def _quiet(stack: tuple[_Collector, ...]) -> bool:
    return any(c.quiet for c in stack)


class Emit:
    """Says a module's warnings (made by :func:`emitter`).

    Attributes
    ----------
    logger : logging.Logger
        The module's logger, the text logged under it.
    """

    def __init__(self, logger_name: str) -> None:
        self.logger = logging.getLogger(logger_name)

    def __call__(self, kind_id: str, scope: Scope | None = None, /, **values: Any
                 ) -> WarningRecord:
        """Say a warning.

        Parameters
        ----------
        kind_id : str
            The kind's id in the catalogue.
        scope : Scope, optional
            Where it is said (default: the innermost collector's that has one, else the
            study).
        **values
            The kind's wording's values.

        Returns
        -------
        WarningRecord
            The record kept.

        Raises
        ------
        KeyError
            An id the catalogue lacks, or a field of the wording without a value.
        """
        stack = _COLLECTORS.get()
        if scope is None:
            scope = next((c.scope for c in reversed(stack) if c.scope is not None), None)
        record = kind(kind_id).record(scope, values, self.logger.name)
        if stack:
            stack[-1].records.append(record)
        if not _quiet(stack):
            self.logger.warning("%s", record.text)
        return record

    def record(self, kind_id: str, scope: Scope | None = None, /, **values: Any
               ) -> WarningRecord:
        """A warning of this module made but not said: kept by no collector, logged by
        nobody, for the caller that says it where it decides (:func:`replay`: compare's
        notes, said in the comparison's order).

        Parameters
        ----------
        kind_id : str
            The kind's id in the catalogue.
        scope : Scope, optional
            Where it is said (default: the study).
        **values
            The kind's wording's values.

        Returns
        -------
        WarningRecord

        Raises
        ------
        KeyError
            An id the catalogue lacks, or a field of the wording without a value.
        """
        return kind(kind_id).record(scope, values, self.logger.name)


def emitter(logger_name: str) -> Emit:
    """A module's emitter of warnings.

    Parameters
    ----------
    logger_name : str
        The module's name (``__name__``): its logger says the warnings.

    Returns
    -------
    Emit
    """
    return Emit(logger_name)


@contextmanager
def collecting(scope: Scope | None = None, *, quiet: bool = False
               ) -> Iterator[list[WarningRecord]]:
    """Keep the warnings said within, in the order said.

    Parameters
    ----------
    scope : Scope, optional
        The scope of a warning said within without one (a trial's, in the worker that
        analyses it).
    quiet : bool
        Log nothing said within (the records are kept all the same).

    Returns
    -------
    context manager
        Yields the list the records are kept in.
    """
    collector = _Collector(scope, quiet)
    token = _COLLECTORS.set((*_COLLECTORS.get(), collector))
    try:
        yield collector.records
    finally:
        _COLLECTORS.reset(token)


def collected(func: Callable[..., T], *args: Any, scope: Scope | None = None, **kwargs: Any
              ) -> tuple[T, list[WarningRecord]]:
    """``func(*args, **kwargs)`` run quietly, with the warnings it said.

    Parameters
    ----------
    func : callable
    *args, **kwargs
        Its arguments.
    scope : Scope, optional
        The scope of the warnings it says without one.

    Returns
    -------
    (object, list of WarningRecord)
        Its result and its warnings, for :func:`replay`. When *func* raises, the exception
        carries the warnings said before it as its ``records`` attribute (they cross
        processes with it).
    """
    with collecting(scope, quiet=True) as records:
        try:
            result = func(*args, **kwargs)
        except BaseException as err:
            try:
                err.records = list(records)  # type: ignore[attr-defined]
            except AttributeError:  # an exception that takes no attributes
                pass
            raise
    return result, records


def replay(records: Iterable[WarningRecord]) -> None:
    """Say records again here, in their order: each kept by the innermost collector and
    logged under the logger of the module that said it, unless a collector is quiet.

    Parameters
    ----------
    records : iterable of WarningRecord
        From :func:`collected` (a worker's), or read back (summary.json, a cache).
    """
    stack = _COLLECTORS.get()
    quiet = _quiet(stack)
    for record in records:
        if stack:
            stack[-1].records.append(record)
        if not quiet:
            logging.getLogger(record.source or "evtribo").warning("%s", record.text)


def rescoped(record: WarningRecord, scope: Scope) -> WarningRecord:
    """*record* as said of *scope*: its kind's wording filled with its values again, the
    scope's prefix first (a record kept without its trial, a decoded trial's from the
    cache, said of the trial that reads it).

    Parameters
    ----------
    record : WarningRecord
    scope : Scope

    Returns
    -------
    WarningRecord
        A kind the catalogue lacks, or one of earlier results, keeps its text.
    """
    try:
        found = kind(record.kind)
    except KeyError:
        return replace(record, scope=scope)
    if found.earlier:
        return replace(record, scope=scope)
    return found.record(scope, dict(record.values), record.source)
