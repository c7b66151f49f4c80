"""An output written as one unit: one writer at a time, and never half-written.

``evtribo analyze``, ``compare`` and ``report`` write their outputs (a result folder OUT, a
report) this way:

1. **A lock.** ``.OUT.evtribo-lock`` beside OUT, held for the whole command and naming the
   process (pid, command, host, start): a :class:`~evtribo.store.lock.WriteLock`, the lock
   a trial being recorded is held by too. A second process is refused with
   :class:`~evtribo.errors.OutputBusyError` (exit 2) naming the holder. A lock file left by
   a process that is gone holds no lock (the system releases it with the process): it is
   taken over.
2. **A new folder beside OUT.** Everything is written into ``.OUT.evtribo-new-<id>/``.
3. **The commit.** The new files are flushed to disk, then a commit record
   (``.evtribo-commit.json`` in the new folder, :mod:`evtribo.store.commit_record`: the files
   to install, and the stale files of the same commands to remove, each with its SHA-256) is
   written and flushed. From then
   on the new results are OUT's results.
4. **The swap.** The stale files are removed, the new ones renamed into OUT (one rename
   each, on the same file system), OUT's manifest records them
   (:mod:`evtribo.store.owned`), then the commit record and the new folder are removed.

A command killed before step 3 leaves OUT as it was (its new folder is deleted by the next
command on OUT); killed during step 4, the next command on OUT finishes the swap before
anything else (:func:`recover`, under the lock), once the commit record passes its checks
(:func:`~evtribo.store.commit_record.read_record`: one planted beside OUT is refused by name).
A file is replaced or removed only if OUT's manifest shows that the command (or one it
supersedes) wrote it, with the bytes it has now: files in OUT that evtribo did not write,
or that were edited since, are never touched, ``--force`` or not; a commit that would
replace one is refused (exit 2) before anything is moved.
"""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import os
import shutil
import stat
import threading
import uuid
from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

from evtribo.errors import EvtriboError, LockedError, OutputBusyError, OutputWriteError
from evtribo.store.commit_record import (
    COMMIT_RECORD,
    STAGE_MARK,
    VERSION,
    apply,
    discard,
    read_record,
    withdraw,
)
from evtribo.store.files import atomic_write, fsync_path
from evtribo.store.lock import WriteLock, lock_holder
from evtribo.store.names import LOCK_SUFFIX, STAGE_INFIX, check_new_path, working_home
from evtribo.store.owned import (
    Entry,
    check_writable,
    file_sha256,
    output_name,
    owned,
    plain_path,
    read_manifest,
    record,
    refuse_foreign,
)

log = logging.getLogger(__name__)

__all__ = ["COMMIT_RECORD", "STAGE_MARK", "Staging", "holder", "inside", "lock_path", "locked",
           "pending", "recover", "release_inherited_locks"]

#: Errors of a folder that cannot be written.
_DENIED = {errno.EACCES, errno.EPERM, errno.EROFS}
#: Errors of writing, whichever file they name.
_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EIO}


def inside(root: Path, rel: str) -> Path | None:
    """``root / rel`` when *rel* is a relative path that stays inside *root* (symbolic links
    resolved), else None.

    Parameters
    ----------
    root : Path
    rel : str
        A path relative to *root*.

    Returns
    -------
    Path or None
    """
    if not isinstance(rel, str) or not rel or Path(rel).is_absolute() or \
            ".." in Path(rel).parts:
        return None
    path = root / rel
    try:
        path.resolve().relative_to(root.resolve())
    except (ValueError, OSError):
        return None
    return path


# ------------------------------------------------------------------------------ the lock

def _real(unit: str | os.PathLike[str]) -> Path:
    return Path(os.path.realpath(unit))


def lock_path(unit: str | os.PathLike[str]) -> Path:
    """The lock file of an output: ``.NAME.evtribo-lock`` beside it (see
    :func:`~evtribo.store.names.working_home`).

    Parameters
    ----------
    unit : path-like
        The output.

    Returns
    -------
    Path
    """
    folder, prefix = working_home(_real(unit))
    return folder / f"{prefix}{LOCK_SUFFIX}"


