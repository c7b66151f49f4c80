"""The errors evtribo raises, in one tree.

::

    EvtriboError
     +-- UserInputError            bad usage, configuration or input file (exit code 2)
     |    +-- ConfigError          study.toml, rig TOML, model parameters   (also ValueError)
     |    |    +-- RigConfigError  the [rig] table or its DBC                (also ValueError)
     |    +-- LogFormatError       a CAN log that cannot be read             (also ValueError)
     |    +-- SidecarError         a trial's JSON sidecar                    (also ValueError)
     |    +-- StudyError           the study folder's layout or names        (also ValueError)
     |    +-- OutputExistsError    refusing to overwrite without --force     (also FileExistsError)
     |         +-- LockedError     another process is writing it (--force does not override)
     |    +-- OutputBusyError      another process is writing that output    (also BlockingIOError)
     |    +-- ResultFolderError    a result folder that is partial, mixed or stale (also ValueError)
     +-- AcquisitionError          the bus or the disk failed while recording (exit code 1)
     +-- AnalysisError             the analysis could not produce a result    (exit code 1)
     +-- OutputWriteError          results could not be written (disk full); the old ones kept (1)

Every error can carry where it happened (``path``, ``line``, ``key``); ``str(err)`` puts that
first, the way compilers do: ``study.toml: key 'rig.dbc': file not found``.
"""

from __future__ import annotations

import os
import re
from typing import Any

#: Stands in a message for the option that overrides a refusal: the command line shows it as
#: ``--force``, Python (``str(err)``) as ``force=True``. Messages never spell either.
FORCE = "{force}"


class EvtriboError(Exception):
    """Root of every error evtribo raises on purpose.

    ``str(err)`` is the message as Python code sees it; :meth:`cli_text` as the command
    line prints it (an override named as the command's option, ``--force``).
    """

    exit_code = 1

    def __init__(
        self,
        message: str,
        *,
        path: str | os.PathLike[str] | None = None,
        line: int | None = None,
        key: str | None = None,
    ) -> None:
        self.message = message
        self.path = None if path is None else os.fspath(path)
        self.line = line
        self.key = key
        super().__init__(self.__str__())

    def location(self) -> str:
        """``file:line: key 'k'`` (the parts that are known), or an empty string."""
        parts = []
        if self.path is not None:
            parts.append(self.path if self.line is None else f"{self.path}:{self.line}")
        if self.key is not None:
            parts.append(f"key '{self.key}'")
        return ": ".join(parts)

    def _text(self, force: str) -> str:
        where = self.location()
        text = f"{where}: {self.message}" if where else self.message
        return text.replace(FORCE, force)

    def __str__(self) -> str:
        return self._text("force=True")

    def cli_text(self) -> str:
        """The message as the command line prints it."""
        return self._text("--force")

    def __reduce__(self) -> tuple[Any, ...]:  # picklable across worker processes, with
        # whatever was added to it (its notes: where a worker raised it)
        return (_rebuild, (type(self), self.message, self.path, self.line, self.key),
                dict(self.__dict__))


def _rebuild(cls: type[EvtriboError], message: str, path: str | None, line: int | None,
             key: str | None) -> EvtriboError:
    return cls(message, path=path, line=line, key=key)


def toml_error_line(err: BaseException) -> int | None:
    """The line number a ``tomllib.TOMLDecodeError`` names in its message.

    Parameters
    ----------
    err : BaseException
        The error ``tomllib`` raised.

    Returns
    -------
    int or None
        The line (1-based), None when the message names none.
    """
    m = re.search(r"line (\d+)", str(err))
    return int(m.group(1)) if m else None


def toml_error_key(err: BaseException, text: str) -> str | None:
    """The key (dotted, with its table) that a ``tomllib`` error of a key or a table given
    twice is about: TOML allows neither, and the error names only the line.

    Parameters
    ----------
    err : BaseException
        The error ``tomllib`` raised.
    text : str
        The document it was reading.

    Returns
    -------
    str or None
        ``"rig.dbc"``; None for another error.
    """
    msg = str(err)
    twice = re.search(r"Cannot declare \(((?:'[^']*',?\s*)+)\) twice", msg)
    if twice:
        return ".".join(re.findall(r"'([^']*)'", twice.group(1)))
    line = toml_error_line(err)
    if "Cannot overwrite a value" not in msg or line is None:
        return None
    table = ""
    for number, row in enumerate(text.splitlines()[:line], 1):
        header = re.match(r"\s*\[+\s*([^\[\]]+?)\s*\]+", row)
        if header and number < line:
            table = header.group(1)
        elif number == line:
            assign = re.match(r"\s*([^=\[]+?)\s*=", row)
            if assign is None:
                return None
            name, table = (re.sub(r"[\"' ]", "", x) for x in (assign.group(1), table))
            return f"{table}.{name}" if table else name
    return None


