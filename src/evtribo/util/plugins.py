"""Plug-ins found through entry points: what a lab installs beside evtribo (a warning kind,
a friction law, a population model, a log reader) without a fork, as python-can finds its
log readers (``can.io.message_reader``).

A plug-in is a distribution that declares an entry point in one of evtribo's groups
(``evtribo.warning_kinds``, ``evtribo.friction_laws``, ``evtribo.population_models``,
``evtribo.log_readers``, ``evtribo.figures``)::

    [project.entry-points."evtribo.warning_kinds"]
    mylab = "mylab.evtribo_kinds:KINDS"

:func:`load` reads a group's entry points once per process and imports each; one that fails
to import is logged (a warning naming it and why) and skipped: a broken plug-in never stops
evtribo. Each registry (:mod:`evtribo.warning.catalogue`, ...) says what the object it
loads must be.
"""

from __future__ import annotations

import logging
from functools import cache

__all__ = ["forget", "load"]

log = logging.getLogger(__name__)


@cache
def _loaded(group: str) -> tuple[tuple[str, object], ...]:
    # imported here: reading the packages' metadata is not free, and a command that needs
    # no plug-in (analyze writing an unchanged study's results again) never does
    from importlib import metadata

    out = []
    for entry in sorted(metadata.entry_points(group=group), key=lambda e: (e.name, e.value)):
        try:
            out.append((entry.name, entry.load()))
        except Exception as err:  # a plug-in's fault, whatever it is, must not stop evtribo
            log.warning("plug-in %s = %s (entry point group %s) cannot be loaded, skipped: "
                        "%s: %s", entry.name, entry.value, group, type(err).__name__, err)
    return tuple(out)


def load(group: str) -> list[tuple[str, object]]:
    """The objects a group's entry points name, each imported once per process.

    Parameters
    ----------
    group : str
        The entry point group (``evtribo.warning_kinds``).

    Returns
    -------
    list of (str, object)
        Each entry point's name and the object it names, by name; those that failed to
        load are left out (and logged).
    """
    return list(_loaded(group))


def forget() -> None:
    """Read the entry points again at the next :func:`load` (after a plug-in was installed
    while the process runs; the tests install theirs so).
    """
    _loaded.cache_clear()
