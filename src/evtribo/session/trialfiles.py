"""A subject's trial files in a session: the number of the next trial, and the recordings
set aside (``SUBJECT/rejected/``) when the operator redoes a trial or a run left one
unfinished."""

from __future__ import annotations

import os
from pathlib import Path

from evtribo.acquisition.replace import finish
from evtribo.acquisition.trialdata import TrialPaths, trial_lock
from evtribo.documents.replacing import replacing
from evtribo.study import log_stem

__all__ = ["REJECTED", "first_free", "reject", "trial_files"]

#: Folder of a subject where recordings the operator chose to redo are kept.
REJECTED = "rejected"


def first_free(subject_dir: Path) -> int:
    """The number after the highest ``run-NN`` trial of the subject.

    Parameters
    ----------
    subject_dir : Path
        The subject's folder (it may not exist yet).

    Returns
    -------
    int
    """
    numbers = [0]
    for f in subject_dir.iterdir() if subject_dir.is_dir() else ():
        split = log_stem(f) if f.is_file() else None
        name = split[0] if split else f.name.split(".", 1)[0]
        if name.startswith("run-") and name[4:].isdigit():
            numbers.append(int(name[4:]))
    return max(numbers) + 1


def trial_files(subject_dir: Path, trial: str) -> list[Path]:
    """The files of *trial* in the subject's folder (log, partial log, sidecar), once a
    re-recording a killed process had made the trial has taken its place
    (:func:`evtribo.acquisition.replace.finish`).

    Parameters
    ----------
    subject_dir : Path
    trial : str

    Returns
    -------
    list of Path
    """
    if replacing(subject_dir, trial) is not None:
        with trial_lock(TrialPaths.of(subject_dir.parent, subject_dir.name, trial),
                        subject_dir.name, trial):
            finish(subject_dir, trial)
    out = []
    for f in sorted(subject_dir.glob(f"{trial}.*")):
        split = log_stem(f)
        if (split and split[0] == trial) or f.name == f"{trial}.json":
            out.append(f)
    return out


def reject(subject_dir: Path, trial: str) -> str | None:
    """Move *trial*'s files to ``rejected/`` under a free name.

    Parameters
    ----------
    subject_dir : Path
    trial : str

    Returns
    -------
    str or None
        The name they were given (``run-03-1``); None: there was nothing to move.
    """
    files = trial_files(subject_dir, trial)
    if not files:
        return None
    folder = subject_dir / REJECTED
    folder.mkdir(exist_ok=True)
    k = 1
    while any(folder.glob(f"{trial}-{k}.*")):
        k += 1
    name = f"{trial}-{k}"
    for f in files:
        os.replace(f, folder / (name + f.name[len(trial):]))
    return name
