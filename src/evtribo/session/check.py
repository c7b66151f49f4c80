"""The short check of a trial just recorded: what the analysis makes of it.

The trial is decoded and analysed as ``evtribo analyze`` would (the study's rig, settings and
calibration), so that the operator sees at once, before the subject's finger is cold, whether
the forces came, whether steady-sliding windows were found in both conditions, and how many
frames the bus lost.
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass, field

from evtribo.analysis.trial import TrialMeta, analyze_signals
from evtribo.canlog.cache import load_trial
from evtribo.errors import EvtriboError, UserInputError
from evtribo.results.pipeline import study_settings
from evtribo.study import StudyFolder, load_study
from evtribo.warning.collect import collecting
from evtribo.warning.record import Scope

log = logging.getLogger(__name__)

__all__ = ["DROPPED_SHARE_WARN", "TrialCheck", "check_recorded", "check_trial"]

#: Frames lost above this share of a cell's frames are a problem.
DROPPED_SHARE_WARN = 0.01


@dataclass
class TrialCheck:
    """What the analysis makes of one trial.

    Attributes
    ----------
    normal_frames, tangential_frames : int
        Samples of each load cell.
    windows_on, windows_off : int
        Steady-sliding windows found with the voltage ON and OFF.
    dropped : int
        Frames lost (the cells' counters and the recording tool).
    problems : list of str
        What should make the operator redo the trial.
    warnings : list of str
        What the analysis, the readers and the decoder warned of, each once (without the
        trial's name).
    """

    normal_frames: int = 0
    tangential_frames: int = 0
    windows_on: int = 0
    windows_off: int = 0
    dropped: int = 0
    problems: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """No problem found."""
        return not self.problems

    def summary(self) -> str:
        """One line for the operator."""
        text = (f"forces {self.normal_frames} + {self.tangential_frames} samples, windows "
                f"{self.windows_on} ON / {self.windows_off} OFF, {self.dropped} frames "
                "dropped" + (f", {len(self.warnings)} warning(s)" if self.warnings else ""))
        return text + ("" if self.ok else ": " + "; ".join(self.problems))

    def lines(self) -> list[str]:
        """What the operator reads before deciding to keep or redo the trial: the summary,
        then each warning on a line of its own.

        Returns
        -------
        list of str
        """
        return [self.summary(), *(f"  warning: {w}" for w in self.warnings)]


def check_trial(study: StudyFolder, subject: str, trial: str, condition: str | None) -> TrialCheck:
    """Analyse one trial of *study* and say what is wrong with it, if anything.

    Parameters
    ----------
    study : StudyFolder
        The study (:func:`evtribo.study.load_study`), its trials discovered after the trial
        was recorded.
    subject, trial : str
    condition : str or None
        What the trial was meant to be (``"alternating"`` needs ON and OFF windows).

    Returns
    -------
    TrialCheck
    """
    out = TrialCheck()
    ref = next((r for r in study.trials if r.subject == subject and r.name == trial), None)
    if ref is None:
        out.problems.append("the trial's log is not in the study folder")
        return out
    rig = study.rig
    if rig is None:
        out.problems.append("the study has no rig")
        return out
    try:
        # shown with the verdict, before keep or redo
        with collecting(Scope(subject, trial), quiet=True) as heard:
            signals = load_trial(ref.log_path, rig, cache=False)
            result = analyze_signals(signals,
                                     TrialMeta.from_sidecar(subject, trial, ref.sidecar),
                                     settings=study_settings(study),
                                     calibration=rig.calibration)
    except EvtriboError as err:
        out.problems.append(f"the analysis failed: {err}")
        return out
    where = f"{subject}/{trial}: "
    # the trial's own warnings, then what the readers and the decoder said, each once
    said = [*result.warnings, *heard]
    out.warnings = list(dict.fromkeys(w.text.removeprefix(where) for w in said))
    out.normal_frames = int(signals.normal.t.size)
    out.tangential_frames = int(signals.tangential.t.size)
    w = result.windows
    if len(w):
        on = w["condition"].astype(str) == "on"
        out.windows_on, out.windows_off = int(on.sum()), int((~on).sum())
    dropped = result.row.get("dropped_frames")
    out.dropped = int(dropped) if isinstance(dropped, int | float) \
        and math.isfinite(dropped) else 0
    for name, n in (("normal", out.normal_frames), ("tangential", out.tangential_frames)):
        if n == 0:
            out.problems.append(f"no {name}-force frames")
    wants = {"alternating": ("on", "off"), "on": ("on",), "off": ("off",)}
    for cond in wants.get(condition or "", ()):
        if (out.windows_on if cond == "on" else out.windows_off) == 0:
            out.problems.append(f"no steady-sliding window with the voltage {cond.upper()}")
    total = out.normal_frames + out.tangential_frames
    if total and out.dropped > DROPPED_SHARE_WARN * total:
        out.problems.append(f"{out.dropped} frames dropped ({100 * out.dropped / total:.1f} %)")
    return out


def check_recorded(study_dir: str | os.PathLike[str], subject: str, trial: str,
                   condition: str | None) -> TrialCheck | None:
    """:func:`check_trial` of a trial just recorded into the study folder *study_dir*; None
    when the study cannot be read as a whole (another trial's file the user may not read, a
    sidecar edited wrong), with a warning saying so: the trial just recorded is kept, and
    what stops the study's analysis is named now rather than ending the session.

    Parameters
    ----------
    study_dir : path-like
        The study folder.
    subject, trial : str
    condition : str or None
        What the trial was meant to be.

    Returns
    -------
    TrialCheck or None
    """
    try:
        study = load_study(study_dir)
    except UserInputError as err:
        log.warning("%s/%s: not checked: the study cannot be read as a whole (%s); the "
                    "trial is kept as recorded, and evtribo analyze will stop there until "
                    "that is fixed", subject, trial, err)
        return None
    return check_trial(study, subject, trial, condition)
