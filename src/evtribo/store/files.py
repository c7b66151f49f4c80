"""Files, read safely and written whole: the one place evtribo does either.

Reading: a sidecar, a study.toml, a rig TOML or a DBC is read whole. A hostile or broken
study folder may name something else under those names: a FIFO (reading blocks forever), a
link to a device such as ``/dev/zero`` (reading never ends), a file of gigabytes. Only
regular files of a sane size are read (:func:`read_limited`); anything else is the caller's
error class (exit 2), naming the file.

Writing: every file evtribo writes whole (a sidecar, study.toml, a cache entry, a decoded
table, a figure, a commit record) goes through :func:`atomic_open` or :func:`atomic_write`: a
temporary file beside the target, renamed over it only when it is complete, removed
otherwise. A reader sees the old file or the new one, never half of one. The exceptions are
the logs being recorded, which grow as ``TRIAL.log.part`` (:func:`partial_path`).

Hashing: :func:`sha256_file` is the one file hash (inputs, result tables, cache entries).
"""

from __future__ import annotations

import errno
import hashlib
import io
import logging
import os
import stat
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any, TypeVar

from evtribo.errors import UserInputError
from evtribo.store.jsondoc import DuplicateKeyError, loads_json_unique
from evtribo.store.tempfiles import Temporary

log = logging.getLogger(__name__)
T = TypeVar("T")

__all__ = ["CHECKSUM_DIGITS", "MAX_CONFIG_BYTES", "MF4_PROGRAM_ID", "PARTIAL_SUFFIX",
           "DuplicateKeyError",
           "atomic_open", "atomic_write", "check_regular_file", "checksummed_entries",
           "fsync_path", "loads_json_unique", "open_regular", "partial_path", "read_checksummed",
           "read_entry", "read_limited", "read_regular", "sha256_file", "write_checksummed"]

#: The program identification of the MF4 files evtribo writes (bytes 16-24 of the file):
#: such a file holds decoded signals, not a raw CAN log, and ``--force`` may replace it.
MF4_PROGRAM_ID = b"evtribo "

#: Suffix of a file still being written by a recording (``run-01.log.part``).
PARTIAL_SUFFIX = ".part"

#: Largest sidecar, study.toml or rig TOML read, bytes.
MAX_CONFIG_BYTES = 1 << 20


def _kind(mode: int) -> str:
    """What a file that is not a regular one is, in words."""
    return ("a folder" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
            else "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
            else "a socket" if stat.S_ISSOCK(mode) else "a symbolic link"
            if stat.S_ISLNK(mode) else "not a regular file")


def check_regular_file(path: str | os.PathLike[str], error: type[UserInputError], *,
                       what: str = "file") -> os.stat_result:
    """The ``stat`` of *path* (links followed) if it is a regular file, else raise *error*.

    Parameters
    ----------
    path : path-like
    error : type
        The error raised (a :class:`~evtribo.errors.UserInputError`), naming *path*.
    what : str
        What the file is, for the message (``"sidecar"``).

    Returns
    -------
    os.stat_result

    Raises
    ------
    FileNotFoundError
        *path* does not exist (the caller says what that means).
    error
        *path* is a folder, a FIFO, a socket or a device.
    """
    st = os.stat(path)
    if stat.S_ISREG(st.st_mode):
        return st
    raise error(f"is {_kind(st.st_mode)}, not a {what}; only regular files are read",
                path=Path(path))


