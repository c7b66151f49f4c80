"""``summary.json``: what one ``evtribo analyze`` did (study, inputs and their hashes, rig,
software, settings, counts, warnings, the tables written and their hashes, ``run_id``).

The document is a JSON object written with two-space indentation, non-ASCII characters as
they are, and a final newline (:func:`summary_text`); its keys are listed in
:data:`SUMMARY_KEYS` in the order ``analyze`` writes them. Its ``summary_version``
(:data:`SUMMARY_VERSION`) is the version of its shape: 2 keeps each warning as a record
(:class:`~evtribo.warning.record.WarningRecord`'s object: ``kind``, ``effect``, ``text``, the
scope's ``subject``, ``trial``, ``waveform``, ``frequency_Hz``, ``amplitude_V``, ``values``,
``source``); a document without it (version 1, written by an earlier evtribo) keeps each
warning as a line of text, lifted into a record when read
(:func:`evtribo.warning.legacy.lift_all`).

:func:`read_summary` gives a :class:`Summary`: the document as a read-only mapping (every key
as written), with the keys other modules rely on as typed attributes, checked when read.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evtribo.errors import ResultFolderError
from evtribo.store.files import atomic_write, read_regular
from evtribo.warning.legacy import lift_all
from evtribo.warning.record import WarningRecord

__all__ = ["SUMMARY_FILE", "SUMMARY_KEYS", "SUMMARY_VERSION", "InputRecord", "Summary",
           "read_summary", "summary_text", "write_summary"]

#: The file's name in a result folder.
SUMMARY_FILE = "summary.json"
#: Version of the shape of the document, its ``summary_version`` (none: 1, warnings as
#: lines of text).
SUMMARY_VERSION = 2
#: The keys ``evtribo analyze`` writes, in its order.
SUMMARY_KEYS: tuple[str, ...] = (
    "study", "run_id", "evtribo_version", "summary_version", "created", "study_dir", "started",
    "inputs", "rig", "software", "host", "subjects", "trials", "trials_analysed", "failed_trials",
    "duplicate_trials", "windows_on", "windows_off", "frames", "dropped_frames",
    "skipped_lines", "strict", "jobs", "calibration", "settings", "warnings", "outputs",
    "output_sha256", "elapsed_s")


@dataclass(frozen=True)
class InputRecord:
    """One input of the analysis as ``summary.json`` records it (``inputs``).

    Attributes
    ----------
    file : str
        The file, relative to the study folder (or as the study names it, for a DBC
        outside it).
    role : str
        ``study``, ``dbc``, ``log`` or ``sidecar``.
    bytes : int or None
        Its size when hashed.
    sha256 : str
        Its SHA-256 when the analysis started.
    """

    file: str
    role: str
    bytes: int | None
    sha256: str


@dataclass(frozen=True)
class Summary(Mapping[str, Any]):
    """``summary.json`` as read: a read-only mapping of its keys, and typed attributes.

    Attributes
    ----------
    data : dict
        The whole document.
    path : Path or None
        Where it was read from.
    """

    data: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.data)

    def __len__(self) -> int:
        return len(self.data)

    def _typed(self, key: str, kind: type | tuple[type, ...], default: Any) -> Any:
        value = self.data.get(key, default)
        if value is None or isinstance(value, kind):
            return default if value is None else value
        raise ResultFolderError(f"key {key!r}: a {type(value).__name__} where evtribo "
                                "analyze writes a "
                                f"{getattr(kind, '__name__', 'value')} (summary.json edited?)",
                                path=self.path)

    def check(self) -> Summary:
        """Raise :class:`ResultFolderError` naming the first key of the wrong kind; return
        self."""
        for name in ("study", "run_id", "study_dir", "evtribo_version", "version", "inputs", "rig",
                     "software", "settings", "warnings", "failed_trials", "output_sha256"):
            getattr(self, name)
        return self

    @property
    def version(self) -> int:
        """The shape's version (``summary_version``; 1 where the document has none)."""
        value = self._typed("summary_version", int, 1)
        return int(value)

    @property
    def study(self) -> str:
        """The study's name ("" when not recorded)."""
        return str(self._typed("study", str, ""))

    @property
    def run_id(self) -> str | None:
        """The analysis's identifier (None in results of an older evtribo)."""
        value = self._typed("run_id", str, None)
        return None if value is None else str(value)

    @property
    def study_dir(self) -> str | None:
        """The study folder, absolute, as it was when analysed."""
        value = self._typed("study_dir", str, None)
        return None if value is None else str(value)

    @property
    def evtribo_version(self) -> str:
        """The evtribo that analysed ("" when not recorded)."""
        return str(self._typed("evtribo_version", str, ""))

    @property
    def inputs(self) -> tuple[InputRecord, ...]:
        """The inputs hashed when the analysis started."""
        out = []
        for rec in self._typed("inputs", list, []):
            if not isinstance(rec, dict) or not isinstance(rec.get("sha256"), str):
                raise ResultFolderError("key 'inputs': an entry without its sha256 "
                                        "(summary.json edited?)", path=self.path)
            size = rec.get("bytes")
            out.append(InputRecord(str(rec.get("file", "")), str(rec.get("role", "")),
                                   size if isinstance(size, int) else None, rec["sha256"]))
        return tuple(out)

    @property
    def rig(self) -> dict[str, Any]:
        """The rig's roles (signals and DBC) the analysis used."""
        return dict(self._typed("rig", dict, {}))

    @property
    def software(self) -> dict[str, Any]:
        """Versions of evtribo, Python and the libraries that analysed."""
        return dict(self._typed("software", dict, {}))

    @property
    def settings(self) -> dict[str, Any]:
        """The analysis's settings."""
        return dict(self._typed("settings", dict, {}))

    @property
    def warnings(self) -> list[WarningRecord]:
        """The analysis's warnings as records, in the order said (a version 1 document's
        lines lifted: :func:`evtribo.warning.legacy.lift_all`, their scopes read against
        the study's subjects)."""
        items = self._typed("warnings", list, [])
        if all(isinstance(w, str) for w in items):  # version 1's lines
            subjects = self.data.get("subjects")
            return lift_all(items, [str(s) for s in subjects]
                            if isinstance(subjects, list) else None)
        out = []
        for k, w in enumerate(items):
            try:
                out.append(WarningRecord.from_json(w))
            except ValueError as err:
                raise ResultFolderError(f"key 'warnings', item {k + 1}: {err} (summary.json "
                                        "edited?)", path=self.path) from None
        return out

    @property
    def failed_trials(self) -> list[dict[str, Any]]:
        """``{"trial": "<subject>/<trial>", "error": ...}`` of each trial not analysed."""
        return [f for f in self._typed("failed_trials", list, []) if isinstance(f, dict)]

    @property
    def output_sha256(self) -> dict[str, str] | None:
        """SHA-256 of each table written (None in results of an older evtribo)."""
        value = self.data.get("output_sha256")
        return None if value is None else dict(self._typed("output_sha256", dict, {}))


