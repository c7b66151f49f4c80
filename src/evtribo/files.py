"""Reading the small files a study is described by, safely.

A sidecar, a study.toml, a rig TOML or a DBC is read whole. A hostile or broken study folder
may name something else under those names: a FIFO (reading blocks forever), a link to a
device such as ``/dev/zero`` (reading never ends), a file of gigabytes. Only regular files of
a sane size are read; anything else is the caller's error class (exit 2), naming the file.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from evtribo.errors import UserInputError

__all__ = ["MAX_CONFIG_BYTES", "check_regular_file", "read_limited"]

#: Largest sidecar, study.toml or rig TOML read, bytes.
MAX_CONFIG_BYTES = 1 << 20


def check_regular_file(path: str | os.PathLike[str], error: type[UserInputError], *,
                       what: str = "file") -> os.stat_result:
    """The ``stat`` of *path* (links followed) if it is a regular file, else raise *error*.

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
    kind = ("a folder" if stat.S_ISDIR(st.st_mode) else "a FIFO (named pipe)"
            if stat.S_ISFIFO(st.st_mode) else "a device" if stat.S_ISCHR(st.st_mode)
            or stat.S_ISBLK(st.st_mode) else "a socket" if stat.S_ISSOCK(st.st_mode)
            else "not a regular file")
    raise error(f"is {kind}, not a {what}; only regular files are read", path=Path(path))


def read_limited(path: str | os.PathLike[str], error: type[UserInputError], *,
                 limit: int = MAX_CONFIG_BYTES, what: str = "file") -> bytes:
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

    Raises
    ------
    FileNotFoundError
        *path* does not exist.
    error
        Not a regular file, or larger than *limit*.
    """
    st = check_regular_file(path, error, what=what)
    if st.st_size > limit:
        raise error(f"is {st.st_size:,} bytes, too large for a {what} (at most {limit:,})",
                    path=Path(path))
    with open(path, "rb") as fh:
        data = fh.read(limit + 1)
    if len(data) > limit:  # it grew while being read
        raise error(f"is larger than {limit:,} bytes, too large for a {what}", path=Path(path))
    return data
