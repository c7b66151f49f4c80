"""One writer at a time: a lock file beside what is being written, naming its holder.

The one lock mechanism of evtribo: a trial being recorded (``P01/run-01.lock``) and an output
written as one unit (a result folder, a report: ``.OUT.evtribo-lock``, through
:func:`evtribo.store.resultdir.locked`) are both locked by a :class:`WriteLock`.

A writer (``evtribo acquire`` recording ``P01/run-01``) holds ``P01/run-01.lock`` while it
writes: a small JSON file with its PID, host, command line and start time, on which it also
holds an exclusive ``flock``. A second writer is refused with :class:`~evtribo.errors.
LockedError` (exit code 2), naming that process, whatever ``--force`` says. The lock file is
removed when the writer ends.

A process that dies without removing its lock (SIGKILL, a power cut) leaves the file, but
not the ``flock``: the kernel releases it with the process. Such a stale lock is detected and
cleared by the next writer, which says so in the log. Where ``flock`` is not available, the
lock is judged by its content: the PID must be alive on this host (and, on Linux, still be
the same process, by its start time). A lock written on another host is never cleared
automatically: the process holding it cannot be checked from here.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import errno
import json
import logging
import os
import shlex
import socket
import stat
import sys
import time
from pathlib import Path
from typing import Any

from evtribo.errors import LockedError, OutputExistsError

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None  # type: ignore[assignment]

__all__ = ["WriteLock", "command_line", "lock_holder"]

log = logging.getLogger(__name__)

_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
#: A lock file without content younger than this is being written by its holder, s.
_EMPTY_GRACE_S = 5.0


def command_line() -> str:
    """This process's command line as a user would type it (``evtribo acquire --study ...``).

    Returns
    -------
    str
    """
    argv = list(sys.argv) or [sys.executable]
    first = Path(argv[0]).name
    if first == "__main__.py":  # python -m evtribo
        first = f"python -m {Path(argv[0]).parent.name}"
    elif first == "-c":
        first = "python -c ..."
        argv = argv[:1]
    return " ".join([first, *(shlex.quote(a) for a in argv[1:])])


def _process_start(pid: int) -> int | None:
    """The start time of process *pid* in clock ticks since boot (Linux), or None."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    try:
        return int(stat.rsplit(")", 1)[1].split()[19])
    except (IndexError, ValueError):
        return None


def _alive(holder: dict[str, Any]) -> bool:
    """Whether the process a lock's content names still runs (True when it cannot tell)."""
    if holder.get("host") != socket.gethostname():
        return True
    pid = holder.get("pid")
    if not isinstance(pid, int) or pid <= 0:
        return False
    if pid == os.getpid():
        return False  # this process holds no lock through another file, or flock would say
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's process
    started = holder.get("process_start")
    return started is None or _process_start(pid) in (None, started)


def _read(fd: int) -> bytes:
    chunks = []
    offset = 0
    while chunk := os.pread(fd, 4096, offset):
        chunks.append(chunk)
        offset += len(chunk)
    return b"".join(chunks)


def _parse(raw: bytes) -> dict[str, Any] | None:
    try:
        holder = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError):
        return None
    return holder if isinstance(holder, dict) else None


def _describe(holder: dict[str, Any] | None) -> str:
    if holder is None:
        return "another process (its lock file names none)"
    return (f"PID {holder.get('pid')} on {holder.get('host')} since {holder.get('since')}: "
            f"{holder.get('command')}")