@dataclass
class _Held:
    lock: WriteLock
    thread: int
    count: int


_HELD: dict[str, _Held] = {}
_HELD_GUARD = threading.Lock()


def holder(unit: str | os.PathLike[str]) -> dict[str, Any] | None:
    """What the lock file of *unit* says about its holder (None when there is none).

    Parameters
    ----------
    unit : path-like
        The output (a result folder, a report).

    Returns
    -------
    dict or None
    """
    return lock_holder(lock_path(unit))


def _busy(unit: Path, shown: str | os.PathLike[str]) -> OutputBusyError:
    who = holder(unit) or {}
    pid = who.get("pid")
    what = f"process {pid}" if pid else "another process"
    details = ", ".join(str(who[k]) for k in ("command", "host") if who.get(k))
    since = f", since {who['since']}" if who.get("since") else ""
    return OutputBusyError(
        f"being written by {what}{f' ({details}{since})' if details else since}; wait until it "
        "has finished (or stop it), then run this again ({force} does not override this)",
        path=shown)


def _acquire(unit: Path, command: str, shown: str | os.PathLike[str]) -> WriteLock:
    check_new_path(shown, folder=True)  # a name evtribo writes, before its lock is made
    path = lock_path(unit)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return WriteLock(path, os.fspath(shown), command=command).acquire()
    except LockedError:
        raise _busy(unit, shown) from None
    except EvtriboError:  # not a lock file: refused by name
        raise
    except OSError as err:
        why = ("its folder must be writable (results are written into a new folder beside "
               f"{unit.name}, then swapped in)" if err.errno in _DENIED else "nothing was written")
        raise OutputWriteError(f"cannot create the lock file beside {unit.name} "
                               f"({err.strerror}): {why}", path=path) from err


@contextlib.contextmanager
def locked(unit: str | os.PathLike[str], command: str) -> Iterator[None]:
    """Hold the lock of an output (a result folder, a report) for the body of a ``with``.

    Re-entrant within one thread (``report`` runs ``compare`` on the folder it holds).

    Parameters
    ----------
    unit : path-like
        The output (it need not exist yet; its parent folder is created).
    command : str
        What is writing it, for the message another process gets (``"evtribo analyze"``).

    Yields
    ------
    None
        The body of the ``with`` runs holding the lock.

    Raises
    ------
    OutputBusyError
        Another process (or thread) holds the lock.
    """
    path = _real(unit)
    key = os.fspath(lock_path(path))
    me = threading.get_ident()
    with _HELD_GUARD:
        held = _HELD.get(key)
        if held is not None and held.thread != me:
            raise _busy(path, unit)
        if held is None:
            held = _HELD[key] = _Held(_acquire(path, command, unit), me, 0)
        held.count += 1
    try:
        yield
    finally:
        with _HELD_GUARD:
            held.count -= 1
            if held.count == 0:
                del _HELD[key]
                held.lock.release()


def release_inherited_locks() -> None:
    """In a process forked from one holding locks: close its copies of the lock files
    (without unlocking: the parent holds them) so that they die with the parent."""
    with _HELD_GUARD:
        for held in _HELD.values():
            held.lock.forget()
        _HELD.clear()


def _holds(unit: Path) -> bool:
    held = _HELD.get(os.fspath(lock_path(unit)))
    return held is not None and held.thread == threading.get_ident()


# -------------------------------------------------------------------- staging and commit

def _stages(unit: Path) -> list[Path]:
    folder, prefix = working_home(unit)
    try:
        names = os.listdir(folder)
    except FileNotFoundError:
        return []
    return sorted(folder / n for n in names if n.startswith(f"{prefix}{STAGE_INFIX}"))


def pending(unit: str | os.PathLike[str]) -> list[Path]:
    """New folders of *unit* whose commit is written but whose swap is not finished.

    Parameters
    ----------
    unit : path-like
        The output.

    Returns
    -------
    list of Path
    """
    return [s for s in _stages(_real(unit)) if os.path.lexists(s / COMMIT_RECORD)]


