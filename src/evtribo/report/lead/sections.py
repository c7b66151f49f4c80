"""The page's first sections: the key results, then the warnings, each kind once; and, under
the electrostatic force, what was analysed and left out per subject and how.

The warnings are numbered ``W1``, ``W2``... in the order of what they do to the reported
numbers (:data:`~evtribo.warning.record.EFFECTS`), each an anchor the flagged
cells of the tables link to (:mod:`evtribo.report.lead.marks`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from markupsafe import escape

from evtribo.documents.fit import FIT_JSON
from evtribo.documents.summary import SUMMARY_FILE
from evtribo.fit.tables import ResultTables
from evtribo.report.lead.analysed import analysed_table, effect_title, methods_text
from evtribo.report.lead.key_results import KeyResults
from evtribo.report.lead.marks import warning_anchor
from evtribo.report.page import Report, hertz
from evtribo.warning.record import Scope, WarningRecord
from evtribo.warning.render import WarningGroup, scope_text

__all__ = ["KEY_SECTION", "WARNINGS_SECTION", "add_analysed", "add_key_results",
           "add_warnings"]

#: The sections' titles.
KEY_SECTION, WARNINGS_SECTION = "Key results", "Warnings"


def add_key_results(report: Report, key: KeyResults) -> None:
    """The page's first section: the answer in a sentence, by voltage, by subject.

    Parameters
    ----------
    report : Report
        The page.
    key : KeyResults
        :func:`~evtribo.report.lead.key_results.key_results`.

    Returns
    -------
    None
    """
    report.add_html(f'<p class="lead">{escape(hertz(key.sentence))}</p>', section=KEY_SECTION)
    for table, links in ((key.by_voltage, key.voltage_links),
                         (key.by_subject, key.subject_links)):
        report.add_table(table.table, table.title, caption=table.caption,
                         section=KEY_SECTION, wrap=True, marks=links, anchor=table.stem)


def add_warnings(report: Report, groups: Sequence[WarningGroup],
                 trials: Sequence[tuple[str, str]], cells: Sequence[Scope],
                 compared: Iterable[WarningRecord] = ()) -> None:
    """The warnings, each kind once with where it was said, under the heading of its effect:
    the analysis's and the comparison's in one list.

    Parameters
    ----------
    report : Report
        The page.
    groups : sequence of WarningGroup
        In the page's order (``W1`` first).
    trials : sequence of (str, str)
        The study's trials.
    cells : sequence of Scope
        The study's cells.
    compared : iterable of WarningRecord
        The comparison's (fit.json's): their kinds' lines are counted there.

    Returns
    -------
    None
    """
    if not groups:
        report.add_html('<p class="caption">None: neither the analysis nor the comparison '
                        "warned of anything.</p>", section=WARNINGS_SECTION)
        return
    fit_kinds = {r.kind for r in compared}
    html, effect = [], None
    for k, g in enumerate(groups, start=1):
        if g.effect != effect:
            if effect is not None:
                html.append("</ol></div>")
            effect = g.effect
            html.append(f'<div class="effect-{escape(effect)}"><h3>'
                        f'{escape(effect_title(effect))}</h3><ol class="warnings">')
        lines = f"{g.count} line{'s' if g.count > 1 else ''}"
        where = FIT_JSON if g.kind in fit_kinds else SUMMARY_FILE
        html.append(
            f'<li id="{warning_anchor(k)}" value="{k}"><b>W{k}. {escape(hertz(g.title))}</b> '
            f'<span class="where">({escape(hertz(scope_text(g, trials, cells)))}; {lines} in '
            f'{where})</span><br><span class="said">{escape(hertz(g.text))}</span></li>')
    html.append("</ol></div>")
    report.add_html("\n".join(html), section=WARNINGS_SECTION)
    report.add_html('<p class="caption">Each kind of warning once, with the trials or cells '
                    "it concerns, by what it does to the reported numbers: first what may "
                    "change a number beyond its interval, then what widens an interval (the "
                    "interval holds it), then what is for information. The cells of the "
                    "tables a warning of the analysis touches link to it. Each line as it "
                    "was said: the analysis's in summary.json's warnings, the comparison's "
                    "(the fit, the population, the figures) in fit.json's; the study's "
                    "inputs as they are now: Provenance.</p>", section=WARNINGS_SECTION)


def add_analysed(report: Report, tables: ResultTables, section: str, *,
                 bootstrap: bool) -> None:
    """What was analysed and left out per subject, and the per-subject methods.

    Parameters
    ----------
    report : Report
        The page.
    tables : ResultTables
        The result folder's tables.
    section : str
        Where (the electrostatic force's section).
    bootstrap : bool
        Whether the fit's intervals are refits to the bootstrap replicates.

    Returns
    -------
    None
    """
    table = analysed_table(tables.trials, tables.windows)
    seconds = any(c.endswith("(s)") and c != "recorded (s)" for c in table.columns)
    report.add_table(table, "What was analysed and what was left out, per subject",
                     section=section, wrap=True, anchor="analysed",
                     caption="Seconds of the trials inside steady-sliding windows (analysed) "
                             "and left out, by reason, with their share of the time "
                             "recorded: the guard around each ON/OFF switch, the finger "
                             "lifted and leaving or touching down, sliding that was not steady "
                             "(reversals, rests, a press that moved), and the rest (no status "
                             "frame, a load cell's data missing); trials.csv's analysed_s and "
                             "excluded_*_s." if seconds else
                             "trials.csv has no seconds analysed and left out (results of an "
                             "older evtribo): analyse the study again to have them.")
    report.add_text(methods_text(tables.summary.settings,
                                 n_subjects=len(tables.subjects), bootstrap=bootstrap),
                    "Methods: each subject's estimates", section=section)
