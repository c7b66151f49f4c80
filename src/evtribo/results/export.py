"""A study's aligned forces, trial by trial, as one ASAM MDF 4 file (``evtribo export``).

Each trial is analysed as ``evtribo analyze`` analyses it (:func:`~evtribo.results.trial_view.
view_trial`, through the cache), and each continuous piece it worked on becomes a channel
group named ``SUBJECT/TRIAL`` (``SUBJECT/TRIAL#2`` for a second piece), with its drive in
the group's comment: on the piece's grid (time in s from the trial's start), the normal and
the tangential force (N; calibrated, tared, hum removed: the forces the windows' means are
taken from) and the condition of every point (1 ON, 0 OFF, -1 excluded, with its value
table). Written through asammdf (the ``mf4`` extra) and put in place only once complete.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from evtribo.analysis.forces.conditions import EXCLUDED, OFF, ON
from evtribo.canlog.decode_mf4 import MF4_EXTRA, save_mdf
from evtribo.errors import AnalysisError, UserInputError
from evtribo.results.trial_view import view_trial
from evtribo.study import StudyFolder, load_study

__all__ = ["CONDITION_TEXT", "Exported", "export_forces"]

log = logging.getLogger(__name__)

#: The condition channel's value table.
CONDITION_TEXT = {ON: "ON", OFF: "OFF", EXCLUDED: "excluded"}


@dataclass
class Exported:
    """What :func:`export_forces` wrote.

    Attributes
    ----------
    groups : list of str
        The channel groups (``SUBJECT/TRIAL``, in the study's order).
    samples : int
        Grid points, over all groups.
    skipped : list of str
        The trials that could not be analysed (``SUBJECT/TRIAL: why``).
    """

    groups: list[str] = field(default_factory=list)
    samples: int = 0
    skipped: list[str] = field(default_factory=list)


def _comment(info: dict[str, Any]) -> str:
    drive = ", ".join(f"{k} {info[k]}" for k in ("waveform", "amplitude_V", "frequency_Hz",
                                                 "condition") if info.get(k) is not None)
    return f"evtribo aligned forces; drive: {drive}" if drive else "evtribo aligned forces"


def export_forces(study: StudyFolder | str | os.PathLike[str], path: str | os.PathLike[str], *,
                  subjects: Sequence[str] | None = None,
                  progress: Callable[[int, int, str], None] | None = None) -> Exported:
    """Write each trial's aligned forces and conditions to an MF4 (see the module's notes).

    Parameters
    ----------
    study : StudyFolder or path-like
        The study, or its folder.
    path : path-like
        The output, ``.mf4``; written whole or not at all.
    subjects : sequence of str, optional
        Only these subjects' trials (default: all).
    progress : callable, optional
        ``progress(done, total, "SUBJECT/TRIAL")`` after each trial.

    Returns
    -------
    Exported

    Raises
    ------
    UserInputError
        asammdf is missing, a subject is not in the study, or no trial could be analysed.
    StudyError
        The study cannot be read.
    """
    try:
        from asammdf import MDF, Signal
    except ImportError:
        raise UserInputError(f"writing .mf4 needs the optional package asammdf: {MF4_EXTRA}",
                             path=str(path), key="-o") from None
    study = study if isinstance(study, StudyFolder) else load_study(Path(study))
    unknown = [s for s in subjects or () if s not in study.subjects]
    if unknown:
        raise UserInputError(f"no subject {unknown[0]!r} in the study; its subjects: "
                             f"{', '.join(study.subjects)}", key="--subject")
    trials = [t for t in study.trials if not t.partial
              and (subjects is None or t.subject in subjects)]
    out = Exported()
    mdf = MDF(version="4.10")
    conversion: dict[str, Any] = {"default": b""}
    for i, (code, text) in enumerate(CONDITION_TEXT.items()):
        conversion |= {f"val_{i}": float(code), f"text_{i}": text.encode()}
    try:
        for k, ref in enumerate(trials):
            key = f"{ref.subject}/{ref.name}"
            try:
                check = view_trial(study, ref.subject, ref.name)
            except AnalysisError as err:
                out.skipped.append(f"{key}: {err}")
                continue
            finally:
                if progress is not None:
                    progress(k + 1, len(trials), key)
            for j, piece in enumerate(check.pieces):
                name = key if j == 0 else f"{key}#{j + 1}"
                t = piece.forces.t - check.t0
                signals = [
                    Signal(piece.forces.normal, t, name="normal_force", unit="N",
                           comment="normal force, calibrated and tared"),
                    Signal(piece.forces.tangential, t, name="tangential_force", unit="N",
                           comment="tangential (friction) force, calibrated and tared"),
                    Signal(piece.condition.astype(np.int8), t, name="condition",
                           comment="1 ON, 0 OFF, -1 excluded (switch guard, lifted...)",
                           conversion=dict(conversion))]
                mdf.append(signals, acq_name=name, comment=_comment(piece.info))
                out.groups.append(name)
                out.samples += int(t.size)
        if not out.groups:
            raise UserInputError("no trial could be analysed: nothing to export"
                                 + (f" ({out.skipped[0]})" if out.skipped else ""),
                                 path=str(study.root))
        save_mdf(mdf, Path(path))
    finally:
        mdf.close()
    return out