def recover(unit: str | os.PathLike[str]) -> list[str]:
    """Finish the swap of a committed write into *unit* that was interrupted, and delete the
    new folders of writes that were killed before their commit. Call it holding the lock.

    Parameters
    ----------
    unit : path-like
        The output.

    Returns
    -------
    list of str
        What was done, one line each (also logged).
    """
    path = _real(unit)
    if not _holds(path):
        raise RuntimeError(f"recover({path}) without holding its lock")
    done = []
    for stage in _stages(path):
        if os.path.lexists(stage / COMMIT_RECORD):
            apply(stage, read_record(stage, path))
            done.append(f"{path}: finished writing the results of an interrupted run "
                        f"({stage.name})")
        elif _made_here(stage):
            discard(stage)
            done.append(f"{path}: removed {stage.name}, left by a run that was interrupted "
                        "before it finished writing (the results were not changed)")
        else:
            log.warning("%s: left alone: named like a new folder of evtribo's, but not one it "
                        "made", stage)
    for line in done:
        log.warning("%s", line)
    return done


def _made_here(stage: Path) -> bool:
    """Whether *stage* is a new folder evtribo made (a folder, not a link, holding its
    mark; or empty)."""
    try:
        if not stat.S_ISDIR(os.lstat(stage).st_mode):
            return False
        return not any(stage.iterdir()) or stat.S_ISREG(os.lstat(stage / STAGE_MARK).st_mode)
    except OSError:
        return False


