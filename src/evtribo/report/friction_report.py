"""The report of results without any electrostatic force: each subject's friction.

A study of OFF trials (or one whose amplifier's status never said ON) has no electrostatic
force and no model fit; its report leads with each subject's friction coefficient μ
(:func:`~evtribo.report.headline.friction_table`), then the subjects' sections, each with its
μ per trial (:func:`trial_table`), its figure and its trials' checks, then the warnings and
the provenance, as every report.
"""

from __future__ import annotations

import pandas as pd

from evtribo.figures.friction_only import trial_mu
from evtribo.report.headline import Headline, friction_table
from evtribo.report.page import Report
from evtribo.util.numbers import frequency, significant, voltage

__all__ = ["SECTION", "add_friction", "add_trial_mu", "trial_table"]

#: The first section's title.
SECTION = "Friction coefficient"


def add_friction(report: Report, windows: pd.DataFrame) -> list[Headline]:
    """The page's first section: μ by subject (what compare said of it, the study folder
    gone, a trial not checked..., is among the page's warnings).

    Parameters
    ----------
    report : Report
        The page.
    windows : DataFrame
        ``windows.csv``.

    Returns
    -------
    list of Headline
        The table (what ``--tables`` exports).
    """
    table = friction_table(windows)
    report.add_table(table.table, table.title, caption=table.caption, section=SECTION,
                     wrap=True)
    return [table]


def trial_table(trials: pd.DataFrame, windows: pd.DataFrame) -> pd.DataFrame:
    """One subject's μ per trial, for people.

    Parameters
    ----------
    trials : DataFrame
        The subject's rows of ``trials.csv``.
    windows : DataFrame
        Its rows of ``windows.csv``.

    Returns
    -------
    DataFrame
        ``trial``, ``drive``, ``condition``, ``μ`` (ratio of means of its OFF windows; ``—``
        without any) and ``OFF windows``.
    """
    mu = trial_mu(windows)
    off = windows[windows["condition"].astype(str).str.lower() == "off"]
    rows = []
    for r in trials.itertuples(index=False):
        key = (str(r.subject), str(r.trial))
        n = int(((off["subject"].astype(str) == key[0])
                 & (off["trial"].astype(str) == key[1])).sum())
        rows.append({"trial": key[1],
                     "drive": f"{getattr(r, 'waveform', '')} "
                              f"{frequency(getattr(r, 'frequency_Hz', None))}, "
                              f"{voltage(getattr(r, 'amplitude_V', None))}",
                     "condition": str(getattr(r, "condition", "")),
                     "μ": significant(mu[key]) if key in mu else "—",
                     "OFF windows": str(n)})
    return pd.DataFrame(rows, columns=["trial", "drive", "condition", "μ", "OFF windows"])


def add_trial_mu(report: Report, trials: pd.DataFrame, windows: pd.DataFrame,
                 section: str) -> None:
    """A subject's μ per trial (:func:`trial_table`), in its section.

    Parameters
    ----------
    report : Report
        The page.
    trials : DataFrame
        The subject's rows of ``trials.csv``.
    windows : DataFrame
        ``windows.csv``.
    section : str
        The subject's section.

    Returns
    -------
    None
    """
    report.add_table(trial_table(trials, windows), "Friction coefficient", section=section,
                     wrap=True, caption="μ: ratio of means of the trial's OFF windows.")
