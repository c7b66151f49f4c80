"""The manifest of a folder evtribo writes into: which files it wrote there, with their bytes.

Every folder evtribo writes an output into holds a manifest, :data:`MANIFEST`
(``.evtribo-manifest.json``): each name evtribo wrote a file at (relative to the folder),
the command that last wrote it (``analyze``, ``compare``, ``report``, ``decode``...), and
the SHA-256 of every version it wrote there (the last :data:`HISTORY`). A file is evtribo's
(:func:`owned`) when the manifest of the folder it was written into lists its name, for one
of the commands asked about, with the bytes it has now (a file evtribo removed and a user
restored byte for byte is still the file it wrote). What evtribo does with that is
:mod:`evtribo.store.owned`'s.

Names are taken as they are written, never through a symbolic link: a name whose folders
include a link (:func:`plain_path` gives None) names nothing of evtribo's. Any name a user
may give an output is recorded as given (:mod:`evtribo.store.names`: bytes that are not UTF-8
text, a backslash, a leading ``.``), in JSON that escapes what is not ASCII, and read back
as it was written; a record of a name no evtribo command writes (an older evtribo's) counts
for nothing, and the others are read. A manifest that cannot be read lists nothing (a
warning names it); one whose name something else than a regular file takes (a folder, a
link) is refused before anything is written beside it (:func:`check_manifest`). Changes to
a manifest are made under an exclusive ``flock`` of its folder, so that two commands
writing into the same folder keep each other's records.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import stat
from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

from evtribo.errors import UserInputError
from evtribo.store.files import atomic_write, read_limited
from evtribo.store.names import name_problem

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None  # type: ignore[assignment]

log = logging.getLogger(__name__)

__all__ = ["HISTORY", "MANIFEST", "Entry", "check_manifest", "file_sha256", "folder_lock",
           "output_name", "owned", "plain_path", "read_manifest", "record"]

#: The manifest of a folder evtribo writes into.
MANIFEST = ".evtribo-manifest.json"
#: Largest manifest read, bytes.
_MAX_BYTES = 16 << 20
#: Versions of a name remembered (each one's SHA-256).
HISTORY = 32
_HEX = frozenset("0123456789abcdef")


@dataclass(frozen=True)
class Entry:
    """One name of a manifest.

    Attributes
    ----------
    sha256 : str
        The SHA-256 of the bytes evtribo wrote there last, 64 hex digits.
    by : str
        The command that wrote it (``"analyze"``).
    written : tuple of str
        The SHA-256 of every version evtribo wrote there (oldest first), *sha256* included.
    """

    sha256: str
    by: str
    written: tuple[str, ...] = ()

    def holds(self, digest: str | None) -> bool:
        """Whether bytes of SHA-256 *digest* are a version evtribo wrote at this name."""
        return digest is not None and (digest == self.sha256 or digest in self.written)


def output_name(rel: str, *, hidden: bool = False) -> bool:
    """Whether *rel* is a name evtribo writes inside a folder: relative, at most three parts
    deep, none of them empty, ``.`` or ``..``, hidden (unless *hidden*), or one that
    :func:`~evtribo.store.names.name_problem` refuses (a control character, evtribo's own
    ``.evtribo-*`` working files, more than 255 bytes).

    Parameters
    ----------
    rel : str
        A name relative to the folder (``figures/fit_P01.png``).
    hidden : bool
        Allow names beginning with ``.`` (a user's ``-o .notes.csv``).

    Returns
    -------
    bool
    """
    if not isinstance(rel, str) or not rel or rel.startswith("/"):
        return False
    parts = rel.split("/")
    return len(parts) <= 3 and all(
        p not in ("", ".", "..") and (hidden or not p.startswith("."))
        and name_problem(p) is None for p in parts)


def plain_path(root: str | os.PathLike[str], rel: str) -> Path | None:
    """``root / rel`` when *rel* is an :func:`output_name` (hidden names allowed) and none
    of its existing parts below *root* is a symbolic link (the last one included), else
    None.

    Parameters
    ----------
    root : path-like
        The folder (it may itself be reached through a link: the user's choice).
    rel : str

    Returns
    -------
    Path or None
    """
    if not output_name(rel, hidden=True):
        return None
    path = Path(root)
    for part in rel.split("/"):
        path = path / part
        try:
            if stat.S_ISLNK(os.lstat(path).st_mode):
                return None
        except FileNotFoundError:
            break  # nothing below a missing part exists
        except OSError:
            return None
    return Path(root) / rel


def file_sha256(path: Path) -> str | None:
    """SHA-256 of *path* if it is a regular file (never through a link), else None.

    Parameters
    ----------
    path : Path

    Returns
    -------
    str or None
    """
    try:
        data = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0)
                       | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return None
    with os.fdopen(data, "rb", buffering=0) as fh:
        if not stat.S_ISREG(os.fstat(data).st_mode):
            return None
        return hashlib.file_digest(fh, "sha256").hexdigest()


def _entries(doc: object) -> dict[str, Entry]:
    if not isinstance(doc, dict) or doc.get("evtribo") != "manifest" or \
            not isinstance(doc.get("files"), dict):
        raise ValueError("not a manifest of evtribo's")
    out = {}
    for rel, rec in doc["files"].items():
        hashes = rec.get("sha256") if isinstance(rec, dict) else None
        if not (isinstance(hashes, list) and hashes and isinstance(rec.get("by"), str)
                and all(isinstance(h, str) and len(h) == 64 and set(h) <= _HEX
                        for h in hashes)):
            raise ValueError(f"a record that is not one of evtribo's ({rel!r})")
        if output_name(rel, hidden=True):
            out[rel] = Entry(hashes[-1], rec["by"], tuple(hashes))
        else:  # a name no evtribo command writes now (an older one's): it counts for nothing
            log.info("%r: a name evtribo does not write; its record left out", rel)
    return out


def read_manifest(folder: str | os.PathLike[str], *, quiet: bool = False
                  ) -> dict[str, Entry]:
    """The files the manifest of *folder* lists (none when there is no manifest, or when
    it is not a regular file evtribo wrote: a warning names it).

    Parameters
    ----------
    folder : path-like
    quiet : bool
        Say nothing of a manifest that cannot be read (one looked at in passing).

    Returns
    -------
    dict of str to Entry
        By name relative to *folder*.
    """
    path = Path(folder) / MANIFEST
    try:
        data = read_limited(path, UserInputError, limit=_MAX_BYTES, what="manifest",
                            follow=False)
        return _entries(json.loads(data))
    except FileNotFoundError:
        return {}
    except (OSError, UserInputError, ValueError, UnicodeDecodeError) as err:
        log.log(logging.DEBUG if quiet else logging.WARNING,
                "%s: not read, so none of the files beside it counts as evtribo's (%s)",
                path, getattr(err, "message", err))
        return {}


def owned(folder: str | os.PathLike[str], rel: str, by: Collection[str] | None = None, *,
          manifest: Mapping[str, Entry] | None = None) -> str | None:
    """The SHA-256 of ``folder / rel`` if evtribo wrote it (by one of the commands *by*)
    and it has bytes evtribo wrote there; None otherwise (a user's file, an edited one, a
    link, no such file).

    Parameters
    ----------
    folder : path-like
        The folder whose manifest records the file.
    rel : str
        Its name relative to *folder*.
    by : collection of str, optional
        The commands whose files count (default: any).
    manifest : mapping, optional
        *folder*'s manifest, already read.

    Returns
    -------
    str or None
    """
    entry = (read_manifest(folder) if manifest is None else manifest).get(rel)
    path = plain_path(folder, rel)
    if entry is None or path is None or (by is not None and entry.by not in by):
        return None
    digest = file_sha256(path)
    return digest if entry.holds(digest) else None


def _not_a_file(mode: int) -> str:
    return ("a folder" if stat.S_ISDIR(mode) else "a symbolic link" if stat.S_ISLNK(mode)
            else "a FIFO (named pipe)" if stat.S_ISFIFO(mode) else "not a regular file")


def check_manifest(folder: str | os.PathLike[str]) -> None:
    """Refuse to write into *folder* when its manifest's name is taken by something that is
    not a regular file (a folder, a link, a FIFO): evtribo could not record what it writes,
    and replaces nothing it did not write.

    Parameters
    ----------
    folder : path-like

    Raises
    ------
    UserInputError
        Naming the manifest (exit code 2).
    """
    path = Path(folder) / MANIFEST
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as err:
        raise UserInputError(f"cannot be looked at ({err.strerror}): evtribo records there "
                             f"which files it wrote into {folder}", path=path) from None
    if not stat.S_ISREG(mode):
        raise UserInputError(
            f"is {_not_a_file(mode)}, not evtribo's manifest (the record of the files it "
            f"writes into {folder}, the only ones it replaces): nothing is written there until "
            "it is moved away", path=path)


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike[str]) -> Iterator[None]:
    """Hold an exclusive ``flock`` of *folder* (its manifest's changes are made under it).

    Parameters
    ----------
    folder : path-like
        An existing folder.

    Yields
    ------
    None
    """
    fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0)
                 | getattr(os, "O_CLOEXEC", 0))
    try:
        if fcntl is not None:
            with contextlib.suppress(OSError):  # a file system without locks
                fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def record(folder: str | os.PathLike[str], add: Mapping[str, Entry], *,
           locked: bool = False) -> None:
    """Record files evtribo wrote into *folder* in its manifest (the versions written
    before at each name are kept: :data:`HISTORY`).

    Parameters
    ----------
    folder : path-like
    add : mapping of str to Entry
        The files written, by name relative to *folder*.
    locked : bool
        The caller holds :func:`folder_lock` of *folder* already.
    """
    with contextlib.nullcontext() if locked else folder_lock(folder):
        check_manifest(folder)
        files = read_manifest(folder)
        for rel, new in add.items():
            old = files.get(rel)
            versions = [h for h in (old.written if old else ()) if h != new.sha256]
            files[rel] = Entry(new.sha256, new.by, (*versions, new.sha256)[-HISTORY:])
        doc = {"evtribo": "manifest", "version": 1,
               "about": "the files evtribo wrote into this folder (the SHA-256 of each "
                        "version, the last one last): the only ones it replaces or removes",
               "files": {rel: {"by": e.by, "sha256": list(e.written or (e.sha256,))}
                         for rel, e in sorted(files.items())}}
        atomic_write(Path(folder) / MANIFEST, json.dumps(doc, indent=1) + "\n")
