"""Temporary files: created exclusively, under names nobody can foresee, and none left behind.

A file evtribo writes whole is written first as a temporary file in the target's folder,
then renamed over the target (:func:`evtribo.store.files.atomic_open`). The temporary file:

- has no name at all while it is written, where the system allows it (Linux's
  ``O_TMPFILE``): a process killed meanwhile (``kill -9``, a power cut) leaves nothing;
- else, or for the instant between being named and being renamed, is named
  ``.NAME.evtribo-<16 random hex digits>.tmp``, created with ``O_EXCL | O_NOFOLLOW`` (a name
  planted in advance, or a link planted there, is never opened: another name is drawn),
  and holds an exclusive ``flock`` for as long as its writer lives;
- left by a killed writer, is removed by the next write of the same target
  (:func:`sweep`): only a file of that exact name pattern, a regular file of this user with
  one link, whose ``flock`` nobody holds any more (its writer is gone).
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import re
import secrets
import shutil
import stat
import time
from pathlib import Path

from evtribo.store.names import leading_bytes

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None  # type: ignore[assignment]

log = logging.getLogger(__name__)

__all__ = ["TEMP_INFIX", "TEMP_SUFFIX", "Temporary", "sweep"]

#: What a named temporary file's name holds after ``.NAME``, and how it ends.
TEMP_INFIX, TEMP_SUFFIX = ".evtribo-", ".tmp"
#: Bytes of the target's name kept in a temporary file's name (names are at most 255).
_NAME_BYTES = 200
#: A temporary file without permissions younger than this is being created, s.
_BEING_MADE_S = 60.0
_TOKEN = re.compile(r"[0-9a-f]{16}")
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)


def _prefix(target: Path) -> str:
    return f".{leading_bytes(target.name, _NAME_BYTES)}{TEMP_INFIX}"


def _fresh(target: Path) -> Path:
    return target.with_name(f"{_prefix(target)}{secrets.token_hex(8)}{TEMP_SUFFIX}")


def _flock(fd: int) -> None:
    if fcntl is not None:
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)


def _create_named(target: Path, mode: int) -> tuple[int, Path]:
    """A new file of a fresh name beside *target*, created exclusively, locked. It is created
    with no permission bits, given *mode* once locked: :func:`sweep` leaves alone a file
    without permissions (one between its creation and its lock) unless it is old."""
    for _ in range(100):
        tmp = _fresh(target)
        try:
            fd = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL | _NOFOLLOW | _CLOEXEC, 0)
        except FileExistsError:
            continue
        _flock(fd)
        os.fchmod(fd, mode or 0o600)
        return fd, tmp
    raise FileExistsError(errno.EEXIST, "no free temporary name", os.fspath(target))


def _create_anonymous(folder: Path, mode: int) -> int | None:
    """A file without a name in *folder* (``O_TMPFILE``), or None where there is none."""
    flag = getattr(os, "O_TMPFILE", 0)
    if not flag:
        return None
    try:
        fd = os.open(folder, flag | os.O_RDWR | _CLOEXEC, mode)
    except OSError as err:
        if err.errno in (errno.EOPNOTSUPP, errno.EINVAL, errno.EISDIR, errno.ENOSYS):
            return None  # a file system without it
        raise
    _flock(fd)
    return fd


class Temporary:
    """A temporary file for *target*, to be put in its place (:meth:`install`) or dropped.

    Parameters
    ----------
    target : Path
        The file it will become; its folder must exist.
    mode : int
        Permission bits the file is created with.

    Attributes
    ----------
    fd : int
        Its descriptor, open for reading and writing.
    path : Path or None
        Its name, while it has one (None: an ``O_TMPFILE`` file, nameless until installed).
    """

    def __init__(self, target: Path, mode: int = 0o600) -> None:
        self.target = target
        folder = target.parent if str(target.parent) else Path(".")
        sweep(target)
        fd = _create_anonymous(folder, mode)
        self.path: Path | None = None
        if fd is None:
            fd, self.path = _create_named(target, mode)
        self.fd = fd

    def _name(self) -> Path:
        """Give the nameless file a fresh name beside the target (a copy where the system
        cannot link it)."""
        for _ in range(100):
            tmp = _fresh(self.target)
            try:
                os.link(f"/proc/self/fd/{self.fd}", tmp, follow_symlinks=True)
                return tmp
            except FileExistsError:
                continue
            except OSError:
                break  # no /proc: copy it under a name
        fd, tmp = _create_named(self.target, stat.S_IMODE(os.fstat(self.fd).st_mode))
        try:
            with os.fdopen(os.dup(self.fd), "rb") as src, os.fdopen(fd, "wb") as dst:
                src.seek(0)
                shutil.copyfileobj(src, dst)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        return tmp

    def install(self) -> None:
        """Rename the file over the target (its descriptor stays open)."""
        if self.path is None:
            self.path = self._name()
        os.replace(self.path, self.target)
        self.path = None

    def drop(self) -> None:
        """Remove the file's name, if it has one (the descriptor is the caller's)."""
        if self.path is not None:
            Path(self.path).unlink(missing_ok=True)
            self.path = None


def _unlocked(fd: int) -> bool:
    """Whether nobody holds the lock of the file behind *fd* (it is taken if so)."""
    if fcntl is None:  # pragma: no cover - not POSIX: nothing is swept
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False  # its writer is alive
    return True


def _stale(path: Path) -> bool:
    """Whether *path* is a temporary file whose writer is gone: a regular file of this user
    with one link, whose lock nobody holds."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | _NOFOLLOW | _CLOEXEC)
    except OSError:
        return False
    try:
        st = os.fstat(fd)
        mine = stat.S_ISREG(st.st_mode) and st.st_nlink == 1 and (
            not hasattr(os, "getuid") or st.st_uid == os.getuid())
        made = bool(stat.S_IMODE(st.st_mode)) or time.time() - st.st_mtime >= _BEING_MADE_S
        return mine and made and _unlocked(fd) and os.path.samestat(st, os.lstat(path))
    except OSError:
        return False
    finally:
        os.close(fd)


def sweep(target: Path) -> list[Path]:
    """Remove the temporary files of *target* that writers killed before they finished left
    behind (see the module's notes); others' files and live writers' are left alone.

    Parameters
    ----------
    target : Path
        The file they were to become.

    Returns
    -------
    list of Path
        The files removed.
    """
    folder = target.parent if str(target.parent) else Path(".")
    prefix = _prefix(target)
    gone: list[Path] = []
    try:
        entries = [e.name for e in os.scandir(folder) if e.name.startswith(prefix)]
    except OSError:
        return gone
    for name in entries:
        token = name[len(prefix):-len(TEMP_SUFFIX)]
        if not name.endswith(TEMP_SUFFIX) or not _TOKEN.fullmatch(token):
            continue
        path = folder / name
        if _stale(path):
            with contextlib.suppress(OSError):
                path.unlink()
                gone.append(path)
                log.info("%s: removed, a temporary file of a write that was killed", path)
    return gone
