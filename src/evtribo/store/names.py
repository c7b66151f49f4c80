"""The names of what evtribo writes: those a user gives (``-o``, ``--out``), checked before
anything is written, and the working names evtribo makes of them (a lock, a new folder, a
temporary file beside an output), made to fit in a file name's 255 bytes.

A name a user gives is written as given, whatever it holds (spaces, a backslash, a leading
``.`` or ``-``, bytes that are not UTF-8 text), and recorded as given in its folder's
manifest (:mod:`evtribo.store.owned`), with three exceptions, each refused by
:func:`check_new_path` before anything is written (exit 2, naming it):

- a control character (a tab, a newline, a line separator): such a name could not be shown
  on one line of a message or a listing, and is nearly always a slip of the keyboard or of a
  paste;
- a name of evtribo's own working files, ``.evtribo-*`` (a folder's manifest, a commit
  record) or ``.NAME.evtribo-*`` (an output's lock, its new folder, a temporary file): evtribo
  creates, reads and removes those itself;
- more than 255 bytes, the most a Linux file system holds in one name.

Only what a command is to create is checked: an output file's own name, and each folder on
its way that does not exist yet. A folder that exists is the user's, whatever its name.

A working name is ``.NAME`` followed by its suffix (``.evtribo-lock``); for a NAME so long
that this would pass 255 bytes, it is the start of NAME, ``~`` and 16 hex digits of NAME's
SHA-256 (:func:`working_prefix`): the same for every process, and a different one for
another NAME.
"""

from __future__ import annotations

import hashlib
import os
import unicodedata
from pathlib import Path

from evtribo.errors import UserInputError

__all__ = ["LOCK_SUFFIX", "NAME_MAX", "RESERVED", "STAGE_INFIX", "check_new_path", "companion",
           "leading_bytes", "name_problem", "shown", "working_home", "working_prefix"]

#: The longest file name Linux file systems hold, bytes.
NAME_MAX = 255
#: What the names of evtribo's own working files hold (``.evtribo-manifest.json``,
#: ``.OUT.evtribo-lock``).
RESERVED = ".evtribo-"
#: Longest path the system takes, bytes (PATH_MAX, its terminating NUL left out).
_PATH_MAX = 4095
#: Unicode categories of the characters no name evtribo writes holds: control characters,
#: line and paragraph separators.
_UNSHOWN = frozenset({"Cc", "Zl", "Zp"})
#: Hex digits of a long name's SHA-256 in its working names.
_HASH_DIGITS = 16
#: What an output's lock file's name ends with, and what its new folders' names hold.
LOCK_SUFFIX, STAGE_INFIX = ".evtribo-lock", ".evtribo-new-"
#: Bytes the longest working name adds to its prefix: a new folder's infix and 32 hex digits.
_SUFFIX_ROOM = max(len(LOCK_SUFFIX), len(STAGE_INFIX) + 32)


def _bytes(name: str) -> bytes | None:
    """*name* as the file system holds it (None: no file name can hold it)."""
    try:
        return os.fsencode(name)
    except UnicodeEncodeError:
        return None


def _unshown(name: str) -> str | None:
    """The first control character (or line separator) of *name*, if any."""
    return next((c for c in name if unicodedata.category(c) in _UNSHOWN), None)


def name_problem(name: str) -> str | None:
    """What keeps *name* from being one that evtribo writes and records, in words (None:
    nothing).

    Parameters
    ----------
    name : str
        One name (no ``/``), as Python holds it (bytes that are not UTF-8 as the file
        system's encoding decodes them).

    Returns
    -------
    str or None
        ``"holds a control character (a tab, \\t): ..."``, or None.
    """
    raw = _bytes(name)
    if raw is None or b"\0" in raw or b"/" in raw or name in ("", ".", ".."):
        return "is not a name a file can have"
    char = _unshown(name)
    if char is not None:
        return (f"holds a control character ({ascii(char)[1:-1]}): a name that cannot be "
                "shown on one line, which evtribo does not write; choose another name")
    if name.startswith(".") and RESERVED in name:
        return ("is named like evtribo's own working files (.evtribo-*, .NAME.evtribo-*: "
                "manifests, locks, new folders, temporary files), which evtribo makes and "
                "removes itself; choose another name")
    if len(raw) > NAME_MAX:
        return (f"has a name of {len(raw)} bytes, and a file name holds at most {NAME_MAX} "
                "(Linux); choose a shorter one")
    return None


