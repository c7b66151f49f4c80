"""A subject's session, ``STUDY/SUBJECT/session.json`` (spec §7): the protocol, the seed, the
planned order and which trials are done.

``evtribo session`` writes it before the first trial and after each one (atomically, and
durably: it is what lets a stopped session go on without re-recording anything). Version
:data:`VERSION`:

.. code-block:: json

    {"version": 1, "subject": "P01", "protocol_file": "/abs/meyer2013.toml",
     "protocol": {"session": {...}, "trial": [...]}, "seed": 1,
     "started": "2026-11-23T08:00:00Z", "updated": "...",
     "planned": [{"trial": "run-01", "waveform": "square", "frequency_Hz": 10000.0,
                  "amplitude_V": 100.0, "condition": "alternating", "notes": "",
                  "status": "done", "rejected": []}, ...]}

``status`` is ``"pending"`` or ``"done"``; ``rejected`` names the recordings of that trial the
operator chose to redo (kept under ``SUBJECT/rejected/``).
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from typing import Any

from evtribo.errors import StudyError
from evtribo.files import atomic_write, read_limited

__all__ = ["FILENAME", "VERSION", "PlannedEntry", "SessionDocument", "read_session",
           "write_session"]

#: The document's name in a subject's folder.
FILENAME = "session.json"
#: Version of the document's layout.
VERSION = 1
#: Keys of a planned entry.
_ENTRY_KEYS = ("trial", "waveform", "frequency_Hz", "amplitude_V", "condition", "notes",
               "status", "rejected")
STATUSES = ("pending", "done")


@dataclass
class PlannedEntry:
    """One planned trial and how far it got.

    Attributes
    ----------
    trial : str
        Its name (``run-01``), in the order recorded.
    waveform, frequency_Hz, amplitude_V, condition, notes
        Its excitation (spec §7's ``[[trial]]`` keys, lists expanded).
    status : {"pending", "done"}
    rejected : list of str
        Names under ``rejected/`` of recordings the operator chose to redo.
    """

    trial: str
    waveform: str
    frequency_Hz: float
    amplitude_V: float
    condition: str
    notes: str = ""
    status: str = "pending"
    rejected: list[str] = field(default_factory=list)


@dataclass
class SessionDocument:
    """The content of ``session.json``.

    Attributes
    ----------
    subject : str
    protocol_file : str
        The protocol's path when the session began.
    protocol : dict
        The protocol as read (``Protocol.to_dict()``): a changed file is noticed.
    seed : int
        Seed of the shuffle.
    planned : list of PlannedEntry
    started, updated : str
        UTC times, ISO 8601.
    version : int
    """

    subject: str
    protocol_file: str
    protocol: dict[str, Any]
    seed: int
    planned: list[PlannedEntry]
    started: str
    updated: str
    version: int = VERSION

    @property
    def next_pending(self) -> PlannedEntry | None:
        """The first trial not done, or None when all are."""
        return next((e for e in self.planned if e.status != "done"), None)

    @property
    def done(self) -> int:
        """Trials done."""
        return sum(e.status == "done" for e in self.planned)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, keys in the documented order."""
        d = asdict(self)
        return {"version": d.pop("version"), **d}


def write_session(path: str | os.PathLike[str], doc: SessionDocument) -> None:
    """Write *doc* to *path* atomically and durably.

    Parameters
    ----------
    path : path-like
        ``SUBJECT/session.json``.
    doc : SessionDocument
    """
    atomic_write(path, json.dumps(doc.to_dict(), indent=2) + "\n", durable=True)


def read_session(path: str | os.PathLike[str]) -> SessionDocument:
    """Read a ``session.json``.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    SessionDocument

    Raises
    ------
    StudyError
        Not JSON, a newer version, or a missing or malformed key; naming the file and key.
    """
    src = os.fspath(path)
    raw = read_limited(path, StudyError, what="session file")
    try:
        data = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise StudyError(f"not valid JSON: {err}", path=src) from err
    if not isinstance(data, dict):
        raise StudyError("expected a JSON object", path=src)
    version = data.get("version")
    if version != VERSION:
        raise StudyError(f"version {version!r} of the session file; this evtribo reads "
                         f"version {VERSION}", path=src, key="version")
    try:
        planned = []
        for i, e in enumerate(data["planned"]):
            if not isinstance(e, dict) or set(e) - set(_ENTRY_KEYS) \
                    or e.get("status") not in STATUSES:
                raise StudyError("malformed planned trial", path=src, key=f"planned[{i}]")
            planned.append(PlannedEntry(**e))
        return SessionDocument(
            subject=str(data["subject"]), protocol_file=str(data["protocol_file"]),
            protocol=dict(data["protocol"]), seed=int(data["seed"]), planned=planned,
            started=str(data["started"]), updated=str(data["updated"]))
    except KeyError as err:
        raise StudyError("missing key", path=src, key=str(err.args[0])) from err
    except (TypeError, ValueError) as err:
        raise StudyError(f"malformed: {err}", path=src) from err
