"""The catalogue of warnings: every kind evtribo says, by its id.

The builtin kinds are declared by area, so that each area's kinds are in one place:
:mod:`~evtribo.warning.kinds_input` (the study folder, the logs, decoding, frames and
clocks), :mod:`~evtribo.warning.kinds_trial` (a trial's analysis),
:mod:`~evtribo.warning.kinds_study` (the study gathered: per subject, drive and cell) and
:mod:`~evtribo.warning.kinds_compare` (the model's fit, the population, the figures), and
those only results of earlier versions have (:mod:`~evtribo.warning.legacy`,
:mod:`~evtribo.warning.legacy_compare`). A
lab's plug-in adds its own through the entry point group ``evtribo.warning_kinds``
(:mod:`evtribo.util.plugins`): the object it names is a :class:`Kind` or a sequence of
them, read the first time an id the builtins lack is asked for (or the whole catalogue
is).

An id is registered once: a second :func:`register` of it is refused (a plug-in's kind of
a builtin's id is logged and skipped); :func:`kind` of an id nobody registered raises, so
that no warning is ever said without its kind.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterable, Iterator, Mapping

from evtribo.util import plugins
from evtribo.warning.kind import Kind
from evtribo.warning.kinds_compare import COMPARE_KINDS
from evtribo.warning.kinds_input import INPUT_KINDS
from evtribo.warning.kinds_study import STUDY_KINDS
from evtribo.warning.kinds_trial import TRIAL_KINDS
from evtribo.warning.legacy import EARLIER_KINDS
from evtribo.warning.legacy_compare import EARLIER_COMPARE_KINDS

__all__ = ["AREAS", "ENTRY_POINTS", "KINDS", "Kind", "kind", "register"]

log = logging.getLogger(__name__)

#: The entry point group of plug-ins' kinds.
ENTRY_POINTS = "evtribo.warning_kinds"
#: The builtin kinds by area, in the order the documentation lists them.
AREAS: dict[str, tuple[Kind, ...]] = {
    "The study folder, the logs and their frames": INPUT_KINDS,
    "A trial's analysis": TRIAL_KINDS,
    "The study's results: subjects, drives and cells": STUDY_KINDS,
    "The comparison: the model's fit, the population, the figures": COMPARE_KINDS,
    "Results of earlier versions": (*EARLIER_KINDS, *EARLIER_COMPARE_KINDS),
}

_KINDS: dict[str, Kind] = {}
_read: dict[str, bool] = {"plugins": False}
_reading = threading.RLock()  # a plug-in that looks a kind up while imported: no wait


def register(*kinds: Kind) -> None:
    """Add kinds to the catalogue.

    Parameters
    ----------
    *kinds : Kind

    Raises
    ------
    TypeError
        Something that is not a :class:`Kind`.
    ValueError
        An id the catalogue has already (none of the kinds is then added).
    """
    seen = set(_KINDS)
    for k in kinds:
        if not isinstance(k, Kind):
            raise TypeError(f"a warning kind is a Kind, not {type(k).__name__}")
        if k.id in seen:
            raise ValueError(f"warning kind {k.id!r} is registered already")
        seen.add(k.id)
    _KINDS.update((k.id, k) for k in kinds)


def _plugins() -> None:
    """The plug-ins' kinds, registered once per process (another thread waits for them)."""
    with _reading:
        if not _read["plugins"]:
            _read["plugins"] = True
            _register_plugins()


def _register_plugins() -> None:
    for name, obj in plugins.load(ENTRY_POINTS):
        found = [obj] if isinstance(obj, Kind) else list(obj) if isinstance(
            obj, Iterable) and not isinstance(obj, str | bytes) else None
        if found is None:
            log.warning("plug-in %s (%s) names %s, not warning kinds: skipped", name,
                        ENTRY_POINTS, type(obj).__name__)
            continue
        for k in found:
            try:
                register(k)
            except (TypeError, ValueError) as err:
                log.warning("plug-in %s (%s): %s; skipped", name, ENTRY_POINTS, err)


def kind(id: str) -> Kind:
    """The kind of an id.

    Parameters
    ----------
    id : str
        ``normal-zero``.

    Returns
    -------
    Kind

    Raises
    ------
    KeyError
        No kind of that id, builtin or a plug-in's.
    """
    found = _KINDS.get(id)
    if found is None:
        _plugins()
        found = _KINDS.get(id)
    if found is None:
        raise KeyError(f"no warning kind {id!r} in the catalogue (evtribo.warning.kinds_*, or "
                       f"a plug-in's entry point {ENTRY_POINTS})")
    return found


class _Catalogue(Mapping[str, Kind]):
    """Every kind by id: the builtins in their areas' order, then the plug-ins'."""

    def __getitem__(self, id: str) -> Kind:
        return kind(id)

    def __iter__(self) -> Iterator[str]:
        _plugins()
        return iter(list(_KINDS))

    def __len__(self) -> int:
        _plugins()
        return len(_KINDS)

    def __contains__(self, id: object) -> bool:
        if id in _KINDS:
            return True
        _plugins()
        return id in _KINDS


#: Every kind by id (:func:`kind` of each).
KINDS: Mapping[str, Kind] = _Catalogue()

register(*(k for area in AREAS.values() for k in area))