def _try_flock(fd: int, shared: bool = False) -> bool | None:
    """True: locked; False: another holds it; None: this file system cannot tell."""
    if fcntl is None:  # pragma: no cover - not POSIX
        return None
    try:
        fcntl.flock(fd, (fcntl.LOCK_SH if shared else fcntl.LOCK_EX) | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    except OSError as err:
        if err.errno in (errno.EAGAIN, errno.EACCES):
            return False
        return None  # ENOLCK, EOPNOTSUPP...: no locks on this file system
    return True


def _held_by(fd: int, lock: bool | None) -> dict[str, Any] | None:
    """The holder's content if the lock behind *fd* is held by a live process, else None.

    *lock* is :func:`_try_flock`'s answer for *fd*.
    """
    deadline = time.monotonic() + (0.0 if lock else 1.0)
    while True:
        raw = _read(fd)
        holder = _parse(raw)
        if holder is not None or time.monotonic() >= deadline:
            break
        time.sleep(0.05)  # its holder may be writing it right now
    if lock is False:
        return holder or {}
    if holder is None:
        age = time.time() - os.fstat(fd).st_mtime
        return {} if (not raw and age < _EMPTY_GRACE_S and lock is None) else None
    return holder if lock is None and _alive(holder) else None


def lock_holder(path: str | os.PathLike[str]) -> dict[str, Any] | None:
    """Who holds the lock file *path*: its content (PID, host, command, since), or None
    when nobody does (no file, or a stale one). Writes nothing.

    Parameters
    ----------
    path : path-like
        The lock file.

    Returns
    -------
    dict or None
    """
    path = Path(path)
    try:
        fd = os.open(path, os.O_RDONLY | _NOFOLLOW | os.O_NONBLOCK | _CLOEXEC)
    except FileNotFoundError:
        return None
    except OSError:  # a link, or what cannot be opened: it holds no lock of evtribo's
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        lock = _try_flock(fd, shared=True)
        if lock:
            fcntl.flock(fd, fcntl.LOCK_UN)
        return _held_by(fd, lock)
    finally:
        os.close(fd)


class WriteLock:
    """An exclusive lock on something being written, through the lock file *path*.

    Use :meth:`acquire` (or ``with WriteLock(path, what):``) and :meth:`release`.

    Parameters
    ----------
    path : path-like
        The lock file (``STUDY/P01/run-01.lock``); its folder must exist.
    what : str
        What is locked, for the message (``"the trial P01/run-01"``).
    verb : str
        What the holder does to it, for the message (``"recorded"``).
    command : str, optional
        What the holder is, as the lock file names it (``"evtribo analyze"``); by default
        this process's command line.
    """

    def __init__(self, path: str | os.PathLike[str], what: str, verb: str = "written", *,
                 command: str | None = None) -> None:
        self.path = Path(path)
        self.what = what
        self.verb = verb
        self.command = command
        self._fd: int | None = None

    def refuse(self, holder: dict[str, Any] | None) -> LockedError:
        """The error saying that *holder* has the lock."""
        return LockedError(f"{self.what} is being {self.verb} by {_describe(holder or None)}; "
                           "wait until it ends ({force} does not override this)",
                           path=self.path)

    def check(self) -> None:
        """Raise :class:`LockedError` if a live process holds the lock (writes nothing)."""
        holder = lock_holder(self.path)
        if holder is not None:
            raise self.refuse(holder)

    def acquire(self) -> WriteLock:
        """Take the lock, clearing a stale one; return self.

        The lock file is opened without following a link and must be a regular file of
        one name holding a lock's content (or nothing): anything else (a link planted in
        its place, a FIFO, a second name of another file) is refused by name, never
        written.

        Raises
        ------
        LockedError
            A live process holds it.
        OutputExistsError
            The file is not a lock file (exit code 2, naming it).
        OSError
            The lock file cannot be created.
        """
        for _ in range(20):
            try:  # created here: nobody else's
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL | _NOFOLLOW
                             | _CLOEXEC, 0o644)
                created = True
            except FileExistsError:
                try:
                    fd = os.open(self.path, os.O_RDWR | _NOFOLLOW | os.O_NONBLOCK | _CLOEXEC)
                except FileNotFoundError:  # its holder just removed it
                    continue
                except OSError as err:
                    raise self._not_a_lock(err) from None
                created = False
            try:
                if not created:
                    self._check_file(fd)
                if self._take(fd, created):
                    self._fd = fd
                    return self
            except BaseException:
                os.close(fd)
                raise
            os.close(fd)  # the file was replaced or removed meanwhile: try again
        raise LockedError(f"{self.what}: cannot take its lock (it keeps changing)",
                          path=self.path)

    def _not_a_lock(self, why: OSError | str) -> OutputExistsError:
        text = why if isinstance(why, str) else (
            "a symbolic link" if why.errno == errno.ELOOP else why.strerror or str(why))
        return OutputExistsError(f"not a lock file evtribo wrote ({text}): it is not opened for "
                           f"writing; if no evtribo command is writing {self.what}, remove "
                           "it and run this again", path=self.path)

    def _check_file(self, fd: int) -> None:
        """Refuse a lock file that is not one: not a regular file, a second name of another
        file, or one holding something else than a lock's content."""
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise self._not_a_lock("not a regular file")
        if st.st_nlink != 1:
            raise self._not_a_lock(f"a file of {st.st_nlink} names")
        raw = _read(fd)
        if raw and _parse(raw) is None:
            raise self._not_a_lock("its content is not a lock's")

    def _take(self, fd: int, created: bool) -> bool:
        lock = _try_flock(fd)
        for _ in range(5):  # another writer's check() holds a shared lock for a moment
            if lock is not False:
                break
            time.sleep(0.02)
            lock = _try_flock(fd)
        if lock is False:
            raise self.refuse(_held_by(fd, lock))
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(self.path))
        except FileNotFoundError:
            same = False
        if not same:
            return False
        if not created:
            holder = _held_by(fd, lock)
            if holder is not None:
                raise self.refuse(holder)
            log.warning("%s: cleared a stale lock (%s: that process is gone)", self.path,
                        _describe(_parse(_read(fd))))
        content = {"pid": os.getpid(), "host": socket.gethostname(),
                   "command": self.command or command_line(),
                   "since": dt.datetime.now(dt.UTC).isoformat(timespec="seconds")
                   .replace("+00:00", "Z"),
                   "process_start": _process_start(os.getpid())}
        data = (json.dumps(content) + "\n").encode("utf-8")
        os.ftruncate(fd, 0)
        os.pwrite(fd, data, 0)
        os.fsync(fd)
        return True

    def release(self) -> None:
        """Remove the lock file and let go of the lock (nothing if not held)."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            if os.path.samestat(os.fstat(fd), os.stat(self.path)):
                self.path.unlink()
        except FileNotFoundError:
            pass
        except OSError as err:
            log.warning("%s: cannot remove the lock file: %s", self.path, err)
        finally:
            os.close(fd)

    def forget(self) -> None:
        """In a process forked from the holder: close this copy of the lock file without
        unlocking or removing it (the parent holds it), so that it dies with the parent."""
        fd, self._fd = self._fd, None
        if fd is not None:
            with contextlib.suppress(OSError):
                os.close(fd)

    @property
    def held(self) -> bool:
        """Whether this object holds the lock."""
        return self._fd is not None

    def __enter__(self) -> WriteLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()
