"""A trial recorded again over itself (``evtribo acquire --force``) without the one recorded
before ever being lost: the new recording grows in a folder of its own beside it, and takes
its place only once it is whole and holds frames of the rig's load cells
(:mod:`evtribo.documents.replacing` says what the trial is at each moment).

Every file this module removes is one a recording wrote, under a name it gives its files: a
re-recording's folder holds ``TRIAL.log.part``, ``TRIAL.log``, ``TRIAL.json`` and the mark;
anything else in it stays (and the folder with it). No path is followed through a link.
"""

from __future__ import annotations

import logging
import os
import stat
import tempfile
from pathlib import Path

from evtribo.documents.replacing import (
    COMMIT_MARK,
    empty,
    replacing,
    stage_prefix,
    unfinished,
)
from evtribo.store.files import fsync_path, partial_path

log = logging.getLogger(__name__)

__all__ = ["commit", "discard", "finish", "new_stage"]


def _regular(path: Path) -> bool:
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except OSError:
        return False


def _own_files(stage: Path, trial: str) -> list[Path]:
    """The files a re-recording of *trial* writes in its folder."""
    log_path = stage / f"{trial}.log"
    return [partial_path(log_path), log_path, stage / f"{trial}.json", stage / COMMIT_MARK]


def new_stage(folder: Path, trial: str) -> Path:
    """A new folder for a re-recording of *trial* in the subject's *folder*, created
    exclusively under a name nobody can foresee (``.TRIAL.evtribo-new-XXXXXXXX``).

    Parameters
    ----------
    folder : Path
        The subject's folder.
    trial : str

    Returns
    -------
    Path
    """
    return Path(tempfile.mkdtemp(prefix=stage_prefix(trial), dir=folder))


def discard(stage: Path, trial: str) -> None:
    """Remove a re-recording's folder and the files it wrote there (what else is in it
    stays, and the folder with it).

    Parameters
    ----------
    stage : Path
        The re-recording's folder.
    trial : str
    """
    for path in _own_files(stage, trial):
        if _regular(path):
            path.unlink()
    try:
        stage.rmdir()
    except OSError as err:
        log.warning("%s is kept: %s", stage, err.strerror or err)


def commit(folder: Path, trial: str, stage: Path) -> None:
    """Make the whole re-recording in *stage* the trial (its log and last sidecar on the
    disk, then the mark), and move it into the subject's *folder* (:func:`finish`).

    Parameters
    ----------
    folder : Path
        The subject's folder.
    trial : str
    stage : Path
        The re-recording's folder, holding ``TRIAL.log`` and ``TRIAL.json``.

    Raises
    ------
    OSError
        The mark could not be made: the trial is still the one recorded before, and the
        new one stays whole in *stage*.
    """
    for name in (f"{trial}.log", f"{trial}.json"):
        fsync_path(stage / name)
    fsync_path(stage, directory=True)
    fd = os.open(stage / COMMIT_MARK,
                 os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o644)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    fsync_path(stage, directory=True)
    finish(folder, trial)


def finish(folder: Path, trial: str) -> bool:
    """Carry out a re-recording of *trial* that was made the trial (:func:`commit`), here or
    by a process killed while it did: its log, then its sidecar, moved into the subject's
    *folder*; what is left of the trial it replaced (``TRIAL.log.part``) and of the trial's
    re-recordings that did not finish removed; then the mark and the folder. The folders
    of re-recordings that hold nothing (one killed as it began, or as its folder was
    removed) are removed too.

    Parameters
    ----------
    folder : Path
        The subject's folder.
    trial : str

    Returns
    -------
    bool
        Whether there was one to carry out.
    """
    for stage in empty(folder, trial):
        discard(stage, trial)
    now = replacing(folder, trial)
    if now is None:
        return False
    for name in (f"{trial}.log", f"{trial}.json"):
        if _regular(now.stage / name):
            os.replace(now.stage / name, folder / name)
    fsync_path(folder, directory=True)
    for path in now.leftover:
        path.unlink()
    for stage in unfinished(folder, trial):
        discard(stage, trial)
    (now.stage / COMMIT_MARK).unlink()
    discard(now.stage, trial)
    fsync_path(folder, directory=True)
    log.info("%s/%s: the trial recorded before was replaced", folder.name, trial)
    return True