def summary_text(summary: Mapping[str, Any]) -> str:
    """The text of ``summary.json`` holding *summary*.

    Parameters
    ----------
    summary : mapping
        The document (keys as in :data:`SUMMARY_KEYS`).

    Returns
    -------
    str
        Two-space-indented JSON, non-ASCII characters as they are, values JSON does not
        know as their ``str``, and a final newline.
    """
    return json.dumps(summary, indent=2, ensure_ascii=False, default=str) + "\n"


def write_summary(path: str | os.PathLike[str], summary: Mapping[str, Any]) -> Path:
    """Write *summary* to *path*, whole or not at all.

    Parameters
    ----------
    path : path-like
        The file (``<out>/summary.json``, or its place in a staging folder).
    summary : mapping
        The document (see :func:`summary_text`).

    Returns
    -------
    Path
        The file written.
    """
    return atomic_write(path, summary_text(summary))


def read_summary(path: str | os.PathLike[str], *, again: str = "",
                 follow: bool = True) -> Summary:
    """Read ``summary.json``.

    Parameters
    ----------
    path : path-like
        The file.
    again : str
        What mends a damaged file, appended to the message (``"; run ..."``).
    follow : bool
        Follow a symbolic link (False: a link is refused).

    Returns
    -------
    Summary
        The document (a JSON value that is not an object is kept under ``"summary"``).

    Raises
    ------
    ResultFolderError
        The file is missing, not a regular file, or not valid JSON, or a key evtribo reads
        is of the wrong kind (naming the key).
    """
    file = Path(path)
    try:
        text = read_regular(file, ResultFolderError, what="summary.json",
                            follow=follow).decode("utf-8")
    except FileNotFoundError as err:
        raise ResultFolderError(f"missing{again}", path=file) from err
    except PermissionError as err:
        raise ResultFolderError(f"cannot read: {err.strerror}", path=file) from None
    except UnicodeDecodeError as err:
        raise ResultFolderError(f"not valid JSON ({err}): half-written?{again}",
                                path=file) from err
    try:
        loaded = json.loads(text)
    except json.JSONDecodeError as err:
        raise ResultFolderError(f"not valid JSON ({err}): half-written?{again}",
                                path=file) from err
    return Summary(loaded if isinstance(loaded, dict) else {"summary": loaded}, file).check()
