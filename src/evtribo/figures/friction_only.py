"""What a study without any electrostatic force has to report: each subject's friction.

A study whose trials are all OFF (or whose amplifier's status never said ON) gives no
electrostatic force and no model fit, but its OFF windows give each subject's friction
coefficient μ: the ratio of means ``ΣF_t / ΣF_n`` of its OFF windows
(:func:`evtribo.analysis.friction.estimate.friction_coefficient`, the estimator's μ when no trend is
supported), per subject and per trial. ``evtribo compare`` then draws each subject's friction
against the normal force (the OFF windows and the line of that μ: the figure kind
``friction_normal_force`` of :mod:`evtribo.figures.registry.builtin`) and the check of every
trial, and ``evtribo report`` leads with the table of μ.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from evtribo.analysis.friction.estimate import friction_coefficient

__all__ = ["subject_mu", "trial_mu"]


def _off(windows: pd.DataFrame) -> pd.DataFrame:
    return windows[windows["condition"].astype(str).str.lower() == "off"]


def _mu(rows: pd.DataFrame) -> float:
    return friction_coefficient(rows["normal_force_N"].to_numpy(float),
                                rows["friction_force_N"].to_numpy(float))


def trial_mu(windows: pd.DataFrame) -> dict[tuple[str, str], float]:
    """Each trial's friction coefficient from its OFF windows (ratio of means).

    Parameters
    ----------
    windows : DataFrame
        ``windows.csv``.

    Returns
    -------
    dict
        ``{(subject, trial): mu}`` for the trials with OFF windows.
    """
    off = _off(windows)
    return {(str(s), str(t)): _mu(g)
            for (s, t), g in off.groupby([off["subject"].astype(str),
                                          off["trial"].astype(str)], sort=False)}


def subject_mu(windows: pd.DataFrame) -> pd.DataFrame:
    """Each subject's friction coefficient from all its OFF windows, and how it varied
    between its trials.

    Parameters
    ----------
    windows : DataFrame
        ``windows.csv``.

    Returns
    -------
    DataFrame
        One row per subject with OFF windows, in their order: ``subject``, ``mu`` (ratio of
        means over its OFF windows), ``mu_trial_min``, ``mu_trial_max`` (over its trials),
        ``trials``, ``windows``, ``normal_force_min_N``, ``normal_force_max_N``.
    """
    off = _off(windows)
    per_trial = trial_mu(windows)
    rows = []
    for subject, g in off.groupby(off["subject"].astype(str), sort=False):
        mus = [m for (s, _), m in per_trial.items() if s == subject]
        fn = g["normal_force_N"].to_numpy(float)
        rows.append({"subject": subject, "mu": _mu(g), "mu_trial_min": min(mus),
                     "mu_trial_max": max(mus), "trials": len(mus), "windows": len(g),
                     "normal_force_min_N": float(np.nanmin(fn)),
                     "normal_force_max_N": float(np.nanmax(fn))})
    return pd.DataFrame(rows, columns=["subject", "mu", "mu_trial_min", "mu_trial_max",
                                       "trials", "windows", "normal_force_min_N",
                                       "normal_force_max_N"])