def toml_problem(err: BaseException, text: str) -> tuple[str, int | None, str | None]:
    """What a ``tomllib`` error says, for a message: its reason (for a key or table given
    twice, said so), its line and the key it is about.

    Parameters
    ----------
    err : BaseException
        The error ``tomllib`` raised.
    text : str
        The document it was reading.

    Returns
    -------
    reason : str
    line : int or None
    key : str or None
    """
    key = toml_error_key(err, text)
    reason = str(err) if key is None else f"given twice, which TOML does not allow ({err})"
    return reason, toml_error_line(err), key


def toml_key_line(text: str, table: str, key: str) -> int | None:
    """The line (1-based) where *key* is set in ``[table]`` of a TOML document's *text*.

    Finds ``key = ...`` under the header ``[table]`` (or ``table.key = ...`` / an inline
    ``table = {key = ...}`` elsewhere).

    Parameters
    ----------
    text : str
        The TOML document.
    table : str
        The dotted table name (``"rig.calibration"``; ``""`` for the top level).
    key : str
        The key in that table.

    Returns
    -------
    int or None
        The line (1-based), None when it cannot tell.
    """
    current = ""
    header = re.compile(r"^\s*\[\s*([^\[\]]+?)\s*\]\s*(#.*)?$")
    assign = re.compile(r"^\s*([A-Za-z0-9_.\-\"' ]+?)\s*=")
    for number, line in enumerate(text.splitlines(), 1):
        m = header.match(line)
        if m:
            current = m.group(1).replace(" ", "").replace('"', "")
            continue
        a = assign.match(line)
        if a is None:
            continue
        name = a.group(1).replace(" ", "").replace('"', "")
        full = f"{current}.{name}" if current else name
        if full == (f"{table}.{key}" if table else key):
            return number
        if full == table and re.search(rf"[{{,]\s*{re.escape(key)}\s*=", line):
            return number
    return None


class UserInputError(EvtriboError):
    """Bad usage, configuration or input: the user can fix it (exit code 2)."""

    exit_code = 2


class ConfigError(UserInputError, ValueError):
    """A configuration value is missing, of the wrong type or out of range."""


class RigConfigError(ConfigError):
    """The rig description (``[rig]`` of study.toml, a rig TOML or its DBC) is wrong."""


class LogFormatError(UserInputError, ValueError):
    """A CAN log cannot be read (unknown format, or a damaged line under ``--strict``)."""


class SidecarError(UserInputError, ValueError):
    """A trial's JSON sidecar is malformed or holds a forbidden value."""


class StudyError(UserInputError, ValueError):
    """The study folder's layout or names are wrong."""


class OutputExistsError(UserInputError, FileExistsError):
    """An output already exists and ``--force`` was not given."""


class LockedError(OutputExistsError):
    """Another process is writing this output right now (its lock file names it)."""


class OutputBusyError(UserInputError, BlockingIOError):
    """Another process is writing the same output (a result folder, a report) right now."""


class ResultFolderError(UserInputError, ValueError):
    """A result folder that is not one analysis's complete results (a file missing, changed
    or half-written, files of two analyses, or a model fit of another analysis)."""


class AcquisitionError(EvtriboError, OSError):
    """Recording failed (bus error, adapter gone, disk full); what was logged is kept."""


class AnalysisError(EvtriboError, RuntimeError):
    """The analysis could not produce a result from valid input."""


class OutputWriteError(EvtriboError, OSError):
    """Results could not be written (a full disk, a folder that is not writable); the
    results that were there before are left as they were."""


__all__ = [
    "FORCE",
    "AcquisitionError",
    "AnalysisError",
    "ConfigError",
    "EvtriboError",
    "LockedError",
    "LogFormatError",
    "OutputBusyError",
    "OutputExistsError",
    "OutputWriteError",
    "ResultFolderError",
    "RigConfigError",
    "SidecarError",
    "StudyError",
    "UserInputError",
    "toml_error_line",
    "toml_key_line",
]