class Staging:
    """Files written into a new folder beside *unit*, swapped into *target* on commit.

    >>> with locked(out, "evtribo analyze"), Staging(out, by="analyze") as stage:   # doctest: +SKIP
    ...     df.to_csv(stage.path("trials.csv"))
    ...     stage.commit(remove=["fit.csv"], last=["summary.json"])

    Leaving the ``with`` block without a commit (an error, Ctrl-C) deletes the new folder.
    An :class:`OSError` while writing (a full disk) becomes :class:`OutputWriteError`.

    Parameters
    ----------
    unit : path-like
        The output the lock and the new folder are named after.
    target : path-like, optional
        The folder the files go into (default: *unit* itself, a result folder).
    by : str
        The command writing (``"analyze"``), as the target's manifest records it.
    replaces : collection of str, optional
        The commands whose files in *target* this one may replace or remove (default:
        its own).
    also : mapping of str to Entry, optional
        Files of the target evtribo wrote that its manifest does not list (an older
        evtribo's results, vouched for by their documents' SHA-256): recorded in the
        manifest at the commit, before anything is replaced.
    """

    def __init__(self, unit: str | os.PathLike[str],
                 target: str | os.PathLike[str] | None = None, *, by: str,
                 replaces: Collection[str] | None = None,
                 also: Mapping[str, Entry] | None = None) -> None:
        self.unit = _real(unit)
        self.target = _real(target) if target is not None else self.unit
        self.by = by
        self.replaces = frozenset(replaces if replaces is not None else (by,))
        self.also = dict(also or {})
        home, prefix = working_home(self.unit)
        self.folder = home / f"{prefix}{STAGE_INFIX}{uuid.uuid4().hex}"
        self.committed = False

    def __enter__(self) -> Staging:
        try:
            self.folder.mkdir(parents=True)
            (self.folder / STAGE_MARK).write_bytes(b"")
        except OSError as err:
            raise self._write_error(err) from err
        return self

    def path(self, rel: str) -> Path:
        """Where to write the file that will be ``target / rel`` (its folder created): a
        name evtribo writes, or the output's own name (a report the user named
        ``.report.html``)."""
        own = rel == self.unit.name and self.target == self.unit.parent
        if not output_name(rel, hidden=own):
            raise ValueError(f"not a name evtribo writes inside the output: {rel!r}")
        p = self.folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def files(self) -> list[str]:
        """The files written so far, relative to the target."""
        return sorted(p.relative_to(self.folder).as_posix() for p in self.folder.rglob("*")
                      if p.is_file() and p.name not in (COMMIT_RECORD, STAGE_MARK))

    def refuse_foreign(self, rels: Iterable[str]) -> None:
        """Refuse (before the work) outputs where files this command may not replace are.

        Parameters
        ----------
        rels : iterable of str
            Names relative to the target.

        Raises
        ------
        OutputExistsError
            Naming the first such file (:func:`~evtribo.store.owned.refuse_foreign`).
        """
        refuse_foreign(self.target, rels, self.replaces)

    def _plan(self, install: list[str], remove: Iterable[str]) -> dict[str, Any]:
        """The commit record: what to install (over what), what to remove."""
        self.refuse_foreign(install)
        manifest = read_manifest(self.target)
        todo = []
        for rel in install:
            fsync_path(self.folder / rel)
            old = owned(self.target, rel, self.replaces, manifest=manifest)
            todo.append([rel, file_sha256(self.folder / rel), old])
        stale = []
        for rel in sorted(set(remove) - set(install)):
            digest = owned(self.target, rel, self.replaces, manifest=manifest)
            if digest is not None:
                stale.append([rel, digest])
            elif (p := plain_path(self.target, rel)) is not None and os.path.lexists(p):
                log.info("%s: left as it is: not a file evtribo %s wrote", p,
                         " or ".join(sorted(self.replaces)))
        check_writable(self.target, [*install, *(rel for rel, _ in stale)])
        return {"evtribo": "commit", "version": VERSION, "unit": self.unit.name,
                "target": os.path.relpath(self.target, self.folder.parent), "by": self.by,
                "install": todo, "remove": stale}

    def commit(self, remove: Iterable[str] = (), last: Sequence[str] = ()) -> None:
        """Make the new files the output's: flush them, write the commit record, swap them in.

        Parameters
        ----------
        remove : iterable of str
            Files of the target (relative) to remove: stale outputs of the same commands
            (only those the target's manifest shows evtribo wrote are removed).
        last : sequence of str
            Files installed after all others (the one that says what the others are).

        Raises
        ------
        OutputExistsError
            A file to replace is not one this command may replace (nothing is moved).
        """
        install = self.files()
        install.sort(key=lambda rel: (rel in last, last.index(rel) if rel in last else 0))
        try:
            self.target.mkdir(parents=True, exist_ok=True)
            check_writable(self.target)  # its manifest first
            adopt = {rel: e for rel, e in self.also.items()
                     if (p := plain_path(self.target, rel)) is not None
                     and file_sha256(p) == e.sha256}
            if adopt:  # what an older evtribo wrote, as its documents show: now listed
                record(self.target, adopt)
            doc = self._plan(install, remove)
            atomic_write(self.folder / COMMIT_RECORD, json.dumps(doc, indent=1), durable=True)
        except OSError as err:
            if isinstance(err, EvtriboError):
                raise
            raise self._write_error(err) from err
        self.committed = True  # from here on, the new files are the output
        try:
            apply(self.folder, doc)
        except Exception as err:  # failed (not interrupted): taken back if nothing was done
            self.committed = not withdraw(self.folder, doc)
            if isinstance(err, OSError) and not isinstance(err, EvtriboError):
                raise self._write_error(err) from err
            raise
        except BaseException:
            apply(self.folder, doc)  # interrupted (Ctrl-C, SIGTERM) mid-swap: finish it first
            raise

    def abort(self) -> None:
        """Delete the new folder (nothing of the target is touched)."""
        shutil.rmtree(self.folder, ignore_errors=True)

    def _write_error(self, err: OSError) -> OutputWriteError:
        why = err.strerror or str(err)
        if err.errno in (errno.ENOSPC, errno.EDQUOT):
            why = "the disk is full"
        if self.committed:  # part of the new files are in place: the next command ends it
            return OutputWriteError(
                f"cannot finish writing the results ({why}); {self.target} holds part of the "
                "new ones: the next evtribo command on it finishes writing them",
                path=err.filename or self.folder)
        return OutputWriteError(f"cannot write the results ({why}); {self.target} is left "
                                "as it was", path=err.filename or self.folder)

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self.committed:
            return
        self.abort()
        if isinstance(exc, OSError) and not isinstance(exc, EvtriboError) and (
                exc.errno in _WRITE_ERRNOS or str(exc.filename or "").startswith(
                    os.fspath(self.folder))):
            raise self._write_error(exc) from exc