def open_regular(path: str | os.PathLike[str], error: type[UserInputError] = UserInputError,
                 *, what: str = "file", follow: bool = True) -> int:
    """A file descriptor of *path*, opened for reading only if it is a regular file: the one
    way evtribo opens a file a user or a study names.

    Opened without blocking and checked on the descriptor itself (no gap between the check
    and the open): a FIFO, a device (a link to ``/dev/zero``), a socket or a folder is
    refused by name, never read, never waited on.

    Parameters
    ----------
    path : path-like
    error : type
        The error raised (a :class:`~evtribo.errors.UserInputError`), naming *path*.
    what : str
        What the file is, for the message.
    follow : bool
        Follow a symbolic link (False: a link is refused).

    Returns
    -------
    int
        The descriptor (blocking again); the caller closes it.

    Raises
    ------
    FileNotFoundError
        *path* does not exist.
    error
        Not a regular file (or, without *follow*, a symbolic link).
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    if not follow:
        flags |= getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags)
    except OSError as err:
        if err.errno == errno.ELOOP and not follow:
            raise error(f"is a symbolic link, not a {what}; it is not followed",
                        path=Path(path)) from None
        if err.errno in (errno.ENXIO, errno.EISDIR, errno.EOPNOTSUPP):  # a socket, a folder
            mode = os.stat(path).st_mode if follow else os.lstat(path).st_mode
            raise error(f"is {_kind(mode)}, not a {what}; only regular files are read",
                        path=Path(path)) from None
        raise
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise error(f"is {_kind(mode)}, not a {what}; only regular files are read",
                        path=Path(path))
        os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


def read_regular(path: str | os.PathLike[str], error: type[UserInputError] = UserInputError,
                 *, what: str = "file", follow: bool = True) -> bytes:
    """The bytes of a regular file (:func:`open_regular`: anything else refused by name,
    never waited on).

    Parameters
    ----------
    path : path-like
    error : type
        The error raised (a :class:`~evtribo.errors.UserInputError`), naming *path*.
    what : str
        What the file is, for the message.
    follow : bool
        Follow a symbolic link (False: a link is refused).

    Returns
    -------
    bytes

    Raises
    ------
    FileNotFoundError
        *path* does not exist.
    error
        Not a regular file (or, without *follow*, a symbolic link).
    """
    with os.fdopen(open_regular(path, error, what=what, follow=follow), "rb") as fh:
        return fh.read()


def read_limited(path: str | os.PathLike[str], error: type[UserInputError], *,
                 limit: int = MAX_CONFIG_BYTES, what: str = "file",
                 follow: bool = True) -> bytes:
    """The bytes of a regular file of at most *limit* bytes, else raise *error*.

    Parameters
    ----------
    path : path-like
    error : type
        The error raised (a :class:`~evtribo.errors.UserInputError`), naming *path*.
    limit : int
        Largest size read, bytes.
    what : str
        What the file is, for the message (``"sidecar"``).
    follow : bool
        Follow a symbolic link (False: a link is refused).

    Returns
    -------
    bytes

    Raises
    ------
    FileNotFoundError
        *path* does not exist.
    error
        Not a regular file, or larger than *limit*.
    """
    fd = open_regular(path, error, what=what, follow=follow)
    with os.fdopen(fd, "rb") as fh:
        size = os.fstat(fd).st_size
        if size > limit:
            raise error(f"is {size:,} bytes, too large for a {what} (at most {limit:,})",
                        path=Path(path))
        data = fh.read(limit + 1)
    if len(data) > limit:  # it grew while being read
        raise error(f"is larger than {limit:,} bytes, too large for a {what}", path=Path(path))
    return data


def partial_path(path: str | os.PathLike[str]) -> Path:
    """Where a recording of *path* grows until it is complete.

    Parameters
    ----------
    path : path-like
        The complete file's name (``P01/run-01.log``).

    Returns
    -------
    Path
        ``NAME`` + :data:`PARTIAL_SUFFIX` (``P01/run-01.log.part``).
    """
    p = Path(path)
    return p.with_name(p.name + PARTIAL_SUFFIX)


def sha256_file(path: str | os.PathLike[str], error: type[UserInputError] = UserInputError,
                *, what: str = "file") -> str:
    """SHA-256 of a regular file's bytes (:func:`hashlib.file_digest`, which reads in blocks
    into one buffer and releases the interpreter's lock while it hashes).

    Parameters
    ----------
    path : path-like
    error : type
        Raised, naming *path*, when it is not a regular file (:func:`open_regular`: a FIFO
        or a device is never read).
    what : str
        What the file is, for that message.

    Returns
    -------
    str
        64 hexadecimal digits.
    """
    with os.fdopen(open_regular(path, error, what=what), "rb", buffering=0) as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def fsync_path(path: str | os.PathLike[str], *, directory: bool = False) -> None:
    """Flush a file (or, with *directory*, a folder's entries) to the disk.

    A file system that cannot flush a folder (or a file: EINVAL) is not an error.

    Parameters
    ----------
    path : path-like
    directory : bool
        *path* is a folder: flush its entries (a rename in it).
    """
    if directory and sys.platform == "win32":  # pragma: no cover
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    except OSError as err:
        if not directory and err.errno not in (errno.EINVAL, errno.ENOTSUP):
            raise
    finally:
        os.close(fd)


@contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "wb", *,
                encoding: str | None = None, durable: bool = False) -> Iterator[IO[Any]]:
    """Open a temporary file beside *path*; it becomes *path* when the block ends without
    an exception, and is removed otherwise.

    The temporary file is created exclusively (:class:`~evtribo.store.tempfiles.Temporary`:
    nameless while it is written where the system allows it, else under a name nobody can
    foresee, never through a link), so a killed process leaves none behind, or one the next
    write of *path* removes.

    Parameters
    ----------
    path : path-like
        The file to write (its folder must exist). An existing file is replaced; refusing
        to overwrite is the caller's decision, made before.
    mode : {"wb", "w", "w+b"}
        ``"w+b"``: bytes, readable too (a writer that reads back what it wrote).
    encoding : str, optional
        For text mode (default UTF-8).
    durable : bool
        Flush the file and its folder to the disk before and after the rename (a sidecar, a
        commit record: what must survive a power cut).

    Yields
    ------
    file object
        The temporary file; its ``name`` is *path*.

    Examples
    --------
    >>> with atomic_open("fit.csv", "w") as fh:  # doctest: +SKIP
    ...     table.to_csv(fh, index=False)
    """
    if mode not in ("wb", "w", "w+b"):
        raise ValueError(f"atomic_open writes whole files: mode 'wb', 'w' or 'w+b', not "
                         f"{mode!r}")
    target = Path(path)
    temp = Temporary(target)
    raw = io.FileIO(temp.fd, "r+", closefd=True)
    raw.name = os.fspath(target)  # what writers that name it see
    buffered = io.BufferedRandom(raw)
    fh: IO[Any] = (buffered if mode != "w" else
                   io.TextIOWrapper(buffered, encoding=encoding or "utf-8", newline=""))
    try:
        with fh:
            yield fh
            fh.flush()
            if durable:
                os.fsync(raw.fileno())
            os.fchmod(raw.fileno(), 0o666 & ~_UMASK)
            temp.install()
    except BaseException:
        temp.drop()
        raise
    if durable:
        fsync_path(target.parent, directory=True)


def atomic_write(path: str | os.PathLike[str], data: bytes | memoryview | str, *,
                 encoding: str = "utf-8", durable: bool = False) -> Path:
    """Write *data* to *path* whole or not at all (see :func:`atomic_open`).

    Parameters
    ----------
    path : path-like
    data : bytes, memoryview or str
        The file's content (a str is encoded with *encoding*).
    encoding : str
    durable : bool
        Flush to the disk before and after the rename.

    Returns
    -------
    Path
        *path*.
    """
    with atomic_open(path, "wb", durable=durable) as fh:
        fh.write(data.encode(encoding) if isinstance(data, str) else data)
    return Path(path)


#: The process's umask, read once (temporary files are created 0600; written files get the
#: mode any other file the user writes gets).
_UMASK = os.umask(0)
os.umask(_UMASK)


#: Hex digits of a checksummed entry's SHA-256 in its name.
CHECKSUM_DIGITS = 16


def checksummed_entries(directory: Path, key: str, suffix: str) -> list[Path]:
    """The entries of *key* in *directory*: files ``<key>.<checksum><suffix>``.

    Parameters
    ----------
    directory : Path
    key : str
    suffix : str
        The entries' ending (``".arrow"``).

    Returns
    -------
    list of Path
        Sorted; none when the folder cannot be read.
    """
    try:
        return sorted(directory.glob(f"{key}.*{suffix}"))
    except OSError:
        return []


def read_checksummed(path: Path, key: str, suffix: str) -> bytes:
    """The bytes of an entry of :func:`checksummed_entries`, checked against its name.

    Parameters
    ----------
    path : Path
    key, suffix : str
        As the entry was written (:func:`write_checksummed`).

    Returns
    -------
    bytes

    Raises
    ------
    ValueError
        The bytes are not those the checksum in the name was taken of.
    OSError
        The file cannot be read.
    """
    data = path.read_bytes()
    if hashlib.sha256(data).hexdigest()[:CHECKSUM_DIGITS] != \
            path.name[len(key) + 1:-len(suffix)]:
        raise ValueError("its bytes do not match its checksum")
    return data


def read_entry(directory: Path, key: str, suffix: str, parse: Callable[[bytes], T], *,
               what: str, then: str) -> T | None:
    """The entry of *key* (:func:`read_checksummed`) as *parse* makes it, or None. An entry
    whose bytes do not match its checksum, or that *parse* refuses, is removed, with a
    warning: ``<path>: damaged <what> (<why>); removed, <then>``.

    Parameters
    ----------
    directory : Path
    key, suffix : str
        As the entry was written (:func:`write_checksummed`).
    parse : callable
        The entry's value from its bytes (any exception: a damaged entry).
    what, then : str
        The warning's words: what the entry is, and what happens instead.

    Returns
    -------
    object or None
    """
    for path in checksummed_entries(directory, key, suffix):
        try:
            return parse(read_checksummed(path, key, suffix))
        except Exception as err:  # damaged, foreign or unreadable: done again
            log.warning("%s: damaged %s (%s); removed, %s", path, what, err, then)
            try:
                path.unlink()
            except OSError:
                pass
    return None


def write_checksummed(directory: Path, key: str, data: bytes | memoryview, suffix: str
                      ) -> Path:
    """Write *data* as the entry of *key*, named after its checksum
    (``<key>.<checksum><suffix>``, whole or not at all), and remove the key's other entries.

    Parameters
    ----------
    directory : Path
        Created if needed.
    key : str
    data : bytes or memoryview
    suffix : str

    Returns
    -------
    Path
        The entry.

    Raises
    ------
    OSError
        It cannot be written.
    """
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{key}.{hashlib.sha256(data).hexdigest()[:CHECKSUM_DIGITS]}{suffix}"
    atomic_write(path, data)
    for other in checksummed_entries(directory, key, suffix):
        if other != path:
            other.unlink(missing_ok=True)
    return path
