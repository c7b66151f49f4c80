"""SIGTERM as an interruption, so that a command stopped by ``kill`` cleans up like Ctrl-C.

By default SIGTERM ends Python at once: no ``finally`` runs, so worker processes are left
running and a new folder of results is left half-written beside the output. Inside
:func:`sigterm_interrupts` it raises :class:`Terminated` instead (a ``KeyboardInterrupt``),
which unwinds the command the way Ctrl-C does.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from types import FrameType

__all__ = ["EXIT_TERMINATED", "Terminated", "sigterm_interrupts"]

#: The exit code of a command stopped by SIGTERM (128 + 15, as a shell reports it).
EXIT_TERMINATED = 128 + signal.SIGTERM


class Terminated(KeyboardInterrupt):
    """SIGTERM was received."""


def _raise(signum: int, frame: FrameType | None) -> None:
    raise Terminated(f"signal {signum}")


@contextlib.contextmanager
def sigterm_interrupts() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)
