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

:class:`Registry` is a registry of things chosen by name (the friction laws of
``[analysis] friction_law``, the population models of ``[population] model``, the log
readers by suffix): the builtins in their order, then the plug-ins of its entry point group,
read the first time a name the builtins lack is asked for (or every name is). A name is
registered once: a second :meth:`Registry.register` of it is refused, and a plug-in's thing
of a name taken (a builtin's) is logged and skipped, as is one that is not what the registry
holds.
"""

from __future__ import annotations

import logging
import threading
import weakref
from collections.abc import Callable, Iterator, Mapping
from functools import cache
from typing import Any, Generic, TypeVar

__all__ = ["Registry", "forget", "load"]

T = TypeVar("T")

#: Every registry made (while it lives), so that :func:`forget` reads their plug-ins again.
_REGISTRIES: list[weakref.ref[Registry[Any]]] = []

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
    while the process runs; the tests install theirs so), and every :class:`Registry`'s
    plug-ins with them.
    """
    _loaded.cache_clear()
    for ref in list(_REGISTRIES):
        registry = ref()
        if registry is None:
            _REGISTRIES.remove(ref)
        else:
            registry.forget()


class Registry(Mapping[str, T], Generic[T]):
    """Things chosen by name: the builtins, then the plug-ins of an entry point group.

    Parameters
    ----------
    group : str
        The entry point group of the plug-ins (``evtribo.friction_laws``).
    what : str
        What a thing is, for messages (``friction law``).
    check : callable
        ``check(obj)``: the thing an entry point's object stands for (a class is made into
        an instance, say), or None when the object is no such thing.
    key : callable
        ``key(entry_name, thing)``: the name a plug-in's thing is registered under (its own
        ``name``, or the entry point's).
    """

    def __init__(self, group: str, what: str, *, check: Callable[[object], T | None],
                 key: Callable[[str, T], str]) -> None:
        self.group = group
        self.what = what
        self._check = check
        self._key = key
        self._things: dict[str, T] = {}
        self._from_plugins: set[str] = set()
        self._read = False
        self._reading = threading.RLock()  # a plug-in that looks a name up while imported
        _REGISTRIES.append(weakref.ref(self))

    def register(self, name: str, thing: T) -> None:
        """Add a thing under *name*.

        Parameters
        ----------
        name : str
        thing : object
            What the registry holds (as its *check* would take it).

        Raises
        ------
        ValueError
            A name registered already, or a thing the registry does not hold.
        """
        if self._check(thing) is None:
            raise ValueError(f"{name!r} is not a {self.what}")
        if name in self._things:
            raise ValueError(f"{self.what} {name!r} is registered already")
        self._things[name] = thing

    def unregister(self, name: str) -> None:
        """Remove the thing of *name* (a test's, or a lab's own for one run).

        Parameters
        ----------
        name : str

        Returns
        -------
        None
        """
        self._things.pop(name, None)

    def is_plugin(self, name: str) -> bool:
        """Whether the thing of *name* is a plug-in's (read through an entry point).

        Parameters
        ----------
        name : str

        Returns
        -------
        bool
        """
        return name in self and name in self._from_plugins

    def _plugins(self) -> None:
        with self._reading:
            if self._read:
                return
            self._read = True
            for entry, obj in load(self.group):
                thing = self._check(obj)
                if thing is None:
                    log.warning("plug-in %s (%s) names %s, not a %s: skipped", entry,
                                self.group, type(obj).__name__, self.what)
                    continue
                name = self._key(entry, thing)
                try:
                    self.register(name, thing)
                except ValueError as err:
                    log.warning("plug-in %s (%s): %s; skipped", entry, self.group, err)
                else:
                    self._from_plugins.add(name)

    def forget(self) -> None:
        """Read the plug-ins again at the next look (the tests install theirs so): those
        read so far are taken out.

        Returns
        -------
        None
        """
        with self._reading:
            for name in self._from_plugins:
                self._things.pop(name, None)
            self._from_plugins.clear()
            self._read = False

    def __getitem__(self, name: str) -> T:
        found = self._things.get(name)
        if found is None:
            self._plugins()
            found = self._things.get(name)
        if found is None:
            raise KeyError(name)
        return found

    def __iter__(self) -> Iterator[str]:
        self._plugins()
        return iter(list(self._things))

    def __len__(self) -> int:
        self._plugins()
        return len(self._things)

    def __contains__(self, name: object) -> bool:
        if name in self._things:
            return True
        self._plugins()
        return name in self._things
