"""A trial being recorded again over itself (``evtribo acquire --force``): where the new
recording grows beside the old one, and which of the two the trial is at any moment.

A forced re-recording of ``SUBJECT/TRIAL`` records into a folder of its own in the subject's
folder, ``.TRIAL.evtribo-new-XXXXXXXX`` (:data:`STAGE_INFIX`; its ``TRIAL.log.part`` and
``TRIAL.json``), and the trial recorded before stays as it was, whatever it is (a complete
log, or the ``TRIAL.log.part`` of a recording that was killed, and its sidecar). Once the new
trial is whole in that folder (``TRIAL.log`` and its last sidecar, on the disk), the mark
:data:`COMMIT_MARK` is made in it: from then on the trial is the new one, whichever of its two
files have already been moved into the subject's folder (the log first, then the sidecar),
and what is left of the old one (its ``TRIAL.log.part``) is no part of it. What is left of
the old trial and of earlier re-recordings that did not finish is removed after the move,
the mark and the folder last.

A folder without the mark is a re-recording that did not finish (killed, a machine that went
down): the trial is still the one recorded before, and the folder keeps what the
re-recording received (:func:`unfinished`).

So at every moment one whole recording of the trial is on the disk, the old one or the new
one, and :func:`evtribo.study.discover_trials` reads that one.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass
from pathlib import Path

from evtribo.store.files import partial_path

__all__ = ["COMMIT_MARK", "STAGE_INFIX", "Replacing", "committed", "empty", "replacing",
           "stage_prefix", "stages", "unfinished"]

#: What the name of a re-recording's folder holds after ``.TRIAL``.
STAGE_INFIX = ".evtribo-new-"
#: The mark that makes a re-recording the trial (a file in its folder).
COMMIT_MARK = ".evtribo-commit"


def stage_prefix(trial: str) -> str:
    """The start of the name of *trial*'s re-recording folders.

    Parameters
    ----------
    trial : str
        The trial's name.

    Returns
    -------
    str
        ``.TRIAL.evtribo-new-``.
    """
    return f".{trial}{STAGE_INFIX}"


def _is(path: Path, kind: int) -> bool:
    """Whether *path* is of *kind* itself (a link to one is not)."""
    try:
        return stat.S_IFMT(os.lstat(path).st_mode) == kind
    except OSError:
        return False


def stages(folder: Path) -> dict[str, list[Path]]:
    """The re-recording folders in a subject's *folder*, by trial (folders, not links to
    them), in the order of their names.

    Parameters
    ----------
    folder : Path
        A subject's folder.

    Returns
    -------
    dict of str to list of Path
    """
    out: dict[str, list[Path]] = {}
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return out
    for name in names:
        trial, infix, _ = name[1:].partition(STAGE_INFIX)
        if name.startswith(".") and infix and trial and _is(folder / name, stat.S_IFDIR):
            out.setdefault(trial, []).append(folder / name)
    return out


def committed(stage: Path) -> bool:
    """Whether the re-recording in *stage* is the trial (its mark is there).

    Parameters
    ----------
    stage : Path
        A re-recording's folder.

    Returns
    -------
    bool
    """
    return _is(stage / COMMIT_MARK, stat.S_IFREG)


def _empty(stage: Path) -> bool:
    try:
        return not os.listdir(stage)
    except OSError:
        return False


def unfinished(folder: Path, trial: str) -> list[Path]:
    """The folders of *trial*'s re-recordings that did not finish (no mark; an empty one is
    the last step of a removal, or of a start, and none).

    Parameters
    ----------
    folder : Path
        The subject's folder.
    trial : str

    Returns
    -------
    list of Path
    """
    return [s for s in stages(folder).get(trial, []) if not committed(s) and not _empty(s)]


def empty(folder: Path, trial: str) -> list[Path]:
    """The folders of *trial*'s re-recordings that hold nothing.

    Parameters
    ----------
    folder : Path
        The subject's folder.
    trial : str

    Returns
    -------
    list of Path
    """
    return [s for s in stages(folder).get(trial, []) if _empty(s)]


@dataclass(frozen=True)
class Replacing:
    """A re-recording that is the trial while its files are moved into the subject's folder.

    Attributes
    ----------
    stage : Path
        Its folder.
    log, sidecar : Path or None
        Where the trial's log and sidecar are now: in *stage* until moved, then in the
        subject's folder (None: neither place has it).
    leftover : list of Path
        What is left of the trial it replaces (its ``TRIAL.log.part``): no part of it.
    """

    stage: Path
    log: Path | None
    sidecar: Path | None
    leftover: list[Path]


def _either(stage: Path, folder: Path, name: str) -> Path | None:
    for where in (stage / name, folder / name):
        if _is(where, stat.S_IFREG):
            return where
    return None


def replacing(folder: Path, trial: str) -> Replacing | None:
    """The re-recording that is *trial* while its files are moved, or None (none is).

    Parameters
    ----------
    folder : Path
        The subject's folder.
    trial : str

    Returns
    -------
    Replacing or None
    """
    done = [s for s in stages(folder).get(trial, []) if committed(s)]
    if not done:
        return None
    stage = done[-1]
    part = partial_path(folder / f"{trial}.log")
    return Replacing(stage=stage, log=_either(stage, folder, f"{trial}.log"),
                     sidecar=_either(stage, folder, f"{trial}.json"),
                     leftover=[part] if _is(part, stat.S_IFREG) else [])
