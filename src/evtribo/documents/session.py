"""A subject's recording session, ``STUDY/SUBJECT/session.json`` (spec §7): its version,
its fields, its reader and writer.

``evtribo session`` records a protocol's trials one after another. ``session.json`` holds the
protocol as given, the seed of its shuffle, the planned order (each trial's name and
excitation) and which trials are done, so that running the same command again continues
with the first trial not done::

    {"version": 1, "subject": "P01", "seed": 1,
     "protocol": {"session": {...}, "trial": [{...}]},
     "order": [{"trial": "run-01", "waveform": "square", "frequency_Hz": 10000.0,
                "amplitude_V": 60.0, "condition": "alternating"}, ...],
     "done": ["run-01"]}
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from evtribo.documents.names import validate_name
from evtribo.documents.sidecar import CONDITIONS, WAVEFORMS
from evtribo.errors import StudyError
from evtribo.store.files import DuplicateKeyError, atomic_write, loads_json_unique, read_limited

__all__ = ["EXCITATION_KEYS", "SESSION_FILE", "VERSION", "Session", "SessionTrial", "parse_session",
           "read_session", "write_session"]

#: Version of the format this module writes (and the newest it reads).
VERSION = 1
#: The file's name in the subject's folder.
SESSION_FILE = "session.json"
#: The excitation keys of a planned trial, as in its sidecar.
EXCITATION_KEYS = ("waveform", "frequency_Hz", "amplitude_V", "condition")


@dataclass(frozen=True)
class SessionTrial:
    """One trial of the planned order.

    Attributes
    ----------
    trial : str
        Its name (``run-01``).
    waveform : {"sine", "square"} or None
    frequency_Hz : float or None, Hz
    amplitude_V : float or None, V
    condition : {"on", "off", "alternating"} or None
    """

    trial: str
    waveform: str | None = None
    frequency_Hz: float | None = None
    amplitude_V: float | None = None
    condition: str | None = None


@dataclass(frozen=True)
class Session:
    """A subject's session: the protocol, its seed, the planned order, the trials done.

    Attributes
    ----------
    subject : str
    seed : int
        Seed of the order's shuffle.
    protocol : dict
        The protocol file's tables as given (``session``, ``trial``).
    order : tuple of SessionTrial
        The trials in the order they are recorded.
    done : tuple of str
        Names of the trials recorded, in the order they were.
    """

    subject: str
    seed: int
    protocol: dict[str, Any] = field(default_factory=dict)
    order: tuple[SessionTrial, ...] = ()
    done: tuple[str, ...] = ()

    def next_trial(self) -> SessionTrial | None:
        """The first trial of the order not done (None: the session is complete)."""
        return next((t for t in self.order if t.trial not in self.done), None)

    def with_done(self, trial: str) -> Session:
        """This session with *trial* (a name of its order) done as well."""
        if trial not in {t.trial for t in self.order}:
            raise ValueError(f"{trial!r} is not a trial of the session")
        return self if trial in self.done else replace(self, done=(*self.done, trial))

    def to_dict(self) -> dict[str, Any]:
        """The JSON-ready mapping :func:`write_session` writes."""
        return {"version": VERSION, "subject": self.subject, "seed": self.seed,
                "protocol": self.protocol,
                "order": [{"trial": t.trial, **{k: getattr(t, k) for k in EXCITATION_KEYS}}
                          for t in self.order],
                "done": list(self.done)}


_KINDS = {int: "an integer", list: "a list", dict: "an object"}


def _get(data: dict[str, Any], key: str, kind: type, path: Path) -> Any:
    """``data[key]``, if it is a *kind* (not a bool for an integer), else StudyError."""
    value = data.get(key)
    if not isinstance(value, kind) or isinstance(value, bool):
        raise StudyError(f"expected {_KINDS[kind]}, got {value!r}", path=path, key=key)
    return value


def _planned(item: object, i: int, path: Path) -> SessionTrial:
    key = f"order[{i}]"
    if not isinstance(item, dict):
        raise StudyError(f"expected an object, got {item!r}", path=path, key=key)
    name = validate_name(item.get("trial"), what="trial", path=path, key=f"{key}.trial")
    for k, allowed in (("waveform", WAVEFORMS), ("condition", CONDITIONS)):
        if item.get(k) is not None and item[k] not in allowed:
            raise StudyError(f"unknown value {item[k]!r}; allowed: {', '.join(allowed)}",
                             path=path, key=f"{key}.{k}")
    for k in ("frequency_Hz", "amplitude_V"):
        v = item.get(k)
        if v is not None and (isinstance(v, bool) or not isinstance(v, int | float)
                              or not math.isfinite(v) or v < 0):
            raise StudyError(f"expected a finite number >= 0, got {v!r}", path=path,
                             key=f"{key}.{k}")
    return SessionTrial(trial=name, waveform=item.get("waveform"),
                        frequency_Hz=None if item.get("frequency_Hz") is None
                        else float(item["frequency_Hz"]),
                        amplitude_V=None if item.get("amplitude_V") is None
                        else float(item["amplitude_V"]),
                        condition=item.get("condition"))


def parse_session(data: object, *, path: str | os.PathLike[str]) -> Session:
    """Validate a session's decoded JSON.

    Parameters
    ----------
    data : object
        The decoded JSON.
    path : path-like
        The file, for messages.

    Returns
    -------
    Session

    Raises
    ------
    StudyError
        Naming *path* and the key at fault (a newer version than :data:`VERSION`, a
        missing or mistyped key, a trial done that is not in the order).
    """
    p = Path(path)
    if not isinstance(data, dict):
        raise StudyError(f"expected a JSON object, got {type(data).__name__}", path=p)
    version = _get(data, "version", int, p)
    if not 1 <= version <= VERSION:
        raise StudyError(f"version {version} is not one this evtribo reads (1 to {VERSION}); "
                         "a newer evtribo wrote it", path=p, key="version")
    order = tuple(_planned(item, i, p)
                  for i, item in enumerate(_get(data, "order", list, p)))
    names = [t.trial for t in order]
    if len(set(names)) != len(names):
        raise StudyError("a trial appears twice in the order", path=p, key="order")
    done = _get(data, "done", list, p)
    for name in done:
        if name not in names:
            raise StudyError(f"trial {name!r} is done but not in the order", path=p,
                             key="done")
    return Session(subject=validate_name(data.get("subject"), what="subject", path=p,
                                         key="subject"),
                   seed=_get(data, "seed", int, p), protocol=_get(data, "protocol", dict, p),
                   order=order, done=tuple(done))


def read_session(path: str | os.PathLike[str]) -> Session:
    """Read and validate a ``session.json`` (a regular file of at most 1 MiB).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    Session

    Raises
    ------
    StudyError
        Unreadable, not UTF-8, not JSON (with its line), or a bad key.
    FileNotFoundError
        No such file (a session not begun).
    """
    p = Path(path)
    try:
        text = read_limited(p, StudyError, what=SESSION_FILE).decode("utf-8")
    except UnicodeDecodeError as err:
        raise StudyError(f"not UTF-8 text ({err.reason} at byte {err.start})", path=p) from err
    try:
        data = loads_json_unique(text)
    except DuplicateKeyError as err:
        raise StudyError(f"invalid JSON: {err} (JSON allows a key once in an object; a reader "
                    "would keep either)", path=p, line=err.line, key=err.key) from err
    except json.JSONDecodeError as err:
        raise StudyError(f"invalid JSON: {err.msg} (column {err.colno})", path=p,
                         line=err.lineno) from err
    except RecursionError as err:
        raise StudyError("invalid JSON: nested too deeply", path=p) from err
    return parse_session(data, path=p)


def write_session(path: str | os.PathLike[str], session: Session) -> Path:
    """Write *session* atomically and durably (it is rewritten after each trial).

    Parameters
    ----------
    path : path-like
        The ``session.json``.
    session : Session

    Returns
    -------
    Path
        *path*.
    """
    text = json.dumps(session.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"
    return atomic_write(path, text, durable=True)