def shown(path: str | os.PathLike[str]) -> str:
    """*path* as a message shows it: its control characters escaped (``a\\tb.csv``), so that
    the message stays on one line.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    str
    """
    text = os.fspath(path)
    return "".join(ascii(c)[1:-1] if unicodedata.category(c) in _UNSHOWN else c for c in text)


def check_new_path(path: str | os.PathLike[str], *, key: str | None = None,
                   folder: bool = False) -> None:
    """Refuse, before anything is written, an output whose name evtribo could not write or
    record (see the module's notes): its own name (for a file), and that of each folder on
    its way that is to be created.

    Parameters
    ----------
    path : path-like
        The output (a file, or with *folder* a folder), as the user gave it.
    key : str, optional
        The option that named it (``"-o"``).
    folder : bool
        The output is a folder (its name is checked only if it is to be created).

    Raises
    ------
    UserInputError
        Naming the output (its control characters escaped) and what is wrong (exit 2).
    """
    full = Path(os.path.abspath(path))
    names = [] if folder else [full.name]
    here = full
    while here != here.parent and not os.path.lexists(here):
        names.append(here.name)
        here = here.parent
    for name in dict.fromkeys(names):
        problem = name_problem(name)
        if problem is not None:
            where = "" if name == full.name else f"the folder {shown(name)} it would create "
            raise UserInputError(f"{where}{problem}", path=shown(path), key=key)
    raw = _bytes(os.fspath(full)) or b""
    if len(raw) > _PATH_MAX - NAME_MAX:
        raise UserInputError(f"the path is {len(raw)} bytes long, too long to write beside "
                             f"(the system takes paths of at most {_PATH_MAX} bytes); choose "
                             "a shorter one", path=shown(path), key=key)


def leading_bytes(name: str, limit: int) -> str:
    """The longest start of *name* that the file system holds in at most *limit* bytes (a
    character is never cut in two).

    Parameters
    ----------
    name : str
    limit : int
        Bytes.

    Returns
    -------
    str
    """
    size = 0
    for i, char in enumerate(name):
        size += len(_bytes(char) or b"????")
        if size > limit:
            return name[:i]
    return name


def companion(stem: str, suffix: str) -> str:
    """The name of a file or folder that goes with another (``report`` and ``_files``:
    ``report_files``), within 255 bytes: for a long *stem*, its start, ``~`` and 16 hex
    digits of its SHA-256.

    Parameters
    ----------
    stem : str
    suffix : str

    Returns
    -------
    str
    """
    raw = _bytes(stem) or stem.encode("utf-8", "surrogatepass")
    if len(raw) + len(_bytes(suffix) or b"") <= NAME_MAX:
        return f"{stem}{suffix}"
    digest = hashlib.sha256(raw).hexdigest()[:_HASH_DIGITS]
    room = NAME_MAX - len(_bytes(suffix) or b"") - 1 - _HASH_DIGITS
    return f"{leading_bytes(stem, room)}~{digest}{suffix}"


def working_prefix(name: str, room: int) -> str:
    """The start of a working name made of *name* (``.NAME``), leaving *room* bytes for what
    follows it within a file name's 255 (see the module's notes).

    Parameters
    ----------
    name : str
        The output's name.
    room : int
        Bytes of the longest suffix a working name adds (``.evtribo-new-`` and 32 hex
        digits).

    Returns
    -------
    str
        ``.NAME``, or ``.START~HASH`` for a long NAME.
    """
    return companion(f".{name}", "\0" * room)[: -room or None]


def working_home(unit: Path) -> tuple[Path, str]:
    """Where the lock file and the new folders of an output written as one unit go
    (:mod:`evtribo.store.resultdir`), and the prefix of their names: beside it (``.NAME``, or
    :func:`working_prefix`'s for a long name), or inside it when it is a folder on its own
    file system (a mount point: a rename from beside it would cross file systems) or in a
    folder this process cannot write.

    Parameters
    ----------
    unit : Path
        The output, its links resolved.

    Returns
    -------
    folder : Path
    prefix : str
    """
    if unit.is_dir() and (os.path.ismount(unit) or not os.access(unit.parent, os.W_OK)):
        return unit, ""
    return unit.parent, working_prefix(unit.name, _SUFFIX_ROOM)
