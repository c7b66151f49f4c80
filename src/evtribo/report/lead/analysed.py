"""What was analysed and what was left out, per subject, and how each subject's numbers
were estimated: the report's account of the per-subject estimation."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import pandas as pd

from evtribo.report.headline import F_EL_DEFINITION
from evtribo.util.numbers import significant, to_float
from evtribo.warning.record import EFFECTS

__all__ = ["analysed_table", "effect_title", "methods_text"]


#: trials.csv's seconds and their headings.
_SECONDS = {"analysed_s": "analysed", "excluded_switch_s": "guard around switches",
            "excluded_lift_s": "lift-offs", "excluded_unsteady_s": "unsteady sliding",
            "excluded_other_s": "other"}


def analysed_table(trials: pd.DataFrame, windows: pd.DataFrame) -> pd.DataFrame:
    """Per subject: trials, windows, seconds recorded, analysed and left out by reason.

    Parameters
    ----------
    trials : DataFrame
        trials.csv (its seconds columns, when the analysis wrote them).
    windows : DataFrame
        windows.csv.

    Returns
    -------
    DataFrame
        One row per subject and one for the study, text cells; the seconds as ``12.3 s
        (41 %)`` of the time recorded.
    """
    rows = []
    groups = [(str(s), g) for s, g in trials.groupby(trials["subject"].astype(str), sort=False)]
    for name, mine in [*groups, ("all", trials)]:
        win = windows if name == "all" else windows[windows["subject"].astype(str) == name]
        cond = win["condition"].astype(str).str.lower() if len(win) else pd.Series(dtype=str)
        total = float(pd.to_numeric(mine["duration_s"], errors="coerce").sum()) \
            if "duration_s" in mine.columns else math.nan
        row = {"subject": name, "trials": str(len(mine)),
               "windows ON / OFF": f"{int((cond == 'on').sum())} / {int((cond == 'off').sum())}",
               "recorded (s)": significant(total, 3)}
        for col, what in _SECONDS.items():
            if col in mine.columns:
                secs = float(pd.to_numeric(mine[col], errors="coerce").sum())
                share = f"\u00a0({100 * secs / total:.0f}\u00a0%)" if total > 0 else ""
                row[f"{what} (s)"] = f"{significant(secs, 3)}{share}"
        rows.append(row)
    return pd.DataFrame(rows)


def methods_text(settings: Mapping[str, Any], *, n_subjects: int, bootstrap: bool) -> str:
    """How each subject's numbers were estimated, in a paragraph, with the settings used.

    Parameters
    ----------
    settings : mapping
        summary.json's ``settings``.
    n_subjects : int
        How many subjects have electrostatic forces.
    bootstrap : bool
        Whether the fit's intervals come from refits to the bootstrap replicates.

    Returns
    -------
    str
    """
    guard = to_float(settings.get("guard_s"))
    n_boot = settings.get("n_boot", "")
    conf = to_float(settings.get("confidence", 0.95))
    min_w = to_float(settings.get("min_window_s"))
    return (
        "Per subject. Each trial's load cells are aligned on one time grid and tared (the "
        "finger-lifted stretches, else the rig's calibration or the friction loop); "
        f"{significant(guard, 2)} s on each side of every ON/OFF switch is left out, as are "
        "the lift-offs. Steady-sliding windows (at least "
        f"{significant(min_w, 2)} s of one stroke at an even pace) give a mean normal and "
        f"friction force each. {F_EL_DEFINITION}. Its {100 * conf:.0f} % interval is a "
        f"percentile bootstrap over the windows ({n_boot} replicates), stretched by a "
        "Student-t factor when there are few windows. The power law F_el = k·U^n is fitted "
        "per drive over the amplitudes. The seed paper's model is fitted to each subject's "
        "electrostatic forces by weighted least squares (h_L free, μ the subject's measured "
        "one, the other parameters fixed as listed), its intervals from "
        + ("refits to the bootstrap replicates" if bootstrap else "the fit's Jacobian")
        + f". Over the {n_subjects} subject(s) the population's estimates are random-effects "
        "pools of the subjects' (see its section). What each trial left out is in its "
        "check, and in seconds per subject below.")


def effect_title(effect: str) -> str:
    """The heading of a group of warnings by their effect.

    Parameters
    ----------
    effect : str
        A key of :data:`~evtribo.warning.record.EFFECTS`.

    Returns
    -------
    str
    """
    return EFFECTS.get(effect, effect).capitalize()
