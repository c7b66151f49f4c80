"""What evtribo's modules warn of while one trial is analysed, kept instead of said.

A trial's warnings are said once, where the decision is made: ``evtribo analyze`` says each
trial's warnings (and why a trial was not analysed) when it gathers the trials' outcomes, in
the study's order, whether the trial ran in a worker process, on a Dask cluster or was taken
from the cache. While a trial is analysed, :func:`heard_warnings` keeps what the readers,
the decoder and the analysis log as warnings from this thread and turns each into a debug
message, so that nothing is said twice (and ``compare``, ``plot trial`` and a session's
check, which analyse a trial again to draw or judge it, do not say again what ``analyze``
said). Other threads' records, and errors, pass as they are.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

__all__ = ["Heard", "heard_warnings", "no_force", "say"]

_log = logging.getLogger("evtribo.analysis")


@dataclass
class Heard:
    """The warnings heard: ``(logger name, message)`` in the order logged."""

    records: list[tuple[str, str]] = field(default_factory=list)

    def messages(self, *, besides: str | None = None) -> list[str]:
        """The messages, in order.

        Parameters
        ----------
        besides : str, optional
            Leave out the records of loggers under this name (``"evtribo.analysis"``: the
            analysis's own, which its result lists already).

        Returns
        -------
        list of str
        """
        return [m for name, m in self.records
                if besides is None or not (name == besides or name.startswith(besides + "."))]


class _Keep(logging.Filter):
    """Keeps this thread's warnings and lowers them to debug messages."""

    def __init__(self, heard: Heard) -> None:
        super().__init__()
        self.heard = heard
        self.thread = threading.get_ident()

    def filter(self, record: logging.LogRecord) -> bool:
        if record.thread == self.thread and logging.WARNING <= record.levelno < logging.ERROR:
            self.heard.records.append((record.name, record.getMessage()))
            record.levelno, record.levelname = logging.DEBUG, "DEBUG"
            # as a debug message would be: only where its logger lets debug messages through
            return logging.getLogger(record.name).isEnabledFor(logging.DEBUG)
        return True


@cache
def _module_names() -> tuple[str, ...]:
    """The name of every module of the package (its loggers' names)."""
    root = Path(__file__).resolve().parents[1]
    names = []
    for path in root.rglob("*.py"):
        parts = path.relative_to(root).with_suffix("").parts
        parts = parts[:-1] if parts[-1] == "__init__" else parts
        names.append(".".join(("evtribo", *parts)))
    return tuple(sorted(names))


def _loggers() -> list[logging.Logger]:
    """evtribo's loggers: one per module (made now for those not yet imported), and any
    other logger under ``evtribo``."""
    made = {name for name in logging.Logger.manager.loggerDict
            if name == "evtribo" or name.startswith("evtribo.")}
    return [logging.getLogger(name) for name in sorted(made | set(_module_names()))]


@contextmanager
def heard_warnings() -> Iterator[Heard]:
    """Keep the warnings evtribo's modules log from this thread, as debug messages.

    Returns
    -------
    context manager
        Yields a :class:`Heard` that fills as warnings are logged.
    """
    heard = Heard()
    keep = _Keep(heard)
    loggers = _loggers()
    for logger in loggers:
        logger.addFilter(keep)
    try:
        yield heard
    finally:
        for logger in loggers:
            logger.removeFilter(keep)


def say(texts: Iterable[str], logger: logging.Logger | None = None) -> list[str]:
    """Log each text as a warning, once, where the analysis decides it.

    Parameters
    ----------
    texts : iterable of str
        The warnings.
    logger : logging.Logger, optional
        Whose warnings they are (default: ``evtribo.analysis``).

    Returns
    -------
    list of str
        The texts, for ``summary.json``.
    """
    out = list(texts)
    for text in out:
        (logger or _log).warning("%s", text)
    return out


def no_force(n_on: int, n_windows: int) -> str:
    """What the analysis says of a study whose trials give no electrostatic force at all.

    Parameters
    ----------
    n_on : int
        ON windows found in all the trials.
    n_windows : int
        Windows found, ON and OFF.

    Returns
    -------
    str
        The warning: why, and where the friction coefficient is.
    """
    why = (f"no trial has an ON window ({n_windows} OFF windows: the trials' condition is "
           "off, or the amplifier's status never said ON)" if n_on == 0 else
           "no subject has both ON and OFF windows with a known amplitude")
    return f"no electrostatic force: {why}; evtribo report shows each subject's μ"
